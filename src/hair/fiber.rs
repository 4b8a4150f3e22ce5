//! Physically based fibre model: smooth dielectric circular cylinder (Zinke & Weber 2007 far-field
//! BCSDF, Marschner et al. 2003 lobes R/TT/TRT), integrated over the entry offset `h`.
//!
//! Conventions (see `docs/hair.md`):
//! - `theta` is an inclination from the normal plane in radians, `[-π/2, π/2]`; the fibre
//!   tangent points to the tip.
//! - Relative azimuth `φ = φ_o − φ_i` in `(−π, π]`; `φ = 0` is back-scatter toward the light,
//!   `|φ| = π` straight through the fibre. Exit azimuth of order `p` (Zinke eq. 17–19, written
//!   for every order; decision FIB-3): `Φ_p(h) = 2γ_i − 2pγ_t + pπ`, `γ_i = asin h`,
//!   `sin γ_t = h / n'` with the Bravais index `n' = sqrt(η² − sin²θ)/cos θ`.
//! - Radius `r = 1`: `σ_a` is an absorption coefficient per unit fibre **radius**; the internal
//!   chord of one pass is `l = 2 cos γ_t / cos θ_t` (Zinke eq. 20, not Marschner's length),
//!   `cos θ_t = sqrt(η² − sin²θ)/η`.
//! - Azimuthal functions are per radian and normalised like Zinke eq. 35:
//!   `∫_{−π}^{π} N_p(θ, φ) dφ = ½ ∫_{−1}^{1} a_p(θ, h) dh` (the energy of lobe `p`).
//! - Attenuations: `a_0 = F`, `a_p = (1 − F)(1 − F_int) F_int^{p−1} T^p`, `T = exp(−σ_a l)`;
//!   orders `p ≥ 3` are lumped into a residual lobe `a_res = (1−F)(1−F_int) F_int² T³ /
//!   (1 − F_int T)` (closed geometric series) spread uniformly in azimuth (density `1/2π`), so
//!   that a lossless fibre scatters exactly all the light it intercepts.
//! - Optional azimuthal roughness: each lobe is convolved with a wrapped normal distribution of
//!   standard deviation `azimuthal_width_rad` (exactly normalised on the circle; it replaces
//!   Zinke's truncated Gaussian `g(π, ·)`).
//!
//! Fresnel factors come from [`crate::optics::fresnel`]; two variants are offered
//! ([`FresnelModel`]), the default being the exact unpolarised 3-D Fresnel at the true angle of
//! incidence on the cylinder.

use crate::math::quadrature::gauss_legendre;
use crate::optics::fresnel::{fresnel_amplitudes_real, fresnel_reflectance_unpolarized};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Number of lobes carried everywhere: R, TT, TRT and the residual `p ≥ 3`.
pub const LOBES: usize = 4;
/// Lobe names in storage order.
pub const LOBE_NAMES: [&str; LOBES] = ["R", "TT", "TRT", "residual"];

/// How the Fresnel factors of the cylinder are evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum FresnelModel {
    /// Exact unpolarised Fresnel reflectance at the 3-D angle of incidence
    /// `cos β = cos θ · sqrt(1 − h²)` (outside) and `cos θ_t cos γ_t` (inside). Physical at every
    /// inclination (default).
    #[default]
    ThreeD,
    /// Marschner/Zinke two-index Bravais Fresnel: `R_s` with `n'`, `R_p` with `n'' = η²/n'`,
    /// each with its own Snell angle, in the normal plane at `γ_i` (outside) and with
    /// `1/n'`, `1/n''` at `γ_t` (inside). Identical to `ThreeD` at `θ = 0`; for `θ > 57.2°`
    /// (η = 1.55) `n'' < 1` and the p-polarised reflection becomes total (non-physical).
    Bravais,
}

impl FresnelModel {
    /// Name as written in manifests and headers.
    pub fn name(self) -> &'static str {
        match self {
            FresnelModel::ThreeD => "three-d",
            FresnelModel::Bravais => "bravais",
        }
    }
}

/// Bravais effective indices `(n', n'')` for inclination `theta_rad` (Marschner's η', η'').
/// `n'` is infinite at `|θ| = π/2`.
pub fn bravais_indices(eta: f64, theta_rad: f64) -> (f64, f64) {
    let s = theta_rad.sin();
    let c = theta_rad.cos().abs();
    let root = (eta * eta - s * s).sqrt();
    (root / c, eta * eta * c / root)
}

