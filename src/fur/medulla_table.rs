//! The fur medulla tables as tables: their axes and channels, the packing of one entry's
//! profile into a row (lobe pdf and cdf for the longitudinal family), the mirroring of rows
//! with a negative entry, and the header that states the conventions. Every method (Monte
//! Carlo [`super::medulla`], adaptive [`super::medulla_fast`], characteristics
//! [`super::disc`], adding–doubling [`super::slab`]) is packed and laid out by this code, so
//! the layouts are identical.
//!
//! Layouts (row-major, channel innermost):
//! - azimuthal `fur-medulla-azimuthal/1`: axes `sigma` × `g` × `h` × `phi` (bins), channels
//!   `energy`, `path_length`, `std_error`;
//! - longitudinal `fur-medulla-longitudinal/1`: axes `sigma` × `g` × `theta_i` × `lobe` (0
//!   back, 1 forward) × `theta_r` (bins/2), channels `pdf`, `cdf`, `energy`, `path_length`,
//!   `std_error`.
//!
//! Per-entry scalars (ballistic and scattered fractions, the standard error of the latter,
//! lobe energies) are stored in the attributes as flat row-major arrays over (σ, g, entry).
//! What each method writes about itself in the header: [`super::medulla_headers`].

use super::medulla::{Geometry, McSettings, Profile, normalise_lobes, simulate};
use crate::table::{Axis, Channel, Schema, TableContent};
use serde_json::{Map, Value};

/// The two families of medulla tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// C^N(φ'; h', σ, g): the unit disc entered at offset h'.
    Azimuthal,
    /// C^M(θ'_r; θ'_i, σ, g): the slab of thickness 2 entered at inclination θ'_i.
    Longitudinal,
}

/// σ used to compute the σ → 0 limit *shape* of the normalised longitudinal lobes.
pub const SIGMA_LIMIT: f64 = 1e-9;

/// One entry's packed row: its values (bins × channels) and its scalars.
pub type PackedRow = (Vec<f32>, Vec<f32>);

/// The grid of a medulla table: σ × g × entries (h' or θ'_i in degrees) × exit bins.
#[derive(Debug, Clone, PartialEq)]
pub struct MedullaLayout {
    pub family: Family,
    /// Exit bins over [−π, π) (azimuthal) or over both faces, bins/2 per lobe (longitudinal).
    pub bins: usize,
    /// Scattering coefficients per unit medulla radius.
    pub sigma: Vec<f64>,
    /// Planar Henyey–Greenstein anisotropies.
    pub g: Vec<f64>,
    /// Entry offsets h' (azimuthal) or inclinations θ'_i in degrees (longitudinal).
    pub entries: Vec<f64>,
}

impl MedullaLayout {
    /// σ × g × h × φ (azimuthal) or σ × g × θ_i × lobe × θ_r (longitudinal).
    pub fn axes(&self) -> Vec<Axis> {
        let b = self.bins;
        let dw_deg = 360.0 / b as f64;
        let mut axes = vec![
            Axis::values("sigma", "1/medulla_radius", self.sigma.clone()),
            Axis::values("g", "1", self.g.clone()),
        ];
        match self.family {
            Family::Azimuthal => axes.extend([
                Axis::values("h", "1", self.entries.clone()),
                Axis::uniform("phi", "deg", -180.0 + 0.5 * dw_deg, dw_deg, b),
            ]),
            Family::Longitudinal => axes.extend([
                Axis::values("theta_i", "deg", self.entries.clone()),
                Axis::values("lobe", "1", vec![0.0, 1.0]),
                Axis::uniform("theta_r", "deg", -90.0 + 0.5 * dw_deg, dw_deg, b / 2),
            ]),
        }
        axes
    }

    /// Channels per bin.
    pub fn channels(&self) -> usize {
        match self.family {
            Family::Azimuthal => 3,
            Family::Longitudinal => 5,
        }
    }

    /// Scalars per entry.
    pub fn scalars(&self) -> usize {
        match self.family {
            Family::Azimuthal => 3,    // ballistic, scattered, scattered_se
            Family::Longitudinal => 5, // ballistic, scattered, scattered_se, back, forward
        }
    }

    /// Values and scalars of one (σ, g) pair: every entry's row and scalars.
    pub fn pair_len(&self) -> (usize, usize) {
        let n = self.entries.len();
        (n * self.bins * self.channels(), n * self.scalars())
    }

