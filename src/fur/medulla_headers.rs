//! What the header of a fur medulla table says about the method that computed it: the
//! fixed-photon Monte Carlo's attributes (which every method's table starts from, as every
//! method lays its rows out with [`super::medulla_table`]), and what the adaptive estimator
//! ([`super::medulla_fast`]), the characteristics solver ([`super::disc`]) and adding–doubling
//! ([`super::slab`]) put in their place, with the solvers' measured errors (`docs/fur.md`).

use super::disc::DiscSettings;
use super::medulla::Estimator;
use super::medulla_fast::AdaptiveSettings;
use super::slab::SlabSettings;
use serde_json::{Map, Value};

/// Measured error of the default [`DiscSettings`] against the adaptive next-event Monte Carlo
/// run to 0.3 % at 24 held-out (σ, g, h') (docs/fur.md): the largest relative deviation on
/// bins above 1e-3 of the profile maximum, Monte Carlo noise included.
pub const CHARACTERISTICS_SOLVER_ERROR: f64 = 0.0083;
/// The same, the median over bins of the worst point.
pub const CHARACTERISTICS_SOLVER_ERROR_MEDIAN: f64 = 0.0024;
/// Measured discretisation error of the default [`SlabSettings`] (docs/fur.md): the largest
/// relative deviation from a solve with twice the direction cells, on bins above 1e-3 of the
/// profile maximum.
pub const ADDING_DOUBLING_SOLVER_ERROR: f64 = 1e-3;

/// The fixed-photon Monte Carlo settings of a table: photons per entry, seed and estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonteCarloRun {
    pub photons: Option<u64>,
    pub seed: u64,
    pub estimator: Estimator,
}

/// Attributes of every medulla table as the fixed-photon Monte Carlo writes them (the other
/// methods replace the sampling ones, [`remove_sampling_attributes`]): model, conventions,
/// estimator, the per-entry scalars `scal` (ballistic, scattered, its standard error, …) and
/// the energy identity over the whole table, in absolute terms and in standard errors.
pub fn monte_carlo_attributes(
    run: &MonteCarloRun,
    scal: &[Vec<f64>],
    dw_deg: f64,
) -> Result<Map<String, Value>, serde_json::Error> {
    // Energy-identity check over the whole table, in standard errors.
    let mut max_dev_se: f64 = 0.0;
    let mut max_dev_abs: f64 = 0.0;
    for ((ballistic, scattered), se) in scal[0].iter().zip(&scal[1]).zip(&scal[2]) {
        let dev = (scattered - (1.0 - ballistic)).abs();
        max_dev_abs = max_dev_abs.max(dev);
        if *se > 0.0 {
            max_dev_se = max_dev_se.max(dev / se);
        }
    }
    let mut a = Map::new();
    a.insert("model".into(), "2-D volumetric Monte Carlo, Tseng 2015 §5 / App. A: purely scattering medium, planar Henyey–Greenstein phase function rho(theta) = (1-g^2)/(2 pi (1+g^2-2g cos theta)), no absorption, index-matched boundary (no Fresnel, no refraction), unit incident energy".into());
    a.insert("sigma_convention".into(), "sigma is the scattering coefficient per unit MEDULLA radius (dimensionless optical coefficient; azimuthal disc radius 1, slab thickness 2). Renderer mapping (docs/fur.md): sigma = sigma_ms[per fiber radius] * kappa = sigma_ms[per fiber diameter] * kappa / 2; the thesis's sigma_ms/kappa lookup is NOT used".into());
    a.insert("length_unit".into(), "medulla radius".into());
    a.insert("estimator".into(), serde_json::to_value(run.estimator)?);
    a.insert("estimator_description".into(), match run.estimator {
        Estimator::Expected => "expected value: forced first collision (weight 1 - exp(-sigma chord)), next-event estimate to every bin at every collision (phase density at bin centre x bin width x exp(-sigma s)), analog continuation",
        Estimator::Histogram => "analog histogram of exit directions",
    }.into());
    a.insert("photons_per_entry".into(), run.photons.into());
    a.insert("method".into(), "monte-carlo".into());
    a.insert("seed".into(), run.seed.into());
    a.insert("rng".into(), "SplitMix64, one stream per entry derived from (seed, family, sigma, g, entry) bit patterns: independent of threads and sharding".into());
    a.insert("grid_endpoints".into(), "axis values are exactly the listed sample points; {start, stop, count} ranges include both endpoints unless centred = true".into());
    a.insert("bin_width_deg".into(), dw_deg.into());
    a.insert("bin_rule".into(), "bins are half-open cells [lower, upper) of equal width 360/bins deg; the axis coordinate is the cell centre; values are averages over the cell (midpoint rule for the expected-value estimator)".into());
    a.insert("energy_convention".into(), "channel `energy` is scattered exiting energy per bin per unit incident energy (NOT a density: divide by the bin width in rad for per-radian density); it sums over bins to the scattered fraction 1 - ballistic".into());
    a.insert("path_length_convention".into(), "channel `path_length` is the energy-weighted mean in-medulla path length (medulla radii) of the light exiting in the bin; 0 where the bin is empty. Medulla absorption at render time: multiply energy by exp(-sigma_a * path_length) (first-order; exact only for a narrow length distribution)".into());
    a.insert("std_error_convention".into(), "channel `std_error` is the Monte Carlo standard error of `energy` in the bin (from per-photon second moments)".into());
    a.insert("symmetry".into(), "rows with a negative entry (h or theta_i) whose positive mirror is on the grid are stored as the exact mirror of that row (bins reversed, within each lobe for the longitudinal family)".into());
    a.insert(
        "scalars_layout".into(),
        "per-entry arrays below are flat row-major over (sigma, g, entry)".into(),
    );
    a.insert("ballistic_fraction".into(), scal[0].clone().into());
    a.insert("scattered_fraction".into(), scal[1].clone().into());
    a.insert(
        "scattered_fraction_std_error".into(),
        scal[2].clone().into(),
    );
    a.insert("energy_identity_max_deviation".into(), max_dev_abs.into());
    a.insert(
        "energy_identity_max_deviation_std_errors".into(),
        max_dev_se.into(),
    );
    Ok(a)
}