/// Per-`h` optical quantities of one cylinder crossing at inclination `theta`.
#[derive(Debug, Clone, Copy)]
pub struct Crossing {
    /// External reflectance `F` at entry.
    pub f_ext: f64,
    /// Internal reflectance `F_int` at every internal hit.
    pub f_int: f64,
    /// Internal chord length of one pass, in units of the radius.
    pub path_length: f64,
    /// Refraction angle in the normal plane, `γ_t` (signed like `h`).
    pub gamma_t: f64,
}

/// Refraction angle `γ_t` in the normal plane (`sin γ_t = h/n'`) for index `eta`, computed as
/// in [`crossing`].
pub fn refraction_angle(eta: f64, theta_rad: f64, h: f64) -> f64 {
    let s = theta_rad.sin();
    let c = theta_rad.cos().abs();
    let root = (eta * eta - s * s).sqrt();
    (h * c / root).clamp(-1.0, 1.0).asin()
}

/// Optical quantities at offset `h ∈ [−1, 1]` and inclination `theta_rad`.
pub fn crossing(eta: f64, theta_rad: f64, h: f64, fresnel: FresnelModel) -> Crossing {
    let s = theta_rad.sin();
    let c = theta_rad.cos().abs();
    let root = (eta * eta - s * s).sqrt(); // = n' cos θ
    let sin_gt = (h * c / root).clamp(-1.0, 1.0); // = h / n'
    let gamma_t = sin_gt.asin();
    let cos_gt = (1.0 - sin_gt * sin_gt).sqrt();
    let cos_theta_t = root / eta;
    let path_length = 2.0 * cos_gt / cos_theta_t;
    let cos_gi = (1.0 - h * h).max(0.0).sqrt();
    let (f_ext, f_int) = match fresnel {
        FresnelModel::ThreeD => {
            let cos_beta = c * cos_gi;
            let cos_inside = cos_theta_t * cos_gt;
            (
                fresnel_reflectance_unpolarized(eta, cos_beta),
                fresnel_reflectance_unpolarized(1.0 / eta, cos_inside),
            )
        }
        FresnelModel::Bravais => {
            let c_safe = c.max(1e-9);
            let n_perp = root / c_safe;
            let n_par = (eta * eta * c_safe / root).max(1e-9);
            let ext =
                0.5 * (reflectance_s(1.0, n_perp, cos_gi) + reflectance_p(1.0, n_par, cos_gi));
            let int = 0.5
                * (reflectance_s(1.0, 1.0 / n_perp, cos_gt)
                    + reflectance_p(1.0, 1.0 / n_par, cos_gt));
            (ext, int)
        }
    };
    Crossing {
        f_ext,
        f_int,
        path_length,
        gamma_t,
    }
}

fn reflectance_s(eta_1: f64, eta_2: f64, cos_i: f64) -> f64 {
    let a = fresnel_amplitudes_real(eta_1, eta_2, cos_i);
    if a.total_internal_reflection {
        1.0
    } else {
        a.reflectance_s()
    }
}

fn reflectance_p(eta_1: f64, eta_2: f64, cos_i: f64) -> f64 {
    let a = fresnel_amplitudes_real(eta_1, eta_2, cos_i);
    if a.total_internal_reflection {
        1.0
    } else {
        a.reflectance_p()
    }
}

/// Attenuations `[a_R, a_TT, a_TRT, a_residual]` of one crossing for absorption `sigma_a`
/// (per unit radius; `f64::INFINITY` allowed = opaque interior).
pub fn attenuations(x: &Crossing, sigma_a: f64) -> [f64; LOBES] {
    let t = if sigma_a == 0.0 {
        1.0
    } else {
        (-sigma_a * x.path_length).exp()
    };
    let f = x.f_ext;
    let fi = x.f_int;
    let tt = (1.0 - f) * (1.0 - fi) * t;
    let trt = tt * fi * t;
    let q = fi * t;
    let residual = if q >= 1.0 - 1e-15 {
        0.0
    } else {
        trt * q / (1.0 - q)
    };
    [f, tt, trt, residual]
}

/// Exit azimuth `Φ_p(h)` (not wrapped) of order `p` for entry angle `γ_i` and refraction `γ_t`.
pub fn exit_azimuth(p: usize, gamma_i: f64, gamma_t: f64) -> f64 {
    let p = p as f64;
    2.0 * gamma_i - 2.0 * p * gamma_t + p * PI
}

/// Wrap an angle into `(−π, π]`.
pub fn wrap_angle(x: f64) -> f64 {
    let mut y = x.rem_euclid(TAU);
    if y > PI {
        y -= TAU;
    }
    y
}

