//! Generic exporters for any table: CSV, JSON and OpenEXR.
//!
//! - **CSV**: a header line `axis1 [unit],…,channel1 [unit],…`, then one row per grid point in
//!   storage order (row-major, last axis fastest). Values printed with full f32 precision. CSV
//!   has nowhere to state an axis' symmetry, so an even-periodic axis (format 3.0, e.g. the
//!   `outgoing_azimuth` of a compact ray-traced table, stored over 0°–180°) is written unfolded
//!   over one whole period: its stored points, then the mirrors `P − x` of those strictly
//!   between 0 and `P/2`, ascending ([`csv_axis_rows`]; decision EXP-3). The rows then cover
//!   the directions a dense table of the same entry covers, with the values every reader's
//!   lookup returns there.
//! - **JSON**: `{"header": <the table header>, "rows": [{"<axis>": x, …, "<channel>": v, …}, …]}`,
//!   one row per grid point in storage order.
//! - **EXR**: one scanline image, f32 channels named after the table channels. The LAST table
//!   axis runs along x (width = its length); the other axes are flattened row-major along y
//!   (height = product of their lengths). So a 1-D table is a `n×1` strip, a 2-D table
//!   `(axis0, axis1)` is an image with `y = i0`, `x = i1`, and a 3-D table `(a0, a1, a2)` is a
//!   vertical atlas of `|a0|` slices, each `|a1|` rows tall: pixel `(x, y) = (i2, i0·|a1| + i1)`.
//!   Lookup for a continuous coordinate `c` on a uniform axis `start + k·step`:
//!   `k = (c − start)/step`, texel centre `k + 0.5` in pixel units (clamp to edge). The full table
//!   header (JSON) is stored in the EXR `string` attribute `scatterbake_header` so the file stays
//!   self-describing. Its bytes are the UTF-8 encoding of the JSON text, unchanged (headers hold
//!   β, σ, θ, −, µ, …): OpenEXR defines text as a sequence of bytes and stores them as given.
//!   Decode them as UTF-8 ([`read_exr_header`]); a reader that maps each byte to one character
//!   (Latin-1, like `Display` of the `exr` crate's `Text`) garbles every non-ASCII character
//!   (decision EXP-2 in docs/decisions.md).

use crate::consumers::ConsumerError;
use crate::error::IoError;
use crate::table::format::write_atomic_streamed;
use crate::table::{Axis, Table};
use std::fmt::Write as _;
use std::path::Path;

/// Export formats handled here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GenericFormat {
    Csv,
    Json,
    Exr,
}

fn grid_points(table: &Table) -> impl Iterator<Item = Vec<usize>> {
    row_major(table.grid_shape())
}

/// Every index of a grid of `shape` in row-major order (last axis fastest).
fn row_major(shape: Vec<usize>) -> impl Iterator<Item = Vec<usize>> {
    let total: usize = shape.iter().product();
    (0..total).map(move |mut flat| {
        let mut idx = vec![0; shape.len()];
        for d in (0..shape.len()).rev() {
            idx[d] = flat % shape[d];
            flat /= shape[d];
        }
        idx
    })
}

/// CSV text of a table.
pub fn to_csv(table: &Table) -> String {
    let mut out = Vec::new();
    write_csv(table, &mut out).expect("writing to memory");
    String::from_utf8(out).expect("CSV text is UTF-8")
}

/// The rows of one axis in the CSV, ascending: `(coordinate, stored index)`. An even-periodic
/// axis of period `P` (stored over exactly 0 … P/2) is unfolded onto one period: its stored
/// points, then `P − x` for each stored `x` strictly inside (0, P/2), taking the value stored at
/// `x`. Any other axis gives its stored points.
pub fn csv_axis_rows(axis: &Axis) -> Vec<(f64, usize)> {
    let mut rows: Vec<(f64, usize)> = (0..axis.len()).map(|i| (axis.coord(i), i)).collect();
    if let Some(symmetry) = axis.symmetry {
        let period = symmetry.period();
        let mirrored = (0..axis.len()).rev().filter_map(|i| {
            let x = axis.coord(i);
            (x > 0.0 && x < 0.5 * period).then_some((period - x, i))
        });
        rows.extend(mirrored);
    }
    rows
}

