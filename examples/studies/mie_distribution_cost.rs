//! Cost and error of Marshall–Palmer table entries (rain 5 mm/h, radii 0.05–3 mm; 0.05° bins,
//! 0.5° sun disc, IAPWS water at 20 °C), the `mie` stage's computation without the table
//! writer. Modes (wall and process CPU times are printed; the machine's load is not
//! controlled, so compare figures of one run):
//!
//! ```text
//! cargo run --release --example mie_distribution_cost -- table [TOLERANCE] [OLD_WAVELENGTH_NM...]
//! cargo run --release --example mie_distribution_cost -- reference WAVELENGTH_NM NODES FILE
//! cargo run --release --example mie_distribution_cost -- compare WAVELENGTH_NM FILE [TOLERANCE...]
//! cargo run --release --example mie_distribution_cost -- old WAVELENGTH_NM RADIUS_POINTS [FILE]
//! ```
//! - `table`: the 33-wavelength (380–700 nm) entry with the adaptive radius rule of
//!   `mie::size_average` (`radius_tolerance`, default the stage's: the estimated output error),
//!   wavelengths in parallel as the pipeline runs tasks; then, for each `OLD_WAVELENGTH_NM`, the
//!   same entry by the adaptive rule and by the fixed Gauss–Legendre rule (24 nodes in ln r,
//!   exact cell averages per node, `radius_tolerance = 0`), and their time ratio.
//! - `reference`: the brute-force reference at one wavelength (`mie::ensemble::reference_entry`:
//!   `NODES` midpoint strata of `n(r) r²`, exact cell averages per node), written to `FILE`
//!   (little-endian f64: i_perp then i_par over the 3601 bins), with the difference between its
//!   two interleaved halves.
//! - `compare`: the adaptive entry at each tolerance against the reference in `FILE`: max and
//!   rms relative error of `i_perp`, `i_par` and where the max is.
//! - `old`: the Gauss–Legendre rule of `RADIUS_POINTS` nodes at one wavelength (against `FILE`).
use num_complex::Complex64;
use rayon::prelude::*;
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::mie::ensemble::{
    DEFAULT_RADIUS_TOLERANCE, EntryResult, compute_entry, reference_entry, relative_difference,
};
use scatterbake::mie::filters::FilterSettings;
use scatterbake::mie::filters::PolarisedPhase;
use scatterbake::optics::water::WaterIndexModel;
use std::time::Instant;

const RAIN: SizeDistribution = SizeDistribution::MarshallPalmer {
    rain_rate_mm_h: 5.0,
    min_radius_um: 50.0,
    max_radius_um: 3000.0,
};

/// Process CPU time (user + system, s) from /proc/self/stat (Linux; 0 elsewhere).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // fields after the command name in parentheses: utime is field 14, stime 15 (1-based)
    let rest = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

fn settings(tolerance: f64, radius_points: usize) -> FilterSettings {
    FilterSettings {
        output_intervals: 3600,
        sun_diameter_deg: 0.5,
        gaussian_sigma_deg: 0.0,
        radius_points,
        radius_tolerance: tolerance,
    }
}

fn index(wavelength_nm: f64) -> anyhow::Result<Complex64> {
    Ok(Complex64::new(
        WaterIndexModel::default().index(wavelength_nm)?,
        0.0,
    ))
}

fn timed<T>(f: impl FnOnce() -> anyhow::Result<T>) -> anyhow::Result<(T, f64, f64)> {
    let (t, c) = (Instant::now(), cpu_seconds());
    let v = f()?;
    Ok((v, t.elapsed().as_secs_f64(), cpu_seconds() - c))
}

fn entry(wavelength_nm: f64, s: &FilterSettings) -> anyhow::Result<EntryResult> {
    let sun = s.sun_operator();
    Ok(compute_entry(
        &RAIN,
        wavelength_nm,
        index(wavelength_nm)?,
        s,
        &sun,
    )?)
}

fn read_curve(path: &str) -> anyhow::Result<PolarisedPhase> {
    let bytes = std::fs::read(path)?;
    let v: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    anyhow::ensure!(v.len() == 2 * 3601, "{path}: expected 2 x 3601 values");
    Ok(PolarisedPhase {
        step_deg: 0.05,
        i_perp: v[..3601].to_vec(),
        i_par: v[3601..].to_vec(),
    })
}

