//! Which reading of Tseng 2015 eq. 5.10 (the σ_ms → medulla-table σ mapping) reproduces the
//! qualitative features of the measured fur profiles (thesis Figure 4.3)? For each reading and
//! each Table 4.2 sample, the far field at θ_i = −40° (the measurement geometry) is computed,
//! the features are measured, and one image per reading shows the ten profiles.
//!
//! `cargo run --release --example fur_readings -- docs/images/fur`
//!
//! Prints one Markdown table per reading (figures in docs/fur.md, "Readings of eq. 5.10").
use plotters::prelude::*;
use scatterbake::fur::farfield::{
    FarField, FarFieldSettings, MedullaShapes, SigmaScaling, TABLE_4_2, far_field, medulla_sigma,
};

fn draw(
    path: &std::path::Path,
    title: &str,
    fields: &[(&str, FarField)],
) -> Result<(), Box<dyn std::error::Error>> {
    scatterbake::consumers::plot::figure::ensure_font();
    let (w, h) = (1500u32, 560u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let (top, body) = root.split_vertically(40);
        top.titled(title, ("sans-serif", 22))?;
        for (area, (name, ff)) in body.split_evenly((2, 5)).iter().zip(fields) {
            let rows: Vec<usize> = (0..ff.theta_r_cells)
                .filter(|&i| ff.theta_r(i).to_degrees().abs() <= 80.0)
                .collect();
            let max = rows
                .iter()
                .flat_map(|&i| (0..ff.phi_cells).map(move |j| ff.total(i, j)))
                .fold(0.0, f64::max);
            let mut chart = ChartBuilder::on(area)
                .caption(*name, ("sans-serif", 16))
                .margin(4)
                .x_label_area_size(22)
                .y_label_area_size(30)
                .build_cartesian_2d(-180.0..180.0, -80.0..80.0)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_labels(5)
                .y_labels(5)
                .label_style(("sans-serif", 11))
                .draw()?;
            let (dt, dp) = (180.0 / ff.theta_r_cells as f64, 360.0 / ff.phi_cells as f64);
            chart.draw_series(rows.iter().flat_map(|&i| {
                (0..ff.phi_cells).map(move |j| {
                    let v = (ff.total(i, j) / max).max(1e-3).log10(); // −3 … 0
                    let c = ViridisRGB::get_color_normalized(v, -3.0, 0.0);
                    let (t, p) = (ff.theta_r(i).to_degrees(), ff.phi(j).to_degrees());
                    Rectangle::new(
                        [(p - 0.5 * dp, t - 0.5 * dt), (p + 0.5 * dp, t + 0.5 * dt)],
                        c.filled(),
                    )
                })
            }))?;
        }
        root.present()?;
    }
    scatterbake::consumers::image::write_png(path, w as usize, h as usize, &buf)?;
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or("/tmp".into()));
    std::fs::create_dir_all(&out)?;
    let ti = (-40f64).to_radians();
    let readings = [
        (SigmaScaling::KappaHalf, "kappa_half", "σ_ms·κ/2"),
        (SigmaScaling::Kappa, "kappa", "σ_ms·κ"),
        (SigmaScaling::ThesisOverKappa, "thesis_over_kappa", "σ_ms/κ"),
    ];
    for (scaling, key, label) in readings {
        let set = FarFieldSettings {
            theta_r_cells: 90,
            phi_cells: 180,
            h_samples: 400,
            medulla_rows: 17,
            medulla_bins: 360,
            photons: 2000,
            seed: 1,
            sigma_scaling: scaling,
        };
        println!("\n### {label} (`medulla_sigma_scaling = \"{key}\"`), θ_i = −40°\n");
        println!(
            "| sample | table σ | R peak / profile peak | forward unscattered | TRT | back diffuse peak θ_r | forward diffuse peak θ_r | forward spot / band beside |"
        );
        println!("|---|---|---|---|---|---|---|---|");
        let mut fields = Vec::new();
        for s in TABLE_4_2.iter() {
            let sigma = medulla_sigma(s, scaling);
            let shapes = MedullaShapes::compute(sigma, s.g, &set);
            let ff = far_field(s, ti, &shapes, &set);
            let f = ff.features(ti);
            println!(
                "| {} | {:.2} | {:.2} | {:.4} | {:.4} | {:+.0}° | {:+.0}° | {:.2} |",
                s.name,
                sigma,
                f.r_prominence,
                f.forward_unscattered,
                ff.energy(2),
                f.back_diffuse_peak_deg,
                f.forward_diffuse_peak_deg,
                f.forward_spot
            );
            fields.push((s.name, ff));
        }
        let path = out.join(format!("farfield-readings-{key}.png"));
        draw(
            &path,
            &format!("far field at θ_i = −40°, medulla σ = {label} (log10, 3 decades)"),
            &fields,
        )?;
        println!("\nimage: {}", path.display());
    }
    Ok(())
}
