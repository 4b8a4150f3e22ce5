//! Plots of the ray tracer's 2-D tables (`raytrace-phase-2d`, versions 1 and 2, see
//! [`crate::consumers::read::phase2d`] for the frame), `scatterbake plot-raytrace` and the build previews of
//! such tables:
//!
//! - `bows`: the phase function (log scale) at one wavelength (default 650 nm) vs outgoing polar
//!   angle in 120°–150° along three outgoing azimuths — φ = 0° (vertical plane, upwards),
//!   φ = 90° (horizontal) and φ = 180° (vertical plane, downwards) — one curve per table (drop
//!   radius), plus below each panel one colour strip per table: the D65 sun (disc averaged,
//!   same code as the renderer and the 1-D `strip` plot) seen at each polar angle along that
//!   azimuth, sRGB, normalised to the strip's brightest angle. For a camera with the drops'
//!   axis vertical and the sun at the table's elevation, φ = 180° is the top of the bow (light
//!   scattered downward to the observer) and φ = 90°/270° its sides;
//! - `latlong`: log10 phase over outgoing_azimuth (x) × outgoing_polar (y) at one wavelength and
//!   sun elevation, drawn as a raster (every pixel sampled with the table's bilinear lookup, no
//!   gaps between cells).

use super::figure::{perr, with_backend};
use super::style::xyz_colour;
use crate::consumers::ConsumerError;
use crate::consumers::read::operators::SunDisc;
use crate::consumers::read::phase2d::{Phase2dTable, PhaseSlice, outgoing_direction};
use crate::consumers::read::spectrum::{THETA_STEP_DEG, xyz_along};
use crate::math::vec3::V3;
use plotters::coord::ReverseCoordTranslate;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Outgoing azimuths of the bows plot (deg) and their names.
pub const BOW_DIRECTIONS: [(f64, &str); 3] = [
    (0.0, "phi = 0 (vertical, upwards)"),
    (90.0, "phi = 90 (horizontal)"),
    (180.0, "phi = 180 (vertical, downwards = bow top)"),
];

/// One table of a bows plot: its label, its `phase` slice (every wavelength) and, when the
/// table has it, its `phase_p2` slice (the primary-bow order alone) for locating the primary.
pub struct BowInput {
    pub label: String,
    pub slice: PhaseSlice,
    pub primary_order: Option<PhaseSlice>,
}

/// Search window (outgoing polar, deg) of the primary-bow maximum in the `phase_p2` channel.
pub const PRIMARY_SEARCH_DEG: (f64, f64) = (125.0, 165.0);

/// Primary-bow peak positions of one table along one azimuth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BowPeak {
    pub azimuth_deg: f64,
    /// Outgoing polar angle (deg) of the phase maximum at the plotted wavelength.
    pub phase_peak_deg: f64,
    /// Outgoing polar angle (deg) of the luminance maximum of the colour strip.
    pub luminance_peak_deg: f64,
    /// Outgoing polar angle (deg) of the maximum of the primary order alone (`phase_p2`) at
    /// the plotted wavelength within [`PRIMARY_SEARCH_DEG`], when available.
    pub order2_peak_deg: Option<f64>,
}

pub fn nearest(all: &[f64], x: f64) -> usize {
    (0..all.len())
        .min_by(|&a, &b| (all[a] - x).abs().total_cmp(&(all[b] - x).abs()))
        .unwrap()
}

/// Polar angle (deg) of the maximum of `slice` at wavelength index k along `azimuth_deg` in
/// `[lo, hi]`, on a [`THETA_STEP_DEG`] grid with the table's interpolation.
pub fn peak_polar_deg(slice: &PhaseSlice, k: usize, azimuth_deg: f64, lo: f64, hi: f64) -> f64 {
    let n = ((hi - lo) / THETA_STEP_DEG).round() as usize;
    (0..=n)
        .map(|i| lo + i as f64 * THETA_STEP_DEG)
        .map(|t| (t, slice.value(k, t, azimuth_deg)))
        .fold((f64::NAN, f64::NEG_INFINITY), |b, (t, v)| {
            if v > b.1 { (t, v) } else { b }
        })
        .0
}

