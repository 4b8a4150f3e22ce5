//! The browsable catalog `DIR/index.html`: one static page, no server, no network, listing every
//! table of a directory's catalog with its description, schema, axes, channels, size, checksum,
//! provenance, the accuracy its header states, its preview pictures, the files exported beside
//! it, and an interactive plot of one of its curves (data embedded in the page as JSON, drawn as
//! SVG by a small script in the page itself).
//!
//! **Which curve.** The plotted axis is `scattering_angle` or `outgoing_polar` when the table has
//! one, otherwise its longest axis; curves are drawn per `wavelength` (up to
//! [`MAX_SERIES`] wavelengths, spread over the axis) when that is not the plotted axis; the
//! first other axis longer than one sample is offered as a choice of entries (up to
//! [`MAX_ENTRIES`] samples, spread over it; the middle one is shown first), and every remaining
//! axis is held at its middle sample, as the previews do. The page names every held coordinate. Each curve keeps at most
//! [`MAX_POINTS`] points: the smallest and the largest value of each of `MAX_POINTS / 2` equal
//! runs of samples, so narrow peaks (forward lobe, glory, bows) stay visible.
//!
//! **Bounded work.** Headers are read for every table ([`crate::table::read_header_only`]); a
//! table's samples are read only when its payload is at most
//! [`PageOptions::max_plot_payload_bytes`] (default 256 MiB), and the page says why a larger
//! table has no plot. Every text from a table or a file name is HTML-escaped, file names in
//! links are percent-encoded, and the embedded JSON cannot close its `<script>` element. The page
//! is written atomically ([`crate::table::format::write_atomic`]).
//!
//! **Checkable.** The page's script sets `data-rendered` on `<body>` to the number of plots it
//! drew, counts script errors in `data-errors` and, once the page has loaded, the pictures that
//! did not load in `data-broken-images`, so a headless browser can check that the page loads
//! without errors, draws every plot and shows every picture.

use super::ConsumerError;
use crate::catalog::{Catalog, CatalogEntry};
use crate::error::IoError;
use crate::table::{Axis, Header, Table};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Largest number of points of one plotted curve.
pub const MAX_POINTS: usize = 512;
/// Largest number of curves (wavelengths) per entry.
pub const MAX_SERIES: usize = 4;
/// Largest number of entries offered per table.
pub const MAX_ENTRIES: usize = 8;
/// Default of [`PageOptions::max_plot_payload_bytes`]: 256 MiB.
pub const DEFAULT_MAX_PLOT_PAYLOAD_BYTES: u64 = 256 << 20;

/// Options of the catalog page.
#[derive(Debug, Clone)]
pub struct PageOptions {
    /// A table whose uncompressed payload is larger is listed without a plot.
    pub max_plot_payload_bytes: u64,
}

impl Default for PageOptions {
    fn default() -> Self {
        PageOptions {
            max_plot_payload_bytes: DEFAULT_MAX_PLOT_PAYLOAD_BYTES,
        }
    }
}

/// What the page holds.
#[derive(Debug, Clone, PartialEq)]
pub struct PageReport {
    /// The page written, `DIR/index.html`.
    pub path: PathBuf,
    /// Tables listed.
    pub tables: usize,
    /// Tables with a plot.
    pub plotted: usize,
    /// Tables listed without a plot, with the reason.
    pub not_plotted: Vec<(String, String)>,
}

/// Write `dir/index.html` for `catalog` (the catalog of `dir`).
pub fn write_catalog_page(
    dir: &Path,
    catalog: &Catalog,
    opts: &PageOptions,
) -> Result<PageReport, ConsumerError> {
    let files = FilesBeside::list(dir)?;
    let names: Vec<&str> = catalog.tables.iter().map(|t| t.name.as_str()).collect();
    let mut sections = String::new();
    let mut plots = Vec::new();
    let mut not_plotted = Vec::new();
    for (k, entry) in catalog.tables.iter().enumerate() {
        let path = dir.join(&entry.file);
        let header = crate::table::read_header_only(&path)?;
        let own = files.of(&entry.name, &names);
        match plot_data(&path, &header, opts) {
            Ok(p) => {
                plots.push(p);
                table_section(&mut sections, k, entry, &header, &own, None);
            }
            Err(why) => {
                plots.push(Value::Null);
                table_section(&mut sections, k, entry, &header, &own, Some(&why));
                not_plotted.push((entry.name.clone(), why));
            }
        }
    }
    let html = page(catalog, &sections, &Value::Array(plots));
    let path = dir.join("index.html");
    crate::table::format::write_atomic(&path, html.as_bytes())
        .map_err(IoError::doing("writing", &path))?;
    Ok(PageReport {
        path,
        tables: catalog.tables.len(),
        plotted: catalog.tables.len() - not_plotted.len(),
        not_plotted,
    })
}

