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
//!   selection, one channel, drawn as a gap-free raster ([`super::figure`]) with a colour bar;
//!   log10 colour scale (viridis) when the data are ≥ 0 and span more than two decades;
//! - `line`: channels of a 1-D table vs its axis.
//!
//! `auto` (and [`super::previews::previews`]) picks phase + strip (+ lee when there is a radius axis) for phase
//! tables, the family figures of [`super::previews`] for known schemas (fur medulla, fur far
//! field, hair Dual Scattering, hair azimuthal, water index), and for other schemas a heatmap
//! (other axes at their middle sample) or a line plot for 1-D tables.

use super::style::{PALETTE, axis_label, short_number, wavelength_colour, xyz_colour};
use crate::consumers::ConsumerError;
use crate::consumers::read::operators::SunDisc;
use crate::consumers::read::phase::{EntrySelection, PhaseCurves, PhaseTable};
use crate::consumers::read::spectrum::{THETA_STEP_DEG, xyz_vs_angle};
use crate::progress::Progress;
use crate::table::Table;
use plotters::prelude::*;
use rayon::prelude::*;
use std::path::Path;

use super::figure::{
    ColourScale, Dash, Figure, HeatPanel, LinePanel, Panel, Series, draw_figure, perr, with_backend,
};

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

/// A log-scale chart of a quantity over the scattering angle 0–180° filling `root`.
type AngleLogChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<
        plotters::coord::types::RangedCoordf64,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

/// The axes shared by every phase-vs-angle figure: 0–180° against `lo`–`hi` on a log scale,
/// with `title` as caption and `y_desc` on the y axis.
fn angle_log_chart<'a, DB: DrawingBackend<ErrorType: 'static>>(
    root: &'a DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    (lo, hi): (f64, f64),
    y_desc: &str,
) -> Result<AngleLogChart<'a, DB>, ConsumerError> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..180f64, (lo * 0.8..hi * 1.25).log_scale())
        .map_err(perr)?;
    chart
        .configure_mesh()
        .x_desc("scattering angle (deg, 0 = forward)")
        .y_desc(y_desc)
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(perr)?;
    Ok(chart)
}

/// Smallest and largest positive value of the curves plotted for wavelength indices `ks`
/// (phase, and i_perp/i_par when `polarised`).
fn positive_range(c: &PhaseCurves, ks: &[usize], polarised: bool) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi: f64 = 0.0;
    for &k in ks {
        let series: Vec<&Vec<f64>> = if polarised {
            vec![&c.phase[k], &c.i_perp[k], &c.i_par[k]]
        } else {
            vec![&c.phase[k]]
        };
        for &v in series.into_iter().flatten().filter(|v| **v > 0.0) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (lo, hi)
}

/// Phase function vs angle.
pub fn plot_phase(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    wavelengths: &[f64],
    polarised: bool,
    out: &Path,
    size: (u32, u32),
) -> Result<(), ConsumerError> {
    let c = pt.curves(entry)?;
    let ks = pick_wavelengths(&c.wavelengths_nm, wavelengths);
    let (lo, hi) = positive_range(&c, &ks, polarised);
    if hi.is_nan() || hi <= 0.0 {
        return Err(ConsumerError::invalid(
            "no positive values to plot on a log scale",
        ));
    }
    let lo = lo.max(hi * 1e-12);
    let title = format!(
        "phase function, {}",
        crate::consumers::read::phase::describe_entry(&pt.table, &c.entry)
    );
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = angle_log_chart(&root, &title, (lo, hi), "p (1/sr)")?;
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
                // i_perp dashed, i_par dotted.
                for (v, dash, gap) in [(&c.i_perp[k], 6, 4), (&c.i_par[k], 2, 3)] {
                    chart
                        .draw_series(DashedLineSeries::new(
                            pts(v),
                            dash,
                            gap,
                            col.stroke_width(1),
                        ))
                        .map_err(perr)?;
                }
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
        Ok::<(), ConsumerError>(())
    })
}

/// The colours of a strip or Lee-diagram column: XYZ vs angle ([`xyz_vs_angle`]) with the sun
/// disc `disc` planned for the table, convolving only what the table has not applied.
pub fn strip_xyz(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    disc: &SunDisc,
) -> Result<Vec<[f64; 3]>, ConsumerError> {
    xyz_vs_angle(pt, entry, disc.extra_deg)
}

