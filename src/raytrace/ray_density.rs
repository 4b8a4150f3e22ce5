//! Radial ray densities of the silhouette ray grid (decisions RT-31, RT-40).
//!
//! The silhouette grid maps the index square onto the silhouette ring by ring: ring
//! `s = max(|ξ1|, |ξ2|)` ∈ [0, 1] lands at the normalised impact parameter `b = ρ / R(ψ)`. A
//! radial profile is the map's inverse `s(b)`: rings per unit of `b` are `N/2 · s′(b)`. The
//! `silhouette` layout uses `s(b) = (2/π) asin b` (rings refined towards the edge as
//! `1/√(1 − b²)`); the `silhouette-bows` layout adds to it a share of the rings in Gaussian bands
//! about the impact parameters whose rays feed the primary and secondary bows (the rainbow rays
//! of the equal-volume sphere, Descartes: `b₂ = √((4 − n²)/3)`, `b₃ = √((9 − n²)/8)`), so the
//! rays there are denser and elsewhere sparser, at the same ray count.
//!
//! Each ring's position `b(s)` and slope `b′(s)` are computed once per trace ([`RingTable`]):
//! the quadrature weight of a ray is the map's Jacobian, and every triangle carries the flux of
//! its own emitting-plane area, so the warp changes where rays are, not what a patch carries.

use crate::math::roots::newton_bracketed;
use std::f64::consts::{FRAC_1_SQRT_2, PI};

/// A Gaussian band of rings: its share of the rings, its centre and width in `b`.
#[derive(Debug, Clone, Copy)]
struct Band {
    share: f64,
    centre: f64,
    width: f64,
    /// erf at b = 0 and b = 1 of the standardised variable, for the normalisation over [0, 1].
    erf0: f64,
    erf1: f64,
}

impl Band {
    fn new(share: f64, centre: f64, width: f64) -> Self {
        let z = |b: f64| libm::erf((b - centre) / width * FRAC_1_SQRT_2);
        Band {
            share,
            centre,
            width,
            erf0: z(0.0),
            erf1: z(1.0),
        }
    }
    /// Share of the rings within `b` (0 at b = 0, `share` at b = 1).
    fn rings_within(&self, b: f64) -> f64 {
        let z = libm::erf((b - self.centre) / self.width * FRAC_1_SQRT_2);
        self.share * (z - self.erf0) / (self.erf1 - self.erf0)
    }
    /// Derivative of [`Band::rings_within`].
    fn density(&self, b: f64) -> f64 {
        let t = (b - self.centre) / self.width;
        let norm = 0.5 * (self.erf1 - self.erf0) * self.width * (2.0 * PI).sqrt();
        self.share * (-0.5 * t * t).exp() / norm
    }
}

/// Shares and widths (in `b`) of the bands of the `silhouette-bows` layout (decision RT-40):
/// the primary's band, then the secondary's.
pub const BOW_BANDS: [(f64, f64); 2] = [(0.30, 0.05), (0.20, 0.03)];

/// A radial profile `s(b)` of the silhouette grid: the edge-refined base `(2/π) asin b` with a
/// share `1 − Σ shares`, plus Gaussian bands normalised over [0, 1].
#[derive(Debug, Clone)]
pub struct RadialProfile {
    base: f64,
    bands: Vec<Band>,
}

impl RadialProfile {
    /// The profile of the `silhouette` layout: `s(b) = (2/π) asin b`, `b = sin(π s / 2)`.
    pub fn sine() -> Self {
        RadialProfile {
            base: 1.0,
            bands: Vec::new(),
        }
    }

    /// The profile of the `silhouette-bows` layout for a drop of relative index `n`: bands
    /// [`BOW_BANDS`] about the equal-volume sphere's primary and secondary rainbow rays.
    pub fn bows(n: f64) -> Self {
        let n2 = n * n;
        let centres = [
            ((4.0 - n2) / 3.0).max(0.0).sqrt(),
            ((9.0 - n2) / 8.0).sqrt(),
        ];
        let bands: Vec<Band> = BOW_BANDS
            .iter()
            .zip(centres)
            .map(|(&(share, width), c)| Band::new(share, c, width))
            .collect();
        RadialProfile {
            base: 1.0 - bands.iter().map(|b| b.share).sum::<f64>(),
            bands,
        }
    }