/// Preview pictures (`previews/`) and exported files (`DIR` itself and `exports/`) of a
/// directory, by file name.
struct FilesBeside {
    previews: Vec<String>,
    exports: Vec<String>,
}

impl FilesBeside {
    fn list(dir: &Path) -> Result<Self, ConsumerError> {
        let names_in = |d: &Path, prefix: &str| -> Result<Vec<String>, ConsumerError> {
            let mut v = Vec::new();
            let rd = match std::fs::read_dir(d) {
                Ok(rd) => rd,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(v),
                Err(e) => return Err(IoError::doing("listing", d)(e).into()),
            };
            for f in rd.flatten() {
                let is_file = f.file_type().is_ok_and(|t| t.is_file());
                if let (true, Some(n)) = (is_file, f.file_name().to_str()) {
                    v.push(format!("{prefix}{n}"));
                }
            }
            v.sort();
            Ok(v)
        };
        let previews = names_in(&dir.join("previews"), "previews/")?
            .into_iter()
            .filter(|n| n.ends_with(".png") || n.ends_with(".svg"))
            .collect();
        let mut exports: Vec<String> = names_in(dir, "")?
            .into_iter()
            .filter(|n| {
                !n.starts_with('.')
                    && !n.ends_with(".sbt")
                    && !n.starts_with("index.")
                    && !n.ends_with(".tmp")
            })
            .collect();
        exports.extend(names_in(&dir.join("exports"), "exports/")?);
        Ok(FilesBeside { previews, exports })
    }

    /// Previews and exports of table `name`: files whose name (after the folder) starts with
    /// `name` followed by `-` or `.`, unless a longer table name also matches (the table
    /// `fur-farfield` does not take the files of `fur-farfield-kappa-half`).
    fn of(&self, name: &str, all: &[&str]) -> (Vec<String>, Vec<String>) {
        let owner = |file: &str| -> Option<usize> {
            let base = file.rsplit('/').next().unwrap_or(file);
            all.iter()
                .filter(|t| {
                    base.strip_prefix(**t)
                        .is_some_and(|rest| rest.starts_with('-') || rest.starts_with('.'))
                })
                .map(|t| t.len())
                .max()
        };
        let mine = |files: &[String]| -> Vec<String> {
            files
                .iter()
                .filter(|f| {
                    let base = f.rsplit('/').next().unwrap_or(f);
                    base.starts_with(name) && owner(f) == Some(name.len())
                })
                .cloned()
                .collect()
        };
        (mine(&self.previews), mine(&self.exports))
    }
}

/// The curves of a table as embedded in the page ([`curves`]), or why it has none.
fn plot_data(path: &Path, header: &Header, opts: &PageOptions) -> Result<Value, String> {
    if header.payload.uncompressed_bytes > opts.max_plot_payload_bytes {
        return Err(format!(
            "not plotted: its payload of {} exceeds the page's limit of {} (plot it with \
             `scatterbake plot`)",
            bytes(header.payload.uncompressed_bytes),
            bytes(opts.max_plot_payload_bytes)
        ));
    }
    let table = Table::open(path).map_err(|e| format!("not plotted: {e}"))?;
    Ok(curves(&table))
}

/// Which axis plays which part in the plot.
struct PlotAxes {
    x: usize,
    series: Option<usize>,
    entry: Option<usize>,
}

fn plot_axes(axes: &[Axis]) -> PlotAxes {
    let x = axes
        .iter()
        .position(|a| a.name == "scattering_angle" || a.name == "outgoing_polar")
        .unwrap_or_else(|| {
            (0..axes.len())
                .rev()
                .max_by_key(|&i| axes[i].len())
                .unwrap_or(0)
        });
    let series = axes
        .iter()
        .position(|a| a.name == "wavelength")
        .filter(|&i| i != x && axes[i].len() > 1);
    let entry = (0..axes.len()).find(|&i| i != x && Some(i) != series && axes[i].len() > 1);
    PlotAxes { x, series, entry }
}

