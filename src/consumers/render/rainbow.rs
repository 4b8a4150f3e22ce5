//! Reference renderer `scatterbake render rainbow`: single scattering of sunlight in a
//! homogeneous rain volume, ray-marched along each view ray, spectral over every table
//! wavelength, to sRGB through CIE 1931 2° and a D65 sun (as the rainbow thesis renders, §3.5 and
//! Appendix A). It reads the table only through the public reader API ([`PhaseTable`] on top of
//! `Table::open`/`Table::sample`).
//!
//! World: z up, camera at `camera_height_m` above flat ground, sun at azimuth 0° and elevation
//! `e`, so the direction *toward* the sun is s = (cos e, 0, sin e) and the antisolar point is
//! −s, e below the horizon at azimuth 180°. A view ray with direction d sees light scattered by
//! the angle θ with cos θ = s·d (θ = 180° at the antisolar point, so a bow of radius r around it
//! comes from θ = 180° − r).
//!
//! Rain: a horizontal layer 0 ≤ z ≤ `rain_top_m` beginning at horizontal distance `rain_near_m`
//! from the camera (clear air nearer), extinction σ_t = σ_s (water drops do not absorb visible
//! light noticeably). Single scattering along the view ray, marched with `steps` midpoint steps
//! between entry and exit (top, ground, or 30 km):
//!
//! ```text
//! L_λ(d) = E_λ · P̄_λ(Θ) · Σ_i σ_s e^{−σ_t (t_i − t_in)} e^{−σ_t (top − z_i)/sin e} Δt
//! ```
//!
//! with the sun's path to each point leaving the rain through the layer top or through the
//! shower's sunward edge, the vertical plane x = −`rain_near_m` (the sun shines from behind the
//! camera through clear air; this keeps a horizon sun, e = 0, lighting the rain), whichever is
//! shorter: `(top − z_i)/sin e` vs `(−rain_near − x_i)/cos e`. P̄_λ(Θ) is the phase
//! function averaged over the sun disc (angular diameter `sun_diameter_deg`), Θ the angle
//! between d and the disc centre: the disc is importance-sampled uniformly in solid angle
//! (cos β uniform on [cos α, 1], stratified in 16 rings × 16 azimuths with rotated offsets).
//! For an axisymmetric phase function that average depends on Θ only, so it is computed once per
//! Θ on a 0.01° grid and looked up per pixel (identical result, much cheaper than per pixel).
//! Spectral: XYZ = Σ_k W_k L_k with [`SpectralWeights`](crate::optics::colour::SpectralWeights) under D65 (the sun spectrum), then
//! linear sRGB, exposure, `intensity` and an added `background` sRGB colour (Table 3.4), then the
//! sRGB transfer curve.
//!
//! Lenses: `rectilinear` (pinhole, horizontal `fov_deg`) and `fisheye` (equidistant: the angle
//! from the view axis is proportional to the distance from the image centre, horizontal
//! `fov_deg` across the width) — the thesis does not say which fisheye mapping; we choose the
//! equidistant one because bow radii can then be read off linearly.

use crate::consumers::ConsumerError;
use crate::consumers::read::phase::{EntrySelection, PhaseTable};
pub use crate::consumers::read::spectrum::SunSpectrum;
use crate::consumers::read::spectrum::{
    Polarisation, THETA_STEP_DEG, disc_average_spectrum, disc_samples, xyz_along, xyz_vs_angle_of,
};
use crate::math::vec3::{V3, cross, dot, normalize};
use crate::optics::colour::{linear_srgb_luminance, srgb_encode, xyz_to_linear_srgb};
use crate::progress::Progress;
use rayon::prelude::*;

/// Camera lens model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lens {
    Rectilinear,
    /// Equidistant fisheye.
    Fisheye,
}

impl Lens {
    /// Every lens, by the name a user writes.
    pub const NAMES: [&'static str; 2] = ["rectilinear", "fisheye"];
}

impl std::str::FromStr for Lens {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rectilinear" => Ok(Self::Rectilinear),
            "fisheye" => Ok(Self::Fisheye),
            _ => Err(format!("unknown lens `{s}` (one of {:?})", Self::NAMES)),
        }
    }
}

/// Camera looking toward the antisolar azimuth (180°) with its axis at `view_elevation_deg`.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    pub lens: Lens,
    pub width: usize,
    pub height: usize,
    /// Horizontal field of view (deg).
    pub fov_deg: f64,
    pub view_elevation_deg: f64,
}

impl Camera {
    fn basis(&self) -> (V3, V3, V3) {
        let p = self.view_elevation_deg.to_radians();
        let f = [-p.cos(), 0.0, p.sin()];
        let r = [0.0, 1.0, 0.0]; // f × z normalised, for azimuth 180°: (0, cos p, 0)/cos p
        let u = [
            r[1] * f[2] - r[2] * f[1],
            r[2] * f[0] - r[0] * f[2],
            r[0] * f[1] - r[1] * f[0],
        ];
        (f, r, normalize(u))
    }

