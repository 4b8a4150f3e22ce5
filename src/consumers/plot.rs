//! Pictures of tables (`scatterbake plot`), drawn with `plotters` (PNG through its bitmap
//! backend + the `png` encoder, or SVG), text in the bundled DejaVu Sans (assets/fonts).
//!
//! Kinds:
//! - `phase`: phase function vs scattering angle, log scale, one curve per wavelength drawn in
//!   that wavelength's own colour (CIE 1931 → sRGB, desaturated into gamut); with `--polarised`
//!   i_perp dashed and i_par dotted;
//! - `strip`: the colour the sun (D65, disc averaged) produces at each scattering angle —
//!   XYZ = Σ_k W_k P̄_k(θ) → sRGB, normalised to the brightest angle of the strip;
//! - `lee`: Lee diagram: drop radius (x) × angle from the antisolar point (y) → colour, each
//!   radius column normalised to its own brightest angle (otherwise small drops are invisible);
//! - `heatmap`: any table with ≥ 2 axes: the last two axes as x/y (e.g. outgoing_azimuth ×
//!   outgoing_polar: a lat-long image of a 2-D phase function), other axes at the entry
//!   selection, one channel, log10 colour scale (viridis) when the data are positive and span
//!   more than two decades;
//! - `line`: channels of a 1-D table vs its axis.
//!
//! `auto` (and [`previews`]) picks phase + strip (+ lee when there is a radius axis) for phase
//! tables, heatmap for other tables of ≥ 2 axes and line for 1-D tables.

use super::phase::{EntrySelection, PhaseTable};
use super::render::{THETA_STEP_DEG, xyz_vs_angle};
use crate::optics::colour::{cie1931_xyz_bar, srgb_encode, xyz_to_linear_srgb};
use crate::table::Table;
use anyhow::{Context, anyhow, bail};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

pub(crate) fn ensure_font() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

pub(crate) fn perr<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e:?}")
}

/// Run `draw` on a PNG or SVG backend chosen by the extension of `out`.
macro_rules! with_backend {
    ($out:expr, $size:expr, |$root:ident| $body:expr) => {{
        ensure_font();
        let out: &Path = $out;
        let size: (u32, u32) = $size;
        match out
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("svg") => {
                let $root = SVGBackend::new(out, size).into_drawing_area();
                $body?;
                $root.present().map_err(perr)?;
            }
            Some("png") => {
                let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
                {
                    let $root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
                    $body?;
                    $root.present().map_err(perr)?;
                }
                super::render::write_png(out, size.0 as usize, size.1 as usize, &buf)?;
            }
            _ => bail!("{}: output must end in .png or .svg", out.display()),
        }
        Ok::<(), anyhow::Error>(())
    }};
}
pub(crate) use with_backend;

/// Display colour of a monochromatic wavelength: CIE 1931 → linear sRGB, desaturated toward
/// white until in gamut, scaled to a maximum of 1, sRGB-encoded; darkened toward the ends of
/// the visible range where the eye's response fades.
pub fn wavelength_colour(wavelength_nm: f64) -> RGBColor {
    let xyz = cie1931_xyz_bar(wavelength_nm.clamp(380.0, 780.0));
    let mut rgb = xyz_to_linear_srgb(xyz);
    let min = rgb.iter().cloned().fold(f64::INFINITY, f64::min);
    if min < 0.0 {
        for c in &mut rgb {
            *c -= min;
        }
    }
    let max = rgb.iter().cloned().fold(0.0, f64::max).max(1e-12);
    let fade = (xyz[1] / 0.2).clamp(0.35, 1.0);
    let e = |c: f64| (srgb_encode(c / max * fade) * 255.0).round() as u8;
    RGBColor(e(rgb[0]), e(rgb[1]), e(rgb[2]))
}

/// XYZ → 8-bit sRGB colour after scaling by `scale` (clipped).
pub(crate) fn xyz_colour(xyz: [f64; 3], scale: f64) -> RGBColor {
    let l = xyz_to_linear_srgb([xyz[0] * scale, xyz[1] * scale, xyz[2] * scale]);
    let e = |c: f64| (srgb_encode(c) * 255.0).round() as u8;
    RGBColor(e(l[0]), e(l[1]), e(l[2]))
}