/// Up to `max` indices spread evenly over `0..len` (all of them when `len <= max`).
fn spread(len: usize, max: usize) -> Vec<usize> {
    if len <= max {
        return (0..len).collect();
    }
    let mut v: Vec<usize> = (0..max)
        .map(|k| (k as f64 * (len - 1) as f64 / (max - 1) as f64).round() as usize)
        .collect();
    v.dedup();
    v
}

/// `name = value unit` of sample `i` of an axis (its label when it has one).
fn coordinate_text(a: &Axis, i: usize) -> String {
    match a.label(i) {
        Some(l) => format!("{} = {l}", a.name),
        None => format!("{} = {} {}", a.name, short(a.coord(i)), a.unit),
    }
}

/// The page's data for one table: the plotted axis, the channels, the entries offered and per
/// entry the curves (per wavelength) of every channel.
fn curves(table: &Table) -> Value {
    let axes = table.axes();
    let pa = plot_axes(axes);
    let xa = &axes[pa.x];
    let held: Vec<String> = (0..axes.len())
        .filter(|&i| i != pa.x && Some(i) != pa.series && Some(i) != pa.entry)
        .filter(|&i| axes[i].len() > 1)
        .map(|i| coordinate_text(&axes[i], axes[i].len() / 2))
        .collect();
    let mut idx: Vec<usize> = axes.iter().map(|a| a.len() / 2).collect();
    let xs: Vec<f64> = xa.coords();
    let kept = decimation(xs.len());
    let entries: Vec<Value> = pa
        .entry
        .map(|e| spread(axes[e].len(), MAX_ENTRIES))
        .unwrap_or_else(|| vec![usize::MAX])
        .into_iter()
        .map(|ei| {
            let label = match pa.entry {
                Some(e) => {
                    idx[e] = ei;
                    coordinate_text(&axes[e], ei)
                }
                None => String::new(),
            };
            let series = entry_series(table, &pa, &mut idx, &kept);
            json!({"label": label, "series": series})
        })
        .collect();
    json!({
        "x": {"name": xa.name, "unit": xa.unit, "values": kept.iter().map(|&i| rounded(xs[i])).collect::<Vec<_>>()},
        "channels": table.header.channels.iter().map(|c| json!({"name": c.name, "unit": c.unit})).collect::<Vec<_>>(),
        "held": held,
        "entries": entries,
    })
}

/// The curves of one entry: per wavelength (or one), per channel, the kept samples.
fn entry_series(table: &Table, pa: &PlotAxes, idx: &mut [usize], kept: &[usize]) -> Vec<Value> {
    let axes = table.axes();
    let series_idx = pa
        .series
        .map(|s| spread(axes[s].len(), MAX_SERIES))
        .unwrap_or_else(|| vec![usize::MAX]);
    let channels = table.header.channels.len();
    series_idx
        .into_iter()
        .map(|si| {
            let label = match pa.series {
                Some(s) => {
                    idx[s] = si;
                    coordinate_text(&axes[s], si)
                }
                None => String::new(),
            };
            let values: Vec<Vec<Value>> = (0..channels)
                .map(|c| {
                    kept.iter()
                        .map(|&xi| {
                            idx[pa.x] = xi;
                            number(table.at(idx, c))
                        })
                        .collect()
                })
                .collect();
            json!({"label": label, "values": values})
        })
        .collect()
}

/// Indices of the samples kept of an axis of `len` samples: all when `len <= MAX_POINTS`,
/// otherwise `MAX_POINTS` samples spread evenly (first and last included).
fn decimation(len: usize) -> Vec<usize> {
    spread(len, MAX_POINTS)
}

/// A finite f32 as a JSON number with 6 significant digits; NaN and ±inf as null (a gap).
fn number(v: f32) -> Value {
    if v.is_finite() {
        rounded(v as f64)
    } else {
        Value::Null
    }
}

/// `v` rounded to 6 significant digits (keeps the page small).
fn rounded(v: f64) -> Value {
    let s = format!("{v:.5e}");
    s.parse::<f64>()
        .ok()
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

fn short(v: f64) -> String {
    let s = format!("{v}");
    if s.len() <= 10 { s } else { format!("{v:.6}") }
}

fn bytes(n: u64) -> String {
    match n {
        n if n >= 1 << 30 => format!("{:.2} GiB", n as f64 / (1u64 << 30) as f64),
        n if n >= 1 << 20 => format!("{:.1} MiB", n as f64 / (1u64 << 20) as f64),
        n if n >= 1 << 10 => format!("{:.1} KiB", n as f64 / 1024.0),
        n => format!("{n} B"),
    }
}

/// Text escaped for HTML content and quoted attribute values.
pub fn escape_html(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c if c.is_control() && c != '\n' && c != '\t' => {
                let _ = write!(o, "\\u{{{:x}}}", c as u32);
            }
            c => o.push(c),
        }
    }
    o
}