    /// World direction through the centre of pixel (i, j) (j = 0 at the top), or `None` outside
    /// the fisheye's 180° half-angle.
    pub fn direction(&self, i: usize, j: usize) -> Option<V3> {
        let (f, r, u) = self.basis();
        let half = 0.5 * self.fov_deg.to_radians();
        let x = 2.0 * (i as f64 + 0.5) / self.width as f64 - 1.0;
        let y = (1.0 - 2.0 * (j as f64 + 0.5) / self.height as f64) * self.height as f64
            / self.width as f64;
        match self.lens {
            Lens::Rectilinear => {
                let t = half.tan();
                Some(normalize([
                    f[0] + t * (x * r[0] + y * u[0]),
                    f[1] + t * (x * r[1] + y * u[1]),
                    f[2] + t * (x * r[2] + y * u[2]),
                ]))
            }
            Lens::Fisheye => {
                let (ax, ay) = (x * half, y * half);
                let rho = (ax * ax + ay * ay).sqrt();
                if rho > std::f64::consts::PI {
                    return None;
                }
                if rho == 0.0 {
                    return Some(f);
                }
                let (s, c) = rho.sin_cos();
                let (cx, cy) = (ax / rho, ay / rho);
                Some([
                    c * f[0] + s * (cx * r[0] + cy * u[0]),
                    c * f[1] + s * (cx * r[1] + cy * u[1]),
                    c * f[2] + s * (cx * r[2] + cy * u[2]),
                ])
            }
        }
    }

    /// Angular size of one pixel at the image centre (deg).
    pub fn pixel_deg(&self) -> f64 {
        match self.lens {
            Lens::Fisheye => self.fov_deg / self.width as f64,
            Lens::Rectilinear => (2.0 * (0.5 * self.fov_deg.to_radians()).tan()
                / self.width as f64)
                .atan()
                .to_degrees(),
        }
    }
}

/// An ideal linear polariser in front of the camera, its transmission axis at `angle_deg` from
/// the image's vertical (0 = vertical, 90 = horizontal, positive toward the image's right).
///
/// Sunlight is unpolarised, so single scattering splits it into light polarised perpendicular
/// to the scattering plane (intensity `i_perp/2`, electric field along `n = s × d`) and parallel
/// to it (`i_par/2`); the polariser passes `i_perp/2 · cos²χ + i_par/2 · sin²χ`, χ the angle
/// between its axis and `n` (Malus). The two halves sum to the unpolarised `phase`, so renders at
/// ψ and ψ + 90° add up to the render without a polariser. At the top of a bow the scattering
/// plane is vertical: a horizontal polariser passes the strongly perpendicular bow light, a
/// vertical one nearly extinguishes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polariser {
    pub angle_deg: f64,
}

impl Polariser {
    /// cos²χ for the view direction `d` (unit) with the sun centre at `sun` (unit, toward the
    /// sun): the fraction of the perpendicular light passed (the parallel light passes 1 − it).
    /// Along the sun–antisolar axis, where the scattering plane is undefined, ½.
    pub fn perpendicular_fraction(&self, camera: &Camera, sun: V3, d: V3) -> f64 {
        let (_, right, up) = camera.basis();
        let n = cross(sun, d);
        let nn = dot(n, n).sqrt();
        if nn < 1e-12 {
            return 0.5;
        }
        // the image's vertical and right at this pixel, perpendicular to d
        let ud = normalize(sub_along(up, d));
        let rd = normalize(sub_along(sub_along(right, d), ud));
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let p = [0, 1, 2].map(|k| c * ud[k] + s * rd[k]);
        (dot(p, n) / nn).powi(2)
    }
}

/// `v` minus its component along the unit vector `u`.
fn sub_along(v: V3, u: V3) -> V3 {
    let a = dot(v, u);
    [0, 1, 2].map(|k| v[k] - a * u[k])
}

/// The rain layer and sun.
#[derive(Debug, Clone, Copy)]
pub struct Scene {
    pub sun_elevation_deg: f64,
    pub sun_diameter_deg: f64,
    pub extinction_per_km: f64,
    pub rain_top_m: f64,
    pub rain_near_m: f64,
    pub camera_height_m: f64,
    pub steps: usize,
    /// The sun's spectrum (D65, or reddened by the air mass of a low sun).
    pub sun_spectrum: SunSpectrum,
}

impl Scene {
    /// Direction toward the sun centre.
    pub fn sun_direction(&self) -> V3 {
        let e = self.sun_elevation_deg.to_radians();
        [e.cos(), 0.0, e.sin()]
    }

    /// Ray-marched single-scattering factor along direction d (per unit sun irradiance and unit
    /// phase function), see the module doc.
    pub fn march(&self, d: V3) -> f64 {
        let sig = self.extinction_per_km * 1e-3;
        let h = self.camera_height_m;
        let horiz = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if horiz < 1e-9 {
            return 0.0;
        }
        let t_in = self.rain_near_m / horiz;
        let mut t_out: f64 = 30_000.0;
        if d[2] > 0.0 {
            t_out = t_out.min((self.rain_top_m - h) / d[2]);
        } else if d[2] < 0.0 {
            t_out = t_out.min(h / -d[2]);
        }
        if t_out <= t_in {
            return 0.0;
        }
        let (sin_e, cos_e) = self.sun_elevation_deg.to_radians().sin_cos();
        let dt = (t_out - t_in) / self.steps as f64;
        let mut acc = 0.0;
        for i in 0..self.steps {
            let t = t_in + (i as f64 + 0.5) * dt;
            let z = (h + t * d[2]).clamp(0.0, self.rain_top_m);
            // Sun path inside the rain: out through the top, or through the shower's sunward
            // edge x = −rain_near, whichever is shorter.
            let up = if sin_e > 1e-9 {
                (self.rain_top_m - z) / sin_e
            } else {
                f64::INFINITY
            };
            let side = if cos_e > 1e-9 {
                (-self.rain_near_m - t * d[0]).max(0.0) / cos_e
            } else {
                f64::INFINITY
            };
            let tau = sig * (t - t_in) + sig * up.min(side);
            acc += sig * (-tau).exp() * dt;
        }
        acc
    }
}

