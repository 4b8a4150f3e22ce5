//! Table format: round trip, corruption detection, version handling, lookup API.

mod common;

use proptest::prelude::*;
use scatterbake::table::{
    Axis, Channel, Provenance, Schema, Table, TableContent, TableError, write_table_atomic,
};
use sha2::{Digest, Sha256};
use std::path::Path;

fn sample_table() -> Table {
    let wl = vec![400.0, 550.0, 700.0];
    let n_angle = 7;
    let mut data = Vec::new();
    for (i, _) in wl.iter().enumerate() {
        for j in 0..n_angle {
            data.push(i as f32 + 0.25 * j as f32);
            data.push(-(j as f32) * 1.5e-3);
        }
    }
    let mut attributes = serde_json::Map::new();
    attributes.insert("normalization".into(), "test".into());
    Table::from_content(
        TableContent {
            schema: Schema::new("test-phase", 3),
            description: "synthetic".into(),
            axes: vec![
                Axis::values("wavelength", "nm", wl),
                Axis::uniform("scattering_angle", "deg", 0.0, 30.0, n_angle),
            ],
            channels: vec![
                Channel::new("phase", "1/sr", "test channel"),
                Channel::new("dolp", "1", "second channel"),
            ],
            attributes,
            data,
        },
        Provenance {
            tool: "scatterbake".into(),
            tool_version: "test".into(),
            parameters: serde_json::json!({"a": 1}),
            parameters_digest: "00".into(),
            created_utc: "2026-01-01T00:00:00Z".into(),
            ..Default::default()
        },
    )
    .unwrap()
}

fn bytes() -> Vec<u8> {
    sample_table().to_bytes().unwrap()
}

#[test]
fn round_trip_preserves_header_and_payload() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.sbt");
    let mut t = sample_table();
    write_table_atomic(&mut t, &path).unwrap();
    let r = Table::open(&path).unwrap();
    assert_eq!(r.header, t.header);
    assert_eq!(r.data, t.data);
    assert_eq!(r.header.layout.shape, vec![3, 7, 2]);
    assert_eq!(r.header.schema.to_string(), "test-phase/3");
    // No temporary files left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

#[test]
fn every_single_byte_flip_is_detected() {
    let good = bytes();
    for pos in 0..good.len() {
        for x in [0x01u8, 0x80, 0xff] {
            let mut b = good.clone();
            b[pos] ^= x;
            assert!(
                Table::from_bytes(&b, Path::new("flip.sbt")).is_err(),
                "flip {x:#x} at byte {pos} of {} went undetected",
                good.len()
            );
        }
    }
}

proptest! {
    #[test]
    fn random_byte_corruption_is_detected(pos in 0usize..100_000, x in 1u8..=255) {
        let good = bytes();
        let pos = pos % good.len();
        let mut b = good.clone();
        b[pos] ^= x;
        prop_assert!(Table::from_bytes(&b, Path::new("p.sbt")).is_err());
    }

    /// Arbitrary bytes never panic the reader and are refused (with the magic prepended too:
    /// they cannot carry a matching SHA-256 of the header).
    #[test]
    fn arbitrary_bytes_are_refused_without_panic(data in proptest::collection::vec(any::<u8>(), 0..512)) {
        prop_assert!(Table::from_bytes(&data, Path::new("fuzz.sbt")).is_err());
        let mut with_magic = b"SBTABLE\0".to_vec();
        with_magic.extend_from_slice(&data);
        prop_assert!(Table::from_bytes(&with_magic, Path::new("fuzz.sbt")).is_err());
    }
}

#[test]
fn every_truncation_is_detected() {
    let good = bytes();
    for len in 0..good.len() {
        let e = Table::from_bytes(&good[..len], Path::new("t.sbt")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("t.sbt"), "error must name the file: {msg}");
    }
    let mut longer = good.clone();
    longer.push(0);
    assert!(matches!(
        Table::from_bytes(&longer, Path::new("t.sbt")),
        Err(TableError::TrailingBytes { .. })
    ));
}

