//! The colour a phase function gives under sunlight: spectral phase functions seen as a
//! [`SkyPhase`] (1-D tables through the phase contract, 2-D ray-traced tables through
//! [`super::phase2d`]), averaged over the sun's disc and weighted into CIE 1931 XYZ under D65.
//! Shared by the exports (RGB lookup textures), the plots (colour strips, Lee diagrams) and the
//! renderer.

use crate::consumers::ConsumerError;
use crate::consumers::read::phase::{EntrySelection, PhaseTable};
use crate::math::vec3::{V3, cross, dot, normalize};
use crate::optics::colour::{Illuminant1931, SpectralWeights};
use rayon::prelude::*;

/// Spacing of the precomputed Θ grid (deg).
pub const THETA_STEP_DEG: f64 = 0.01;

/// A phase function as the renderer sees it: light of every table wavelength propagating along
/// `inc` (unit vector, world frame) scattered into the unit direction `out`. The 1-D tables
/// depend only on the angle between them; the ray tracer's 2-D tables
/// ([`crate::consumers::read::phase2d::PhaseSlice`]) on the full direction in the drop frame.
pub trait SkyPhase: Sync {
    fn wavelengths_nm(&self) -> &[f64];
    /// Add p_k(inc → out) (1/sr) for every wavelength k to `spec[k]`.
    fn add_phase(&self, inc: V3, out: V3, spec: &mut [f64]);
}

/// The spectrum of the sun a renderer lights the rain with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SunSpectrum {
    /// CIE D65, standing for a high sun (the thesis's renders).
    D65,
    /// D65 reddened by the extra air mass of a sun at `elevation_deg` through `atmosphere`
    /// ([`crate::optics::atmosphere::ClearAtmosphere::reddening`]): dimmer and redder, on the
    /// same absolute scale as [`SunSpectrum::D65`].
    Reddened {
        elevation_deg: f64,
        atmosphere: crate::optics::atmosphere::ClearAtmosphere,
    },
}

impl SunSpectrum {
    /// XYZ weights of spectral samples at `wavelengths_nm` under this sun. Normalised so that a
    /// flat spectrum of 1 under D65 has Y = 1; the reddened sun multiplies each sample's weight
    /// by its transmission factor (smooth over a sample's cell), so it keeps that scale.
    pub fn weights(&self, wavelengths_nm: &[f64]) -> SpectralWeights {
        let mut sw = SpectralWeights::new(wavelengths_nm, Illuminant1931::D65);
        if let SunSpectrum::Reddened {
            elevation_deg,
            atmosphere,
        } = *self
        {
            for (w, &l) in sw.weights.iter_mut().zip(wavelengths_nm) {
                let t = atmosphere.reddening(l, elevation_deg);
                w.iter_mut().for_each(|c| *c *= t);
            }
        }
        sw
    }
}

/// Which light of an unpolarised sun a renderer follows: all of it (`phase`), or the part
/// polarised perpendicular (`i_perp`) or parallel (`i_par`) to the scattering plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Polarisation {
    Unpolarised,
    Perpendicular,
    Parallel,
}

/// A 1-D phase function (phase contract) at one entry, one polarisation channel.
struct Curves1d(crate::consumers::read::phase::PhaseCurves, Polarisation);

impl SkyPhase for Curves1d {
    fn wavelengths_nm(&self) -> &[f64] {
        &self.0.wavelengths_nm
    }
    fn add_phase(&self, inc: V3, out: V3, spec: &mut [f64]) {
        let th = dot(inc, out).clamp(-1.0, 1.0).acos().to_degrees();
        // All wavelengths share the angle grid: locate once, interpolate each.
        let (j, t) = self.0.locate_angle(th);
        let curves = match self.1 {
            Polarisation::Unpolarised => &self.0.phase,
            Polarisation::Perpendicular => &self.0.i_perp,
            Polarisation::Parallel => &self.0.i_par,
        };
        for (s, p) in spec.iter_mut().zip(curves) {
            *s += p[j] * (1.0 - t) + p[j + 1] * t;
        }
    }
}