/// Which wavelengths to draw: the requested ones (nearest), or up to 8 spread over the table.
fn pick_wavelengths(all: &[f64], wanted: &[f64]) -> Vec<usize> {
    if !wanted.is_empty() {
        let mut v: Vec<usize> = wanted
            .iter()
            .map(|w| {
                (0..all.len())
                    .min_by(|&a, &b| (all[a] - w).abs().total_cmp(&(all[b] - w).abs()))
                    .unwrap()
            })
            .collect();
        v.dedup();
        return v;
    }
    let n = all.len();
    if n <= 8 {
        return (0..n).collect();
    }
    let mut v: Vec<usize> = (0..8).map(|i| i * (n - 1) / 7).collect();
    v.dedup();
    v
}

/// Phase function vs angle.
pub fn plot_phase(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    wavelengths: &[f64],
    polarised: bool,
    out: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    let c = pt.curves(entry)?;
    let ks = pick_wavelengths(&c.wavelengths_nm, wavelengths);
    let mut lo = f64::INFINITY;
    let mut hi: f64 = 0.0;
    for &k in &ks {
        let series: Vec<&Vec<f64>> = if polarised {
            vec![&c.phase[k], &c.i_perp[k], &c.i_par[k]]
        } else {
            vec![&c.phase[k]]
        };
        for s in series {
            for &v in s {
                if v > 0.0 {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
    }
    if hi.is_nan() || hi <= 0.0 {
        bail!("no positive values to plot on a log scale");
    }
    lo = lo.max(hi * 1e-12);
    let title = format!(
        "phase function, {}",
        super::phase::describe_entry(&pt.table, &c.entry)
    );
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..180f64, (lo * 0.8..hi * 1.25).log_scale())
            .map_err(perr)?;
        chart
            .configure_mesh()
            .x_desc("scattering angle (deg, 0 = forward)")
            .y_desc("p (1/sr)")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(perr)?;
        for &k in &ks {
            let col = wavelength_colour(c.wavelengths_nm[k]);
            let pts = |v: &Vec<f64>| {
                c.angles_deg
                    .iter()
                    .cloned()
                    .zip(v.iter().map(|x| x.max(lo)))
                    .collect::<Vec<_>>()
            };
            chart
                .draw_series(LineSeries::new(pts(&c.phase[k]), col.stroke_width(2)))
                .map_err(perr)?
                .label(format!("{} nm", c.wavelengths_nm[k]))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
            if polarised {
                chart
                    .draw_series(DashedLineSeries::new(
                        pts(&c.i_perp[k]),
                        6,
                        4,
                        col.stroke_width(1),
                    ))
                    .map_err(perr)?;
                chart
                    .draw_series(DashedLineSeries::new(
                        pts(&c.i_par[k]),
                        2,
                        3,
                        col.stroke_width(1),
                    ))
                    .map_err(perr)?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(perr)?;
        if polarised {
            root.draw(&Text::new(
                "solid: phase, dashed: i_perp, dotted: i_par",
                (90, size.1 as i32 - 60),
                ("sans-serif", 14),
            ))
            .map_err(perr)?;
        }
        Ok::<(), anyhow::Error>(())
    })
}

/// Colour strip vs scattering angle over `[lo, hi]`.
pub fn plot_strip(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: f64,
    range: (f64, f64),
    out: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    let xyz = xyz_vs_angle(pt, entry, sun_diameter_deg)?;
    let idx = |a: f64| ((a / THETA_STEP_DEG).round() as usize).min(xyz.len() - 1);
    let (i0, i1) = (idx(range.0), idx(range.1));
    let ymax = xyz[i0..=i1].iter().map(|v| v[1]).fold(0.0, f64::max);
    let scale = if ymax > 0.0 { 1.0 / ymax } else { 1.0 };
    let e = pt.resolve_entry(entry)?;
    let title = format!(
        "rainbow colours vs scattering angle (D65 sun, {sun_diameter_deg} deg disc), {}",
        super::phase::describe_entry(&pt.table, &e)
    );
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(10)
            .build_cartesian_2d(range.0..range.1, 0f64..1f64)
            .map_err(perr)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .disable_y_axis()
            .x_desc("scattering angle (deg); bow radius = 180 - angle")
            .draw()
            .map_err(perr)?;
        let n = size.0 as usize;
        let step = (range.1 - range.0) / n as f64;
        chart
            .draw_series((0..n).map(|i| {
                let a = range.0 + i as f64 * step;
                let v = xyz[idx(a + 0.5 * step)];
                Rectangle::new([(a, 0.0), (a + step, 1.0)], xyz_colour(v, scale).filled())
            }))
            .map_err(perr)?;
        Ok::<(), anyhow::Error>(())
    })
}