#[test]
fn wrong_magic_is_named() {
    let mut b = bytes();
    b[0] = b'X';
    let e = Table::from_bytes(&b, Path::new("t.sbt")).unwrap_err();
    assert!(matches!(e, TableError::BadMagic { .. }));
    assert!(e.to_string().contains("not a scatterbake table"));
}

/// Rewrite the version fields and fix up the header checksum, as a future writer would.
fn with_version(mut b: Vec<u8>, major: u16, minor: u16) -> Vec<u8> {
    b[8..10].copy_from_slice(&major.to_le_bytes());
    b[10..12].copy_from_slice(&minor.to_le_bytes());
    let hlen = u64::from_le_bytes(b[16..24].try_into().unwrap()) as usize;
    let mut h = Sha256::new();
    h.update(&b[..24]);
    h.update(&b[56..56 + hlen]);
    let d = h.finalize();
    b[24..56].copy_from_slice(&d);
    b
}

#[test]
fn newer_major_is_refused_newer_minor_is_read() {
    let e = Table::from_bytes(&with_version(bytes(), 2, 0), Path::new("t.sbt")).unwrap_err();
    assert!(matches!(e, TableError::NewerMajor { major: 2, .. }), "{e}");
    assert!(e.to_string().contains("newer"));
    let t = Table::from_bytes(&with_version(bytes(), 1, 9), Path::new("t.sbt")).unwrap();
    assert_eq!(t.data, sample_table().data);
}

/// Lookup points of a table: the first grid point, an interior point between the first two
/// samples of every axis, and a point clamped beyond the last sample.
fn probe_points(t: &Table) -> Vec<Vec<f64>> {
    let axes = t.axes();
    let first = axes.iter().map(|a| a.coord(0)).collect();
    let interior = axes
        .iter()
        .map(|a| {
            if a.len() > 1 {
                0.37 * a.coord(0) + 0.63 * a.coord(1)
            } else {
                a.coord(0)
            }
        })
        .collect();
    let beyond = axes.iter().map(|a| a.coord(a.len() - 1) + 1.0).collect();
    vec![first, interior, beyond]
}

/// The format's promise for a newer minor version: a 1.1 file with unknown header fields at the
/// top level and inside every nested object (axes, uniform ranges, channels, layout,
/// provenance, payload), checksums recomputed as the spec says, reads as the 1.0 file it was
/// made from: the same header (unknown fields dropped), bit-identical samples and lookups.
#[test]
fn newer_minor_with_unknown_fields_is_read() {
    let dir = tempfile::tempdir().unwrap();
    for p in common::synthetic_tables(dir.path()) {
        let newer = dir.path().join("newer.sbt");
        common::newer_minor_copy(&p, &newer);
        let b = std::fs::read(&newer).unwrap();
        assert_eq!(&b[8..12], &[1, 0, 1, 0], "format 1.1");
        let header = String::from_utf8_lossy(&b[56..]);
        assert!(header.contains("future_top_level") && header.contains("future_axis_field"));
        let old = Table::open(&p).unwrap();
        let new = Table::open(&newer).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert_eq!(new.header, old.header, "{}", p.display());
        let bits = |t: &Table| t.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&new), bits(&old), "{}", p.display());
        for x in probe_points(&old) {
            let (u, v) = (old.sample(&x).unwrap(), new.sample(&x).unwrap());
            let ub: Vec<u64> = u.iter().map(|v| v.to_bits()).collect();
            let vb: Vec<u64> = v.iter().map(|v| v.to_bits()).collect();
            assert_eq!(ub, vb, "{} at {x:?}", p.display());
        }
        // The header-only reader (resume checks, catalogue) accepts it too.
        assert_eq!(
            scatterbake::table::read_header_only(&newer).unwrap(),
            old.header
        );
    }
}