/// Density of the wrapped normal distribution (standard deviation `w`) at angle `x`.
pub fn wrapped_normal(x: f64, w: f64) -> f64 {
    let x = wrap_angle(x);
    let norm = 1.0 / ((TAU).sqrt() * w);
    let images = (3.0 * w / TAU).ceil() as i32 + 1;
    let mut s = 0.0;
    for k in -images..=images {
        let d = x - TAU * k as f64;
        s += (-d * d / (2.0 * w * w)).exp();
    }
    s * norm
}

/// Standard normal cumulative distribution.
fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// Fraction of the wrapped normal (centre `c`, width `w`; `w = 0` is a Dirac) that falls in the
/// backward half-circle `|φ| < π/2`. The forward fraction is `1 −` this.
pub fn backward_fraction(c: f64, w: f64) -> f64 {
    let c = wrap_angle(c);
    if w <= 0.0 {
        return if c.abs() < FRAC_PI_2 { 1.0 } else { 0.0 };
    }
    let images = (4.0 * w / TAU).ceil() as i32 + 1;
    let mut s = 0.0;
    for k in -images..=images {
        let m = c + TAU * k as f64;
        let hi = (FRAC_PI_2 - m) / w;
        let lo = (-FRAC_PI_2 - m) / w;
        // Φ(±8.5) is 1 ∓ 1e-17: skip the error functions where they cannot matter.
        if hi < -8.5 || lo > 8.5 {
            continue;
        }
        if lo < -8.5 && hi > 8.5 {
            s += 1.0;
            continue;
        }
        s += normal_cdf(hi) - normal_cdf(lo);
    }
    s.clamp(0.0, 1.0)
}

/// Quadrature in `γ_i ∈ [0, π/2]` (`h = sin γ_i`, the half-width; the other half follows by the
/// mirror symmetry `h → −h`, `Φ → −Φ`, `a` even).
#[derive(Debug, Clone)]
pub struct OffsetQuadrature {
    /// Nodes `γ_i`.
    pub gamma: Vec<f64>,
    /// Weights for `½ ∫_{−1}^{1} … dh = ∫_0^{π/2} … cos γ dγ` (includes `cos γ`; symmetric
    /// integrands only).
    pub weight: Vec<f64>,
}

impl OffsetQuadrature {
    /// Composite Gauss–Legendre with `order` nodes per panel, panels no wider than
    /// `max_panel_rad`, and panel edges at every `breakpoints` value (sorted, inside (0, π/2)).
    pub fn new(max_panel_rad: f64, order: usize, breakpoints: &[f64]) -> Self {
        let (x, w) = gauss_legendre(order);
        let mut edges = vec![0.0];
        edges.extend(
            breakpoints
                .iter()
                .copied()
                .filter(|&b| b > 0.0 && b < FRAC_PI_2),
        );
        edges.push(FRAC_PI_2);
        let mut gamma = Vec::new();
        let mut weight = Vec::new();
        for seg in edges.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            if b - a <= 0.0 {
                continue;
            }
            let n = ((b - a) / max_panel_rad).ceil().max(1.0) as usize;
            let step = (b - a) / n as f64;
            for k in 0..n {
                let lo = a + step * k as f64;
                for (xi, wi) in x.iter().zip(&w) {
                    let g = lo + 0.5 * step * (xi + 1.0);
                    gamma.push(g);
                    weight.push(0.5 * step * wi * g.cos());
                }
            }
        }
        OffsetQuadrature { gamma, weight }
    }
}

/// Values of `γ_i ∈ (0, π/2)` where some lobe's exit azimuth crosses the hemisphere boundary
/// `|φ| = π/2` (where the hemisphere indicator of a smooth fibre jumps).
pub fn hemisphere_breakpoints(eta: f64, theta_rad: f64) -> Vec<f64> {
    hemisphere_breakpoints_trt(eta, eta, theta_rad)
}

