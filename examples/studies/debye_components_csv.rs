//! Writes `docs/debye-100um-650nm.csv`: Mie and its Debye components p = 0..3 (the rest, p ≥ 4
//! plus interference, is Mie minus these) for a 100 µm drop at 650 nm (water, IAPWS R9-97 at
//! 20 °C), 0..180° step 0.05°, point values — the data of MiePlot's classic figure:
//!
//! `cargo run --release --example debye_components_csv`

use num_complex::Complex64;

fn main() -> anyhow::Result<()> {
    let n = scatterbake::optics::water::WaterIndexModel::from_name("iapws1997", Some(20.0))?
        .index(650.0)?;
    let x = scatterbake::mie::size_parameter(100.0, 650.0);
    let angles: Vec<f64> = (0..=3600).map(|k| k as f64 * 0.05).collect();
    let c =
        scatterbake::debye::mie_with_components(x, Complex64::new(n, 0.0), &[0, 1, 2, 3], &angles)?;
    // The primary bow of p = 2 sits near the Mie primary (≈ 138.6° for 100 µm at 650 nm).
    let k2 = (2000..3000)
        .max_by(|&a, &b| c.components[2][a].total_cmp(&c.components[2][b]))
        .expect("non-empty range");
    anyhow::ensure!(
        (angles[k2] - 138.6).abs() < 0.3,
        "p = 2 maximum at {}°, expected near 138.6°",
        angles[k2]
    );
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/debye-100um-650nm.csv");
    let header = format!(
        "# Mie and Debye components p=0..3, radius 100 um, 650 nm, n = {n} (IAPWS R9-97, 20 C), x = {x}; phase functions s11/(pi x^2 Q_sca) of the full sphere (1/sr), point values\n"
    );
    std::fs::write(path, header + &c.to_csv())?;
    println!("wrote {path}; p = 2 maximum at {}°", angles[k2]);
    Ok(())
}