/// Lee diagram over the entry axis `radius`.
pub fn plot_lee(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: f64,
    range: (f64, f64),
    out: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    let axes = pt.table.axes();
    let ai = pt
        .entry_axes
        .iter()
        .copied()
        .find(|&i| axes[i].name == "radius")
        .ok_or_else(|| anyhow!("a Lee diagram needs an entry axis `radius`"))?;
    let radii = axes[ai].coords();
    if radii.len() < 2 {
        bail!("a Lee diagram needs at least two radii");
    }
    let unit = axes[ai].unit.clone();
    let mut cols = Vec::new();
    for &r in &radii {
        let mut sel: Vec<EntrySelection> = entry
            .iter()
            .filter(|e| e.axis != "radius")
            .cloned()
            .collect();
        sel.push(EntrySelection {
            axis: "radius".into(),
            value: r,
        });
        cols.push(xyz_vs_angle(pt, &sel, sun_diameter_deg)?);
    }
    let idx = |a: f64| ((a / THETA_STEP_DEG).round() as usize).min(cols[0].len() - 1);
    let log_x = radii[0] > 0.0 && radii[radii.len() - 1] / radii[0] > 20.0;
    let fx = |r: f64| if log_x { r.log10() } else { r };
    let edges: Vec<f64> = (0..=radii.len())
        .map(|i| {
            if i == 0 {
                fx(radii[0]) - 0.5 * (fx(radii[1]) - fx(radii[0]))
            } else if i == radii.len() {
                fx(radii[i - 1]) + 0.5 * (fx(radii[i - 1]) - fx(radii[i - 2]))
            } else {
                0.5 * (fx(radii[i - 1]) + fx(radii[i]))
            }
        })
        .collect();
    let (ylo, yhi) = (180.0 - range.1, 180.0 - range.0);
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Lee diagram (each radius normalised to its brightest angle)",
                ("sans-serif", 18),
            )
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(edges[0]..edges[radii.len()], ylo..yhi)
            .map_err(perr)?;
        chart
            .configure_mesh()
            .x_desc(if log_x {
                format!("log10 drop radius ({unit})")
            } else {
                format!("drop radius ({unit})")
            })
            .y_desc("angle from antisolar point (deg)")
            .draw()
            .map_err(perr)?;
        let ny = size.1 as usize;
        let dy = (yhi - ylo) / ny as f64;
        for (c, col) in cols.iter().enumerate() {
            let ymax = col[idx(range.0)..=idx(range.1)]
                .iter()
                .map(|v| v[1])
                .fold(0.0, f64::max);
            let scale = if ymax > 0.0 { 1.0 / ymax } else { 1.0 };
            chart
                .draw_series((0..ny).map(|j| {
                    let rad = ylo + j as f64 * dy;
                    let v = col[idx(180.0 - (rad + 0.5 * dy))];
                    Rectangle::new(
                        [(edges[c], rad), (edges[c + 1], rad + dy)],
                        xyz_colour(v, scale).filled(),
                    )
                }))
                .map_err(perr)?;
        }
        Ok::<(), anyhow::Error>(())
    })
}