/// Write the CSV of a table to `w`, a row at a time (memory independent of the table's size).
/// Even-periodic axes are unfolded over one period ([`csv_axis_rows`]).
pub fn write_csv(table: &Table, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    let h = &table.header;
    let cols: Vec<String> = h
        .axes
        .iter()
        .map(|a| format!("{} [{}]", a.name, a.unit))
        .chain(
            h.channels
                .iter()
                .map(|c| format!("{} [{}]", c.name, c.unit)),
        )
        .collect();
    writeln!(w, "{}", cols.join(","))?;
    let nc = h.channels.len();
    let axis_rows: Vec<Vec<(f64, usize)>> = h.axes.iter().map(csv_axis_rows).collect();
    let row_shape: Vec<usize> = axis_rows.iter().map(Vec::len).collect();
    let shape = table.grid_shape();
    let mut row = String::new();
    for idx in row_major(row_shape) {
        row.clear();
        let mut flat = 0;
        for (k, (rows, &i)) in axis_rows.iter().zip(&idx).enumerate() {
            let (coord, stored) = rows[i];
            flat = flat * shape[k] + stored;
            let sep = if k == 0 { "" } else { "," };
            let _ = write!(row, "{sep}{coord}");
        }
        for c in 0..nc {
            let _ = write!(row, ",{:e}", table.data[flat * nc + c]);
        }
        row.push('\n');
        w.write_all(row.as_bytes())?;
    }
    Ok(())
}

/// JSON value of a table (header + rows). [`write_json`] writes the same JSON without building
/// it in memory.
pub fn to_json(table: &Table) -> serde_json::Value {
    serde_json::to_value(JsonTable::new(table)).expect("a table serialises to JSON")
}

/// Write the JSON of a table (pretty-printed, as `serde_json::to_writer_pretty(&to_json(t))`)
/// to `w`, a row at a time: memory independent of the table's size.
pub fn write_json(table: &Table, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    serde_json::to_writer_pretty(w, &JsonTable::new(table)).map_err(std::io::Error::other)
}

/// Where a JSON row key takes its value from.
#[derive(Clone, Copy)]
enum RowKey {
    Axis(usize),
    Channel(usize),
}

/// The JSON of a table, serialised lazily: `{"header": …, "rows": [{key: value, …}, …]}` with
/// each row's keys in sorted order (those of a `serde_json::Map`; a channel named like an axis
/// gives the channel's value), non-finite values as `null`.
struct JsonTable<'a> {
    table: &'a Table,
    keys: Vec<(&'a str, RowKey)>,
}

impl<'a> JsonTable<'a> {
    fn new(table: &'a Table) -> Self {
        let h = &table.header;
        let mut keys = std::collections::BTreeMap::new();
        for (i, a) in h.axes.iter().enumerate() {
            keys.insert(a.name.as_str(), RowKey::Axis(i));
        }
        for (c, ch) in h.channels.iter().enumerate() {
            keys.insert(ch.name.as_str(), RowKey::Channel(c));
        }
        JsonTable {
            table,
            keys: keys.into_iter().collect(),
        }
    }
}

impl serde::Serialize for JsonTable<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("header", &self.table.header)?;
        m.serialize_entry("rows", &JsonRows(self))?;
        m.end()
    }
}

struct JsonRows<'a, 'b>(&'b JsonTable<'a>);

impl serde::Serialize for JsonRows<'_, '_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(
            grid_points(self.0.table)
                .enumerate()
                .map(|(flat, idx)| JsonRow(self.0, flat, idx)),
        )
    }
}

/// Row `flat` (grid index `idx`) of a [`JsonTable`].
struct JsonRow<'a, 'b>(&'b JsonTable<'a>, usize, Vec<usize>);

impl serde::Serialize for JsonRow<'_, '_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let JsonRow(json, flat, idx) = self;
        let (h, nc) = (&json.table.header, json.table.header.channels.len());
        let mut m = s.serialize_map(Some(json.keys.len()))?;
        for &(name, key) in &json.keys {
            let v = match key {
                RowKey::Axis(a) => h.axes[a].coord(idx[a]),
                RowKey::Channel(c) => f64::from(json.table.data[flat * nc + c]),
            };
            m.serialize_entry(name, &v.is_finite().then_some(v))?;
        }
        m.end()
    }
}

/// Name of the EXR attribute holding the table header (JSON text, UTF-8).
pub const EXR_HEADER_ATTRIBUTE: &str = "scatterbake_header";

/// The UTF-8 bytes of `text` as an EXR name (channel names: 1 to 255 bytes, no NUL).
fn exr_text(text: &str, what: &str) -> Result<exr::meta::attribute::Text, ConsumerError> {
    if text.is_empty() || text.len() > 255 || text.contains('\0') {
        return Err(ConsumerError::layout(format!(
            "{what} `{}` cannot be stored in EXR (1 to 255 bytes of UTF-8, no NUL)",
            text.escape_debug()
        )));
    }
    Ok(exr::meta::attribute::Text::from_bytes_unchecked(
        text.as_bytes().into(),
    ))
}

