//! Figures made of panels (line plots and raster heatmaps with a colour bar), drawn with
//! `plotters` on a PNG (bitmap) or SVG backend. The table-specific code only builds the data
//! ([`Figure`], [`Panel`]); this module draws it.
//!
//! Heatmaps are rasters: the plot area is partitioned into cells whose pixel edges are integers
//! shared by neighbouring cells (cell `i` spans `[e_i, e_{i+1})`, `e_0` = left edge, `e_n` =
//! right edge of the plot area), so no background shows between cells. On the bitmap backend
//! every pixel is coloured from the cell containing its centre and the raster is blitted as one
//! image; on the SVG backend each cell is one rectangle with those integer edges (a per-pixel
//! image would make huge SVG files). Cells narrower than a pixel are drawn only where a pixel
//! centre falls into them.
//!
//! Colour: [`ColourScale`] (viridis, linear or log10), shown in a colour bar at the right of
//! every heatmap panel.

use crate::consumers::ConsumerError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Register the bundled DejaVu Sans as `sans-serif` (once).
pub fn ensure_font() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A `plotters` drawing error as a [`ConsumerError::Plot`].
pub fn perr<E: std::error::Error + Send + Sync + 'static>(e: E) -> ConsumerError {
    ConsumerError::Plot(Box::new(e))
}

/// Run `body` on a PNG or SVG backend chosen by the extension of `out`. The form
/// `|root, vector| body` also binds `vector: bool` (true for SVG).
macro_rules! with_backend {
    ($out:expr, $size:expr, |$root:ident| $body:expr) => {
        $crate::consumers::plot::figure::with_backend!($out, $size, |$root, _vector| $body)
    };
    ($out:expr, $size:expr, |$root:ident, $vector:ident| $body:expr) => {{
        use plotters::prelude::IntoDrawingArea as _;
        $crate::consumers::plot::figure::ensure_font();
        let out: &std::path::Path = $out;
        let size: (u32, u32) = $size;
        match out
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("svg") => {
                let $vector = true;
                let $root = plotters::prelude::SVGBackend::new(out, size).into_drawing_area();
                $body?;
                $root
                    .present()
                    .map_err($crate::consumers::plot::figure::perr)?;
            }
            Some("png") => {
                let $vector = false;
                let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
                {
                    let $root = plotters::prelude::BitMapBackend::with_buffer(&mut buf, size)
                        .into_drawing_area();
                    $body?;
                    $root
                        .present()
                        .map_err($crate::consumers::plot::figure::perr)?;
                }
                $crate::consumers::image::write_png(out, size.0 as usize, size.1 as usize, &buf)?;
            }
            _ => {
                return Err($crate::consumers::ConsumerError::invalid(format!(
                    "{}: output must end in .png or .svg",
                    out.display()
                )));
            }
        }
        Ok::<(), $crate::consumers::ConsumerError>(())
    }};
}
pub(crate) use with_backend;

/// Map from values to colours: viridis over `[lo, hi]`, in log10 when `log`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourScale {
    /// Lowest value of the scale (> 0 when `log`); values below get the lowest colour.
    pub lo: f64,
    /// Highest value; values above get the highest colour.
    pub hi: f64,
    pub log: bool,
}

impl ColourScale {
    /// Linear scale over `[lo, hi]`.
    pub fn linear(lo: f64, hi: f64) -> Self {
        ColourScale { lo, hi, log: false }
    }

    /// Scale for `values`: log10 when every value is ≥ 0 and the positive ones span more than
    /// two decades (then from max(smallest positive, 10⁻⁶·largest) to the largest; zeros get the
    /// lowest colour), linear from min to max otherwise. Non-finite values are ignored.
    pub fn auto(values: impl IntoIterator<Item = f64>) -> Self {
        Self::auto_with_floor(values, 1e-6)
    }

