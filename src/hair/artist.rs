//! The artist-friendly hair model (Sadeghi, Pritchett, Jensen, Tamstorf 2010; thesis §4.6) and
//! its Dual Scattering averages with the single-scalar normalisation of thesis eq. 4.17.
//!
//! ```text
//! f'_X(θ_i, θ_o, φ) = C_X I_X g'(θ_h − α_X, β_X²) N'_X(|φ|) / cos²θ_d      (4.15, 4.16)
//! N'_R = cos(φ/2),  N'_TT = g'(π − φ, γ_TT²),
//! N'_TRT = cos(φ/2) + I_g ⟨g'(G − φ, γ_g²)⟩_{G ~ U[G_min, G_max]}              (4.10–4.14)
//! ```
//!
//! with unit-height Gaussians `g'` ([`super::longitudinal::gaussian_unit_height`]), `φ ∈ [0, π]`
//! folded (decision DS-21 in `docs/decisions.md`), `cos²θ_d ≥ 1e-3` (DS-18).
//!
//! Eq. 4.17 (DS-4) divides `f'_s` by its integral over the full sphere of outgoing directions,
//! under the same measure as the DS averages (`cos²θ_o dθ_o dφ`, see [`super::dual`]), glints
//! included. The normaliser is one **scalar over the channels** (the maximum over RGB, so the
//! hair colour is kept) taken **per light inclination** `θ_i`
//! ([`ArtistNormalisation::PerInclination`], the default): the brightest channel then scatters
//! exactly the light it receives at every `θ_i` and every channel satisfies `ā_f + ā_b ≤ 1`, so
//! multiple scattering neither vanishes nor blows up (thesis Fig. 4.12).
//! [`ArtistNormalisation::NormalIncidence`] keeps the earlier single constant `K` taken at
//! `θ_i = 0`, for which the unclamped `ā_f + ā_b` exceeds 1 toward grazing light (2.2 with the
//! default parameters). The stored `N^G_X` include `C_X I_X / K(θ_i)` so that
//! `f_s^scatter = Σ_X M'^G_X N^G_X` uses `f'^norm` as the thesis requires;
//! [`bare_forward_average`] gives the bare constants.

use super::dual::{DualScattering, from_lobe_energies};
use super::longitudinal::{gaussian_unit_height, lobe_energy};
use crate::math::quadrature::gauss_legendre;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// How eq. 4.17 normalises `f'_s` (decision DS-4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ArtistNormalisation {
    /// One scalar per light inclination: `K(θ_i) = max_RGB ∫∫ f'_s(θ_i, θ_o, φ) cos²θ_o dθ_o dφ`.
    #[default]
    PerInclination,
    /// One scalar for all inclinations, `K = K(0)` (energy conserving at normal incidence only).
    NormalIncidence,
}

impl ArtistNormalisation {
    /// The name used in parameter files, on the command line and in table headers.
    pub fn name(self) -> &'static str {
        match self {
            ArtistNormalisation::PerInclination => "per-inclination",
            ArtistNormalisation::NormalIncidence => "normal-incidence",
        }
    }
}

