//! The fabric BRDF of Sadeghi et al. 2013 (thesis §5.6, eqs. 5.12–5.20) in the cloth's frame.
//!
//! Cloth frame: normal `n = +z`, family 1 (warp) along `+x`, family 2 (weft) along `+y`;
//! θ from the normal, φ from `+x` toward `+y`, radians. `ω_i` points toward the light, `ω_r`
//! toward the viewer, both away from the surface.
//!
//! A tangent sample of family `j` (in-plane direction `u_j`) at elevation α has the frame
//! `t = cos α u_j + sin α n`, `n_t = −sin α u_j + cos α n`, `b = t × n_t = u_j × n`
//! (decision CLOTH-9). With the arc-length mean `⟨·⟩_j` over family `j`'s curve:
//!
//! ```text
//! K(ω_i, ω_r) = Σ_j a_j ⟨f_s M P cos θ_i⟩_j / (⟨P⟩_1 + ⟨P⟩_2)              (5.12), (5.20)
//! f(ω_i, ω_r) = K / (n·ω_i)          (0 unless n·ω_i > 0 and n·ω_r > 0)
//! M = (1 − u(|φ_d|)) M_i M_r + u(|φ_d|) min(M_i, M_r),  M_x = max(cos φ_x, 0)   (5.14)–(5.16)
//! P = (1 − u(|ψ_d|)) P_i P_r + u(|ψ_d|) min(P_i, P_r),  P_x = max(cos ψ_x, 0)   (5.18)–(5.19)
//! u(x) = exp(−x²/2σ_u²), σ_u = 20°
//! ```
//!
//! φ is the azimuth about `t` from the sample's own normal `n_t` and ψ = atan2(ω·t, ω·n_t)
//! (decision CLOTH-4); θ_i in `cos θ_i` is the thread-frame inclination (CLOTH-5); the
//! normalisation is the thesis's `1/ΣP` over both families with `a_j` on top (CLOTH-6). `f` is
//! in sr⁻¹. It is **not reciprocal** (the thread-frame `cos θ_i` over `n·ω_i`), not isotropic,
//! and not energy conserving near grazing incidence: the directional albedo grows like
//! `1/cos θ_i` and exceeds 1 above θ_i ≈ 84–88° for every preset (decision CLOTH-7).

use super::curve::TangentNode;
use super::fabric::Fabric;
use super::thread::{ThreadDir, ThreadSide, cos_phi_d, thread_bsdf_sides};
use crate::hair::longitudinal::gaussian_unit_height;
use crate::math::vec3::dot;
use std::f64::consts::PI;

/// Evaluation options of the model (defaults: the decisions of `docs/decisions.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelOptions {
    /// Largest step in α of the tangent-curve quadrature on ramps, degrees.
    pub ramp_step_deg: f64,
    /// Width σ_u of the correlation Gaussian `u` of eqs. 5.16 and 5.19, degrees.
    pub u_sigma_deg: f64,
    /// `Some(T)`: the thesis's `T` equidistant tangent samples per family (eq. 5.13) instead of
    /// the arc-length quadrature (`None`, the limit `T → ∞`).
    pub tangent_samples: Option<usize>,
}

impl Default for ModelOptions {
    fn default() -> Self {
        ModelOptions {
            ramp_step_deg: 1.0,
            u_sigma_deg: 20.0,
            tangent_samples: None,
        }
    }
}

/// The BRDF split into its lobes (sr⁻¹).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ClothValue {
    /// Surface reflection of the threads (white).
    pub surface: f64,
    /// Volume scattering of the threads, RGB.
    pub volume: [f64; 3],
}

impl ClothValue {
    /// The BRDF per channel.
    pub fn total(&self) -> [f64; 3] {
        self.volume.map(|v| v + self.surface)
    }
}

/// Unit vector of cloth-frame angles (θ from `+z`, φ from `+x`), radians.
pub fn direction(theta_rad: f64, phi_rad: f64) -> [f64; 3] {
    let (st, ct) = theta_rad.sin_cos();
    let (sp, cp) = phi_rad.sin_cos();
    [st * cp, st * sp, ct]
}