/// Colour strip vs scattering angle over `[lo, hi]`; the sun disc is planned from the table
/// and `sun_diameter_deg` ([`SunDisc::plan`]: `None` keeps the table's own) and returned.
pub fn plot_strip(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: Option<f64>,
    range: (f64, f64),
    out: &Path,
    size: (u32, u32),
) -> Result<SunDisc, ConsumerError> {
    let disc = SunDisc::plan(&pt.table, sun_diameter_deg)?;
    let xyz = strip_xyz(pt, entry, &disc)?;
    let idx = |a: f64| ((a / THETA_STEP_DEG).round() as usize).min(xyz.len() - 1);
    let (i0, i1) = (idx(range.0), idx(range.1));
    let ymax = xyz[i0..=i1].iter().map(|v| v[1]).fold(0.0, f64::max);
    let scale = if ymax > 0.0 { 1.0 / ymax } else { 1.0 };
    let e = pt.resolve_entry(entry)?;
    let title = format!(
        "rainbow colours vs scattering angle (D65 sun, {} deg disc), {}",
        disc.target_deg,
        crate::consumers::read::phase::describe_entry(&pt.table, &e)
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
        Ok::<(), ConsumerError>(())
    })?;
    Ok(disc)
}

/// The colour column (XYZ vs angle) of every radius, in parallel, the other entry axes at
/// `entry`.
fn lee_columns(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    radii: &[f64],
    disc: &SunDisc,
    progress: &dyn Progress,
) -> Result<Vec<Vec<[f64; 3]>>, ConsumerError> {
    progress.start(radii.len() as u64, "radii");
    radii
        .par_iter()
        .map(|&r| {
            let mut sel: Vec<EntrySelection> = entry
                .iter()
                .filter(|e| e.axis != "radius")
                .cloned()
                .collect();
            sel.push(EntrySelection {
                axis: "radius".into(),
                value: r,
            });
            let col = strip_xyz(pt, &sel, disc);
            progress.advance(1);
            col
        })
        .collect()
}

/// Lee diagram over the entry axis `radius`; the sun disc as in [`plot_strip`].
pub fn plot_lee(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    sun_diameter_deg: Option<f64>,
    range: (f64, f64),
    out: &Path,
    size: (u32, u32),
    progress: &dyn Progress,
) -> Result<SunDisc, ConsumerError> {
    let disc = SunDisc::plan(&pt.table, sun_diameter_deg)?;
    let axes = pt.table.axes();
    let ai = pt
        .entry_axes
        .iter()
        .copied()
        .find(|&i| axes[i].name == "radius")
        .ok_or_else(|| ConsumerError::layout("a Lee diagram needs an entry axis `radius`"))?;
    let radii = axes[ai].coords();
    if radii.len() < 2 {
        return Err(ConsumerError::layout(
            "a Lee diagram needs at least two radii",
        ));
    }
    let unit = axes[ai].unit.clone();
    let cols = lee_columns(pt, entry, &radii, &disc, progress)?;
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
        Ok::<(), ConsumerError>(())
    })?;
    Ok(disc)
}