/// Artist-friendly parameters (angles in degrees as in the artists' UI). Defaults: the public
/// Arnold "aiMarschner" sample shader of this model (Sadeghi 2012 gives no numeric defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArtistParams {
    pub colour_r: [f64; 3],
    pub intensity_r: f64,
    pub shift_r_deg: f64,
    pub width_r_deg: f64,
    pub colour_tt: [f64; 3],
    pub intensity_tt: f64,
    pub shift_tt_deg: f64,
    pub width_tt_deg: f64,
    /// Azimuthal width γ_TT of the transmission lobe.
    pub azimuthal_width_tt_deg: f64,
    pub colour_trt: [f64; 3],
    pub intensity_trt: f64,
    pub shift_trt_deg: f64,
    pub width_trt_deg: f64,
    /// Glint intensity relative to the secondary highlight, I_g.
    pub glint_intensity: f64,
    /// Glint azimuthal width γ_g.
    pub glint_width_deg: f64,
    /// Range of the per-strand random glint half-angle G_angle, averaged uniformly (DS-14).
    pub glint_angle_deg: [f64; 2],
    /// Colour of the glints (linear RGB). `None` (the default): the glints share `colour_trt`,
    /// as in thesis eqs. 4.13–4.15; a colour makes the glint part of the TRT lobe
    /// `colour_glint · intensity_trt · glint_intensity` (decision DS-15).
    pub colour_glint: Option<[f64; 3]>,
    /// Normalisation of eq. 4.17 (`per-inclination` or `normal-incidence`).
    pub normalisation: ArtistNormalisation,
}

impl Default for ArtistParams {
    fn default() -> Self {
        ArtistParams {
            colour_r: [1.0, 1.0, 0.7],
            intensity_r: 1.0,
            shift_r_deg: -8.0,
            width_r_deg: 8.0,
            colour_tt: [1.0, 0.6, 0.28],
            intensity_tt: 4.0,
            shift_tt_deg: 4.0,
            width_tt_deg: 4.0,
            azimuthal_width_tt_deg: 10.0,
            colour_trt: [1.0, 0.62, 0.2],
            intensity_trt: 0.5,
            shift_trt_deg: 5.0,
            width_trt_deg: 15.0,
            glint_intensity: 2.5,
            glint_width_deg: 10.0,
            glint_angle_deg: [30.0, 45.0],
            colour_glint: None,
            normalisation: ArtistNormalisation::PerInclination,
        }
    }
}