/// [`hemisphere_breakpoints`] with the TRT exit azimuth computed for its own index `eta_trt`
/// (the effective index η* of an elliptic fibre, [`super::elliptic`]); R and TT use `eta`.
pub fn hemisphere_breakpoints_trt(eta: f64, eta_trt: f64, theta_rad: f64) -> Vec<f64> {
    let s = theta_rad.sin();
    let c = theta_rad.cos().abs();
    let root = (eta * eta - s * s).sqrt();
    let root_trt = (eta_trt * eta_trt - s * s).sqrt();
    let gt = |g: f64, r: f64| (g.sin() * c / r).asin();
    let level = |p: usize, g: f64| {
        let r = if p == 2 { root_trt } else { root };
        wrap_angle(exit_azimuth(p, g, gt(g, r))).abs() - FRAC_PI_2
    };
    let n = 4096;
    let mut out = Vec::new();
    for p in 0..3 {
        let mut g0 = 0.0;
        let mut v0 = level(p, g0);
        for k in 1..=n {
            let g1 = FRAC_PI_2 * k as f64 / n as f64;
            let v1 = level(p, g1);
            // A sign change of |wrap Φ| − π/2 (continuous even across the ±π wrap); an exact
            // zero on a scan node is taken as is (and not counted again in the next interval).
            if v1 == 0.0 {
                out.push(g1);
            } else if v0 * v1 < 0.0 && v0 != 0.0 {
                let (mut a, mut b, mut va) = (g0, g1, v0);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    let vm = level(p, m);
                    if va * vm <= 0.0 {
                        b = m;
                    } else {
                        a = m;
                        va = vm;
                    }
                }
                out.push(0.5 * (a + b));
            }
            g0 = g1;
            v0 = v1;
        }
    }
    out.sort_by(|a, b| a.partial_cmp(b).unwrap());
    out
}

/// Geometry and Fresnel factors of one inclination on an [`OffsetQuadrature`], reusable for
/// any absorption and azimuthal width.
#[derive(Debug, Clone)]
pub struct FiberSlice {
    pub theta_rad: f64,
    pub weight: Vec<f64>,
    pub crossing: Vec<Crossing>,
    /// Exit azimuths `Φ_p` for p = R, TT, TRT (unwrapped).
    pub phi: Vec<[f64; 3]>,
}

impl FiberSlice {
    pub fn new(eta: f64, theta_rad: f64, fresnel: FresnelModel, quad: &OffsetQuadrature) -> Self {
        let mut crossing_v = Vec::with_capacity(quad.gamma.len());
        let mut phi = Vec::with_capacity(quad.gamma.len());
        for &g in &quad.gamma {
            let x = crossing(eta, theta_rad, g.sin(), fresnel);
            phi.push([
                exit_azimuth(0, g, x.gamma_t),
                exit_azimuth(1, g, x.gamma_t),
                exit_azimuth(2, g, x.gamma_t),
            ]);
            crossing_v.push(x);
        }
        FiberSlice {
            theta_rad,
            weight: quad.weight.clone(),
            crossing: crossing_v,
            phi,
        }
    }

    /// The same slice with the TRT exit azimuths recomputed for the index `eta_trt` (the
    /// effective index η* of an elliptic fibre, [`super::elliptic`]); the attenuations (Fresnel
    /// and chord of the true index) and the R, TT azimuths are kept (decision FIB-23).
    /// `quad` must be the quadrature the slice was built on.
    pub fn with_trt_index(&self, eta_trt: f64, quad: &OffsetQuadrature) -> Self {
        let mut out = self.clone();
        for (ph, &g) in out.phi.iter_mut().zip(&quad.gamma) {
            ph[2] = exit_azimuth(2, g, refraction_angle(eta_trt, self.theta_rad, g.sin()));
        }
        out
    }

    /// Lobe energies `½∫ a_p dh` for absorption `sigma_a`.
    pub fn lobe_energies(&self, sigma_a: f64) -> [f64; LOBES] {
        let mut e = [0.0; LOBES];
        for (x, w) in self.crossing.iter().zip(&self.weight) {
            let a = attenuations(x, sigma_a);
            for p in 0..LOBES {
                e[p] += w * a[p];
            }
        }
        e
    }

    /// Backward fractions `W_b` of lobes R, TT, TRT at every node for azimuthal width `w`.
    pub fn backward_fractions(&self, w: f64) -> Vec<[f64; 3]> {
        self.phi
            .iter()
            .map(|ph| {
                [
                    backward_fraction(ph[0], w),
                    backward_fraction(ph[1], w),
                    backward_fraction(ph[2], w),
                ]
            })
            .collect()
    }

    /// Per-lobe energies scattered into the backward (`|φ| < π/2`) and forward half-circles,
    /// `([E_b; 4], [E_f; 4])`, given the node fractions from [`Self::backward_fractions`].
    /// The residual lobe is uniform in azimuth, so it splits evenly.
    pub fn hemisphere_energies(
        &self,
        sigma_a: f64,
        wb: &[[f64; 3]],
    ) -> ([f64; LOBES], [f64; LOBES]) {
        self.hemisphere_energies_from(&self.weighted_attenuations(sigma_a), wb)
    }

    /// Quadrature weight × attenuations at every node, for reuse across azimuthal widths.
    pub fn weighted_attenuations(&self, sigma_a: f64) -> Vec<[f64; LOBES]> {
        self.crossing
            .iter()
            .zip(&self.weight)
            .map(|(x, w)| attenuations(x, sigma_a).map(|a| w * a))
            .collect()
    }

