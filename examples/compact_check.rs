//! The error of a compact 2-D ray-traced table, measured from the files: a dense table and a
//! compact table of the same manifest line (`compression = "none"` and
//! `compression = { kind = "sun-disc-resampled", … }`). Each dense entry is seen through the
//! sun's disc the compact header states (`compression.sun_diameter_deg`), and the compact table
//! is sampled by the public reader (`Table::sample`, bilinear between knots) at every direction
//! of the dense grid; the error of `phase`, `i_perp` and `i_par` relative to the filtered `phase`
//! at that direction gives the maximum and the solid-angle-weighted RMS per scattering-angle
//! window, printed next to what the compact header states (docs/raytrace.md, "Compact tables").
//!
//! ```text
//! cargo run --release --example compact_check -- DENSE.sbt COMPACT.sbt
//! ```

use anyhow::{Context, Result, ensure};
use scatterbake::raytrace::compact::{ERROR_WINDOWS, disc_filter};
use scatterbake::raytrace::tracer::DirectionGrid;
use scatterbake::table::Table;

const ENTRY_AXES: [&str; 3] = ["radius", "wavelength", "sun_elevation"];

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    ensure!(
        args.len() == 2,
        "usage: compact_check DENSE.sbt COMPACT.sbt"
    );
    let dense = Table::open(&args[0]).with_context(|| format!("opening {}", args[0]))?;
    let compact = Table::open(&args[1]).with_context(|| format!("opening {}", args[1]))?;
    let stated = compact
        .header
        .attributes
        .get("compression")
        .context("the second table has no compression attribute")?;
    let sun_deg = stated["sun_diameter_deg"]
        .as_f64()
        .context("compression.sun_diameter_deg")?;
    let shape = dense.grid_shape();
    ensure!(
        shape.len() == 5 && shape[..3] == [1, 1, 1],
        "one dense entry expected"
    );
    let grid = DirectionGrid {
        n_polar: shape[3],
        n_azimuth: shape[4],
    };
    let channel = |name: &str| -> Result<Vec<f64>> {
        let c = dense.channel_index(name)?;
        let v: Vec<f64> = (0..grid.n_polar * grid.n_azimuth)
            .map(|i| dense.at(&[0, 0, 0, i / grid.n_azimuth, i % grid.n_azimuth], c) as f64)
            .collect();
        Ok(disc_filter(&v, grid, sun_deg / 4.0))
    };
    let (i_perp, i_par) = (channel("i_perp")?, channel("i_par")?);
    let entry: Vec<f64> = (0..3).map(|a| dense.axes()[a].coord(0)).collect();
    for (a, name) in ENTRY_AXES.iter().enumerate() {
        ensure!(dense.axes()[a].name == *name, "axis {a} is not {name}");
        ensure!(
            compact.axes()[a].coord(0) == entry[a],
            "the tables hold other entries"
        );
    }
    let (polar, azimuth) = (dense.axes()[3].coords(), dense.axes()[4].coords());
    let ch: Vec<usize> = ["phase", "i_perp", "i_par"]
        .iter()
        .map(|n| compact.channel_index(n))
        .collect::<Result<_, _>>()?;
    let mut sums = [[0.0f64; 3]; ERROR_WINDOWS.len()];
    for (j, &theta) in polar.iter().enumerate() {
        let w = theta.to_radians().sin();
        for (k, &phi) in azimuth.iter().enumerate() {
            let s = compact.sample(&[entry[0], entry[1], entry[2], theta, phi])?;
            let (p, q) = (
                i_perp[j * grid.n_azimuth + k],
                i_par[j * grid.n_azimuth + k],
            );
            let phase = 0.5 * (p + q);
            let rel = [s[ch[0]] - phase, s[ch[1]] - p, s[ch[2]] - q]
                .iter()
                .map(|d| d.abs() / phase.max(f64::MIN_POSITIVE))
                .fold(0.0, f64::max);
            for (acc, &(_, lo, hi)) in sums.iter_mut().zip(&ERROR_WINDOWS) {
                if (lo..=hi).contains(&theta) {
                    *acc = [acc[0] + w * rel * rel, acc[1] + w, acc[2].max(rel)];
                }
            }
        }
    }
    let header_errors = &stated["entries"][0]["errors"];
    println!(
        "entry radius {} um, {} nm, sun {} deg; knots {} x {}; compact payload {} bytes",
        entry[0],
        entry[1],
        entry[2],
        compact.axes()[3].len(),
        compact.axes()[4].len(),
        compact.header.payload.compressed_bytes
    );
    println!("| window | measured rms | measured max | stated rms | stated max |");
    println!("|---|---|---|---|---|");
    for (s, &(name, _, _)) in sums.iter().zip(&ERROR_WINDOWS) {
        let st = &header_errors[name];
        println!(
            "| {name} | {:.2e} | {:.2e} | {} | {} |",
            (s[0] / s[1]).sqrt(),
            s[2],
            st["rms_relative"],
            st["max_relative"]
        );
    }
    Ok(())
}
