//! Default preview figures per table family (schema), used by
//! [`previews`]. Each builder reads the table's stored samples (no interpolation),
//! picks slices where the family's physics happens (e.g. a medulla at mid σ and g, never the
//! σ = 0 slice, which is all zeros) and returns [`Figure`]s named by a file suffix. What each
//! figure shows is described in `docs/consumers.md` ("Previews").

use super::figure::draw_figure;
use super::figure::{ColourScale, Dash, Figure, HeatPanel, Legend, LinePanel, Panel, Series};
use super::style::{PALETTE, short_number};
use super::tables::{
    heat_panel_sampled, plot_debye_components, plot_heatmap, plot_lee, plot_line, plot_phase,
    plot_strip,
};
pub use super::view::View;
use crate::consumers::ConsumerError;
use crate::consumers::read::phase::{EntrySelection, PhaseTable};
use crate::error::IoError;
use crate::table::Table;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Write the default previews of a table into `out_dir` as `<stem>-<kind>.png`; returns the
/// files written. Phase tables (by the phase contract) get phase + strip (+ lee); other tables
/// get the figures of their schema family (`super::previews`); unknown schemas a heatmap of the
/// last two axes with every other axis at its middle sample (first non-constant channel), or a
/// line plot when 1-D.
///
/// The pictures never land outside `out_dir`: `out_dir` must be a real directory (a symbolic
/// link is refused), every picture is drawn into a fresh private directory inside it and then
/// renamed into place, so a symbolic link planted under a picture's name is replaced, not
/// followed.
pub fn previews(table_path: &Path, out_dir: &Path) -> Result<Vec<PathBuf>, ConsumerError> {
    std::fs::create_dir_all(out_dir).map_err(IoError::doing("creating", out_dir))?;
    let meta = std::fs::symlink_metadata(out_dir).map_err(IoError::doing("reading", out_dir))?;
    if !meta.is_dir() {
        return Err(ConsumerError::Invalid(format!(
            "{} is a symbolic link or not a directory; refusing to draw previews through it",
            out_dir.display()
        )));
    }
    remove_orphan_staging(out_dir);
    let staging = tempfile::Builder::new()
        .prefix(&staging_prefix(std::process::id()))
        .tempdir_in(out_dir)
        .map_err(IoError::doing("creating a directory in", out_dir))?;
    // an error names the picture where it was to go, not the private directory
    let drawn = draw_previews_into(table_path, staging.path()).map_err(|e| {
        let staged = staging.path().display().to_string();
        let mut chain = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            chain = format!("{chain}: {c}");
            cause = c.source();
        }
        if chain.contains(&staged) {
            ConsumerError::Invalid(chain.replace(&staged, &out_dir.display().to_string()))
        } else {
            e
        }
    })?;
    let mut written = Vec::with_capacity(drawn.len());
    for p in drawn {
        let dest = out_dir.join(p.file_name().expect("a picture has a file name"));
        std::fs::rename(&p, &dest).map_err(IoError::doing("moving a preview to", &dest))?;
        written.push(dest);
    }
    Ok(written)
}

/// Prefix of the private directory a process draws its previews into:
/// `.previews.<host>.<pid>.`, so that the next process can tell one a killed process left.
fn staging_prefix(pid: u32) -> String {
    format!(".previews.{}.{pid}.", crate::table::format::host_tag())
}