    /// [`ColourScale::auto`] with the log scale's floor at `floor`·largest.
    pub fn auto_with_floor(values: impl IntoIterator<Item = f64>, floor: f64) -> Self {
        let (mut lo, mut hi, mut lo_pos) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
        for v in values.into_iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
            if v > 0.0 {
                lo_pos = lo_pos.min(v);
            }
        }
        if !lo.is_finite() {
            return ColourScale::linear(0.0, 1.0);
        }
        if lo >= 0.0 && hi > 0.0 && hi / lo_pos > 100.0 {
            ColourScale {
                lo: lo_pos.max(hi * floor),
                hi,
                log: true,
            }
        } else {
            ColourScale::linear(lo, hi)
        }
    }

    /// The scale's coordinate of `v` (log10 v when logarithmic).
    pub fn transform(&self, v: f64) -> f64 {
        if self.log { v.max(self.lo).log10() } else { v }
    }

    /// Position of `v` in the scale, clamped to [0, 1] (0.5 for a degenerate scale).
    pub fn unit(&self, v: f64) -> f64 {
        let (a, b) = (self.transform(self.lo), self.transform(self.hi));
        if !(b > a) {
            return 0.5;
        }
        ((self.transform(v) - a) / (b - a)).clamp(0.0, 1.0)
    }

    pub fn colour(&self, v: f64) -> RGBColor {
        if !v.is_finite() {
            return RGBColor(255, 0, 255);
        }
        ViridisRGB.get_color(self.unit(v) as f32)
    }

    /// Colour-bar axis label for a quantity `name`.
    pub fn label(&self, name: &str) -> String {
        if self.log {
            format!("log10 {name}")
        } else {
            name.to_string()
        }
    }
}

/// Line style of a series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dash {
    Solid,
    Dashed,
    Dotted,
}

/// One curve.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text (empty: not in the legend).
    pub label: String,
    pub colour: RGBColor,
    pub dash: Dash,
    pub points: Vec<(f64, f64)>,
}

/// Curves over a common x axis.
#[derive(Debug, Clone)]
pub struct LinePanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Logarithmic y axis (values below 10⁻⁵ of the maximum are clipped).
    pub log_y: bool,
    /// Where the legend goes.
    pub legend: Legend,
}

/// Legend corner of a line panel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    #[default]
    UpperRight,
    UpperLeft,
    UpperMiddle,
    LowerRight,
    LowerLeft,
    MiddleLeft,
}

impl Legend {
    fn position(self) -> SeriesLabelPosition {
        match self {
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::UpperMiddle => SeriesLabelPosition::UpperMiddle,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
            Legend::MiddleLeft => SeriesLabelPosition::MiddleLeft,
        }
    }
}

/// A field over two axes, one value per cell; `xs`, `ys` are cell centres (increasing), cell
/// edges are the midpoints between centres (half a spacing beyond the end centres).
#[derive(Debug, Clone)]
pub struct HeatPanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    /// Row-major `values[j * xs.len() + i]` at (`xs[i]`, `ys[j]`).
    pub values: Vec<f64>,
    pub scale: ColourScale,
    /// Name and unit of the value, for the colour bar.
    pub value_label: String,
}

impl HeatPanel {
    /// Smallest and largest finite value.
    pub fn range(&self) -> (f64, f64) {
        range_of(self.values.iter().copied())
    }
}

/// A panel of a figure.
#[derive(Debug, Clone)]
pub enum Panel {
    Lines(LinePanel),
    Heat(HeatPanel),
}

/// Panels on a grid of `cols` columns (rows as needed) under a title.
#[derive(Debug, Clone)]
pub struct Figure {
    pub title: String,
    pub cols: usize,
    pub size: (u32, u32),
    pub panels: Vec<Panel>,
}

/// Smallest and largest finite value (±∞ when there is none).
pub fn range_of(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        })
}