/// The frame `(t, n_t, b)` of a tangent sample of family `family` (0: `+x`, 1: `+y`).
pub fn sample_frame(family: usize, alpha_rad: f64) -> [[f64; 3]; 3] {
    let (sa, ca) = alpha_rad.sin_cos();
    let (u, b) = if family == 0 {
        ([1.0, 0.0, 0.0], [0.0, -1.0, 0.0])
    } else {
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    };
    let t = [ca * u[0], ca * u[1], sa];
    let n_t = [-sa * u[0], -sa * u[1], ca];
    [t, n_t, b]
}

/// What one direction contributes, per tangent sample, to the pair evaluation.
#[derive(Debug, Clone, Copy)]
struct SampleSide {
    dir: ThreadDir,
    side: ThreadSide,
    /// `max(cos φ, 0)` (eq. 5.14).
    mask: f64,
    /// ψ = atan2(ω·t, ω·n_t).
    psi: f64,
    /// `max(cos ψ, 0)` (eq. 5.18).
    proj: f64,
}

/// A direction prepared for repeated evaluation against many others (for tables).
#[derive(Debug, Clone)]
pub struct PreparedDirection {
    cos_surface: f64,
    sides: [Vec<SampleSide>; 2],
}

impl PreparedDirection {
    /// `n·ω`.
    pub fn cos_surface(&self) -> f64 {
        self.cos_surface
    }
}

/// A fabric with its tangent quadrature, ready to evaluate.
#[derive(Debug, Clone)]
pub struct ClothModel {
    fabric: Fabric,
    nodes: [Vec<TangentNode>; 2],
    frames: [Vec<[[f64; 3]; 3]>; 2],
    u_variance: f64,
}

/// `(1 − u) p q + u min(p, q)` (eqs. 5.16, 5.19).
fn blend(u: f64, p: f64, q: f64) -> f64 {
    (1.0 - u) * p * q + u * p.min(q)
}

impl ClothModel {
    /// The model of `fabric` with `options`.
    pub fn new(fabric: Fabric, options: ModelOptions) -> Self {
        let nodes = match options.tangent_samples {
            Some(t) => fabric
                .families
                .each_ref()
                .map(|f| f.curve.equidistant(t.max(1))),
            None => fabric.nodes(options.ramp_step_deg),
        };
        let frames = [0, 1].map(|j| {
            nodes[j]
                .iter()
                .map(|n| sample_frame(j, n.alpha_rad))
                .collect()
        });
        ClothModel {
            fabric,
            nodes,
            frames,
            u_variance: options.u_sigma_deg.to_radians().powi(2),
        }
    }

    /// The fabric.
    pub fn fabric(&self) -> &Fabric {
        &self.fabric
    }

    /// The tangent quadrature of each family.
    pub fn nodes(&self) -> &[Vec<TangentNode>; 2] {
        &self.nodes
    }

    /// Prepares the unit direction `w` (cloth frame).
    pub fn prepare(&self, w: [f64; 3]) -> PreparedDirection {
        let sides = [0, 1].map(|j| {
            let eta = self.fabric.families[j].optics.eta;
            self.frames[j]
                .iter()
                .map(|[t, n_t, b]| {
                    let dir = ThreadDir {
                        s: dot(w, *t),
                        c: dot(w, *n_t),
                        d: dot(w, *b),
                    };
                    let side = ThreadSide::new(eta, &dir);
                    let mask = if side.cos_theta > 0.0 {
                        (dir.c / side.cos_theta).max(0.0)
                    } else {
                        0.0
                    };
                    let proj_len = dir.s.hypot(dir.c);
                    let proj = if proj_len > 0.0 {
                        (dir.c / proj_len).max(0.0)
                    } else {
                        0.0
                    };
                    SampleSide {
                        dir,
                        side,
                        mask,
                        psi: dir.s.atan2(dir.c),
                        proj,
                    }
                })
                .collect()
        });
        PreparedDirection {
            cos_surface: w[2],
            sides,
        }
    }

    /// The BRDF for prepared light (`wi`) and view (`wr`) directions.
    pub fn eval_prepared(&self, wi: &PreparedDirection, wr: &PreparedDirection) -> ClothValue {
        if wi.cos_surface <= 0.0 || wr.cos_surface <= 0.0 {
            return ClothValue::default();
        }
        let k = self.patch_prepared(wi, wr);
        let scale = 1.0 / wi.cos_surface;
        ClothValue {
            surface: k.surface * scale,
            volume: k.volume.map(|v| v * scale),
        }
    }

