//! `scatterbake export --format rgb-lut`: a 1-D colour lookup texture for real-time renderers.
//!
//! Row k holds the linear-sRGB colour of single scattering of a D65 sun at scattering angle
//! θ_k = k · 180° / (N − 1):
//!
//! ```text
//! rgb(θ) = M_XYZ→sRGB · Σ_λ W_λ · P̄_λ(θ)      [1/sr, per unit sun irradiance]
//! ```
//!
//! with P̄ the phase function averaged over the sun disc and W_λ the CIE
//! 1931 2° weights under D65 ([`SpectralWeights`](crate::optics::colour::SpectralWeights)), as
//! in the reference renderer. A shader multiplies it by the sun's irradiance and the medium's
//! in-scattering factor: `L = lut[θ] · E_sun · σ_s · (path integral)`, θ = acos(dot(sun_dir,
//! view_dir)) (the angle between the direction toward the sun and the view direction; 180° at
//! the antisolar point), interpolating linearly between rows. A channel that comes out negative
//! (a colour outside the sRGB gamut) is written as 0, and the count and most negative value are
//! printed and stored with the texture (header attribute in the EXR's `scatterbake_header` and
//! PNG `tEXt` chunk `negative_values`, CSV
//! line `# negative_values: …`): the policy of every export ([`NegativeClamp`]).
//!
//! The disc is the table's own (`sun_diameter_deg`, already averaged: nothing more is
//! convolved) unless `--sun-diameter-deg` asks for a wider one ([`SunDisc`]); what was done is
//! printed and stored with the texture (header attribute `sun_disc` in the EXR's
//! `scatterbake_header`, PNG `tEXt` chunk
//! `scatterbake_sun_disc`, CSV first line `# sun_disc: …`).
//!
//! Output, by the extension of `--out`:
//! - `.exr`: N × 1 texels, float32 channels `R`, `G`, `B` (linear values as computed, the
//!   recommended form; the table header JSON is in the EXR attribute `scatterbake_header`);
//! - `.csv`: `angle_deg,r,g,b`;
//! - `.png`: 16-bit RGB, N × 1 pixels, **log-encoded** because a drop's phase function spans
//!   ~6 decades (forward peak vs the bows; a linear 16-bit PNG quantises everything beyond a
//!   few degrees to 0): `v = (log10(rgb) − L0)/(L1 − L0)` in [0, 1] (stored as round(v·65535)),
//!   `L1 = log10(max)`, `L0 = L1 − 8` (`LOG_DECADES`); a stored 0 means `rgb ≤ 10^L0`. Decode in a shader: `rgb = v > 0 ? pow(10, L0 + v·(L1 − L0)) : 0`.
//!   L0 and L1 are printed and stored in the `tEXt` chunks `scatterbake_log10_min`,
//!   `scatterbake_log10_max` (with `scatterbake_encoding = log10`). Step: 8/65535 decades
//!   = 0.028 % relative.

use crate::consumers::ConsumerError;
use crate::consumers::export::NegativeClamp;
use crate::consumers::read::operators::SunDisc;
use crate::consumers::read::phase::{EntrySelection, PhaseTable};
use crate::consumers::read::spectrum::{THETA_STEP_DEG, xyz_vs_angle};
use crate::optics::colour::xyz_to_linear_srgb;
use crate::table::{Axis, Channel, Provenance, Schema, Table, TableContent};

/// Decades below the maximum that the log-encoded PNG LUT represents.
pub const LOG_DECADES: f64 = 8.0;

/// Log10 encoding of the PNG LUT: 16-bit codes and (L0, L1) with
/// `rgb = 10^(L0 + code/65535 · (L1 − L0))` for code > 0, 0 otherwise.
pub fn log_encode(lut: &[[f64; 3]]) -> (Vec<u16>, f64, f64) {
    let max = lut
        .iter()
        .flatten()
        .cloned()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let l1 = max.log10();
    let l0 = l1 - LOG_DECADES;
    let codes = lut
        .iter()
        .flatten()
        .map(|&v| {
            if v > 10f64.powf(l0) {
                (((v.log10() - l0) / (l1 - l0)).clamp(0.0, 1.0) * 65535.0).round() as u16
            } else {
                0
            }
        })
        .collect();
    (codes, l0, l1)
}

/// Inverse of [`log_encode`] (what a shader does).
pub fn log_decode(code: u16, l0: f64, l1: f64) -> f64 {
    if code == 0 {
        0.0
    } else {
        10f64.powf(l0 + code as f64 / 65535.0 * (l1 - l0))
    }
}

/// The LUT as a 1-D table (axis `scattering_angle`, channels `R`, `G`, `B`) for the EXR writer.
pub fn lut_table(
    lut: &RgbLut,
    source: &str,
    entry: &str,
    disc: &SunDisc,
) -> Result<Table, ConsumerError> {
    let n = lut.rows.len();
    let mut attributes = serde_json::Map::new();
    attributes.insert("sun_disc".into(), disc.describe().into());
    attributes.insert("negative_values".into(), lut.negatives.describe().into());
    attributes.insert("sun_diameter_deg".into(), disc.target_deg.into());
    attributes.insert("source_table".into(), source.into());
    attributes.insert("entry".into(), entry.into());
    attributes.insert("lookup".into(), "L = lut(theta) * E_sun * sigma_s * path integral; theta = acos(dot(sun_dir, view_dir)), 180 deg at the antisolar point; texel k at theta = k * 180/(N-1) deg, linear interpolation".into());
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("rgb-lut", 1),
        description: "linear sRGB of single scattering of a D65 sun vs scattering angle (1/sr per unit sun irradiance)".into(),
        axes: vec![Axis::uniform(
            "scattering_angle",
            "deg",
            0.0,
            180.0 / (n - 1) as f64,
            n,
        )],
        channels: ["R", "G", "B"]
            .iter()
            .map(|c| Channel::new(c, "1/sr", &format!("linear sRGB {c} per unit sun irradiance")))
            .collect(),
        attributes,
        data: lut.rows.iter().flatten().map(|&v| v as f32).collect(),
    };
    Ok(Table::from_content(content, Provenance::default())?)
}

