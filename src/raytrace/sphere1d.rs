//! Fast exact 1-D geometric-optics-plus-phase path for spheres (design digest §5).
//!
//! For a sphere of radius `a` and relative index `n`, order `p` (p = 0 external reflection,
//! p ≥ 1 two refractions and `p − 1` internal reflections) leaves at deviation
//! `D(i) = 2i − 2p·t + (p − 1)π` (incidence angle `i`, refraction angle `t`, `sin t = sin i / n`),
//! folded into the scattering angle `θ ∈ [0, π]`. Every branch `i` with `fold(D(i)) = θ`
//! contributes the complex amplitude (per polarisation, ⊥ and ∥)
//!
//! ```text
//! E = sqrt(a² sin i cos i / (sin θ |dD/di|)) · ε · exp(i(k l − (π/2)·[dl/di > 0]))
//! ε = r₁₂ (p = 0),  t₁₂ · r₂₁^(p−1) · t₂₁ (p ≥ 1);   l = 2a (p n cos t − cos i)
//! ```
//!
//! so that `|E|²` is the differential scattering cross-section dσ/dΩ (µm²/sr when `a` is in µm).
//! The focal-line term uses the corrected rule of digest §2.9 (`dl/di = a sin i · dD/di`, the
//! longer-path branch is π/2 behind); the literal thesis rule is off by half a fringe for the
//! primary bow. Per-order constant phases (axial focal lines) are ignored, as in the thesis: they
//! only shift the fine cross-order ripple, which the diffraction filter removes.
//!
//! Axial caustics (θ = 0° for p = 1, 3, …; θ = 180° for p = 2, …) are singular like 1/sin θ;
//! callers evaluate pole samples a fraction of a bin away from the pole (see
//! [`crate::raytrace::post`]).

use crate::optics::fresnel::fresnel_amplitudes_real;
use num_complex::Complex64;
use std::f64::consts::{FRAC_PI_2, PI};

/// Complex far-field amplitudes of one order at one scattering angle, in sqrt(µm²/sr) when the
/// radius is in µm: `|perp|²` and `|par|²` are dσ/dΩ for ⊥ and ∥ incident polarisation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct OrderField {
    pub perp: Complex64,
    pub par: Complex64,
}

/// Geometric-optics-plus-phase model of a sphere for one wavelength.
#[derive(Debug, Clone)]
pub struct SphereGo {
    /// Sphere radius (µm).
    pub radius_um: f64,
    /// Vacuum wavelength (nm).
    pub wavelength_nm: f64,
    /// Relative refractive index (water/air).
    pub n: f64,
    /// Highest order traced (p = 0..=max_order).
    pub max_order: usize,
    /// Per order: monotonic intervals of D(i) as (i_lo, i_hi).
    intervals: Vec<Vec<(f64, f64)>>,
}

impl SphereGo {
    /// Set up the model; `n > 1` is required (water drops in air).
    pub fn new(radius_um: f64, wavelength_nm: f64, n: f64, max_order: usize) -> Self {
        assert!(n > 1.0 && radius_um > 0.0 && wavelength_nm > 0.0);
        let intervals = (0..=max_order)
            .map(|p| {
                let lo = 0.0;
                let hi = FRAC_PI_2;
                if p >= 2 {
                    let c2 = (n * n - 1.0) / ((p * p - 1) as f64);
                    if c2 < 1.0 {
                        let ir = c2.sqrt().acos();
                        return vec![(lo, ir), (ir, hi)];
                    }
                }
                vec![(lo, hi)]
            })
            .collect();
        SphereGo {
            radius_um,
            wavelength_nm,
            n,
            max_order,
            intervals,
        }
    }

    /// Deviation D(i) of order `p`.
    pub fn deviation(&self, p: usize, i: f64) -> f64 {
        let t = (i.sin() / self.n).asin();
        2.0 * i - 2.0 * p as f64 * t + (p as f64 - 1.0) * PI
    }

    /// dD/di of order `p`.
    pub fn deviation_derivative(&self, p: usize, i: f64) -> f64 {
        let t = (i.sin() / self.n).asin();
        2.0 - 2.0 * p as f64 * i.cos() / (self.n * t.cos())
    }

