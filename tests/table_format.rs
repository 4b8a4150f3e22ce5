//! Table format on the library's tables: version handling (newer minor with unknown fields,
//! newer major), the crafted corpus, declared sizes, tensor-train tables. The tests that need
//! only the format crate are in `table-format/tests/format.rs`.

mod common;

use scatterbake::table::{Table, TableError};
use std::path::Path;

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
    let dir = tempfile::tempdir().unwrap();
    let p = common::synthetic_tables(dir.path()).remove(0);
    let bytes = std::fs::read(&p).unwrap();
    let b = common::rewrite_table(&bytes, 1, 0, |h| {
        h["future_note"] = serde_json::json!("x");
    });
    let e = Table::from_bytes(&b, Path::new("t.sbt")).unwrap_err();
    assert!(matches!(e, TableError::BadHeader { .. }), "{e}");
    assert!(e.to_string().contains("`future_note`"), "{e}");
    // The same file as 1.1 reads.
    let b = common::rewrite_table(&bytes, 1, 1, |h| {
        h["future_note"] = serde_json::json!("x");
    });
    assert_eq!(
        Table::from_bytes(&b, Path::new("t.sbt")).unwrap().data,
        Table::open(&p).unwrap().data
    );
}

/// A newer major is refused on its version alone, before its header is interpreted (the crafted
/// 4.0 header has valid checksums but no `layout`), with an error naming the version.
#[test]
fn newer_major_with_valid_checksums_is_refused_naming_the_version() {
    let dir = tempfile::tempdir().unwrap();
    let p = common::synthetic_tables(dir.path()).remove(0);
    let newer = dir.path().join("v4.sbt");
    common::newer_major_copy(&p, &newer);
    let e = Table::open(&newer).unwrap_err();
    assert!(
        matches!(
            e,
            TableError::NewerMajor {
                major: 4,
                minor: 0,
                ..
            }
        ),
        "{e}"
    );
    let msg = e.to_string();
    assert!(msg.contains("4.0") && msg.contains("newer"), "{msg}");
    assert!(matches!(
        scatterbake::table::read_header_only(&newer).unwrap_err(),
        TableError::NewerMajor { major: 4, .. }
    ));
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

/// Bit patterns of lookups (NaN kept as its bits).
fn bits64(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// One entry opened alone (`Table::open_slice`, `Table::from_bytes_slice`) holds exactly that
/// entry's samples of the whole table, bit for bit; every axis stays, a fixed one holding its
/// chosen coordinate (and label) alone; lookups equal the whole table's at the fixed
/// coordinates, bit for bit.
#[test]
fn one_entry_reads_bit_for_bit() {
    use scatterbake::table::ReadLimits;
    let dir = tempfile::tempdir().unwrap();
    let p = common::entries::entries_table(dir.path());
    let bytes = std::fs::read(&p).unwrap();
    let whole = Table::open(&p).unwrap();
    let shape = whole.grid_shape();
    let nc = whole.header.channels.len();
    for entry in common::entries::entries() {
        let t = Table::open_slice(&p, &entry, &ReadLimits::default()).unwrap();
        let count = shape[entry.len()..].iter().product::<usize>() * nc;
        let first = entry
            .iter()
            .zip(&shape)
            .fold(0, |acc, (&i, &n)| acc * n + i)
            * count;
        let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&t.data),
            bits(&whole.data[first..first + count]),
            "{entry:?}"
        );
        let from_bytes =
            Table::from_bytes_slice(&bytes, &p, &entry, &ReadLimits::default()).unwrap();
        assert_eq!(bits(&from_bytes.data), bits(&t.data), "{entry:?}");
        assert_eq!(from_bytes.header, t.header);
        assert_eq!(t.header.payload, whole.header.payload);
        assert_eq!(t.header.layout.axis_order, whole.header.layout.axis_order);
        assert_eq!(t.axes().len(), whole.axes().len());
        let mut expect_shape = shape.clone();
        for (k, (a, b)) in t.axes().iter().zip(whole.axes()).enumerate() {
            assert_eq!((&a.name, &a.unit), (&b.name, &b.unit));
            if let Some(&i) = entry.get(k) {
                assert_eq!(a.len(), 1, "{entry:?} axis {}", a.name);
                assert_eq!(a.coord(0).to_bits(), b.coord(i).to_bits());
                assert_eq!(a.label(0), b.label(i));
                expect_shape[k] = 1;
            } else {
                assert_eq!(a, b);
            }
        }
        assert_eq!(t.grid_shape(), expect_shape);
        let coords = common::entries::lookup_point(&whole, &entry);
        assert_eq!(
            bits64(&t.sample(&coords).unwrap()),
            bits64(&whole.sample(&coords).unwrap()),
            "{entry:?} at {coords:?}"
        );
    }
}

/// A bad entry is refused before the payload is read, with an error naming the axis.
#[test]
fn bad_entry_is_refused_naming_the_axis() {
    use scatterbake::table::ReadLimits;
    let dir = tempfile::tempdir().unwrap();
    let p = common::entries::entries_table(dir.path());
    let limits = ReadLimits::default();
    for (entry, words) in [
        (vec![2], vec!["index 2 of axis `radius`", "2 samples"]),
        (
            vec![0, 3],
            vec!["index 3 of axis `wavelength`", "indices 0 to 2"],
        ),
        (vec![1, 2, 2], vec!["axis `sun_elevation`"]),
        (vec![0, 0, 0, 7], vec!["axis `outgoing_polar`"]),
        (
            vec![0; 6],
            vec![
                "6 indices",
                "more than the table's axes",
                "radius, wavelength, sun_elevation, outgoing_polar, outgoing_azimuth",
            ],
        ),
    ] {
        let e = Table::open_slice(&p, &entry, &limits).unwrap_err();
        assert!(matches!(e, TableError::Entry { .. }), "{e}");
        let m = e.to_string();
        assert!(m.starts_with(&p.display().to_string()), "{m}");
        for w in words {
            assert!(m.contains(w), "{entry:?}: {m} lacks {w}");
        }
    }
}

