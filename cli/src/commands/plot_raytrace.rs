//! `scatterbake` glue for [`scatterbake::consumers::plot::raytrace`].

use anyhow::{Context, anyhow};
#[allow(unused_imports)]
use scatterbake::consumers::plot::raytrace::*;
use scatterbake::consumers::read::operators::SunDisc;
use scatterbake::consumers::read::phase::EntrySelection;
use scatterbake::consumers::read::phase2d::Phase2dTable;
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::path::PathBuf;

/// `scatterbake plot-raytrace`: plots of 2-D ray-traced tables (one or several, e.g. one per
/// drop radius).
#[derive(Debug, Clone, clap::Args)]
pub struct PlotRaytraceArgs {
    /// 2-D tables (`raytrace-phase-2d`); the bows plot draws one curve/strip per table.
    #[arg(required = true)]
    pub tables: Vec<PathBuf>,
    /// bows: the bows near the rainbow angles per outgoing azimuth with colour strips;
    /// latlong: a latitude–longitude map of the outgoing directions.
    #[arg(long, value_enum, default_value = "bows")]
    pub kind: RaytracePlotKind,
    /// Entry selection for extra entry axes (e.g. radius=1000); `--sun-elevation-deg` selects
    /// the elevation.
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Sun elevation (default: each table's lowest).
    #[arg(long)]
    pub sun_elevation_deg: Option<f64>,
    /// Wavelength of the phase curves / the lat-long map (nearest table wavelength).
    #[arg(long, default_value_t = 650.0)]
    pub wavelength_nm: f64,
    /// Sun disc of the colour strips (deg). Default: the disc the tables already averaged over
    /// (attribute `sun_diameter_deg`), 0.5 for point-sun tables (what the ray tracer writes).
    #[arg(long)]
    pub sun_diameter_deg: Option<f64>,
    /// Polar-angle range of the bows plot, LO,HI in deg.
    #[arg(long, default_value = "120,150")]
    pub polar_range: String,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1500)]
    pub width: u32,
    /// Image height in pixels (default: from the plot's layout).
    #[arg(long)]
    pub height: Option<u32>,
    /// Output .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `scatterbake plot-raytrace`; prints the bow peaks (bows).
pub fn run_plot_raytrace(args: &PlotRaytraceArgs) -> anyhow::Result<()> {
    let (a, b) = args
        .polar_range
        .split_once(',')
        .ok_or_else(|| anyhow!("--polar-range: expected LO,HI"))?;
    let range: (f64, f64) = (a.trim().parse()?, b.trim().parse()?);
    anyhow::ensure!(
        0.0 <= range.0 && range.0 < range.1 && range.1 <= 180.0,
        "--polar-range: need 0 <= LO < HI <= 180"
    );
    let mut inputs = vec![];
    let mut disc: Option<SunDisc> = None;
    for path in &args.tables {
        let t2 = Phase2dTable::open(path)?;
        let d = SunDisc::plan(&t2.table, args.sun_diameter_deg)
            .with_context(|| crate::display::path(path))?;
        if let Some(first) = disc {
            anyhow::ensure!(
                first == d,
                "{}: {} (the first table: {}); one figure needs one sun disc",
                crate::display::path(path),
                d.describe(),
                first.describe()
            );
        }
        disc = Some(d);
        let e = t2.resolve_elevation(args.sun_elevation_deg)?;
        let slice = t2.slice(e, &args.entry, "phase")?;
        let label = format!("a = {}", t2.radius_label(&slice.entry));
        let primary_order = t2.slice(e, &args.entry, "phase_p2").ok();
        inputs.push(BowInput {
            label,
            slice,
            primary_order,
        });
    }
    match args.kind {
        RaytracePlotKind::Latlong => {
            let s = &inputs[0].slice;
            let k = crate::args::nearest_wavelength(&s.wavelengths_nm, args.wavelength_nm);
            let prefix = format!("{}: ", inputs[0].label);
            plot_latlong(
                s,
                k,
                &prefix,
                &args.out,
                (args.width, args.height.unwrap_or(args.width * 3 / 5)),
            )?;
        }
        RaytracePlotKind::Bows => {
            let h = args
                .height
                .unwrap_or(600 + 30 * inputs.len() as u32 + 60 + 30);
            let disc = disc.ok_or_else(|| anyhow!("no tables"))?;
            eprintln!("{}", disc.describe());
            let peaks = plot_bows(
                &inputs,
                args.wavelength_nm,
                &disc,
                range,
                &args.out,
                (args.width, h),
            )?;
            for (inp, ps) in inputs.iter().zip(&peaks) {
                for p in ps {
                    println!(
                        "{}\tsun {} deg\tphi {:>5.1} deg\tphase peak {:.2} deg\tluminance peak {:.2} deg\tphase_p2 peak {}",
                        inp.label,
                        inp.slice.sun_elevation_deg,
                        p.azimuth_deg,
                        p.phase_peak_deg,
                        p.luminance_peak_deg,
                        p.order2_peak_deg
                            .map(|v| format!("{v:.2} deg"))
                            .unwrap_or_else(|| "-".into())
                    );
                }
            }
        }
    }
    eprintln!("wrote {}", crate::display::path(&args.out));
    Ok(())
}
/// What to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RaytracePlotKind {
    Bows,
    Latlong,
}
