//! Table format: round trip, corruption detection, version handling, lookup API.

use proptest::prelude::*;
use scatterbake_table::{
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
            encoding: Default::default(),
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

/// Header numbers come back bit for bit: the reader parses JSON floats with correct rounding
/// (serde_json's `float_roundtrip`), as Python's `json` and the C reader's caller expect. These
/// values, shortest round-trip forms of backscattering efficiencies, came back one unit in the
/// last place off with the fast parser.
#[test]
fn header_floats_round_trip_bit_for_bit() {
    let values = [
        1.0444543171679215_f64,
        0.22064440169284738,
        0.39640688887316444,
        0.014909307407881807,
        1.9918141089210615,
    ];
    let mut t = sample_table();
    t.header
        .attributes
        .insert("q_back".into(), serde_json::json!(values));
    let r = Table::from_bytes(&t.to_bytes().unwrap(), Path::new("t.sbt")).unwrap();
    let back: Vec<f64> = serde_json::from_value(r.header.attributes["q_back"].clone()).unwrap();
    for (a, b) in values.iter().zip(&back) {
        assert_eq!(a.to_bits(), b.to_bits(), "{a} read back as {b}");
    }
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
    let e = Table::from_bytes(&with_version(bytes(), 3, 0), Path::new("t.sbt")).unwrap_err();
    assert!(matches!(e, TableError::NewerMajor { major: 3, .. }), "{e}");
    assert!(e.to_string().contains("3.0 is newer"), "{e}");
    for (major, minor) in [(1, 9), (2, 0), (2, 7)] {
        let t = Table::from_bytes(&with_version(bytes(), major, minor), Path::new("t.sbt"));
        assert_eq!(t.unwrap().data, sample_table().data, "{major}.{minor}");
    }
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
        encoding: Default::default(),
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

/// Axis labels (decision MIE-17) survive a round trip, are absent from the header when unused,
/// and a label count that differs from the samples' is refused.
#[test]
fn axis_labels_round_trip_and_are_checked() {
    let content = |labels: Vec<String>| TableContent {
        encoding: Default::default(),
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

/// A table of `i_perp`, `i_par` (stored) and `phase`, `dolp` (derived) over
/// wavelength (2) × polar (5) × azimuth (4), stored as `encoding`.
fn polarised_table(encoding: scatterbake_table::ValueEncoding, scale: f32) -> (Table, Vec<f32>) {
    let mut input = Vec::new();
    for i in 0..40 {
        let p = scale * (1.0 + (i as f32 * 0.731).sin().abs() * 1e3);
        let q = scale * (0.2 + (i as f32 * 0.377).cos().abs());
        input.extend([0.0, p, q, 0.0]);
    }
    let content = TableContent {
        schema: Schema::new("test-polarised", 1),
        description: "synthetic".into(),
        axes: vec![
            Axis::values("wavelength", "nm", vec![450.0, 650.0]),
            Axis::uniform("outgoing_polar", "deg", 0.0, 45.0, 5),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, 90.0, 4),
        ],
        channels: vec![
            Channel::derived("phase", "1/sr", "mean", "mean", "i_perp", "i_par"),
            Channel::new("i_perp", "1/sr", "perpendicular"),
            Channel::new("i_par", "1/sr", "parallel"),
            Channel::derived(
                "dolp",
                "1",
                "nd",
                "normalized-difference",
                "i_perp",
                "i_par",
            ),
        ],
        attributes: Default::default(),
        data: input.clone(),
        encoding,
    };
    (
        Table::from_content(content, Provenance::default()).unwrap(),
        input,
    )
}

fn top16_rows() -> scatterbake_table::ValueEncoding {
    scatterbake_table::ValueEncoding::Top16 {
        predictor: Some(scatterbake_table::PreviousRow {
            stride: 8,
            block: 40,
        }),
    }
}

/// 16-bit values round trip: the file is format 2.0, stored values are within 2^−9 relative of
/// the input, derived channels are exactly their definition on the stored values, and every
/// read (whole, one entry, verification, header only) agrees with the writer's table.
#[test]
fn top16_round_trip() {
    use scatterbake_table::{ReadLimits, read_header_only, verify_file};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.sbt");
    for scale in [1.0f32, 3.7e-20, 2.1e15] {
        let (mut t, input) = polarised_table(top16_rows(), scale);
        write_table_atomic(&mut t, &path).unwrap();
        let b = std::fs::read(&path).unwrap();
        assert_eq!(&b[8..12], &[2, 0, 0, 0]);
        let r = Table::open(&path).unwrap();
        assert_eq!(r.header, t.header);
        assert_eq!(r.data, t.data);
        assert_eq!(r.header.layout.shape, vec![2, 5, 4, 2]);
        assert_eq!(r.header.layout.dtype, "f32-top16le");
        for (got, want) in r.data.chunks(4).zip(input.chunks(4)) {
            for c in [1, 2] {
                let rel = (got[c] as f64 - want[c] as f64).abs() / want[c] as f64;
                assert!(rel <= 1.0 / 512.0, "{} vs {}", got[c], want[c]);
            }
            let (p, q) = (got[1] as f64, got[2] as f64);
            assert_eq!(got[0], (0.5 * (p + q)) as f32);
            assert_eq!(got[3], ((p - q) / (p + q)) as f32);
        }
        let limits = ReadLimits::default();
        let e = Table::open_slice(&path, &[1], &limits).unwrap();
        assert_eq!(e.data, t.data[80..]);
        let one = Table::open_slice(&path, &[1, 2, 3], &limits).unwrap();
        assert_eq!(one.data, t.data[124..128]);
        assert_eq!(verify_file(&path, &limits).unwrap().header, t.header);
        assert_eq!(read_header_only(&path).unwrap(), t.header);
        // Written again, the same bytes.
        assert_eq!(r.clone().to_bytes().unwrap(), b);
    }
}

/// The memory limit is the decoded values': 160 values of 4 bytes, from an 80-value payload of
/// 2 bytes each.
#[test]
fn top16_limit_is_the_decoded_size() {
    let (mut t, _) = polarised_table(top16_rows(), 1.0);
    let b = t.to_bytes().unwrap();
    let limits = |max_payload_bytes| scatterbake_table::ReadLimits { max_payload_bytes };
    assert!(Table::from_bytes_with_limits(&b, Path::new("t"), &limits(640)).is_ok());
    let e = Table::from_bytes_with_limits(&b, Path::new("t"), &limits(639)).unwrap_err();
    assert!(e.to_string().contains("decoded values (640 bytes"), "{e}");
}

/// Tables without 16-bit values or derived channels are still written as 1.0, with no new
/// header field; derived channels alone make a 2.0 file of f32 values; the writer refuses
/// values a 16-bit code cannot hold.
#[test]
fn versions_and_writer_refusals() {
    let mut plain = sample_table();
    let b = plain.to_bytes().unwrap();
    assert_eq!(&b[8..12], &[1, 0, 0, 0]);
    let text = String::from_utf8_lossy(&b[56..]);
    assert!(!text.contains("predictor") && !text.contains("derived"));
    let (mut f32_derived, input) = polarised_table(Default::default(), 1.0);
    let b = f32_derived.to_bytes().unwrap();
    assert_eq!(&b[8..12], &[2, 0, 0, 0]);
    let r = Table::from_bytes(&b, Path::new("t")).unwrap();
    assert_eq!(r.data, f32_derived.data);
    assert_eq!(r.data[1], input[1]);
    for bad in [-1.0, f32::NAN, f32::INFINITY, f32::MAX] {
        let (t, mut input) = polarised_table(top16_rows(), 1.0);
        input[5] = bad;
        let content = TableContent {
            schema: t.header.schema.clone(),
            description: String::new(),
            axes: t.header.axes.clone(),
            channels: t.header.channels.clone(),
            attributes: Default::default(),
            data: input,
            encoding: top16_rows(),
        };
        let e = Table::from_content(content, Provenance::default()).unwrap_err();
        assert!(
            e.to_string().contains("cannot be stored as f32-top16le"),
            "{e}"
        );
    }
}
