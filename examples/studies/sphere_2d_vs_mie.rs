//! A sphere through the 2-D patch tracer (shape `profile` with a constant radius), against
//! scatrs Lorenz–Mie, per diffraction model of the 2-D path: relative L2 of the azimuth-mean
//! phase over 120–150° after a 0.5° sun disc, the worst column's L2, the azimuthal spread (std over
//! azimuth / mean, per polar row over 120–150°: raw, after the disc along θ per column, and after
//! the disc over the sphere of directions as `render` applies it), and the primary and
//! supernumerary maxima (both smoothed by σ = 0.04°·(0.4 mm/a)), and Alexander's band (mean
//! over 131–136° of the azimuth mean, before the disc) over Mie's. `airy-local-p3` is
//! `airy-local` without the equal-volume sphere's orders 4–6 (`sphere_higher_orders = false`).
//!
//! `cargo run --release --example sphere_2d_vs_mie -- [rays] [polar_step_deg] [azimuth_step_deg] [radius_um] [ray_grid] [mirror]`
//! (with `SPREAD_CSV_DIR=dir`, the per-row spreads and the azimuth mean over 120–150° are written
//! to `dir/<model>.csv`)
//! (default 600 0.0125 5 400 square average; the seed resolution is 3000 0.0125 0.2; `mirror` is
//! `average` for `mirror_symmetrise` or `half` for `mirror_half`).
#[path = "common/curves.rs"]
#[allow(dead_code)] // window_mean serves other examples
mod curves;
use curves::maxima;
#[path = "common/mie_reference.rs"]
mod mie_reference;
use mie_reference::{mie_phase, sun_disc};
use scatterbake::mie::filters::gaussian_blur_1d;
use scatterbake::stages::raytrace::{RaytraceJob, RaytraceParams};