    /// [`Self::hemisphere_energies`] from precomputed [`Self::weighted_attenuations`].
    pub fn hemisphere_energies_from(
        &self,
        wa: &[[f64; LOBES]],
        wb: &[[f64; 3]],
    ) -> ([f64; LOBES], [f64; LOBES]) {
        let mut eb = [0.0; LOBES];
        let mut ef = [0.0; LOBES];
        for (a, b) in wa.iter().zip(wb) {
            for p in 0..3 {
                eb[p] += a[p] * b[p];
                ef[p] += a[p] * (1.0 - b[p]);
            }
            eb[3] += 0.5 * a[3];
            ef[3] += 0.5 * a[3];
        }
        (eb, ef)
    }

    /// Azimuthal functions `N_p(θ, φ_j)` (per radian) on the uniform grid
    /// `φ_j = phi_start + j·phi_step` for absorption
    /// `sigma_a` and azimuthal width `w > 0`; returns `out[j][p]` for R, TT, TRT, residual.
    /// Gaussian tails beyond 8 w (relative 1e-14) are dropped. Uses the mirror symmetry
    /// (`±Φ` share the half-range weight), so the result is even in `φ` by construction.
    pub fn azimuthal_on_grid(
        &self,
        sigma_a: f64,
        w: f64,
        phi_start: f64,
        phi_step: f64,
        phi_count: usize,
    ) -> Vec<[f64; LOBES]> {
        self.azimuthal_on_grid_lobes(sigma_a, w, phi_start, phi_step, phi_count, &[0, 1, 2])
    }

    /// [`Self::azimuthal_on_grid`] evaluating only the listed lobes among R, TT, TRT (the others
    /// stay 0; the residual is always filled).
    pub fn azimuthal_on_grid_lobes(
        &self,
        sigma_a: f64,
        w: f64,
        phi_start: f64,
        phi_step: f64,
        phi_count: usize,
        lobes: &[usize],
    ) -> Vec<[f64; LOBES]> {
        assert!(w > 0.0, "azimuthal grid evaluation needs a positive width");
        assert!(phi_step > 0.0 && phi_count > 0);
        let mut out = vec![[0.0; LOBES]; phi_count];
        let norm = 1.0 / (TAU.sqrt() * w);
        let cut = 8.0 * w;
        let images = (cut / TAU).ceil() as i32 + 1;
        let mut residual = 0.0;
        for ((x, wt), ph) in self.crossing.iter().zip(&self.weight).zip(&self.phi) {
            let a = attenuations(x, sigma_a);
            residual += wt * a[3];
            for &p in lobes {
                if a[p] == 0.0 {
                    continue;
                }
                let amp = 0.5 * wt * a[p] * norm;
                for centre in [ph[p], -ph[p]] {
                    let c = wrap_angle(centre);
                    for k in -images..=images {
                        let m = c + TAU * k as f64;
                        let lo = ((m - cut - phi_start) / phi_step).ceil().max(0.0);
                        let hi = ((m + cut - phi_start) / phi_step).floor();
                        if hi < 0.0 || lo > (phi_count - 1) as f64 {
                            continue;
                        }
                        let hi = hi.min((phi_count - 1) as f64) as usize;
                        for (j, o) in out.iter_mut().enumerate().take(hi + 1).skip(lo as usize) {
                            let d = phi_start + phi_step * j as f64 - m;
                            o[p] += amp * (-d * d / (2.0 * w * w)).exp();
                        }
                    }
                }
            }
        }
        for o in out.iter_mut() {
            o[3] = residual / TAU;
        }
        out
    }
}

/// A fibre and the quadrature of a pointwise `N_p` evaluation ([`azimuthal_pointwise`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointwiseFiber {
    /// Index of refraction.
    pub eta: f64,
    /// Absorption per unit radius (see [`attenuations`]).
    pub sigma_a: f64,
    /// Azimuthal width: standard deviation of the wrapped normal blur (rad), > 0.
    pub w: f64,
    pub fresnel: FresnelModel,
    /// Gauss–Legendre panels in `γ_i ∈ [−π/2, π/2]` and nodes per panel.
    pub panels: usize,
    pub order: usize,
}

/// `N_p(θ, φ)` at one point by direct integration over the full width `h ∈ [−1, 1]`
/// (no symmetry used), for width `f.w > 0`. Reference implementation for tests and small
/// queries: `f.panels` Gauss–Legendre panels of `f.order` nodes in `γ_i ∈ [−π/2, π/2]`.
pub fn azimuthal_pointwise(f: &PointwiseFiber, theta_rad: f64, phi_rad: f64) -> [f64; LOBES] {
    azimuthal_pointwise_trt(f, f.eta, theta_rad, phi_rad)
}