/// Sun-disc samples `[sin β, cos β, cos ψ, sin ψ]`: uniform in solid angle within the angular
/// radius α (cos β uniform on [cos α, 1]), stratified in 16 rings × 16 azimuths with rotated
/// offsets; one sample at the centre for a point sun.
pub fn disc_samples(sun_diameter_deg: f64) -> Vec<[f64; 4]> {
    let alpha = 0.5 * sun_diameter_deg.to_radians();
    let (nr, na) = if alpha > 0.0 { (16, 16) } else { (1, 1) };
    let mut disc = Vec::with_capacity(nr * na);
    for a in 0..nr {
        let u = (a as f64 + 0.5) / nr as f64;
        let beta = (1.0 - u * (1.0 - alpha.cos())).acos();
        for b in 0..na {
            let psi =
                2.0 * std::f64::consts::PI * (b as f64 + 0.5 + 0.5 * (a % 2) as f64) / na as f64;
            disc.push([beta.sin(), beta.cos(), psi.cos(), psi.sin()]);
        }
    }
    disc
}

/// The sun-disc average of the spectral phase function for a view ray `view` (unit, pointing
/// away from the camera) and the sun centre `sun` (unit, toward the sun): the mean over the
/// disc samples s′ of p(−s′ → −view), written into `spec` (one value per wavelength).
pub fn disc_average_spectrum(
    phase: &dyn SkyPhase,
    sun: V3,
    view: V3,
    disc: &[[f64; 4]],
    spec: &mut [f64],
) {
    spec.iter_mut().for_each(|s| *s = 0.0);
    // Orthonormal a, b ⊥ sun.
    let helper = if sun[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let a = normalize(cross(helper, sun));
    let b = cross(sun, a);
    let out = [-view[0], -view[1], -view[2]];
    for &[sb, cb, cp, sp] in disc {
        let inc = [0, 1, 2].map(|c| -(cb * sun[c] + sb * (cp * a[c] + sp * b[c])));
        phase.add_phase(inc, out, spec);
    }
    let n = disc.len() as f64;
    spec.iter_mut().for_each(|s| *s /= n);
}

/// XYZ (per unit sun irradiance, D65 sun, sun disc averaged) for each view direction.
pub fn xyz_along(
    phase: &dyn SkyPhase,
    sun: V3,
    views: &[V3],
    sun_diameter_deg: f64,
) -> Vec<[f64; 3]> {
    xyz_along_under(phase, sun, views, sun_diameter_deg, SunSpectrum::D65)
}

/// [`xyz_along`] under any [`SunSpectrum`].
pub fn xyz_along_under(
    phase: &dyn SkyPhase,
    sun: V3,
    views: &[V3],
    sun_diameter_deg: f64,
    spectrum: SunSpectrum,
) -> Vec<[f64; 3]> {
    let sw = spectrum.weights(phase.wavelengths_nm());
    let disc = disc_samples(sun_diameter_deg);
    views
        .par_iter()
        .map_init(
            || vec![0.0; phase.wavelengths_nm().len()],
            |spec, &v| {
                disc_average_spectrum(phase, sun, v, &disc, spec);
                sw.xyz(spec)
            },
        )
        .collect()
}

/// XYZ (per unit sun irradiance, D65 sun, sun disc averaged) as a function of the angle Θ
/// between view direction and sun centre, on a grid of [`THETA_STEP_DEG`] over [0, 180].
pub fn xyz_vs_angle(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: f64,
) -> Result<Vec<[f64; 3]>, ConsumerError> {
    xyz_vs_angle_of(
        pt,
        entry,
        sun_diameter_deg,
        Polarisation::Unpolarised,
        SunSpectrum::D65,
    )
}

/// [`xyz_vs_angle`] of one polarisation channel (`i_perp` or `i_par` instead of `phase`) under
/// any [`SunSpectrum`].
pub fn xyz_vs_angle_of(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: f64,
    polarisation: Polarisation,
    spectrum: SunSpectrum,
) -> Result<Vec<[f64; 3]>, ConsumerError> {
    let c = Curves1d(pt.curves(entry)?, polarisation);
    let n = (180.0 / THETA_STEP_DEG).round() as usize + 1;
    // Sun at the pole, view rays at angle Θ from it: the average depends on Θ only.
    let views: Vec<V3> = (0..n)
        .map(|i| {
            let (s, c) = (i as f64 * THETA_STEP_DEG).to_radians().sin_cos();
            [s, 0.0, c]
        })
        .collect();
    Ok(xyz_along_under(
        &c,
        [0.0, 0.0, 1.0],
        &views,
        sun_diameter_deg,
        spectrum,
    ))
}