    /// The patch integrand `K = f·(n·ω_i)` of eq. 5.20 for prepared directions, without the
    /// horizon test: below the horizon it is the same formula continued (the tables store it
    /// there so that interpolation next to the horizon does not blend with zeros).
    pub fn patch_prepared(&self, wi: &PreparedDirection, wr: &PreparedDirection) -> ClothValue {
        let (mut surface, mut volume, mut den) = (0.0, [0.0; 3], 0.0);
        for j in 0..2 {
            let family = &self.fabric.families[j];
            for (k, node) in self.nodes[j].iter().enumerate() {
                let (a, b) = (&wi.sides[j][k], &wr.sides[j][k]);
                let psi_d = (a.psi - b.psi + PI).rem_euclid(2.0 * PI) - PI;
                let p = blend(gaussian_unit_height(psi_d, self.u_variance), a.proj, b.proj);
                den += node.weight * p;
                if p <= 0.0 || a.mask <= 0.0 || b.mask <= 0.0 {
                    continue;
                }
                let Some(cpd) = cos_phi_d(&a.dir, &b.dir) else {
                    continue;
                };
                let m = blend(
                    gaussian_unit_height(cpd.acos(), self.u_variance),
                    a.mask,
                    b.mask,
                );
                let lobes = thread_bsdf_sides(&family.optics, &a.side, &b.side, cpd);
                let w = family.coverage * node.weight * m * p * a.side.cos_theta;
                surface += w * lobes.surface;
                for (v, l) in volume.iter_mut().zip(lobes.volume) {
                    *v += w * l;
                }
            }
        }
        if den <= 0.0 {
            return ClothValue::default();
        }
        let scale = 1.0 / den;
        ClothValue {
            surface: surface * scale,
            volume: volume.map(|v| v * scale),
        }
    }

    /// The BRDF `f(ω_i, ω_r)` for unit directions in the cloth frame.
    pub fn eval(&self, wi: [f64; 3], wr: [f64; 3]) -> ClothValue {
        self.eval_prepared(&self.prepare(wi), &self.prepare(wr))
    }

    /// The BRDF for cloth-frame angles in radians.
    pub fn eval_angles(
        &self,
        theta_i_rad: f64,
        phi_i_rad: f64,
        theta_r_rad: f64,
        phi_r_rad: f64,
    ) -> ClothValue {
        self.eval(
            direction(theta_i_rad, phi_i_rad),
            direction(theta_r_rad, phi_r_rad),
        )
    }

    /// Directional albedo `ρ(ω_i) = ∫_H f(ω_i, ω_r) cos θ_r dω_r` (RGB) by the midpoint rule on
    /// an `n_theta × n_phi` grid of (θ_r, φ_r) cells over the hemisphere.
    pub fn directional_albedo(&self, wi: [f64; 3], n_theta: usize, n_phi: usize) -> [f64; 3] {
        let pi_dir = self.prepare(wi);
        let (dt, dp) = (0.5 * PI / n_theta as f64, 2.0 * PI / n_phi as f64);
        let mut sum = [0.0; 3];
        for a in 0..n_theta {
            let theta = (a as f64 + 0.5) * dt;
            let w = theta.sin() * theta.cos() * dt * dp;
            for b in 0..n_phi {
                let phi = (b as f64 + 0.5) * dp;
                let f = self.eval_prepared(&pi_dir, &self.prepare(direction(theta, phi)));
                for (s, v) in sum.iter_mut().zip(f.total()) {
                    *s += w * v;
                }
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::super::fabric::preset;
    use super::*;

    #[test]
    fn below_the_horizon_is_zero() {
        let m = ClothModel::new(preset("linen_plain").unwrap(), ModelOptions::default());
        let v = m.eval_angles(0.3, 0.0, 1.7, 0.0);
        assert_eq!(v, ClothValue::default());
    }

    #[test]
    fn frames_are_orthonormal() {
        for j in 0..2 {
            let [t, n, b] = sample_frame(j, 0.4);
            for (x, y) in [(t, n), (t, b), (n, b)] {
                assert!(dot(x, y).abs() < 1e-15);
            }
            let c = crate::math::vec3::cross(t, n);
            assert!((dot(c, b) - 1.0).abs() < 1e-15);
        }
    }
}
