//! Stages `fur-medulla-azimuthal` (C^N) and `fur-medulla-longitudinal` (C^M): parameters,
//! their checks, and the job of the chosen method.
//!
//! Methods (manifest key `method`): `monte-carlo` (both families, [`crate::fur::medulla`]; its
//! job in `fur_medulla_job.rs`), `adaptive` (azimuthal; `fur_medulla_adaptive.rs`),
//! `characteristics` (azimuthal, the default there; deterministic, `fur_medulla_disc.rs`) and
//! `adding-doubling` (longitudinal, the default there; deterministic, `fur_medulla_slab.rs`).
//! All methods pack, mirror and lay out their rows with [`crate::fur::medulla_table`], so the
//! layouts are identical (axes, channels and per-entry scalars are listed there).
//!
//! Monte Carlo: one task per (σ, g) pair: it computes every entry row (h' or θ'_i) of that pair, in
//! parallel over rows (each row has its own random stream derived from the seed and the entry
//! parameters, so results do not depend on thread count or sharding). When the entry grid is
//! mirror-symmetric, rows with a negative entry are the exact mirror of the positive row
//! (C^N(φ'; −h') = C^N(−φ'; h'), C^M(θ'_r; −θ'_i) = C^M(−θ'_r; θ'_i)); the symmetry itself is
//! tested on independent runs in [`crate::fur::medulla`].

use crate::fur::medulla_table::MedullaLayout;
use crate::stages::{Job, ParamDoc, PlanError, StageParams, StageSpec};

#[path = "fur_medulla_job.rs"]
mod job;
use job::{Family, MedullaJob};
pub use job::{Grid, MedullaParams, Method};

#[path = "fur_medulla_adaptive.rs"]
mod adaptive_job;
#[path = "fur_medulla_disc.rs"]
mod disc_job;
#[path = "fur_medulla_slab.rs"]
mod slab_job;

fn check_grid(
    key: &str,
    pts: &[f64],
    lo: f64,
    hi: f64,
    lo_open: bool,
    hi_open: bool,
) -> Result<(), PlanError> {
    if pts.is_empty() || pts.len() > 4096 {
        return Err(PlanError::invalid(key, "needs 1 to 4096 points"));
    }
    if pts.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PlanError::invalid(key, "must be strictly increasing"));
    }
    for &p in pts {
        let below = if lo_open { p <= lo } else { p < lo };
        let above = if hi_open { p >= hi } else { p > hi };
        if !p.is_finite() || below || above {
            return Err(PlanError::invalid(
                key,
                format!(
                    "value {p} outside the valid domain {}{lo}, {hi}{}",
                    if lo_open { "(" } else { "[" },
                    if hi_open { ")" } else { "]" }
                ),
            ));
        }
    }
    Ok(())
}

/// The entry parameter a family does not take (left out of its documentation).
fn foreign_entry_key(family: Family) -> &'static str {
    match family {
        Family::Azimuthal => "theta_i_deg",
        Family::Longitudinal => "h",
    }
}

/// Stage for the azimuthal family C^N(φ'; h', σ, g).
pub struct FurMedullaAzimuthalStage;
/// Stage for the longitudinal family C^M(θ'_r; θ'_i, σ, g).
pub struct FurMedullaLongitudinalStage;

/// The method of a plan (explicit, or the family's default) after checking it against the
/// family and its own settings; sets `p.method` and the adaptive method's default target.
fn checked_method(family: Family, p: &mut MedullaParams) -> Result<Method, PlanError> {
    let method = match (family, p.method) {
        (Family::Azimuthal, Some(Method::AddingDoubling)) => {
            return Err(PlanError::invalid(
                "method",
                "adding-doubling is a slab solver: longitudinal stage only",
            ));
        }
        (Family::Longitudinal, Some(Method::Adaptive)) => {
            return Err(PlanError::invalid(
                "method",
                "adaptive is the disc estimator: azimuthal stage only",
            ));
        }
        (Family::Longitudinal, Some(Method::Characteristics)) => {
            return Err(PlanError::invalid(
                "method",
                "characteristics is the disc solver: azimuthal stage only",
            ));
        }
        (Family::Azimuthal, m) => m.unwrap_or(Method::Characteristics),
        (Family::Longitudinal, m) => m.unwrap_or(Method::AddingDoubling),
    };
    p.method = Some(method);
    match (method, p.target_rel_error) {
        (Method::Adaptive, None) => p.target_rel_error = Some(0.01),
        (Method::Adaptive, Some(t)) if !(t > 0.0 && t < 1.0) => {
            return Err(PlanError::invalid("target_rel_error", "must be in (0, 1)"));
        }
        (Method::Adaptive, Some(_)) | (_, None) => {}
        (_, Some(_)) => {
            return Err(PlanError::invalid(
                "target_rel_error",
                "only for method = \"adaptive\"",
            ));
        }
    }
    Ok(method)
}