/// Disc-averaged XYZ (D65) along `azimuth_deg` at the polar angles `polar_deg`.
pub fn strip_xyz(
    slice: &PhaseSlice,
    azimuth_deg: f64,
    polar_deg: &[f64],
    sun_diameter_deg: f64,
) -> Vec<[f64; 3]> {
    let e = slice.sun_elevation_deg;
    let sun = {
        let (s, c) = e.to_radians().sin_cos();
        [c, 0.0, s]
    };
    let views: Vec<V3> = polar_deg
        .iter()
        .map(|&t| outgoing_direction(e, t, azimuth_deg).map(|c| -c))
        .collect();
    xyz_along(slice, sun, &views, sun_diameter_deg)
}

/// Fill the plotting area of a chart pixel by pixel with `colour(x, y)` (data coordinates).
fn raster<DB: DrawingBackend<ErrorType: 'static>>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    colour: impl Fn(f64, f64) -> RGBColor,
) -> Result<(), ConsumerError> {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let spec = chart.as_coord_spec();
    for py in yr.clone() {
        for px in xr.clone() {
            if let Some((x, y)) = spec.reverse_translate((px, py)) {
                root.draw_pixel((px, py), &colour(x, y)).map_err(perr)?;
            }
        }
    }
    Ok(())
}

/// Curves, colour strips and peaks of a bows figure, per input and per [`BOW_DIRECTIONS`] entry.
struct BowSeries {
    /// Outgoing polar angles (deg) of the strips, [`THETA_STEP_DEG`] apart.
    polar: Vec<f64>,
    /// `[input][direction]` → (θ, p) at every second strip angle.
    curves: Vec<Vec<Vec<(f64, f64)>>>,
    /// `[input][direction]` → disc-averaged XYZ at every strip angle.
    strips: Vec<Vec<Vec<[f64; 3]>>>,
    peaks: Vec<Vec<BowPeak>>,
    /// Smallest and largest positive phase value over every curve.
    lo: f64,
    hi: f64,
}

/// Primary-bow window (outgoing polar, deg) searched for the phase and luminance maxima:
/// between Alexander's band and the bright inside (the geometric primary of water is at
/// 137.5°–138.5°).
const PRIMARY_WINDOW_DEG: (f64, f64) = (133.0, 146.0);

fn bow_series(
    inputs: &[BowInput],
    wavelength_nm: f64,
    disc: &SunDisc,
    range: (f64, f64),
) -> BowSeries {
    let n_strip = ((range.1 - range.0) / THETA_STEP_DEG).round() as usize + 1;
    let polar: Vec<f64> = (0..n_strip)
        .map(|i| range.0 + i as f64 * THETA_STEP_DEG)
        .collect();
    let mut series = BowSeries {
        curves: Vec::new(),
        strips: Vec::new(),
        peaks: Vec::new(),
        lo: f64::INFINITY,
        hi: 0.0,
        polar: Vec::new(),
    };
    for inp in inputs {
        let k = nearest(&inp.slice.wavelengths_nm, wavelength_nm);
        let (mut cs, mut ss, mut ps) = (vec![], vec![], vec![]);
        for &(phi, _) in &BOW_DIRECTIONS {
            let c: Vec<(f64, f64)> = polar
                .iter()
                .step_by(2)
                .map(|&t| (t, inp.slice.value(k, t, phi)))
                .collect();
            for &(_, v) in c.iter().filter(|(_, v)| *v > 0.0) {
                series.lo = series.lo.min(v);
                series.hi = series.hi.max(v);
            }
            let xyz = strip_xyz(&inp.slice, phi, &polar, disc.extra_deg);
            ps.push(bow_peak(inp, k, phi, &polar, &xyz, range));
            cs.push(c);
            ss.push(xyz);
        }
        series.curves.push(cs);
        series.strips.push(ss);
        series.peaks.push(ps);
    }
    series.polar = polar;
    series
}