/// Cell edges around increasing centres.
pub fn cell_edges(centres: &[f64]) -> Vec<f64> {
    let n = centres.len();
    if n == 1 {
        return vec![centres[0] - 0.5, centres[0] + 0.5];
    }
    (0..=n)
        .map(|i| {
            if i == 0 {
                centres[0] - 0.5 * (centres[1] - centres[0])
            } else if i == n {
                centres[n - 1] + 0.5 * (centres[n - 1] - centres[n - 2])
            } else {
                0.5 * (centres[i - 1] + centres[i])
            }
        })
        .collect()
}

/// Integer pixel edges of cells with data edges `edges` on a pixel span of `len` pixels
/// (`flip`: data increases upward, pixel rows downward). Monotone, first 0, last `len`.
fn pixel_edges(edges: &[f64], len: u32, flip: bool) -> Vec<i32> {
    let (a, b) = (edges[0], edges[edges.len() - 1]);
    let mut px: Vec<i32> = edges
        .iter()
        .map(|&e| (((e - a) / (b - a)) * len as f64).round() as i32)
        .collect();
    if flip {
        px = px.iter().rev().map(|&p| len as i32 - p).collect();
    }
    px
}

/// Fill `area` (pixel origin at its top-left) with cells: column `i` spans pixels
/// `[xe[i], xe[i+1])`, row `r` spans `[ye[r], ye[r+1])`; `colour(i, r)`.
fn fill_cells<DB: DrawingBackend<ErrorType: 'static>>(
    area: &DrawingArea<DB, Shift>,
    xe: &[i32],
    ye: &[i32],
    colour: &dyn Fn(usize, usize) -> RGBColor,
    vector: bool,
) -> Result<(), ConsumerError> {
    let (w, h) = area.dim_in_pixel();
    if w == 0 || h == 0 {
        return Ok(());
    }
    if vector {
        for r in 0..ye.len() - 1 {
            for i in 0..xe.len() - 1 {
                if xe[i + 1] > xe[i] && ye[r + 1] > ye[r] {
                    area.draw(&Rectangle::new(
                        [(xe[i], ye[r]), (xe[i + 1], ye[r + 1])],
                        colour(i, r).filled(),
                    ))
                    .map_err(perr)?;
                }
            }
        }
        return Ok(());
    }
    // Cell of each pixel centre: the last edge ≤ pixel (edges are integer, so pixel p lies in
    // the cell [e_k, e_{k+1}) with e_k ≤ p < e_{k+1}).
    let cell_of = |edges: &[i32], p: i32| -> usize {
        let k = edges.partition_point(|&e| e <= p);
        k.saturating_sub(1).min(edges.len() - 2)
    };
    let cols: Vec<usize> = (0..w as i32).map(|p| cell_of(xe, p)).collect();
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    for v in 0..h as usize {
        let r = cell_of(ye, v as i32);
        for (u, &i) in cols.iter().enumerate() {
            let c = colour(i, r);
            let o = (v * w as usize + u) * 3;
            buf[o..o + 3].copy_from_slice(&[c.0, c.1, c.2]);
        }
    }
    let elem = BitMapElement::with_owned_buffer((0, 0), (w, h), buf)
        .ok_or_else(|| ConsumerError::invalid("raster buffer size mismatch"))?;
    area.draw(&elem).map_err(perr)?;
    Ok(())
}

const TITLE_FONT: u32 = 15;
const LABEL_FONT: u32 = 12;