/// Remove the private preview directories in `out_dir` of processes of this host that no longer
/// exist (left by a kill while drawing; needs `/proc`). Symbolic links and other hosts' directories
/// are left alone.
fn remove_orphan_staging(out_dir: &Path) {
    let host_prefix = format!(".previews.{}.", crate::table::format::host_tag());
    let (true, Ok(entries)) = (Path::new("/proc/self").exists(), std::fs::read_dir(out_dir)) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix(&host_prefix)
            .and_then(|rest| rest.split('.').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        let is_dir = e.file_type().is_ok_and(|t| t.is_dir());
        if is_dir && !Path::new("/proc").join(pid.to_string()).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// [`previews`] drawn into `out_dir`, a directory this process created.
fn draw_previews_into(table_path: &Path, out_dir: &Path) -> Result<Vec<PathBuf>, ConsumerError> {
    let stem = table_path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("table")
        .to_string();
    let table = Table::open(table_path)?;
    let name = |k: &str| out_dir.join(format!("{stem}-{k}.png"));
    if crate::consumers::read::phase2d::is_2d(&table) {
        return super::raytrace::previews_2d(table, &stem, out_dir);
    }
    let mut written = Vec::new();
    if let Ok(pt) = PhaseTable::new(table.clone()) {
        let p = name("phase");
        // Three wavelengths, unpolarised: Mie ripple makes 8 polarised curves unreadable.
        plot_phase(&pt, &[], &[450.0, 550.0, 650.0], false, &p, (1000, 600))?;
        written.push(p);
        let p = name("strip");
        plot_strip(&pt, &[], None, (120.0, 145.0), &p, (1000, 160))?;
        written.push(p);
        if pt
            .entry_axes
            .iter()
            .any(|&i| pt.table.axes()[i].name == "radius" && pt.table.axes()[i].len() > 1)
        {
            let p = name("lee");
            plot_lee(
                &pt,
                &[],
                None,
                (120.0, 145.0),
                &p,
                (900, 600),
                &crate::progress::Silent,
            )?;
            written.push(p);
        }
        if pt.table.channel_index("phase_p2").is_ok() {
            // Per-order channels (Debye or ray orders): MiePlot's "Mie with its Debye
            // components" figure at 650 nm.
            let p = name("orders");
            plot_debye_components(&pt, &[], 650.0, &p, (1000, 600))?;
            written.push(p);
        }
        return Ok(written);
    }
    let view = View::new(&table, &stem);
    let figures = match table.header.schema.name.as_str() {
        "fur-medulla-azimuthal" => medulla_azimuthal(&view)?,
        "fur-medulla-longitudinal" => medulla_longitudinal(&view)?,
        "fur-farfield" => fur_farfield(&view)?,
        "hair-dual" => hair_dual(&view)?,
        "hair-azimuthal" => hair_azimuthal(&view)?,
        "water-index" => water_index(&view)?,
        "cloth-brdf" => super::cloth::incidence_plane(&view)?,
        _ => {
            let p = generic_preview(&table, &name)?;
            written.push(p);
            return Ok(written);
        }
    };
    for (kind, fig) in figures {
        let p = name(kind);
        draw_figure(&fig, &p).map_err(|e| e.in_file(&p))?;
        written.push(p);
    }
    Ok(written)
}

/// Preview of a table of unknown schema: heatmap of the last two axes at the middle sample of
/// every other axis, first channel that is not constant there; line plot for 1-D tables.
fn generic_preview(
    table: &Table,
    name: &dyn Fn(&str) -> PathBuf,
) -> Result<PathBuf, ConsumerError> {
    let axes = table.axes();
    let n = axes.len();
    let entry: Vec<EntrySelection> = axes[..n.saturating_sub(if n >= 2 { 2 } else { 1 })]
        .iter()
        .map(|a| EntrySelection {
            axis: a.name.clone(),
            value: a.coord(a.len() / 2),
        })
        .collect();
    if n < 2 {
        let p = name("line");
        plot_line(table, &entry, &p, (1000, 600))?;
        return Ok(p);
    }
    let mut coords: Vec<f64> = axes.iter().map(|a| a.coord(0)).collect();
    for e in &entry {
        coords[table.axis_index(&e.axis)?] = e.value;
    }
    let mut ch = 0;
    for c in 0..table.header.channels.len() {
        let hp = heat_panel_sampled(table, &coords, n - 1, n - 2, c)?;
        let (lo, hi) = hp.range();
        if hi > lo {
            ch = c;
            break;
        }
    }
    let p = name("heatmap");
    plot_heatmap(
        table,
        &entry,
        Some(&table.header.channels[ch].name),
        &p,
        (1000, 600),
    )?;
    Ok(p)
}

/// Up to `k` items of `items` at evenly spaced positions (both ends included).
pub fn spread<T: Copy>(items: &[T], k: usize) -> Vec<T> {
    let n = items.len();
    if n <= k {
        return items.to_vec();
    }
    let mut idx: Vec<usize> = (0..k).map(|i| i * (n - 1) / (k - 1).max(1)).collect();
    idx.dedup();
    idx.into_iter().map(|i| items[i]).collect()
}

/// Sequential colour `k` of `n` (viridis from dark purple to green, avoiding the pale end).
pub fn seq_colour(k: usize, n: usize) -> RGBColor {
    let t = if n > 1 {
        0.88 * k as f64 / (n - 1) as f64
    } else {
        0.0
    };
    ViridisRGB.get_color(t as f32)
}

fn series(label: String, colour: RGBColor, dash: Dash, points: Vec<(f64, f64)>) -> Series {
    Series {
        label,
        colour,
        dash,
        points,
    }
}

fn lines(title: String, x_label: String, y_label: String, s: Vec<Series>, log_y: bool) -> Panel {
    Panel::Lines(LinePanel {
        title,
        x_label,
        y_label,
        series: s,
        log_y,
        legend: Legend::UpperRight,
    })
}

/// `lines` with the legend at `at`.
fn lines_at(
    title: String,
    x_label: String,
    y_label: String,
    s: Vec<Series>,
    log_y: bool,
    at: Legend,
) -> Panel {
    let mut p = lines(title, x_label, y_label, s, log_y);
    if let Panel::Lines(l) = &mut p {
        l.legend = at;
    }
    p
}

/// Colour scale of a heat panel.
enum Scale {
    /// [`ColourScale::auto`] of the panel's values.
    Auto,
    /// Linear from 0 to the panel's maximum (Monte Carlo energies: the grazing bins near 0
    /// would otherwise force a log scale that flattens the lobes).
    FromZero,
    Fixed(ColourScale),
}

fn heat(
    title: String,
    x_label: String,
    y_label: String,
    (xs, ys, values): (Vec<f64>, Vec<f64>, Vec<f64>),
    scale: Scale,
    value_label: String,
) -> Panel {
    let scale = match scale {
        Scale::Auto => ColourScale::auto(values.iter().copied()),
        Scale::FromZero => {
            let (_, hi) = super::figure::range_of(values.iter().copied());
            ColourScale::linear(0.0, hi)
        }
        Scale::Fixed(s) => s,
    };
    Panel::Heat(HeatPanel {
        title,
        x_label,
        y_label,
        scale,
        xs,
        ys,
        values,
        value_label,
    })
}

/// Index of the first sample whose coordinate is ≥ 0 (symmetric axes store mirrored rows).
fn non_negative(v: &View, axis: usize, exclude_abs_one: bool) -> Vec<usize> {
    (0..v.len(axis))
        .filter(|&i| {
            let c = v.coord(axis, i);
            c >= 0.0 && !(exclude_abs_one && (c.abs() - 1.0).abs() < 1e-9)
        })
        .collect()
}

/// Samples of `axis` with a non-zero coordinate (σ = 0 slices of Monte Carlo tables are empty).
fn non_zero(v: &View, axis: usize) -> Vec<usize> {
    (0..v.len(axis))
        .filter(|&i| v.coord(axis, i) != 0.0)
        .collect()
}

/// A middle sample of `axis` among the non-zero ones.
fn mid_non_zero(v: &View, axis: usize) -> usize {
    let nz = non_zero(v, axis);
    if nz.is_empty() || nz.contains(&v.mid(axis)) {
        v.mid(axis)
    } else {
        nz[nz.len() / 2]
    }
}

/// One curve per pick of `axis` (labelled `name`), each a line of channel `ch` along `along`
/// through the index `at(pick)`.
fn sweep_series(
    v: &View,
    axis: usize,
    picks: &[usize],
    name: &str,
    along: usize,
    ch: usize,
    at: impl Fn(usize) -> Vec<usize>,
) -> Vec<Series> {
    picks
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            series(
                v.at_text(axis, i, name),
                seq_colour(k, picks.len()),
                Dash::Solid,
                v.line(&at(i), along, ch),
            )
        })
        .collect()
}

