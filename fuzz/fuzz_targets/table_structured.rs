//! Structure-aware fuzzing of the table reader. The input is decoded (`arbitrary`) into a
//! description of a table: its axes (uniform or explicit), channels and samples, and one of the
//! three layouts a reader meets (a plain table, a compact 2-D ray-traced table with its
//! `compression` attribute and explicit knot axes, a tensor train with `dims`, `ranks`,
//! `core_offsets` and `log_floor`). The writer turns it into a valid file; then a list of
//! edits rewrites fields of the JSON header (numbers, integers, strings, nulls, removals at
//! the paths the rules read) and the header is re-sealed with a correct checksum, so every
//! input reaches the structural rules, the layout rules and the lookup, not the checksum.
//!
//! Every read must give Ok or a clean error, never a panic, an abort or an allocation beyond
//! the limit; an accepted table must be usable through the lookup API at its first and last
//! grid points, its first entry must open alone with the same samples, and a reconstructed
//! tensor train must hold finite values. Run:
//! `cargo +nightly fuzz run table_structured -- -max_total_time=600 -rss_limit_mb=2048`.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use scatterbake_table::{Axis, Channel, Provenance, ReadLimits, Schema, Table, TableContent};
use serde_json::{Value, json};
use sha2::{Digest, Sha256};
use std::path::Path;

#[derive(Arbitrary, Debug)]
enum Points {
    Uniform { start: f64, step: f64, count: u8 },
    Values(Vec<f64>),
}

#[derive(Arbitrary, Debug)]
enum Layout {
    Plain,
    Compact2d { tolerance: f64, knots: Vec<u16> },
    TensorTrain { dims: Vec<u8>, ranks: Vec<u8>, log_floor: Option<f64> },
}

/// A value written at one of the paths the rules read.
#[derive(Arbitrary, Debug)]
enum NewValue {
    Remove,
    Null,
    Int(u64),
    Negative(i64),
    Number(f64),
    Text(String),
    Empty,
    List(Vec<u32>),
}

#[derive(Arbitrary, Debug)]
struct Edit {
    path: u8,
    value: NewValue,
}

#[derive(Arbitrary, Debug)]
struct Spec {
    axes: Vec<Points>,
    channels: u8,
    layout: Layout,
    values: Vec<f32>,
    edits: Vec<Edit>,
    minor: bool,
}

/// The header fields the reading rules look at (JSON pointers).
const PATHS: &[&str] = &[
    "/axes/0/uniform/count",
    "/axes/0/uniform/step",
    "/axes/0/uniform/start",
    "/axes/0/values",
    "/axes/0/values/1",
    "/axes/1/values/0",
    "/axes/1/uniform/count",
    "/axes/0/name",
    "/axes/1",
    "/layout/shape/0",
    "/layout/shape",
    "/layout/axis_order/0",
    "/layout/dtype",
    "/layout/order",
    "/payload/uncompressed_bytes",
    "/payload/compressed_bytes",
    "/payload/compression",
    "/channels/0/name",
    "/channels",
    "/schema/name",
    "/schema/version",
    "/attributes/dims/0",
    "/attributes/dims",
    "/attributes/ranks/1",
    "/attributes/ranks",
    "/attributes/core_offsets/1",
    "/attributes/core_offsets",
    "/attributes/log_floor",
    "/attributes/source_axes",
    "/attributes/source_axes/0/uniform/count",
    "/attributes/source_schema",
    "/attributes/source_channel",
    "/attributes/compression/tolerance",
    "/attributes/compression/kind",
    "/attributes/compression/knots",
    "/attributes/sun_diameter_deg",
    "/provenance/parameters",
];

fn axis(k: usize, p: &Points) -> Axis {
    let name = format!("a{k}");
    match p {
        Points::Uniform { start, step, count } => {
            Axis::uniform(&name, "1", *start, *step, usize::from(*count % 6) + 1)
        }
        Points::Values(v) => Axis::values(&name, "1", v.iter().take(6).copied().collect()),
    }
}

