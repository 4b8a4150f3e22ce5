//! Table format: round trip, corruption detection, version handling, lookup API.

use proptest::prelude::*;
use scatterbake_table::{
    Axis, Channel, Provenance, Schema, Symmetry, Table, TableContent, TableError,
    write_table_atomic,
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

/// A newer major (4.0) is refused naming it; every minor of 1, 2 and 3 reads, a 3.0 file
/// without a symmetric axis as the same table.
#[test]
fn newer_major_is_refused_newer_minor_is_read() {
    let e = Table::from_bytes(&with_version(bytes(), 4, 0), Path::new("t.sbt")).unwrap_err();
    assert!(matches!(e, TableError::NewerMajor { major: 4, .. }), "{e}");
    assert!(e.to_string().contains("4.0 is newer"), "{e}");
    assert!(e.to_string().contains("supports 1.x to 3.x"), "{e}");
    for (major, minor) in [(1, 9), (2, 0), (2, 7), (3, 0), (3, 4)] {
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

/// Tables without a symmetric axis are written exactly as before format 3.0 existed: 1.0, and
/// 2.0 with derived channels or 16-bit values. The hashes are those of the bytes the writer
/// produced for these tables before it knew 3.0.
#[test]
fn tables_without_symmetry_are_written_as_before() {
    let sha = |mut t: Table| hex::encode(Sha256::digest(t.to_bytes().unwrap()));
    assert_eq!(
        sha(sample_table()),
        "3a152e211eaca95331581d93535b0c0334c13ae512aaade2a1421c3467022148"
    );
    assert_eq!(
        sha(polarised_table(Default::default(), 1.0).0),
        "9fd84c037d296f84e7a8a1ab8569d1b32877c767f12a2b5784b411b397f62a65"
    );
    assert_eq!(
        sha(polarised_table(top16_rows(), 1.0).0),
        "6c225812325da0e1104e4ea6a940018aa19fe13ce10a3cae5ca69114a43645d6"
    );
}

/// `polarised_table`'s grid with its azimuth axis even and periodic: 0, 45, …, 180° (uniform)
/// or 0, 10, 90, 170, 180° (explicit), period 360°.
fn symmetric_table(encoding: scatterbake_table::ValueEncoding, explicit: bool) -> Table {
    let (t, input) = polarised_table(encoding, 1.0);
    let azimuth = if explicit {
        Axis::values(
            "outgoing_azimuth",
            "deg",
            vec![0.0, 10.0, 90.0, 170.0, 180.0],
        )
    } else {
        Axis::uniform("outgoing_azimuth", "deg", 0.0, 45.0, 5)
    };
    let mut axes = t.header.axes.clone();
    axes[2] = azimuth.with_symmetry(Symmetry::EvenPeriodic { period: 360.0 });
    axes[1] = Axis::uniform("outgoing_polar", "deg", 0.0, 45.0, 4);
    let content = TableContent {
        schema: t.header.schema.clone(),
        description: String::new(),
        axes,
        channels: t.header.channels.clone(),
        attributes: Default::default(),
        data: input,
        encoding,
    };
    Table::from_content(content, Provenance::default()).unwrap()
}

/// A table with a symmetric axis is written as 3.0 (also with 16-bit values and derived
/// channels) and reads back with its symmetry; lookups fold: the value at x equals the value at
/// −x, 360° − x and x + 360° bit for bit, a stored coordinate returns the stored value, and
/// the fold is r = fmod(|x|, P), P − r beyond P/2.
#[test]
fn symmetric_axis_is_format_3_and_lookups_fold() {
    for (encoding, explicit) in [
        (scatterbake_table::ValueEncoding::F32, false),
        (scatterbake_table::ValueEncoding::F32, true),
        (top16_rows(), false),
    ] {
        let mut t = symmetric_table(encoding, explicit);
        let b = t.to_bytes().unwrap();
        assert_eq!(&b[8..12], &[3, 0, 0, 0]);
        let r = Table::from_bytes(&b, Path::new("t.sbt")).unwrap();
        assert_eq!(r.header, t.header);
        assert_eq!(r.data, t.data);
        let az = &r.axes()[2];
        assert_eq!(az.symmetry, Some(Symmetry::EvenPeriodic { period: 360.0 }));
        let bits = |x: f64, y: f64| -> Vec<u64> {
            let v = r.sample(&[470.0, 67.5, x]).unwrap();
            assert_eq!(v, r.sample(&[470.0, 67.5, y]).unwrap());
            v.iter().map(|v| v.to_bits()).collect()
        };
        for x in [0.0, 3.5, 37.25, 90.0, 100.125, 179.75, 180.0] {
            let at = bits(x, x);
            for y in [-x, 360.0 - x, x + 360.0, x - 720.0, 1080.0 - x] {
                assert_eq!(bits(y, y), at, "{x} vs {y}");
            }
        }
        // Where 360° − x and x + 360° round, −x still folds to x's bits (x − P·floor(x/P)
        // would give 0.10000000000002274 for −0.1).
        for x in [0.1, 100.3, 1e-17, 179.99999999999997] {
            assert_eq!(bits(-x, -x), bits(x, x), "{x}");
            assert_eq!(az.fold(-x).to_bits(), x.to_bits(), "{x}");
        }
        // Beyond the last stored azimuth the lookup folds back, it does not clamp at 180°.
        let beyond = r.sample(&[450.0, 0.0, 185.0]).unwrap();
        assert_eq!(beyond, r.sample(&[450.0, 0.0, 175.0]).unwrap());
        assert_ne!(beyond, r.sample(&[450.0, 0.0, 180.0]).unwrap());
        // A stored coordinate returns the stored value, from either side of the period.
        let coords = az.coords();
        for (k, &x) in coords.iter().enumerate() {
            let stored = r.at(&[1, 2, k], 1);
            for y in [x, -x, 360.0 - x, x + 360.0] {
                assert_eq!(
                    r.sample(&[650.0, 90.0, y]).unwrap()[1],
                    f64::from(stored),
                    "{y}"
                );
            }
        }
    }
    let s = Symmetry::EvenPeriodic { period: 360.0 };
    for (x, want) in [
        (-37.25, 37.25),
        (397.25, 37.25),
        (322.75, 37.25),
        (180.0, 180.0),
        (360.0, 0.0),
        (540.0, 180.0),
        (-0.0, 0.0),
        (1e300, (1e300f64 % 360.0).min(360.0 - 1e300f64 % 360.0)),
    ] {
        assert_eq!(s.fold(x).to_bits(), want.to_bits(), "{x}");
    }
    assert!(s.fold(f64::INFINITY).is_nan());
    let t = symmetric_table(Default::default(), false);
    let e = t.sample(&[400.0, 0.0, f64::INFINITY]).unwrap_err();
    assert!(e.to_string().contains("`outgoing_azimuth`"), "{e}");
    assert!(t.sample(&[400.0, 0.0, f64::NAN]).is_err());
    // An infinite coordinate of an ordinary axis still clamps.
    assert!(t.sample(&[f64::INFINITY, 0.0, 0.0]).is_ok());
}

/// One entry of a table keeps the symmetry of the axes it leaves free and drops it from a
/// fixed one (one sample, constant); the writer refuses a symmetric axis that breaks a rule.
#[test]
fn symmetric_axis_in_entries_and_writer_refusals() {
    use scatterbake_table::ReadLimits;
    let mut t = symmetric_table(Default::default(), false);
    let b = t.to_bytes().unwrap();
    let e = Table::from_bytes_slice(&b, Path::new("t"), &[1, 2], &ReadLimits::default()).unwrap();
    assert_eq!(e.axes()[2].symmetry, t.axes()[2].symmetry);
    let e =
        Table::from_bytes_slice(&b, Path::new("t"), &[1, 2, 3], &ReadLimits::default()).unwrap();
    assert_eq!(e.axes()[2].symmetry, None);
    assert_eq!(e.header.format_version(), (2, 0));
    assert_eq!(
        e.sample(&[0.0, 0.0, 1e9]).unwrap(),
        t.sample(&[650.0, 90.0, 135.0]).unwrap()
    );
    let (base, input) = polarised_table(Default::default(), 1.0);
    for (axis, rule) in [
        (
            Axis::uniform("a", "deg", 0.0, 45.0, 4),
            "ends at half its period",
        ),
        (Axis::uniform("a", "deg", 1.0, 44.75, 4), "starts at 0"),
        (Axis::values("a", "deg", vec![0.0, 90.0, 170.0, 180.0]), ""),
    ] {
        for (period, fragment) in [
            (360.0, rule),
            (-360.0, "not finite and > 0"),
            (f64::NAN, "not finite"),
        ] {
            let mut axes = base.header.axes.clone();
            axes[2] = axis
                .clone()
                .with_symmetry(Symmetry::EvenPeriodic { period });
            let content = TableContent {
                schema: base.header.schema.clone(),
                description: String::new(),
                axes,
                channels: base.header.channels.clone(),
                attributes: Default::default(),
                data: input.clone(),
                encoding: Default::default(),
            };
            match Table::from_content(content, Provenance::default()) {
                Ok(_) => assert!(fragment.is_empty(), "{period} {axis:?} accepted"),
                Err(e) => assert!(
                    !fragment.is_empty() && e.to_string().contains(fragment),
                    "{period}: {e}"
                ),
            }
        }
    }
}