/// The table header stored in an EXR file written by [`to_exr`] (attribute
/// [`EXR_HEADER_ATTRIBUTE`], UTF-8 JSON), read back from the file's first part.
pub fn read_exr_header(path: &Path) -> Result<crate::table::Header, ConsumerError> {
    let meta =
        exr::meta::MetaData::read_from_file(path, false).map_err(|source| ConsumerError::Exr {
            what: format!("reading the EXR header of {}", path.display()),
            source,
        })?;
    let missing = || {
        ConsumerError::invalid(format!(
            "{}: no `{EXR_HEADER_ATTRIBUTE}` text attribute (not a scatterbake EXR export)",
            path.display()
        ))
    };
    let header = meta.headers.first().ok_or_else(missing)?;
    let Some(exr::meta::attribute::AttributeValue::Text(text)) =
        header
            .own_attributes
            .other
            .get(&exr::meta::attribute::Text::new_or_panic(
                EXR_HEADER_ATTRIBUTE,
            ))
    else {
        return Err(missing());
    };
    let json = std::str::from_utf8(text.bytes()).map_err(|e| {
        ConsumerError::invalid(format!(
            "{}: `{EXR_HEADER_ATTRIBUTE}` is not UTF-8 text ({e})",
            path.display()
        ))
    })?;
    serde_json::from_str(json).map_err(|e| {
        ConsumerError::invalid(format!(
            "{}: `{EXR_HEADER_ATTRIBUTE}` is not a table header ({e})",
            path.display()
        ))
    })
}

/// EXR bytes of a table (layout in the module docs).
pub fn to_exr(table: &Table) -> Result<Vec<u8>, ConsumerError> {
    let mut buf = std::io::Cursor::new(Vec::new());
    write_exr(table, &mut buf)?;
    Ok(buf.into_inner())
}