/// The valid table the description gives, or None when the writer refuses it.
fn base_table(spec: &Spec) -> Option<Table> {
    let mut axes: Vec<Axis> = spec.axes.iter().take(4).enumerate().map(|(k, p)| axis(k, p)).collect();
    let mut attributes = serde_json::Map::new();
    let mut schema = Schema::new("fuzz", 1);
    let mut channels = usize::from(spec.channels % 4) + 1;
    match &spec.layout {
        Layout::Plain => {}
        Layout::Compact2d { tolerance, knots } => {
            schema = Schema::new("raytrace-phase-2d", 2);
            let polar: Vec<f64> = knots.iter().take(8).map(|k| f64::from(*k) / 364.0).collect();
            axes = vec![
                Axis::values("wavelength", "nm", vec![550.0]),
                Axis::values("outgoing_polar", "deg", polar),
                Axis::values("outgoing_azimuth", "deg", vec![0.0, 90.0, 180.0]),
            ];
            channels = 3;
            attributes.insert(
                "compression".into(),
                json!({"kind": "sun-disc-resampled", "tolerance": tolerance, "norm": "rms",
                       "sun_diameter_deg": 0.5}),
            );
            attributes.insert("sun_diameter_deg".into(), json!(0.5));
        }
        Layout::TensorTrain { dims, ranks, log_floor } => {
            schema = Schema::new("fur-medulla-tt", 1);
            let dims: Vec<u64> = dims.iter().take(4).map(|d| u64::from(*d % 5) + 1).collect();
            let mut ranks: Vec<u64> = ranks.iter().take(dims.len() + 1).map(|r| u64::from(*r % 4) + 1).collect();
            ranks.resize(dims.len() + 1, 1);
            if let (Some(f), Some(l)) = (ranks.first_mut(), Some(1)) {
                *f = l;
            }
            *ranks.last_mut()? = 1;
            let mut offsets = vec![0u64];
            for k in 0..dims.len() {
                offsets.push(offsets[k] + ranks[k] * dims[k] * ranks[k + 1]);
            }
            let n = usize::try_from(*offsets.last()?).ok()?;
            axes = vec![Axis::uniform("value", "1", 0.0, 1.0, n.max(1))];
            channels = 1;
            let source_axes: Vec<Value> = dims
                .iter()
                .enumerate()
                .map(|(k, d)| json!({"name": format!("s{k}"), "unit": "1",
                                     "uniform": {"start": 0.0, "step": 1.0, "count": d}}))
                .collect();
            attributes.insert("dims".into(), json!(dims));
            attributes.insert("ranks".into(), json!(ranks));
            attributes.insert("core_offsets".into(), json!(offsets));
            attributes.insert("source_schema".into(), json!("fuzz/1"));
            attributes.insert("source_description".into(), json!("fuzz"));
            attributes.insert("source_axes".into(), Value::Array(source_axes));
            attributes.insert("source_channel".into(), json!({"name": "v", "unit": "1", "meaning": "fuzz"}));
            attributes.insert("source_attributes".into(), json!({}));
            if let Some(f) = log_floor {
                attributes.insert("log_floor".into(), json!(f));
            }
        }
    }
    let n: usize = axes.iter().map(Axis::len).product::<usize>() * channels;
    let data: Vec<f32> = (0..n).map(|i| spec.values.get(i % spec.values.len().max(1)).copied().unwrap_or(0.5)).collect();
    let content = TableContent {
        schema,
        description: "fuzz".into(),
        axes,
        channels: (0..channels).map(|c| Channel::new(&format!("c{c}"), "1", "fuzz")).collect(),
        attributes,
        data,
        encoding: Default::default(),
    };
    Table::from_content(content, Provenance::default()).ok()
}

fn apply(header: &mut Value, edit: &Edit) {
    let path = PATHS[usize::from(edit.path) % PATHS.len()];
    let new = match &edit.value {
        NewValue::Remove => {
            let (parent, key) = path.rsplit_once('/').unwrap();
            match header.pointer_mut(parent) {
                Some(Value::Object(m)) => {
                    m.remove(key);
                }
                Some(Value::Array(a)) => {
                    if let Ok(i) = key.parse::<usize>() {
                        if i < a.len() {
                            a.remove(i);
                        }
                    }
                }
                _ => {}
            }
            return;
        }
        NewValue::Null => Value::Null,
        NewValue::Int(v) => json!(v),
        NewValue::Negative(v) => json!(v),
        NewValue::Number(v) => serde_json::Number::from_f64(*v).map_or(Value::Null, Value::Number),
        NewValue::Text(s) => json!(s),
        NewValue::Empty => json!([]),
        NewValue::List(v) => json!(v),
    };
    if let Some(slot) = header.pointer_mut(path) {
        *slot = new;
    }
}

/// A file of `header` and `payload` with a correct header checksum.
fn sealed(minor: u16, header: &[u8], payload: &[u8]) -> Vec<u8> {
    let mut file = Vec::new();
    file.extend_from_slice(b"SBTABLE\0");
    file.extend_from_slice(&1u16.to_le_bytes());
    file.extend_from_slice(&minor.to_le_bytes());
    file.extend_from_slice(&0u32.to_le_bytes());
    file.extend_from_slice(&(header.len() as u64).to_le_bytes());
    let mut s = Sha256::new();
    s.update(&file[..24]);
    s.update(header);
    file.extend_from_slice(&s.finalize());
    file.extend_from_slice(header);
    file.extend_from_slice(payload);
    file
}

/// What must hold of a table a reader accepted.
fn use_accepted(t: &Table, file: &[u8], path: &Path, limits: &ReadLimits) {
    let first: Vec<f64> = t.axes().iter().map(|a| a.coord(0)).collect();
    let last: Vec<f64> = t.axes().iter().map(|a| a.coord(a.len() - 1)).collect();
    t.sample(&first).expect("lookup at the first grid point");
    t.sample(&last).expect("lookup at the last grid point");
    if t.axes().len() > 1 {
        let one = Table::from_bytes_slice(file, path, &[0], limits).expect("the first entry opens");
        let n = one.data.len();
        assert_eq!(one.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                   t.data[..n].iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                   "the first entry alone equals the whole table's");
    }
    if let Ok(dense) = t.clone().reconstructed(path, limits) {
        if t.header.schema.name == "fur-medulla-tt" {
            assert!(dense.data.iter().all(|v| v.is_finite()), "a reconstruction holds a non-finite value");
        }
    }
}

fuzz_target!(|spec: Spec| {
    let Some(mut table) = base_table(&spec) else { return };
    let Ok(bytes) = table.to_bytes() else { return };
    let h_len = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    let Ok(mut header) = serde_json::from_slice::<Value>(&bytes[56..56 + h_len]) else { return };
    for edit in spec.edits.iter().take(4) {
        apply(&mut header, edit);
    }
    let header = serde_json::to_vec(&header).unwrap();
    let file = sealed(u16::from(spec.minor), &header, &bytes[56 + h_len..]);
    let path = Path::new("fuzz.sbt");
    let limits = ReadLimits { max_payload_bytes: 64 << 20 };
    if let Ok(t) = Table::from_bytes_with_limits(&file, path, &limits) {
        use_accepted(&t, &file, path, &limits);
    }
});