/// Draw a heatmap panel with its colour bar; returns the pixel rectangle of the raster
/// (backend coordinates).
fn draw_heat<DB: DrawingBackend<ErrorType: 'static>>(
    area: &DrawingArea<DB, Shift>,
    p: &HeatPanel,
    vector: bool,
) -> Result<PixelRect, ConsumerError> {
    let (nx, ny) = (p.xs.len(), p.ys.len());
    if nx == 0 || ny == 0 || p.values.len() != nx * ny {
        return Err(ConsumerError::invalid(format!(
            "heatmap `{}`: {nx} × {ny} cells, {} values",
            p.title,
            p.values.len()
        )));
    }
    let (w, _) = area.dim_in_pixel();
    let bar_w = 100.min(w / 3);
    let (main, bar) = area.split_horizontally(w - bar_w);
    let (xe, ye) = (cell_edges(&p.xs), cell_edges(&p.ys));
    // A constant field would show one colour without meaning: say so in the title.
    let (lo, hi) = p.range();
    let title = if lo == hi {
        format!("{} (constant {})", p.title, format_tick(lo))
    } else {
        p.title.clone()
    };
    let mut chart = ChartBuilder::on(&main)
        .caption(&title, ("sans-serif", TITLE_FONT))
        .margin(6)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(xe[0]..xe[nx], ye[0]..ye[ny])
        .map_err(perr)?;
    let x_labels = ((w - bar_w) / 75).clamp(3, 12) as usize;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(x_labels)
        .x_label_formatter(&|v| format_tick(*v))
        .y_label_formatter(&|v| format_tick(*v))
        .x_desc(&p.x_label)
        .y_desc(&p.y_label)
        .label_style(("sans-serif", LABEL_FONT))
        .axis_desc_style(("sans-serif", LABEL_FONT))
        .draw()
        .map_err(perr)?;
    let plot = chart.plotting_area().strip_coord_spec();
    let rect = chart.plotting_area().get_pixel_range();
    let (pw, ph) = plot.dim_in_pixel();
    let xpe = pixel_edges(&xe, pw, false);
    let ype = pixel_edges(&ye, ph, true);
    // Pixel row r counts from the top: the cell index of row r is ny − 1 − r.
    fill_cells(
        &plot,
        &xpe,
        &ype,
        &|i, r| p.scale.colour(p.values[(ny - 1 - r) * nx + i]),
        vector,
    )?;
    draw_colour_bar(&bar, p, bar_w, vector)?;
    Ok(rect)
}

/// The colour bar of a heatmap panel: the scale's full range in 256 steps, labelled with the
/// value label (and the scale's transform) on the right.
fn draw_colour_bar<DB: DrawingBackend<ErrorType: 'static>>(
    bar: &DrawingArea<DB, Shift>,
    p: &HeatPanel,
    bar_w: u32,
    vector: bool,
) -> Result<(), ConsumerError> {
    let (t0, t1) = (p.scale.transform(p.scale.lo), p.scale.transform(p.scale.hi));
    let (t0, t1) = if t1 > t0 {
        (t0, t1)
    } else {
        (t0 - 0.5, t0 + 0.5)
    };
    let mut bc = ChartBuilder::on(bar)
        .margin_top(6 + TITLE_FONT + 6)
        .margin_bottom(6)
        .margin_right(12)
        .x_label_area_size(36)
        .y_label_area_size(0)
        .right_y_label_area_size(bar_w.saturating_sub(34))
        .build_cartesian_2d(0f64..1f64, t0..t1)
        .map_err(perr)?;
    bc.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| format_tick(*v))
        .y_desc(p.scale.label(&p.value_label))
        .label_style(("sans-serif", LABEL_FONT - 1))
        .axis_desc_style(("sans-serif", LABEL_FONT - 1))
        .draw()
        .map_err(perr)?;
    let bar_area = bc.plotting_area().strip_coord_spec();
    let (bw, bh) = bar_area.dim_in_pixel();
    let steps = 256usize;
    let bx = [0, bw as i32];
    let by: Vec<i32> = (0..=steps)
        .map(|k| (k as f64 / steps as f64 * bh as f64).round() as i32)
        .collect();
    fill_cells(
        &bar_area,
        &bx,
        &by,
        &|_, r| {
            let t = 1.0 - (r as f64 + 0.5) / steps as f64;
            ViridisRGB.get_color(t as f32)
        },
        vector,
    )?;
    Ok(())
}

