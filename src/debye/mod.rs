//! Debye series of a homogeneous sphere: the Lorenz–Mie coefficients split by ray order `p`
//! (pure physics, no I/O), and Airy theory of the rainbow ([`airy`]).
//!
//! # Conventions
//! Bohren & Huffman (1983), as in [`crate::mie`]: time dependence `e^{−iωt}`, `m = n + ik`
//! (`k ≥ 0` absorbing), size parameter `x`, inside argument `y = m x`. The outgoing
//! Riccati–Hankel function is `ζ¹_n = ξ_n = ψ_n − iχ_n` (`~ e^{+iz}`), the incoming one
//! `ζ²_n = ψ_n + iχ_n`; `D¹`, `D²`, `D^ψ` are logarithmic derivatives (derivative with respect
//! to the function's own argument). Under the opposite time convention `e^{+iωt}` (used by
//! Hovenac & Lock 1992 and by MiePlot's documentation) the roles of `ζ¹` and `ζ²` swap and
//! every coefficient below is the complex conjugate of theirs; intensities are identical.
//!
//! # The series (derived in `docs/debye.md`)
//! Outside, each partial wave is `ψ_n(x) − c_n ξ_n(x) = ½[ζ²_n(x) + (1 − 2c_n) ζ¹_n(x)]`
//! (`c = a` for TM, `c = b` for TE), so `S_n = 1 − 2c_n` is the ratio of outgoing to incoming
//! amplitude. Following the wave through the surface:
//!
//! ```text
//! S_n = R22 + T21 T12 Σ_{p≥1} R11^{p−1}
//! c_n^{(0)} = ½ (1 − R22)               (p = 0: diffraction ½ and external reflection −½R22)
//! c_n^{(p)} = −½ T21 T12 R11^{p−1}      (p ≥ 1: p chords through the sphere)
//! Σ_{p≥P} c_n^{(p)} = −½ T21 T12 R11^{P−1} / (1 − R11)   (P ≥ 1, the exact remainder)
//! ```
//!
//! Boundary conditions on `u` (outside radial function) and `v` (inside): `v = A u`,
//! `v' = B u'` with `(A, B) = (1, m)` for TM (`a_n`) and `(m, 1)` for TE (`b_n`). With
//! `den = B D¹(x) − A D²(y)`, `r_x = ζ²(x)/ζ¹(x)` (unit modulus) and `ρ = ζ¹(y)/ζ²(y)`:
//!
//! ```text
//! R22     = r_x (A D²(y) − B D²(x)) / den          (external reflection)
//! R11     = −ρ (B D¹(x) − A D¹(y)) / den           (internal reflection)
//! T21 T12 = −r_x ρ A B (D¹(x) − D²(x)) (D²(y) − D¹(y)) / den²
//! ```
//!
//! # Numerics (stable for large `x` and for absorbing spheres)
//! - Outside (real `x`): `ψ_n`, `χ_n` and `D^ψ_n(x)` from [`crate::mie::riccati::RiccatiBessel`];
//!   `D¹(x) = ξ_{n−1}/ξ_n − n/x`, `D²(x) = conj D¹(x)`, `D¹(x) − D²(x) = 2i/|ξ_n|²`
//!   (Wronskian, no cancellation), `r_x = conj(ξ_n)/ξ_n`.
//! - Inside (complex `y`): `D^ψ_n(y)` by the downward recurrence of [`crate::mie::riccati`];
//!   `D¹_n(y)` by [`crate::mie::riccati::log_derivative_xi_complex`] (upward from `D¹_0 = i`;
//!   ζ¹ is the dominant solution upward when `Im y ≥ 0`), and the ratio
//!   `g_n = ζ¹_{n−1}/ζ¹_n = 1/(n/y − D¹_{n−1})` (no cancellation).
//!   The inside ratio enters only through `q_n = ζ¹_n(y)/ψ_n(y)`, kept as a complex logarithm
//!   (`ln q_0 = ln(2E/(E − 1))`, `E = e^{2iy}`; `q_n = q_{n−1} (ψ_{n−1}/ψ_n)/(ζ¹_{n−1}/ζ¹_n)`),
//!   so neither `e^{±Im y}` overflows nor underflow loses the large-`n` waves:
//!   `ρ = q/(2 − q)`, `D²(y) − D¹(y) = (1 + ρ)(D^ψ(y) − D¹(y))` with `1 + ρ = 2/(2 − q)`.
//!   For a strongly absorbing sphere `ρ → 0`: `R11`, `T21 T12 → 0` and `c^{(0)}` → Mie, as
//!   it must.
//!
//! Validated domain: [`VALIDATED_DOMAIN`] (`10⁻³ ≤ x ≤ 10⁵`, `1.05 ≤ Re m ≤ 2.5`,
//! `0 ≤ Im m ≤ 1`; narrower than the Lorenz–Mie module's), checked by
//! [`DebyeCoefficients::new`]. Accuracy:
//! the closed-form sum over all `p` reproduces [`crate::mie`] to ≤ 1e-10 relative in s11 at
//! x = 100, 1000, 10⁴ (figures in `docs/debye.md`).