/// An RGB lookup texture: rows of linear sRGB and what clamping negatives changed.
#[derive(Debug, Clone)]
pub struct RgbLut {
    pub rows: Vec<[f64; 3]>,
    pub negatives: NegativeClamp,
}

/// Linear sRGB vs angle on `n` uniform angles over [0, 180], convolving only the disc the
/// table has not applied (`disc.extra_deg`); negative channels (outside the sRGB gamut) are
/// clamped at 0 and counted.
pub fn rgb_lut(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    disc: &SunDisc,
    n: usize,
) -> Result<RgbLut, ConsumerError> {
    let xyz = xyz_vs_angle(pt, entry, disc.extra_deg)?;
    let mut rows: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let a = 180.0 * k as f64 / (n - 1) as f64;
            let u = a / THETA_STEP_DEG;
            let i = (u.floor() as usize).min(xyz.len() - 2);
            let t = u - i as f64;
            xyz_to_linear_srgb([0, 1, 2].map(|c| xyz[i][c] * (1.0 - t) + xyz[i + 1][c] * t))
        })
        .collect();
    let negatives = NegativeClamp::apply(rows.iter_mut().flatten());
    Ok(RgbLut { rows, negatives })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::henyey_greenstein_table;

    #[test]
    fn grey_table_gives_grey_lut_equal_to_the_phase_function() {
        // Wavelength-independent HG: every row is (p, p, p) since a flat spectrum under D65
        // maps to sRGB (1, 1, 1) — with no sun disc.
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let pt =
            PhaseTable::new(henyey_greenstein_table(&wl, &[1.0], |_, _| 0.5, 1801, 0.0)).unwrap();
        let disc = SunDisc::plan(&pt.table, Some(0.0)).unwrap();
        let lut = rgb_lut(&pt, &[], &disc, 181).unwrap();
        assert_eq!(lut.negatives.count, 0);
        for (k, v) in lut.rows.iter().enumerate() {
            let p =
                crate::optics::henyey_greenstein::hg_density_sr((k as f64).to_radians().cos(), 0.5);
            for c in v {
                assert!((c - p).abs() < 5e-3 * p, "angle {k}: {v:?} vs {p}");
            }
        }
    }

    /// Nearly monochromatic light (a narrow peak whose angle moves with wavelength) lies outside
    /// the sRGB gamut: the LUT holds no negative value and says how many it clamped.
    #[test]
    fn out_of_gamut_colours_are_clamped_and_counted() {
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let t = crate::fixtures::peak_table(&wl, |l| 100.0 + (l - 380.0) / 4.0, 0.3, 1e-6, 3601);
        let pt = PhaseTable::new(t).unwrap();
        let disc = SunDisc::plan(&pt.table, Some(0.0)).unwrap();
        let lut = rgb_lut(&pt, &[], &disc, 1801).unwrap();
        assert!(lut.negatives.count > 10, "{:?}", lut.negatives);
        assert!(lut.negatives.most_negative < 0.0);
        assert!(lut.rows.iter().flatten().all(|v| *v >= 0.0));
    }

    /// The PNG's log encoding keeps the bows of a drop whose forward peak is ~6 decades
    /// brighter: every value above 1e-8 of the maximum decodes to within 0.03 %.
    #[test]
    fn log_encoding_keeps_six_decades() {
        let lut: Vec<[f64; 3]> = (0..2000)
            .map(|k| {
                let v = 1e4 * 10f64.powf(-7.0 * k as f64 / 1999.0);
                [v, 0.5 * v, -1e-3]
            })
            .collect();
        let (codes, l0, l1) = log_encode(&lut);
        assert!((l1 - 4.0).abs() < 1e-12 && (l1 - l0 - LOG_DECADES).abs() < 1e-12);
        for (k, v) in lut.iter().enumerate() {
            for c in 0..2 {
                let d = log_decode(codes[3 * k + c], l0, l1);
                assert!((d / v[c] - 1.0).abs() < 3e-4, "{k},{c}: {d} vs {}", v[c]);
            }
            assert_eq!(codes[3 * k + 2], 0, "negative (out of gamut) encodes as 0");
        }
    }

    /// EXR output: a float N × 1 image with channels R, G, B equal to the LUT.
    #[test]
    fn exr_lut_holds_float_values() {
        let lut: Vec<[f64; 3]> = (0..181)
            .map(|k| [1e3 / (1.0 + k as f64), 0.1, 1e-5])
            .collect();
        let disc = SunDisc::from_applied(0.5, true, None).unwrap();
        let lut = RgbLut {
            rows: lut,
            negatives: NegativeClamp::default(),
        };
        let t = lut_table(&lut, "x.sbt", "radius=1 um", &disc).unwrap();
        assert_eq!(
            t.header.attributes["negative_values"],
            "negative values: none"
        );
        assert_eq!(t.header.attributes["sun_diameter_deg"], 0.5);
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("lut.exr");
        crate::consumers::export::generic::export(
            &t,
            crate::consumers::export::generic::GenericFormat::Exr,
            &path,
        )
        .unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let layer = &img.layer_data[0];
        assert_eq!(layer.size.0, 181);
        let r = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == "R")
            .unwrap();
        for (k, v) in r.sample_data.values_as_f32().enumerate() {
            assert_eq!(v, lut.rows[k][0] as f32);
        }
    }
}