/// Draw a line panel.
fn draw_lines<DB: DrawingBackend<ErrorType: 'static>>(
    area: &DrawingArea<DB, Shift>,
    p: &LinePanel,
) -> Result<(), ConsumerError> {
    let (x0, x1) = range_of(p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0)));
    let (y0, y1) = range_of(p.series.iter().flat_map(|s| s.points.iter().map(|q| q.1)));
    if !x0.is_finite() {
        return Err(ConsumerError::invalid(format!(
            "line panel `{}` has no points",
            p.title
        )));
    }
    if !y0.is_finite() {
        return Err(ConsumerError::invalid(format!(
            "line panel `{}` has no finite value to draw (every value is NaN or infinite; \
             `scatterbake verify` counts them per channel)",
            p.title
        )));
    }
    let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
    let x_labels = (area.dim_in_pixel().0 / 75).clamp(3, 12) as usize;
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&p.title, ("sans-serif", TITLE_FONT))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(62);
    macro_rules! finish {
        ($chart:expr, $clip:expr, $fmt:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(&p.x_label)
                .y_desc(&p.y_label)
                .x_labels(x_labels)
                .x_label_formatter(&|v| format_tick(*v))
                .y_label_formatter($fmt)
                .label_style(("sans-serif", LABEL_FONT))
                .axis_desc_style(("sans-serif", LABEL_FONT))
                .light_line_style(WHITE.mix(0.0))
                .bold_line_style(BLACK.mix(0.08))
                .draw()
                .map_err(perr)?;
            let mut labelled = false;
            for s in &p.series {
                let col = s.colour;
                let style = col.stroke_width(2);
                let pts: Vec<(f64, f64)> = s.points.iter().map(|&(x, y)| (x, $clip(y))).collect();
                let anno = match s.dash {
                    Dash::Solid => chart.draw_series(LineSeries::new(pts, style)),
                    Dash::Dashed => chart.draw_series(DashedLineSeries::new(pts, 7, 4, style)),
                    Dash::Dotted => chart.draw_series(DashedLineSeries::new(pts, 2, 3, style)),
                }
                .map_err(perr)?;
                if !s.label.is_empty() {
                    labelled = true;
                    let dash = s.dash;
                    anno.label(&s.label).legend(move |(x, y)| {
                        let len = if dash == Dash::Solid { 20 } else { 14 };
                        PathElement::new(vec![(x, y), (x + len, y)], col.stroke_width(2))
                    });
                }
            }
            if labelled {
                chart
                    .configure_series_labels()
                    .label_font(("sans-serif", LABEL_FONT - 1))
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK.mix(0.4))
                    .position(p.legend.position())
                    .draw()
                    .map_err(perr)?;
            }
        }};
    }
    if p.log_y {
        let hi = if y1 > 0.0 { y1 } else { 1.0 };
        let (lo_pos, _) = range_of(
            p.series
                .iter()
                .flat_map(|s| s.points.iter().map(|q| q.1))
                .filter(|&v| v > 0.0),
        );
        let lo = lo_pos.max(hi * 1e-5).min(hi * 0.5);
        let chart = builder
            .build_cartesian_2d(x0..x1, (lo * 0.8..hi * 1.5).log_scale())
            .map_err(perr)?;
        let clip = |y: f64| y.max(lo * 0.8);
        finish!(chart, clip, &|v: &f64| format!("{v:.0e}"));
    } else {
        let pad = if y1 > y0 {
            0.05 * (y1 - y0)
        } else {
            0.5 * y0.abs().max(1.0)
        };
        let chart = builder
            .build_cartesian_2d(x0..x1, y0 - pad..y1 + pad)
            .map_err(perr)?;
        let clip = |y: f64| y;
        finish!(chart, clip, &|v: &f64| format_tick(*v));
    }
    Ok(())
}