/// The entry axis of the family: h' (azimuthal) or θ'_i in degrees (longitudinal), checked.
fn entry_points(family: Family, p: &MedullaParams) -> Result<Vec<f64>, PlanError> {
    Ok(match family {
        Family::Azimuthal => {
            if p.theta_i_deg.is_some() {
                return Err(PlanError::invalid(
                    "theta_i_deg",
                    "belongs to the longitudinal stage",
                ));
            }
            let h =
                p.h.as_ref()
                    .ok_or_else(|| PlanError::invalid("h", "required"))?
                    .points();
            check_grid("h", &h, -1.0, 1.0, false, false)?;
            h
        }
        Family::Longitudinal => {
            if p.h.is_some() {
                return Err(PlanError::invalid("h", "belongs to the azimuthal stage"));
            }
            let t = p
                .theta_i_deg
                .as_ref()
                .ok_or_else(|| PlanError::invalid("theta_i_deg", "required"))?
                .points();
            check_grid("theta_i_deg", &t, -90.0, 90.0, true, true)?;
            t
        }
    })
}

fn plan(family: Family, mut p: MedullaParams) -> Result<Box<dyn Job>, PlanError> {
    let method = checked_method(family, &mut p)?;
    let sigma = p.sigma.points();
    let g = p.g.points();
    check_grid("sigma", &sigma, 0.0, 200.0, false, false)?;
    check_grid("g", &g, 0.0, 0.95, false, false)?;
    let entries = entry_points(family, &p)?;
    if p.bins < 8 || !p.bins.is_multiple_of(4) || p.bins > 36_000 {
        return Err(PlanError::invalid(
            "bins",
            "must be a multiple of 4 in 8..=36000",
        ));
    }
    let layout = MedullaLayout {
        family,
        bins: p.bins,
        sigma,
        g,
        entries,
    };
    let deterministic = matches!(method, Method::AddingDoubling | Method::Characteristics);
    match p.photons {
        Some(_) if deterministic => {
            return Err(PlanError::invalid(
                "photons",
                "only for the Monte Carlo methods (monte-carlo, adaptive)",
            ));
        }
        None if !deterministic => {
            return Err(PlanError::invalid(
                "photons",
                "required by the Monte Carlo methods (monte-carlo, adaptive)",
            ));
        }
        Some(n) if n == 0 || n > 1_000_000_000 => {
            return Err(PlanError::invalid("photons", "must be in 1..=1e9"));
        }
        _ => {}
    }
    let job = MedullaJob { p, layout };
    Ok(match method {
        Method::AddingDoubling => Box::new(slab_job::SlabJob::new(job)),
        Method::Characteristics => Box::new(disc_job::DiscJob::new(job)),
        Method::Adaptive => Box::new(adaptive_job::AdaptiveJob::new(job)),
        Method::MonteCarlo => Box::new(job),
    })
}

/// The documentation of `MedullaParams` without the other family's entry key (and, for the
/// longitudinal family, without the adaptive method's key).
fn family_docs(family: Family) -> Vec<ParamDoc> {
    MedullaParams::docs()
        .into_iter()
        .filter(|d| d.name != foreign_entry_key(family))
        .filter(|d| !(family == Family::Longitudinal && d.name == "target_rel_error"))
        .collect()
}

impl StageSpec for FurMedullaAzimuthalStage {
    const NAME: &'static str = "fur-medulla-azimuthal";
    const VERSION: u32 = 4;
    const SUMMARY: &'static str = "fur medulla azimuthal scattering C^N(φ'; h', σ, g): 2-D transport in the unit disc (deterministic characteristics solver, adaptive or fixed-photon Monte Carlo)";
    type Params = MedullaParams;
    fn plan_params(&self, p: MedullaParams) -> Result<Box<dyn Job>, PlanError> {
        plan(Family::Azimuthal, p)
    }
    fn parameter_docs(&self) -> Vec<ParamDoc> {
        family_docs(Family::Azimuthal)
    }
}