/// A rendered image: linear sRGB (before exposure) per pixel, row-major from the top-left.
pub struct Rendered {
    pub camera: Camera,
    pub linear_srgb: Vec<[f64; 3]>,
}

/// The shared integrator: for every pixel, the ray-marched single-scattering factor times the
/// sun-disc averaged XYZ of the phase function for that view direction (`xyz_of_view`), to
/// linear sRGB.
pub fn render_with(
    scene: &Scene,
    camera: &Camera,
    progress: &dyn Progress,
    xyz_of_view: impl Fn(V3) -> [f64; 3] + Sync,
) -> Rendered {
    progress.start(camera.height as u64, "image rows");
    let mut px = vec![[0.0; 3]; camera.width * camera.height];
    px.par_chunks_mut(camera.width.max(1))
        .enumerate()
        .for_each(|(j, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                let Some(d) = camera.direction(i, j) else {
                    continue;
                };
                let m = scene.march(d);
                if m != 0.0 {
                    *out = xyz_to_linear_srgb(xyz_of_view(d).map(|c| c * m));
                }
            }
            progress.advance(1);
        });
    Rendered {
        camera: *camera,
        linear_srgb: px,
    }
}

/// Linear interpolation of a table of XYZ on the Θ grid of [`THETA_STEP_DEG`] at `big_deg`.
fn xyz_at_angle(xyz: &[[f64; 3]], big_deg: f64) -> [f64; 3] {
    let u = big_deg / THETA_STEP_DEG;
    let k = (u.floor() as usize).min(xyz.len() - 2);
    let t = u - k as f64;
    [0, 1, 2].map(|c| xyz[k][c] * (1.0 - t) + xyz[k + 1][c] * t)
}

/// Render linear sRGB radiance (unit sun irradiance) of a 1-D (axisymmetric) phase table: the
/// disc average depends on the angle to the sun only, so it is precomputed on a Θ grid.
pub fn render(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    scene: &Scene,
    camera: &Camera,
    progress: &dyn Progress,
) -> Result<Rendered, ConsumerError> {
    let xyz = xyz_vs_angle_of(
        pt,
        entry,
        scene.sun_diameter_deg,
        Polarisation::Unpolarised,
        scene.sun_spectrum,
    )?;
    let s = scene.sun_direction();
    Ok(render_with(scene, camera, progress, |d| {
        xyz_at_angle(&xyz, dot(s, d).clamp(-1.0, 1.0).acos().to_degrees())
    }))
}

/// [`render`] through a linear [`Polariser`]: the `i_perp` and `i_par` channels, each averaged
/// over the sun disc like `phase`, weighted per pixel by Malus's law.
pub fn render_polarised(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    scene: &Scene,
    camera: &Camera,
    polariser: Polariser,
    progress: &dyn Progress,
) -> Result<Rendered, ConsumerError> {
    let of = |p| xyz_vs_angle_of(pt, entry, scene.sun_diameter_deg, p, scene.sun_spectrum);
    let (perp, par) = (
        of(Polarisation::Perpendicular)?,
        of(Polarisation::Parallel)?,
    );
    let s = scene.sun_direction();
    Ok(render_with(scene, camera, progress, |d| {
        let big = dot(s, d).clamp(-1.0, 1.0).acos().to_degrees();
        let f = polariser.perpendicular_fraction(camera, s, d);
        let (a, b) = (xyz_at_angle(&perp, big), xyz_at_angle(&par, big));
        [0, 1, 2].map(|c| 0.5 * (f * a[c] + (1.0 - f) * b[c]))
    }))
}

/// [`render_2d`] through a linear [`Polariser`], from the `i_perp` and `i_par` slices of the
/// table (same elevation and entry).
pub fn render_2d_polarised(
    perp: &crate::consumers::read::phase2d::PhaseSlice,
    par: &crate::consumers::read::phase2d::PhaseSlice,
    scene: &Scene,
    camera: &Camera,
    polariser: Polariser,
    progress: &dyn Progress,
) -> Result<Rendered, ConsumerError> {
    let sw = scene.sun_spectrum.weights(&perp.wavelengths_nm);
    let disc = disc_samples(scene.sun_diameter_deg);
    let s = scene.sun_direction();
    let nw = perp.wavelengths_nm.len();
    Ok(render_with(scene, camera, progress, |d| {
        let (mut a, mut b) = (vec![0.0; nw], vec![0.0; nw]);
        disc_average_spectrum(perp, s, d, &disc, &mut a);
        disc_average_spectrum(par, s, d, &disc, &mut b);
        let f = polariser.perpendicular_fraction(camera, s, d);
        let (xa, xb) = (sw.xyz(&a), sw.xyz(&b));
        [0, 1, 2].map(|c| 0.5 * (f * xa[c] + (1.0 - f) * xb[c]))
    }))
}

