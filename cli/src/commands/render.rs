//! `scatterbake` glue for [`scatterbake::consumers::render::rainbow`].

use anyhow::Context;
use scatterbake::consumers::image::write_png;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
use scatterbake::consumers::read::spectrum::{THETA_STEP_DEG, xyz_vs_angle};
#[allow(unused_imports)]
use scatterbake::consumers::render::rainbow::*;
use scatterbake::optics::colour::linear_srgb_luminance;
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::path::PathBuf;

fn parse_rgb(s: &str) -> Result<[u8; 3], String> {
    let v: Vec<u8> = s
        .split(',')
        .map(|x| x.trim().parse::<u8>().map_err(|e| format!("`{s}`: {e}")))
        .collect::<Result<_, _>>()?;
    v.try_into().map_err(|_| format!("`{s}`: expected R,G,B"))
}

/// `scatterbake render rainbow`.
#[derive(Debug, Clone, clap::Args)]
pub struct RenderRainbowArgs {
    /// Phase-function table (.sbt): a 1-D table following the phase contract, or a ray-traced
    /// 2-D table (`raytrace-phase-2d`, drops with vertical symmetry axis).
    #[arg(long)]
    pub table: PathBuf,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Sun elevation; default 25° for 1-D tables, the table's lowest sun elevation for 2-D
    /// tables (which refuse elevations outside their sun_elevation axis).
    #[arg(long)]
    pub sun_elevation_deg: Option<f64>,
    /// Angular diameter of the sun disc (0 = point sun).
    #[arg(long, default_value_t = 0.5)]
    pub sun_diameter_deg: f64,
    /// Horizontal field of view.
    #[arg(long, default_value_t = 120.0)]
    pub fov_deg: f64,
    #[arg(long, default_value = "fisheye", value_parser = crate::commands::named::<Lens>(&Lens::NAMES))]
    pub lens: Lens,
    #[arg(long, default_value_t = 1024)]
    pub width: usize,
    /// Default: width · 2/3.
    #[arg(long)]
    pub height: Option<usize>,
    /// Elevation of the view axis (toward the antisolar azimuth); default: the midpoint between
    /// the antisolar point and the top of the secondary bow, 51° above it.
    #[arg(long)]
    pub view_elevation_deg: Option<f64>,
    /// Rain extinction coefficient (1/km).
    #[arg(long, default_value_t = 0.5)]
    pub extinction_per_km: f64,
    #[arg(long, default_value_t = 1500.0)]
    pub rain_top_m: f64,
    #[arg(long, default_value_t = 300.0)]
    pub rain_near_m: f64,
    /// Ray-marching steps per view ray.
    #[arg(long, default_value_t = 64)]
    pub steps: usize,
    /// Linear exposure multiplier; default: automatic (99.5th luminance percentile → 0.9).
    #[arg(long)]
    pub exposure: Option<f64>,
    /// Rendering intensity (Table 3.4 "Intensity", 1 = 100 %).
    #[arg(long, default_value_t = 1.0)]
    pub intensity: f64,
    /// Background sRGB colour added to the render, R,G,B in 0–255 (Table 3.4).
    #[arg(long, default_value = "0,0,0", value_parser = parse_rgb)]
    pub background: [u8; 3],
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run the renderer; prints the measured bow radii next to the table's.
pub fn run_render_rainbow(args: &RenderRainbowArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.width >= 2 && args.steps >= 1,
        "width ≥ 2 and steps ≥ 1"
    );
    anyhow::ensure!(
        args.fov_deg > 0.0 && (args.lens == Lens::Fisheye || args.fov_deg < 179.0),
        "fov must be positive (and below 179° for a rectilinear lens)"
    );
    anyhow::ensure!(
        (0.0..=10.0).contains(&args.sun_diameter_deg),
        "--sun-diameter-deg must be within 0…10°"
    );
    let table = scatterbake::table::Table::open(&args.table)
        .map_err(|e| anyhow::anyhow!(e))
        .with_context(|| args.table.display().to_string())?;
    // 1-D tables: the phase contract; 2-D ray-traced tables: a slice at the sun elevation.
    enum Source {
        OneD(Box<PhaseTable>),
        TwoD(
            Box<scatterbake::consumers::read::phase2d::PhaseSlice>,
            String,
        ),
    }
    let (source, sun_elevation_deg) = if scatterbake::consumers::read::phase2d::is_2d(&table) {
        let t2 = scatterbake::consumers::read::phase2d::Phase2dTable::new(table)
            .with_context(|| args.table.display().to_string())?;
        let e = t2.resolve_elevation(args.sun_elevation_deg)?;
        let slice = t2.slice(e, &args.entry, "phase")?;
        let label = format!(
            "2-D table, radius {}, sun elevation {e} deg{}",
            t2.radius_label(&slice.entry),
            if args.sun_elevation_deg.is_none() {
                " (table default)"
            } else {
                ""
            }
        );
        (Source::TwoD(Box::new(slice), label), e)
    } else {
        let pt = PhaseTable::new(table).with_context(|| args.table.display().to_string())?;
        (
            Source::OneD(Box::new(pt)),
            args.sun_elevation_deg.unwrap_or(25.0),
        )
    };
    anyhow::ensure!(
        (-90.0..=90.0).contains(&sun_elevation_deg),
        "--sun-elevation-deg must be within −90…90°"
    );
    let camera = Camera {
        lens: args.lens,
        width: args.width,
        height: args.height.unwrap_or(args.width * 2 / 3).max(2),
        fov_deg: args.fov_deg,
        view_elevation_deg: args
            .view_elevation_deg
            .unwrap_or(0.5 * 51.0 - sun_elevation_deg),
    };
    let scene = Scene {
        sun_elevation_deg,
        sun_diameter_deg: args.sun_diameter_deg,
        extinction_per_km: args.extinction_per_km,
        rain_top_m: args.rain_top_m,
        rain_near_m: args.rain_near_m,
        camera_height_m: 1.7,
        steps: args.steps,
    };
    let t0 = std::time::Instant::now();
    let r = match &source {
        Source::OneD(pt) => render(pt, &args.entry, &scene, &camera)?,
        Source::TwoD(slice, _) => render_2d(slice, &scene, &camera)?,
    };
    let seconds = t0.elapsed().as_secs_f64();
    let exposure = args
        .exposure
        .unwrap_or_else(|| auto_exposure(&r.linear_srgb));
    let rgb = to_srgb8(&r.linear_srgb, exposure, args.intensity, args.background);
    write_png(&args.out, camera.width, camera.height, &rgb)?;
    let what = match &source {
        Source::OneD(pt) => {
            let entry = pt.resolve_entry(&args.entry)?;
            describe_entry(&pt.table, &entry)
        }
        Source::TwoD(_, label) => label.clone(),
    };
    eprintln!(
        "rendered {} ({}x{}, {:?}, fov {} deg, sun {} deg, disc {} deg, {}) in {seconds:.1} s, exposure {:.4e}",
        args.out.display(),
        camera.width,
        camera.height,
        camera.lens,
        camera.fov_deg,
        sun_elevation_deg,
        args.sun_diameter_deg,
        what,
        exposure
    );
    let xyz = match &source {
        Source::OneD(pt) => Some(xyz_vs_angle(pt, &args.entry, args.sun_diameter_deg)?),
        Source::TwoD(..) => None,
    };
    // The brightest pixel of the centre column within each window; a 2-D table's bow may lie
    // outside it (flattened drops move the top of the bow), which the edge note reports.
    let windows = [("primary", 36.0, 46.0), ("secondary", 48.0, 56.0)];
    let mut radii = [f64::NAN; 2];
    for (w, (name, lo, hi)) in windows.into_iter().enumerate() {
        if let Some(m) = measure_bow(&r, sun_elevation_deg, lo, hi) {
            radii[w] = m.radius_deg;
            let table_max = match (&source, &xyz) {
                (_, Some(xyz)) => table_bow_radius(xyz, lo, hi),
                (Source::TwoD(slice, _), None) => {
                    table_bow_radius_2d(slice.as_ref(), args.sun_diameter_deg, lo, hi)
                }
                _ => f64::NAN,
            };
            eprintln!(
                "{name} bow (centre column, top of the bow): image radius {:.2} deg (R {:.2}, G {:.2}, B {:.2}), table maximum {:.2} deg, pixel {:.3} deg",
                m.radius_deg,
                m.radius_rgb_deg[0],
                m.radius_rgb_deg[1],
                m.radius_rgb_deg[2],
                table_max,
                camera.pixel_deg()
            );
            if m.radius_deg - lo < camera.pixel_deg() || hi - m.radius_deg < camera.pixel_deg() {
                eprintln!("  (at the edge of the {lo}-{hi} deg window: no {name} maximum inside)");
                // Not a bow: keep it out of the band and fringe reports below.
                radii[w] = f64::NAN;
            }
        }
    }
    // Supernumerary fringes inside the primary (up to 5° inside its maximum), image column vs
    // the disc-averaged table luminance (1-D tables).
    if let (Some(xyz), true) = (&xyz, radii[0].is_finite()) {
        let (lo, hi) = (radii[0] - 5.0, radii[0] - 0.3);
        let mut column: Vec<(f64, f64)> = centre_column(&r, sun_elevation_deg)
            .unwrap_or_default()
            .into_iter()
            .map(|(radius, p)| (radius, linear_srgb_luminance(p)))
            .collect();
        column.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut table: Vec<(f64, f64)> = xyz
            .iter()
            .enumerate()
            .map(|(i, v)| (180.0 - i as f64 * THETA_STEP_DEG, v[1]))
            .collect();
        table.sort_by(|a, b| a.0.total_cmp(&b.0));
        let fmt = |v: Vec<f64>| {
            v.iter()
                .rev()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        eprintln!(
            "supernumerary maxima inside the primary ({lo:.1}-{hi:.1} deg, outermost first): image [{}], table [{}]",
            fmt(prominent_maxima(&column, lo, hi, 0.02)),
            fmt(prominent_maxima(&table, lo, hi, 0.02))
        );
    }
    // Alexander's dark band: between the bows (1° clear of each maximum) against the sky
    // inside the primary (from 10° to 2° inside its maximum), centre column.
    if radii.iter().all(|r| r.is_finite()) && radii[1] - radii[0] > 3.0 {
        let band = column_mean_luminance(&r, sun_elevation_deg, radii[0] + 1.0, radii[1] - 1.0);
        let inside = column_mean_luminance(&r, sun_elevation_deg, radii[0] - 10.0, radii[0] - 2.0);
        if let (Some(b), Some(i)) = (band, inside) {
            eprintln!(
                "Alexander's dark band ({:.1}-{:.1} deg): mean luminance {:.3e} = {:.2} x the sky inside the primary ({:.1}-{:.1} deg, {:.3e})",
                radii[0] + 1.0,
                radii[1] - 1.0,
                b,
                b / i,
                radii[0] - 10.0,
                radii[0] - 2.0,
                i
            );
        }
    }
    Ok(())
}
