//! `scatterbake` glue for [`scatterbake::consumers::render::rainbow`].

use anyhow::Context;
use scatterbake::consumers::image::write_png;
use scatterbake::consumers::read::operators::SunDisc;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
use scatterbake::consumers::read::phase2d::{Phase2dTable, PhaseSlice, is_2d};
use scatterbake::consumers::read::spectrum::xyz_vs_angle;
use scatterbake::consumers::render::measure::{
    RainbowMeasurements, TableReference, measure_rainbow,
};
#[allow(unused_imports)]
use scatterbake::consumers::render::rainbow::*;
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
    /// Entry selection, NAME=VALUE per entry axis, repeatable (e.g. radius=400; default: the
    /// first sample of each entry axis).
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Sun elevation; default 25° for 1-D tables, the table's lowest sun elevation for 2-D
    /// tables (which refuse elevations outside their sun_elevation axis).
    #[arg(long)]
    pub sun_elevation_deg: Option<f64>,
    /// Angular diameter of the sun disc (0 = point sun). Default: the disc the table already
    /// averaged over (attribute `sun_diameter_deg`; nothing more is applied), 0.5 for a
    /// point-sun table. A value smaller than the table's is refused.
    #[arg(long)]
    pub sun_diameter_deg: Option<f64>,
    /// Horizontal field of view.
    #[arg(long, default_value_t = 120.0)]
    pub fov_deg: f64,
    /// Projection: fisheye (equidistant) or rectilinear.
    #[arg(long, default_value = "fisheye", value_parser = crate::args::named::<Lens>(&Lens::NAMES))]
    pub lens: Lens,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1024)]
    pub width: usize,
    /// Image height in pixels (at least 2); default: width · 2/3, at least 2.
    #[arg(long)]
    pub height: Option<usize>,
    /// Elevation of the view axis (toward the antisolar azimuth); default: the midpoint between
    /// the antisolar point and the top of the secondary bow, 51° above it.
    #[arg(long)]
    pub view_elevation_deg: Option<f64>,
    /// Rain extinction coefficient (1/km).
    #[arg(long, default_value_t = 0.5)]
    pub extinction_per_km: f64,
    /// Top of the rain layer above the camera (m).
    #[arg(long, default_value_t = 1500.0)]
    pub rain_top_m: f64,
    /// Horizontal distance from the camera to the rain's near edge (m; clear air nearer).
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
    /// The sun's spectrum: `d65` (a high sun, the default) or `reddened`: D65 reddened by the
    /// extra air mass of the sun at --sun-elevation-deg through a clear atmosphere (Rayleigh,
    /// Hansen & Travis 1974, plus Ångström aerosol β = 0.05, α = 1.3; air mass of Kasten & Young
    /// 1989).
    #[arg(long, default_value = "d65", value_parser = ["d65", "reddened"])]
    pub sun_spectrum: String,
    /// Ideal linear polariser in front of the camera: transmission axis at this angle from the
    /// image's vertical (0 = vertical, 90 = horizontal). Uses the table's i_perp and i_par.
    #[arg(long)]
    pub polariser_deg: Option<f64>,
    /// Output PNG (`.png`; other extensions are refused).
    #[arg(long)]
    pub out: PathBuf,
}

/// The table a render reads: a 1-D phase table, or a 2-D ray-traced slice at the sun elevation.
enum Source {
    OneD(Box<PhaseTable>),
    /// The `phase` slice, and the `i_perp` and `i_par` slices for a polarised render.
    TwoD(Box<PhaseSlice>, Option<Box<(PhaseSlice, PhaseSlice)>>),
}