/// `a = 1, b = 2 nm` for the axes of `table` at `coords`, except the axes in `skip`.
pub fn describe_slice(table: &Table, coords: &[f64], skip: &[usize]) -> String {
    table
        .axes()
        .iter()
        .enumerate()
        .filter(|(i, _)| !skip.contains(i))
        .map(|(i, a)| {
            let u = if a.unit.is_empty() || a.unit == "1" {
                String::new()
            } else {
                format!(" {}", a.unit)
            };
            format!("{} = {}{u}", a.name, short_number(coords[i]))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Cell centres for a heatmap axis: the axis samples, or `max` uniform points over its range
/// when it has more.
fn heat_coords(coords: Vec<f64>, max: usize) -> Vec<f64> {
    if coords.len() <= max {
        return coords;
    }
    let (a, b) = (coords[0], coords[coords.len() - 1]);
    (0..max)
        .map(|i| a + (b - a) * i as f64 / (max - 1) as f64)
        .collect()
}

/// Heatmap of one channel over the last two axes (x = last, y = the one before), other axes
/// at the entry selection (first sample when not selected), sampled with the table's lookup
/// formula at the axis samples (at most 800 × 500 cells: longer axes are resampled uniformly),
/// drawn as a raster with a colour bar (log10 when the values are ≥ 0 and span > 2 decades).
pub fn plot_heatmap(
    table: &Table,
    entry: &[EntrySelection],
    channel: Option<&str>,
    out: &Path,
    size: (u32, u32),
) -> Result<(), ConsumerError> {
    let axes = table.axes();
    if axes.len() < 2 {
        return Err(ConsumerError::layout("a heatmap needs at least two axes"));
    }
    let ch = match channel {
        Some(n) => table.channel_index(n)?,
        None => 0,
    };
    let n = axes.len();
    let mut coords: Vec<f64> = axes.iter().map(|a| a.coord(0)).collect();
    for s in entry {
        let i = table.axis_index(&s.axis)?;
        coords[i] = s.value;
    }
    let panel = heat_panel_sampled(table, &coords, n - 1, n - 2, ch)?;
    let title = format!(
        "{}: {}",
        table.header.schema,
        describe_slice(table, &coords, &[n - 1, n - 2])
    );
    draw_figure(
        &Figure {
            title,
            cols: 1,
            size,
            panels: vec![Panel::Heat(panel)],
        },
        out,
    )
}

/// Heat panel of channel `ch` over axes `xa` × `ya` at `coords` (lookup formula).
pub fn heat_panel_sampled(
    table: &Table,
    coords: &[f64],
    xa: usize,
    ya: usize,
    ch: usize,
) -> Result<HeatPanel, ConsumerError> {
    let axes = table.axes();
    let xs = heat_coords(axes[xa].coords(), 800);
    let ys = heat_coords(axes[ya].coords(), 500);
    let mut values = Vec::with_capacity(xs.len() * ys.len());
    let mut c = coords.to_vec();
    for &y in &ys {
        for &x in &xs {
            c[xa] = x;
            c[ya] = y;
            values.push(table.sample(&c)?[ch]);
        }
    }
    let chan = &table.header.channels[ch];
    let value_label = axis_label(&chan.name, &chan.unit);
    Ok(HeatPanel {
        title: value_label.clone(),
        x_label: axis_label(&axes[xa].name, &axes[xa].unit),
        y_label: axis_label(&axes[ya].name, &axes[ya].unit),
        scale: ColourScale::auto(values.iter().copied()),
        xs,
        ys,
        values,
        value_label,
    })
}

/// Channels of a 1-D table (or of the last axis at the entry selection) vs that axis.
pub fn plot_line(
    table: &Table,
    entry: &[EntrySelection],
    out: &Path,
    size: (u32, u32),
) -> Result<(), ConsumerError> {
    let axes = table.axes();
    let n = axes.len();
    let xa = &axes[n - 1];
    let mut coords: Vec<f64> = axes.iter().map(|a| a.coord(0)).collect();
    for s in entry {
        coords[table.axis_index(&s.axis)?] = s.value;
    }
    let nch = table.header.channels.len();
    let mut points = vec![Vec::new(); nch];
    for x in xa.coords() {
        let mut c = coords.clone();
        c[n - 1] = x;
        let v = table.sample(&c)?;
        for k in 0..nch {
            points[k].push((x, v[k]));
        }
    }
    let series = points
        .into_iter()
        .enumerate()
        .map(|(k, pts)| {
            let ch = &table.header.channels[k];
            Series {
                label: axis_label(&ch.name, &ch.unit),
                colour: PALETTE[k % PALETTE.len()],
                dash: Dash::Solid,
                points: pts,
            }
        })
        .collect();
    let slice = describe_slice(table, &coords, &[n - 1]);
    draw_figure(
        &Figure {
            title: String::new(),
            cols: 1,
            size,
            panels: vec![Panel::Lines(LinePanel {
                title: if slice.is_empty() {
                    format!("{}: {}", table.header.schema, table.header.description)
                } else {
                    format!("{}: {slice}", table.header.schema)
                },
                x_label: axis_label(&xa.name, &xa.unit),
                y_label: String::new(),
                series,
                log_y: false,
                legend: Default::default(),
            })],
        },
        out,
    )
}

/// The per-order channels `phase_p<k>` of a table: (name, channel index).
fn order_channels(t: &Table) -> Vec<(String, usize)> {
    t.header
        .channels
        .iter()
        .enumerate()
        .filter(|(_, c)| {
            c.name
                .strip_prefix("phase_p")
                .is_some_and(|k| k.parse::<u32>().is_ok())
        })
        .map(|(i, c)| (c.name.clone(), i))
        .collect()
}

/// (θ, value) of the total `phase` (first) and of each order channel at one wavelength `w`
/// (nm) and a resolved entry.
fn order_series(
    pt: &PhaseTable,
    entry: &[(String, f64)],
    w: f64,
    orders: &[(String, usize)],
) -> Result<Vec<Vec<(f64, f64)>>, ConsumerError> {
    let t = &pt.table;
    let ch_sum = t.channel_index("phase")?;
    let mut coords = vec![0.0; t.axes().len()];
    coords[pt.wavelength_axis] = w;
    for (&i, e) in pt.entry_axes.iter().zip(entry) {
        coords[i] = e.1;
    }
    let mut series: Vec<Vec<(f64, f64)>> = vec![Vec::new(); orders.len() + 1];
    for a in pt.angles_deg() {
        coords[pt.angle_axis] = a;
        let v = t.sample(&coords)?;
        series[0].push((a, v[ch_sum]));
        for (k, (_, c)) in orders.iter().enumerate() {
            series[k + 1].push((a, v[*c]));
        }
    }
    Ok(series)
}

/// Legend text of an order channel `phase_p<p>`.
fn order_label(name: &str) -> String {
    let p = &name["phase_p".len()..];
    let what = match p {
        "0" => " (diffraction + external reflection)",
        "1" => " (direct transmission)",
        "2" => " (primary bow)",
        "3" => " (secondary bow)",
        _ => "",
    };
    format!("p = {p}{what}")
}

/// The contiguous runs of a curve above `floor`, each its own polyline: a component outside
/// its geometric zone leaves the plot instead of running along its bottom.
fn runs_above(curve: &[(f64, f64)], floor: f64) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for &(a, v) in curve {
        if v > floor {
            runs.last_mut().expect("run").push((a, v));
        } else if !runs.last().expect("run").is_empty() {
            runs.push(Vec::new());
        }
    }
    runs.retain(|r| r.len() > 1);
    runs
}

/// MiePlot's "Mie with its Debye components" figure for a table with per-order channels
/// `phase_p<k>` (the `debye` stage): at one wavelength (nearest to `wavelength_nm`) and entry,
/// the coherent sum of the tabulated orders (`phase`, grey) and each order alone, log scale.
pub fn plot_debye_components(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    wavelength_nm: f64,
    out: &Path,
    size: (u32, u32),
) -> Result<(), ConsumerError> {
    let t = &pt.table;
    let orders = order_channels(t);
    if orders.is_empty() {
        return Err(ConsumerError::layout(
            "table has no per-order channels `phase_p<k>`",
        ));
    }
    let entry = pt.resolve_entry(entry)?;
    let w = pt
        .wavelengths_nm()
        .iter()
        .cloned()
        .min_by(|a, b| {
            (a - wavelength_nm)
                .abs()
                .total_cmp(&(b - wavelength_nm).abs())
        })
        .ok_or_else(|| ConsumerError::layout("the table has no wavelengths"))?;
    let series = order_series(pt, &entry, w, &orders)?;
    let hi = series.iter().flatten().map(|p| p.1).fold(0.0, f64::max);
    if hi <= 0.0 {
        return Err(ConsumerError::invalid(
            "no positive values to plot on a log scale",
        ));
    }
    // Floor: a decade below the smallest value of the total.
    let lo = series[0]
        .iter()
        .map(|p| p.1)
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min)
        .max(hi * 1e-9)
        * 0.1;
    let debye = t.header.schema.name.starts_with("debye");
    let (what, total_label, y_desc) = if debye {
        (
            "Debye components",
            "coherent sum of these orders",
            "p (1/sr), over the full Mie C_sca",
        )
    } else {
        (
            "per-order contributions",
            "phase (all orders, filtered, + diffraction lobe)",
            "p (1/sr)",
        )
    };
    let title = format!(
        "{what}, {}, {w} nm",
        crate::consumers::read::phase::describe_entry(t, &entry)
    );
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = angle_log_chart(&root, &title, (lo, hi), y_desc)?;
        // The total first (grey, underneath), then each order on top of it.
        for (k, s) in series.iter().enumerate() {
            let (col, label) = if k == 0 {
                (RGBColor(110, 110, 110), total_label.to_string())
            } else {
                (
                    PALETTE[(k - 1) % PALETTE.len()],
                    order_label(&orders[k - 1].0),
                )
            };
            for (i, run) in runs_above(s, lo).into_iter().enumerate() {
                let drawn = chart
                    .draw_series(LineSeries::new(run, col.stroke_width(1)))
                    .map_err(perr)?;
                if i == 0 {
                    drawn.label(label.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                    });
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(perr)?;
        Ok::<(), ConsumerError>(())
    })
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

    /// The Debye-components figure draws a real `debye` table (orders 0–3 of a 20 µm drop) and
    /// refuses a phase table without per-order channels with a message naming them.
    #[test]
    fn debye_components_figure() {
        let job = crate::stages::plan_from_lines(
            &crate::stages::debye::DebyeStage,
            "radii_um = [20.0]\nwavelengths_nm = [650.0]\nangle_step_deg = 0.5\nsun_diameter_deg = 0.0",
        )
        .unwrap();
        let chunks: Vec<crate::stages::Chunk> = (0..job.tasks().len())
            .map(|i| job.run_task(i).unwrap())
            .collect();
        let t = Table::from_content(job.assemble(chunks).unwrap(), Default::default()).unwrap();
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("orders.png");
        plot_debye_components(&PhaseTable::new(t).unwrap(), &[], 650.0, &out, (600, 400)).unwrap();
        assert!(std::fs::metadata(&out).unwrap().len() > 1000);
        let wl: Vec<f64> = vec![450.0, 650.0];
        let hg = crate::fixtures::henyey_greenstein_table(&wl, &[1.0], |_, _| 0.5, 181, 0.0);
        let e = plot_debye_components(&PhaseTable::new(hg).unwrap(), &[], 650.0, &out, (600, 400))
            .unwrap_err();
        assert!(e.to_string().contains("phase_p"), "{e}");
    }
}
