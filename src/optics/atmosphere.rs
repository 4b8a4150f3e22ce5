//! Direct sunlight through a clear atmosphere: the spectral transmission that reddens a low sun.
//!
//! `T(λ, e) = exp(−m(e) · (τ_R(λ) + τ_a(λ)))` with
//! - the Rayleigh optical depth of a standard sea-level atmosphere, Hansen & Travis (1974,
//!   eq. 2.29): `τ_R = 0.008569 λ⁻⁴ (1 + 0.0113 λ⁻² + 0.00013 λ⁻⁴)`, λ in µm (0.0973 at 550 nm);
//! - an aerosol optical depth after Ångström (1929), `τ_a = β λ^−α` (λ in µm);
//! - the relative optical air mass of Kasten & Young (1989),
//!   `m = 1/(sin e + 0.50572 (e + 6.07995°)^−1.6364)` (e the solar elevation in degrees;
//!   37.9 at the horizon, 1 at the zenith).
//!
//! Valid for a clear sky at sea level, 300–1000 nm, elevations −1°…90° (the air-mass formula is
//! fitted down to the horizon); no ozone absorption (the Chappuis band removes a few per cent
//! around 600 nm at low sun) and no refraction of the sun's disc.

/// Rayleigh optical depth of a standard sea-level atmosphere (Hansen & Travis 1974).
pub fn rayleigh_optical_depth(wavelength_nm: f64) -> f64 {
    let l = wavelength_nm * 1e-3;
    let l2 = 1.0 / (l * l);
    0.008569 * l2 * l2 * (1.0 + 0.0113 * l2 + 0.00013 * l2 * l2)
}

/// Relative optical air mass at solar elevation `elevation_deg` (Kasten & Young 1989).
pub fn air_mass(elevation_deg: f64) -> f64 {
    let e = elevation_deg.clamp(-1.0, 90.0);
    1.0 / (e.to_radians().sin() + 0.50572 * (e + 6.07995).powf(-1.6364))
}

/// A clear atmosphere: Rayleigh scattering plus Ångström aerosol `τ_a = β λ^−α` (λ in µm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearAtmosphere {
    /// Ångström turbidity β (aerosol optical depth at 1 µm).
    pub aerosol_beta: f64,
    /// Ångström exponent α.
    pub aerosol_alpha: f64,
}

impl ClearAtmosphere {
    /// A clean continental atmosphere: β = 0.05, α = 1.3 (Ångström 1929's typical exponent).
    pub const CLEAN: ClearAtmosphere = ClearAtmosphere {
        aerosol_beta: 0.05,
        aerosol_alpha: 1.3,
    };

    /// Vertical optical depth at `wavelength_nm`.
    pub fn optical_depth(&self, wavelength_nm: f64) -> f64 {
        rayleigh_optical_depth(wavelength_nm)
            + self.aerosol_beta * (wavelength_nm * 1e-3).powf(-self.aerosol_alpha)
    }

    /// Direct-beam transmission at `wavelength_nm` for the sun at `elevation_deg`.
    pub fn transmission(&self, wavelength_nm: f64, elevation_deg: f64) -> f64 {
        (-air_mass(elevation_deg) * self.optical_depth(wavelength_nm)).exp()
    }

    /// Transmission at `elevation_deg` relative to the zenith sun: the factor that turns a
    /// high-sun spectrum (CIE D65 stands for it) into the spectrum of a sun at that elevation.
    pub fn reddening(&self, wavelength_nm: f64, elevation_deg: f64) -> f64 {
        ((1.0 - air_mass(elevation_deg)) * self.optical_depth(wavelength_nm)).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_values() {
        // Hansen & Travis (1974): τ_R(550 nm) ≈ 0.0973; Kasten & Young (1989): m(0°) ≈ 38,
        // m(90°) = 1, m(30°) ≈ 1.995.
        assert!((rayleigh_optical_depth(550.0) - 0.0973).abs() < 5e-4);
        assert!((air_mass(0.0) - 37.92).abs() < 0.1, "{}", air_mass(0.0));
        assert!((air_mass(90.0) - 1.0).abs() < 1e-3);
        assert!((air_mass(30.0) - 1.995).abs() < 0.01, "{}", air_mass(30.0));
        // λ⁻⁴ (steepened by the dispersion of air: ≈ λ^−4.08) between 400 and 700 nm
        let r = rayleigh_optical_depth(400.0) / rayleigh_optical_depth(700.0);
        assert!(
            (r / (700.0f64 / 400.0).powf(4.08) - 1.0).abs() < 0.01,
            "{r}"
        );
    }

    #[test]
    fn a_low_sun_is_red() {
        let a = ClearAtmosphere::CLEAN;
        assert!((a.reddening(550.0, 90.0) - 1.0).abs() < 1e-3);
        let (blue, red) = (a.reddening(450.0, 2.0), a.reddening(650.0, 2.0));
        assert!(red > 5.0 * blue, "blue {blue}, red {red}");
        assert!(a.transmission(650.0, 2.0) < a.transmission(650.0, 30.0));
    }
}