/// A relative file path as a URL path: every byte outside the unreserved set (and `/`)
/// percent-encoded.
fn url_path(p: &str) -> String {
    let mut o = String::new();
    for b in p.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            o.push(b as char);
        } else {
            let _ = write!(o, "%{b:02X}");
        }
    }
    o
}

/// Attributes that state an accuracy: names with `error`, `accuracy`, `validated`,
/// `tolerance` or `uncertainty`.
fn stated_accuracy(h: &Header) -> Vec<(String, String)> {
    h.attributes
        .iter()
        .filter(|(k, _)| {
            ["error", "accuracy", "validated", "tolerance", "uncertainty"]
                .iter()
                .any(|w| k.contains(w))
        })
        .map(|(k, v)| (k.clone(), value_text(v)))
        .collect()
}

/// A header value as text: strings as they are, other values as compact JSON, cut at 600
/// characters.
fn value_text(v: &Value) -> String {
    let s = match v {
        Value::String(s) => s.clone(),
        v => v.to_string(),
    };
    if s.chars().count() > 600 {
        format!("{}…", s.chars().take(600).collect::<String>())
    } else {
        s
    }
}

fn axis_text(a: &Axis) -> String {
    let n = a.len();
    let range = if n == 0 {
        String::new()
    } else if a.labels.is_empty() {
        format!(
            "{} … {} {}",
            short(a.coord(0)),
            short(a.coord(n - 1)),
            a.unit
        )
    } else {
        format!("{} … {}", a.labels[0], a.labels[n - 1])
    };
    format!("{} ({n}): {range}", a.name)
}

/// The `<section>` of table `k`.
fn table_section(
    out: &mut String,
    k: usize,
    e: &CatalogEntry,
    h: &Header,
    (previews, exports): &(Vec<String>, Vec<String>),
    no_plot: Option<&str>,
) {
    let esc = escape_html;
    let _ = write!(
        out,
        "<section class=\"table\" id=\"t{k}\" data-name=\"{}\" data-schema=\"{}\">\n<h2>{}</h2>\n<p class=\"desc\">{}</p>\n<dl>\n",
        esc(&e.name),
        esc(&e.schema),
        esc(&e.name),
        esc(&e.description)
    );
    let mut row = |dt: &str, dd: String| {
        let _ = writeln!(out, "<dt>{dt}</dt><dd>{dd}</dd>");
    };
    row(
        "file",
        format!(
            "<a href=\"{}\">{}</a> ({}, format {})",
            url_path(&e.file),
            esc(&e.file),
            bytes(e.size_bytes),
            esc(&e.format_version)
        ),
    );
    row("schema", format!("<code>{}</code>", esc(&e.schema)));
    row(
        "axes",
        h.axes
            .iter()
            .map(|a| esc(&axis_text(a)))
            .collect::<Vec<_>>()
            .join("<br>"),
    );
    row(
        "channels",
        h.channels
            .iter()
            .map(|c| format!("<code>{}</code> ({})", esc(&c.name), esc(&c.unit)))
            .collect::<Vec<_>>()
            .join(", "),
    );
    let origin = [("manifest", &e.manifest), ("stage", &e.stage)]
        .iter()
        .filter_map(|(k, v)| v.as_ref().map(|v| format!("{k} <code>{}</code>", esc(v))))
        .chain([format!("created {}", esc(&e.created_utc))])
        .chain(
            h.provenance
                .git_commit
                .as_ref()
                .map(|c| format!("commit <code>{}</code>", esc(c))),
        )
        .collect::<Vec<_>>()
        .join(", ");
    row("provenance", origin);
    row("SHA-256", format!("<code>{}</code>", esc(&e.sha256)));
    let acc = stated_accuracy(h);
    if !acc.is_empty() {
        row(
            "stated accuracy",
            acc.iter()
                .map(|(k, v)| format!("<code>{}</code>: {}", esc(k), esc(v)))
                .collect::<Vec<_>>()
                .join("<br>"),
        );
    }
    if !exports.is_empty() {
        row("exports", links(exports));
    }
    out.push_str("</dl>\n");
    match no_plot {
        Some(why) => {
            let _ = writeln!(out, "<p class=\"noplot\">{}</p>", esc(why));
        }
        None => {
            let _ = writeln!(out, "<div class=\"plot\" data-table=\"{k}\"></div>");
        }
    }
    for p in previews {
        let _ = writeln!(
            out,
            "<a href=\"{0}\"><img class=\"preview\" src=\"{0}\" alt=\"{1}\"></a>",
            url_path(p),
            esc(p)
        );
    }
    let _ = writeln!(
        out,
        "<details><summary>all header attributes</summary><pre>{}</pre></details>\n</section>",
        esc(&serde_json::to_string_pretty(&h.attributes).unwrap_or_default())
    );
}