    /// The geometry of entry coordinate `x`.
    pub fn geometry(&self, x: f64) -> Geometry {
        match self.family {
            Family::Azimuthal => Geometry::Azimuthal { h: x },
            Family::Longitudinal => Geometry::Longitudinal {
                theta_i_rad: x.to_radians(),
            },
        }
    }

    /// Index of the mirror entry if it exists and is > 0 (negative rows are mirrored).
    pub fn mirror_source(&self, i: usize) -> Option<usize> {
        let x = self.entries[i];
        if x >= 0.0 {
            return None;
        }
        self.entries.iter().position(|&y| y == -x)
    }

    fn mirror_bin(&self, k: usize) -> usize {
        let b = self.bins;
        match self.family {
            Family::Azimuthal => b - 1 - k,
            Family::Longitudinal => {
                let half = b / 2;
                if k < half {
                    half - 1 - k
                } else {
                    half + (b - 1 - k)
                }
            }
        }
    }

    /// The Monte Carlo row of entry `x` at (σ, g) with settings `s` (whose bins are the
    /// layout's).
    pub fn monte_carlo_row(&self, sigma: f64, g: f64, x: f64, s: &McSettings) -> PackedRow {
        let geom = self.geometry(x);
        let prof: Profile = simulate(sigma, g, geom, s);
        self.pack_row(sigma, &prof, || simulate(SIGMA_LIMIT, g, geom, s).energy)
    }

    /// Row values and scalars of a computed profile; `limit_shape` gives the σ → 0 lobe shape
    /// (any scale) stored in the longitudinal pdf/cdf at σ = 0.
    pub fn pack_row(
        &self,
        sigma: f64,
        prof: &Profile,
        limit_shape: impl FnOnce() -> Vec<f64>,
    ) -> PackedRow {
        let b = self.bins;
        let mut v = Vec::with_capacity(b * self.channels());
        let mut scalars = vec![
            prof.ballistic as f32,
            prof.scattered as f32,
            prof.scattered_std_error as f32,
        ];
        match self.family {
            Family::Azimuthal => {
                for k in 0..b {
                    v.extend([
                        prof.energy[k] as f32,
                        prof.path_length[k] as f32,
                        prof.std_error[k] as f32,
                    ]);
                }
            }
            Family::Longitudinal => {
                // Lobe shapes: for σ = 0 the stored pdf/cdf are the σ → 0 limit (energy stays 0).
                let (pdf, cdf) = if sigma > 0.0 {
                    normalise_lobes(&prof.energy)
                } else {
                    normalise_lobes(&limit_shape())
                };
                for k in 0..b {
                    v.extend([
                        pdf[k] as f32,
                        cdf[k] as f32,
                        prof.energy[k] as f32,
                        prof.path_length[k] as f32,
                        prof.std_error[k] as f32,
                    ]);
                }
                let back: f64 = prof.energy[..b / 2].iter().sum();
                let fwd: f64 = prof.energy[b / 2..].iter().sum();
                scalars.extend([back as f32, fwd as f32]);
            }
        }
        (v, scalars)
    }

    /// The values and scalars of one (σ, g) pair: every entry row in order (negative rows
    /// mirrored from their positive source, which `rows` holds; mirrored rows are `None`) and
    /// the per-entry scalars.
    pub fn pair(&self, rows: &[Option<PackedRow>]) -> (Vec<f32>, Vec<f64>) {
        let n = self.entries.len();
        let (b, c) = (self.bins, self.channels());
        let mut data = Vec::with_capacity(n * b * c);
        let mut scalars = Vec::with_capacity(n * self.scalars());
        for i in 0..n {
            let sc = match (&rows[i], self.mirror_source(i)) {
                (Some((v, sc)), _) => {
                    data.extend_from_slice(v);
                    sc
                }
                (None, Some(src)) => {
                    let (v, sc) = rows[src].as_ref().expect("mirror source computed");
                    self.push_mirrored(v, &mut data);
                    sc
                }
                (None, None) => unreachable!("a row that is not mirrored is computed"),
            };
            scalars.extend(sc.iter().map(|&s| f64::from(s)));
        }
        (data, scalars)
    }