/// Unknown fields are a newer minor's privilege: in a file of the minor this reader implements
/// (1.0) an unknown top-level field is refused, naming the field.
#[test]
fn unknown_top_level_field_in_a_known_minor_is_refused() {
    let b = common::rewrite_table(&bytes(), 1, 0, |h| {
        h["future_note"] = serde_json::json!("x");
    });
    let e = Table::from_bytes(&b, Path::new("t.sbt")).unwrap_err();
    assert!(matches!(e, TableError::BadHeader { .. }), "{e}");
    assert!(e.to_string().contains("`future_note`"), "{e}");
    // The same file as 1.1 reads.
    let b = common::rewrite_table(&bytes(), 1, 1, |h| {
        h["future_note"] = serde_json::json!("x");
    });
    assert_eq!(
        Table::from_bytes(&b, Path::new("t.sbt")).unwrap().data,
        sample_table().data
    );
}

/// A newer major is refused on its version alone, before its header is interpreted (the crafted
/// 2.0 header has valid checksums but no `layout`), with an error naming the version.
#[test]
fn newer_major_with_valid_checksums_is_refused_naming_the_version() {
    let dir = tempfile::tempdir().unwrap();
    let p = common::synthetic_tables(dir.path()).remove(0);
    let newer = dir.path().join("v2.sbt");
    common::newer_major_copy(&p, &newer);
    let e = Table::open(&newer).unwrap_err();
    assert!(
        matches!(
            e,
            TableError::NewerMajor {
                major: 2,
                minor: 0,
                ..
            }
        ),
        "{e}"
    );
    let msg = e.to_string();
    assert!(msg.contains("2.0") && msg.contains("newer"), "{msg}");
    assert!(matches!(
        scatterbake::table::read_header_only(&newer).unwrap_err(),
        TableError::NewerMajor { major: 2, .. }
    ));
}

