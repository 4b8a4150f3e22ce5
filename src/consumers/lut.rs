//! `scatterbake export --format rgb-lut`: a 1-D colour lookup texture for real-time renderers.
//!
//! Row k holds the linear-sRGB colour of single scattering of a D65 sun at scattering angle
//! θ_k = k · 180° / (N − 1):
//!
//! ```text
//! rgb(θ) = M_XYZ→sRGB · Σ_λ W_λ · P̄_λ(θ)      [1/sr, per unit sun irradiance]
//! ```
//!
//! with P̄ the phase function averaged over the sun disc (`--sun-diameter-deg`) and W_λ the CIE
//! 1931 2° weights under D65 ([`SpectralWeights`](crate::optics::colour::SpectralWeights)), as
//! in the reference renderer. A shader multiplies it by the sun's irradiance and the medium's
//! in-scattering factor: `L = lut[θ] · E_sun · σ_s · (path integral)`, θ = acos(dot(sun_dir,
//! view_dir)) (the angle between the direction toward the sun and the view direction; 180° at
//! the antisolar point), interpolating linearly between rows. Channels can be slightly negative
//! where the colour is outside the sRGB gamut; they are written as computed.
//!
//! Output: CSV `angle_deg,r,g,b` (`.csv`) or a 16-bit-per-channel PNG of N × 1 pixels
//! (`.png`, linear values scaled by `1/max` and clamped at 0; the scale is printed and stored in
//! the PNG's `tEXt` chunk `scatterbake_scale`).

use super::phase::{EntrySelection, PhaseTable};
use super::render::{THETA_STEP_DEG, xyz_vs_angle};
use crate::optics::colour::xyz_to_linear_srgb;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Linear sRGB vs angle on `n` uniform angles over [0, 180].
pub fn rgb_lut(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: f64,
    n: usize,
) -> anyhow::Result<Vec<[f64; 3]>> {
    let xyz = xyz_vs_angle(pt, entry, sun_diameter_deg)?;
    Ok((0..n)
        .map(|k| {
            let a = 180.0 * k as f64 / (n - 1) as f64;
            let u = a / THETA_STEP_DEG;
            let i = (u.floor() as usize).min(xyz.len() - 2);
            let t = u - i as f64;
            xyz_to_linear_srgb([0, 1, 2].map(|c| xyz[i][c] * (1.0 - t) + xyz[i + 1][c] * t))
        })
        .collect())
}

/// `scatterbake export --format rgb-lut`.
#[derive(Debug, Clone, clap::Args)]
pub struct LutArgs {
    /// Phase-function table (.sbt) following the phase contract.
    pub table: PathBuf,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Number of rows (uniform in angle over [0, 180] deg).
    #[arg(long, default_value_t = 7201)]
    pub samples: usize,
    #[arg(long, default_value_t = 0.5)]
    pub sun_diameter_deg: f64,
    /// Output `.csv` or `.png`.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run the LUT export.
pub fn run_lut(args: &LutArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.samples >= 2, "--samples must be at least 2");
    anyhow::ensure!(
        (0.0..=10.0).contains(&args.sun_diameter_deg),
        "--sun-diameter-deg must be within 0…10°"
    );
    let pt = PhaseTable::open(&args.table)?;
    let lut = rgb_lut(&pt, &args.entry, args.sun_diameter_deg, args.samples)?;
    match args.out.extension().and_then(|e| e.to_str()) {
        Some("csv") => {
            let mut s = String::from("angle_deg,r,g,b\n");
            for (k, v) in lut.iter().enumerate() {
                let a = 180.0 * k as f64 / (args.samples - 1) as f64;
                let _ = writeln!(s, "{a},{:e},{:e},{:e}", v[0], v[1], v[2]);
            }
            std::fs::write(&args.out, s)?;
        }
        Some("png") => {
            let max = lut
                .iter()
                .flatten()
                .cloned()
                .fold(0.0, f64::max)
                .max(f64::MIN_POSITIVE);
            let f = std::io::BufWriter::new(std::fs::File::create(&args.out)?);
            let mut enc = png::Encoder::new(f, args.samples as u32, 1);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Sixteen);
            enc.add_text_chunk("scatterbake_scale".into(), format!("{max:e}"))?;
            let mut w = enc.write_header()?;
            let bytes: Vec<u8> = lut
                .iter()
                .flatten()
                .flat_map(|v| (((v / max).clamp(0.0, 1.0) * 65535.0).round() as u16).to_be_bytes())
                .collect();
            w.write_image_data(&bytes)?;
            w.finish()?;
            eprintln!("PNG value 1.0 = {max:e} (linear sRGB per unit sun irradiance, 1/sr)");
        }
        _ => anyhow::bail!("{}: output must end in .csv or .png", args.out.display()),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::consumers::synthetic::henyey_greenstein_table;

    #[test]
    fn grey_table_gives_grey_lut_equal_to_the_phase_function() {
        // Wavelength-independent HG: every row is (p, p, p) since a flat spectrum under D65
        // maps to sRGB (1, 1, 1) — with no sun disc.
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let pt =
            PhaseTable::new(henyey_greenstein_table(&wl, &[1.0], |_, _| 0.5, 1801, 0.0)).unwrap();
        let lut = rgb_lut(&pt, &[], 0.0, 181).unwrap();
        for (k, v) in lut.iter().enumerate() {
            let p =
                crate::consumers::synthetic::henyey_greenstein(0.5, (k as f64).to_radians().cos());
            for c in v {
                assert!((c - p).abs() < 5e-3 * p, "angle {k}: {v:?} vs {p}");
            }
        }
    }
}
