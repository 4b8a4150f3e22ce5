//! Fabrics: two orthogonal thread families with their optics, coverages and tangent curves, and
//! the six measured fabrics of the thesis's Table 5.2 (optics) and Table E.1 (curves) as presets.
//!
//! Family 1 (the first row of each table: "Flat", "Dir 1", or "Both") runs along the cloth's
//! `+x` (warp), family 2 along `+y` (weft) (decision CLOTH-11). The readings of the tables'
//! damaged cells are decision CLOTH-10.

use super::curve::{CurveError, TangentCurve, TangentNode};
use super::thread::ThreadOptics;

/// One thread family of a fabric.
#[derive(Debug, Clone, PartialEq)]
pub struct ThreadFamily {
    /// Optics of the thread (η is the fabric's).
    pub optics: ThreadOptics,
    /// Area coverage `a_j` of eq. 5.12.
    pub coverage: f64,
    /// Tangent curve of Table E.1.
    pub curve: TangentCurve,
}

/// A woven fabric: family 1 along `+x`, family 2 along `+y`.
#[derive(Debug, Clone, PartialEq)]
pub struct Fabric {
    /// Preset name (or a user label).
    pub name: String,
    /// The two families.
    pub families: [ThreadFamily; 2],
}

/// The mirror and swap symmetries of a fabric's BRDF, derived from its parameters: a mirror
/// maps every tangent sample α of the family it crosses to −α, so it holds when that family's
/// curve is symmetric; the swap `x ↔ y` holds when both families are identical.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Symmetry {
    /// `f(Mω_i, Mω_r) = f(ω_i, ω_r)` for `M: x → −x` (φ → π − φ).
    pub mirror_x: bool,
    /// The same for `y → −y` (φ → −φ).
    pub mirror_y: bool,
    /// The same for `x ↔ y` (φ → π/2 − φ).
    pub swap_xy: bool,
}

impl Symmetry {
    /// The range `[lo, hi]` of φ_i (degrees) that the symmetries map every azimuth into.
    pub fn phi_i_domain_deg(&self) -> (f64, f64) {
        match (self.mirror_x, self.mirror_y, self.swap_xy) {
            (true, true, true) => (0.0, 45.0),
            (true, true, false) => (0.0, 90.0),
            (false, true, _) => (0.0, 180.0),
            (true, false, _) => (-90.0, 90.0),
            (false, false, _) => (-180.0, 180.0),
        }
    }

    /// Maps `(φ_i, φ_r)` (degrees) by the same symmetry operations so that φ_i lands in
    /// [`Symmetry::phi_i_domain_deg`]; the BRDF is unchanged by the map.
    pub fn reduce_deg(&self, phi_i_deg: f64, phi_r_deg: f64) -> (f64, f64) {
        let wrap = |p: f64| (p + 180.0).rem_euclid(360.0) - 180.0;
        let (mut pi, mut pr) = (wrap(phi_i_deg), wrap(phi_r_deg));
        if self.mirror_y && pi < 0.0 {
            (pi, pr) = (-pi, -pr);
        }
        if self.mirror_x && pi.abs() > 90.0 {
            (pi, pr) = (wrap(180.0 - pi), wrap(180.0 - pr));
        }
        if self.swap_xy && self.mirror_y && pi > 45.0 {
            (pi, pr) = (90.0 - pi, 90.0 - pr);
        }
        (wrap(pi), wrap(pr))
    }
}

/// Names of the presets, in the order of Table 5.2.
pub const PRESET_NAMES: [&str; 6] = [
    "linen_plain",
    "silk_crepe_de_chine",
    "polyester_satin_front",
    "polyester_satin_back",
    "silk_shot",
    "velvet",
];

/// Why a fabric is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FabricError {
    #[error("unknown fabric `{0}` (presets: {names})", names = PRESET_NAMES.join(", "))]
    Unknown(String),
    #[error("tangent curve of family {family}")]
    Curve {
        family: usize,
        #[source]
        source: CurveError,
    },
}

/// One family from table values (angles in degrees).
#[allow(clippy::too_many_arguments)]
fn family(
    eta: f64,
    albedo: [f64; 3],
    k_d: f64,
    gamma_s_deg: f64,
    gamma_v_deg: f64,
    coverage: f64,
    offsets_deg: &[f64],
    lengths: &[f64],
) -> ThreadFamily {
    ThreadFamily {
        optics: ThreadOptics {
            eta,
            albedo,
            k_d,
            gamma_s_rad: gamma_s_deg.to_radians(),
            gamma_v_rad: gamma_v_deg.to_radians(),
        },
        coverage,
        curve: TangentCurve::new(offsets_deg, lengths).expect("preset curves are valid"),
    }
}

fn scaled(base: [f64; 3], s: f64) -> [f64; 3] {
    base.map(|b| b * s)
}