pub mod airy;
pub mod filtered;

use crate::mie::coefficients::MieCoefficients;
use crate::mie::filters::PolarisedPhase;
use crate::mie::riccati::{RiccatiBessel, log_derivative_complex, log_derivative_xi_complex};
use crate::mie::{MieError, Sphere, ValidatedDomain};

/// Inputs for which the Debye series is validated: water, ice, glass and absorbing aerosols
/// (`10⁻³ ≤ x ≤ 10⁵`, `1.05 ≤ Re m ≤ 2.5`, `0 ≤ Im m ≤ 1`). Spheres with `m < 1`, metals and
/// high indices, which the Lorenz–Mie module accepts, have not been checked for the per-order
/// terms.
pub const VALIDATED_DOMAIN: ValidatedDomain = ValidatedDomain {
    x_min: 1e-3,
    x_max: 1e5,
    m_re_min: 1.05,
    m_re_max: 2.5,
    m_im_max: 1.0,
    mx_max: f64::INFINITY,
    m_minus_one_min: 0.0,
};
use num_complex::Complex64;

/// Surface coefficients of one partial wave for one polarisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceCoefficients {
    /// `R22`: reflection of the incoming outside wave (external reflection).
    pub r_ext: Complex64,
    /// `R11`: reflection of the outgoing inside wave back inwards (internal reflection).
    pub r_int: Complex64,
    /// `T21 T12`: transmission in and back out (only the product is physical for a sphere).
    pub t_product: Complex64,
}

/// Polarisation of a partial wave: TM gives `a_n` (and the ∥ field at most angles), TE gives
/// `b_n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Transverse magnetic, Mie `a_n`.
    Tm,
    /// Transverse electric, Mie `b_n`.
    Te,
}

/// A selection of Debye terms.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OrderSet {
    /// The given orders `p` (each once).
    Orders(Vec<usize>),
    /// All orders `p ≥ P` (closed form of the geometric series).
    From(usize),
}

/// Debye-series coefficients of one sphere (orders `n = 1..=n_stop`, index `n − 1`).
#[derive(Debug, Clone)]
pub struct DebyeCoefficients {
    /// Size parameter.
    pub size_parameter: f64,
    /// Relative refractive index.
    pub m: Complex64,
    /// TM (`a_n`) surface coefficients.
    pub tm: Vec<SurfaceCoefficients>,
    /// TE (`b_n`) surface coefficients.
    pub te: Vec<SurfaceCoefficients>,
    /// The Lorenz–Mie solution of the same sphere and truncation (reference and normalisation).
    pub mie: MieCoefficients,
}