/// Heatmap of one channel over the last two axes (others at the entry selection / first
/// sample), sampled with the table's lookup formula on a grid of at most 800 × 500 cells.
pub fn plot_heatmap(
    table: &Table,
    entry: &[EntrySelection],
    channel: Option<&str>,
    out: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    let axes = table.axes();
    if axes.len() < 2 {
        bail!("a heatmap needs at least two axes");
    }
    let ch = match channel {
        Some(n) => table.channel_index(n)?,
        None => 0,
    };
    let (xa, ya) = (&axes[axes.len() - 1], &axes[axes.len() - 2]);
    let mut coords: Vec<f64> = axes.iter().map(|a| a.coord(0)).collect();
    for s in entry {
        let i = table.axis_index(&s.axis)?;
        coords[i] = s.value;
    }
    let (xs, ys) = (xa.coords(), ya.coords());
    let (x0, x1, y0, y1) = (xs[0], xs[xs.len() - 1], ys[0], ys[ys.len() - 1]);
    let nx = xs.len().clamp(1, 800);
    let ny = ys.len().clamp(1, 500);
    let mut vals = vec![0.0; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            let mut c = coords.clone();
            let n = c.len();
            c[n - 1] = if nx > 1 {
                x0 + (x1 - x0) * i as f64 / (nx - 1) as f64
            } else {
                x0
            };
            c[n - 2] = if ny > 1 {
                y0 + (y1 - y0) * j as f64 / (ny - 1) as f64
            } else {
                y0
            };
            vals[j * nx + i] = table.sample(&c)?[ch];
        }
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in &vals {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let log = lo > 0.0 && hi / lo > 100.0;
    let f = |v: f64| if log { v.log10() } else { v };
    let (flo, fhi) = (f(lo), f(hi));
    let cname = table.header.channels[ch].name.clone();
    let cunit = table.header.channels[ch].unit.clone();
    let title = format!(
        "{cname} ({cunit}){}, range {lo:.3e} .. {hi:.3e}",
        if log { ", log10 colour" } else { "" }
    );
    let (dx, dy) = ((x1 - x0) / nx as f64, (y1 - y0) / ny as f64);
    let (dx, dy) = (
        if dx > 0.0 { dx } else { 1.0 },
        if dy > 0.0 { dy } else { 1.0 },
    );
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0 - 0.5 * dx..x1 + 0.5 * dx, y0 - 0.5 * dy..y1 + 0.5 * dy)
            .map_err(perr)?;
        chart
            .configure_mesh()
            .x_desc(format!("{} ({})", xa.name, xa.unit))
            .y_desc(format!("{} ({})", ya.name, ya.unit))
            .draw()
            .map_err(perr)?;
        let cx = |i: usize| {
            if nx > 1 {
                x0 + (x1 - x0) * i as f64 / (nx - 1) as f64
            } else {
                x0
            }
        };
        let cy = |j: usize| {
            if ny > 1 {
                y0 + (y1 - y0) * j as f64 / (ny - 1) as f64
            } else {
                y0
            }
        };
        chart
            .draw_series(
                (0..ny)
                    .flat_map(|j| (0..nx).map(move |i| (i, j)))
                    .map(|(i, j)| {
                        let v = vals[j * nx + i];
                        let t = if fhi > flo {
                            ((f(v) - flo) / (fhi - flo)) as f32
                        } else {
                            0.5
                        };
                        let col: RGBColor = ViridisRGB.get_color(t);
                        Rectangle::new(
                            [
                                (cx(i) - 0.5 * dx, cy(j) - 0.5 * dy),
                                (cx(i) + 0.5 * dx, cy(j) + 0.5 * dy),
                            ],
                            col.filled(),
                        )
                    }),
            )
            .map_err(perr)?;
        Ok::<(), anyhow::Error>(())
    })
}

/// Channels of a 1-D table (or of the last axis at the entry selection) vs that axis.
pub fn plot_line(
    table: &Table,
    entry: &[EntrySelection],
    out: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    let axes = table.axes();
    let xa = &axes[axes.len() - 1];
    let mut coords: Vec<f64> = axes.iter().map(|a| a.coord(0)).collect();
    for s in entry {
        coords[table.axis_index(&s.axis)?] = s.value;
    }
    let xs = xa.coords();
    let nch = table.header.channels.len();
    let mut series = vec![Vec::new(); nch];
    for &x in &xs {
        let mut c = coords.clone();
        let n = c.len();
        c[n - 1] = x;
        let v = table.sample(&c)?;
        for k in 0..nch {
            series[k].push((x, v[k]));
        }
    }
    let all = series.iter().flatten().map(|p| p.1);
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let pad = if hi > lo { 0.05 * (hi - lo) } else { 1.0 };
    let palette = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&table.header.description, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                xs[0]..xs[xs.len() - 1].max(xs[0] + 1e-9),
                lo - pad..hi + pad,
            )
            .map_err(perr)?;
        chart
            .configure_mesh()
            .x_desc(format!("{} ({})", xa.name, xa.unit))
            .draw()
            .map_err(perr)?;
        for (k, s) in series.iter().enumerate() {
            let col = palette[k % palette.len()];
            let ch = &table.header.channels[k];
            chart
                .draw_series(LineSeries::new(s.clone(), col.stroke_width(2)))
                .map_err(perr)?
                .label(format!("{} ({})", ch.name, ch.unit))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(perr)?;
        Ok::<(), anyhow::Error>(())
    })
}