impl ArtistParams {
    /// Range checks; returns `(key, message)` on failure.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (k, v) in [
            ("width_r_deg", self.width_r_deg),
            ("width_tt_deg", self.width_tt_deg),
            ("width_trt_deg", self.width_trt_deg),
            ("azimuthal_width_tt_deg", self.azimuthal_width_tt_deg),
            ("glint_width_deg", self.glint_width_deg),
        ] {
            if !(0.5..=60.0).contains(&v) {
                return Err((k, format!("{v} is outside 0.5–60°")));
            }
        }
        for (k, v) in [
            ("shift_r_deg", self.shift_r_deg),
            ("shift_tt_deg", self.shift_tt_deg),
            ("shift_trt_deg", self.shift_trt_deg),
        ] {
            if !(-30.0..=30.0).contains(&v) {
                return Err((k, format!("{v} is outside −30–30°")));
            }
        }
        for (k, c) in [
            ("colour_r", self.colour_r),
            ("colour_tt", self.colour_tt),
            ("colour_trt", self.colour_trt),
            ("colour_glint", self.colour_glint.unwrap_or(self.colour_trt)),
        ] {
            if c.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err((k, "colours must be finite and ≥ 0 (linear RGB)".into()));
            }
        }
        for (k, v) in [
            ("intensity_r", self.intensity_r),
            ("intensity_tt", self.intensity_tt),
            ("intensity_trt", self.intensity_trt),
            ("glint_intensity", self.glint_intensity),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err((k, format!("{v} must be finite and ≥ 0")));
            }
        }
        let [g0, g1] = self.glint_angle_deg;
        if !(0.0..=90.0).contains(&g0) || !(g0..=90.0).contains(&g1) {
            return Err(("glint_angle_deg", "needs 0 ≤ min ≤ max ≤ 90°".into()));
        }
        if self.energy_weights().iter().all(|&w| w <= 0.0) {
            return Err(("intensity_r", "all lobes are black".into()));
        }
        Ok(())
    }

    fn shifts(&self) -> [f64; 3] {
        [self.shift_r_deg, self.shift_tt_deg, self.shift_trt_deg].map(f64::to_radians)
    }
    fn widths(&self) -> [f64; 3] {
        [self.width_r_deg, self.width_tt_deg, self.width_trt_deg].map(f64::to_radians)
    }
    fn weights(&self, c: usize) -> [f64; 3] {
        [
            self.colour_r[c] * self.intensity_r,
            self.colour_tt[c] * self.intensity_tt,
            self.colour_trt[c] * self.intensity_trt,
        ]
    }
    fn energy_weights(&self) -> [f64; 3] {
        std::array::from_fn(|c| self.weights(c).iter().sum())
    }

    /// Azimuthal function `N'_X(φ)`, `φ` folded into `[0, π]`.
    pub fn azimuthal(&self, lobe: usize, phi: f64) -> f64 {
        let phi = super::fiber::wrap_angle(phi).abs();
        match lobe {
            0 => (0.5 * phi).cos(),
            1 => gaussian_unit_height(PI - phi, self.azimuthal_width_tt_deg.to_radians().powi(2)),
            _ => (0.5 * phi).cos() + self.glints(phi),
        }
    }

    /// The glint part of `N'_TRT(φ)`: `I_g` times two unit-height peaks at ±G_angle (G_angle
    /// averaged over its range, DS-14), `φ` folded into `[0, π]`.
    pub fn glints(&self, phi: f64) -> f64 {
        let phi = super::fiber::wrap_angle(phi).abs();
        let v = self.glint_width_deg.to_radians().powi(2);
        let [g0, g1] = self.glint_angle_deg.map(f64::to_radians);
        let glint = if g1 - g0 < 1e-12 {
            gaussian_unit_height(g0 - phi, v)
        } else {
            let (x, w) = gauss_legendre(16);
            x.iter()
                .zip(&w)
                .map(|(xi, wi)| {
                    let g = g0 + 0.5 * (g1 - g0) * (xi + 1.0);
                    0.5 * wi * gaussian_unit_height(g - phi, v)
                })
                .sum()
        };
        self.glint_intensity * glint
    }

    /// `(∫_{|φ|<π/2} N'_X dφ, ∫_{|φ|≥π/2} N'_X dφ)` over both signs of φ, by composite
    /// Gauss–Legendre with panels ≤ a quarter of the narrowest azimuthal width.
    pub fn azimuthal_hemispheres(&self, lobe: usize) -> (f64, f64) {
        self.hemispheres_of(|phi| self.azimuthal(lobe, phi))
    }

    /// The same integrals of the glint part alone ([`Self::glints`]).
    pub fn glint_hemispheres(&self) -> (f64, f64) {
        self.hemispheres_of(|phi| self.glints(phi))
    }

    fn hemispheres_of(&self, azimuthal: impl Fn(f64) -> f64) -> (f64, f64) {
        let narrow = self
            .azimuthal_width_tt_deg
            .min(self.glint_width_deg)
            .to_radians();
        let (x, w) = gauss_legendre(8);
        let n = ((FRAC_PI_2 / (0.25 * narrow)).ceil() as usize).max(4);
        let integrate = |a: f64| {
            let step = FRAC_PI_2 / n as f64;
            let mut s = 0.0;
            for k in 0..n {
                let lo = a + step * k as f64;
                for (xi, wi) in x.iter().zip(&w) {
                    s += 0.5 * step * wi * azimuthal(lo + 0.5 * step * (xi + 1.0));
                }
            }
            2.0 * s
        };
        (integrate(0.0), integrate(FRAC_PI_2))
    }
}

/// The bare forward average `N'^G_X = (2/π) ∫_{π/2}^{π} N'_X dφ` (thesis 4.35), without colour,
/// intensity or normalisation.
pub fn bare_forward_average(params: &ArtistParams, lobe: usize) -> f64 {
    params.azimuthal_hemispheres(lobe).1 / PI
}