fn rel_l2(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

/// The uniform sun disc of angular diameter `diam_deg` averaged over the sphere of directions,
/// as `render` does it: each pixel (polar row `j`, azimuth column `k`) becomes the
/// solid-angle-weighted mean of the pixels whose centres lie within the disc's radius of its own
/// centre (great-circle distance; pixel solid angle ∝ sin θ). `cols[k][j]`; the result has the
/// same layout, computed on rows `rows` only (zero elsewhere).
fn sun_disc_2d(
    cols: &[Vec<f64>],
    pstep_deg: f64,
    astep_deg: f64,
    diam_deg: f64,
    rows: std::ops::RangeInclusive<usize>,
) -> Vec<Vec<f64>> {
    let na = cols.len();
    let np = cols[0].len() as i64;
    let (pstep, astep) = (pstep_deg.to_radians(), astep_deg.to_radians());
    let cos_r = (0.5 * diam_deg).to_radians().cos();
    let dj_max = (0.5 * diam_deg / pstep_deg).ceil() as i64;
    let mut out = vec![vec![0.0; np as usize]; na];
    for j in rows {
        let th = j as f64 * pstep;
        // Per row offset: the azimuth columns within the disc, and the row's weight.
        let mut spans = Vec::new();
        for dj in -dj_max..=dj_max {
            let jj = j as i64 + dj;
            if jj < 0 || jj >= np {
                continue;
            }
            let th2 = jj as f64 * pstep;
            let (s, s2) = (th.sin(), th2.sin());
            let c = (cos_r - th.cos() * th2.cos()) / (s * s2);
            if c > 1.0 {
                continue;
            }
            let dphi = c.max(-1.0).acos();
            let dk = (dphi / astep).floor() as i64;
            spans.push((jj as usize, dk, s2));
        }
        for (k, o) in out.iter_mut().enumerate() {
            let (mut sum, mut wsum) = (0.0, 0.0);
            for &(jj, dk, w) in &spans {
                for d in -dk..=dk {
                    let kk = (k as i64 + d).rem_euclid(na as i64) as usize;
                    sum += w * cols[kk][jj];
                    wsum += w;
                }
            }
            o[j] = sum / wsum;
        }
    }
    out
}

type Error = Box<dyn std::error::Error>;

/// The settings every diffraction model is traced with, and the Mie reference.
struct Setup {
    rays: usize,
    pstep: f64,
    astep: f64,
    a: f64,
    ray_grid: String,
    mirror_half: bool,
    lambda: f64,
    elev: f64,
    angles: Vec<f64>,
    /// Rows of 120° and 150°.
    lo: usize,
    hi: usize,
    mie: Vec<f64>,
    mie_disc: Vec<f64>,
    /// σ of the smoothing before the maxima are read (rows).
    sig: f64,
    mie_max: Vec<f64>,
}

impl Setup {
    fn from_args() -> Result<Setup, Error> {
        let args: Vec<String> = std::env::args().skip(1).collect();
        let arg = |i: usize, d: f64| args.get(i).map_or(d, |s| s.parse().unwrap());
        let (rays, pstep, astep, a) = (
            arg(0, 600.0) as usize,
            arg(1, 0.0125),
            arg(2, 5.0),
            arg(3, 400.0),
        );
        let ray_grid = args.get(4).map_or("square", String::as_str).to_string();
        let mirror_half = match args.get(5).map_or("average", String::as_str) {
            "average" => false,
            "half" => true,
            other => return Err(format!("mirror must be average or half, not {other}").into()),
        };
        let (lambda, elev) = (650.0, 17.0);
        let angles: Vec<f64> = (0..=((180.0 / pstep).round() as usize))
            .map(|j| j as f64 * pstep)
            .collect();
        let (lo, hi) = (
            (120.0 / pstep).round() as usize,
            (150.0 / pstep).round() as usize,
        );
        let mie = mie_phase(a, lambda, 1.331, &angles);
        let mie_disc = sun_disc(&mie, pstep, 0.5);
        let sig = 0.04 * (400.0 / a) / pstep;
        let mie_s = gaussian_blur_1d(&mie, 1.0, sig);
        let peak = mie_s[lo..=hi].iter().copied().fold(0.0, f64::max);
        let mie_max = maxima(&angles, &mie_s, 137.0, 145.0, 0.1 * peak);
        Ok(Setup {
            rays,
            pstep,
            astep,
            a,
            ray_grid,
            mirror_half,
            lambda,
            elev,
            angles,
            lo,
            hi,
            mie,
            mie_disc,
            sig,
            mie_max,
        })
    }

    /// The rows 120–150° of `v`.
    fn win(&self, v: &[f64]) -> Vec<f64> {
        v[self.lo..=self.hi].to_vec()
    }

    /// Mean of `v` over Alexander's band (131–136°).
    fn band(&self, v: &[f64]) -> f64 {
        let sel: Vec<f64> = self
            .angles
            .iter()
            .zip(v)
            .filter(|(t, _)| (131.0..=136.0).contains(*t))
            .map(|(_, x)| *x)
            .collect();
        sel.iter().sum::<f64>() / sel.len() as f64
    }

    /// Azimuthal spread (std / mean) of each row 120–150° of the columns `cs`.
    fn row_spread(&self, cs: &[Vec<f64>]) -> Vec<f64> {
        let na = cs.len() as f64;
        (self.lo..=self.hi)
            .map(|j| {
                let m = cs.iter().map(|c| c[j]).sum::<f64>() / na;
                let var = cs.iter().map(|c| (c[j] - m).powi(2)).sum::<f64>() / na;
                var.sqrt() / m
            })
            .collect()
    }

    /// Median and maximum of [`Setup::row_spread`].
    fn spread(&self, cs: &[Vec<f64>]) -> (f64, f64) {
        let mut s = self.row_spread(cs);
        s.sort_by(f64::total_cmp);
        (s[s.len() / 2], s[s.len() - 1])
    }

    /// The azimuth columns (`cols[k][j]`, channel 0 = phase per unit σ) of the 2-D trace with
    /// `model`, and the trace time in seconds.
    fn trace(&self, model: &str, higher: bool) -> Result<(Vec<Vec<f64>>, f64), Error> {
        let (a, lambda, elev, rays) = (self.a, self.lambda, self.elev, self.rays);
        let (ray_grid, pstep, astep, mirror_half) =
            (&self.ray_grid, self.pstep, self.astep, self.mirror_half);
        let toml = format!(
            "shape = \"profile\"\nradii_um = [{a}]\nwavelengths_nm = [{lambda}]\nwater_index_model = \"sadeghi-table-3.2\"\nsun_elevation_deg = [{elev}]\nrays = {rays}\nray_grid = \"{ray_grid}\"\npolar_step_deg = {pstep}\nazimuth_step_deg = {astep}\ndiffraction_model = \"{model}\"\nsphere_higher_orders = {higher}\nmirror_half = {mirror_half}\nprofile_theta_deg = [0.0, 90.0, 180.0]\nprofile_r = [1.0, 1.0, 1.0]"
        );
        let p: RaytraceParams = toml::from_str(&toml)?;
        let job = RaytraceJob::new(p)?;
        let t0 = std::time::Instant::now();
        let (values, _sigma) = job.trace_2d(lambda, elev)?;
        let secs = t0.elapsed().as_secs_f64();
        let (np, na) = (self.angles.len(), (360.0 / astep).round() as usize);
        let nch = values.len() / (np * na);
        // Channel 0 = phase (per unit σ; the table renormalises, so compare shapes after scaling
        // the mean to Mie over the window).
        let col =
            |k: usize| -> Vec<f64> { (0..np).map(|j| values[(j * na + k) * nch] as f64).collect() };
        Ok(((0..na).map(col).collect(), secs))
    }
}

fn main() -> Result<(), Error> {
    let s = Setup::from_args()?;
    println!(
        "sphere a = {} µm, {} nm, n = 1.331, sun {}°, {}² rays ({} grid), {}° × {}°, mirror_half = {}",
        s.a, s.lambda, s.elev, s.rays, s.ray_grid, s.pstep, s.astep, s.mirror_half
    );
    println!(
        "Mie maxima (primary, supernumeraries): {:?}",
        s.mie_max
            .iter()
            .take(5)
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>()
    );
    for (model, higher) in [
        ("gaussian", true),
        ("airy-local", true),
        ("airy-local", false),
    ] {
        let (cols, secs) = s.trace(model, higher)?;
        let model = if higher {
            model.to_string()
        } else {
            format!("{model}-p3")
        };
        let na = cols.len();
        let mean: Vec<f64> = (0..s.angles.len())
            .map(|j| cols.iter().map(|c| c[j]).sum::<f64>() / na as f64)
            .collect();
        println!(
            "{model:>10}: Alexander's band (131–136°, azimuth mean, per unit σ) / Mie: {:.3}",
            s.band(&mean) / s.band(&s.mie)
        );
        report_spread(&s, &model, &cols, &mean)?;
        report_accuracy(&s, &model, &cols, &mean, secs);
    }
    Ok(())
}

/// The azimuthal spread: raw near the caustics, after the disc over the sphere of directions
/// (`SPREAD_CSV_DIR` gets the per-row spreads).
fn report_spread(s: &Setup, model: &str, cols: &[Vec<f64>], mean: &[f64]) -> Result<(), Error> {
    let (angles, lo) = (&s.angles, s.lo);
    let raw_rows = s.row_spread(cols);
    let discs: Vec<Vec<f64>> = cols.iter().map(|c| sun_disc(c, s.pstep, 0.5)).collect();
    let disc_rows = s.row_spread(&discs);
    // Largest raw spread around the primary and secondary caustics.
    let caustic_spread = raw_rows
        .iter()
        .enumerate()
        .filter(|(i, _)| {
            let t = angles[lo + i];
            (136.8..=138.5).contains(&t) || (128.8..=130.4).contains(&t)
        })
        .map(|(_, s)| *s)
        .fold(0.0, f64::max);
    let worst_row = (0..raw_rows.len())
        .max_by(|&x, &y| raw_rows[x].total_cmp(&raw_rows[y]))
        .unwrap_or(0);
    // The disc over the sphere of directions (what `render` shows): rows lo..=hi only.
    let discs_2d = sun_disc_2d(cols, s.pstep, s.astep, 0.5, lo..=s.hi);
    let disc2_rows = s.row_spread(&discs_2d);
    let (d2m, d2x) = s.spread(&discs_2d);
    let d2_row = angles[lo
        + (0..disc2_rows.len())
            .max_by(|&x, &y| disc2_rows[x].total_cmp(&disc2_rows[y]))
            .unwrap_or(0)];
    if let Some(dir) = std::env::var_os("SPREAD_CSV_DIR") {
        let mut csv = String::from("theta_deg,spread_raw,spread_disc,spread_disc_2d,mean,mie\n");
        for (i, ((r, d), d2)) in raw_rows.iter().zip(&disc_rows).zip(&disc2_rows).enumerate() {
            let j = lo + i;
            csv += &format!("{},{r},{d},{d2},{},{}\n", angles[j], mean[j], s.mie[j]);
        }
        std::fs::write(std::path::Path::new(&dir).join(format!("{model}.csv")), csv)?;
    }
    // Maxima of the mean on the dark side of the primary (137–137.9°), which Mie lacks.
    let s2 = gaussian_blur_1d(mean, 1.0, s.sig);
    let dark: Vec<String> = maxima(
        angles,
        &s2,
        137.0,
        137.9,
        0.01 * s.win(&s2).into_iter().fold(0.0, f64::max),
    )
    .iter()
    .map(|x| format!("{x:.3}"))
    .collect();
    println!(
        "{model:>10}: worst raw-spread row {:.4}°, largest raw spread at the caustics (136.8–138.5°, 128.8–130.4°) {:.2} %, dark-side (137–137.9°) maxima of the mean {dark:?}",
        angles[lo + worst_row],
        100.0 * caustic_spread
    );
    println!(
        "{model:>10}: spread after the disc over the sphere of directions (as rendered): median {:.3} % max {:.3} % (at {d2_row:.4}°)",
        100.0 * d2m,
        100.0 * d2x
    );
    Ok(())
}

/// L2 of the mean and of the worst column after the disc, the spreads, and the maxima against
/// Mie's.
fn report_accuracy(s: &Setup, model: &str, cols: &[Vec<f64>], mean: &[f64], secs: f64) {
    let l2 = rel_l2(&s.win(&sun_disc(mean, s.pstep, 0.5)), &s.win(&s.mie_disc));
    let worst = cols
        .iter()
        .map(|c| rel_l2(&s.win(&sun_disc(c, s.pstep, 0.5)), &s.win(&s.mie_disc)))
        .fold(0.0, f64::max);
    let (sm, sx) = s.spread(cols);
    let discs: Vec<Vec<f64>> = cols.iter().map(|c| sun_disc(c, s.pstep, 0.5)).collect();
    let (dm, dx) = s.spread(&discs);
    let s2 = gaussian_blur_1d(mean, 1.0, s.sig);
    let mx = maxima(
        &s.angles,
        &s2,
        137.0,
        145.0,
        0.1 * s.win(&s2).into_iter().fold(0.0, f64::max),
    );
    let dev = mx
        .iter()
        .zip(&s.mie_max)
        .take(5)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    println!(
        "{model:>10}: L2 (mean, disc) {:.2} %, worst column {:.2} %, spread raw median {:.2} % max {:.2} %, after disc median {:.3} % max {:.3} %, maxima {:?} (max dev {:.3}°), trace {secs:.1} s",
        100.0 * l2,
        100.0 * worst,
        100.0 * sm,
        100.0 * sx,
        100.0 * dm,
        100.0 * dx,
        mx.iter()
            .take(5)
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>(),
        dev
    );
}