/// Axes, channels and the default slice of a `fur-medulla-azimuthal` table.
struct MedullaAzimuthalView {
    sa: usize,
    ga: usize,
    ha: usize,
    pa: usize,
    energy: usize,
    path: usize,
    /// Default σ, g and h' samples.
    s0: usize,
    g0: usize,
    h_half: usize,
    /// " per X° bin" when the table says its bin width.
    bin: String,
    at_sg: String,
    x_label: String,
}

impl MedullaAzimuthalView {
    fn new(v: &View) -> Result<Self, ConsumerError> {
        let (sa, ga, ha, pa) = (v.ax("sigma")?, v.ax("g")?, v.ax("h")?, v.ax("phi")?);
        let (s0, g0) = (mid_non_zero(v, sa), v.mid(ga));
        let bin =
            v.t.header
                .attributes
                .get("bin_width_deg")
                .and_then(|b| b.as_f64())
                .map(|b| format!(" per {}° bin", short_number(b)))
                .unwrap_or_default();
        Ok(Self {
            sa,
            ga,
            ha,
            pa,
            energy: v.ch("energy")?,
            path: v.ch("path_length")?,
            s0,
            g0,
            h_half: v.nearest(ha, 0.5),
            bin,
            at_sg: format!("{}, {}", v.at_text(sa, s0, "σ"), v.at_text(ga, g0, "g")),
            x_label: v.axis_label(pa, "φ' (0 = straight through)"),
        })
    }

    /// Index with σ, g, h' set (φ' left at 0).
    fn index(&self, s: usize, g: usize, h: usize) -> Vec<usize> {
        let mut i = vec![0; 4];
        i[self.sa] = s;
        i[self.ga] = g;
        i[self.ha] = h;
        i
    }

    /// Energy and path length vs φ' for several h', σ and g.
    fn profiles(&self, v: &View) -> Figure {
        let (s0, g0, h_half, pa) = (self.s0, self.g0, self.h_half, self.pa);
        let hs = spread(&non_negative(v, self.ha, true), 5);
        let by_h = |ch| sweep_series(v, self.ha, &hs, "h'", pa, ch, |h| self.index(s0, g0, h));
        let sigmas = spread(&non_zero(v, self.sa), 5);
        let by_sigma = sweep_series(v, self.sa, &sigmas, "σ", pa, self.energy, |s| {
            self.index(s, g0, h_half)
        });
        let gs = spread(&(0..v.len(self.ga)).collect::<Vec<_>>(), 5);
        let by_g = sweep_series(v, self.ga, &gs, "g", pa, self.energy, |g| {
            self.index(s0, g, h_half)
        });
        let e_label = format!("scattered energy{} (1)", self.bin);
        let at_sg = &self.at_sg;
        let xl = &self.x_label;
        Figure {
            title: v.title("azimuthal profile C^N(φ'; h', σ, g) of the medulla"),
            cols: 2,
            size: (1400, 900),
            panels: vec![
                lines(
                    format!("energy vs φ' for several h', {at_sg}"),
                    xl.clone(),
                    e_label.clone(),
                    by_h(self.energy),
                    false,
                ),
                lines(
                    format!(
                        "energy vs φ' for several σ, {}, {}",
                        v.at_text(self.ha, h_half, "h'"),
                        v.at_text(self.ga, g0, "g")
                    ),
                    xl.clone(),
                    e_label.clone(),
                    by_sigma,
                    false,
                ),
                lines(
                    format!(
                        "energy vs φ' for several g, {}, {}",
                        v.at_text(self.sa, s0, "σ"),
                        v.at_text(self.ha, h_half, "h'")
                    ),
                    xl.clone(),
                    e_label,
                    by_g,
                    false,
                ),
                lines(
                    format!("mean path length in the medulla, {at_sg}"),
                    xl.clone(),
                    v.channel_label(self.path, "path length"),
                    by_h(self.path),
                    false,
                ),
            ],
        }
    }