/// Peaks of one input along azimuth `phi` (deg): phase and luminance maxima in
/// [`PRIMARY_WINDOW_DEG`] (clipped to the plotted range), and the primary order's maximum.
fn bow_peak(
    inp: &BowInput,
    k: usize,
    phi: f64,
    polar: &[f64],
    xyz: &[[f64; 3]],
    range: (f64, f64),
) -> BowPeak {
    let (plo, phi_hi) = (
        PRIMARY_WINDOW_DEG.0.max(range.0),
        PRIMARY_WINDOW_DEG.1.min(range.1),
    );
    let lum_peak = polar
        .iter()
        .zip(xyz)
        .filter(|(t, _)| **t >= plo && **t <= phi_hi)
        .fold((f64::NAN, f64::NEG_INFINITY), |b, (t, v)| {
            if v[1] > b.1 { (*t, v[1]) } else { b }
        })
        .0;
    BowPeak {
        azimuth_deg: phi,
        phase_peak_deg: peak_polar_deg(&inp.slice, k, phi, plo, phi_hi),
        luminance_peak_deg: lum_peak,
        order2_peak_deg: inp.primary_order.as_ref().map(|p2| {
            let (a, b) = PRIMARY_SEARCH_DEG;
            peak_polar_deg(p2, k, phi, a, b)
        }),
    }
}

/// Colour of the `i`-th of `n` inputs.
fn bow_palette(i: usize, n: usize) -> RGBColor {
    ViridisRGB.get_color(if n > 1 {
        0.9 * i as f32 / (n - 1) as f32
    } else {
        0.0
    })
}

/// The bows figure (see the module doc); returns the peaks per input and direction. The colour
/// strips convolve `disc.extra_deg`, the disc the tables have not applied ([`SunDisc::plan`]).
pub fn plot_bows(
    inputs: &[BowInput],
    wavelength_nm: f64,
    disc: &SunDisc,
    range: (f64, f64),
    out: &Path,
    size: (u32, u32),
) -> Result<Vec<Vec<BowPeak>>, ConsumerError> {
    if inputs.is_empty() {
        return Err(ConsumerError::invalid("no tables to plot"));
    }
    let mut series = bow_series(inputs, wavelength_nm, disc, range);
    if !(series.hi > 0.0) {
        return Err(ConsumerError::invalid(format!(
            "no positive phase values in {range:?}"
        )));
    }
    series.lo = series.lo.max(series.hi * 1e-8);
    let k0 = nearest(&inputs[0].slice.wavelengths_nm, wavelength_nm);
    let wl_label = inputs[0].slice.wavelengths_nm[k0];
    let n = inputs.len();
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let title = format!(
            "phase at {wl_label} nm (log) and D65 colour strips ({} deg sun), sun elevation {} deg",
            disc.target_deg, inputs[0].slice.sun_elevation_deg
        );
        let (head, body) = root.split_vertically(30);
        head.draw(&Text::new(title, (10, 8), ("sans-serif", 18)))
            .map_err(perr)?;
        let strip_h = (30 * n as u32 + 60).min(size.1 / 2);
        let (upper, lower) = body.split_vertically(size.1 - 30 - strip_h);
        let ups = upper.split_evenly((1, 3));
        let lows = lower.split_evenly((1, 3));
        for (d, &(_, name)) in BOW_DIRECTIONS.iter().enumerate() {
            draw_bow_curves(&ups[d], name, d, inputs, &series, range)?;
            draw_bow_strips(&root, &lows[d], d, inputs, &series, range)?;
        }
        Ok::<(), ConsumerError>(())
    })?;
    Ok(series.peaks)
}

/// The log-scale phase panel of direction `d`: one curve per input, legend on the first.
fn draw_bow_curves<DB: DrawingBackend<ErrorType: 'static>>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    name: &str,
    d: usize,
    inputs: &[BowInput],
    series: &BowSeries,
    range: (f64, f64),
) -> Result<(), ConsumerError> {
    let (lo, hi) = (series.lo, series.hi);
    let mut chart = ChartBuilder::on(area)
        .caption(name, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(range.0..range.1, (lo * 0.8..hi * 1.25).log_scale())
        .map_err(perr)?;
    chart
        .configure_mesh()
        .x_desc("outgoing polar angle (deg)")
        .y_desc("p (1/sr)")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(perr)?;
    for (i, inp) in inputs.iter().enumerate() {
        let col = bow_palette(i, inputs.len());
        let s = chart
            .draw_series(LineSeries::new(
                series.curves[i][d].iter().map(|&(t, v)| (t, v.max(lo))),
                col.stroke_width(1),
            ))
            .map_err(perr)?;
        if d == 0 {
            s.label(inp.label.clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
            });
        }
    }
    if d == 0 {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(perr)?;
    }
    Ok(())
}