fn report(what: &str, a: &PolarisedPhase, reference: &PolarisedPhase) {
    let (max, at, ch, rms) = relative_difference(a, reference);
    println!("  {what}: max rel. error {max:.3e} ({ch} at {at:.2} deg), rms {rms:.3e}");
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num = |i: usize| -> anyhow::Result<Option<f64>> {
        args.get(i)
            .map(|s| s.parse::<f64>())
            .transpose()
            .map_err(Into::into)
    };
    println!(
        "load average at start: {} ({} rayon threads)",
        load_average(),
        rayon::current_num_threads()
    );
    match args.first().map(String::as_str) {
        Some("table") | None => {
            let tol = num(1)?.unwrap_or(DEFAULT_RADIUS_TOLERANCE);
            let s = settings(tol, 24);
            let wavelengths: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
            let sun = s.sun_operator();
            let (results, wall, cpu) = timed(|| {
                wavelengths
                    .par_iter()
                    .map(|&l| Ok(compute_entry(&RAIN, l, index(l)?, &s, &sun)?))
                    .collect::<anyhow::Result<Vec<EntryResult>>>()
            })?;
            for (l, r) in wavelengths.iter().zip(&results) {
                println!(
                    "  {l} nm: {} nodes, estimated rms error {:.2e}, Q_sca {:.6}, g {:.6}",
                    r.radius_nodes, r.error_rms, r.q_sca, r.g
                );
            }
            println!(
                "33-wavelength Marshall-Palmer entry, radius_tolerance {tol}: wall {wall:.1} s, CPU {cpu:.1} s, load average now {}",
                load_average()
            );
            for l in args.iter().skip(2) {
                let l: f64 = l.parse()?;
                let (_, new_wall, new_cpu) = timed(|| entry(l, &s))?;
                let (_, old_wall, old_cpu) = timed(|| entry(l, &settings(0.0, 24)))?;
                println!(
                    "  {l} nm, one entry: adaptive {new_wall:.2} s wall / {new_cpu:.2} s CPU, Gauss-Legendre 24 nodes {old_wall:.2} s / {old_cpu:.2} s; CPU ratio old/new {:.1}",
                    old_cpu / new_cpu
                );
            }
        }
        Some("reference") => {
            let l = num(1)?.ok_or_else(|| anyhow::anyhow!("wavelength"))?;
            let nodes = num(2)?.ok_or_else(|| anyhow::anyhow!("nodes"))? as usize;
            let path = args.get(3).ok_or_else(|| anyhow::anyhow!("file"))?;
            let s = settings(0.0, 24);
            let sun = s.sun_operator();
            let ([all, even, odd], wall, cpu) =
                timed(|| Ok(reference_entry(&RAIN, l, index(l)?, &s, &sun, nodes)?))?;
            println!("reference {l} nm, {nodes} nodes: wall {wall:.1} s, CPU {cpu:.1} s");
            report("even half vs odd half", &even, &odd);
            report("even half vs all", &even, &all);
            let bytes: Vec<u8> = all
                .i_perp
                .iter()
                .chain(&all.i_par)
                .flat_map(|v| v.to_le_bytes())
                .collect();
            std::fs::write(path, bytes)?;
        }
        Some("compare") => {
            let l = num(1)?.ok_or_else(|| anyhow::anyhow!("wavelength"))?;
            let reference = read_curve(args.get(2).ok_or_else(|| anyhow::anyhow!("file"))?)?;
            let tolerances: Vec<f64> = args[3..]
                .iter()
                .map(|t| t.parse())
                .collect::<Result<_, _>>()?;
            let tolerances = if tolerances.is_empty() {
                vec![DEFAULT_RADIUS_TOLERANCE]
            } else {
                tolerances
            };
            for tol in tolerances {
                let (r, wall, cpu) = timed(|| entry(l, &settings(tol, 24)))?;
                println!(
                    "{l} nm, radius_tolerance {tol}: {} nodes, estimated rms {:.2e}, wall {wall:.2} s, CPU {cpu:.2} s",
                    r.radius_nodes, r.error_rms
                );
                report("adaptive vs reference", &r.curve, &reference);
            }
        }
        Some("old") => {
            let l = num(1)?.ok_or_else(|| anyhow::anyhow!("wavelength"))?;
            let points = num(2)?.ok_or_else(|| anyhow::anyhow!("radius points"))? as usize;
            let (r, wall, cpu) = timed(|| entry(l, &settings(0.0, points)))?;
            println!("{l} nm, Gauss-Legendre {points} nodes: wall {wall:.2} s, CPU {cpu:.2} s");
            if let Some(path) = args.get(3) {
                report("Gauss-Legendre vs reference", &r.curve, &read_curve(path)?);
            }
        }
        Some(other) => anyhow::bail!("unknown mode {other}"),
    }
    Ok(())
}