impl DebyeCoefficients {
    /// Computes the surface coefficients for `n = 1..=n_stop_default(x)`, refusing inputs
    /// outside [`VALIDATED_DOMAIN`].
    pub fn new(x: f64, m: Complex64) -> Result<Self, MieError> {
        VALIDATED_DOMAIN.check(x, m)?;
        let mie = MieCoefficients::new(x, m)?;
        Ok(Self::from_mie(mie))
    }

    /// As [`DebyeCoefficients::new`] with the truncation of an existing Mie solution.
    pub fn from_mie(mie: MieCoefficients) -> Self {
        let x = mie.size_parameter;
        let m = mie.m;
        let n_stop = mie.n_stop();
        let (tm, te) = surface_coefficients(x, m, n_stop);
        DebyeCoefficients {
            size_parameter: x,
            m,
            tm,
            te,
            mie,
        }
    }

    /// Number of partial waves.
    pub fn n_stop(&self) -> usize {
        self.tm.len()
    }

    /// The surface coefficients of one polarisation.
    pub fn surface(&self, mode: Mode) -> &[SurfaceCoefficients] {
        match mode {
            Mode::Tm => &self.tm,
            Mode::Te => &self.te,
        }
    }

    /// `c_n^{(p)}` for one polarisation (`a` for TM, `b` for TE), `n = 1..=n_stop`.
    pub fn term(&self, mode: Mode, p: usize) -> Vec<Complex64> {
        self.surface(mode).iter().map(|s| s.term(p)).collect()
    }

    /// `Σ_{p ≥ p_min} c_n^{(p)}` in closed form (`p_min = 0` gives the Mie coefficient).
    pub fn remainder(&self, mode: Mode, p_min: usize) -> Vec<Complex64> {
        self.surface(mode)
            .iter()
            .map(|s| remainder_of(s, p_min))
            .collect()
    }

    /// `(a_n, b_n)` of a set of orders.
    pub fn coefficients(&self, set: &OrderSet) -> (Vec<Complex64>, Vec<Complex64>) {
        let one = |mode: Mode| -> Vec<Complex64> {
            match set {
                OrderSet::From(p) => self.remainder(mode, *p),
                OrderSet::Orders(ps) => {
                    let mut ps = ps.clone();
                    ps.sort_unstable();
                    ps.dedup();
                    self.surface(mode)
                        .iter()
                        .map(|s| ps.iter().map(|&p| s.term(p)).sum())
                        .collect()
                }
            }
        };
        (one(Mode::Tm), one(Mode::Te))
    }

    /// `(a_n, b_n)` of the diffraction part of `p = 0` alone (`½` for every `n ≤ n_stop`).
    pub fn diffraction(&self) -> (Vec<Complex64>, Vec<Complex64>) {
        let h = vec![Complex64::new(0.5, 0.0); self.n_stop()];
        (h.clone(), h)
    }

    /// `(a_n, b_n)` of the external reflection part of `p = 0` alone (`−½ R22`).
    pub fn external_reflection(&self) -> (Vec<Complex64>, Vec<Complex64>) {
        let f = |v: &[SurfaceCoefficients]| v.iter().map(|s| -0.5 * s.r_ext).collect();
        (f(&self.tm), f(&self.te))
    }

    /// A [`Sphere`] whose coefficients are the given Debye terms: its angular series gives
    /// `S_1`, `S_2` of exactly those terms. Note: the efficiencies of the returned sphere
    /// are those of the partial series (`q_sca` = the terms' own scattering efficiency); use
    /// [`DebyeCoefficients::mie_normalisation`] to normalise to the full sphere.
    pub fn term_sphere(&self, a: Vec<Complex64>, b: Vec<Complex64>) -> Sphere {
        let mut c = self.mie.clone();
        c.a = a;
        c.b = b;
        Sphere::from_coefficients(c)
    }

