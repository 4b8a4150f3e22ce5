//! Colour: CIE 1931 2° colour-matching functions, the D65 illuminant, and XYZ → linear sRGB.
//!
//! Data: the CIE 1931 2° observer and CIE D65 at 1 nm from 380 to 780 nm, provided by the
//! `colorimetry` crate (CIE 15:2018 tables); between integer wavelengths values are linearly
//! interpolated, outside 380–780 nm they are zero. XYZ → linear sRGB uses the IEC 61966-2-1
//! matrix (D65 white), and [`srgb_encode`] the sRGB transfer function.
//!
//! Spectral integration over a coarse sampling (e.g. the 33 samples 380–700 nm of the rainbow
//! stage) uses [`SpectralWeights`]: per-sample X̄, Ȳ, Z̄ weights integrated with the trapezoid
//! rule over each sample's cell, normalised so that a spectrally flat unit reflectance under the
//! chosen illuminant gives Y = 1.

use colorimetry::illuminant::Illuminant;
use colorimetry::observer::Observer;
use std::sync::OnceLock;

const CMF_START_NM: f64 = 380.0;
const CMF_SAMPLES: usize = 401;

struct Tables {
    xyz_bar: Vec<[f64; 3]>,
    d65: Vec<f64>,
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let obs = Observer::Cie1931;
        let xyz_bar = (0..CMF_SAMPLES)
            .map(|i| {
                obs.xyz_at_wavelength(380 + i)
                    .map(|v| v.to_array())
                    .unwrap_or([0.0; 3])
            })
            .collect();
        let d65_spectrum = Illuminant::d65();
        let arr: &[f64] = d65_spectrum.as_ref().as_ref();
        Tables {
            xyz_bar,
            d65: arr.to_vec(),
        }
    })
}

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at `wavelength_nm`; zero outside 380–780 nm.
pub fn cie1931_xyz_bar(wavelength_nm: f64) -> [f64; 3] {
    let t = tables();
    let u = wavelength_nm - CMF_START_NM;
    if !(0.0..=(CMF_SAMPLES - 1) as f64).contains(&u) {
        return [0.0; 3];
    }
    let i = (u.floor() as usize).min(CMF_SAMPLES - 2);
    let f = u - i as f64;
    let a = t.xyz_bar[i];
    let b = t.xyz_bar[i + 1];
    [
        a[0] + f * (b[0] - a[0]),
        a[1] + f * (b[1] - a[1]),
        a[2] + f * (b[2] - a[2]),
    ]
}

/// Relative spectral power of CIE D65 (normalised to 100 at 560 nm); zero outside 380–780 nm.
pub fn d65_spd(wavelength_nm: f64) -> f64 {
    let t = tables();
    crate::table::interp::interp1_uniform(&t.d65, CMF_START_NM, 1.0, wavelength_nm)
        * f64::from(u8::from((380.0..=780.0).contains(&wavelength_nm)))
}

/// Illuminant used to weight spectral samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Illuminant1931 {
    /// CIE equal-energy illuminant E.
    EqualEnergy,
    /// CIE D65 daylight.
    D65,
}

impl Illuminant1931 {
    /// Relative spectral power at `wavelength_nm`.
    pub fn spd(self, wavelength_nm: f64) -> f64 {
        match self {
            Illuminant1931::EqualEnergy => 1.0,
            Illuminant1931::D65 => d65_spd(wavelength_nm),
        }
    }
}

/// XYZ (D65 white) → linear sRGB, IEC 61966-2-1.
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z,
        -0.969_266_0 * x + 1.876_010_8 * y + 0.041_556_0 * z,
        0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z,
    ]
}

/// sRGB transfer function (linear → encoded), input clamped to [0, 1].
pub fn srgb_encode(linear: f64) -> f64 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Per-sample weights that turn a spectrum sampled at given wavelengths into XYZ.
#[derive(Debug, Clone)]
pub struct SpectralWeights {
    /// Wavelengths of the samples (nm), strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// XYZ weight of each sample: XYZ = Σ_k `weights[k]` · value_k.
    pub weights: Vec<[f64; 3]>,
}