impl StageSpec for FurMedullaLongitudinalStage {
    const NAME: &'static str = "fur-medulla-longitudinal";
    const VERSION: u32 = 2;
    const SUMMARY: &'static str = "fur medulla longitudinal scattering C^M(θ'_r; θ'_i, σ, g): back/forward lobes of a slab of thickness 2 (adding–doubling or Monte Carlo)";
    type Params = MedullaParams;
    fn plan_params(&self, p: MedullaParams) -> Result<Box<dyn Job>, PlanError> {
        plan(Family::Longitudinal, p)
    }
    fn parameter_docs(&self) -> Vec<ParamDoc> {
        family_docs(Family::Longitudinal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::TableContent;

    use crate::fur::medulla_headers::CHARACTERISTICS_SOLVER_ERROR as SOLVER_ERROR_CHARACTERISTICS;
    use crate::stages::Stage;
    use std::f64::consts::PI;

    fn plan_str(family: Family, s: &str) -> Result<Box<dyn Job>, PlanError> {
        let v = toml::de::ValueDeserializer::parse(s).unwrap();
        match family {
            Family::Azimuthal => FurMedullaAzimuthalStage.plan(v),
            Family::Longitudinal => FurMedullaLongitudinalStage.plan(v),
        }
    }

    fn run(job: &dyn Job) -> TableContent {
        crate::stages::run_in_memory(job).unwrap()
    }

    #[test]
    fn azimuthal_table_energy_zeros_and_mirror_rows() {
        for method in ["monte-carlo", "adaptive", "characteristics"] {
            let deterministic = method == "characteristics";
            let photons = if deterministic {
                ""
            } else {
                ", photons = 300, seed = 3"
            };
            let job = plan_str(
                Family::Azimuthal,
                &format!("{{ sigma = [0.0, 2.0], g = [0.0, 0.6], h = {{ start = -1.0, stop = 1.0, count = 5 }}, bins = 72, method = \"{method}\"{photons} }}"),
            )
            .unwrap();
            let t = run(job.as_ref());
            assert_eq!(t.data.len(), t.expected_len());
            assert_eq!(t.attributes["method"], method);
            let (nh, b, c) = (5, 72, 3);
            let at = |si: usize, gi: usize, hi: usize, k: usize, ch: usize| {
                t.data[(((si * 2 + gi) * nh + hi) * b + k) * c + ch]
            };
            let se = t.attributes["scattered_fraction_std_error"]
                .as_array()
                .unwrap();
            for gi in 0..2 {
                for hi in 0..nh {
                    for k in 0..b {
                        assert_eq!(at(0, gi, hi, k, 0), 0.0); // σ = 0
                    }
                }
                for k in 0..b {
                    assert_eq!(at(1, gi, 0, k, 0), 0.0); // h = −1
                    assert_eq!(at(1, gi, 4, k, 0), 0.0); // h = +1
                    assert_eq!(at(1, gi, 1, k, 0), at(1, gi, 3, b - 1 - k, 0)); // mirror
                }
                for hi in 0..nh {
                    let h: f64 = -1.0 + 0.5 * hi as f64;
                    let sum: f64 = (0..b).map(|k| at(1, gi, hi, k, 0) as f64).sum();
                    let expect = 1.0 - (-2.0 * 2.0 * (1.0 - h * h).max(0.0).sqrt()).exp();
                    let err = se[(2 + gi) * nh + hi].as_f64().unwrap();
                    // The deterministic solver: within its discretisation error (the energy
                    // identity is not imposed by the method; measured ≤ 2.2e-3 relative).
                    let tol = if deterministic {
                        (3e-3 * expect).max(1e-12)
                    } else {
                        (5.0 * err).max(1e-4)
                    };
                    assert!(
                        (sum - expect).abs() < tol,
                        "{method} h={h}: {sum} vs {expect} ± {err}"
                    );
                }
            }
            if deterministic {
                assert_eq!(t.attributes["solver_error"], SOLVER_ERROR_CHARACTERISTICS);
            } else {
                assert!(
                    t.attributes["energy_identity_max_deviation_std_errors"]
                        .as_f64()
                        .unwrap()
                        < 5.0
                );
            }
        }
    }

    /// Error bars that hold when rebinned, read from the stored table: for groups of bins, the
    /// spread of group sums over replicate tables (independent seeds) against the error the
    /// header documents, Var(Σ_G energy) = Σ_{k,l∈G} se_k se_l exp(−|k−l|/ℓ), with `std_error`
    /// and the entry's `std_error_correlation_length_bins` ℓ. Two entries: a moderate one and a
    /// σ = 12 one read through its mirrored row (h' = −0.5). Groups of 1 to 72 bins must agree
    /// within the noise of 16 replicates; 180-bin groups (where energy conservation makes far
    /// bins anti-correlated) must not be understated; the plain quadrature sum must understate
    /// 10° groups (so the test fails if the correlation were dropped).
    #[test]
    fn rebinned_error_bars_from_the_table_match_replicate_runs() {
        use crate::fur::medulla_fast::correlated_group_error;
        let reps = 16u64;
        for (sigma, g) in [(4.0, 0.6), (12.0, 0.2)] {
            // Rows per table: h' = −0.5 (mirror of +0.5) and +0.5; the test reads row 0.
            let tables: Vec<TableContent> = (0..reps)
                .map(|r| {
                    let job = plan_str(
                        Family::Azimuthal,
                        &format!("{{ sigma = [{sigma}], g = [{g}], h = [-0.5, 0.5], method = \"adaptive\", target_rel_error = 0.001, photons = 1024, seed = {} }}", 100 + r),
                    )
                    .unwrap();
                    run(job.as_ref())
                })
                .collect();
            let c = 3;
            let column = |t: &TableContent, ch: usize| -> Vec<f64> {
                (0..720).map(|k| t.data[k * c + ch] as f64).collect()
            };
            let energy: Vec<Vec<f64>> = tables.iter().map(|t| column(t, 0)).collect();
            let se: Vec<Vec<f64>> = tables.iter().map(|t| column(t, 2)).collect();
            let ell: Vec<f64> = tables
                .iter()
                .map(|t| {
                    t.attributes["std_error_correlation_length_bins"][0]
                        .as_f64()
                        .unwrap()
                })
                .collect();
            let n = reps as f64;
            for (group, lo, hi) in [
                (1usize, 0.7, 1.3),
                (20, 0.7, 1.3),
                (72, 0.7, 1.3),
                (180, 0.0, 1.2),
            ] {
                let (mut ratio, mut ratio_quad) = (0.0, 0.0);
                let groups = 720 / group;
                for gi in 0..groups {
                    let r = gi * group..(gi + 1) * group;
                    let sums: Vec<f64> = energy.iter().map(|e| e[r.clone()].iter().sum()).collect();
                    let mean = sums.iter().sum::<f64>() / n;
                    let sd =
                        (sums.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                    let model = se
                        .iter()
                        .zip(&ell)
                        .map(|(s, &l)| correlated_group_error(s, l, r.clone()))
                        .sum::<f64>()
                        / n;
                    let quad = se
                        .iter()
                        .map(|s| s[r.clone()].iter().map(|x| x * x).sum::<f64>().sqrt())
                        .sum::<f64>()
                        / n;
                    ratio += sd / model / groups as f64;
                    ratio_quad += sd / quad / groups as f64;
                }
                println!(
                    "σ={sigma} g={g} h'=-0.5: {group}-bin groups: replicate sd / stored-model error {ratio:.3}, / quadrature sum {ratio_quad:.3} (mean ℓ {:.1} bins)",
                    ell.iter().sum::<f64>() / n
                );
                assert!((lo..hi).contains(&ratio), "σ={sigma} {group} bins: {ratio}");
                if group == 20 {
                    assert!(ratio_quad > 2.0, "σ={sigma} 10° groups: {ratio_quad}");
                }
            }
        }
    }

    #[test]
    fn longitudinal_lobes_normalised_and_cdf_ends_at_one() {
        let job = plan_str(
            Family::Longitudinal,
            "{ sigma = [0.0, 1.5], g = [0.3], theta_i_deg = { start = -60.0, stop = 60.0, count = 4, centred = true }, bins = 120, method = \"monte-carlo\", photons = 200 }",
        )
        .unwrap();
        let t = run(job.as_ref());
        let (nt, half, c) = (4, 60, 5);
        let dw = 2.0 * PI / 120.0;
        for si in 0..2 {
            for ti in 0..nt {
                for lobe in 0..2 {
                    let base = (((si * nt + ti) * 2 + lobe) * half) * c;
                    let int: f64 = (0..half).map(|j| t.data[base + j * c] as f64 * dw).sum();
                    assert!((int - 1.0).abs() < 1e-5, "σ{si} θ{ti} lobe {lobe}: {int}");
                    assert!((t.data[base + (half - 1) * c + 1] - 1.0).abs() < 1e-6);
                    assert!(
                        (0..half - 1)
                            .all(|j| t.data[base + (j + 1) * c + 1] >= t.data[base + j * c + 1])
                    );
                    if si == 0 {
                        assert!((0..half).all(|j| t.data[base + j * c + 2] == 0.0));
                    }
                }
            }
        }
    }

    #[test]
    fn methods_resolve_per_family_and_reject_foreign_keys() {
        let az = "sigma = [1.0], g = [0.0], h = [0.5]";
        let lo = "sigma = [1.0], g = [0.0], theta_i_deg = [10.0]";
        crate::stages::assert_planning(
            &FurMedullaAzimuthalStage,
            &[
                &format!("{az}, method = \"adding-doubling\", photons = 10"),
                &format!("{az}, method = \"adaptive\""),
                &format!("{az}, method = \"adaptive\", photons = 10, target_rel_error = 0.0"),
                &format!("{az}, method = \"monte-carlo\", photons = 10, target_rel_error = 0.1"),
                &format!("{az}, method = \"bogus\", photons = 10"),
                &format!("{az}, photons = 10"),
                &format!("{az}, method = \"characteristics\", target_rel_error = 0.01"),
            ],
            &[
                az,
                &format!("{az}, method = \"characteristics\""),
                &format!("{az}, method = \"adaptive\", photons = 10"),
                &format!("{az}, method = \"adaptive\", photons = 10, target_rel_error = 0.05"),
                &format!("{az}, method = \"monte-carlo\", photons = 10"),
            ],
        );
        crate::stages::assert_planning(
            &FurMedullaLongitudinalStage,
            &[
                &format!("{lo}, method = \"adaptive\", photons = 10"),
                &format!("{lo}, method = \"characteristics\""),
                &format!("{lo}, photons = 10"),
                &format!("{lo}, method = \"monte-carlo\""),
                &format!("{lo}, target_rel_error = 0.01"),
            ],
            &[
                lo,
                &format!("{lo}, method = \"adding-doubling\""),
                &format!("{lo}, method = \"monte-carlo\", photons = 10"),
            ],
        );
        // The resolved method is part of the recorded parameters (and so of the content key).
        let job = plan_str(Family::Azimuthal, &format!("{{ {az} }}")).unwrap();
        assert_eq!(job.parameters()["method"], "characteristics");
        assert_eq!(job.tasks().len(), 1);
        let job = plan_str(
            Family::Azimuthal,
            &format!("{{ {az}, method = \"adaptive\", photons = 10 }}"),
        )
        .unwrap();
        assert_eq!(job.parameters()["target_rel_error"], 0.01);
        let job = plan_str(Family::Longitudinal, &format!("{{ {lo} }}")).unwrap();
        assert_eq!(job.parameters()["method"], "adding-doubling");
        assert_eq!(job.tasks().len(), 1);
    }

    #[test]
    fn rejects_bad_params() {
        let common = "sigma = [1.0], g = [0.0], photons = 1";
        crate::stages::assert_planning(
            &FurMedullaAzimuthalStage,
            &[
                &format!("{common}, h = [1.5]"),
                "sigma = [1.0], g = [0.99], h = [0.5]",
                &format!("{common}, h = [0.5], bogus = 2"),
                &format!("{common}, theta_i_deg = [0.5]"),
            ],
            &[&format!("{common}, h = [0.5], method = \"adaptive\"")],
        );
        crate::stages::assert_planning(
            &FurMedullaLongitudinalStage,
            &[&format!("{common}, theta_i_deg = [90.0]")],
            &[&format!(
                "{common}, theta_i_deg = [0.5], method = \"monte-carlo\""
            )],
        );
    }
}