    /// `π x² Q_sca` of the full (Mie) sphere: `∫_{4π} s11 dΩ`, the divisor shared by all orders
    /// so that normalised per-order curves add up to the Mie phase function plus interference.
    pub fn mie_normalisation(&self) -> f64 {
        let x = self.size_parameter;
        std::f64::consts::PI * x * x * self.mie.efficiencies().q_sca
    }

    /// Efficiency `(2/x²) Σ (2n+1)(|a|² + |b|²)` of a coefficient set: `∫ s11 dΩ / (π x²)`,
    /// i.e. the energy (relative to the geometric cross-section) that term scatters alone.
    pub fn efficiency_of(&self, a: &[Complex64], b: &[Complex64]) -> f64 {
        let x = self.size_parameter;
        let s: f64 = a
            .iter()
            .zip(b)
            .enumerate()
            .map(|(i, (a, b))| (2 * i + 3) as f64 * (a.norm_sqr() + b.norm_sqr()))
            .sum();
        2.0 * s / (x * x)
    }

    /// `S_1`, `S_2` of a set of orders at scattering angles (degrees).
    pub fn amplitudes_deg(
        &self,
        set: &OrderSet,
        angles_deg: &[f64],
    ) -> (Vec<Complex64>, Vec<Complex64>) {
        let (a, b) = self.coefficients(set);
        self.term_sphere(a, b).amplitudes_deg(angles_deg)
    }

    /// Cell-averaged curve of a set of orders on a uniform grid of `intervals` cells
    /// (as [`PolarisedPhase::from_sphere`]), normalised by the full Mie `π x² Q_sca`.
    pub fn curve(
        &self,
        set: &OrderSet,
        intervals: usize,
        points: usize,
        parallel: bool,
    ) -> PolarisedPhase {
        let (a, b) = self.coefficients(set);
        self.curve_of(a, b, intervals, points, parallel)
    }

    /// As [`DebyeCoefficients::curve`] for explicit coefficients.
    pub fn curve_of(
        &self,
        a: Vec<Complex64>,
        b: Vec<Complex64>,
        intervals: usize,
        points: usize,
        parallel: bool,
    ) -> PolarisedPhase {
        let sphere = self.term_sphere(a, b);
        let own = sphere.phase_normalisation();
        let mut curve = PolarisedPhase::from_sphere(&sphere, intervals, points, parallel);
        let scale = if own > 0.0 {
            own / self.mie_normalisation()
        } else {
            0.0
        };
        for v in curve.i_perp.iter_mut().chain(curve.i_par.iter_mut()) {
            *v *= scale;
        }
        curve
    }
}

/// Point values of the full Mie phase function and of single Debye orders: the data of
/// MiePlot's "Mie with its Debye components" figure. All curves are `s11/(π x² Q_sca)` with the
/// full sphere's `Q_sca` (1/sr), so components are on the Mie scale.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentCurves {
    /// Scattering angles (deg).
    pub angles_deg: Vec<f64>,
    /// Full Mie phase function.
    pub mie: Vec<f64>,
    /// Orders of `components`.
    pub orders: Vec<usize>,
    /// Phase function of each order alone, `components[k][j]` for `orders[k]` at `angles_deg[j]`.
    pub components: Vec<Vec<f64>>,
}

impl ComponentCurves {
    /// CSV: `angle_deg,mie,p<k>...` with a header row.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("angle_deg,mie");
        for p in &self.orders {
            s.push_str(&format!(",p{p}"));
        }
        s.push('\n');
        for (j, t) in self.angles_deg.iter().enumerate() {
            s.push_str(&format!("{t},{:.6e}", self.mie[j]));
            for c in &self.components {
                s.push_str(&format!(",{:.6e}", c[j]));
            }
            s.push('\n');
        }
        s
    }
}