/// [`azimuthal_pointwise`] with the TRT exit azimuth computed for its own index `eta_trt` (the
/// effective index η* of an elliptic fibre); attenuations use `f.eta` (decision FIB-23).
pub fn azimuthal_pointwise_trt(
    f: &PointwiseFiber,
    eta_trt: f64,
    theta_rad: f64,
    phi_rad: f64,
) -> [f64; LOBES] {
    let PointwiseFiber {
        eta,
        sigma_a,
        w,
        fresnel,
        panels,
        order,
    } = *f;
    let (x, wq) = gauss_legendre(order);
    let step = PI / panels as f64;
    let mut out = [0.0; LOBES];
    for k in 0..panels {
        let lo = -FRAC_PI_2 + step * k as f64;
        for (xi, wi) in x.iter().zip(&wq) {
            let g = lo + 0.5 * step * (xi + 1.0);
            let weight = 0.5 * 0.5 * step * wi * g.cos();
            let c = crossing(eta, theta_rad, g.sin(), fresnel);
            let a = attenuations(&c, sigma_a);
            for p in 0..3 {
                let gt = if p == 2 && eta_trt != eta {
                    refraction_angle(eta_trt, theta_rad, g.sin())
                } else {
                    c.gamma_t
                };
                out[p] += weight * a[p] * wrapped_normal(phi_rad - exit_azimuth(p, g, gt), w);
            }
            out[3] += weight * a[3] / TAU;
        }
    }
    out
}

