//! Where the `mixture` stage hands its drops over from Lorenz–Mie to the traced 1-D sphere path:
//! Marshall–Palmer mixtures built with the handover at each given radius, against the `mie`
//! stage's table of the same radii and weights (`radius_tolerance = 0`: Lorenz–Mie at every
//! radius). Prints, per wavelength, Alexander's band (mean phase over 131–136°) over Mie's and
//! the relative L2 difference over 125–145° (both after the sun's disc).
//!
//! `cargo run --release --example mixture_handover [-- HANDOVER_UM ...]` (default 100 400).
#[path = "common/curves.rs"]
#[allow(dead_code)] // maxima serves other examples
mod curves;

use scatterbake::stages::{Job, run_in_memory};
use scatterbake::table::TableContent;
use std::time::Instant;

const COMMON: &str =
    "wavelengths_nm = [450.0, 550.0, 650.0]\nangle_step_deg = 0.05\nradius_points = 24\n";

/// The distributions: Marshall–Palmer at 5 mm/h over these radius ranges (µm).
const RANGES_UM: [(f64, f64); 2] = [(50.0, 300.0), (50.0, 2000.0)];

fn distribution((lo, hi): (f64, f64)) -> String {
    format!(
        "distributions = [{{ kind = \"marshall-palmer\", rain_rate_mm_h = 5.0, min_radius_um = {lo}, max_radius_um = {hi} }}]\n"
    )
}

fn build(stage: &str, params: &str) -> anyhow::Result<(TableContent, f64)> {
    let stage = scatterbake::stages::find(stage).expect("stage");
    let inline = toml::Value::Table(toml::from_str(params)?).to_string();
    let job: Box<dyn Job> = stage.plan(toml::de::ValueDeserializer::parse(&inline)?)?;
    let t0 = Instant::now();
    let table = run_in_memory(&*job)?;
    Ok((table, t0.elapsed().as_secs_f64()))
}

/// The `phase` curve of wavelength row `w` of a one-entry table (axes entry × wavelength ×
/// angle), with its angles (deg).
fn phase_row(t: &TableContent, w: usize) -> (Vec<f64>, Vec<f64>) {
    let angles = t.axes.last().expect("angle axis").coords();
    let (na, nch) = (angles.len(), t.channels.len());
    let phase = (0..na).map(|j| t.data[(w * na + j) * nch] as f64).collect();
    (angles, phase)
}

fn main() -> anyhow::Result<()> {
    let handovers: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let handovers = if handovers.is_empty() {
        vec![100.0, 400.0]
    } else {
        handovers
    };
    for range in RANGES_UM {
        let dist = distribution(range);
        let (mie, mie_s) = build("mie", &format!("{COMMON}{dist}radius_tolerance = 0.0"))?;
        println!(
            "Marshall–Palmer 5 mm/h, {}–{} µm: mie stage {mie_s:.1} s",
            range.0, range.1
        );
        let wavelengths = mie.axes[1].coords();
        for &h in &handovers {
            let (mix, mix_s) = build(
                "mixture",
                &format!("{COMMON}{dist}handover_radius_um = {h}"),
            )?;
            let mut line = format!("  handover {h} µm ({mix_s:.1} s):");
            for (w, l) in wavelengths.iter().enumerate() {
                let (angles, a) = phase_row(&mix, w);
                let (_, b) = phase_row(&mie, w);
                let band = curves::window_mean(&angles, &a, 131.0, 136.0)
                    / curves::window_mean(&angles, &b, 131.0, 136.0);
                let (mut d2, mut n2) = (0.0, 0.0);
                for ((t, x), y) in angles.iter().zip(&a).zip(&b) {
                    if (125.0..=145.0).contains(t) {
                        d2 += (x - y) * (x - y);
                        n2 += y * y;
                    }
                }
                line += &format!(
                    "  {l} nm band {band:.3} L2 {:.2} %",
                    100.0 * (d2 / n2).sqrt()
                );
            }
            println!("{line}");
        }
    }
    Ok(())
}
