//! Tables of every layout the readers of other languages must handle, written by the Rust
//! writer, plus every `.sbt` already in the repository's `tables/` (the default build output),
//! so each real table family is checked once it has been built.

#![allow(dead_code)]

pub mod c;
pub mod crafted;
pub mod entries;
pub mod python;

use scatterbake::fixtures::{henyey_greenstein_table, peak_table};
use scatterbake::table::{
    Axis, Channel, Provenance, Schema, Table, TableContent, write_table_atomic,
};
use std::path::{Path, PathBuf};

/// Write the synthetic tables into `dir` and return their paths together with the repository's
/// built tables.
pub fn tables(dir: &Path) -> Vec<PathBuf> {
    let mut out = synthetic_tables(dir);
    out.push(compact_raytrace_table(dir));
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("tables");
    if let Ok(rd) = std::fs::read_dir(&built) {
        let mut v: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "sbt"))
            .collect();
        v.sort();
        out.extend(v);
    }
    out
}

/// A small compact 2-D `raytrace` table (`compression`: explicit, non-uniform polar and
/// azimuth axes chosen at build time), written into `dir`: every reader samples it as the Rust
/// reader does.
pub fn compact_raytrace_table(dir: &Path) -> PathBuf {
    let stage = scatterbake::stages::find("raytrace").expect("raytrace stage");
    let params = r#"{ shape = "beard-chuang", radii_um = [1500.0], wavelengths_nm = [550.0], sun_elevation_deg = [30.0], rays = 60, polar_step_deg = 0.25, azimuth_step_deg = 10.0, diagnostic_channels = false, compression = { kind = "sun-disc-resampled", tolerance = 0.01 } }"#;
    let job = stage
        .plan(toml::de::ValueDeserializer::parse(params).unwrap())
        .unwrap();
    let content = scatterbake::stages::run_in_memory(job.as_ref()).unwrap();
    let mut t = Table::from_content(content, Provenance::default()).unwrap();
    let p = dir.join("raytrace-compact.sbt");
    write_table_atomic(&mut t, &p).unwrap();
    p
}

/// Write the synthetic tables (every layout: explicit and uniform axes, 1 to 4 axes, 1 to 4
/// channels, special f32 values) into `dir` and return their paths.
pub fn synthetic_tables(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut write = |name: &str, mut t: Table| {
        let p = dir.join(name);
        write_table_atomic(&mut t, &p).unwrap();
        out.push(p);
    };
    write(
        "hg.sbt",
        henyey_greenstein_table(
            &[450.0, 550.0, 650.0],
            &[10.0, 100.0, 1000.0],
            |k, r| 0.3 + 0.1 * k as f64 + 0.15 * r as f64,
            361,
            0.5,
        ),
    );
    let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
    write(
        "peak.sbt",
        peak_table(&wl, |l| 139.0 - (l - 380.0) / 200.0, 0.3, 1e-3, 1801),
    );
    // 2-D phase function of a non-spherical drop (layout of the ray-traced stage).
    let (np, na) = (91, 72);
    let mut data = Vec::new();
    for w in 0..2 {
        for e in 0..3 {
            for i in 0..np {
                for j in 0..na {
                    let v = 1e-3
                        * (1.0 + w as f32)
                        * (1.0 + e as f32 * 0.1)
                        * (1.0 + (i as f32 * 0.1).sin() * (j as f32 * 0.2).cos().abs());
                    data.extend_from_slice(&[v, v * 1.1, v * 0.9, 0.1]);
                }
            }
        }
    }
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("synthetic-2d-phase", 1),
        description: "2-D phase function layout".into(),
        axes: vec![
            Axis::values("wavelength", "nm", vec![450.0, 650.0]),
            Axis::values("sun_elevation", "deg", vec![0.0, 20.0, 40.0]),
            Axis::uniform("outgoing_polar", "deg", 0.0, 2.0, np),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, 5.0, na),
        ],
        channels: ["phase", "i_perp", "i_par", "dolp"]
            .iter()
            .map(|n| Channel::new(n, "1/sr", "test"))
            .collect(),
        attributes: serde_json::Map::new(),
        data,
    };
    write(
        "latlong.sbt",
        Table::from_content(content, Provenance::default()).unwrap(),
    );
    // Special float values must survive bit for bit.
    let special = vec![
        0.0f32,
        -0.0,
        f32::MIN_POSITIVE,
        1e-45,
        f32::MAX,
        -f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.0 / 3.0,
    ];
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("special-values", 1),
        description: "special f32 values".into(),
        axes: vec![Axis::values(
            "x",
            "1",
            (0..special.len()).map(|i| i as f64 * 0.5).collect(),
        )],
        channels: vec![Channel::new("value", "1", "test")],
        attributes: serde_json::Map::new(),
        data: special,
    };
    write(
        "special.sbt",
        Table::from_content(content, Provenance::default()).unwrap(),
    );
    out
}

