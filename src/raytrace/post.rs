//! Diffraction post-processing shared by the 1-D sphere path and the 2-D tracer.
//!
//! - The Gaussian "diffraction" filter of the thesis (§3.4.4, Table 3.3): a 1-D blur in the
//!   scattering (polar) angle with σ(a) from Table 3.3 for the primary region and 2σ for the
//!   secondary region. Decisions (RT-9 in `docs/decisions.md`): the split between the two
//!   regions is the Alexander-band midpoint (mean of the geometric primary and secondary bow
//!   angles at the wavelength); σ is interpolated linearly in radius inside 0.1–1.0 mm and
//!   continued by Airy scaling σ ∝ a^(−2/3) outside; no wavelength scaling; the filter acts on the coherent
//!   intensity (and on each order's intensity for the per-order channels); Gaussian weights are
//!   renormalised over the samples available near 0° and 180°.
//! - The forward Fraunhofer diffraction lobe of the silhouette (decision RT-10):
//!   `dσ/dΩ = a² J₁(x sin θ)² / sin² θ` (x = 2πa/λ), unpolarised, for θ < 90°. It is tabulated as
//!   the exact average over each table bin (from Rayleigh's encircled-energy formula
//!   `πa² [1 − J₀²(x sin θ) − J₁²(x sin θ)]`), so the unresolved lobe still carries its πa² of
//!   cross-section in any bin-sum over the table.

use std::f64::consts::PI;

/// Table 3.3 of the thesis: σ of the Gaussian diffraction filter (deg) vs radius (mm).
pub const SIGMA_TABLE_3_3: [(f64, f64); 10] = [
    (0.1, 0.70),
    (0.2, 0.45),
    (0.3, 0.30),
    (0.4, 0.25),
    (0.5, 0.22),
    (0.6, 0.20),
    (0.7, 0.18),
    (0.8, 0.17),
    (0.9, 0.16),
    (1.0, 0.15),
];

/// σ (deg) of the primary-bow Gaussian filter for a drop of equivalent radius `radius_mm`:
/// Table 3.3 linearly interpolated, Airy scaling a^(−2/3) outside 0.1–1.0 mm.
pub fn filter_sigma_deg(radius_mm: f64) -> f64 {
    let t = &SIGMA_TABLE_3_3;
    if radius_mm <= t[0].0 {
        return t[0].1 * (radius_mm / t[0].0).powf(-2.0 / 3.0);
    }
    if radius_mm >= t[9].0 {
        return t[9].1 * (radius_mm / t[9].0).powf(-2.0 / 3.0);
    }
    let grid: Vec<f64> = t.iter().map(|r| r.0).collect();
    let vals: Vec<f64> = t.iter().map(|r| r.1).collect();
    crate::table::interp::interp1(&grid, &vals, radius_mm)
}

/// Gaussian blur of samples `values` given on the uniform polar grid `theta_j = start + j·step`
/// (radians), evaluated at `out_theta` (radians), with a per-output σ (radians) from `sigma_at`.
/// Weights are renormalised over the available samples. A σ of 0 returns linear interpolation.
pub fn gaussian_blur(
    values: &[f64],
    start_rad: f64,
    step_rad: f64,
    out_theta_rad: &[f64],
    sigma_at: impl Fn(f64) -> f64,
) -> Vec<f64> {
    let n = values.len();
    out_theta_rad
        .iter()
        .map(|&th| {
            let s = sigma_at(th);
            if s <= 0.0 || n < 2 {
                return crate::table::interp::interp1_uniform(values, start_rad, step_rad, th);
            }
            let c = (th - start_rad) / step_rad;
            let half = (4.0 * s / step_rad).ceil() as i64 + 1;
            let j0 = ((c.floor() as i64) - half).max(0);
            let j1 = ((c.ceil() as i64) + half).min(n as i64 - 1);
            let mut wsum = 0.0;
            let mut acc = 0.0;
            for j in j0..=j1 {
                let d = (start_rad + step_rad * j as f64 - th) / s;
                let w = (-0.5 * d * d).exp();
                wsum += w;
                acc += w * values[j as usize];
            }
            if wsum > 0.0 { acc / wsum } else { 0.0 }
        })
        .collect()
}