/// The preset fabric `name` (see [`PRESET_NAMES`]).
pub fn preset(name: &str) -> Result<Fabric, FabricError> {
    let families = match name {
        "linen_plain" => {
            let a = scaled([0.20, 0.80, 1.00], 0.3);
            let f = family(1.46, a, 0.3, 12.0, 24.0, 0.33, &[-25.0, 25.0], &[1.0]);
            [f.clone(), f]
        }
        "silk_crepe_de_chine" => {
            let base = [1.00, 0.95, 0.05];
            let flat = [-35.0, -35.0, 35.0, 35.0];
            [
                family(
                    1.345,
                    scaled(base, 0.12),
                    0.2,
                    5.0,
                    10.0,
                    0.75,
                    &flat,
                    &[1.0; 3],
                ),
                family(
                    1.345,
                    scaled(base, 0.16),
                    0.3,
                    18.0,
                    32.0,
                    0.25,
                    &[0.0, 0.0],
                    &[1.0],
                ),
            ]
        }
        "polyester_satin_front" | "polyester_satin_back" => satin(name == "polyester_satin_front"),
        "silk_shot" => [
            family(
                1.345,
                scaled([0.10, 1.00, 0.40], 0.2),
                0.1,
                4.0,
                8.0,
                0.86,
                &[-25.0, -25.0, 25.0, 25.0],
                &[1.33, 2.67, 1.33],
            ),
            family(
                1.345,
                scaled([1.00, 0.00, 0.10], 0.6),
                0.1,
                5.0,
                10.0,
                0.14,
                &[0.0, 0.0],
                &[1.0],
            ),
        ],
        "velvet" => {
            let a = scaled([0.05, 0.02, 0.00], 0.3);
            [
                family(1.46, a, 0.1, 6.0, 12.0, 0.5, &[-90.0, -50.0], &[1.0]),
                family(
                    1.46,
                    a,
                    0.1,
                    6.0,
                    12.0,
                    0.5,
                    &[-90.0, -55.0, 55.0, 90.0],
                    &[0.5, 0.0, 0.5],
                ),
            ]
        }
        other => return Err(FabricError::Unknown(other.to_string())),
    };
    Ok(Fabric {
        name: name.to_string(),
        families,
    })
}

/// Polyester satin charmeuse: one optics row, front and back curves.
fn satin(front: bool) -> [ThreadFamily; 2] {
    let base = [1.00, 0.37, 0.30];
    let (flat_a, twisted_a) = (scaled(base, 0.035), scaled(base, 0.2));
    if front {
        [
            family(
                1.539,
                flat_a,
                0.1,
                2.5,
                5.0,
                0.9,
                &[-32.0, -32.0, -18.0, 0.0, 0.0, 18.0, 32.0, 32.0],
                &[1.33, 0.66, 2.0, 2.0, 2.0, 0.66, 1.33],
            ),
            family(1.539, twisted_a, 0.7, 30.0, 60.0, 0.1, &[0.0, 0.0], &[1.0]),
        ]
    } else {
        [
            family(
                1.539,
                flat_a,
                0.1,
                2.5,
                5.0,
                0.67,
                &[-30.0, -30.0, 30.0, 30.0, -5.0, -5.0, 5.0, 5.0],
                &[1.33, 1.33, 1.33, 0.0, 0.67, 0.67, 0.67],
            ),
            family(1.539, twisted_a, 0.7, 30.0, 60.0, 0.33, &[0.0, 0.0], &[3.0]),
        ]
    }
}

impl Fabric {
    /// The symmetries of this fabric's BRDF.
    pub fn symmetry(&self) -> Symmetry {
        let [f1, f2] = &self.families;
        Symmetry {
            mirror_x: f1.curve.is_symmetric(),
            mirror_y: f2.curve.is_symmetric(),
            swap_xy: f1 == f2,
        }
    }

    /// The tangent-sample quadrature of each family (ramps at ≤ `max_step_deg`).
    pub fn nodes(&self, max_step_deg: f64) -> [Vec<TangentNode>; 2] {
        [
            self.families[0].curve.nodes(max_step_deg),
            self.families[1].curve.nodes(max_step_deg),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_exist_with_their_symmetries() {
        for name in PRESET_NAMES {
            let f = preset(name).unwrap();
            let s = f.symmetry();
            assert!(s.mirror_y, "{name}");
            assert_eq!(s.mirror_x, name != "velvet", "{name}");
            assert_eq!(s.swap_xy, name == "linen_plain", "{name}");
        }
        assert!(preset("denim").is_err());
    }

    #[test]
    fn reduce_lands_in_the_domain() {
        for name in PRESET_NAMES {
            let s = preset(name).unwrap().symmetry();
            let (lo, hi) = s.phi_i_domain_deg();
            for k in 0..72 {
                let (pi, _) = s.reduce_deg(-180.0 + 5.0 * k as f64 + 0.3, 17.0);
                assert!(pi >= lo - 1e-9 && pi <= hi + 1e-9, "{name} {pi}");
            }
        }
    }
}