/// Write the default previews of a table into `out_dir` as `<stem>-<kind>.png`; returns the
/// files written.
pub fn previews(table_path: &Path, out_dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out_dir)?;
    let stem = table_path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("table")
        .to_string();
    let table = Table::open(table_path).map_err(|e| anyhow!(e))?;
    let name = |k: &str| out_dir.join(format!("{stem}-{k}.png"));
    if super::phase2d::is_2d(&table) {
        return super::plot_raytrace::previews_2d(table, &stem, out_dir);
    }
    let mut written = Vec::new();
    match PhaseTable::new(table.clone()) {
        Ok(pt) => {
            let p = name("phase");
            // Three wavelengths, unpolarised: Mie ripple makes 8 polarised curves unreadable.
            plot_phase(&pt, &[], &[450.0, 550.0, 650.0], false, &p, (1000, 600))?;
            written.push(p);
            let p = name("strip");
            plot_strip(&pt, &[], 0.5, (120.0, 145.0), &p, (1000, 160))?;
            written.push(p);
            if pt
                .entry_axes
                .iter()
                .any(|&i| pt.table.axes()[i].name == "radius" && pt.table.axes()[i].len() > 1)
            {
                let p = name("lee");
                plot_lee(&pt, &[], 0.5, (120.0, 145.0), &p, (900, 600))?;
                written.push(p);
            }
        }
        Err(_) if table.axes().len() >= 2 => {
            let p = name("heatmap");
            plot_heatmap(&table, &[], None, &p, (1000, 600))?;
            written.push(p);
        }
        Err(_) => {
            let p = name("line");
            plot_line(&table, &[], &p, (1000, 600))?;
            written.push(p);
        }
    }
    Ok(written)
}

/// Plot kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlotKind {
    /// Every default preview of the table into the directory `--out`.
    Auto,
    Phase,
    Strip,
    Lee,
    Heatmap,
    Line,
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}`: expected LO,HI"))?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|e| format!("{e}"))?,
        b.trim().parse().map_err(|e| format!("{e}"))?,
    );
    if !(0.0..=180.0).contains(&a) || !(0.0..=180.0).contains(&b) || a >= b {
        return Err(format!("`{s}`: need 0 <= LO < HI <= 180"));
    }
    Ok((a, b))
}

/// `scatterbake plot`.
#[derive(Debug, Clone, clap::Args)]
pub struct PlotArgs {
    /// Table (.sbt).
    pub table: PathBuf,
    #[arg(long, value_enum, default_value = "auto")]
    pub kind: PlotKind,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Channel for heatmaps (default: the first).
    #[arg(long)]
    pub channel: Option<String>,
    /// Wavelengths to draw in phase plots (default: up to 8 spread over the table).
    #[arg(long = "wavelength-nm")]
    pub wavelength_nm: Vec<f64>,
    /// Also draw i_perp (dashed) and i_par (dotted) in phase plots.
    #[arg(long)]
    pub polarised: bool,
    /// Scattering-angle range of strips and Lee diagrams, LO,HI in deg.
    #[arg(long, default_value = "120,145", value_parser = parse_range)]
    pub angle_range: (f64, f64),
    #[arg(long, default_value_t = 0.5)]
    pub sun_diameter_deg: f64,
    #[arg(long, default_value_t = 1000)]
    pub width: u32,
    #[arg(long, default_value_t = 600)]
    pub height: u32,
    /// Output .png or .svg (a directory for --kind auto).
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `scatterbake plot`.
pub fn run_plot(args: &PlotArgs) -> anyhow::Result<()> {
    let size = (args.width, args.height);
    let phase = || PhaseTable::open(&args.table);
    match args.kind {
        PlotKind::Auto => {
            for p in previews(&args.table, &args.out)? {
                eprintln!("wrote {}", p.display());
            }
            return Ok(());
        }
        PlotKind::Phase => plot_phase(
            &phase()?,
            &args.entry,
            &args.wavelength_nm,
            args.polarised,
            &args.out,
            size,
        )?,
        PlotKind::Strip => plot_strip(
            &phase()?,
            &args.entry,
            args.sun_diameter_deg,
            args.angle_range,
            &args.out,
            size,
        )?,
        PlotKind::Lee => plot_lee(
            &phase()?,
            &args.entry,
            args.sun_diameter_deg,
            args.angle_range,
            &args.out,
            size,
        )?,
        PlotKind::Heatmap | PlotKind::Line => {
            let t = Table::open(&args.table)
                .map_err(|e| anyhow!(e))
                .with_context(|| args.table.display().to_string())?;
            if args.kind == PlotKind::Heatmap {
                plot_heatmap(&t, &args.entry, args.channel.as_deref(), &args.out, size)?
            } else {
                plot_line(&t, &args.entry, &args.out, size)?
            }
        }
    }
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wavelength_colours_are_ordered_like_the_spectrum() {
        let r = wavelength_colour(650.0);
        let g = wavelength_colour(530.0);
        let b = wavelength_colour(460.0);
        assert!(r.0 > r.1 && r.0 > r.2, "{r:?}");
        assert!(g.1 > g.0 && g.1 > g.2, "{g:?}");
        assert!(b.2 > b.0 && b.2 > b.1, "{b:?}");
    }
}
