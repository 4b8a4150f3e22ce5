//! Tables of every layout the readers of other languages must handle, written by the Rust
//! writer, plus every `.sbt` already in the repository's `tables/` (the default build output),
//! so each real table family is checked once it has been built.

#![allow(dead_code)]

use scatterbake::consumers::synthetic::{henyey_greenstein_table, peak_table};
use scatterbake::table::{
    Axis, Channel, Provenance, Schema, Table, TableContent, write_table_atomic,
};
use std::path::{Path, PathBuf};

/// Write the synthetic tables into `dir` and return their paths together with the repository's
/// built tables.
pub fn tables(dir: &Path) -> Vec<PathBuf> {
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

/// Copy of `src` claiming format major 2.
pub fn newer_major_copy(src: &Path, dst: &Path) {
    let mut b = std::fs::read(src).unwrap();
    b[8] = 2;
    std::fs::write(dst, b).unwrap();
}