    /// Geometric rainbow (scattering) angle of order `p ≥ 2` in radians, if it exists.
    pub fn rainbow_angle_rad(&self, p: usize) -> Option<f64> {
        if p < 2 {
            return None;
        }
        let iv = &self.intervals[p];
        if iv.len() < 2 {
            return None;
        }
        Some(fold(self.deviation(p, iv[0].1)))
    }

    /// Amplitude products ε (⊥, ∥) of order `p` at incidence angle `i` (real for a sphere).
    pub fn fresnel_product(&self, p: usize, i: f64) -> (f64, f64) {
        let ext = fresnel_amplitudes_real(1.0, self.n, i.cos());
        if p == 0 {
            return (ext.r_s.re, ext.r_p.re);
        }
        let cos_t = ext.cos_theta_t.re;
        let int = fresnel_amplitudes_real(self.n, 1.0, cos_t);
        let q = (p - 1) as i32;
        (
            ext.t_s.re * int.r_s.re.powi(q) * int.t_s.re,
            ext.t_p.re * int.r_p.re.powi(q) * int.t_p.re,
        )
    }

    /// Optical path l(i) = 2a (p n cos t − cos i) (µm), relative to the reference planes.
    pub fn optical_path_um(&self, p: usize, i: f64) -> f64 {
        let t = (i.sin() / self.n).asin();
        2.0 * self.radius_um * (p as f64 * self.n * t.cos() - i.cos())
    }

    /// Coherent field of order `p` at scattering angle `theta_rad` (0 < θ < π), summed over all
    /// geometric branches.
    pub fn order_field(&self, p: usize, theta_rad: f64) -> OrderField {
        let mut out = OrderField::default();
        self.for_each_branch(p, theta_rad, |_, f| {
            out.perp += f.perp;
            out.par += f.par;
        });
        out
    }

    /// Calls `f(i, field)` for every branch of order `p` reaching `theta_rad`.
    pub fn for_each_branch(&self, p: usize, theta_rad: f64, mut f: impl FnMut(f64, OrderField)) {
        let k = 2.0 * PI / (self.wavelength_nm * 1e-3);
        let sin_theta = theta_rad.sin();
        if sin_theta <= 0.0 {
            return;
        }
        for &(lo, hi) in &self.intervals[p] {
            let d_lo = self.deviation(p, lo);
            let d_hi = self.deviation(p, hi);
            let (dmin, dmax) = if d_lo < d_hi { (d_lo, d_hi) } else { (d_hi, d_lo) };
            // Candidates D* = ±θ + 2πm inside [dmin, dmax].
            let m_lo = ((dmin - PI) / (2.0 * PI)).floor() as i64 - 1;
            let m_hi = ((dmax + PI) / (2.0 * PI)).ceil() as i64 + 1;
            for m in m_lo..=m_hi {
                for sign in [1.0, -1.0] {
                    let target = sign * theta_rad + 2.0 * PI * m as f64;
                    if target < dmin || target > dmax {
                        continue;
                    }
                    let i = self.solve(p, lo, hi, d_lo, target);
                    let dd = self.deviation_derivative(p, i);
                    if dd == 0.0 {
                        continue;
                    }
                    let weight = self.radius_um * self.radius_um * i.sin() * i.cos()
                        / (sin_theta * dd.abs());
                    if !(weight > 0.0) {
                        continue;
                    }
                    let amp = weight.sqrt();
                    let (es, ep) = self.fresnel_product(p, i);
                    let focal = if dd > 0.0 { FRAC_PI_2 } else { 0.0 };
                    let phase = k * self.optical_path_um(p, i) - focal;
                    let ph = Complex64::from_polar(amp, phase);
                    f(
                        i,
                        OrderField {
                            perp: ph * es,
                            par: ph * ep,
                        },
                    );
                }
            }
        }
    }

    /// Solve D(i) = target on the monotonic interval [lo, hi] (bisection + secant polish).
    fn solve(&self, p: usize, lo: f64, hi: f64, d_lo: f64, target: f64) -> f64 {
        let (mut a, mut b) = (lo, hi);
        let increasing = self.deviation(p, hi) > d_lo;
        for _ in 0..60 {
            let mid = 0.5 * (a + b);
            let dm = self.deviation(p, mid);
            if (dm < target) == increasing {
                a = mid;
            } else {
                b = mid;
            }
            if b - a < 1e-15 {
                break;
            }
        }
        0.5 * (a + b)
    }

