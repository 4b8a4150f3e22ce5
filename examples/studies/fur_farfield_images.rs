//! Lat-long images of the far-field fur profiles (docs/images/fur/):
//! `cargo run --release -- build manifests/fur-farfield.toml --out /tmp/ff`, then
//! `cargo run --release --example fur_farfield_images -- /tmp/ff/fur-farfield.sbt docs/images/fur -40`
//! One PNG per sample at the given θ_i: the `energy` channel over θ_r ∈ [−80°, 80°] × φ, floored
//! at 1e-3 of the image maximum so that `plot_heatmap`'s log10 colour map spans three decades.
//! Also prints per-sample component energies and forward-window figures.
use scatterbake::consumers::plot::tables::plot_heatmap;
use scatterbake::table::{Axis, Channel, Provenance, Schema, Table, TableContent};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args.next().expect("table path");
    let dir = std::path::PathBuf::from(args.next().expect("output dir"));
    let ti: f64 = args.next().map(|s| s.parse().unwrap()).unwrap_or(-40.0);
    std::fs::create_dir_all(&dir)?;
    let t = Table::open(&path).map_err(|e| anyhow::anyhow!(e))?;
    let h = &t.header;
    let (ns, nti, nt, np, nc) = (
        h.axes[0].len(),
        h.axes[1].len(),
        h.axes[2].len(),
        h.axes[3].len(),
        h.channels.len(),
    );
    let iti = (0..nti)
        .find(|&i| (h.axes[1].coord(i) - ti).abs() < 1e-9)
        .expect("theta_i on the grid");
    let names: Vec<String> = h.attributes["samples"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect();
    let rows: Vec<usize> = (0..nt)
        .filter(|&i| h.axes[2].coord(i).abs() <= 80.0)
        .collect();
    let (dt, dp) = (
        (180.0 / nt as f64).to_radians(),
        (360.0 / np as f64).to_radians(),
    );
    println!(
        "sample,total,r,tt,trt,medulla_paths,scattered,fwd_unscattered(|phi|>150),tt_fraction(|phi|>170)"
    );
    for (s, name) in names.iter().enumerate().take(ns) {
        let at = |i: usize, j: usize, c: usize| {
            t.data[(((s * nti + iti) * nt + i) * np + j) * nc + c] as f64
        };
        let mut vals = Vec::new();
        for &i in &rows {
            for j in 0..np {
                vals.push(at(i, j, 0));
            }
        }
        let max = vals.iter().cloned().fold(0.0, f64::max);
        let vals: Vec<f32> = vals.iter().map(|v| v.max(1e-3 * max) as f32).collect();
        let mut e = [0.0; 6];
        let (mut fwd, mut tt170) = (0.0, 0.0);
        for i in 0..nt {
            for j in 0..np {
                let phi = h.axes[3].coord(j).abs();
                for (c, ec) in e.iter_mut().enumerate() {
                    *ec += at(i, j, c) * dt * dp;
                }
                if phi > 150.0 {
                    fwd += (at(i, j, 2) + at(i, j, 4)) * dt * dp;
                }
                if phi > 170.0 {
                    tt170 += at(i, j, 2) * dt * dp;
                }
            }
        }
        println!(
            "{name},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.3}",
            e[0],
            e[1],
            e[2],
            e[3],
            e[4],
            e[5],
            fwd,
            if e[2] > 0.0 { tt170 / e[2] } else { 0.0 }
        );
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new("fur-farfield-image", 1),
            description: format!("{name}, theta_i = {ti} deg"),
            axes: vec![
                Axis::values(
                    "theta_r",
                    "deg",
                    rows.iter().map(|&i| h.axes[2].coord(i)).collect(),
                ),
                Axis::values("phi", "deg", h.axes[3].coords()),
            ],
            channels: vec![Channel::new(
                &format!("{name} theta_i={ti} energy"),
                "1/rad^2",
                "",
            )],
            attributes: Default::default(),
            data: vals,
        };
        let img =
            Table::from_content(content, Provenance::default()).map_err(|e| anyhow::anyhow!(e))?;
        let out = dir.join(format!("farfield-{name}-ti{ti}.png"));
        plot_heatmap(&img, &[], None, &out, (900, 420))?;
    }
    Ok(())
}