/// Write the EXR of a table to `w` (layout in the module docs).
pub fn write_exr(
    table: &Table,
    w: &mut (impl std::io::Write + std::io::Seek),
) -> Result<(), ConsumerError> {
    use exr::prelude::*;
    let h = &table.header;
    let shape = table.grid_shape();
    let width = *shape.last().expect("at least one axis");
    let height: usize = shape[..shape.len() - 1].iter().product::<usize>().max(1);
    if width > i32::MAX as usize / 2 || height > i32::MAX as usize / 2 {
        return Err(ConsumerError::layout(format!(
            "table too large for an EXR image ({width}×{height})"
        )));
    }
    let nc = h.channels.len();
    let mut list = smallvec::SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (c, ch) in h.channels.iter().enumerate() {
        let samples: Vec<f32> = (0..width * height)
            .map(|p| table.data[p * nc + c])
            .collect();
        list.push(AnyChannel::new(
            exr_text(&ch.name, "channel name")?,
            FlatSamples::F32(samples),
        ));
    }
    let header_json = serde_json::to_string(h)?;
    let mut layer = Layer::new(
        (width, height),
        LayerAttributes::named("scatterbake"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    // An attribute value has no length limit; the JSON has no NUL byte (it escapes control
    // characters), so the bytes are stored as they are.
    let header_text = Text::from_bytes_unchecked(header_json.into_bytes().into());
    layer.attributes.other.insert(
        Text::new_or_panic(EXR_HEADER_ATTRIBUTE),
        AttributeValue::Text(header_text),
    );
    let image = Image::from_layer(layer);
    image
        .write()
        .to_buffered(w)
        .map_err(|source| ConsumerError::Exr {
            what: "EXR encoding failed".into(),
            source,
        })
}

/// Export `table` to `out` in `format`, atomically. CSV and JSON are written a row at a time
/// and EXR straight into the file, so memory stays about the table's own size (rainbow-mie,
/// 20.9 MB of samples: peak memory of `scatterbake export` JSON 2.3 GB → 50 MB, CSV 117 → 49 MB,
/// EXR 82 → 62 MB).
pub fn export(table: &Table, format: GenericFormat, out: &Path) -> Result<(), ConsumerError> {
    let mut exr_error = None;
    write_atomic_streamed(out, |w| match format {
        GenericFormat::Csv => write_csv(table, w),
        GenericFormat::Json => write_json(table, w),
        GenericFormat::Exr => {
            write_exr(table, w).map_err(|e| std::io::Error::other(exr_error.insert(e).to_string()))
        }
    })
    .map_err(|e| match exr_error.take() {
        Some(exr) => exr,
        None => IoError::doing("writing", out)(e).into(),
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::henyey_greenstein_table;

    /// The streamed JSON is the table's rows as a `serde_json::Map` per grid point would give
    /// them (built here directly), non-finite values as null; the streamed CSV is `to_csv`.
    #[test]
    fn streamed_json_and_csv_are_the_table() {
        let mut t = henyey_greenstein_table(&[450.0, 650.0], &[1.0], |k, _| 0.3 * k as f64, 7, 0.1);
        t.data[5] = f32::NAN;
        t.data[9] = f32::INFINITY;
        let mut bytes = Vec::new();
        write_json(&t, &mut bytes).unwrap();
        let got: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        let h = &t.header;
        let nc = h.channels.len();
        let rows: Vec<serde_json::Value> = grid_points(&t)
            .enumerate()
            .map(|(flat, idx)| {
                let mut m = serde_json::Map::new();
                for (a, &i) in h.axes.iter().zip(&idx) {
                    m.insert(a.name.clone(), a.coord(i).into());
                }
                for (c, ch) in h.channels.iter().enumerate() {
                    m.insert(ch.name.clone(), f64::from(t.data[flat * nc + c]).into());
                }
                serde_json::Value::Object(m)
            })
            .collect();
        assert_eq!(rows.len(), 2 * 7);
        let expected = serde_json::json!({ "header": h, "rows": rows });
        assert_eq!(got, expected);
        assert_eq!(
            got["rows"][5 / nc][&h.channels[5 % nc].name],
            serde_json::Value::Null
        );
        assert_eq!(to_json(&t), expected);
        let mut csv = Vec::new();
        write_csv(&t, &mut csv).unwrap();
        assert_eq!(String::from_utf8(csv).unwrap(), to_csv(&t));
        assert_eq!(to_csv(&t).lines().count(), 1 + 2 * 7);
    }

    /// An even-periodic axis is written over its whole period: the stored 0°–180° then the
    /// mirrors 225°, 270°, 315° with the values stored at 135°, 90°, 45°, which are the values
    /// the table's own lookup returns there; the other axes and JSON keep the stored grid.
    #[test]
    fn csv_unfolds_even_periodic_axes_over_one_period() {
        use crate::table::{Channel, Provenance, Schema, Symmetry, TableContent};
        let azimuth = vec![0.0, 45.0, 90.0, 135.0, 180.0];
        let value = |p: usize, a: f64| (1.0 + p as f64 + a.to_radians().cos() / 4.0) as f32;
        let data: Vec<f32> = (0..2)
            .flat_map(|p| azimuth.iter().map(move |&a| value(p, a)))
            .collect();
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new("test-2d", 1),
            description: "test".into(),
            axes: vec![
                Axis::values("outgoing_polar", "deg", vec![10.0, 20.0]),
                Axis::values("outgoing_azimuth", "deg", azimuth)
                    .with_symmetry(Symmetry::EvenPeriodic { period: 360.0 }),
            ],
            channels: vec![Channel::new("phase", "1/sr", "test")],
            attributes: Default::default(),
            data,
        };
        let t = Table::from_content(content, Provenance::default()).unwrap();
        let csv = to_csv(&t);
        let rows: Vec<(f64, f64, f32)> = csv
            .lines()
            .skip(1)
            .map(|l| {
                let v: Vec<&str> = l.split(',').collect();
                (
                    v[0].parse().unwrap(),
                    v[1].parse().unwrap(),
                    v[2].parse().unwrap(),
                )
            })
            .collect();
        let expected_azimuth = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0];
        assert_eq!(rows.len(), 2 * expected_azimuth.len());
        for (k, &(polar, azimuth, phase)) in rows.iter().enumerate() {
            assert_eq!(polar, [10.0, 20.0][k / 8]);
            assert_eq!(azimuth, expected_azimuth[k % 8]);
            assert_eq!(phase, value(k / 8, azimuth), "{polar} {azimuth}");
            let looked_up = t.sample_channel("phase", &[polar, azimuth]).unwrap();
            assert_eq!(f64::from(phase), looked_up, "{polar} {azimuth}");
        }
        let json = to_json(&t);
        assert_eq!(json["rows"].as_array().unwrap().len(), 2 * 5);
        assert_eq!(json["header"]["axes"][1]["symmetry"]["period"], 360.0);
    }
}
