//! Chief-ray geometry of the coaxial (double) cylinder in the azimuthal cross-section
//! (Tseng 2015 §5; Yan et al. 2015): exit azimuths Φ_p(h) and chord lengths of the unscattered
//! paths. A building block of the far-field fur profiles ([`super::farfield`]).
//!
//! Fiber radius 1, medulla radius `kappa`, cortex index `eta_c`, medulla index `eta_m`, ray
//! moving along +x hitting at signed offset `h` ∈ (−1, 1). Angles in radians. Φ follows
//! Marschner's convention: the outgoing direction measured from straight back towards the
//! source (Φ_R(h) = −2γ_i, Φ_TT(0) = π), wrapped to (−π, π].
//!
//! γ_i = asin h, γ_t = asin(h/η_c), γ_i2 = asin(h/(η_c κ)), γ_t2 = asin(h/(η_m κ)).
//! Zones: |h| < κη_m the chief ray can enter the medulla; κη_m ≤ |h| < κη_c it is totally
//! reflected by it; |h| ≥ κη_c it misses it.

use std::f64::consts::PI;

/// Unscattered path types (upper case: fiber surface, lower case: medulla surface).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Path {
    R,
    TT,
    TRT,
    TrT,
    TttT,
    TtrtT,
    TrRrT,
    TttRttT,
}

/// Coaxial fiber cross-section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoaxialFiber {
    pub kappa: f64,
    pub eta_c: f64,
    pub eta_m: f64,
}

fn wrap(phi: f64) -> f64 {
    let mut p = (phi + PI).rem_euclid(2.0 * PI) - PI;
    if p <= -PI {
        p += 2.0 * PI;
    }
    p
}

impl CoaxialFiber {
    /// Whether the chief ray of `path` exists at offset `h` (zone logic).
    pub fn exists(&self, path: Path, h: f64) -> bool {
        let a = h.abs();
        let hits_medulla = a < self.kappa * self.eta_c;
        let enters = a < self.kappa * self.eta_m;
        match path {
            Path::R => a <= 1.0,
            Path::TT | Path::TRT => !hits_medulla && a < 1.0,
            Path::TrT | Path::TrRrT => hits_medulla,
            Path::TttT | Path::TtrtT | Path::TttRttT => enters,
        }
    }

    /// Exit azimuth Φ_p(h) in closed form (sum of the deviations Γ of the path's events at the
    /// cuticle and medulla interfaces); `None` when the path does not exist.
    pub fn exit_azimuth(&self, path: Path, h: f64) -> Option<f64> {
        if !self.exists(path, h) {
            return None;
        }
        let gi = h.asin();
        let gt = (h / self.eta_c).asin();
        let gi2 = (h / (self.eta_c * self.kappa)).clamp(-1.0, 1.0).asin();
        let gt2 = (h / (self.eta_m * self.kappa)).clamp(-1.0, 1.0).asin();
        let phi = match path {
            Path::R => -2.0 * gi,
            Path::TT => PI + 2.0 * gt - 2.0 * gi,
            Path::TRT => 4.0 * gt - 2.0 * gi,
            Path::TrT => 2.0 * gt - 2.0 * gi - 2.0 * gi2,
            Path::TttT => PI + 2.0 * (gt - gi) + 2.0 * (gt2 - gi2),
            Path::TtrtT => 2.0 * (gt - gi) + 2.0 * (gt2 - gi2) + 2.0 * gt2,
            Path::TrRrT => 4.0 * gt - 2.0 * gi - 4.0 * gi2,
            Path::TttRttT => 4.0 * gt - 2.0 * gi + 4.0 * (gt2 - gi2),
        };
        Some(wrap(phi))
    }

    /// One cortex pass from the outer surface to the medulla, L_c (fiber radii).
    pub fn cortex_pass(&self, h: f64) -> f64 {
        let b = h / self.eta_c;
        (1.0 - b * b).sqrt() - (self.kappa * self.kappa - b * b).max(0.0).sqrt()
    }

    /// One medulla chord L_m = 2κ cos γ_t2 (fiber radii); 0 when the ray does not enter.
    pub fn medulla_chord(&self, h: f64) -> f64 {
        let b = h / self.eta_m;
        2.0 * (self.kappa * self.kappa - b * b).max(0.0).sqrt()
    }