/// Smooth-fibre (`w → 0`) azimuthal function by root finding (Marschner et al. 2003):
/// `N_p(φ) = ½ Σ_roots a_p(h)/|dΦ_p/dh|`, roots bracketed on a fine `h` grid (decision FIB-10). For
/// validation; infinite at caustics. Returns R, TT, TRT.
pub fn azimuthal_smooth_roots(
    eta: f64,
    theta_rad: f64,
    phi_rad: f64,
    sigma_a: f64,
    fresnel: FresnelModel,
) -> [f64; 3] {
    let (n_perp, _) = bravais_indices(eta, theta_rad);
    let mut out = [0.0; 3];
    let n = 20000;
    for (p, slot) in out.iter_mut().enumerate() {
        let f = |h: f64| {
            let gt = (h / n_perp).asin();
            wrap_angle(exit_azimuth(p, h.asin(), gt) - phi_rad)
        };
        let mut h0 = -1.0 + 1e-12;
        let mut v0 = f(h0);
        for k in 1..=n {
            let h1 = -1.0 + 2.0 * k as f64 / n as f64 - if k == n { 1e-12 } else { 0.0 };
            let v1 = f(h1);
            let bracket = v1 == 0.0 || (v0 * v1 < 0.0 && v0 != 0.0);
            if bracket && (v1 - v0).abs() < PI {
                let (mut a, mut b, mut va) = (h0, h1, v0);
                for _ in 0..80 {
                    let m = 0.5 * (a + b);
                    let vm = f(m);
                    if va * vm <= 0.0 {
                        b = m;
                    } else {
                        a = m;
                        va = vm;
                    }
                }
                let h = 0.5 * (a + b);
                let dphi =
                    2.0 / (1.0 - h * h).sqrt() - 2.0 * p as f64 / (n_perp * n_perp - h * h).sqrt();
                let x = crossing(eta, theta_rad, h, fresnel);
                *slot += 0.5 * attenuations(&x, sigma_a)[p] / dphi.abs();
            }
            h0 = h1;
            v0 = v1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(x: f64) -> f64 {
        x.to_radians()
    }

    /// A keratin fibre (η = 1.55, 3-D Fresnel) with absorption `sigma_a` and width `w`, on
    /// `panels` panels of 8 nodes.
    fn fiber(sigma_a: f64, w: f64, panels: usize) -> PointwiseFiber {
        PointwiseFiber {
            eta: 1.55,
            sigma_a,
            w,
            fresnel: FresnelModel::ThreeD,
            panels,
            order: 8,
        }
    }

    fn energies(theta: f64, sigma_a: f64, fresnel: FresnelModel) -> [f64; LOBES] {
        let q = OffsetQuadrature::new(0.02, 8, &[]);
        FiberSlice::new(1.55, theta, fresnel, &q).lobe_energies(sigma_a)
    }

    #[test]
    fn bravais_indices_match_reference_table() {
        for (t, n1, n2) in [
            (30.0, 1.69411, 1.41815),
            (60.0, 2.57099, 0.93446),
            (75.0, 4.68367, 0.51295),
        ] {
            let (a, b) = bravais_indices(1.55, deg(t));
            assert!(
                (a - n1).abs() < 2e-5 && (b - n2).abs() < 2e-5,
                "{t}: {a} {b}"
            );
        }
        // n'' = 1 at θ = acos(1/sqrt(η²+1)) = 57.17°.
        let t = (1.0 / (1.55f64 * 1.55 + 1.0).sqrt()).acos();
        assert!((bravais_indices(1.55, t).1 - 1.0).abs() < 1e-12);
        assert!((t.to_degrees() - 57.17).abs() < 0.01);
    }

    #[test]
    fn fresnel_limits_and_variants() {
        // Normal incidence: ((η−1)/(η+1))² for both variants and for the inside reflection.
        let r0 = ((1.55f64 - 1.0) / 2.55).powi(2);
        for m in [FresnelModel::ThreeD, FresnelModel::Bravais] {
            let x = crossing(1.55, 0.0, 0.0, m);
            assert!((x.f_ext - r0).abs() < 1e-12 && (x.f_int - r0).abs() < 1e-12);
            assert!((x.path_length - 2.0).abs() < 1e-12, "one diameter at h = 0");
            // Grazing entry: everything is reflected.
            assert!(crossing(1.55, 0.3, 1.0, m).f_ext > 0.999_999);
        }
        // Independent references: Bravais vs true 3-D reflectance.
        for (t, h, brav, three_d) in [
            (30.0, 0.9, 0.14881, 0.15485),
            (60.0, 0.9, 0.26135, 0.31804),
            (75.0, 0.9, 0.84177, 0.53951),
        ] {
            let b = crossing(1.55, deg(t), h, FresnelModel::Bravais).f_ext;
            let d = crossing(1.55, deg(t), h, FresnelModel::ThreeD).f_ext;
            assert!(
                (b - brav).abs() < 2e-5 && (d - three_d).abs() < 2e-5,
                "{t} {h}: {b} {d}"
            );
        }
        // 3-D: reflectance inside equals outside (reciprocity of the unpolarised reflectance).
        let x = crossing(1.55, deg(40.0), 0.7, FresnelModel::ThreeD);
        assert!((x.f_ext - x.f_int).abs() < 1e-12);
    }

    #[test]
    fn lossless_attenuations_sum_to_one_for_every_offset() {
        for m in [FresnelModel::ThreeD, FresnelModel::Bravais] {
            for t in [0.0, 20.0, 45.0, 70.0, 89.0] {
                for h in [0.0, 0.3, 0.6, 0.9, 0.99, 0.999] {
                    let a = attenuations(&crossing(1.55, deg(t), h, m), 0.0);
                    let s: f64 = a.iter().sum();
                    assert!((s - 1.0).abs() < 1e-13, "{m:?} θ={t} h={h}: {s}");
                }
            }
        }
        // Independent per-h attenuations at θ = 0.
        for (h, r, tt, trt) in [
            (0.0, 0.04652, 0.90912, 0.04229),
            (0.9, 0.12268, 0.76969, 0.09443),
            (0.99, 0.46620, 0.28495, 0.13284),
        ] {
            let a = attenuations(&crossing(1.55, 0.0, h, FresnelModel::ThreeD), 0.0);
            assert!(
                (a[0] - r).abs() < 1e-5 && (a[1] - tt).abs() < 1e-5 && (a[2] - trt).abs() < 1e-5,
                "h={h}: {a:?}"
            );
        }
    }

    /// Width-averaged lobe energies ½∫a_p dh of the smooth cylinder of Zinke & Weber 2007 (σ per
    /// unit radius), computed independently by Simpson's rule.
    #[test]
    fn lobe_energies_match_smooth_cylinder_references() {
        let cases = [
            (FresnelModel::ThreeD, 0.0, 0.0, [0.07496, 0.86179, 0.05567]),
            (FresnelModel::ThreeD, 0.0, 0.5, [0.07496, 0.33998, 0.00933]),
            (FresnelModel::ThreeD, 0.0, 2.0, [0.07496, 0.02143, 0.00005]),
            (
                FresnelModel::Bravais,
                30.0,
                0.0,
                [0.08513, 0.84596, 0.06169],
            ),
            (
                FresnelModel::Bravais,
                60.0,
                0.0,
                [0.18350, 0.70697, 0.09311],
            ),
            (
                FresnelModel::Bravais,
                60.0,
                0.5,
                [0.18350, 0.21719, 0.00893],
            ),
        ];
        // Tolerance: the references are 5-digit Simpson results; at 60° the Bravais p-TIR
        // kink (n'' < 1) limits them to ≈ 4e-5 (ours converge to 1e-9 under panel doubling).
        for (m, t, s, want) in cases {
            let e = energies(deg(t), s, m);
            for p in 0..3 {
                assert!(
                    (e[p] - want[p]).abs() < 5e-5,
                    "{m:?} θ={t} σ={s} p={p}: {} vs {}",
                    e[p],
                    want[p]
                );
            }
        }
        // Lossless: the residual p ≥ 3 holds the rest (0.00757 at θ = 0), the total is 1.
        let e = energies(0.0, 0.0, FresnelModel::ThreeD);
        assert!((e[3] - 0.00757).abs() < 2e-5, "{}", e[3]);
        assert!((e.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn smooth_fibre_root_values_match_references() {
        let n = azimuthal_smooth_roots(1.55, 0.0, 0.0, 0.0, FresnelModel::ThreeD);
        assert!((n[0] - 0.011630).abs() < 2e-6, "N_R(0) = {}", n[0]);
        assert!((n[2] - 0.058818).abs() < 2e-6, "N_TRT(0) = {}", n[2]);
        let n = azimuthal_smooth_roots(1.55, 0.0, PI, 0.0, FresnelModel::ThreeD);
        assert!((n[1] - 0.64052).abs() < 2e-5, "N_TT(π) = {}", n[1]);
        // R lobe in closed form (Zinke eq. 43 / Marschner eq. 8): ¼ a_R(γ = φ/2) cos(φ/2).
        for phi in [0.3, 1.0, 2.5] {
            let n = azimuthal_smooth_roots(1.55, deg(35.0), phi, 0.0, FresnelModel::ThreeD);
            let a = crossing(1.55, deg(35.0), (phi / 2.0).sin(), FresnelModel::ThreeD).f_ext;
            assert!((n[0] - 0.25 * a * (phi / 2.0).cos()).abs() < 1e-9);
        }
    }

    /// A narrow azimuthal blur converges to the smooth fibre away from caustics.
    #[test]
    fn rough_fibre_tends_to_smooth_fibre() {
        for (t, phi, s) in [
            (0.0, 2.6, 0.0),
            (deg(30.0), 2.0, 0.3),
            (deg(10.0), 0.05, 0.0),
        ] {
            let smooth = azimuthal_smooth_roots(1.55, t, phi, s, FresnelModel::ThreeD);
            let rough = azimuthal_pointwise(&fiber(s, deg(0.2), 2000), t, phi);
            for p in 0..3 {
                let tol = 2e-3 * smooth[p].abs() + 1e-6;
                assert!(
                    (rough[p] - smooth[p]).abs() < tol,
                    "θ={t} φ={phi} p={p}: {} vs {}",
                    rough[p],
                    smooth[p]
                );
            }
        }
    }

    #[test]
    fn azimuthal_functions_are_even_normalised_and_grid_matches_pointwise() {
        let w = deg(4.0);
        let t = deg(25.0);
        let s = 0.2;
        for phi in [0.1, 0.7, 1.9, 3.0] {
            let a = azimuthal_pointwise(&fiber(s, w, 600), t, phi);
            let b = azimuthal_pointwise(&fiber(s, w, 600), t, -phi);
            for p in 0..LOBES {
                assert!((a[p] - b[p]).abs() < 1e-12 * (1.0 + a[p]), "symmetry p={p}");
            }
        }
        let q = OffsetQuadrature::new(w / 2.0, 8, &[]);
        let slice = FiberSlice::new(1.55, t, FresnelModel::ThreeD, &q);
        let n = 361;
        let step = PI / (n - 1) as f64;
        let grid = slice.azimuthal_on_grid(s, w, 0.0, step, n);
        for j in [0, 40, 200, 360] {
            let a = azimuthal_pointwise(&fiber(s, w, 600), t, step * j as f64);
            for p in 0..LOBES {
                assert!(
                    (grid[j][p] - a[p]).abs() < 1e-9,
                    "j={j} p={p}: {} vs {}",
                    grid[j][p],
                    a[p]
                );
            }
        }
        // ∫_{−π}^{π} N_p dφ = lobe energy (trapezoid on the even function, [0, π] doubled).
        let e = slice.lobe_energies(s);
        for p in 0..LOBES {
            let mut int = 0.0;
            for (j, g) in grid.iter().enumerate() {
                let wj = if j == 0 || j == n - 1 { 0.5 } else { 1.0 };
                int += 2.0 * wj * step * g[p];
            }
            assert!((int - e[p]).abs() < 1e-7, "p={p}: {int} vs {}", e[p]);
        }
    }
}