/// Longitudinal energy `∫ g'(θ_h − α, β²) cos²θ_o/cos²θ_d dθ_o` of each lobe at `θ_i`.
fn longitudinal_energies(params: &ArtistParams, theta_i: f64) -> [f64; 3] {
    let a = params.shifts();
    let b = params.widths();
    std::array::from_fn(|x| {
        lobe_energy(theta_i, b[x], |t_h| {
            gaussian_unit_height(t_h - a[x], b[x] * b[x])
        })
    })
}

/// Colour-weighted azimuthal hemisphere integrals `C_X I_X ∫ N'_X` of each lobe in channel
/// `c`, from the bare integrals `hemi` of each lobe and `glint` of the glints alone: the glint
/// part of TRT takes `colour_glint` when it is set.
fn weighted_hemispheres(
    params: &ArtistParams,
    hemi: &[(f64, f64); 3],
    glint: (f64, f64),
    c: usize,
) -> [(f64, f64); 3] {
    let w = params.weights(c);
    let mut out: [(f64, f64); 3] = std::array::from_fn(|x| (w[x] * hemi[x].0, w[x] * hemi[x].1));
    if let Some(cg) = params.colour_glint {
        let (ct, i) = (params.colour_trt[c], params.intensity_trt);
        out[2] = (
            i * (ct * (hemi[2].0 - glint.0) + cg[c] * glint.0),
            i * (ct * (hemi[2].1 - glint.1) + cg[c] * glint.1),
        );
    }
    out
}

/// Largest energy over the RGB channels of `f'_s` given the lobe longitudinal energies `l` and
/// the colour-weighted hemisphere integrals of each channel.
fn brightest_channel_energy(l: &[f64; 3], weighted: &[[(f64, f64); 3]; 3]) -> f64 {
    weighted
        .iter()
        .map(|wh| (0..3).map(|x| l[x] * (wh[x].0 + wh[x].1)).sum::<f64>())
        .fold(0.0, f64::max)
}

/// The scalar normaliser of eq. 4.17 (decision DS-4) at light inclination `theta_i`: the largest
/// energy over RGB of `f'_s` at that inclination.
pub fn normalisation_at(params: &ArtistParams, theta_i: f64) -> f64 {
    let l = longitudinal_energies(params, theta_i);
    let hemi: [(f64, f64); 3] = std::array::from_fn(|x| params.azimuthal_hemispheres(x));
    let glint = params.glint_hemispheres();
    let weighted = std::array::from_fn(|c| weighted_hemispheres(params, &hemi, glint, c));
    brightest_channel_energy(&l, &weighted)
}

/// The normaliser at normal incidence, `K(0)` (the constant of
/// [`ArtistNormalisation::NormalIncidence`]).
pub fn normalisation(params: &ArtistParams) -> f64 {
    normalisation_at(params, 0.0)
}

/// Precomputed pieces of the artist model that do not depend on `θ_i`.
#[derive(Debug, Clone)]
pub struct ArtistModel {
    pub params: ArtistParams,
    /// `K(0)`, the normaliser at normal incidence.
    pub k: f64,
    /// Colour-weighted hemisphere integrals per channel ([`weighted_hemispheres`]).
    weighted: [[(f64, f64); 3]; 3],
}

impl ArtistModel {
    pub fn new(params: ArtistParams) -> Self {
        let k = normalisation(&params);
        let hemi = std::array::from_fn(|x| params.azimuthal_hemispheres(x));
        let glint = params.glint_hemispheres();
        let weighted = std::array::from_fn(|c| weighted_hemispheres(&params, &hemi, glint, c));
        ArtistModel {
            params,
            k,
            weighted,
        }
    }

    /// The normaliser used at `θ_i` given the lobe longitudinal energies `l` there.
    fn k_at(&self, l: &[f64; 3]) -> f64 {
        let k = match self.params.normalisation {
            ArtistNormalisation::PerInclination => brightest_channel_energy(l, &self.weighted),
            ArtistNormalisation::NormalIncidence => self.k,
        };
        // All lobes black at this inclination: nothing to normalise (every energy is 0).
        if k > 0.0 { k } else { 1.0 }
    }