    /// Energy and path length over h' × φ' at the default σ, g.
    fn map(&self, v: &View) -> Figure {
        let idx = self.index(self.s0, self.g0, 0);
        let at_sg = &self.at_sg;
        let y_label = v.axis_label(self.ha, "h' (entry offset)");
        Figure {
            title: v.title(&format!("entry offset h' × exit azimuth φ', {at_sg}")),
            cols: 1,
            size: (1200, 900),
            panels: vec![
                heat(
                    format!("scattered energy{}, {at_sg}", self.bin),
                    self.x_label.clone(),
                    y_label.clone(),
                    v.grid(&idx, self.pa, self.ha, self.energy),
                    Scale::FromZero,
                    "energy".into(),
                ),
                heat(
                    format!("mean in-medulla path length, {at_sg}"),
                    self.x_label.clone(),
                    y_label,
                    v.grid(&idx, self.pa, self.ha, self.path),
                    Scale::FromZero,
                    v.channel_label(self.path, "path length"),
                ),
            ],
        }
    }
}

/// `fur-medulla-azimuthal/1`: profile plots and an h' × φ' map.
pub fn medulla_azimuthal(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let m = MedullaAzimuthalView::new(v)?;
    Ok(vec![("profiles", m.profiles(v)), ("map", m.map(v))])
}

/// `fur-medulla-longitudinal/1`: back and forward lobes vs θ'_r.
pub fn medulla_longitudinal(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let (sa, ga, ia, la, ra) = (
        v.ax("sigma")?,
        v.ax("g")?,
        v.ax("theta_i")?,
        v.ax("lobe")?,
        v.ax("theta_r")?,
    );
    let energy = v.ch("energy")?;
    let (s0, g0) = (mid_non_zero(v, sa), v.mid(ga));
    let i_mid = v.nearest(ia, 37.5);
    let base = |s: usize, g: usize, ti: usize, lobe: usize| {
        let mut i = vec![0; 5];
        i[sa] = s;
        i[ga] = g;
        i[ia] = ti;
        i[la] = lobe;
        i
    };
    let lobe_name = |l: usize| if l == 0 { "back lobe" } else { "forward lobe" };
    let lobe_of = |want: f64| v.nearest(la, want);
    let at_sg = format!("{}, {}", v.at_text(sa, s0, "σ"), v.at_text(ga, g0, "g"));
    let xl = v.axis_label(ra, "θ'_r");
    let yl = v.channel_label(energy, "scattered energy per bin");
    let tis = spread(&non_negative(v, ia, false), 4);
    let sigmas = spread(&non_zero(v, sa), 5);
    let mut panels = Vec::new();
    for l in [lobe_of(0.0), lobe_of(1.0)] {
        let s: Vec<Series> = tis
            .iter()
            .enumerate()
            .map(|(k, &ti)| {
                series(
                    v.at_text(ia, ti, "θ'_i"),
                    seq_colour(k, tis.len()),
                    Dash::Solid,
                    v.line(&base(s0, g0, ti, l), ra, energy),
                )
            })
            .collect();
        panels.push(lines(
            format!("{} for several θ'_i, {at_sg}", lobe_name(l)),
            xl.clone(),
            yl.clone(),
            s,
            false,
        ));
    }
    for l in [lobe_of(0.0), lobe_of(1.0)] {
        let s: Vec<Series> = sigmas
            .iter()
            .enumerate()
            .map(|(k, &si)| {
                series(
                    v.at_text(sa, si, "σ"),
                    seq_colour(k, sigmas.len()),
                    Dash::Solid,
                    v.line(&base(si, g0, i_mid, l), ra, energy),
                )
            })
            .collect();
        panels.push(lines(
            format!(
                "{} for several σ, {}, {}",
                lobe_name(l),
                v.at_text(ia, i_mid, "θ'_i"),
                v.at_text(ga, g0, "g")
            ),
            xl.clone(),
            yl.clone(),
            s,
            false,
        ));
    }
    let lobes = Figure {
        title: v.title("longitudinal lobes C^M(θ'_r; θ'_i, σ, g) of the medulla slab"),
        cols: 2,
        size: (1400, 900),
        panels,
    };
    let map = Figure {
        title: v.title(&format!("incidence θ'_i × exit θ'_r, {at_sg}")),
        cols: 2,
        size: (1400, 600),
        panels: [lobe_of(0.0), lobe_of(1.0)]
            .iter()
            .map(|&l| {
                heat(
                    format!("{}, {at_sg}", lobe_name(l)),
                    xl.clone(),
                    v.axis_label(ia, "θ'_i"),
                    v.grid(&base(s0, g0, 0, l), ra, ia, energy),
                    Scale::FromZero,
                    "energy per bin".into(),
                )
            })
            .collect(),
    };
    Ok(vec![("lobes", lobes), ("map", map)])
}