/// Remove the header attributes that describe Monte Carlo sampling (for the deterministic
/// methods, which lay out their tables through the same code).
pub fn remove_sampling_attributes(a: &mut Map<String, Value>) {
    for key in [
        "estimator",
        "estimator_description",
        "photons_per_entry",
        "seed",
        "rng",
        "energy_identity_max_deviation_std_errors",
    ] {
        a.remove(key);
    }
}

/// The header of a characteristics table (`a`: the Monte Carlo attributes of its rows): the
/// method, its settings `s` and its measured error in place of the sampling attributes.
pub fn characteristics_attributes(s: &DiscSettings, a: &mut Map<String, Value>) {
    remove_sampling_attributes(a);
    a.insert("method".into(), "characteristics".into());
    a.insert("method_description".into(), format!(
        "deterministic: by reciprocity and rotational symmetry every h' and exit bin of one (sigma, g) is a line integral of the emission of one plane-wave problem. Single scattering in closed form (Gauss-Legendre along the entry chord); orders >= 2 from the plane-wave transport solved by the method of characteristics on polar cells (boundary ring width min({}, 1/({} sigma)), interior width <= min({}, {}/sigma), growth {}, sector arc {} x width), {} source per cell and direction, {} directions (mirror-symmetric half solved), parallel tracks at {} x the smallest cell dimension, GMRES({}) to relative residual {:e}; the final line integrals use the exact exit direction (Nystrom) and the emission linear in each cell; path lengths from the derivative with respect to an absorption coefficient (second solve, flat-source operator); bin midpoint rule for the exit direction",
        s.max_cell, s.boundary_rings_per_mean_free_path, s.max_cell, s.interior_cell_mean_free_paths, s.ring_growth, s.arc_ratio, if s.linear_source { "linear" } else { "flat" }, s.directions, s.track_spacing, s.restart, s.tolerance
    ).into());
    a.insert("solver_error".into(), CHARACTERISTICS_SOLVER_ERROR.into());
    a.insert(
        "solver_error_median".into(),
        CHARACTERISTICS_SOLVER_ERROR_MEDIAN.into(),
    );
    a.insert("solver_error_convention".into(), "relative deviation of `energy` from the adaptive next-event Monte Carlo run to 0.3 % relative standard error, on bins above 1e-3 of the profile maximum, at 24 held-out (sigma, g, h') over sigma in [0.13, 20], g in [0.05, 0.8] (docs/fur.md): `solver_error` is the largest deviation over all points and bins, `solver_error_median` the largest per-point median (both include the Monte Carlo's own noise)".into());
    a.insert("std_error_convention".into(), "channel `std_error` is 0: the characteristics solution has no sampling noise (its discretisation error is `solver_error`)".into());
}