    /// Impact parameter of the chief ray on the unit medulla circle, h' = h/(η_m κ) = sin γ_t2:
    /// the `h` axis of the azimuthal medulla table.
    pub fn medulla_offset(&self, h: f64) -> f64 {
        h / (self.eta_m * self.kappa)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FIBER: CoaxialFiber = CoaxialFiber {
        kappa: 0.5,
        eta_c: 1.43,
        eta_m: 1.35,
    };

    #[test]
    fn closed_form_reference_vectors() {
        // Independent evaluation of the closed forms (η_c = 1.43, η_m = 1.35, κ = 0.5).
        for (p, h, phi) in [
            (Path::TT, 0.8, 2.474424),
            (Path::TRT, 0.8, 0.520252),
            (Path::TttT, 0.25, 3.032108),
            (Path::TrT, 0.25, -0.868300),
            (Path::TtrtT, 0.25, 0.649331),
            (Path::TrRrT, 0.25, -1.231239),
            (Path::TttRttT, 0.25, 0.286392),
            (Path::TttT, -0.3, -3.010070),
        ] {
            let got = FIBER.exit_azimuth(p, h).unwrap();
            assert!((got - phi).abs() < 2e-6, "{p:?} h={h}: {got} vs {phi}");
        }
        // The reference lengths carry ~2e-5 rounding (e.g. L_m(0.25) = 2·sqrt(0.25 − (0.25/1.35)²)
        // = 0.928884 exactly, printed 0.92890).
        assert!((FIBER.cortex_pass(0.25) - 0.51615).abs() < 3e-5);
        assert!((FIBER.medulla_chord(0.25) - 0.92890).abs() < 3e-5);
        assert!((FIBER.cortex_pass(-0.3) - 0.52390).abs() < 3e-5);
        assert!((FIBER.medulla_chord(-0.3) - 0.89580).abs() < 3e-5);
        let b: f64 = 0.25 / 1.35;
        assert!((FIBER.medulla_chord(0.25) - 2.0 * (0.25 - b * b).sqrt()).abs() < 1e-15);
    }

    /// Independent 2-D ray trace through the two circles (vector Snell's law).
    fn trace(f: &CoaxialFiber, h: f64, events: &[(char, bool)]) -> f64 {
        // events: (surface 'O' outer / 'M' medulla, transmit?) in order.
        let mut p = [-(1.0 - h * h).sqrt(), h];
        let mut d = [1.0, 0.0];
        let mut first = true;
        for &(surface, transmit) in events {
            if !first {
                // Move to the next hit of `surface` along d from p.
                let r = if surface == 'O' { 1.0 } else { f.kappa };
                let b = p[0] * d[0] + p[1] * d[1];
                let c = p[0] * p[0] + p[1] * p[1] - r * r;
                let disc = b * b - c;
                assert!(disc >= 0.0, "the path misses the {surface} surface");
                let (t1, t2) = (-b - disc.sqrt(), -b + disc.sqrt());
                let t = if t1 > 1e-9 { t1 } else { t2 };
                assert!(t > 1e-9);
                p = [p[0] + t * d[0], p[1] + t * d[1]];
            }
            first = false;
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            let mut n = [p[0] / r, p[1] / r];
            if n[0] * d[0] + n[1] * d[1] > 0.0 {
                n = [-n[0], -n[1]];
            }
            let cos_i = -(n[0] * d[0] + n[1] * d[1]);
            if transmit {
                // n faces the incoming ray; pointing inwards means the ray is leaving the circle.
                let outside_going = n[0] * p[0] + n[1] * p[1] < 0.0;
                let (n1, n2) = match (surface, outside_going) {
                    ('O', false) => (1.0, f.eta_c),
                    ('O', true) => (f.eta_c, 1.0),
                    ('M', false) => (f.eta_c, f.eta_m),
                    _ => (f.eta_m, f.eta_c),
                };
                let eta = n1 / n2;
                let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
                assert!(k >= 0.0, "TIR on a transmission event");
                let cos_t = k.sqrt();
                d = [
                    eta * d[0] + (eta * cos_i - cos_t) * n[0],
                    eta * d[1] + (eta * cos_i - cos_t) * n[1],
                ];
            } else {
                d = [d[0] + 2.0 * cos_i * n[0], d[1] + 2.0 * cos_i * n[1]];
            }
        }
        wrap(d[1].atan2(d[0]) - PI)
    }

    #[test]
    fn closed_forms_match_an_independent_ray_trace() {
        use Path::*;
        let seq = |p: Path| -> Vec<(char, bool)> {
            match p {
                R => vec![('O', false)],
                TT => vec![('O', true), ('O', true)],
                TRT => vec![('O', true), ('O', false), ('O', true)],
                TrT => vec![('O', true), ('M', false), ('O', true)],
                TttT => vec![('O', true), ('M', true), ('M', true), ('O', true)],
                TtrtT => vec![
                    ('O', true),
                    ('M', true),
                    ('M', false),
                    ('M', true),
                    ('O', true),
                ],
                TrRrT => vec![
                    ('O', true),
                    ('M', false),
                    ('O', false),
                    ('M', false),
                    ('O', true),
                ],
                TttRttT => vec![
                    ('O', true),
                    ('M', true),
                    ('M', true),
                    ('O', false),
                    ('M', true),
                    ('M', true),
                    ('O', true),
                ],
            }
        };
        for fiber in [
            FIBER,
            CoaxialFiber {
                kappa: 0.69,
                eta_c: 1.55,
                eta_m: 1.37,
            },
        ] {
            let mut checked = 0;
            for i in 0..41 {
                let h = -0.975 + 0.04875 * i as f64;
                for p in [R, TT, TRT, TrT, TttT, TtrtT, TrRrT, TttRttT] {
                    let Some(phi) = fiber.exit_azimuth(p, h) else {
                        continue;
                    };
                    let traced = trace(&fiber, h, &seq(p));
                    let diff = wrap(phi - traced).abs();
                    assert!(diff < 1e-9, "{p:?} h={h}: closed {phi} traced {traced}");
                    checked += 1;
                }
            }
            assert!(checked > 150);
        }
    }

    #[test]
    fn zones_follow_the_kappa_eta_products() {
        // Cat (κη_m ≥ 1): no TT anywhere. Raccoon: TT only for |h| > κη_c = 0.726.
        let cat = CoaxialFiber {
            kappa: 0.85,
            eta_c: 1.43,
            eta_m: 1.35,
        };
        assert!((0..100).all(|i| !cat.exists(Path::TT, -0.99 + 0.02 * i as f64)));
        let raccoon = CoaxialFiber {
            kappa: 0.59,
            eta_c: 1.23,
            eta_m: 1.23,
        };
        assert!(!raccoon.exists(Path::TT, 0.72) && raccoon.exists(Path::TT, 0.73));
        // η_m = η_c: no total-reflection zone, every medulla hit can transmit.
        assert!(raccoon.exists(Path::TttT, 0.72));
    }
}