/// `fur-farfield/1`: θ_r × φ images per sample, and the components of one sample.
pub fn fur_farfield(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let (sa, ia, ra, pa) = (
        v.ax("sample")?,
        v.ax("theta_i")?,
        v.ax("theta_r")?,
        v.ax("phi")?,
    );
    let energy = v.ch("energy")?;
    let ti = v.nearest(ia, -40.0);
    let names: Vec<String> = (0..v.len(sa))
        .map(|i| {
            v.t.header
                .attributes
                .get("samples")
                .and_then(|s| s.get(i))
                .and_then(|s| s.get("name"))
                .and_then(|n| n.as_str())
                .map(str::to_string)
                .unwrap_or_else(|| format!("sample {i}"))
        })
        .collect();
    let base = |s: usize| {
        let mut i = vec![0; 4];
        i[sa] = s;
        i[ia] = ti;
        i
    };
    let grids: Vec<_> = (0..v.len(sa))
        .map(|s| v.grid(&base(s), pa, ra, energy))
        .collect();
    let scale = ColourScale::auto_with_floor(grids.iter().flat_map(|g| g.2.iter().copied()), 1e-4);
    let ti_text = v.at_text(ia, ti, "θ_i");
    let (xl, yl) = (v.axis_label(pa, "φ"), v.axis_label(ra, "θ_r"));
    let cols = if grids.len() > 6 { 5 } else { 3 };
    let rows = grids.len().div_ceil(cols) as u32;
    let samples = Figure {
        title: v.title(&format!(
            "total scattered energy over θ_r × φ per sample, {ti_text}, common colour scale"
        )),
        cols,
        size: (360 * cols as u32, 40 + 340 * rows),
        panels: grids
            .into_iter()
            .enumerate()
            .map(|(s, g)| {
                heat(
                    names[s].clone(),
                    xl.clone(),
                    yl.clone(),
                    g,
                    Scale::Fixed(scale),
                    v.channel_label(energy, "energy"),
                )
            })
            .collect(),
    };
    let s0 = 0;
    let chans: Vec<usize> = (0..v.t.header.channels.len()).collect();
    let components = Figure {
        title: v.title(&format!(
            "components of the scattered energy of {}, {ti_text}",
            names[s0]
        )),
        cols: 3,
        size: (1500, 40 + 380 * chans.len().div_ceil(3) as u32),
        panels: chans
            .iter()
            .map(|&c| {
                let name = v.t.header.channels[c].name.clone();
                heat(
                    name.clone(),
                    xl.clone(),
                    yl.clone(),
                    v.grid(&base(s0), pa, ra, c),
                    Scale::Auto,
                    v.channel_label(c, &name),
                )
            })
            .collect(),
    };
    Ok(vec![("samples", samples), ("components", components)])
}

/// Colour of a `colour_channel` sample (0 = R, 1 = G, 2 = B).
fn rgb_colour(c: f64) -> RGBColor {
    match c.round() as i64 {
        0 => RGBColor(210, 30, 30),
        1 => RGBColor(30, 150, 40),
        2 => RGBColor(30, 70, 220),
        _ => RGBColor(0, 0, 0),
    }
}

/// How a `hair-dual` channel is drawn: as stored, radians → degrees, or the square root of a
/// variance (rad²) in degrees.
#[derive(Clone, Copy)]
enum DualPlotted {
    AsStored,
    Degrees,
    SqrtDegrees,
}

impl DualPlotted {
    fn apply(self, y: f64) -> f64 {
        let deg = 180.0 / std::f64::consts::PI;
        match self {
            DualPlotted::AsStored => y,
            DualPlotted::Degrees => y * deg,
            DualPlotted::SqrtDegrees => y.max(0.0).sqrt() * deg,
        }
    }
}

/// One panel of [`hair_dual_colour`].
struct DualPanel {
    title: &'static str,
    y_label: &'static str,
    /// Channels drawn solid, dashed, dotted.
    channels: &'static [(&'static str, DualPlotted)],
    /// Legend at the upper middle (else upper right).
    upper_middle: bool,
}

/// The panels of [`hair_dual_colour`].
const HAIR_DUAL_PANELS: [DualPanel; 6] = [
    DualPanel {
        title: "a_f (solid: forward), a_b (dashed: backward)",
        y_label: "average attenuation (1)",
        channels: &[
            ("a_f", DualPlotted::AsStored),
            ("a_b", DualPlotted::AsStored),
        ],
        upper_middle: true,
    },
    DualPanel {
        title: "alpha_f (solid), alpha_b (dashed): mean longitudinal shifts",
        y_label: "shift (deg)",
        channels: &[
            ("alpha_f", DualPlotted::Degrees),
            ("alpha_b", DualPlotted::Degrees),
        ],
        upper_middle: false,
    },
    DualPanel {
        title: "sqrt(beta_f2) (solid), sqrt(beta_b2) (dashed): mean widths",
        y_label: "width (deg)",
        channels: &[
            ("beta_f2", DualPlotted::SqrtDegrees),
            ("beta_b2", DualPlotted::SqrtDegrees),
        ],
        upper_middle: false,
    },
    DualPanel {
        title: "A_b: multiple backscattering attenuation",
        y_label: "A_b (1)",
        channels: &[("A_b", DualPlotted::AsStored)],
        upper_middle: true,
    },
    DualPanel {
        title: "delta_b (solid), sigma_b = sqrt(sigma_b2) (dashed)",
        y_label: "backscattering shift, width (deg)",
        channels: &[
            ("delta_b", DualPlotted::Degrees),
            ("sigma_b2", DualPlotted::SqrtDegrees),
        ],
        upper_middle: false,
    },
    DualPanel {
        title: "lobe energies E_R (solid), E_TT (dashed), E_TRT (dotted)",
        y_label: "energy (1)",
        channels: &[
            ("E_R", DualPlotted::AsStored),
            ("E_TT", DualPlotted::AsStored),
            ("E_TRT", DualPlotted::AsStored),
        ],
        upper_middle: true,
    },
];