/// The header of an adding–doubling table (`a`: the Monte Carlo attributes of its rows): the
/// model and method, the settings `s` and the measured error in place of the sampling
/// attributes.
pub fn adding_doubling_attributes(s: &SlabSettings, a: &mut Map<String, Value>) {
    remove_sampling_attributes(a);
    a.insert("model".into(), "2-D volumetric transport, Tseng 2015 §5 / App. A: purely scattering medium, planar Henyey–Greenstein phase function rho(theta) = (1-g^2)/(2 pi (1+g^2-2g cos theta)), no absorption, index-matched boundary (no Fresnel, no refraction), unit incident energy".into());
    a.insert("method".into(), "adding-doubling".into());
    a.insert("method_description".into(), format!(
        "deterministic adding-doubling (van de Hulst 1980; diamond initialisation, Wiscombe 1976) on the circle of directions: {} direction cells per face (one per exit bin, bins next to grazing cut into {:?} cells), phase function integrated exactly over each cell, exact incident direction and beam attenuation, thin layer of optical thickness {:e}, one adding step per sigma of a uniform grid; path lengths from the exact derivative with respect to an absorption coefficient",
        s.bins / 2,
        s.edge_refinement,
        s.thin_layer
    ).into());
    a.insert("solver_error".into(), ADDING_DOUBLING_SOLVER_ERROR.into());
    a.insert("solver_error_convention".into(), "largest relative deviation of `energy` from a solve with twice the direction cells (and twice the grazing refinement), on bins above 1e-3 of the profile maximum, measured over sigma in [0, 20], g in [0, 0.8], |theta_i| <= 86 deg (docs/fur.md); the energy identity holds to 1e-8".into());
    a.insert("std_error_convention".into(), "channel `std_error` is 0: the adding-doubling solution has no sampling noise (its discretisation error is `solver_error`)".into());
    a.insert("bin_rule".into(), "bins are half-open cells [lower, upper) of equal width 360/bins deg; the axis coordinate is the cell centre; values are integrals over the cell".into());
}

/// The header of an adaptive table (`a`: the Monte Carlo attributes of its rows): the
/// estimator and its stopping rule under settings `s`, and the per-entry `extras` (flat over
/// (σ, g, entry)): the correlation length of the bin errors, the photons used and the worst
/// relative error reached.
pub fn adaptive_attributes(s: &AdaptiveSettings, extras: &[Vec<f64>], a: &mut Map<String, Value>) {
    a.remove("estimator");
    a.remove("photons_per_entry");
    a.insert("method".into(), "adaptive".into());
    a.insert("estimator_description".into(), format!(
        "single scattering in closed form (Gauss-Legendre along the entry chord, bin midpoint rule); orders >= 2 by next-event Monte Carlo (forced first and second collisions, score to every bin at every later collision, importance-sampled directions, survival biasing, Russian roulette), Latin-hypercube first collision and deflection within batches of {} photons; an entry stops once every bin above {} of its maximum has relative standard error <= {} or at {} photons",
        s.batch_photons, s.threshold, s.target_rel_error, s.max_photons
    ).into());
    a.insert("target_rel_error".into(), s.target_rel_error.into());
    a.insert("max_photons_per_entry".into(), s.max_photons.into());
    a.insert("std_error_convention".into(), "channel `std_error` is the standard error of `energy` in the bin from the spread of batch means (at least 16 batches). Errors of neighbouring bins are positively correlated (one photon scores every bin): for a group G of bins use Var(sum_G energy) = sum_{k,l in G} std_error_k std_error_l exp(-|k-l|/ell) with ell = `std_error_correlation_length_bins` of the entry; measured to hold within 15 % for groups up to 36 deg and to be conservative (overestimating up to 2x) for wider groups (docs/fur.md)".into());
    a.insert(
        "std_error_correlation_length_bins".into(),
        extras[0].clone().into(),
    );
    a.insert("photons_used".into(), extras[1].clone().into());
    a.insert("worst_rel_std_error".into(), extras[2].clone().into());
}