    /// Fraction of the flux incident on the silhouette that leaves in order `p`
    /// (unpolarised): `∫₀¹ ½(|ε⊥|² + |ε∥|²) d(b²)`, Gauss–Legendre in `i`.
    pub fn energy_fraction(&self, p: usize) -> f64 {
        crate::optics::quadrature::integrate(
            |i| {
                let (s, pp) = self.fresnel_product(p, i);
                0.5 * (s * s + pp * pp) * 2.0 * i.sin() * i.cos()
            },
            0.0,
            FRAC_PI_2,
            400,
        )
    }
}

/// Options of the 1-D sphere phase function.
#[derive(Debug, Clone, Copy)]
pub struct Phase1dOptions {
    /// Apply the Gaussian diffraction filter to the main channels.
    pub diffraction_filter: bool,
    /// Add the forward Fraunhofer lobe (always on in the stage; off to study GO alone).
    pub forward_lobe: bool,
}

impl Default for Phase1dOptions {
    fn default() -> Self {
        Phase1dOptions {
            diffraction_filter: true,
            forward_lobe: true,
        }
    }
}

/// Phase-function channels of a sphere at the requested scattering angles, normalised against
/// the full scattering cross-section `σ = σ_GO + πa²` (traced orders plus the forward lobe), in
/// the channel order of [`crate::raytrace::channel_names`]: phase, i_perp, i_par, dolp,
/// phase_p0..phase_pN, phase_unfiltered, i_perp_unfiltered, i_par_unfiltered.
/// Returns `(values[channel][angle], sigma_total_um2)`.
pub fn sphere_phase_1d(
    go: &SphereGo,
    angles_deg: &[f64],
    opts: Phase1dOptions,
) -> (Vec<Vec<f64>>, f64) {
    use rayon::prelude::*;
    let a = go.radius_um;
    let out_step = if angles_deg.len() > 1 {
        (angles_deg[1] - angles_deg[0]).abs().to_radians()
    } else {
        0.1f64.to_radians()
    };
    // Fine internal grid resolving the cross-order (p = 0 / p = 2) ripple.
    let fine_target = (go.wavelength_nm * 1e-3 / (10.0 * a)).min(out_step);
    let nf = (PI / fine_target).ceil() as usize + 1;
    let fstep = PI / (nf - 1) as f64;
    let orders = go.max_order + 1;
    // Per fine angle: [i_perp_total, i_par_total, phase_p0.., ] as dσ/dΩ (µm²/sr).
    let fine: Vec<Vec<f64>> = (0..nf)
        .into_par_iter()
        .map(|j| {
            let mut th = fstep * j as f64;
            th = th.clamp(0.25 * fstep, PI - 0.25 * fstep);
            let mut tot = OrderField::default();
            let mut row = vec![0.0; 2 + orders];
            for p in 0..orders {
                let f = go.order_field(p, th);
                tot.perp += f.perp;
                tot.par += f.par;
                row[2 + p] = 0.5 * (f.perp.norm_sqr() + f.par.norm_sqr());
            }
            row[0] = tot.perp.norm_sqr();
            row[1] = tot.par.norm_sqr();
            row
        })
        .collect();
    let column = |c: usize| -> Vec<f64> { fine.iter().map(|r| r[c]).collect() };
    let out_rad: Vec<f64> = angles_deg.iter().map(|d| d.to_radians()).collect();
    let sigma = crate::raytrace::post::filter_sigma_deg(a * 1e-3).to_radians();
    let split = match (go.rainbow_angle_rad(2), go.rainbow_angle_rad(3)) {
        (Some(p), Some(s)) => 0.5 * (p + s),
        _ => 133.5f64.to_radians(),
    };
    let sigma_at = |th: f64| {
        if !opts.diffraction_filter {
            0.0
        } else if th > split {
            sigma
        } else {
            2.0 * sigma
        }
    };
    let unfiltered = |c: usize| {
        crate::raytrace::post::gaussian_blur(&column(c), 0.0, fstep, &out_rad, |_| 0.0)
    };
    let filtered =
        |c: usize| crate::raytrace::post::gaussian_blur(&column(c), 0.0, fstep, &out_rad, sigma_at);
    let sigma_go: f64 = (0..orders).map(|p| go.energy_fraction(p)).sum::<f64>() * PI * a * a;
    let sigma_total = sigma_go + if opts.forward_lobe { PI * a * a } else { 0.0 };
    let lobe: Vec<f64> = out_rad
        .iter()
        .map(|&th| {
            if !opts.forward_lobe {
                return 0.0;
            }
            let (lo, hi) = crate::raytrace::post::bin_edges(th, out_step);
            crate::raytrace::post::fraunhofer_bin_average(a, go.wavelength_nm, lo, hi)
        })
        .collect();
    let norm = |v: Vec<f64>, with_lobe: bool| -> Vec<f64> {
        v.iter()
            .zip(&lobe)
            .map(|(x, l)| (x + if with_lobe { *l } else { 0.0 }) / sigma_total)
            .collect()
    };
    let i_perp = norm(filtered(0), true);
    let i_par = norm(filtered(1), true);
    let phase: Vec<f64> = i_perp.iter().zip(&i_par).map(|(a, b)| 0.5 * (a + b)).collect();
    let dolp: Vec<f64> = i_perp
        .iter()
        .zip(&i_par)
        .map(|(a, b)| if a + b > 0.0 { (a - b) / (a + b) } else { 0.0 })
        .collect();
    let mut channels = vec![phase, i_perp, i_par, dolp];
    for p in 0..orders {
        channels.push(norm(filtered(2 + p), false));
    }
    let ip_u = norm(unfiltered(0), true);
    let ipar_u = norm(unfiltered(1), true);
    channels.push(ip_u.iter().zip(&ipar_u).map(|(a, b)| 0.5 * (a + b)).collect());
    channels.push(ip_u);
    channels.push(ipar_u);
    (channels, sigma_total)
}

