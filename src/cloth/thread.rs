//! The thread scattering function `f_s` of Sadeghi et al. 2013 (thesis eqs. 5.6–5.11).
//!
//! A thread is a dielectric microcylinder. Directions are given in the thread's frame
//! ([`ThreadDir`]): `s = ω·t` along the tangent, `c = ω·n` along a normal `n` of the thread's
//! normal plane, `d = ω·b` with `b = t × n`. The longitudinal angle is `θ = asin s` (from the
//! normal plane, `θ = π/2` along `t`), the azimuth `φ = atan2(d, c)` is measured from `n`.
//!
//! ```text
//! f_s = (f_r,s + f_r,v) / cos²θ_d                                             (5.11)
//! f_r,s = F_r(η, acos(cos θ_d cos(φ_d/2))) · cos(φ_d/2) · g(γ_s, θ_h)         (5.7), (5.8)
//! f_r,v = F_t(η, cos θ_i) F_t(η, cos θ_r) [(1 − k_d) g(γ_v, θ_h) + k_d] A / (cos θ_i + cos θ_r)
//!                                                                             (5.9), (5.10)
//! θ_h = (θ_i + θ_r)/2,  θ_d = (θ_i − θ_r)/2,  |φ_d| ∈ [0, π]
//! ```
//!
//! `g` is the unit-area Gaussian of standard deviation γ (radians). θ_d is half the difference
//! of the inclinations (decision CLOTH-1), the transmission product uses the two thread-frame
//! cosines (CLOTH-2). `f_s` is in sr⁻¹ per the curve-radiance integral (5.6); it depends on the
//! directions only through `(θ_i, θ_r, |φ_d|)`, is symmetric in `ω_i ↔ ω_r` and invariant under
//! `t → −t`. The surface lobe is white, the volume lobe carries the albedo `A`.

use crate::hair::longitudinal::gaussian;
use crate::optics::fresnel::fresnel_reflectance_unpolarized;

/// Optical parameters of one thread (one row of the thesis's Table 5.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreadOptics {
    /// Relative refractive index η of the fibre material (air outside).
    pub eta: f64,
    /// Volume-scattering albedo `A`, linear RGB.
    pub albedo: [f64; 3],
    /// Isotropic fraction `k_d` of volume scattering, in [0, 1].
    pub k_d: f64,
    /// Surface roughness γ_s: standard deviation of the surface lobe in θ_h, radians.
    pub gamma_s_rad: f64,
    /// Volume spread γ_v: standard deviation of the forward volume lobe in θ_h, radians.
    pub gamma_v_rad: f64,
}

/// A unit direction in a thread's frame: components along the tangent `t`, the normal `n` and
/// the binormal `b = t × n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreadDir {
    /// `ω·t = sin θ`.
    pub s: f64,
    /// `ω·n = cos θ cos φ`.
    pub c: f64,
    /// `ω·b = cos θ sin φ`.
    pub d: f64,
}

impl ThreadDir {
    /// The direction with inclination `theta_rad` from the normal plane and azimuth `phi_rad`
    /// from `n`.
    pub fn from_angles(theta_rad: f64, phi_rad: f64) -> Self {
        let (st, ct) = theta_rad.sin_cos();
        let (sp, cp) = phi_rad.sin_cos();
        ThreadDir {
            s: st,
            c: ct * cp,
            d: ct * sp,
        }
    }

    /// Inclination θ from the normal plane, radians in [−π/2, π/2].
    pub fn theta_rad(&self) -> f64 {
        self.s.clamp(-1.0, 1.0).asin()
    }

    /// `cos θ = |projection onto the normal plane|` (≥ 0).
    pub fn cos_theta(&self) -> f64 {
        self.c.hypot(self.d)
    }
}

/// The two lobes of `f_s` at one direction pair, each already divided by `cos²θ_d` (sr⁻¹).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThreadLobes {
    /// Surface reflection (white).
    pub surface: f64,
    /// Volume scattering, RGB.
    pub volume: [f64; 3],
}

impl ThreadLobes {
    /// `f_s` per channel: surface + volume.
    pub fn total(&self) -> [f64; 3] {
        self.volume.map(|v| v + self.surface)
    }
}

/// `cos φ_d` of two directions from their normal-plane components; `None` when either lies
/// along the tangent (azimuth undefined).
pub fn cos_phi_d(wi: &ThreadDir, wr: &ThreadDir) -> Option<f64> {
    let (ci, cr) = (wi.cos_theta(), wr.cos_theta());
    (ci > 0.0 && cr > 0.0).then(|| ((wi.c * wr.c + wi.d * wr.d) / (ci * cr)).clamp(-1.0, 1.0))
}