    /// The ring index `s(b)` ∈ [0, 1] of the normalised impact parameter `b` ∈ [0, 1].
    pub fn ring_of(&self, b: f64) -> f64 {
        self.base * 2.0 / PI * b.clamp(-1.0, 1.0).asin()
            + self.bands.iter().map(|k| k.rings_within(b)).sum::<f64>()
    }

    /// `s′(b)`, rings per unit of `b` over the ring count (infinite at b = 1).
    pub fn ring_density(&self, b: f64) -> f64 {
        self.base * 2.0 / PI / (1.0 - b * b).sqrt()
            + self.bands.iter().map(|k| k.density(b)).sum::<f64>()
    }

    /// The impact parameter `b(s)` of ring `s` ∈ [0, 1] and the slope `b′(s)`: `s(b)` inverted
    /// by Newton's method safeguarded by bisection ([`newton_bracketed`]; `s` is strictly
    /// increasing), to the last bits.
    pub fn impact_parameter(&self, s: f64) -> (f64, f64) {
        if s <= 0.0 {
            return (0.0, 1.0 / self.ring_density(0.0));
        }
        if s >= 1.0 {
            return (1.0, 0.0);
        }
        let b = newton_bracketed(
            |b| (self.ring_of(b) - s, self.ring_density(b)),
            (0.0, self.ring_of(0.0) - s),
            (1.0, self.ring_of(1.0) - s),
            |_| 1e-16,
        );
        (b, 1.0 / self.ring_density(b))
    }
}

/// The rings of an `N`-ray silhouette grid under a [`RadialProfile`]: ring `m` (s = m/(N − 1),
/// m = 0..N) at `b_m` with slope `b′_m`, computed once per trace.
#[derive(Debug, Clone)]
pub struct RingTable {
    rings: Vec<(f64, f64)>,
}

impl RingTable {
    /// The ring table of `rays` rays per side (at least 2) under `profile`.
    pub fn new(profile: &RadialProfile, rays: usize) -> Self {
        let last = (rays.max(2) - 1) as f64;
        RingTable {
            rings: (0..rays.max(2))
                .map(|m| profile.impact_parameter(m as f64 / last))
                .collect(),
        }
    }

    /// `(b, b′(s))` of ring `m`.
    pub fn ring(&self, m: usize) -> (f64, f64) {
        self.rings[m]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The profile runs from ring 0 at the centre to ring 1 at the edge, increases strictly, its
    /// inverse returns the impact parameter it came from and its slope is the reciprocal of the
    /// ring density (checked against a central difference).
    #[test]
    fn bows_profile_is_a_monotone_map_of_the_unit_interval() {
        let p = RadialProfile::bows(1.334);
        assert!(p.ring_of(0.0).abs() < 1e-15);
        assert!((p.ring_of(1.0) - 1.0).abs() < 1e-14);
        let mut prev = -1.0;
        for i in 0..=2000 {
            let b = i as f64 / 2000.0 * 0.999_999;
            let s = p.ring_of(b);
            assert!(s > prev, "not increasing at b = {b}");
            prev = s;
            let (back, slope) = p.impact_parameter(s);
            assert!((back - b).abs() < 1e-12, "b = {b}: inverse {back}");
            let h = 1e-6;
            if b > 2.0 * h && b < 0.99 {
                let fd = (p.ring_of(b + h) - p.ring_of(b - h)) / (2.0 * h);
                assert!((fd * slope - 1.0).abs() < 1e-6, "slope at b = {b}");
            }
        }
        // The bands hold their shares: at the primary's rainbow ray the rings per unit b
        // exceed the sine profile's more than twofold (2.4×).
        let b2 = ((4.0 - 1.334f64.powi(2)) / 3.0).sqrt();
        let ratio = p.ring_density(b2) / RadialProfile::sine().ring_density(b2);
        assert!(ratio > 2.0, "density ratio at b₂ {ratio}");
    }

    /// The sine profile is the `silhouette` layout's map `b = sin(π s / 2)`.
    #[test]
    fn sine_profile_is_the_silhouette_map() {
        let p = RadialProfile::sine();
        for i in 0..=100 {
            let s = i as f64 / 100.0;
            let (b, slope) = p.impact_parameter(s);
            assert!((b - (0.5 * PI * s).sin()).abs() < 1e-14, "s = {s}");
            assert!(
                (slope - 0.5 * PI * (0.5 * PI * s).cos()).abs() < 1e-9,
                "s = {s}"
            );
        }
    }
}