/// The colour strips of direction `d`: one row per input (first input at the top), each
/// normalised to its brightest angle, labelled at the left.
fn draw_bow_strips<DB: DrawingBackend<ErrorType: 'static>>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    area: &DrawingArea<DB, plotters::coord::Shift>,
    d: usize,
    inputs: &[BowInput],
    series: &BowSeries,
    range: (f64, f64),
) -> Result<(), ConsumerError> {
    let n = inputs.len();
    let n_strip = series.polar.len();
    let mut sc = ChartBuilder::on(area)
        .margin(8)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(range.0..range.1, 0f64..n as f64)
        .map_err(perr)?;
    sc.configure_mesh()
        .disable_mesh()
        .disable_y_axis()
        .x_desc("outgoing polar angle (deg)")
        .draw()
        .map_err(perr)?;
    for (i, inp) in inputs.iter().enumerate() {
        let (x, y) = sc.backend_coord(&(range.0, (n - i) as f64 - 0.5));
        root.draw(&Text::new(
            inp.label.replace("a = ", ""),
            (x - 56, y - 7),
            ("sans-serif", 13),
        ))
        .map_err(perr)?;
    }
    let scales: Vec<f64> = (0..n)
        .map(|i| {
            let m = series.strips[i][d].iter().map(|v| v[1]).fold(0.0, f64::max);
            if m > 0.0 { 1.0 / m } else { 1.0 }
        })
        .collect();
    raster(root, &sc, |t, y| {
        let i = n - 1 - (y.floor().max(0.0) as usize).min(n - 1);
        let j = (((t - range.0) / THETA_STEP_DEG).round().max(0.0) as usize).min(n_strip - 1);
        xyz_colour(series.strips[i][d][j], scales[i])
    })
}