/// Fold a deviation angle into the scattering angle in [0, π].
pub fn fold(d: f64) -> f64 {
    let m = d.rem_euclid(2.0 * PI);
    if m > PI { 2.0 * PI - m } else { m }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn energy_shares_match_digest() {
        // Digest §6 test 2: n = 1.333, p = 0 6.64 %, p = 1 88.37 %, p = 2 4.06 %, p = 3 0.61 %,
        // left over 0.32 %.
        let go = SphereGo::new(400.0, 650.0, 1.333, 3);
        let f: Vec<f64> = (0..=3).map(|p| go.energy_fraction(p)).collect();
        let want = [0.0664, 0.8837, 0.0406, 0.0061];
        for p in 0..4 {
            assert!((f[p] - want[p]).abs() < 6e-5, "p={p}: {} vs {}", f[p], want[p]);
        }
        let left = 1.0 - f.iter().sum::<f64>();
        assert!((left - 0.0032).abs() < 1e-4, "left {left}");
    }

    #[test]
    fn descartes_angles_match_digest() {
        // Digest §3 table: n = 1.331 → 137.630° primary, 129.635° secondary.
        let go = SphereGo::new(400.0, 650.0, 1.331, 3);
        let p = go.rainbow_angle_rad(2).unwrap().to_degrees();
        let s = go.rainbow_angle_rad(3).unwrap().to_degrees();
        assert!((p - 137.630).abs() < 2e-3, "{p}");
        assert!((s - 129.635).abs() < 2e-3, "{s}");
    }

    #[test]
    fn external_reflection_is_a_quarter_a_squared_times_r2() {
        let go = SphereGo::new(100.0, 550.0, 1.333, 0);
        let theta: f64 = 1.0;
        let f = go.order_field(0, theta);
        let i = (PI - theta) / 2.0;
        let (rs, rp) = go.fresnel_product(0, i);
        assert!((f.perp.norm_sqr() - 0.25 * 1e4 * rs * rs).abs() < 1e-9 * 1e4);
        assert!((f.par.norm_sqr() - 0.25 * 1e4 * rp * rp).abs() < 1e-9 * 1e4);
    }
}