    /// DS quantities per colour channel at `θ_i`, plus the normalised lobe energies
    /// `[R, TT, TRT]` per channel.
    pub fn dual_scattering(
        &self,
        theta_i: f64,
        d_b: f64,
        clamp: f64,
    ) -> [(DualScattering, [f64; 3]); 3] {
        let l = longitudinal_energies(&self.params, theta_i);
        let alpha = self.params.shifts();
        let beta = self.params.widths();
        let k = self.k_at(&l);
        std::array::from_fn(|c| {
            let wh = &self.weighted[c];
            let eb: [f64; 3] = std::array::from_fn(|x| l[x] * wh[x].0 / k);
            let ef: [f64; 3] = std::array::from_fn(|x| l[x] * wh[x].1 / k);
            let ng: [f64; 3] = std::array::from_fn(|x| wh[x].1 / (k * PI));
            let ds = from_lobe_energies(&eb, &ef, &alpha, &beta, ng, d_b, clamp);
            (ds, std::array::from_fn(|x| eb[x] + ef[x]))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn erf(x: f64) -> f64 {
        libm::erf(x)
    }

    #[test]
    fn forward_averages_match_closed_forms() {
        let mut p = ArtistParams {
            glint_intensity: 0.0,
            ..Default::default()
        };
        // Cosine lobe: (4/π)(1 − 1/√2) = 0.3729232.
        assert!((bare_forward_average(&p, 0) - 0.3729232).abs() < 1e-7);
        assert!((bare_forward_average(&p, 2) - 0.3729232).abs() < 1e-7);
        for (g, want) in [
            (5.0, 0.069629),
            (10.0, 0.139257),
            (15.0, 0.208886),
            (20.0, 0.278512),
            (30.0, 0.416643),
        ] {
            p.azimuthal_width_tt_deg = g;
            assert!(
                (bare_forward_average(&p, 1) - want).abs() < 2e-6,
                "γ={g}: {}",
                bare_forward_average(&p, 1)
            );
            // And the closed form (2/π) γ sqrt(π/2) erf(π/(2√2 γ)) of the Gaussian N'_TT.
            let gr = f64::to_radians(g);
            let cf = 2.0 / PI * gr * (PI / 2.0).sqrt() * erf(PI / (2.0 * 2f64.sqrt() * gr));
            assert!((bare_forward_average(&p, 1) - cf).abs() < 1e-9);
        }
        // Glint contribution per unit I_g at a fixed angle (independent 2-digit references).
        for (gang, gw, want) in [
            (45.0, 25.0, 2.5e-2),
            (35.0, 25.0, 9.7e-3),
            (45.0, 15.0, 5.6e-4),
        ] {
            let base = ArtistParams {
                glint_angle_deg: [gang, gang],
                glint_width_deg: gw,
                glint_intensity: 0.0,
                ..Default::default()
            };
            let with = ArtistParams {
                glint_intensity: 1.0,
                ..base.clone()
            };
            let d = bare_forward_average(&with, 2) - bare_forward_average(&base, 2);
            assert!((d - want).abs() < 0.05 * want, "G={gang} γ={gw}: {d}");
        }
    }

    #[test]
    fn normalised_model_conserves_energy_for_the_brightest_channel_at_normal_incidence() {
        let m = ArtistModel::new(ArtistParams::default());
        let ds = m.dual_scattering(0.0, 0.7, 1.0);
        let totals: Vec<f64> = ds.iter().map(|(_, e)| e.iter().sum()).collect();
        let max = totals.iter().cloned().fold(0.0, f64::max);
        assert!((max - 1.0).abs() < 1e-12, "{totals:?}");
        // Colour is kept: red > green > blue for the default brown-ish colours.
        assert!(totals[0] > totals[1] && totals[1] > totals[2]);
        // N^G_X carries the lobe colour C_X: G/R ratio of TT is the C_TT ratio.
        let r = ds[1].0.n_g_tt / ds[0].0.n_g_tt;
        assert!((r - 0.6).abs() < 1e-12);
        // Scaling every intensity leaves the normalised model unchanged (scalar K).
        let mut p = ArtistParams::default();
        p.intensity_r *= 3.0;
        p.intensity_tt *= 3.0;
        p.intensity_trt *= 3.0;
        let ds3 = ArtistModel::new(p).dual_scattering(0.3, 0.7, 1.0);
        let ds1 = m.dual_scattering(0.3, 0.7, 1.0);
        for c in 0..3 {
            let (a, b) = (ds1[c].0.to_array(), ds3[c].0.to_array());
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-12);
            }
        }
    }

    /// Glints of the TRT colour are the thesis's model exactly; glints of another colour change
    /// only the glint part of TRT: with red glints, the green and blue TRT hemisphere integrals
    /// are those of the model without glints.
    #[test]
    fn glint_colour_changes_only_the_glints() {
        let p = ArtistParams::default();
        let same = ArtistParams {
            colour_glint: Some(p.colour_trt),
            ..p.clone()
        };
        for theta in [-0.7, 0.0, 0.4] {
            let (a, b) = (
                ArtistModel::new(p.clone()).dual_scattering(theta, 0.7, 0.99),
                ArtistModel::new(same.clone()).dual_scattering(theta, 0.7, 0.99),
            );
            for c in 0..3 {
                for (x, y) in a[c].0.to_array().iter().zip(b[c].0.to_array()) {
                    assert!((x - y).abs() < 1e-12, "θ={theta} c={c}: {x} vs {y}");
                }
            }
        }
        let red = ArtistParams {
            colour_glint: Some([1.0, 0.0, 0.0]),
            ..p.clone()
        };
        let no_glints = ArtistParams {
            glint_intensity: 0.0,
            ..p.clone()
        };
        let hemi = |q: &ArtistParams| -> [(f64, f64); 3] {
            std::array::from_fn(|x| q.azimuthal_hemispheres(x))
        };
        for c in 1..3 {
            let with = weighted_hemispheres(&red, &hemi(&red), red.glint_hemispheres(), c)[2];
            let without = weighted_hemispheres(&no_glints, &hemi(&no_glints), (0.0, 0.0), c)[2];
            assert!(
                (with.0 - without.0).abs() < 1e-12 * without.0,
                "{with:?} {without:?}"
            );
            assert!((with.1 - without.1).abs() < 1e-12 * without.1.max(1e-300));
        }
        let r_with = weighted_hemispheres(&red, &hemi(&red), red.glint_hemispheres(), 0)[2];
        let r_without = weighted_hemispheres(&no_glints, &hemi(&no_glints), (0.0, 0.0), 0)[2];
        assert!(r_with.0 > r_without.0, "red glints add red backward energy");
    }

    /// Default and five random parameter sets (fixed seed).
    fn parameter_sets() -> Vec<ArtistParams> {
        let mut rng = crate::math::rng::SplitMix64::new(0x5ade_2012);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_f64();
        let mut sets = vec![ArtistParams::default()];
        for set in 0..5 {
            let mut colour = || [u(0.05, 1.0), u(0.05, 1.0), u(0.05, 1.0)];
            let (c_r, c_tt, c_trt) = (colour(), colour(), colour());
            let g0 = u(20.0, 40.0);
            sets.push(ArtistParams {
                colour_r: c_r,
                intensity_r: u(0.1, 5.0),
                shift_r_deg: u(-12.0, -2.0),
                width_r_deg: u(2.0, 20.0),
                colour_tt: c_tt,
                intensity_tt: u(0.1, 8.0),
                shift_tt_deg: u(0.0, 8.0),
                width_tt_deg: u(1.0, 15.0),
                azimuthal_width_tt_deg: u(5.0, 40.0),
                colour_trt: c_trt,
                intensity_trt: u(0.1, 5.0),
                shift_trt_deg: u(2.0, 15.0),
                width_trt_deg: u(4.0, 30.0),
                glint_intensity: u(0.0, 5.0),
                glint_width_deg: u(5.0, 25.0),
                glint_angle_deg: [g0, g0 + u(0.0, 15.0)],
                // Two sets with glints of their own colour.
                colour_glint: (set >= 3).then(|| [u(0.05, 1.0), u(0.05, 1.0), u(0.05, 1.0)]),
                normalisation: ArtistNormalisation::PerInclination,
            });
        }
        sets
    }

    /// Largest and smallest over channels of the unclamped `ā_f + ā_b`, per θ_i (1° steps).
    fn albedo_extremes(p: &ArtistParams) -> Vec<(f64, f64, f64)> {
        let m = ArtistModel::new(p.clone());
        (0..=180)
            .map(|k| {
                let theta = f64::to_radians(-90.0 + k as f64);
                let ds = m.dual_scattering(theta, 0.7, f64::INFINITY);
                let sums: Vec<f64> = ds.iter().map(|(d, _)| d.a_f + d.a_b).collect();
                let max = sums.iter().cloned().fold(f64::MIN, f64::max);
                let min = sums.iter().cloned().fold(f64::MAX, f64::min);
                (theta, max, min)
            })
            .collect()
    }

    /// Thesis eq. 4.17 / Fig. 4.12: with the per-inclination normaliser, `ā_f + ā_b ≤ 1` for
    /// every θ_i and channel, the brightest channel is exactly 1 (no vanishing), at the default
    /// and five random parameter sets; the normal-incidence constant exceeds 1 at grazing light.
    #[test]
    fn per_inclination_normalisation_conserves_energy_at_every_inclination() {
        let mut worst_new: f64 = 0.0;
        let mut worst_old: f64 = 0.0;
        for (i, p) in parameter_sets().into_iter().enumerate() {
            p.validate().unwrap();
            let new = albedo_extremes(&p);
            let old = albedo_extremes(&ArtistParams {
                normalisation: ArtistNormalisation::NormalIncidence,
                ..p.clone()
            });
            let max_new = new.iter().map(|e| e.1).fold(0.0, f64::max);
            let max_old = old.iter().map(|e| e.1).fold(0.0, f64::max);
            println!(
                "set {i}: max over θ, channels of ā_f + ā_b: normal-incidence {max_old:.4} → per-inclination {max_new:.4}"
            );
            for (theta, max, min) in &new {
                assert!(*max <= 1.0 + 1e-12, "set {i} θ={theta}: {max}");
                assert!(
                    (max - 1.0).abs() < 1e-12,
                    "set {i} θ={theta}: brightest {max}"
                );
                assert!(*min > 0.0, "set {i} θ={theta}: a channel vanished");
            }
            worst_new = worst_new.max(max_new);
            worst_old = worst_old.max(max_old);
        }
        println!("all sets: normal-incidence {worst_old:.4} → per-inclination {worst_new:.4}");
        assert!(
            worst_old > 1.2,
            "the normal-incidence variant no longer exceeds 1: {worst_old}"
        );
        // The normal-incidence variant is unchanged at θ_i = 0.
        let p = ArtistParams::default();
        let a = ArtistModel::new(p.clone()).dual_scattering(0.0, 0.7, 1.0);
        let b = ArtistModel::new(ArtistParams {
            normalisation: ArtistNormalisation::NormalIncidence,
            ..p
        })
        .dual_scattering(0.0, 0.7, 1.0);
        for c in 0..3 {
            assert_eq!(a[c].0.to_array(), b[c].0.to_array());
        }
    }
}