fn check_args(args: &RenderRainbowArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.width >= 2 && args.steps >= 1,
        "--width {} and --steps {}: need a width of at least 2 pixels and at least 1 step",
        args.width,
        args.steps
    );
    if let Some(h) = args.height {
        anyhow::ensure!(h >= 2, "--height {h}: need at least 2 pixels");
    }
    anyhow::ensure!(
        args.fov_deg > 0.0 && (args.lens == Lens::Fisheye || args.fov_deg < 179.0),
        "fov must be positive (and below 179° for a rectilinear lens)"
    );
    if let Some(p) = args.polariser_deg {
        anyhow::ensure!(
            p.is_finite() && (-360.0..=360.0).contains(&p),
            "--polariser-deg {p} must be an angle within -360…360°"
        );
    }
    image_format(&args.out)
}

/// The render writes PNG only: refuse any other extension before computing.
fn image_format(out: &std::path::Path) -> anyhow::Result<()> {
    match out.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") => Ok(()),
        _ => anyhow::bail!(
            "{}: render writes PNG images; the output must end in .png",
            crate::display::path(out)
        ),
    }
}

/// Open the table: the source, its sun elevation, the sun disc plan and a label.
fn load_source(args: &RenderRainbowArgs) -> anyhow::Result<(Source, f64, SunDisc, String)> {
    let table = Table::open(&args.table)
        .map_err(|e| anyhow::anyhow!(e))
        .with_context(|| crate::display::path(&args.table))?;
    let disc = SunDisc::plan(&table, args.sun_diameter_deg)
        .with_context(|| crate::display::path(&args.table))?;
    if is_2d(&table) {
        let t2 = Phase2dTable::new(table).with_context(|| crate::display::path(&args.table))?;
        let e = t2.resolve_elevation(args.sun_elevation_deg)?;
        let slice = t2.slice(e, &args.entry, "phase")?;
        let polarised = match args.polariser_deg {
            Some(_) => Some(Box::new((
                t2.slice(e, &args.entry, "i_perp")?,
                t2.slice(e, &args.entry, "i_par")?,
            ))),
            None => None,
        };
        let default = if args.sun_elevation_deg.is_none() {
            " (table default)"
        } else {
            ""
        };
        let label = format!(
            "2-D table, radius {}, sun elevation {e} deg{default}",
            t2.radius_label(&slice.entry)
        );
        Ok((Source::TwoD(Box::new(slice), polarised), e, disc, label))
    } else {
        let pt = PhaseTable::new(table).with_context(|| crate::display::path(&args.table))?;
        let label = describe_entry(&pt.table, &pt.resolve_entry(&args.entry)?);
        let e = args.sun_elevation_deg.unwrap_or(25.0);
        Ok((Source::OneD(Box::new(pt)), e, disc, label))
    }
}

/// Camera and scene of the arguments; the scene convolves only the disc the table lacks.
fn camera_and_scene(
    args: &RenderRainbowArgs,
    sun_elevation_deg: f64,
    disc: &SunDisc,
) -> (Camera, Scene) {
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
        sun_diameter_deg: disc.extra_deg,
        extinction_per_km: args.extinction_per_km,
        rain_top_m: args.rain_top_m,
        rain_near_m: args.rain_near_m,
        camera_height_m: 1.7,
        steps: args.steps,
        sun_spectrum: match args.sun_spectrum.as_str() {
            "reddened" => SunSpectrum::Reddened {
                elevation_deg: sun_elevation_deg,
                atmosphere: scatterbake::optics::atmosphere::ClearAtmosphere::CLEAN,
            },
            _ => SunSpectrum::D65,
        },
    };
    (camera, scene)
}