/// Raw little-endian bytes of a table's samples.
pub fn raw_bytes(t: &Table) -> Vec<u8> {
    t.data.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Copy of `src` with one byte flipped at `offset_from_end` bytes before the end (payload).
pub fn corrupt_copy(src: &Path, dst: &Path, offset_from_end: usize) {
    let mut b = std::fs::read(src).unwrap();
    let n = b.len();
    b[n - offset_from_end] ^= 0x40;
    std::fs::write(dst, b).unwrap();
}

/// Rewrite table bytes as a writer of format `major.minor` would: the header JSON passed through
/// `edit`, then every checksum recomputed as `docs/table-format.md` specifies (header length,
/// SHA-256 of bytes 0–23 plus the header, and the SHA-256 of the compressed and uncompressed
/// payload, which is carried over unchanged).
pub fn rewrite_table(
    bytes: &[u8],
    major: u16,
    minor: u16,
    edit: impl FnOnce(&mut serde_json::Value),
) -> Vec<u8> {
    use sha2::{Digest, Sha256};
    let hlen = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    let mut header: serde_json::Value = serde_json::from_slice(&bytes[56..56 + hlen]).unwrap();
    let payload = &bytes[56 + hlen..];
    let raw = zstd::stream::decode_all(payload).unwrap();
    header["payload"]["compressed_bytes"] = payload.len().into();
    header["payload"]["uncompressed_bytes"] = raw.len().into();
    header["payload"]["sha256_compressed"] = hex::encode(Sha256::digest(payload)).into();
    header["payload"]["sha256_uncompressed"] = hex::encode(Sha256::digest(&raw)).into();
    edit(&mut header);
    let header = serde_json::to_vec_pretty(&header).unwrap();
    let mut out = bytes[..8].to_vec();
    out.extend_from_slice(&major.to_le_bytes());
    out.extend_from_slice(&minor.to_le_bytes());
    out.extend_from_slice(&bytes[12..16]); // flags
    out.extend_from_slice(&(header.len() as u64).to_le_bytes());
    let mut h = Sha256::new();
    h.update(&out[..24]);
    h.update(&header);
    out.extend_from_slice(&h.finalize());
    out.extend_from_slice(&header);
    out.extend_from_slice(payload);
    out
}

/// Header fields a later minor version might add: at the top level and inside every nested
/// object (schema, each axis and its uniform range, each channel, layout, provenance, payload).
pub fn add_unknown_fields(h: &mut serde_json::Value) {
    use serde_json::json;
    let o = h.as_object_mut().unwrap();
    o.insert(
        "future_top_level".into(),
        json!({"nested": [1, 2.5, "x"], "flag": true}),
    );
    o.insert(
        "future_note".into(),
        json!("written by a newer minor version"),
    );
    h["schema"]["future_schema_field"] = json!(7);
    for a in h["axes"].as_array_mut().unwrap() {
        a["future_axis_field"] = json!({"interpolation": "cubic", "weights": [0.5, 0.5]});
        if let Some(u) = a["points"].get_mut("uniform") {
            u["future_range_field"] = json!(null);
        }
    }
    for c in h["channels"].as_array_mut().unwrap() {
        c["future_channel_field"] = json!(["a", "b"]);
    }
    h["layout"]["future_alignment"] = json!(64);
    h["provenance"]["future_host"] = json!({"os": "any"});
    h["payload"]["future_dictionary"] = json!(null);
}

/// Copy of `src` as format 1.1 with unknown header fields everywhere ([`add_unknown_fields`]),
/// checksums recomputed: every 1.x reader must read it as it reads `src`.
pub fn newer_minor_copy(src: &Path, dst: &Path) {
    let b = std::fs::read(src).unwrap();
    std::fs::write(dst, rewrite_table(&b, 1, 1, add_unknown_fields)).unwrap();
}

/// Copy of `src` as format 4.0 with valid checksums and a header no reader of 1.x to 3.x
/// could parse (no `layout`, a renamed field): readers must refuse it on the version alone.
pub fn newer_major_copy(src: &Path, dst: &Path) {
    let b = std::fs::read(src).unwrap();
    let out = rewrite_table(&b, 4, 0, |h| {
        let o = h.as_object_mut().unwrap();
        let layout = o.remove("layout").unwrap();
        o.insert("storage".into(), layout);
    });
    std::fs::write(dst, out).unwrap();
}