impl SpectralWeights {
    /// Weights for samples at `wavelengths_nm` under `illuminant`. Each sample stands for the
    /// cell between the midpoints to its neighbours (half cells at the ends); the CMFs and the
    /// illuminant are integrated over that cell at 1 nm. Normalisation: a flat spectrum of 1 gives
    /// Y = 1 (i.e. the colour of a perfect white reflector under the illuminant, over the sampled
    /// band).
    pub fn new(wavelengths_nm: &[f64], illuminant: Illuminant1931) -> Self {
        let n = wavelengths_nm.len();
        let mut weights = vec![[0.0; 3]; n];
        for k in 0..n {
            let lo = if k == 0 {
                wavelengths_nm[0]
            } else {
                0.5 * (wavelengths_nm[k - 1] + wavelengths_nm[k])
            };
            let hi = if k + 1 == n {
                wavelengths_nm[n - 1]
            } else {
                0.5 * (wavelengths_nm[k] + wavelengths_nm[k + 1])
            };
            let (lo, hi) = if n == 1 {
                (wavelengths_nm[0] - 0.5, wavelengths_nm[0] + 0.5)
            } else {
                (lo, hi)
            };
            let steps = ((hi - lo) / 0.25).ceil().max(1.0) as usize;
            let dl = (hi - lo) / steps as f64;
            for s in 0..steps {
                let l = lo + (s as f64 + 0.5) * dl;
                let e = illuminant.spd(l);
                let c = cie1931_xyz_bar(l);
                for j in 0..3 {
                    weights[k][j] += c[j] * e * dl;
                }
            }
        }
        let y: f64 = weights.iter().map(|w| w[1]).sum();
        if y > 0.0 {
            for w in &mut weights {
                for v in w.iter_mut() {
                    *v /= y;
                }
            }
        }
        SpectralWeights {
            wavelengths_nm: wavelengths_nm.to_vec(),
            weights,
        }
    }

    /// XYZ of a spectrum given at the sample wavelengths.
    pub fn xyz(&self, values: &[f64]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (w, &v) in self.weights.iter().zip(values) {
            for j in 0..3 {
                out[j] += w[j] * v;
            }
        }
        out
    }

    /// Linear sRGB of a spectrum given at the sample wavelengths.
    pub fn linear_srgb(&self, values: &[f64]) -> [f64; 3] {
        xyz_to_linear_srgb(self.xyz(values))
    }
}

/// Relative luminance Y of a linear sRGB triple (IEC 61966-2-1 primaries, D65 white = 1).
pub fn linear_srgb_luminance(rgb: [f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cmf_known_values() {
        // CIE 1931 2°: ȳ(555) = 1.0 (to 1e-3), x̄(600) = 1.0622, z̄(450) = 1.7721.
        assert!((cie1931_xyz_bar(555.0)[1] - 1.0).abs() < 2e-3);
        assert!((cie1931_xyz_bar(600.0)[0] - 1.0622).abs() < 2e-3);
        assert!((cie1931_xyz_bar(450.0)[2] - 1.7721).abs() < 2e-3);
        assert_eq!(cie1931_xyz_bar(300.0), [0.0; 3]);
    }

    #[test]
    fn d65_white_is_srgb_white() {
        let wl: Vec<f64> = (380..=780).map(f64::from).collect();
        let w = SpectralWeights::new(&wl, Illuminant1931::D65);
        let rgb = w.linear_srgb(&vec![1.0; wl.len()]);
        for c in rgb {
            assert!((c - 1.0).abs() < 3e-3, "{rgb:?}");
        }
        let xyz = w.xyz(&vec![1.0; wl.len()]);
        let s = xyz[0] + xyz[1] + xyz[2];
        // D65 chromaticity (0.3127, 0.3290).
        assert!((xyz[0] / s - 0.3127).abs() < 3e-4);
        assert!((xyz[1] / s - 0.3290).abs() < 3e-4);
    }

    #[test]
    fn equal_energy_white_chromaticity_is_one_third() {
        let wl: Vec<f64> = (380..=780).map(f64::from).collect();
        let w = SpectralWeights::new(&wl, Illuminant1931::EqualEnergy);
        let xyz = w.xyz(&vec![1.0; wl.len()]);
        let s = xyz[0] + xyz[1] + xyz[2];
        assert!((xyz[0] / s - 1.0 / 3.0).abs() < 5e-4, "{xyz:?}");
        assert!((xyz[1] / s - 1.0 / 3.0).abs() < 5e-4);
        // E in sRGB is slightly pink: R > G, B < R (known: linear ≈ (1.205, 0.948, 0.909)).
        let rgb = xyz_to_linear_srgb(xyz);
        assert!((rgb[0] - 1.2049).abs() < 5e-3, "{rgb:?}");
        assert!((rgb[1] - 0.9484).abs() < 5e-3, "{rgb:?}");
        assert!((rgb[2] - 0.9086).abs() < 5e-3, "{rgb:?}");
    }

    #[test]
    fn srgb_transfer_end_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-12);
        assert!((srgb_encode(0.0031308) - 0.04045).abs() < 1e-4);
    }
}