/// Run the renderer; prints the measured bow radii next to the table's.
pub fn run_render_rainbow(args: &RenderRainbowArgs) -> anyhow::Result<()> {
    check_args(args)?;
    let (source, sun_elevation_deg, disc, what) = load_source(args)?;
    anyhow::ensure!(
        (-90.0..=90.0).contains(&sun_elevation_deg),
        "--sun-elevation-deg must be within −90…90°"
    );
    let (camera, scene) = camera_and_scene(args, sun_elevation_deg, &disc);
    let t0 = std::time::Instant::now();
    let r = {
        let progress = crate::progress::TerminalProgress::new("render", false);
        let polariser = args.polariser_deg.map(|angle_deg| Polariser { angle_deg });
        match (&source, polariser) {
            (Source::OneD(pt), None) => render(pt, &args.entry, &scene, &camera, &progress)?,
            (Source::OneD(pt), Some(p)) => {
                render_polarised(pt, &args.entry, &scene, &camera, p, &progress)?
            }
            (Source::TwoD(slice, _), None) => render_2d(slice, &scene, &camera, &progress)?,
            (Source::TwoD(_, Some(pair)), Some(p)) => {
                render_2d_polarised(&pair.0, &pair.1, &scene, &camera, p, &progress)?
            }
            (Source::TwoD(_, None), Some(_)) => {
                anyhow::bail!("internal: polarised slices were not loaded")
            }
        }
    };
    let seconds = t0.elapsed().as_secs_f64();
    let exposure = args
        .exposure
        .unwrap_or_else(|| auto_exposure(&r.linear_srgb));
    let rgb = to_srgb8(&r.linear_srgb, exposure, args.intensity, args.background);
    write_png(&args.out, camera.width, camera.height, &rgb)?;
    eprintln!(
        "rendered {} ({}x{}, {:?}, fov {} deg, sun {} deg, {}) in {seconds:.1} s, exposure {:.4e}",
        crate::display::path(&args.out),
        camera.width,
        camera.height,
        camera.lens,
        camera.fov_deg,
        sun_elevation_deg,
        what,
        exposure
    );
    eprintln!("{}", disc.describe());
    let m = match &source {
        Source::OneD(pt) => {
            let xyz = xyz_vs_angle(pt, &args.entry, disc.extra_deg)?;
            measure_rainbow(&r, sun_elevation_deg, &TableReference::OneD(&xyz))
        }
        Source::TwoD(slice, _) => measure_rainbow(
            &r,
            sun_elevation_deg,
            &TableReference::TwoD(slice, disc.extra_deg),
        ),
    };
    print_measurements(&m, camera.pixel_deg());
    Ok(())
}

/// Print the measurements of a render.
fn print_measurements(m: &RainbowMeasurements, pixel_deg: f64) {
    for b in &m.bows {
        eprintln!(
            "{} bow (centre column, top of the bow): image radius {:.2} deg (R {:.2}, G {:.2}, B {:.2}), table maximum {:.2} deg, pixel {pixel_deg:.3} deg",
            b.name,
            b.image.radius_deg,
            b.image.radius_rgb_deg[0],
            b.image.radius_rgb_deg[1],
            b.image.radius_rgb_deg[2],
            b.table_max_deg,
        );
        if b.at_window_edge {
            eprintln!(
                "  (at the edge of the {}-{} deg window: no {} maximum inside)",
                b.window_deg.0, b.window_deg.1, b.name
            );
        }
        if !b.maxima.is_empty() {
            let list = b
                .maxima
                .iter()
                .map(|(r, y)| format!("{r:.2} ({y:.2})"))
                .collect::<Vec<_>>()
                .join(", ");
            eprintln!(
                "  luminance maxima in the {}-{} deg window, outermost first, deg (relative): {list}",
                b.window_deg.0, b.window_deg.1
            );
        }
    }
    let fmt = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(s) = &m.supernumeraries {
        eprintln!(
            "supernumerary maxima inside the primary ({:.1}-{:.1} deg, outermost first): image [{}], table [{}]",
            s.window_deg.0,
            s.window_deg.1,
            fmt(&s.image_deg),
            fmt(&s.table_deg)
        );
    }
    if let Some(d) = &m.dark_band {
        eprintln!(
            "Alexander's dark band ({:.1}-{:.1} deg): mean luminance {:.3e} = {:.2} x the sky inside the primary ({:.1}-{:.1} deg, {:.3e})",
            d.band_deg.0,
            d.band_deg.1,
            d.band_luminance,
            d.band_luminance / d.inside_luminance,
            d.inside_deg.0,
            d.inside_deg.1,
            d.inside_luminance
        );
    }
}