#[test]
fn failed_write_keeps_existing_table() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.sbt");
    let mut t = sample_table();
    write_table_atomic(&mut t, &path).unwrap();
    let before = std::fs::read(&path).unwrap();
    // A table that cannot be serialised must not touch the existing file.
    let bad = TableContent {
        schema: Schema::new("x", 1),
        description: String::new(),
        axes: vec![Axis::values("a", "1", vec![0.0, 1.0])],
        channels: vec![Channel::new("c", "1", "")],
        attributes: Default::default(),
        data: vec![1.0],
    };
    assert!(Table::from_content(bad, Provenance::default()).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

#[test]
fn sample_interpolates_and_clamps() {
    let t = sample_table();
    // phase = i + 0.25 j with j = angle / 30.
    let v = t.sample(&[475.0, 45.0]).unwrap();
    assert!((v[0] - (0.5 + 0.25 * 1.5)).abs() < 1e-6, "{v:?}");
    // Clamped below and above.
    let lo = t.sample_channel("phase", &[100.0, -10.0]).unwrap();
    assert!((lo - 0.0).abs() < 1e-7);
    let hi = t.sample_channel("phase", &[900.0, 500.0]).unwrap();
    assert!((hi - (2.0 + 0.25 * 6.0)).abs() < 1e-6);
    assert!(t.sample(&[f64::NAN, 0.0]).is_err());
    assert!(t.sample(&[1.0]).is_err());
    assert!(t.sample_channel("nope", &[1.0, 1.0]).is_err());
}

/// Every crafted file of the corpus is accepted or refused as marked, with an error (never a
/// panic), and an accepted one can be looked up at its first and last grid points.
#[test]
fn crafted_corpus_rust_reader() {
    let mut wrong = Vec::new();
    for case in common::crafted::cases() {
        let r = Table::from_bytes(&case.bytes, Path::new(case.name));
        match (&r, case.valid) {
            (Ok(t), true) => {
                for pick in [0usize, 1] {
                    let coords: Vec<f64> = t
                        .axes()
                        .iter()
                        .map(|a| a.coord(if pick == 0 { 0 } else { a.len() - 1 }))
                        .collect();
                    t.sample(&coords).unwrap();
                }
            }
            (Err(e), false) => {
                let msg = e.to_string();
                assert!(
                    msg.starts_with(case.name),
                    "{}: error does not name the file: {msg}",
                    case.name
                );
            }
            _ => wrong.push(format!(
                "{}: valid={} got {:?}",
                case.name,
                case.valid,
                r.map(|_| ())
            )),
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Reading a file declaring a huge payload that its bytes do not back allocates little: the
/// declared size is refused by the limit, and a raised limit only costs what decompresses.
#[test]
fn declared_sizes_are_not_allocated() {
    use scatterbake::table::ReadLimits;
    let case = common::crafted::cases()
        .into_iter()
        .find(|c| c.name == "declares_1gib_backed_by_18_floats")
        .unwrap();
    let small = ReadLimits {
        max_payload_bytes: 1 << 20,
    };
    let e = Table::from_bytes_with_limits(&case.bytes, Path::new("t.sbt"), &small).unwrap_err();
    assert!(e.to_string().contains("exceeds the reader limit"), "{e}");
    let e = Table::from_bytes(&case.bytes, Path::new("t.sbt")).unwrap_err();
    assert!(e.to_string().contains("zstd frame declares 72"), "{e}");
}

/// Axis labels (decision MIE-17) survive a round trip, are absent from the header when unused,
/// and a label count that differs from the samples' is refused.
#[test]
fn axis_labels_round_trip_and_are_checked() {
    let content = |labels: Vec<String>| TableContent {
        schema: Schema::new("x", 1),
        description: String::new(),
        axes: vec![Axis::labelled("distribution", "1", vec![0.0, 1.0], labels)],
        channels: vec![Channel::new("c", "1", "")],
        attributes: Default::default(),
        data: vec![1.0, 2.0],
    };
    let names = vec!["gamma r_eff=3 um v_eff=0.1".to_string(), "fog".to_string()];
    let mut t = Table::from_content(content(names.clone()), Provenance::default()).unwrap();
    let bytes = t.to_bytes().unwrap();
    let r = Table::from_bytes(&bytes, Path::new("t.sbt")).unwrap();
    assert_eq!(r.header.axes[0].labels, names);
    assert_eq!(r.header.axes[0].label(1), Some("fog"));
    let mut plain = sample_table();
    let text = String::from_utf8_lossy(&plain.to_bytes().unwrap()).to_string();
    assert!(!text.contains("\"labels\""), "no labels key when unused");
    assert!(Table::from_content(content(vec!["one".into()]), Provenance::default()).is_err());
}

/// Tensor-train tables: the valid one reconstructs to its source (axes, channel, values within
/// the f32 rounding of the cores); each crafted inconsistency (ranks, dims, offsets, source
/// axes, non-finite core, log floor) is refused by `Table::open_reconstructed` with an error
/// naming the file and the rule, never a panic, while the plain format reader opens them all.
#[test]
fn tensor_train_tables_reconstruct_or_are_refused() {
    use scatterbake::table::ReadLimits;
    let dir = tempfile::tempdir().unwrap();
    let (_, dense) = common::crafted::tensor_train_table();
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::tensor_train_cases() {
        let p = dir.path().join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        assert!(Table::open(&p).is_ok(), "{}: a valid .sbt file", case.name);
        match (
            Table::open_reconstructed(&p, &ReadLimits::default()),
            case.valid,
        ) {
            (Ok(t), true) => {
                assert_eq!(t.header.schema.name, "fur-medulla-azimuthal");
                assert_eq!(t.grid_shape(), vec![4, 3, 5]);
                for (a, b) in t.data.iter().zip(&dense) {
                    assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{a} vs {b}");
                }
            }
            (Err(e), false) => {
                let m = e.to_string();
                if !(m.contains(case.name)
                    && m.contains("tensor-train table is not valid")
                    && m.contains(fragment))
                {
                    wrong.push(format!("{}: unclear error: {m}", case.name));
                }
            }
            (r, _) => wrong.push(format!(
                "{}: valid={} got {:?}",
                case.name,
                case.valid,
                r.map(|_| ())
            )),
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