/// Lat-long raster of log10 of one slice's phase at wavelength index k.
pub fn plot_latlong(
    slice: &PhaseSlice,
    k: usize,
    title_prefix: &str,
    out: &Path,
    size: (u32, u32),
) -> Result<(), ConsumerError> {
    // Colour scale: log10 between the 1st and 99th percentiles of the positive grid values
    // (the forward lobe, 10⁵ 1/sr, would otherwise leave everything else dark).
    let mut logs: Vec<f64> = slice
        .polar_deg
        .iter()
        .flat_map(|&p| slice.azimuth_deg.iter().map(move |&a| (p, a)))
        .map(|(p, a)| slice.value(k, p, a))
        .filter(|v| *v > 0.0)
        .map(f64::log10)
        .collect();
    if logs.is_empty() {
        return Err(ConsumerError::invalid("no positive phase values"));
    }
    logs.sort_by(|a, b| a.total_cmp(b));
    let pct = |q: f64| logs[((logs.len() - 1) as f64 * q).round() as usize];
    let (flo, fhi) = (pct(0.01), pct(0.99).max(pct(0.01) + 1e-3));
    let title = format!(
        "{title_prefix}log10 phase at {} nm, sun {} deg: {flo:.1} (dark) .. {fhi:.1} (yellow), 1-99 % clipped",
        slice.wavelengths_nm[k], slice.sun_elevation_deg
    );
    with_backend!(out, size, |root| {
        root.fill(&WHITE).map_err(perr)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..360f64, 0f64..180f64)
            .map_err(perr)?;
        raster(&root, &chart, |a, p| {
            let v = slice.value(k, p, a);
            let t = if v > 0.0 {
                ((v.log10() - flo) / (fhi - flo)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            ViridisRGB.get_color(t as f32)
        })?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("outgoing azimuth (deg; 0 = vertical plane upwards, 90 = +y)")
            .y_desc("outgoing polar (deg; 0 = forward)")
            .draw()
            .map_err(perr)?;
        Ok::<(), ConsumerError>(())
    })
}

/// Build previews of a 2-D table: `<stem>-latlong.png` (550 nm or the nearest wavelength,
/// lowest sun elevation) and `<stem>-bows.png` (the table's own bows, 650 nm or nearest).
pub fn previews_2d(
    table: crate::table::Table,
    stem: &str,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, ConsumerError> {
    let t2 = Phase2dTable::new(table)?;
    let e = t2.resolve_elevation(None)?;
    let slice = t2.slice(e, &[], "phase")?;
    let entry = t2.resolve_entry(&[])?;
    let mut written = vec![];
    let p = out_dir.join(format!("{stem}-latlong.png"));
    let k = nearest(&slice.wavelengths_nm, 550.0);
    plot_latlong(&slice, k, "", &p, (1000, 600))?;
    written.push(p);
    let p = out_dir.join(format!("{stem}-bows.png"));
    let label = format!("a = {}", t2.radius_label(&entry));
    let primary_order = t2.slice(e, &[], "phase_p2").ok();
    let disc = SunDisc::plan(&t2.table, None)?;
    plot_bows(
        &[BowInput {
            label,
            slice,
            primary_order,
        }],
        650.0,
        &disc,
        (120.0, 150.0),
        &p,
        (1500, 700),
    )?;
    written.push(p);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{lat_long_from_1d, peak_table};

    #[test]
    fn bow_peaks_follow_the_table_and_pictures_are_written() {
        // A 2-D table whose peak moves with azimuth: 138° + 1.5° cos φ (every wavelength).
        let wl = [450.0, 550.0, 650.0];
        let t1 = peak_table(&wl, |_| 138.0, 0.3, 1e-3, 3601);
        let t2 = lat_long_from_1d(&t1, &[0.0], 10.0, |_, _| 1.0);
        let mut content = t2.clone();
        let na = 36;
        for (idx, v) in content.data.iter_mut().enumerate() {
            let i = idx % na;
            let j = (idx / na) % 3601;
            let (t, phi) = (j as f64 * 0.05, i as f64 * 10.0);
            let c = 138.0 + 1.5 * phi.to_radians().cos();
            *v = (1e-3 + (-(t - c).powi(2) / (2.0 * 0.3 * 0.3)).exp()) as f32;
        }
        let t2 = Phase2dTable::new(content).unwrap();
        let slice = t2.slice(0.0, &[], "phase").unwrap();
        let dir = std::env::temp_dir().join(format!("sb-plot-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("bows.png");
        let peaks = plot_bows(
            &[BowInput {
                label: "synthetic".into(),
                slice: slice.clone(),
                primary_order: Some(slice.clone()),
            }],
            650.0,
            &SunDisc::from_applied(0.0, true, Some(0.0)).unwrap(),
            (120.0, 150.0),
            &out,
            (900, 500),
        )
        .unwrap();
        for (p, want) in peaks[0].iter().zip([139.5, 138.0, 136.5]) {
            assert!((p.phase_peak_deg - want).abs() < 0.02, "{p:?} vs {want}");
            assert!(
                (p.luminance_peak_deg - want).abs() < 0.02,
                "{p:?} vs {want}"
            );
        }
        let ll = dir.join("ll.png");
        plot_latlong(&slice, 1, "", &ll, (400, 240)).unwrap();
        // The raster has no white gaps inside the plotting area.
        let img = std::fs::read(&ll).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(img));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        let (w, h) = (info.width as usize, info.height as usize);
        let white_inside = (h / 4..3 * h / 4)
            .flat_map(|y| (w / 4..3 * w / 4).map(move |x| (x, y)))
            .filter(|&(x, y)| buf[(y * w + x) * 3..(y * w + x) * 3 + 3] == [255, 255, 255])
            .count();
        assert_eq!(white_inside, 0);
        std::fs::remove_dir_all(&dir).ok();
    }
}