fn links(files: &[String]) -> String {
    files
        .iter()
        .map(|f| format!("<a href=\"{}\">{}</a>", url_path(f), escape_html(f)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// JSON that can sit inside a `<script>` element: `<`, `>` and `&` as `\u` escapes (which
/// JSON reads back unchanged), so no `</script>` or `<!--` can appear.
fn script_json(v: &Value) -> String {
    let s = v.to_string();
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '<' => o.push_str("\\u003c"),
            '>' => o.push_str("\\u003e"),
            '&' => o.push_str("\\u0026"),
            '\u{2028}' => o.push_str("\\u2028"),
            '\u{2029}' => o.push_str("\\u2029"),
            c => o.push(c),
        }
    }
    o
}

/// The whole page.
fn page(catalog: &Catalog, sections: &str, plots: &Value) -> String {
    let mut toc = String::new();
    for (k, t) in catalog.tables.iter().enumerate() {
        let _ = write!(
            toc,
            "<li><a href=\"#t{k}\">{}</a> <span class=\"schema\">{}</span></li>",
            escape_html(&t.name),
            escape_html(&t.schema)
        );
    }
    let invalid: String = catalog
        .invalid
        .iter()
        .map(|(f, why)| format!("<li>{}: {}</li>", escape_html(f), escape_html(why)))
        .collect();
    let invalid = if invalid.is_empty() {
        String::new()
    } else {
        format!("<h2>Files that are not valid tables</h2><ul class=\"invalid\">{invalid}</ul>")
    };
    fill(
        include_str!("catalog_page.html"),
        &[
            ("@COUNT@", &catalog.tables.len().to_string()),
            ("@TOC@", &toc),
            ("@INVALID@", &invalid),
            ("@SECTIONS@", sections),
            ("@DATA@", &script_json(plots)),
            ("@SCRIPT@", include_str!("catalog_page.js")),
        ],
    )
}

/// `template` with each marker replaced by its value, markers looked for in the template only
/// (a value that happens to contain a marker is not expanded).
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let mut out = String::with_capacity(template.len());
    let mut rest = template;
    while let Some((at, marker, value)) = values
        .iter()
        .filter_map(|(m, v)| rest.find(m).map(|i| (i, *m, *v)))
        .min_by_key(|(i, _, _)| *i)
    {
        out.push_str(&rest[..at]);
        out.push_str(value);
        rest = &rest[at + marker.len()..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Provenance, TableContent, write_table_atomic};

    fn write(dir: &Path, file: &str, mut t: Table) {
        write_table_atomic(&mut t, &dir.join(file)).unwrap();
    }

    /// A one-axis table named by `description`.
    fn line_table(description: &str, n: usize) -> Table {
        let content = TableContent {
            encoding: Default::default(),
            schema: crate::table::Schema::new("line", 1),
            description: description.into(),
            axes: vec![Axis::uniform("x", "1", 0.0, 1.0, n)],
            channels: vec![crate::table::Channel::new("y", "1", "x squared")],
            attributes: [("interpolation_error_max".to_string(), json!(0.01))]
                .into_iter()
                .collect(),
            data: (0..n).map(|i| (i * i) as f32).collect(),
        };
        Table::from_content(content, Provenance::default()).unwrap()
    }

    fn embedded(html: &str) -> Value {
        let start = html.find("id=\"plot-data\">").unwrap() + "id=\"plot-data\">".len();
        let end = start + html[start..].find("</script>").unwrap();
        serde_json::from_str(&html[start..end]).unwrap()
    }

    #[test]
    fn the_page_lists_every_table_with_its_curve_previews_and_exports() {
        let dir = tempfile::tempdir().unwrap();
        let hg = crate::fixtures::henyey_greenstein_table(
            &[450.0, 550.0, 650.0],
            &[1.0, 2.0],
            |k, r| 0.2 + 0.1 * (k + 3 * r) as f64,
            1801,
            0.3,
        );
        write(dir.path(), "hg.sbt", hg);
        write(dir.path(), "hg-wide.sbt", line_table("second", 5));
        std::fs::create_dir_all(dir.path().join("previews")).unwrap();
        for f in [
            "previews/hg-phase.png",
            "previews/hg-wide-line.png",
            "hg.csv",
        ] {
            std::fs::write(dir.path().join(f), b"x").unwrap();
        }
        let catalog = crate::catalog::rebuild(dir.path()).unwrap();
        let r = write_catalog_page(dir.path(), &catalog, &PageOptions::default()).unwrap();
        assert_eq!((r.tables, r.plotted), (2, 2));
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        let hg = &html[html.find("data-name=\"hg\"").unwrap()..];
        let hg = &hg[..hg.find("</section>").unwrap()];
        // its own preview and export, not those of `hg-wide`
        assert!(
            hg.contains("previews/hg-phase.png") && hg.contains("hg.csv"),
            "{hg}"
        );
        assert!(!hg.contains("hg-wide-line.png"), "{hg}");
        assert!(html.contains("interpolation_error_max"));
        let data = embedded(&html);
        let d = &data[0];
        let wide = if d["x"]["name"] == "x" { 0 } else { 1 };
        let hgd = &data[1 - wide];
        assert_eq!(hgd["x"]["name"], "scattering_angle");
        assert_eq!(hgd["x"]["values"].as_array().unwrap().len(), MAX_POINTS);
        assert_eq!(hgd["entries"].as_array().unwrap().len(), 2);
        let series = hgd["entries"][1]["series"].as_array().unwrap();
        assert_eq!(series.len(), 3);
        assert_eq!(series[2]["label"], "wavelength = 650 nm");
        // the values are the table's (HG with g = 0.2 + 0.1 (2 + 3) = 0.7 at 0 deg)
        let g: f64 = 0.7;
        let hg0 = (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 - g).powi(3));
        let got = series[2]["values"][0][0].as_f64().unwrap();
        assert!((got / hg0 - 1.0).abs() < 1e-5, "{got} vs {hg0}");
        assert_eq!(data[wide]["entries"][0]["series"][0]["values"][0][4], 16.0);
    }

    #[test]
    fn names_and_texts_from_files_cannot_inject_markup() {
        let dir = tempfile::tempdir().unwrap();
        let evil = "</script><img src=x onerror=alert(1)>&\u{1b}";
        write(dir.path(), "a<b>&\"'.sbt", line_table(evil, 3));
        let catalog = crate::catalog::rebuild(dir.path()).unwrap();
        write_catalog_page(dir.path(), &catalog, &PageOptions::default()).unwrap();
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        assert!(!html.contains("<img src=x"), "description not escaped");
        assert!(!html.contains("<b>"), "file name not escaped");
        assert!(
            html.contains("a%3Cb%3E%26%22%27.sbt"),
            "link not percent-encoded"
        );
        assert!(!html.contains('\u{1b}'), "control character printed raw");
        // one </script> for each script element, none from the data
        assert_eq!(html.matches("</script>").count(), 2);
        let data = embedded(&html);
        assert_eq!(data[0]["entries"][0]["series"][0]["values"][0][2], 4.0);
    }

    #[test]
    fn a_table_over_the_plot_limit_is_listed_without_a_plot_and_says_why() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "big.sbt", line_table("big", 100));
        let catalog = crate::catalog::rebuild(dir.path()).unwrap();
        let opts = PageOptions {
            max_plot_payload_bytes: 100,
        };
        let r = write_catalog_page(dir.path(), &catalog, &opts).unwrap();
        assert_eq!((r.tables, r.plotted), (1, 0));
        assert!(
            r.not_plotted[0].1.contains("exceeds the page's limit"),
            "{r:?}"
        );
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        assert!(html.contains("class=\"noplot\"") && !html.contains("data-table=\"0\""));
        assert_eq!(embedded(&html), json!([null]));
    }

    #[test]
    fn markers_in_values_are_not_expanded() {
        assert_eq!(
            fill("a@X@b@Y@c", &[("@X@", "@Y@"), ("@Y@", "z")]),
            "a@Y@bzc"
        );
    }
}
