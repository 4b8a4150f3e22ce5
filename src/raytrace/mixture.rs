//! Drop-size mixtures of spheres that use Lorenz–Mie for the small drops and the exact 1-D
//! traced path ([`super::sphere1d`]) for the large ones: each radius' normalised curve on the
//! intermediate grid of [`FilterSettings`], mixed with weights `n(r) dr · C_sca(r)`, convolved
//! with the sun's disc and averaged over the output bins as the Lorenz–Mie tables are.

use super::post::integral_1d;
use super::sphere1d::{Phase1dOptions, SphereGo, sphere_phase_1d};
use crate::mie::filters::{
    FINE_CELL_POINTS, FilterSettings, PolarisedPhase, SunDiscOperator, resample_bins,
};
use crate::mie::{MieError, Sphere, size_parameter};
use num_complex::Complex64;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Where a mixture's drops switch from Lorenz–Mie to the traced path, and the traced orders.
#[derive(Debug, Clone, Copy)]
pub struct Handover {
    /// Radii below this use Lorenz–Mie, radii at or above it the traced 1-D path (µm).
    pub radius_um: f64,
    /// Highest order traced.
    pub max_order: usize,
}

/// A mixture's curve on the output grid, with what its caller checks before using it.
#[derive(Debug, Clone)]
pub struct MixedCurve {
    /// The mixed curve (bin averages on the output grid; meaningless unless
    /// `cross_section_um2` is positive and finite).
    pub curve: PolarisedPhase,
    /// Share of the scattering cross-section carried by traced drops.
    pub traced_fraction: f64,
    /// Σ n(r) dr · C_sca(r) over the radii (µm² per unit of the number weights).
    pub cross_section_um2: f64,
    /// ∫ p dΩ of each traced radius' curve on the intermediate grid (1 up to the
    /// discretisation, unless the computation failed), in radius order.
    pub traced_integrals: Vec<f64>,
}

/// One radius' normalised curve on the intermediate grid (`mid` intervals) and its scattering
/// cross-section (µm²): Lorenz–Mie below `handover_um`, the traced 1-D path at or above.
pub fn radius_curve(
    r: f64,
    wavelength_nm: f64,
    n: f64,
    mid: usize,
    handover_um: f64,
    max_order: usize,
) -> Result<(PolarisedPhase, f64, bool), MieError> {
    if r < handover_um {
        let sphere = Sphere::new(size_parameter(r, wavelength_nm), Complex64::new(n, 0.0))?;
        // Fine cells nest in intermediate cells, as in the Lorenz–Mie tables.
        let fine_cells = FilterSettings::fine_grid_intervals(mid, sphere.coefficients.n_stop());
        let fine = PolarisedPhase::from_sphere(&sphere, fine_cells, FINE_CELL_POINTS, false);
        let c_sca = PI * r * r * sphere.efficiencies.q_sca;
        return Ok((resample_bins(&fine, mid), c_sca, false));
    }
    let go = SphereGo::new(r, wavelength_nm, n, max_order).with_axial_phases(true);
    let angles: Vec<f64> = (0..=mid).map(|j| 180.0 * j as f64 / mid as f64).collect();
    let (ch, _) = sphere_phase_1d(&go, &angles, Phase1dOptions::default());
    let sigma_go: f64 = (0..=max_order).map(|p| go.energy_fraction(p)).sum::<f64>() * PI * r * r;
    let curve = PolarisedPhase {
        step_deg: 180.0 / mid as f64,
        i_perp: ch[1].clone(),
        i_par: ch[2].clone(),
    };
    Ok((curve, sigma_go + PI * r * r, true))
}

/// The mixture of `radii` with number weights `weights` (n(r) dr) at `wavelength_nm` and real
/// index `n`: every radius' curve ([`radius_curve`]) mixed with weights `n(r) dr · C_sca(r)` on
/// the intermediate grid of `settings`, convolved with `sun` (its sun-disc operator) and
/// averaged over the output bins.
pub fn mix_sizes(
    radii: &[f64],
    weights: &[f64],
    wavelength_nm: f64,
    n: f64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
    handover: Handover,
) -> Result<MixedCurve, MieError> {
    let mid = settings.intermediate_intervals();
    let parts: Vec<(PolarisedPhase, f64, bool)> = radii
        .par_iter()
        .zip(weights)
        .map(|(&r, &nw)| {
            let (c, c_sca, traced) = radius_curve(
                r,
                wavelength_nm,
                n,
                mid,
                handover.radius_um,
                handover.max_order,
            )?;
            Ok((c, nw * c_sca, traced))
        })
        .collect::<Result<_, MieError>>()?;
    let traced_integrals = parts
        .iter()
        .filter(|p| p.2)
        .map(|(curve, _, _)| {
            let phase = curve
                .i_perp
                .iter()
                .zip(&curve.i_par)
                .map(|(a, b)| 0.5 * (a + b));
            integral_1d(phase, curve.step_deg.to_radians())
        })
        .collect();
    let total: f64 = parts.iter().map(|p| p.1).sum();
    let traced: f64 = parts.iter().filter(|p| p.2).map(|p| p.1).sum();
    let mut mix = PolarisedPhase::zeros(mid);
    for (curve, weight, _) in &parts {
        mix.add_scaled(curve, weight / total);
    }
    let mix = sun.apply(&mix);
    Ok(MixedCurve {
        curve: resample_bins(&mix, settings.output_intervals),
        traced_fraction: traced / total,
        cross_section_um2: total,
        traced_integrals,
    })
}
