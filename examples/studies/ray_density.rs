//! Where a 2-D entry needs its rays (figures for docs/raytrace.md, "Ray density"; a
//! measurement, not a test). Three modes:
//!
//! - `entry OUT RADIUS_MM WAVELENGTH_NM SUN_DEG RAYS RAY_GRID` traces one Beard–Chuang entry as
//!   the `raytrace` stage does (Table 3.2 index, thesis grid 0.0125° × 0.2°, `mirror_half`,
//!   `airy-local`), renormalises it to ∫p dΩ = 1 and writes the azimuths 0°–180° of `phase`,
//!   the unfiltered per-order intensities `phase_p0` … `phase_p3` and `phase_unfiltered` (f32)
//!   to OUT;
//! - `compare REF FILE…` prints, per file and scattering-angle window, the error of `phase`
//!   against REF: relative L2 (solid-angle weighted) of the raw values and after the sun's
//!   0.5° disc (the compact form's filter, σ = 0.125°), the root mean square and maximum of the
//!   error relative to the filtered REF (the compact tables' norm), and the relative L2 of each
//!   unfiltered order;
//! - `map RADIUS_MM WAVELENGTH_NM SUN_DEG` prints, per order p = 2, 3 and direction ψ on the
//!   silhouette, the normalised impact parameters b whose rays leave into the primary
//!   (134–150°) and secondary (115–134°) windows and the b of the extreme deviation (the
//!   caustic's ray).
//!
//! `cargo run --release --example ray_density -- entry /tmp/a.bin 1.25 520 0 3000 silhouette`

use scatterbake::optics::water::WaterIndexModel;
use scatterbake::raytrace::compact::{ERROR_WINDOWS, disc_filter};
use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::table2d::entry_integral_2d;
use scatterbake::raytrace::tracer::{
    DirectionGrid, RayGridLayout, TraceConfig, outgoing_directions,
};
use scatterbake::stages::raytrace::{RaytraceJob, RaytraceParams};
use std::io::{Read, Write};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

const GRID: DirectionGrid = DirectionGrid {
    n_polar: 14401,
    n_azimuth: 1800,
};
/// Held columns (φ = 0°–180°) and the channels written per direction.
const HELD: usize = 901;
/// Table channels kept: phase, then phase_p0 … phase_p3 and phase_unfiltered (diagnostic
/// channels of a `max_order = 3` table).
const KEPT: [usize; 6] = [0, 4, 5, 6, 7, 8];