/// Fraunhofer forward lobe of a disc of radius `radius_um` at wavelength `wavelength_nm`,
/// averaged over the polar bin [θ_lo, θ_hi] (radians, clamped to [0, π/2]): µm²/sr.
pub fn fraunhofer_bin_average(radius_um: f64, wavelength_nm: f64, lo_rad: f64, hi_rad: f64) -> f64 {
    let x = 2.0 * PI * radius_um / (wavelength_nm * 1e-3);
    let lo = lo_rad.clamp(0.0, PI / 2.0);
    let hi = hi_rad.clamp(0.0, PI / 2.0);
    if hi <= lo {
        return 0.0;
    }
    let enclosed = |th: f64| {
        let u = x * th.sin();
        let frac = if u < 1e-3 {
            // 1 − J0² − J1² = u²/4 − u⁴/32 + O(u⁶), avoiding cancellation.
            u * u / 4.0 - u.powi(4) / 32.0
        } else {
            let j0 = libm::j0(u);
            let j1 = libm::j1(u);
            1.0 - j0 * j0 - j1 * j1
        };
        PI * radius_um * radius_um * frac
    };
    // cos lo − cos hi without cancellation.
    let omega = 4.0 * PI * (0.5 * (hi + lo)).sin() * (0.5 * (hi - lo)).sin();
    (enclosed(hi) - enclosed(lo)) / omega
}

/// Default half-width of the caustic window, in units of the local filter σ.
pub const DEFAULT_CAUSTIC_WINDOW_SIGMAS: f64 = 2.0;

/// Weight in [0, 1] of the filtered value near caustics: `max_c exp(−½((θ − θ_c)/w)²)` over the
/// caustic angles `centres` (radians), window half-width `w` (radians).
pub fn caustic_weight(theta: f64, centres: &[f64], w: f64) -> f64 {
    if w <= 0.0 {
        return 1.0;
    }
    centres
        .iter()
        .map(|c| (-0.5 * ((theta - c) / w).powi(2)).exp())
        .fold(0.0, f64::max)
}

/// Polar bin edges of sample `theta` on a uniform grid of spacing `step` (radians), clamped to
/// [0, π].
pub fn bin_edges(theta: f64, step: f64) -> (f64, f64) {
    ((theta - 0.5 * step).max(0.0), (theta + 0.5 * step).min(PI))
}

/// ∫ p dΩ of a 1-D phase function on a uniform [0, π] grid of step `step` (rad): bin-sum with
/// exact bin solid angles.
pub fn integral_1d(values: impl Iterator<Item = f64>, step: f64) -> f64 {
    values
        .enumerate()
        .map(|(j, v)| {
            let (lo, hi) = bin_edges(step * j as f64, step);
            v * 2.0 * PI * (lo.cos() - hi.cos())
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_table_nodes_and_scaling() {
        assert_eq!(filter_sigma_deg(0.4), 0.25);
        assert!((filter_sigma_deg(0.45) - 0.235).abs() < 1e-12);
        assert!((filter_sigma_deg(2.0) - 0.15 * 2f64.powf(-2.0 / 3.0)).abs() < 1e-12);
    }

    #[test]
    fn fraunhofer_lobe_integrates_to_geometric_cross_section() {
        // Sum of bin averages × bin solid angles over the forward hemisphere ≈ πa² (Babinet).
        let a = 400.0;
        let step = 0.001f64.to_radians();
        let mut total = 0.0;
        let mut th = 0.0;
        while th < PI / 2.0 {
            let avg = fraunhofer_bin_average(a, 650.0, th, th + step);
            total += avg * 2.0 * PI * (th.cos() - (th + step).cos());
            th += step;
        }
        assert!(
            (total / (PI * a * a) - 1.0).abs() < 1e-3,
            "{}",
            total / (PI * a * a)
        );
        // Peak value a²x²/4 at θ → 0 (Airy disc).
        let x = 2.0 * PI * a / 0.65;
        let peak = fraunhofer_bin_average(a, 650.0, 0.0, 1e-9);
        assert!((peak / (a * a * x * x / 4.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn blur_preserves_constants_and_smooths_a_spike() {
        let step = 0.01f64.to_radians();
        let mut v = vec![1.0; 1000];
        let out = gaussian_blur(&v, 0.0, step, &[0.0, 0.05, 5.0f64.to_radians()], |_| {
            0.2f64.to_radians()
        });
        assert!(out.iter().all(|x| (x - 1.0).abs() < 1e-12));
        v.iter_mut().for_each(|x| *x = 0.0);
        v[500] = 1.0;
        let out = gaussian_blur(&v, 0.0, step, &[500.0 * step], |_| 0.1f64.to_radians());
        // Peak of a unit spike blurred by σ = 10 samples: 1/(sqrt(2π)·10).
        assert!((out[0] - 1.0 / ((2.0 * PI).sqrt() * 10.0)).abs() < 1e-4);
    }
}