/// Curves of a per-colour `hair-dual` table along θ at a fixed index of the other axes.
struct RgbCurves<'v, 'a> {
    v: &'v View<'a>,
    colour_axis: usize,
    theta_axis: usize,
    idx: Vec<usize>,
}

impl RgbCurves<'_, '_> {
    /// One curve of channel `name` per colour; legend "R", "G", "B" when `label`.
    fn curves(
        &self,
        name: &str,
        plotted: DualPlotted,
        dash: Dash,
        label: bool,
    ) -> Result<Vec<Series>, ConsumerError> {
        let (v, ca) = (self.v, self.colour_axis);
        let ch = v.ch(name)?;
        Ok((0..v.len(ca))
            .map(|c| {
                let mut k = self.idx.clone();
                k[ca] = c;
                let cc = v.coord(ca, c);
                let rgb = ["R", "G", "B"].get(cc.round() as usize).unwrap_or(&"?");
                series(
                    if label {
                        rgb.to_string()
                    } else {
                        String::new()
                    },
                    rgb_colour(cc),
                    dash,
                    v.line(&k, self.theta_axis, ch)
                        .into_iter()
                        .map(|(x, y)| (x, plotted.apply(y)))
                        .collect(),
                )
            })
            .collect())
    }

    /// The curves of several channels, told apart by line style (solid, dashed, dotted).
    fn group(&self, names: &[(&str, DualPlotted)]) -> Result<Vec<Series>, ConsumerError> {
        let dashes = [Dash::Solid, Dash::Dashed, Dash::Dotted];
        let mut s = Vec::new();
        for (k, &(name, plotted)) in names.iter().enumerate() {
            s.extend(self.curves(name, plotted, dashes[k % 3], k == 0)?);
        }
        Ok(s)
    }
}

/// `hair-dual/1` per colour: the Dual Scattering quantities vs θ, one curve per RGB channel
/// (line style = which quantity; the legend names the colours once per panel).
fn hair_dual_colour(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let mut rgb = RgbCurves {
        v,
        colour_axis: v.ax("colour_channel")?,
        theta_axis: v.ax("theta")?,
        idx: vec![0; v.t.axes().len()],
    };
    let mut slice = String::new();
    if let Ok(r) = v.ax("roughness") {
        rgb.idx[r] = v.mid(r);
        slice = format!(", {}", v.at_text(r, rgb.idx[r], "roughness"));
    }
    let xl = v.axis_label(rgb.theta_axis, "θ_i (light inclination)");
    let panels = HAIR_DUAL_PANELS
        .iter()
        .map(|p| {
            Ok(lines_at(
                p.title.into(),
                xl.clone(),
                p.y_label.into(),
                rgb.group(p.channels)?,
                false,
                if p.upper_middle {
                    Legend::UpperMiddle
                } else {
                    Legend::UpperRight
                },
            ))
        })
        .collect::<Result<Vec<Panel>, ConsumerError>>()?;
    Ok(vec![(
        "curves",
        Figure {
            title: v.title(&format!(
                "Dual Scattering averages vs light inclination, RGB channels{slice}"
            )),
            cols: 3,
            size: (1650, 900),
            panels,
        },
    )])
}

/// `hair-dual/1` LUT over roughness × absorption_u × theta: ā_f and ā_b maps.
fn hair_dual_lut(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let (ra, ua, ta) = (v.ax("roughness")?, v.ax("absorption_u")?, v.ax("theta")?);
    let rs = spread(&(0..v.len(ra)).collect::<Vec<_>>(), 3);
    let mut grids = Vec::new();
    for name in ["a_f", "a_b"] {
        let ch = v.ch(name)?;
        for &r in &rs {
            let mut idx = vec![0; 3];
            idx[ra] = r;
            grids.push((name, r, v.grid(&idx, ta, ua, ch)));
        }
    }
    let (lo, hi) = super::figure::range_of(grids.iter().flat_map(|g| g.2.2.iter().copied()));
    let scale = ColourScale::linear(lo, hi);
    let panels = grids
        .into_iter()
        .map(|(name, r, g)| {
            let shown = name;
            heat(
                format!("{shown}, {}", v.at_text(ra, r, "roughness")),
                v.axis_label(ta, "θ_i"),
                v.axis_label(ua, "absorption u = 1 − exp(−2σ_a)"),
                g,
                Scale::Fixed(scale),
                shown.into(),
            )
        })
        .collect();
    Ok(vec![(
        "lut",
        Figure {
            title: v.title("Dual Scattering LUT: forward (top) and backward (bottom) attenuation"),
            cols: rs.len(),
            size: (520 * rs.len() as u32, 800),
            panels,
        },
    )])
}

/// `hair-dual/1`: per-colour curves or the LUT maps, by the table's axes.
pub fn hair_dual(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    if v.ax("colour_channel").is_ok() {
        hair_dual_colour(v)
    } else if v.ax("absorption_u").is_ok() && v.ax("roughness").is_ok() {
        hair_dual_lut(v)
    } else {
        Err(ConsumerError::layout(
            "hair-dual table with neither a colour_channel nor an absorption_u axis",
        ))
    }
}