/// Computes [`ComponentCurves`] of the sphere `(x, m)` at `angles_deg` for `orders`.
pub fn mie_with_components(
    x: f64,
    m: Complex64,
    orders: &[usize],
    angles_deg: &[f64],
) -> Result<ComponentCurves, MieError> {
    let d = DebyeCoefficients::new(x, m)?;
    let norm = d.mie_normalisation();
    let phase = |s1: &[Complex64], s2: &[Complex64]| -> Vec<f64> {
        s1.iter()
            .zip(s2)
            .map(|(a, b)| 0.5 * (a.norm_sqr() + b.norm_sqr()) / norm)
            .collect()
    };
    let mie_sphere = Sphere::from_coefficients(d.mie.clone());
    let (s1, s2) = mie_sphere.amplitudes_deg(angles_deg);
    let mie = phase(&s1, &s2);
    let components = orders
        .iter()
        .map(|&p| {
            let (s1, s2) = d.amplitudes_deg(&OrderSet::Orders(vec![p]), angles_deg);
            phase(&s1, &s2)
        })
        .collect();
    Ok(ComponentCurves {
        angles_deg: angles_deg.to_vec(),
        mie,
        orders: orders.to_vec(),
        components,
    })
}

impl SurfaceCoefficients {
    /// `c^{(p)}` of this partial wave: `½(1 − R22)` for p = 0, `−½ T21 T12 R11^{p−1}` for p ≥ 1.
    pub fn term(&self, p: usize) -> Complex64 {
        if p == 0 {
            0.5 * (1.0 - self.r_ext)
        } else {
            -0.5 * self.t_product * self.r_int.powu((p - 1) as u32)
        }
    }
}

/// `Σ_{p ≥ p_min} c^{(p)}` of one partial wave (closed form).
fn remainder_of(s: &SurfaceCoefficients, p_min: usize) -> Complex64 {
    let tail = -0.5 * s.t_product * s.r_int.powu(p_min.saturating_sub(1) as u32) / (1.0 - s.r_int);
    if p_min == 0 {
        0.5 * (1.0 - s.r_ext) + tail
    } else {
        tail
    }
}