/// Render a 2-D ray-traced table slice (drops with vertical symmetry axis, sun at the slice's
/// elevation, which must equal `scene.sun_elevation_deg`): the disc average is evaluated per
/// pixel with the same disc samples and spectral weights as the 1-D path.
pub fn render_2d(
    slice: &crate::consumers::read::phase2d::PhaseSlice,
    scene: &Scene,
    camera: &Camera,
    progress: &dyn Progress,
) -> Result<Rendered, ConsumerError> {
    if !((slice.sun_elevation_deg - scene.sun_elevation_deg).abs() < 1e-9) {
        return Err(ConsumerError::invalid(format!(
            "slice at sun elevation {} deg, scene at {} deg",
            slice.sun_elevation_deg, scene.sun_elevation_deg
        )));
    }
    let sw = scene.sun_spectrum.weights(&slice.wavelengths_nm);
    let disc = disc_samples(scene.sun_diameter_deg);
    let s = scene.sun_direction();
    let nw = slice.wavelengths_nm.len();
    Ok(render_with(scene, camera, progress, |d| {
        let mut spec = vec![0.0; nw];
        disc_average_spectrum(slice, s, d, &disc, &mut spec);
        sw.xyz(&spec)
    }))
}

/// Disc-averaged luminance maximum of a 2-D slice along the vertical plane through the sun and
/// the antisolar point (the image's centre column): radius (deg from the antisolar point) in
/// `[lo, hi]` above the antisolar point — what the image measurement should reproduce.
pub fn table_bow_radius_2d(
    slice: &crate::consumers::read::phase2d::PhaseSlice,
    sun_diameter_deg: f64,
    lo_deg: f64,
    hi_deg: f64,
) -> f64 {
    let e = slice.sun_elevation_deg;
    let n = ((hi_deg - lo_deg) / THETA_STEP_DEG).round() as usize + 1;
    let radii: Vec<f64> = (0..n).map(|i| lo_deg + i as f64 * THETA_STEP_DEG).collect();
    let views: Vec<V3> = radii
        .iter()
        .map(|r| {
            let (s, c) = (r - e).to_radians().sin_cos();
            [-c, 0.0, s]
        })
        .collect();
    let sun = {
        let (s, c) = e.to_radians().sin_cos();
        [c, 0.0, s]
    };
    let xyz = xyz_along(slice, sun, &views, sun_diameter_deg);
    let mut best = (f64::NEG_INFINITY, f64::NAN);
    for (r, v) in radii.iter().zip(&xyz) {
        if v[1] > best.0 {
            best = (v[1], *r);
        }
    }
    best.1
}

/// Exposure that maps the 99.5th percentile of luminance (Y) to 0.9.
pub fn auto_exposure(img: &[[f64; 3]]) -> f64 {
    let mut y: Vec<f64> = img
        .iter()
        .map(|&p| linear_srgb_luminance(p))
        .filter(|v| *v > 0.0)
        .collect();
    if y.is_empty() {
        return 1.0;
    }
    let k = ((y.len() as f64 * 0.995) as usize).min(y.len() - 1);
    let (_, v, _) = y.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    if *v > 0.0 { 0.9 / *v } else { 1.0 }
}

/// Encode as 8-bit sRGB: `encode(exposure · intensity · linear) + background/255`, clamped.
pub fn to_srgb8(img: &[[f64; 3]], exposure: f64, intensity: f64, background: [u8; 3]) -> Vec<u8> {
    img.iter()
        .flat_map(|p| {
            (0..3).map(move |c| {
                let v = srgb_encode(p[c] * exposure * intensity) + background[c] as f64 / 255.0;
                (v.clamp(0.0, 1.0) * 255.0).round() as u8
            })
        })
        .collect()
}

/// Bow measurement along the image column through the antisolar point (fisheye only, where
/// the vertical centre line maps angle linearly): radius (deg from the antisolar point) of the
/// luminance maximum within `[lo, hi]` deg, and of each sRGB channel's maximum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BowMeasurement {
    pub radius_deg: f64,
    pub radius_rgb_deg: [f64; 3],
}

/// The centre column of an equidistant fisheye render as (radius from the antisolar point in
/// deg, linear sRGB) per pixel row, from the lens definition alone (centre column elevation =
/// view elevation + (H/2 − j − ½)·pixel), independent of the renderer's ray generation; `None`
/// for other lenses. When the width is even the column centre sits half a pixel off the
/// azimuth-180° axis; the angular offset is below 0.25 px, negligible.
pub fn centre_column(r: &Rendered, sun_elevation_deg: f64) -> Option<Vec<(f64, [f64; 3])>> {
    let cam = &r.camera;
    if cam.lens != Lens::Fisheye {
        return None;
    }
    let pix = cam.pixel_deg();
    Some(
        (0..cam.height)
            .map(|j| {
                let elev =
                    cam.view_elevation_deg + (cam.height as f64 / 2.0 - j as f64 - 0.5) * pix;
                (
                    elev + sun_elevation_deg,
                    r.linear_srgb[j * cam.width + cam.width / 2],
                )
            })
            .collect(),
    )
}