    /// Appends row `v` mirrored (bins reversed, within each lobe for the longitudinal family,
    /// whose cdf is re-accumulated in the mirrored order; the lobe energies are unchanged).
    fn push_mirrored(&self, v: &[f32], data: &mut Vec<f32>) {
        let (b, c) = (self.bins, self.channels());
        for k in 0..b {
            let m = self.mirror_bin(k);
            data.extend_from_slice(&v[m * c..(m + 1) * c]);
        }
        if self.family == Family::Longitudinal {
            let half = b / 2;
            for lobe in 0..2 {
                let base = data.len() - b * c + lobe * half * c;
                let mut acc = 0.0f64;
                let mut tot = 0.0f64;
                for j in 0..half {
                    tot += data[base + j * c] as f64;
                }
                for j in 0..half {
                    acc += data[base + j * c] as f64;
                    data[base + j * c + 1] = if tot > 0.0 { (acc / tot) as f32 } else { 0.0 };
                }
            }
        }
    }

    /// The table: `data` in layout order, the per-entry scalars `scal` (one array per scalar,
    /// each flat over (σ, g, entry)) and the method's `attributes`, completed by the family's
    /// geometry and conventions.
    pub fn content(
        &self,
        data: Vec<f32>,
        scal: &[Vec<f64>],
        mut a: Map<String, Value>,
    ) -> TableContent {
        let axes = self.axes();
        match self.family {
            Family::Azimuthal => {
                a.insert(
                    "geometry".into(),
                    "unit disc entered at (-sqrt(1-h^2), h) moving along +x".into(),
                );
                a.insert("bin_convention".into(), "phi' = atan2(d_y, d_x) of the exit direction relative to the entering propagation direction: 0 = unscattered continuation (forward), +/-180 deg = straight back towards the source, counter-clockwise = towards the side of positive h'; bins cover [-180, 180) deg".into());
                a.insert(
                    "energy_identity".into(),
                    "sum over phi of energy = 1 - exp(-2 sigma sqrt(1 - h^2))".into(),
                );
                TableContent {
                    encoding: Default::default(),
                    schema: Schema::new("fur-medulla-azimuthal", 1),
                    description: "fur medulla azimuthal scattering profile C^N(phi'; h', sigma, g) (scattered energy per exit-direction bin)".into(),
                    axes,
                    channels: vec![
                        Channel::new("energy", "1", "scattered exiting energy in the bin per unit incident energy"),
                        Channel::new("path_length", "medulla_radius", "mean in-medulla path length of the energy in the bin"),
                        Channel::new("std_error", "1", "Monte Carlo standard error of energy"),
                    ],
                    attributes: a,
                    data,
                }
            }
            Family::Longitudinal => {
                a.insert("geometry".into(), "slab 0 <= x <= 2 (x along the slab normal = in the fiber's normal plane, y along the fiber axis), entered at x = 0 with propagation direction (cos theta_i, -sin theta_i)".into());
                a.insert("bin_convention".into(), "theta_i is the inclination of the direction towards the source, theta_r of the exit direction (sin theta_r = exit d_y), both from the slab normal, Marschner-style: the unscattered continuation exits at theta_r = -theta_i. lobe 0 = back (exits through the entry face x = 0, the thesis's 'upper' lobe, used at phi = 0), lobe 1 = forward (exits through x = 2, the 'lower' lobe, used at phi = +/-180 deg); theta_r bins cover [-90, 90) deg per lobe".into());
                a.insert("pdf_convention".into(), "channel `pdf` is each lobe normalised to a probability density per radian of theta_r (sum pdf * bin_width_rad = 1 per lobe); `cdf` is its cumulative distribution at the UPPER edge of each bin (last bin = 1). At sigma = 0 energy is 0 and pdf/cdf hold the sigma -> 0 limit shape (single scattering on the chord)".into());
                a.insert(
                    "energy_identity".into(),
                    "sum over both lobes of energy = 1 - exp(-2 sigma / cos theta_i)".into(),
                );
                a.insert("back_lobe_energy".into(), scal[3].clone().into());
                a.insert("forward_lobe_energy".into(), scal[4].clone().into());
                TableContent {
                    encoding: Default::default(),
                    schema: Schema::new("fur-medulla-longitudinal", 1),
                    description: "fur medulla longitudinal scattering lobes C^M(theta'_r; theta'_i, sigma, g) of a slab of thickness 2".into(),
                    axes,
                    channels: vec![
                        Channel::new("pdf", "1/rad", "lobe-normalised density of theta_r"),
                        Channel::new("cdf", "1", "lobe cumulative distribution at the bin's upper edge"),
                        Channel::new("energy", "1", "scattered exiting energy in the bin per unit incident energy"),
                        Channel::new("path_length", "medulla_radius", "mean in-medulla path length of the energy in the bin"),
                        Channel::new("std_error", "1", "Monte Carlo standard error of energy"),
                    ],
                    attributes: a,
                    data,
                }
            }
        }
    }
}