/// `hair-azimuthal/1`: N_p vs φ at θ = 0 for a few absorptions, and φ × θ maps.
pub fn hair_azimuthal(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let (ua, ta, pa) = (v.ax("absorption_u")?, v.ax("theta")?, v.ax("phi")?);
    let lobes = [("R", PALETTE[0]), ("TT", PALETTE[1]), ("TRT", PALETTE[2])];
    let t0 = v.nearest(ta, 0.0);
    let us = spread(&(0..v.len(ua)).collect::<Vec<_>>(), 4);
    let xl = v.axis_label(pa, "φ (0 = back toward the light)");
    let mut panels = Vec::new();
    for &u in &us {
        let mut idx = vec![0; 3];
        idx[ua] = u;
        idx[ta] = t0;
        let mut s = Vec::new();
        for (name, col) in lobes {
            s.push(series(
                format!("N_{name}"),
                col,
                Dash::Solid,
                v.line(&idx, pa, v.ch(name)?),
            ));
        }
        s.push(series(
            "sum".into(),
            RGBColor(0, 0, 0),
            Dash::Dotted,
            v.line(&idx, pa, v.ch("sum")?),
        ));
        panels.push(lines_at(
            format!(
                "{}, {}",
                v.at_text(ua, u, "absorption u"),
                v.at_text(ta, t0, "θ_d")
            ),
            xl.clone(),
            "N_p (1/rad)".into(),
            s,
            true,
            Legend::UpperMiddle,
        ));
    }
    let curves = Figure {
        title: v.title("azimuthal scattering functions N_R, N_TT, N_TRT"),
        cols: 2,
        size: (1400, 900),
        panels,
    };
    let u1 = v.nearest(ua, 0.2);
    let mut idx = vec![0; 3];
    idx[ua] = u1;
    let map = Figure {
        title: v.title(&format!(
            "N_p over φ × θ_d, {}",
            v.at_text(ua, u1, "absorption u")
        )),
        cols: 3,
        size: (1650, 520),
        panels: lobes
            .iter()
            .map(|&(name, _)| {
                Ok(heat(
                    format!("N_{name}"),
                    xl.clone(),
                    v.axis_label(ta, "θ_d"),
                    v.grid(&idx, pa, ta, v.ch(name)?),
                    Scale::Auto,
                    format!("N_{name} (1/rad)"),
                ))
            })
            .collect::<Result<_, ConsumerError>>()?,
    };
    Ok(vec![("lobes", curves), ("map", map)])
}

/// `water-index/1`: n vs wavelength per temperature, and the difference to the middle one.
pub fn water_index(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let (ta, wa) = (v.ax("temperature")?, v.ax("wavelength")?);
    let n = v.ch("n")?;
    let nt = v.len(ta);
    let tref = v.nearest(ta, 20.0);
    let reference = {
        let mut i = vec![0; 2];
        i[ta] = tref;
        v.line(&i, wa, n)
    };
    let colour = |k: usize| {
        let t = if nt > 1 {
            k as f64 / (nt - 1) as f64
        } else {
            0.0
        };
        let l = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
        RGBColor(l(30.0, 215.0), l(70.0, 40.0), l(210.0, 30.0))
    };
    let temp = |k: usize| {
        let u = &v.t.axes()[ta].unit;
        let u = if u == "degC" { "°C" } else { u.as_str() };
        format!("{} {u}", short_number(v.coord(ta, k)))
    };
    let mut abs = Vec::new();
    let mut diff = Vec::new();
    for k in 0..nt {
        let mut i = vec![0; 2];
        i[ta] = k;
        let l = v.line(&i, wa, n);
        diff.push(series(
            temp(k),
            colour(k),
            Dash::Solid,
            l.iter()
                .zip(&reference)
                .map(|(a, b)| (a.0, (a.1 - b.1) * 1e3))
                .collect(),
        ));
        abs.push(series(temp(k), colour(k), Dash::Solid, l));
    }
    let xl = v.axis_label(wa, "vacuum wavelength");
    Ok(vec![(
        "line",
        Figure {
            title: v.title("refractive index of liquid water"),
            cols: 2,
            size: (1400, 600),
            panels: vec![
                lines(
                    "n vs wavelength, one curve per temperature".into(),
                    xl.clone(),
                    "n (1)".into(),
                    abs,
                    false,
                ),
                lines(
                    format!("n(T) − n({}) (× 10⁻³)", temp(tref)),
                    xl,
                    "Δn × 1000".into(),
                    diff,
                    false,
                ),
            ],
        },
    )])
}

#[cfg(test)]
mod tests {
    /// A staging directory of a process that no longer exists is removed; this process's own,
    /// and a symbolic link named like one, are kept.
    #[test]
    fn orphan_staging_directories_are_removed() {
        let d = tempfile::tempdir().unwrap();
        // Above the kernel's pid limit (2^22): no such process.
        let dead = d
            .path()
            .join(format!("{}abc123", super::staging_prefix(4_000_000_000)));
        let alive = d.path().join(format!(
            "{}def456",
            super::staging_prefix(std::process::id())
        ));
        for dir in [&dead, &alive] {
            std::fs::create_dir(dir).unwrap();
            std::fs::write(dir.join("x-phase.png"), b"png").unwrap();
        }
        let outside = tempfile::tempdir().unwrap();
        let link = d
            .path()
            .join(format!("{}link", super::staging_prefix(4_000_000_001)));
        #[cfg(unix)]
        std::os::unix::fs::symlink(outside.path(), &link).unwrap();
        std::fs::write(outside.path().join("keep"), b"").unwrap();
        super::remove_orphan_staging(d.path());
        assert!(!dead.exists());
        assert!(alive.join("x-phase.png").exists());
        assert!(outside.path().join("keep").exists());
    }