/// Mean luminance (linear sRGB Y) of the centre column of an equidistant fisheye render over
/// radii `[lo_deg, hi_deg]` from the antisolar point (same lens mapping as [`measure_bow`]);
/// `None` for other lenses or when no pixel falls in the range.
pub fn column_mean_luminance(
    r: &Rendered,
    sun_elevation_deg: f64,
    lo_deg: f64,
    hi_deg: f64,
) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0usize);
    for (radius, q) in centre_column(r, sun_elevation_deg)? {
        if (lo_deg..=hi_deg).contains(&radius) {
            sum += linear_srgb_luminance(q);
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// Measure a bow in `[lo_deg, hi_deg]` from the antisolar point along the centre column of an
/// equidistant fisheye render (see [`centre_column`]): radius of the luminance maximum and of
/// each sRGB channel's maximum.
pub fn measure_bow(
    r: &Rendered,
    sun_elevation_deg: f64,
    lo_deg: f64,
    hi_deg: f64,
) -> Option<BowMeasurement> {
    let mut best = [(f64::NEG_INFINITY, f64::NAN); 4];
    for (radius, p) in centre_column(r, sun_elevation_deg)? {
        if radius < lo_deg || radius > hi_deg {
            continue;
        }
        let vals = [linear_srgb_luminance(p), p[0], p[1], p[2]];
        for c in 0..4 {
            if vals[c] > best[c].0 {
                best[c] = (vals[c], radius);
            }
        }
    }
    if best[0].1.is_nan() {
        return None;
    }
    Some(BowMeasurement {
        radius_deg: best[0].1,
        radius_rgb_deg: [best[1].1, best[2].1, best[3].1],
    })
}

/// Radii of the prominent local maxima of `(radius, value)` samples (sorted by radius) in
/// `[lo_deg, hi_deg]`, by topographic prominence: from a local maximum, walk left and right
/// until a higher sample (or the window's end); the higher of the two lowest values met is its
/// floor, and the maximum counts when it exceeds the floor by the factor `1 + prominence` (so
/// the Mie ripple and pixel noise on a fringe do not count as fringes). Used to locate
/// supernumerary fringes.
pub fn prominent_maxima(
    samples: &[(f64, f64)],
    lo_deg: f64,
    hi_deg: f64,
    prominence: f64,
) -> Vec<f64> {
    let v: Vec<(f64, f64)> = samples
        .iter()
        .copied()
        .filter(|(r, _)| (lo_deg..=hi_deg).contains(r))
        .collect();
    let n = v.len();
    let mut out = Vec::new();
    for i in 1..n.saturating_sub(1) {
        let y = v[i].1;
        if !(y > v[i - 1].1 && y >= v[i + 1].1) {
            continue;
        }
        let mut left = f64::INFINITY;
        for p in v[..i].iter().rev() {
            if p.1 > y {
                break;
            }
            left = left.min(p.1);
        }
        let mut right = f64::INFINITY;
        for p in &v[i + 1..] {
            if p.1 > y {
                break;
            }
            right = right.min(p.1);
        }
        if y > (1.0 + prominence) * left.max(right).min(y) && left.max(right).is_finite() {
            out.push(v[i].0);
        }
    }
    out
}

/// Radius (deg from the antisolar point, 180° − θ) of the luminance maximum of the
/// disc-averaged table in `[lo, hi]` — what the image measurement should reproduce.
pub fn table_bow_radius(xyz: &[[f64; 3]], lo_deg: f64, hi_deg: f64) -> f64 {
    let mut best = (f64::NEG_INFINITY, f64::NAN);
    for (i, v) in xyz.iter().enumerate() {
        let r = 180.0 - i as f64 * THETA_STEP_DEG;
        if r >= lo_deg && r <= hi_deg && v[1] > best.0 {
            best = (v[1], r);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::peak_table;
    use crate::progress::Silent;

    fn cam() -> Camera {
        Camera {
            lens: Lens::Fisheye,
            width: 240,
            height: 160,
            fov_deg: 120.0,
            view_elevation_deg: 5.0,
        }
    }

    fn scene(disc: f64) -> Scene {
        Scene {
            sun_elevation_deg: 25.0,
            sun_diameter_deg: disc,
            extinction_per_km: 0.5,
            rain_top_m: 1500.0,
            rain_near_m: 300.0,
            camera_height_m: 1.7,
            steps: 32,
            sun_spectrum: SunSpectrum::D65,
        }
    }

    /// Counts what a render reports.
    #[derive(Default)]
    struct Counting {
        total: std::sync::atomic::AtomicU64,
        done: std::sync::atomic::AtomicU64,
    }

    impl Progress for Counting {
        fn start(&self, total: u64, _what: &str) {
            self.total
                .store(total, std::sync::atomic::Ordering::Relaxed);
        }
        fn advance(&self, n: u64) {
            self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
    }

    #[test]
    fn render_reports_every_row_once() {
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let pt = PhaseTable::new(peak_table(&wl, |_| 138.0, 0.2, 1e-4, 3601)).unwrap();
        let p = Counting::default();
        render(&pt, &[], &scene(0.5), &cam(), &p).unwrap();
        let rows = cam().height as u64;
        assert_eq!(p.total.load(std::sync::atomic::Ordering::Relaxed), rows);
        assert_eq!(p.done.load(std::sync::atomic::Ordering::Relaxed), rows);
    }

    /// Malus per pixel: renders through crossed polarisers add up to the unpolarised render,
    /// and at the top of the bow (vertical scattering plane) a vertical polariser passes the
    /// table's i_par, a horizontal one its i_perp.
    #[test]
    fn polariser_follows_malus_and_the_scattering_plane() {
        let wl: Vec<f64> = (0..9).map(|i| 380.0 + 40.0 * i as f64).collect();
        let pt = PhaseTable::new(peak_table(&wl, |_| 138.0, 0.3, 1e-4, 3601)).unwrap();
        let (sc, c) = (scene(0.0), cam());
        let plain = render(&pt, &[], &sc, &c, &Silent).unwrap();
        let pol = |a: f64| {
            render_polarised(&pt, &[], &sc, &c, Polariser { angle_deg: a }, &Silent).unwrap()
        };
        let (v, h, d45, d135) = (pol(0.0), pol(90.0), pol(45.0), pol(135.0));
        let mut worst: f64 = 0.0;
        for k in 0..plain.linear_srgb.len() {
            for ch in 0..3 {
                let p = plain.linear_srgb[k][ch];
                for (x, y) in [(&v, &h), (&d45, &d135)] {
                    let s = x.linear_srgb[k][ch] + y.linear_srgb[k][ch];
                    worst = worst.max((s - p).abs() / p.abs().max(1e-12));
                }
            }
        }
        // phase and (i_perp + i_par)/2 are stored separately as f32
        assert!(worst < 1e-6, "crossed polarisers do not add up: {worst}");
        // top of the bow: centre column, the pixel nearest 42° above the antisolar point
        let col = |r: &Rendered| centre_column(r, 25.0).unwrap();
        let (cv, ch) = (col(&v), col(&h));
        let j = (0..cv.len())
            .min_by(|&a, &b| (cv[a].0 - 42.0).abs().total_cmp(&(cv[b].0 - 42.0).abs()))
            .unwrap();
        let lum = |p: [f64; 3]| linear_srgb_luminance(p);
        let ratio = lum(cv[j].1) / lum(ch[j].1);
        let curves = pt.curves(&[]).unwrap();
        let (i, _) = curves.locate_angle(138.0);
        let k = curves.wavelengths_nm.len() / 2;
        let expected = curves.i_par[k][i] / curves.i_perp[k][i];
        assert!(expected < 0.9, "the synthetic bow is polarised: {expected}");
        assert!(
            (ratio - expected).abs() < 0.05 * expected,
            "vertical/horizontal {ratio} vs i_par/i_perp {expected}"
        );
    }

    /// A sun 2° above the horizon through a clear atmosphere: the same bow, redder (R/B of the
    /// bow pixel up by the transmission ratio's order) and dimmer than under D65.
    #[test]
    fn reddened_sun_renders_a_red_dim_bow() {
        let wl: Vec<f64> = (0..9).map(|i| 380.0 + 40.0 * i as f64).collect();
        let pt = PhaseTable::new(peak_table(&wl, |_| 138.0, 0.3, 1e-4, 3601)).unwrap();
        let low = Scene {
            sun_elevation_deg: 2.0,
            ..scene(0.0)
        };
        let red = Scene {
            sun_spectrum: SunSpectrum::Reddened {
                elevation_deg: 2.0,
                atmosphere: crate::optics::atmosphere::ClearAtmosphere::CLEAN,
            },
            ..low
        };
        let c = Camera {
            view_elevation_deg: 20.0,
            ..cam()
        };
        let (a, b) = (
            render(&pt, &[], &low, &c, &Silent).unwrap(),
            render(&pt, &[], &red, &c, &Silent).unwrap(),
        );
        let bow = |r: &Rendered| {
            let col = centre_column(r, 2.0).unwrap();
            let j = (0..col.len())
                .min_by(|&x, &y| (col[x].0 - 42.0).abs().total_cmp(&(col[y].0 - 42.0).abs()))
                .unwrap();
            col[j].1
        };
        let (pa, pb) = (bow(&a), bow(&b));
        assert!(pa[0] > 0.0 && pa[2] > 0.0 && pb[0] > 0.0, "{pa:?} {pb:?}");
        let (ra, rb) = (pa[0] / pa[2].max(1e-300), pb[0] / pb[2].max(1e-300));
        assert!(rb > 5.0 * ra, "R/B under D65 {ra}, reddened {rb}");
        assert!(
            linear_srgb_luminance(pb) < 0.5 * linear_srgb_luminance(pa),
            "{pa:?} {pb:?}"
        );
    }

    #[test]
    fn peak_at_138_deg_renders_ring_of_42_deg() {
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let pt = PhaseTable::new(peak_table(&wl, |_| 138.0, 0.2, 1e-4, 3601)).unwrap();
        let r = render(&pt, &[], &scene(0.5), &cam(), &Silent).unwrap();
        let m = measure_bow(&r, 25.0, 30.0, 60.0).unwrap();
        let pix = cam().pixel_deg();
        assert!((m.radius_deg - 42.0).abs() <= pix, "{m:?}, pixel {pix}");
        // Ring, not a blob: in every direction around the antisolar point the brightest pixel
        // within 30°–60° lies at 42° (directions from the camera model; 8 azimuths).
        let s = scene(0.5).sun_direction();
        let mut by_angle: Vec<(f64, f64)> = vec![];
        for j in 0..160 {
            for i in 0..240 {
                if let Some(d) = cam().direction(i, j) {
                    let rad = 180.0 - dot(s, d).clamp(-1.0, 1.0).acos().to_degrees();
                    let p = r.linear_srgb[j * 240 + i];
                    by_angle.push((rad, p[0] + p[1] + p[2]));
                }
            }
        }
        let bright: Vec<&(f64, f64)> = by_angle.iter().filter(|(_, v)| *v > 0.0).collect();
        let max = bright.iter().map(|x| x.1).fold(0.0, f64::max);
        for (rad, v) in &bright {
            if *v > 0.5 * max {
                assert!((rad - 42.0).abs() < 1.0, "bright pixel at radius {rad}");
            }
        }
    }

    #[test]
    fn primary_and_secondary_colour_order_and_dark_band() {
        // Dispersive synthetic table: primary at θ = 137.6° (red, 700 nm) … 139.4° (violet, 400
        // nm) — red outside; secondary at 129.9° (red) … 126.6° (violet) — red inside; plus a
        // bright region inside the primary (θ > 140°) and a floor; the Alexander band between.
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let mut t = peak_table(&wl, |l| 139.4 - 1.8 * (l - 400.0) / 300.0, 0.25, 0.0, 3601);
        let sec = peak_table(&wl, |l| 126.6 + 3.3 * (l - 400.0) / 300.0, 0.35, 0.0, 3601);
        // Combine: p = primary + 0.4·secondary + inside glow for θ > 140°, rebuilt through
        // TableContent so the table stays a valid contract table.
        for (k, v) in t.data.chunks_mut(4).enumerate() {
            let j = k % 3601;
            let theta = j as f64 * 0.05;
            let glow = if theta > 140.0 { 2e-3 } else { 1e-4 };
            let s = sec.data[k * 4] as f64;
            let p = v[0] as f64 + 0.4 * s + glow;
            v[0] = p as f32;
            v[1] = p as f32;
            v[2] = p as f32;
            v[3] = 0.0;
        }
        let pt = PhaseTable::new(t).unwrap();
        let r = render(&pt, &[], &scene(0.5), &cam(), &Silent).unwrap();
        let pix = cam().pixel_deg();
        let p = measure_bow(&r, 25.0, 36.0, 46.0).unwrap();
        let s = measure_bow(&r, 25.0, 47.0, 58.0).unwrap();
        // Primary: red channel peaks outside blue; secondary reversed.
        assert!(p.radius_rgb_deg[0] > p.radius_rgb_deg[2], "{p:?}");
        assert!(s.radius_rgb_deg[0] < s.radius_rgb_deg[2], "{s:?}");
        // Radii against the geometry: red primary at 180 − 137.6 = 42.4°, violet-blue side
        // near 40.8°; secondary red at 50.1°.
        assert!((p.radius_rgb_deg[0] - 42.2).abs() < 2.0 * pix, "{p:?}");
        assert!((s.radius_rgb_deg[0] - 50.3).abs() < 2.0 * pix, "{s:?}");
        // Alexander's dark band: mean luminance at radii 44–48° below that at 30–38°.
        let mean = |lo: f64, hi: f64| column_mean_luminance(&r, 25.0, lo, hi).unwrap();
        assert!(mean(44.0, 48.0) < 0.5 * mean(30.0, 38.0));
    }

    /// The scene of the 2-D tests: horizon sun (the tables' own elevation), so the bow's sides
    /// (at the horizon) are in the rain and visible.
    fn horizon_scene(disc: f64) -> Scene {
        Scene {
            sun_elevation_deg: 0.0,
            ..scene(disc)
        }
    }

    fn horizon_cam() -> Camera {
        Camera {
            view_elevation_deg: 25.5,
            ..cam()
        }
    }

    fn luminance(p: [f64; 3]) -> f64 {
        linear_srgb_luminance(p)
    }

    fn dispersive_1d() -> crate::table::Table {
        let wl: Vec<f64> = (0..5).map(|i| 450.0 + 50.0 * i as f64).collect();
        peak_table(&wl, |l| 139.4 - 1.8 * (l - 400.0) / 300.0, 0.25, 1e-3, 3601)
    }

    fn slice_of(t: crate::table::Table, e: f64) -> crate::consumers::read::phase2d::PhaseSlice {
        let t2 = crate::consumers::read::phase2d::Phase2dTable::new(t).unwrap();
        t2.slice(t2.resolve_elevation(Some(e)).unwrap(), &[], "phase")
            .unwrap()
    }

    #[test]
    fn sphere_as_2d_table_renders_the_same_bow_as_1d() {
        let t1 = dispersive_1d();
        let t2 = crate::fixtures::lat_long_from_1d(&t1, &[0.0, 10.0], 10.0, |_, _| 1.0);
        let pt = PhaseTable::new(t1).unwrap();
        let (sc, cam) = (horizon_scene(0.5), horizon_cam());
        let r1 = render(&pt, &[], &sc, &cam, &Silent).unwrap();
        let r2 = render_2d(&slice_of(t2, 0.0), &sc, &cam, &Silent).unwrap();
        let pix = cam.pixel_deg();
        let m1 = measure_bow(&r1, 0.0, 36.0, 46.0).unwrap();
        let m2 = measure_bow(&r2, 0.0, 36.0, 46.0).unwrap();
        let xyz = crate::consumers::read::spectrum::xyz_vs_angle(&pt, &[], 0.5).unwrap();
        let t_max = table_bow_radius(&xyz, 36.0, 46.0);
        assert!(
            (m1.radius_deg - m2.radius_deg).abs() <= pix,
            "{m1:?} {m2:?}"
        );
        assert!(
            (m2.radius_deg - t_max).abs() <= pix,
            "{m2:?} vs table {t_max}"
        );
        for c in 0..3 {
            assert!(
                (m1.radius_rgb_deg[c] - m2.radius_rgb_deg[c]).abs() <= pix,
                "{m1:?} {m2:?}"
            );
        }
        // Pixel by pixel: the same radiance (interpolation differences only).
        let max = r1
            .linear_srgb
            .iter()
            .map(|p| luminance(*p))
            .fold(0.0, f64::max);
        for (a, b) in r1.linear_srgb.iter().zip(&r2.linear_srgb) {
            assert!(
                (luminance(*a) - luminance(*b)).abs() < 0.02 * max,
                "{a:?} {b:?}"
            );
        }
        // Elevations outside the table's axis are refused with the range in the message.
        let t3 =
            crate::fixtures::lat_long_from_1d(&dispersive_1d(), &[0.0, 10.0], 10.0, |_, _| 1.0);
        let t3 = crate::consumers::read::phase2d::Phase2dTable::new(t3).unwrap();
        let err = t3.resolve_elevation(Some(25.0)).unwrap_err().to_string();
        assert!(err.contains("[0, 10]"), "{err}");
        assert_eq!(t3.resolve_elevation(None).unwrap(), 0.0);
    }

    #[test]
    fn azimuth_dependent_table_maps_to_the_sky_as_documented() {
        use crate::consumers::read::phase2d::table_angles;
        let (sc, cam) = (horizon_scene(0.0), horizon_cam());
        let t1 = dispersive_1d();
        let r1 = render(
            &PhaseTable::new(t1.clone()).unwrap(),
            &[],
            &sc,
            &cam,
            &Silent,
        )
        .unwrap();
        let f_sym = |_: f64, phi: f64| 1.0 + 0.8 * phi.to_radians().cos();
        let f_asym = |_: f64, phi: f64| 1.0 + 0.5 * phi.to_radians().sin();
        let sym = crate::fixtures::lat_long_from_1d(&t1, &[0.0], 10.0, f_sym);
        let asym = crate::fixtures::lat_long_from_1d(&t1, &[0.0], 10.0, f_asym);
        let rs = render_2d(&slice_of(sym, 0.0), &sc, &cam, &Silent).unwrap();
        let ra = render_2d(&slice_of(asym, 0.0), &sc, &cam, &Silent).unwrap();
        let (w, h) = (cam.width, cam.height);
        let max = r1
            .linear_srgb
            .iter()
            .map(|p| luminance(*p))
            .fold(0.0, f64::max);
        let s = sc.sun_direction();
        let (mut top, mut side, mut n) = (f64::NAN, f64::NAN, 0);
        for j in 0..h {
            for i in 0..w {
                let y1 = luminance(r1.linear_srgb[j * w + i]);
                if y1 < 0.3 * max {
                    continue;
                }
                n += 1;
                // Every bright pixel: 2-D / 1-D = the factor at the pixel's outgoing azimuth
                // (point sun: incident −s, outgoing −d).
                let d = cam.direction(i, j).unwrap();
                let (_, phi) = table_angles([-s[0], -s[1], -s[2]], [-d[0], -d[1], -d[2]]);
                let rs_ = luminance(rs.linear_srgb[j * w + i]) / y1;
                let ra_ = luminance(ra.linear_srgb[j * w + i]) / y1;
                assert!(
                    (rs_ - f_sym(0.0, phi)).abs() < 0.01,
                    "({i},{j}) φ {phi}: {rs_}"
                );
                assert!(
                    (ra_ - f_asym(0.0, phi)).abs() < 0.01,
                    "({i},{j}) φ {phi}: {ra_}"
                );
                if i == w / 2 {
                    top = rs_;
                }
                if d[2].abs() < 0.03 && d[1] > 0.0 {
                    side = rs_;
                }
            }
        }
        assert!(n > 100, "{n} bright pixels");
        // Top of the bow = light scattered downward (φ = 180°): factor 0.2; its sides (at the
        // horizon, φ = 90°/270°): factor 1.
        assert!(
            (top - 0.2).abs() < 0.02 && (side - 1.0).abs() < 0.03,
            "{top} {side}"
        );
        // φ ↔ −φ symmetric table → left–right mirror-symmetric image; the antisymmetric part
        // (sin φ) brightens the left half (φ = 90°, outgoing +y, seen looking toward −y).
        let (mut left, mut right) = (0.0, 0.0);
        for j in 0..h {
            for i in 0..w / 2 {
                let (a, b) = (rs.linear_srgb[j * w + i], rs.linear_srgb[j * w + w - 1 - i]);
                for c in 0..3 {
                    assert!(
                        (a[c] - b[c]).abs() <= 1e-9 * max + 1e-6 * a[c].abs(),
                        "({i},{j}) {a:?} {b:?}"
                    );
                }
                left += luminance(ra.linear_srgb[j * w + i]);
                right += luminance(ra.linear_srgb[j * w + w - 1 - i]);
            }
        }
        assert!(left > 1.5 * right, "{left} {right}");
    }

    /// Fringe finder: the maxima of a cosine fringe pattern are found, a 0.5 % ripple on top
    /// is not counted, and the window is respected.
    #[test]
    fn prominent_maxima_find_fringes_not_ripple() {
        let samples: Vec<(f64, f64)> = (0..=1000)
            .map(|i| {
                let r = 30.0 + 0.01 * i as f64;
                let fringe = 1.5 + (2.0 * std::f64::consts::PI * (r - 30.0) / 2.0).cos();
                let ripple = 1.0 + 0.005 * (2.0 * std::f64::consts::PI * r / 0.07).sin();
                (r, fringe * ripple)
            })
            .collect();
        let m = prominent_maxima(&samples, 31.0, 39.0, 0.02);
        assert_eq!(m.len(), 4, "{m:?}");
        for (k, r) in m.iter().enumerate() {
            assert!((r - (32.0 + 2.0 * k as f64)).abs() < 0.05, "{m:?}");
        }
    }
}