/// Short tick label (|v| < 10⁻¹² is 0: tick positions computed as sums leave ±10⁻¹⁷ residues).
fn format_tick(v: f64) -> String {
    let a = v.abs();
    if a < 1e-12 {
        "0".into()
    } else if !(1e-4..1e5).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

/// Pixel rectangle (x range, y range) in backend coordinates.
pub type PixelRect = (Range<i32>, Range<i32>);

/// Draw `fig` on `root`; returns the raster rectangles of its heatmap panels.
pub fn draw_figure_on<DB: DrawingBackend<ErrorType: 'static>>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure,
    vector: bool,
) -> Result<Vec<PixelRect>, ConsumerError> {
    root.fill(&WHITE).map_err(perr)?;
    let body = if fig.title.is_empty() {
        root.clone()
    } else {
        root.titled(&fig.title, ("sans-serif", 18)).map_err(perr)?
    };
    let cols = fig.cols.max(1);
    let rows = fig.panels.len().div_ceil(cols).max(1);
    let areas = body.split_evenly((rows, cols));
    let mut rects = Vec::new();
    for (p, a) in fig.panels.iter().zip(areas.iter()) {
        match p {
            Panel::Lines(l) => draw_lines(a, l)?,
            Panel::Heat(h) => rects.push(draw_heat(a, h, vector)?),
        }
    }
    Ok(rects)
}

/// Write `fig` to `out` (.png or .svg).
pub fn draw_figure(fig: &Figure, out: &Path) -> Result<(), ConsumerError> {
    with_backend!(out, fig.size, |root, vector| draw_figure_on(
        &root, fig, vector
    )
    .map(|_| ()))
}

