//! Lorenz–Mie scattering by homogeneous spheres (pure physics, no I/O).
//!
//! Conventions (Bohren & Huffman 1983): time dependence `e^{−iωt}`, relative refractive index
//! `m = n + i k` with `k ≥ 0` absorbing, size parameter `x = 2π r/λ` (λ in the outside medium),
//! `S_1` is the amplitude for the electric field perpendicular to the scattering plane, `S_2`
//! parallel to it. Per angle:
//! `i_perp = |S_1|²`, `i_par = |S_2|²`, `s11 = (|S_1|² + |S_2|²)/2`,
//! `DoLP = (i_perp − i_par)/(i_perp + i_par)` and the normalised phase function
//! `p = s11/(π x² Q_sca)`, so that `∫_{4π} p dΩ = 1`.
//!
//! Validated domain ([`VALIDATED_DOMAIN`], enforced by [`MieCoefficients::new`]):
//! `10⁻³ ≤ x ≤ 10⁵`, `0.05 ≤ Re m ≤ 10`, `0 ≤ Im m ≤ 10`, `|m − 1| ≥ 10⁻⁵` and `|m| x ≤ 1.5·10⁵`
//! (bubbles and ice in water, metals such as gold and silver, high-index semiconductors,
//! water and glass). Evidence in `docs/mie.md`: 40-digit references on 15 indices ×
//! x = 10⁻³ … 10⁴ (`tests/mie_wide.rs`), the earlier references at x = 2000 and 25000, `scatrs`
//! up to 2·10⁴, convergence and energy checks up to 10⁵.
//!
//! Units: `x` and the angles are dimensionless and in degrees; efficiencies are cross-sections
//! over `π r²`; `S_1`, `S_2` are dimensionless. A sphere in a medium of index `n_medium`
//! ([`in_medium`]) takes the relative index `m/n_medium` and the wavelength in the medium.
//!
//! Layout: [`riccati`] (Riccati–Bessel functions and log-derivatives, reusable by a Debye
//! series), [`coefficients`] (`a_n`, `b_n`, efficiencies), [`angular`] (the vectorised
//! `S_1`/`S_2` kernel), [`filters`] (sun disc, blur, bin resampling, the filter grids of a
//! table), [`distributions`], [`size_average`] (size-distribution averages to a requested
//! accuracy: the adaptive radius rule and its error estimate) and [`ensemble`] (a table entry of
//! a distribution, and its brute-force reference); the `mie` stage is [`crate::stages::mie`].

pub mod angular;
pub mod coated;
pub mod coefficients;
pub mod distributions;
pub mod domain;
pub mod ensemble;
pub mod filters;
pub mod riccati;
pub mod size_average;

pub use angular::{
    AngularSeries, MirroredAmplitudes, amplitudes, amplitudes_at_angles, amplitudes_mirrored,
    amplitudes_mirrored_batch,
};
pub use coefficients::{Efficiencies, MieCoefficients};
pub use domain::{
    MieError, VALIDATED_DOMAIN, VALIDATED_DOMAIN_TEXT, ValidatedDomain, check_domain,
};

use num_complex::Complex64;

/// The two backscattering conventions, as labelled wherever both are printed.
pub const Q_BACK_CONVENTIONS: &str = "q_back: radar convention, 4 pi (dC_sca/dOmega at 180 deg) / (pi r^2) = |sum_n (2n+1) (-1)^n (a_n - b_n)|^2 / x^2 = 4 |S1(180)|^2 / x^2; q_back_per_sr: per steradian (MiePlot), (dC_sca/dOmega at 180 deg) / (pi r^2) = q_back / (4 pi) = |S1(180)|^2 / (pi x^2)";

/// Size parameter `2π r/λ` from a radius in µm and a wavelength in nm (outside index 1).
pub fn size_parameter(radius_um: f64, wavelength_nm: f64) -> f64 {
    2.0 * std::f64::consts::PI * radius_um * 1e3 / wavelength_nm
}

/// A sphere of absolute index `index` (`n + ik`, `k ≥ 0`) in a non-absorbing medium of real
/// index `n_medium`, lit at the vacuum wavelength `wavelength_nm`: returns the size parameter
/// `x = 2π r n_medium/λ` (the wavelength in the medium is `λ/n_medium`) and the relative index
/// `m = index/n_medium` that the Lorenz–Mie solution takes. `S_1`, `S_2`, the efficiencies and
/// the phase function are then those of the medium (Bohren & Huffman 1983, §4.1).
pub fn in_medium(
    radius_um: f64,
    wavelength_nm: f64,
    index: Complex64,
    n_medium: f64,
) -> (f64, Complex64) {
    (
        size_parameter(radius_um, wavelength_nm / n_medium),
        index / n_medium,
    )
}

/// One solved sphere: coefficients, efficiencies and the prepared angular series.
#[derive(Debug, Clone)]
pub struct Sphere {
    pub coefficients: MieCoefficients,
    pub efficiencies: Efficiencies,
    series: AngularSeries,
}

/// Raw (Bohren–Huffman normalised, dimensionless) intensities on an angle grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RawCurve {
    /// Scattering angles in degrees.
    pub angles_deg: Vec<f64>,
    /// `|S_1|²`.
    pub i_perp: Vec<f64>,
    /// `|S_2|²`.
    pub i_par: Vec<f64>,
}

impl Sphere {
    /// Solves the sphere of size parameter `x` and index `m` (domain-checked).
    pub fn new(x: f64, m: Complex64) -> Result<Self, MieError> {
        let coefficients = MieCoefficients::new(x, m)?;
        Ok(Self::from_coefficients(coefficients))
    }

