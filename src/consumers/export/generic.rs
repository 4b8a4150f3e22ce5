//! Generic exporters for any table: CSV, JSON and OpenEXR.
//!
//! - **CSV**: a header line `axis1 [unit],…,channel1 [unit],…`, then one row per grid point in
//!   storage order (row-major, last axis fastest). Values printed with full f32 precision.
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
use crate::table::Table;
use crate::table::format::write_atomic;
use std::fmt::Write as _;
use std::path::Path;

/// Export formats handled here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GenericFormat {
    Csv,
    Json,
    Exr,
}

fn grid_points(table: &Table) -> impl Iterator<Item = Vec<usize>> + '_ {
    let shape = table.grid_shape();
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
    let h = &table.header;
    let mut out = String::new();
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
    out.push_str(&cols.join(","));
    out.push('\n');
    let nc = h.channels.len();
    for (flat, idx) in grid_points(table).enumerate() {
        let mut row = Vec::with_capacity(idx.len() + nc);
        for (a, &i) in h.axes.iter().zip(&idx) {
            row.push(format!("{}", a.coord(i)));
        }
        for c in 0..nc {
            row.push(format!("{:e}", table.data[flat * nc + c]));
        }
        let _ = writeln!(out, "{}", row.join(","));
    }
    out
}

/// JSON value of a table (header + rows).
pub fn to_json(table: &Table) -> serde_json::Value {
    let h = &table.header;
    let nc = h.channels.len();
    let rows: Vec<serde_json::Value> = grid_points(table)
        .enumerate()
        .map(|(flat, idx)| {
            let mut m = serde_json::Map::new();
            for (a, &i) in h.axes.iter().zip(&idx) {
                m.insert(a.name.clone(), a.coord(i).into());
            }
            for (c, ch) in h.channels.iter().enumerate() {
                let v = f64::from(table.data[flat * nc + c]);
                m.insert(
                    ch.name.clone(),
                    if v.is_finite() {
                        v.into()
                    } else {
                        serde_json::Value::Null
                    },
                );
            }
            serde_json::Value::Object(m)
        })
        .collect();
    serde_json::json!({ "header": h, "rows": rows })
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
    let mut buf = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut buf)
        .map_err(|source| ConsumerError::Exr {
            what: "EXR encoding failed".into(),
            source,
        })?;
    Ok(buf.into_inner())
}

/// Export `table` to `out` in `format`, atomically.
pub fn export(table: &Table, format: GenericFormat, out: &Path) -> Result<(), ConsumerError> {
    let bytes = match format {
        GenericFormat::Csv => to_csv(table).into_bytes(),
        GenericFormat::Json => serde_json::to_vec_pretty(&to_json(table))?,
        GenericFormat::Exr => to_exr(table)?,
    };
    write_atomic(out, &bytes).map_err(IoError::doing("writing", out))?;
    Ok(())
}