/// Render `fig` into an RGB buffer (for tests and previews); returns the buffer and the
/// raster rectangles of its heatmap panels.
pub fn render_rgb(fig: &Figure) -> Result<(Vec<u8>, Vec<PixelRect>), ConsumerError> {
    ensure_font();
    let (w, h) = fig.size;
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    let rects = {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let r = draw_figure_on(&root, fig, false)?;
        root.present().map_err(perr)?;
        r
    };
    Ok((buf, rects))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp_panel(nx: usize, ny: usize) -> HeatPanel {
        let xs: Vec<f64> = (0..nx).map(|i| -179.75 + 0.5 * i as f64).collect();
        let ys: Vec<f64> = (0..ny)
            .map(|j| -1.0 + 2.0 * j as f64 / (ny - 1) as f64)
            .collect();
        let values: Vec<f64> = (0..ny)
            .flat_map(|j| {
                (0..nx).map(move |i| 1e-4 * 10f64.powf(4.0 * (i + j) as f64 / (nx + ny) as f64))
            })
            .collect();
        HeatPanel {
            title: "ramp".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            scale: ColourScale::auto(values.iter().copied()),
            xs,
            ys,
            values,
            value_label: "v".into(),
        }
    }

    /// The raster covers the whole plot area: no background (white) pixel inside it, for cell
    /// counts below, near and above the pixel count (the old per-cell rectangles left white
    /// lines where rounding put a gap between neighbours).
    #[test]
    fn raster_heatmap_has_no_gaps() {
        for (nx, ny) in [(37, 9), (720, 9), (180, 90)] {
            let p = ramp_panel(nx, ny);
            assert!(p.scale.log);
            let fig = Figure {
                title: "t".into(),
                cols: 2,
                size: (1000, 420),
                panels: vec![Panel::Heat(p.clone()), Panel::Heat(p)],
            };
            let (buf, rects) = render_rgb(&fig).unwrap();
            assert_eq!(rects.len(), 2);
            for (xr, yr) in rects {
                assert!(
                    xr.end - xr.start > 100 && yr.end - yr.start > 100,
                    "{xr:?} {yr:?}"
                );
                let (mut white, mut distinct) = (0, std::collections::HashSet::new());
                for y in yr.clone() {
                    for x in xr.clone() {
                        let o = (y as usize * 1000 + x as usize) * 3;
                        let c = (buf[o], buf[o + 1], buf[o + 2]);
                        if c == (255, 255, 255) {
                            white += 1;
                        }
                        distinct.insert(c);
                    }
                }
                assert_eq!(white, 0, "{nx}×{ny}: white pixels in the plot area");
                assert!(distinct.len() > 30, "{nx}×{ny}: {} colours", distinct.len());
                // Bottom-left cell is the smallest value (lowest viridis colour), top-right the
                // largest.
                let px = |x: i32, y: i32| {
                    let o = (y as usize * 1000 + x as usize) * 3;
                    RGBColor(buf[o], buf[o + 1], buf[o + 2])
                };
                let near = |a: RGBColor, b: RGBColor| {
                    (a.0 as i32 - b.0 as i32).abs() <= 2
                        && (a.1 as i32 - b.1 as i32).abs() <= 2
                        && (a.2 as i32 - b.2 as i32).abs() <= 2
                };
                let bl = px(xr.start, yr.end - 1);
                assert!(near(bl, ViridisRGB.get_color(0.0)), "{bl:?}");
                let tr = px(xr.end - 1, yr.start);
                assert!(near(tr, ViridisRGB.get_color(1.0)), "{tr:?}");
            }
        }
    }

    /// SVG heatmaps are one rectangle per cell (not per pixel): a 180 × 90 field gives at most
    /// 16 200 cell rectangles plus the colour bar's 256, and the cells tile the plot area.
    #[test]
    fn svg_heatmap_is_one_rect_per_cell() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("h.svg");
        let fig = Figure {
            title: "t".into(),
            cols: 1,
            size: (900, 500),
            panels: vec![Panel::Heat(ramp_panel(180, 90))],
        };
        draw_figure(&fig, &out).unwrap();
        let svg = std::fs::read_to_string(&out).unwrap();
        let rects = svg.matches("<rect").count();
        assert!(
            rects > 180 * 90 / 2 && rects < 180 * 90 + 256 + 50,
            "{rects} rects"
        );
        assert!(svg.len() < 4_000_000, "{} bytes", svg.len());
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(format_tick(-2.2e-16), "0");
        assert_eq!(format_tick(0.0015), "0.0015");
        assert_eq!(format_tick(80.0), "80");
        assert_eq!(format_tick(2.5e-5), "2.5e-5");
    }

    #[test]
    fn a_line_panel_without_a_finite_value_is_an_error_not_a_panic() {
        let panel = |y: f64| {
            Panel::Lines(LinePanel {
                title: "t".into(),
                x_label: "x".into(),
                y_label: "y".into(),
                log_y: false,
                series: vec![Series {
                    label: String::new(),
                    colour: BLUE,
                    dash: Dash::Solid,
                    points: vec![(0.0, y), (1.0, y)],
                }],
                legend: Legend::default(),
            })
        };
        for y in [f64::NAN, f64::INFINITY] {
            let fig = Figure {
                title: String::new(),
                cols: 1,
                size: (200, 150),
                panels: vec![panel(y)],
            };
            let e = render_rgb(&fig).unwrap_err().to_string();
            assert!(e.contains("no finite value"), "{e}");
        }
    }

    #[test]
    fn colour_scale_goes_log_for_wide_positive_ranges() {
        let s = ColourScale::auto([0.0, 1e-3, 1.0]);
        assert!(s.log && s.lo == 1e-3 && s.hi == 1.0);
        assert!((s.unit(10f64.powf(-1.5)) - 0.5).abs() < 1e-12);
        assert_eq!(s.unit(0.0), 0.0);
        let s = ColourScale::auto([-1.0, 1e-3, 1.0]);
        assert!(!s.log);
        assert!((s.unit(0.0) - 0.5).abs() < 1e-12);
    }
}