    /// Wraps already computed coefficients.
    pub fn from_coefficients(coefficients: MieCoefficients) -> Self {
        let efficiencies = coefficients.efficiencies();
        let series = AngularSeries::new(&coefficients);
        Sphere {
            coefficients,
            efficiencies,
            series,
        }
    }

    /// Size parameter.
    pub fn size_parameter(&self) -> f64 {
        self.coefficients.size_parameter
    }

    /// `π x² Q_sca = ∫_{4π} s11 dΩ`: the divisor that turns `s11` into the phase function.
    pub fn phase_normalisation(&self) -> f64 {
        let x = self.size_parameter();
        std::f64::consts::PI * x * x * self.efficiencies.q_sca
    }

    /// `S_1`, `S_2` at arbitrary scattering angles (degrees), on the calling thread; supplementary
    /// angles are summed once ([`amplitudes_at_angles`]).
    pub fn amplitudes_deg(&self, angles_deg: &[f64]) -> (Vec<Complex64>, Vec<Complex64>) {
        amplitudes_at_angles(&self.series, angles_deg, false)
    }

    /// [`Self::amplitudes_deg`] split over rayon's pool when the sum is large enough to gain.
    pub fn amplitudes_deg_parallel(&self, angles_deg: &[f64]) -> (Vec<Complex64>, Vec<Complex64>) {
        amplitudes_at_angles(&self.series, angles_deg, true)
    }

    /// `S_1`, `S_2` at cosines `mu` and `−mu` (see [`amplitudes_mirrored`]).
    pub fn amplitudes_mirrored(&self, mu: &[f64], parallel: bool) -> MirroredAmplitudes {
        amplitudes_mirrored(&self.series, mu, parallel)
    }

    /// `S_1`, `S_2` at cosines `mu` and `−mu` of several spheres, sharing the angular functions
    /// (see [`amplitudes_mirrored_batch`]); one entry per sphere, in order.
    pub fn amplitudes_mirrored_batch(spheres: &[&Sphere], mu: &[f64]) -> Vec<MirroredAmplitudes> {
        let series: Vec<&AngularSeries> = spheres.iter().map(|s| &s.series).collect();
        amplitudes_mirrored_batch(&series, mu)
    }

    /// Raw intensities at `θ_j = j·180°/intervals`, `j = 0..=intervals`, using the
    /// `θ ↔ 180° − θ` symmetry (only `θ ≤ 90°` is summed).
    pub fn uniform_curve(&self, intervals: usize, parallel: bool) -> RawCurve {
        let intervals = intervals.max(1);
        let half = intervals / 2;
        let step = std::f64::consts::PI / intervals as f64;
        let mu: Vec<f64> = (0..=half).map(|j| (j as f64 * step).cos()).collect();
        let amp = self.amplitudes_mirrored(&mu, parallel);
        let mut i_perp = vec![0.0; intervals + 1];
        let mut i_par = vec![0.0; intervals + 1];
        for j in 0..=half {
            i_perp[j] = amp.s1[j].norm_sqr();
            i_par[j] = amp.s2[j].norm_sqr();
            i_perp[intervals - j] = amp.s1_mirror[j].norm_sqr();
            i_par[intervals - j] = amp.s2_mirror[j].norm_sqr();
        }
        RawCurve {
            angles_deg: (0..=intervals)
                .map(|j| j as f64 * 180.0 / intervals as f64)
                .collect(),
            i_perp,
            i_par,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domain_is_enforced() {
        assert!(Sphere::new(2e5, Complex64::new(1.33, 0.0)).is_err());
        assert!(Sphere::new(1e-4, Complex64::new(1.33, 0.0)).is_err());
        assert!(Sphere::new(10.0, Complex64::new(1.33, -0.1)).is_err());
        assert!(Sphere::new(10.0, Complex64::new(0.04, 0.0)).is_err());
        assert!(Sphere::new(10.0, Complex64::new(1.0, 0.0)).is_err());
        assert!(Sphere::new(10.0, Complex64::new(10.0, 10.5)).is_err());
        assert!(Sphere::new(10.0, Complex64::new(0.9, 0.0)).is_ok());
        assert!(Sphere::new(10.0, Complex64::new(0.1425812, 3.6813284)).is_ok());
        assert!(Sphere::new(10.0, Complex64::new(1.33, 0.0)).is_ok());
    }

    /// Optical theorem: Q_ext = (4/x²) Re S(0°), with Q_ext from Q_sca + Q_abs.
    #[test]
    fn optical_theorem() {
        for (x, m) in [
            (0.5, Complex64::new(1.5, 0.0)),
            (30.0, Complex64::new(1.33, 0.05)),
            (800.0, Complex64::new(1.333, 0.0)),
        ] {
            let s = Sphere::new(x, m).unwrap();
            let (s1, s2) = s.amplitudes_deg(&[0.0]);
            let q = 4.0 / (x * x) * s1[0].re;
            assert!(((q - s.efficiencies.q_ext) / q).abs() < 1e-10, "x={x}");
            assert!((s1[0] - s2[0]).norm() < 1e-10 * s1[0].norm());
        }
    }

    /// Q_back from the coefficient series equals 4|S_1(180°)|²/x².
    #[test]
    fn backscatter_consistency() {
        let s = Sphere::new(77.7, Complex64::new(1.45, 0.01)).unwrap();
        let (s1, _) = s.amplitudes_deg(&[180.0]);
        let x = s.size_parameter();
        let q = 4.0 * s1[0].norm_sqr() / (x * x);
        assert!(((q - s.efficiencies.q_back) / q).abs() < 1e-10);
    }
}