fn entry(args: &[String]) -> Res<()> {
    let [out, a_mm, lambda, sun, rays, grid] = args else {
        return Err("entry OUT RADIUS_MM WAVELENGTH_NM SUN_DEG RAYS RAY_GRID".into());
    };
    let (a_um, lambda, sun) = (
        a_mm.parse::<f64>()? * 1e3,
        lambda.parse::<f64>()?,
        sun.parse::<f64>()?,
    );
    let toml = format!(
        "shape = \"beard-chuang\"\nradii_um = [{a_um}]\nwavelengths_nm = [{lambda}]\nwater_index_model = \"sadeghi-table-3.2\"\nsun_elevation_deg = [{sun}]\nrays = {rays}\nray_grid = \"{grid}\"\npolar_step_deg = 0.0125\nazimuth_step_deg = 0.2\nmirror_half = true\ndiagnostic_channels = true"
    );
    let p: RaytraceParams = toml::from_str(&toml)?;
    let job = RaytraceJob::new(p)?;
    let t = std::time::Instant::now();
    let (values, sigma) = job.trace_2d(lambda, sun)?;
    let secs = t.elapsed().as_secs_f64();
    let nch = values.len() / (GRID.n_polar * GRID.n_azimuth);
    let integral = entry_integral_2d(&values, GRID, nch);
    let mut bytes = Vec::with_capacity(GRID.n_polar * HELD * KEPT.len() * 4);
    for j in 0..GRID.n_polar {
        for k in 0..HELD {
            for &c in &KEPT {
                let v = values[(j * GRID.n_azimuth + k) * nch + c] as f64 / integral;
                bytes.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
    }
    std::fs::File::create(out)?.write_all(&bytes)?;
    println!(
        "{a_mm} mm {lambda} nm sun {sun}: {rays}² {grid}: trace {secs:.1} s wall, σ {sigma:.1} µm², ∫p dΩ {integral:.5}"
    );
    Ok(())
}

/// One stored entry: `[polar][held column][KEPT]`.
fn load(path: &str) -> Res<Vec<f32>> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.read_to_end(&mut bytes)?;
    let v: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if v.len() != GRID.n_polar * HELD * KEPT.len() {
        return Err(format!("{path}: {} values, not an entry of this study", v.len()).into());
    }
    Ok(v)
}

/// Channel `c` (index into KEPT) over the whole azimuth circle, mirrored from the held half.
fn channel(v: &[f32], c: usize) -> Vec<f64> {
    let na = GRID.n_azimuth;
    let mut out = vec![0.0; GRID.n_polar * na];
    for j in 0..GRID.n_polar {
        for k in 0..na {
            let kk = if k < HELD { k } else { na - k };
            out[j * na + k] = v[(j * HELD + kk) * KEPT.len() + c] as f64;
        }
    }
    out
}

/// Per window: [Σ w Δ², Σ w ref², Σ w (Δ/ref)², Σ w, max |Δ|/ref].
fn window_sums(x: &[f64], r: &[f64]) -> Vec<[f64; 5]> {
    let na = GRID.n_azimuth;
    let dth = GRID.polar_step().to_degrees();
    ERROR_WINDOWS
        .iter()
        .map(|&(_, lo, hi)| {
            let mut s = [0.0f64; 5];
            for j in 0..GRID.n_polar {
                let th = dth * j as f64;
                if !(lo..=hi).contains(&th) {
                    continue;
                }
                let w = th.to_radians().sin().max(1e-6);
                for k in 0..na {
                    let (a, b) = (x[j * na + k], r[j * na + k]);
                    let d = a - b;
                    let rel = d.abs() / b.max(f64::MIN_POSITIVE);
                    s[0] += w * d * d;
                    s[1] += w * b * b;
                    s[2] += w * rel * rel;
                    s[3] += w;
                    s[4] = s[4].max(rel);
                }
            }
            s
        })
        .collect()
}

/// Where the error of the disc-filtered `phase` lies within 115–150°: per 30° azimuth sector
/// (0°–180°) the relative L2, and the 1° polar bins holding the largest shares of Σ w Δ².
fn locate(name: &str, x: &[f64], r: &[f64]) {
    let na = GRID.n_azimuth;
    let dth = GRID.polar_step().to_degrees();
    let mut sectors = [[0.0f64; 2]; 6];
    let mut bins = vec![0.0f64; 180];
    for j in 0..GRID.n_polar {
        let th = dth * j as f64;
        if !(115.0..=150.0).contains(&th) {
            continue;
        }
        let w = th.to_radians().sin();
        for k in 0..HELD {
            let (a, b) = (x[j * na + k], r[j * na + k]);
            let sector = ((k as f64 * 0.2 / 30.0) as usize).min(5);
            sectors[sector][0] += w * (a - b).powi(2);
            sectors[sector][1] += w * b * b;
            bins[th as usize] += w * (a - b).powi(2);
        }
    }
    let total: f64 = bins.iter().sum();
    let mut order: Vec<usize> = (0..180).collect();
    order.sort_by(|&a, &b| bins[b].total_cmp(&bins[a]));
    let sec: Vec<String> = sectors
        .iter()
        .map(|s| format!("{:.3}", (s[0] / s[1]).sqrt()))
        .collect();
    let top: Vec<String> = order[..6]
        .iter()
        .map(|&d| format!("{d}°: {:.0}%", 100.0 * bins[d] / total))
        .collect();
    println!(
        "# {name}: disc L2 over 115–150° per azimuth sector 0–30…150–180°: {}; largest 1° bins: {}",
        sec.join(" "),
        top.join(", ")
    );
}

fn compare(args: &[String]) -> Res<()> {
    let Some((reference, files)) = args.split_first() else {
        return Err("compare REF FILE…".into());
    };
    let r = load(reference)?;
    let sigma = 0.125;
    let r_phase = channel(&r, 0);
    let r_disc = disc_filter(&r_phase, GRID, sigma);
    let r_orders: Vec<Vec<f64>> = (1..KEPT.len()).map(|c| channel(&r, c)).collect();
    println!(
        "file,window,l2_raw,l2_disc,rms_rel_disc,max_rel_disc,l2_p0,l2_p1,l2_p2,l2_p3,l2_unfiltered"
    );
    for f in files {
        let v = load(f)?;
        let phase = channel(&v, 0);
        let raw = window_sums(&phase, &r_phase);
        let phase_disc = disc_filter(&phase, GRID, sigma);
        locate(f, &phase_disc, &r_disc);
        let disc = window_sums(&phase_disc, &r_disc);
        let orders: Vec<Vec<[f64; 5]>> = r_orders
            .iter()
            .enumerate()
            .map(|(c, ro)| window_sums(&channel(&v, c + 1), ro))
            .collect();
        for (w, &(name, _, _)) in ERROR_WINDOWS.iter().enumerate() {
            let l2 = |s: &[f64; 5]| (s[0] / s[1].max(f64::MIN_POSITIVE)).sqrt();
            let per: Vec<String> = orders
                .iter()
                .map(|o| format!("{:.3e}", l2(&o[w])))
                .collect();
            println!(
                "{f},{name},{:.3e},{:.3e},{:.3e},{:.3e},{}",
                l2(&raw[w]),
                l2(&disc[w]),
                (disc[w][2] / disc[w][3]).sqrt(),
                disc[w][4],
                per.join(",")
            );
        }
    }
    Ok(())
}

fn map(args: &[String]) -> Res<()> {
    let [a_mm, lambda, sun] = args else {
        return Err("map RADIUS_MM WAVELENGTH_NM SUN_DEG".into());
    };
    let (a_mm, lambda, sun) = (
        a_mm.parse::<f64>()?,
        lambda.parse::<f64>()?,
        sun.parse::<f64>()?,
    );
    let n = WaterIndexModel::SadeghiTable32.index(lambda)?;
    let shape = DropShape::beard_chuang(a_mm);
    let cfg = TraceConfig {
        rays: 2,
        max_order: 3,
        sun_elevation_rad: sun.to_radians(),
        wavelength_nm: lambda,
        n,
        ray_grid: RayGridLayout::Silhouette,
    };
    let bs: Vec<f64> = (0..4000).map(|i| (i as f64 + 0.5) / 4000.0).collect();
    println!(
        "{a_mm} mm {lambda} nm (n = {n:.4}) sun {sun}°; sphere rainbow rays b2 = {:.4}, b3 = {:.4}",
        ((4.0 - n * n) / 3.0).sqrt(),
        ((9.0 - n * n) / 8.0).sqrt()
    );
    println!("psi_deg,order,b_extreme,theta_extreme_deg,b_range_primary,b_range_secondary");
    for step in 0..24 {
        let psi = (step as f64 * 15.0).to_radians();
        let dirs = outgoing_directions(&shape, &cfg, psi, &bs);
        for p in [2usize, 3] {
            let th: Vec<Option<f64>> = dirs
                .iter()
                .map(|d| d[p].map(|x| x.0.to_degrees()))
                .collect();
            let extreme = th
                .iter()
                .enumerate()
                .filter_map(|(i, t)| t.map(|t| (i, t)))
                .fold(None::<(usize, f64)>, |acc, (i, t)| match acc {
                    Some((_, best)) if (p == 2 && t >= best) || (p == 3 && t <= best) => acc,
                    _ => Some((i, t)),
                });
            let range = |lo: f64, hi: f64| {
                let inside: Vec<f64> = th
                    .iter()
                    .zip(&bs)
                    .filter(|(t, _)| t.is_some_and(|t| (lo..=hi).contains(&t)))
                    .map(|(_, &b)| b)
                    .collect();
                match (inside.first(), inside.last()) {
                    (Some(a), Some(b)) => format!(
                        "{a:.3}-{b:.3} ({:.0}%)",
                        100.0 * inside.len() as f64 / bs.len() as f64
                    ),
                    _ => "none".into(),
                }
            };
            let (bx, tx) = extreme.map_or((f64::NAN, f64::NAN), |(i, t)| (bs[i], t));
            println!(
                "{},{p},{bx:.4},{tx:.3},{},{}",
                step * 15,
                range(134.0, 150.0),
                range(115.0, 134.0)
            );
        }
    }
    Ok(())
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("entry") => entry(&args[1..]),
        Some("compare") => compare(&args[1..]),
        Some("map") => map(&args[1..]),
        _ => Err("usage: ray_density entry|compare|map …".into()),
    }
}