/// The entry reader accepts and refuses the crafted corpus exactly as the whole-table reader,
/// with the same message (every rule applies to the whole file), and an accepted file's first
/// entry is the whole table's first entry; the payload limit bounds the whole payload for an
/// entry too.
#[test]
fn crafted_corpus_through_the_entry_reader() {
    use scatterbake::table::ReadLimits;
    let limits = ReadLimits::default();
    let mut wrong = Vec::new();
    for case in common::crafted::cases() {
        let path = Path::new(case.name);
        let whole = Table::from_bytes(&case.bytes, path);
        let first = Table::from_bytes_slice(&case.bytes, path, &[0], &limits);
        match (&whole, &first) {
            (Ok(w), Ok(f)) => {
                let n = f.data.len();
                let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                if bits(&w.data[..n]) != bits(&f.data) || w.data.len() % n != 0 {
                    wrong.push(format!("{}: the first entry differs", case.name));
                }
            }
            (Err(a), Err(b)) if a.to_string() == b.to_string() => {}
            _ => wrong.push(format!(
                "{}: whole {:?}, entry {:?}",
                case.name,
                whole.as_ref().map(|_| ()).map_err(|e| e.to_string()),
                first.as_ref().map(|_| ()).map_err(|e| e.to_string())
            )),
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    let dir = tempfile::tempdir().unwrap();
    let p = common::entries::entries_table(dir.path());
    let payload = scatterbake::table::read_header_only(&p)
        .unwrap()
        .payload
        .uncompressed_bytes;
    let small = ReadLimits {
        max_payload_bytes: payload - 4,
    };
    let e = Table::open_slice(&p, &[0, 0, 0], &small).unwrap_err();
    assert!(e.to_string().contains("exceeds the reader limit"), "{e}");
    let exact = ReadLimits {
        max_payload_bytes: payload,
    };
    assert!(Table::open_slice(&p, &[0, 0, 0], &exact).is_ok());
}

/// Format 2.0 (16-bit values, derived channels): each crafted file is accepted or refused as
/// marked by every read (whole table, one entry, verification), a refusal naming the file and
/// the rule; an accepted one reads the values of the writer's table, its entries the same
/// values as the whole table.
#[test]
fn top16_corpus_rust_reader() {
    let dir = tempfile::tempdir().unwrap();
    let want = common::crafted::top16_table().data;
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::top16_cases() {
        wrong.extend(misreads(dir.path(), &case, fragment, &want, false).1);
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The crafted `case` written into `dir`, and what the reads of it did wrong: the whole table,
/// entry 1, verification and (with `header_only`) `read_header_only`. A valid case must read
/// `want`, its entry the second half of it; an invalid one must be refused with an error
/// naming the file and holding `fragment`.
fn misreads(
    dir: &Path,
    case: &common::crafted::Case,
    fragment: &str,
    want: &[f32],
    header_only: bool,
) -> (std::path::PathBuf, Vec<String>) {
    use scatterbake::table::{ReadLimits, read_header_only, verify_file};
    let p = common::crafted::written(dir, case);
    let limits = ReadLimits::default();
    let mut reads = vec![
        Table::open(&p).map(|t| t.data),
        Table::open_slice(&p, &[1], &limits).map(|t| t.data),
        verify_file(&p, &limits).map(|_| Vec::new()),
    ];
    if header_only {
        reads.push(read_header_only(&p).map(|_| Vec::new()));
    }
    let mut wrong = Vec::new();
    for (k, r) in reads.into_iter().enumerate() {
        match (r, case.valid) {
            (Ok(data), true) => {
                let expect: &[f32] = match k {
                    0 => want,
                    1 => &want[want.len() / 2..],
                    _ => &[],
                };
                if data != expect {
                    wrong.push(format!("{} (read {k}): values differ", case.name));
                }
            }
            (Err(e), false) => {
                let msg = e.to_string();
                if !(msg.contains(case.name) && msg.contains(fragment)) {
                    wrong.push(format!("{} (read {k}): {msg}", case.name));
                }
            }
            (r, _) => wrong.push(format!("{} (read {k}): {:?}", case.name, r.map(|_| ()))),
        }
    }
    (p, wrong)
}

/// Format 3.0 (even-periodic axes): each crafted file is accepted or refused as marked by every
/// read (whole table, one entry, verification, header only), a refusal naming the file and the
/// rule; an accepted one reads the writer's values, and its azimuth is symmetric exactly when
/// the file is 3.x and declares it (in a 1.x or 2.x file `symmetry` is not a field: ignored,
/// whatever it holds): a lookup at 270° then folds to 90°, else clamps to 180°.
#[test]
fn symmetry_corpus_rust_reader() {
    let dir = tempfile::tempdir().unwrap();
    let want = common::crafted::symmetry_table().data;
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::symmetry_cases() {
        let (p, found) = misreads(dir.path(), &case, fragment, &want, true);
        wrong.extend(found);
        if !case.valid {
            continue;
        }
        let t = Table::open(&p).unwrap();
        let declared = case.bytes[8] >= 3 && case.name != "sym_format_3_without_symmetry";
        let folds = t.axes()[1].symmetry.is_some();
        let at = |x: f64| t.sample(&[450.0, x]).unwrap();
        let expect = if declared { at(90.0) } else { at(180.0) };
        if folds != declared || at(270.0) != expect {
            wrong.push(format!(
                "{}: symmetric {folds}, declared {declared}",
                case.name
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