    use super::*;
    use crate::table::{Axis, Channel, Provenance, Schema, TableContent, write_table_atomic};

    /// A small table shaped like `fur-medulla-azimuthal/1` whose σ = 0 slice is all zeros and
    /// whose |h| = 1 rows are zeros (nothing enters), as in the real tables: energy
    /// 1 − exp(−2σ√(1−h²)) spread over φ with a forward peak that grows with h and g.
    fn medulla_like() -> Table {
        let sigma = vec![0.0, 1.0, 2.0, 4.0];
        let g = vec![0.0, 0.4, 0.8];
        let h: Vec<f64> = (0..9).map(|i| -1.0 + 0.25 * i as f64).collect();
        let nphi = 72;
        let mut data = Vec::new();
        for &s in &sigma {
            for &gg in &g {
                for &hh in &h {
                    let total = 1.0 - (-2.0 * s * (1.0 - hh * hh).max(0.0).sqrt()).exp();
                    let shape: Vec<f64> = (0..nphi)
                        .map(|k| {
                            let phi = (-177.5 + 5.0 * k as f64).to_radians();
                            1.0 + (gg + 0.5 * hh.abs()) * (phi - hh).cos()
                        })
                        .collect();
                    let norm: f64 = shape.iter().sum();
                    for v in shape {
                        let e = total * v / norm;
                        data.extend_from_slice(&[e as f32, (s * (1.0 + v)) as f32, 0.0]);
                    }
                }
            }
        }
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new("fur-medulla-azimuthal", 1),
            description: "test".into(),
            axes: vec![
                Axis::values("sigma", "1/medulla_radius", sigma),
                Axis::values("g", "1", g),
                Axis::values("h", "1", h),
                Axis::uniform("phi", "deg", -177.5, 5.0, nphi),
            ],
            channels: vec![
                Channel::new("energy", "1", "e"),
                Channel::new("path_length", "medulla_radius", "l"),
                Channel::new("std_error", "1", "s"),
            ],
            attributes: serde_json::Map::new(),
            data,
        };
        Table::from_content(content, Provenance::default()).unwrap()
    }

    fn non_constant(p: &[(f64, f64)]) -> bool {
        let (lo, hi) = super::super::figure::range_of(p.iter().map(|q| q.1));
        hi > lo
    }

    /// The medulla previews never show the empty σ = 0 slice: every heatmap varies, every line
    /// panel has a varying curve, and no title names σ = 0 (the old default — first sample of
    /// every axis — drew σ = 0, all zeros).
    #[test]
    fn medulla_previews_pick_non_trivial_slices() {
        let t = medulla_like();
        let figs = medulla_azimuthal(&View::new(&t, "m")).unwrap();
        assert_eq!(figs.len(), 2);
        for (_, f) in &figs {
            assert!(!f.title.contains("σ = 0,"), "{}", f.title);
            for p in &f.panels {
                match p {
                    Panel::Heat(h) => {
                        let (lo, hi) = h.range();
                        assert!(hi > lo, "constant heatmap {}", h.title);
                        assert!(!h.title.contains("σ = 0,"), "{}", h.title);
                    }
                    Panel::Lines(l) => {
                        assert!(!l.series.is_empty());
                        assert!(
                            l.series.iter().any(|s| non_constant(&s.points)),
                            "all curves constant in {}",
                            l.title
                        );
                        // Every energy curve of the several-h' panel carries energy (no |h| = 1).
                        if l.title.starts_with("energy vs φ' for several h'") {
                            for s in &l.series {
                                assert!(s.points.iter().any(|q| q.1 > 0.0), "{}", s.label);
                            }
                        }
                    }
                }
            }
        }
    }

    /// `previews()` on the file writes the family's figures, and each picture has varied
    /// content inside its heatmaps (not one flat colour).
    #[test]
    fn medulla_preview_files_are_written_and_not_flat() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("med.sbt");
        write_table_atomic(&mut medulla_like(), &path).unwrap();
        let out = dir.path().join("prev");
        let written = super::previews(&path, &out).unwrap();
        assert_eq!(
            written,
            vec![out.join("med-profiles.png"), out.join("med-map.png")]
        );
        let figs = medulla_azimuthal(&View::new(&Table::open(&path).unwrap(), "med")).unwrap();
        let (buf, rects) = super::super::figure::render_rgb(&figs[1].1).unwrap();
        assert_eq!(rects.len(), 2);
        let w = figs[1].1.size.0 as usize;
        for (xr, yr) in rects {
            let mut colours = std::collections::HashSet::new();
            for y in yr.clone() {
                for x in xr.clone() {
                    let o = (y as usize * w + x as usize) * 3;
                    colours.insert((buf[o], buf[o + 1], buf[o + 2]));
                }
            }
            assert!(colours.len() > 20, "{} colours", colours.len());
        }
        for p in written {
            assert!(std::fs::metadata(p).unwrap().len() > 10_000);
        }
    }

    #[test]
    fn spread_keeps_ends() {
        assert_eq!(spread(&[1, 2, 3, 4, 5, 6, 7, 8, 9], 5), vec![1, 3, 5, 7, 9]);
        assert_eq!(spread(&[1, 2], 5), vec![1, 2]);
    }
}