/// The surface coefficients of both polarisations for `n = 1..=n_stop` (see the module doc).
pub fn surface_coefficients(
    x: f64,
    m: Complex64,
    n_stop: usize,
) -> (Vec<SurfaceCoefficients>, Vec<SurfaceCoefficients>) {
    let rb = RiccatiBessel::new(x, n_stop);
    let y = m * x;
    let mut d_psi_y = Vec::new();
    log_derivative_complex(y, n_stop, &mut d_psi_y);
    let i = Complex64::new(0.0, 1.0);
    let inv_y = 1.0 / y;
    let inv_x = 1.0 / x;
    // q_n = ξ¹_n(y)/ψ_n(y) (ξ¹_0 = −i e^{iy}), upward from q_1 in closed form:
    // q_1 = E(−i/y − 1) / ((E − 1)/(2iy) − (E + 1)/2), E = e^{2iy}, as a logarithm (ln E = 2iy,
    // so nothing overflows when E underflows for Im y > ~350). Starting at n = 0 instead,
    // q_0 = 2E/(E − 1), multiplies a pole by a zero where sin y = ψ_0(y) vanishes (y = kπ, e.g.
    // x = 1600π, m = 1.335): rounding then leaves every q_n wrong by a constant factor.
    let e = (2.0 * i * y).exp();
    let ln_q1 = 2.0 * i * y + (-i * inv_y - 1.0).ln()
        - ((e - 1.0) * inv_y / (2.0 * i) - 0.5 * (e + 1.0)).ln();
    let mut ln_q = Complex64::new(0.0, 0.0);
    // D¹_n(y) = ξ_n'(y)/ξ_n(y), upward from D¹_0 = i (the dominant direction for Im y ≥ 0)
    let mut d1_y_all = Vec::new();
    log_derivative_xi_complex(y, n_stop, &mut d1_y_all);
    let mut tm = Vec::with_capacity(n_stop);
    let mut te = Vec::with_capacity(n_stop);
    for (n, &dpsi) in d_psi_y.iter().enumerate().skip(1) {
        let nf = n as f64;
        // inside: ζ¹ ratio and log-derivative (upward), ψ ratio (from the downward D^ψ)
        // ζ¹_{n−1}/ζ¹_n from D¹_{n−1} (no cancellation, unlike D¹_n + n/y above the edge)
        let g1 = 1.0 / (nf * inv_y - d1_y_all[n - 1]);
        let d1_y = d1_y_all[n];
        let gpsi = dpsi + nf * inv_y; // ψ_{n−1}/ψ_n
        if n == 1 {
            ln_q = ln_q1;
        } else {
            ln_q += (gpsi / g1).ln();
        }
        // ρ = q/(2 − q) and 1 + ρ = 2/(2 − q), evaluated without overflow (via 1/q when |q| > 1)
        let (rho, one_plus_rho) = if ln_q.re <= 0.0 {
            let q = ln_q.exp();
            let d = 2.0 - q;
            (q / d, 2.0 / d)
        } else {
            let w = (-ln_q).exp(); // 1/q
            let d = 2.0 * w - 1.0;
            (1.0 / d, 2.0 * w / d)
        };
        let dy_diff_scaled = rho * one_plus_rho * (dpsi - d1_y); // ρ (D²(y) − D¹(y))
        let d2_y = d1_y + one_plus_rho * (dpsi - d1_y);
        // outside
        let xi = rb.xi(n);
        let xi_prev = Complex64::new(rb.psi_prev(n), -rb.chi_prev(n));
        let d1_x = xi_prev / xi - nf * inv_x;
        let d2_x = d1_x.conj();
        let xi_abs2 = xi.norm_sqr();
        let r_x = xi.conj() * xi.conj() / xi_abs2;
        let dx_diff = Complex64::new(0.0, 2.0 / xi_abs2); // D¹(x) − D²(x)
        for (mode, out) in [(Mode::Tm, &mut tm), (Mode::Te, &mut te)] {
            let (a, b) = match mode {
                Mode::Tm => (Complex64::new(1.0, 0.0), m),
                Mode::Te => (m, Complex64::new(1.0, 0.0)),
            };
            let den = b * d1_x - a * d2_y;
            let r_ext = r_x * (a * d2_y - b * d2_x) / den;
            let r_int = -rho * (b * d1_x - a * d1_y) / den;
            let t_product = -r_x * a * b * dx_diff * dy_diff_scaled / (den * den);
            out.push(SurfaceCoefficients {
                r_ext,
                r_int,
                t_product,
            });
        }
    }
    (tm, te)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where sin(mx) vanishes (mx = kπ: a = 400 µm at 500 nm with m = 1.335 gives x = 1600π,
    /// mx = 2136π) the coefficients are those of a neighbouring m (mx 5e-6 away from kπ), the
    /// internal reflection keeps |R11| ≤ 1, and the closed-form sum is still Mie's.
    #[test]
    fn coefficients_are_regular_where_sin_mx_vanishes() {
        let x = 1600.0 * std::f64::consts::PI;
        let n_stop = crate::mie::riccati::n_stop_default(x);
        let at = |m: f64| surface_coefficients(x, Complex64::new(m, 0.0), n_stop);
        let (tm, te) = at(1.335);
        let (tm_near, te_near) = at(1.335 * (1.0 + 1e-9));
        for (a, b) in tm.iter().chain(&te).zip(tm_near.iter().chain(&te_near)) {
            assert!(a.r_int.norm() <= 1.0 + 1e-9, "|R11| = {}", a.r_int.norm());
            for p in 0..=6 {
                assert!(
                    (a.term(p) - b.term(p)).norm() < 1e-4,
                    "p={p}: {} vs {}",
                    a.term(p),
                    b.term(p)
                );
            }
        }
        let d = DebyeCoefficients::new(x, Complex64::new(1.335, 0.0)).unwrap();
        let (a, b) = d.coefficients(&OrderSet::From(0));
        for n in 0..d.n_stop() {
            assert!((a[n] - d.mie.a[n]).norm() < 1e-9, "a_{}", n + 1);
            assert!((b[n] - d.mie.b[n]).norm() < 1e-9, "b_{}", n + 1);
        }
    }

    /// The closed-form sum over all p reproduces the Mie coefficients (independent formula in
    /// `crate::mie::coefficients`), for real and absorbing spheres, small and large x.
    #[test]
    fn closed_form_sum_equals_mie_coefficients() {
        for (x, m) in [
            (0.5, Complex64::new(1.33, 0.0)),
            (10.0, Complex64::new(1.5, 0.01)),
            (100.0, Complex64::new(1.333, 0.0)),
            (1000.0, Complex64::new(1.333, 1e-4)),
            (300.0, Complex64::new(1.5, 0.5)),
            (3000.0, Complex64::new(1.05, 1.0)),
        ] {
            let d = DebyeCoefficients::new(x, m).unwrap();
            let (a, b) = d.coefficients(&OrderSet::From(0));
            let scale = d.mie.a.iter().map(|v| v.norm()).fold(0.0, f64::max);
            for n in 0..d.n_stop() {
                assert!(
                    (a[n] - d.mie.a[n]).norm() < 1e-11 * scale,
                    "x={x} m={m} n={} a {} vs {}",
                    n + 1,
                    a[n],
                    d.mie.a[n]
                );
                assert!(
                    (b[n] - d.mie.b[n]).norm() < 1e-11 * scale,
                    "x={x} m={m} n={} b {} vs {}",
                    n + 1,
                    b[n],
                    d.mie.b[n]
                );
            }
        }
    }

    /// Lossless sphere: the partial-wave S-matrix element `1 − 2c_n` of each order set is
    /// unitary only in total; check |R22| = |R11| (reciprocity) and |R|² + |T21 T12| = 1
    /// (energy at a lossless interface; for a sphere T12 T21 is real-positive up to the
    /// phase of r_x ρ, and |T12 T21| = 1 − |R|²).
    #[test]
    fn lossless_interface_conserves_energy() {
        let d = DebyeCoefficients::new(500.0, Complex64::new(1.333, 0.0)).unwrap();
        for mode in [Mode::Tm, Mode::Te] {
            for (k, s) in d.surface(mode).iter().enumerate() {
                let n = k + 1;
                assert!((s.r_ext.norm() - s.r_int.norm()).abs() < 1e-9, "n={n}");
                assert!(
                    (s.r_ext.norm_sqr() + s.t_product.norm() - 1.0).abs() < 1e-9,
                    "n={n} {:?}",
                    s
                );
            }
        }
    }

    /// The partial sums Σ_{p<P} converge geometrically to Mie (|R11| < 1) and the remainder
    /// formula is exact: Σ_{p<P} + Σ_{p≥P} = Mie for every P.
    #[test]
    fn partial_sums_plus_remainder_are_exact() {
        let d = DebyeCoefficients::new(50.0, Complex64::new(1.333, 0.0)).unwrap();
        for mode in [Mode::Tm, Mode::Te] {
            let mie = match mode {
                Mode::Tm => &d.mie.a,
                Mode::Te => &d.mie.b,
            };
            let mut partial = vec![Complex64::new(0.0, 0.0); d.n_stop()];
            for p in 0..6 {
                for (s, t) in partial.iter_mut().zip(d.term(mode, p)) {
                    *s += t;
                }
                let rest = d.remainder(mode, p + 1);
                for n in 0..d.n_stop() {
                    assert!(
                        (partial[n] + rest[n] - mie[n]).norm() < 1e-12,
                        "p={p} n={}",
                        n + 1
                    );
                }
                // geometric convergence: waves that reach the surface (n < x) are partly
                // transmitted on every internal hit, |R11| < 1
                assert!((0..40).all(|n| d.surface(mode)[n].r_int.norm() < 0.999));
            }
        }
    }
}