/// The per-direction quantities of `f_s` that do not depend on the other direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreadSide {
    /// θ, radians.
    pub theta_rad: f64,
    /// cos θ (≥ 0).
    pub cos_theta: f64,
    /// Fresnel transmittance `F_t(η, cos θ)` (eq. 5.10, one factor).
    pub transmittance: f64,
}

impl ThreadSide {
    /// The quantities of `w` for a thread of index `eta`.
    pub fn new(eta: f64, w: &ThreadDir) -> Self {
        let cos_theta = w.cos_theta();
        ThreadSide {
            theta_rad: w.theta_rad(),
            cos_theta,
            transmittance: 1.0 - fresnel_reflectance_unpolarized(eta, cos_theta),
        }
    }
}

/// `f_s` from the prepared sides and `cos φ_d` (see [`cos_phi_d`]).
pub fn thread_bsdf_sides(
    optics: &ThreadOptics,
    wi: &ThreadSide,
    wr: &ThreadSide,
    cos_phi_d: f64,
) -> ThreadLobes {
    if wi.cos_theta <= 0.0 || wr.cos_theta <= 0.0 {
        return ThreadLobes::default();
    }
    let cos_half_phi = (0.5 * (1.0 + cos_phi_d)).max(0.0).sqrt();
    let theta_h = 0.5 * (wi.theta_rad + wr.theta_rad);
    let cos_theta_d = (0.5 * (wi.theta_rad - wr.theta_rad)).cos();
    let inv_cos2 = 1.0 / (cos_theta_d * cos_theta_d);
    let fresnel = fresnel_reflectance_unpolarized(optics.eta, cos_theta_d * cos_half_phi);
    let gs = gaussian(theta_h, optics.gamma_s_rad * optics.gamma_s_rad);
    let surface = fresnel * cos_half_phi * gs * inv_cos2;
    let gv = gaussian(theta_h, optics.gamma_v_rad * optics.gamma_v_rad);
    let shape = wi.transmittance * wr.transmittance * ((1.0 - optics.k_d) * gv + optics.k_d)
        / (wi.cos_theta + wr.cos_theta)
        * inv_cos2;
    ThreadLobes {
        surface,
        volume: optics.albedo.map(|a| a * shape),
    }
}

/// `f_s(ω_i, ω_r)` of eq. 5.11 for directions in the thread's frame (zero when either direction
/// lies along the tangent).
pub fn thread_bsdf(optics: &ThreadOptics, wi: &ThreadDir, wr: &ThreadDir) -> ThreadLobes {
    match cos_phi_d(wi, wr) {
        Some(cpd) => thread_bsdf_sides(
            optics,
            &ThreadSide::new(optics.eta, wi),
            &ThreadSide::new(optics.eta, wr),
            cpd,
        ),
        None => ThreadLobes::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linen() -> ThreadOptics {
        ThreadOptics {
            eta: 1.46,
            albedo: [0.06, 0.24, 0.30],
            k_d: 0.3,
            gamma_s_rad: 12f64.to_radians(),
            gamma_v_rad: 24f64.to_radians(),
        }
    }

    #[test]
    fn symmetric_in_directions_and_tangent_flip() {
        let o = linen();
        let a = ThreadDir::from_angles(0.4, 0.3);
        let b = ThreadDir::from_angles(-0.2, 2.1);
        let f = thread_bsdf(&o, &a, &b);
        let g = thread_bsdf(&o, &b, &a);
        let flip = |w: ThreadDir| ThreadDir { s: -w.s, ..w };
        let h = thread_bsdf(&o, &flip(a), &flip(b));
        for k in 0..3 {
            assert!((f.total()[k] - g.total()[k]).abs() < 1e-15 * f.total()[k].max(1.0));
            assert!((f.total()[k] - h.total()[k]).abs() < 1e-15 * f.total()[k].max(1.0));
        }
    }

    #[test]
    fn surface_lobe_peaks_on_the_specular_cone() {
        // At normal incidence the cone factor 1/cos²θ_d is even about θ_r = 0 and the lobe
        // peaks there; at oblique incidence that factor moves the peak slightly beyond −θ_i.
        let o = linen();
        let wi = ThreadDir::from_angles(0.0, 0.0);
        let at = |theta_r: f64| thread_bsdf(&o, &wi, &ThreadDir::from_angles(theta_r, 0.0)).surface;
        assert!(at(0.0) > at(0.05) && at(0.0) > at(-0.05));
        assert!((at(0.05) - at(-0.05)).abs() < 1e-15);
    }

    #[test]
    fn along_the_tangent_is_zero() {
        let o = linen();
        let t = ThreadDir {
            s: 1.0,
            c: 0.0,
            d: 0.0,
        };
        let w = ThreadDir::from_angles(0.1, 0.2);
        assert_eq!(thread_bsdf(&o, &t, &w), ThreadLobes::default());
    }
}
