//! A corpus of crafted `.sbt` files: each breaks one rule of `docs/table-format.md` (or sits
//! exactly on a limit) with every checksum recomputed, so the reader must catch it by the rule
//! itself. Every reader (Rust, C, Python) must accept exactly the files marked valid and refuse
//! the others with an error, never a crash.

use scatterbake::table::{Axis, Channel, Provenance, Schema, Table, TableContent};
use serde_json::{Value, json};
use sha2::{Digest, Sha256};

/// One crafted file.
pub struct Case {
    pub name: &'static str,
    pub bytes: Vec<u8>,
    /// True when every reader must accept it.
    pub valid: bool,
}

/// What a reader's run on a crafted case did wrong, if anything (the line to report): a valid
/// case must exit 0 and pass `accepted` (e.g. the values it dumped are the expected ones); an
/// invalid one must exit 3 with a message naming the file and holding every fragment of `rule`.
pub fn misread(
    case: &Case,
    out: &std::process::Output,
    accepted: impl FnOnce() -> bool,
    rule: &[&str],
) -> Option<String> {
    let code = out.status.code();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let ok = match case.valid {
        true => code == Some(0) && accepted(),
        false => {
            code == Some(3) && stderr.contains(case.name) && rule.iter().all(|f| stderr.contains(f))
        }
    };
    (!ok).then(|| {
        format!(
            "{}: valid={} exit {code:?}: {stderr}",
            case.name, case.valid
        )
    })
}

/// `case` written into `dir` as `NAME.sbt`.
pub fn written(dir: &std::path::Path, case: &Case) -> std::path::PathBuf {
    let p = dir.join(format!("{}.sbt", case.name));
    std::fs::write(&p, &case.bytes).unwrap();
    p
}

fn sha_hex(b: &[u8]) -> String {
    hex::encode(Sha256::digest(b))
}

/// zstd frame with content size and checksum (as the writer makes it).
pub fn zstd_frame(raw: &[u8]) -> Vec<u8> {
    zstd::bulk::compress(raw, 3).unwrap()
}

/// A zstd frame that does not declare its content size.
fn zstd_frame_unsized(raw: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = zstd::stream::Encoder::new(Vec::new(), 3).unwrap();
    e.include_contentsize(false).unwrap();
    e.write_all(raw).unwrap();
    e.finish().unwrap()
}

/// Preamble (with a correct header checksum) + header bytes + payload bytes.
pub fn assemble(major: u16, minor: u16, flags: u32, header: &[u8], payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(b"SBTABLE\0");
    out.extend_from_slice(&major.to_le_bytes());
    out.extend_from_slice(&minor.to_le_bytes());
    out.extend_from_slice(&flags.to_le_bytes());
    out.extend_from_slice(&(header.len() as u64).to_le_bytes());
    let mut h = Sha256::new();
    h.update(&out[..24]);
    h.update(header);
    out.extend_from_slice(&h.finalize());
    out.extend_from_slice(header);
    out.extend_from_slice(payload);
    out
}

/// Fill the payload section of `header` for these payload bytes (sizes and checksums).
pub fn set_payload(header: &mut Value, raw: &[u8], compressed: &[u8]) {
    header["payload"] = json!({
        "compression": "zstd",
        "compressed_bytes": compressed.len(),
        "uncompressed_bytes": raw.len(),
        "sha256_compressed": sha_hex(compressed),
        "sha256_uncompressed": sha_hex(raw),
    });
}

/// Base table: axes `wavelength` (values 400, 500, 600 nm) and `scattering_angle` (uniform
/// 0, 90, 180 deg), channels `phase` and `dolp`.
pub fn base_header() -> Value {
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("crafted", 1),
        description: "crafted test table".into(),
        axes: vec![
            Axis::values("wavelength", "nm", vec![400.0, 500.0, 600.0]),
            Axis::uniform("scattering_angle", "deg", 0.0, 90.0, 3),
        ],
        channels: vec![
            Channel::new("phase", "1/sr", "test"),
            Channel::new("dolp", "1", "test"),
        ],
        attributes: serde_json::Map::new(),
        data: (0..18).map(|i| i as f32 * 0.25).collect(),
    };
    let mut t = Table::from_content(content, Provenance::default()).unwrap();
    let bytes = t.to_bytes().unwrap();
    let hlen = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[56..56 + hlen]).unwrap()
}

fn floats(n: usize, f: impl Fn(usize) -> f32) -> Vec<u8> {
    (0..n).flat_map(|i| f(i).to_le_bytes()).collect()
}

/// A file from a header (payload section filled in for `raw`), with `tweak` applied last.
fn file_with(mut header: Value, raw: &[u8], tweak: impl FnOnce(&mut Value)) -> Vec<u8> {
    let c = zstd_frame(raw);
    set_payload(&mut header, raw, &c);
    tweak(&mut header);
    assemble(1, 0, 0, &serde_json::to_vec(&header).unwrap(), &c)
}

/// Header with its payload filled in, as text, for textual edits.
fn header_text(raw: &[u8]) -> (String, Vec<u8>) {
    let mut h = base_header();
    let c = zstd_frame(raw);
    set_payload(&mut h, raw, &c);
    (serde_json::to_string(&h).unwrap(), c)
}

fn base_raw() -> Vec<u8> {
    floats(18, |i| i as f32 * 0.25)
}

/// Set the axes (and the layout that goes with them) of a header.
fn set_axes(h: &mut Value, axes: Value, channels: usize) {
    let mut shape: Vec<Value> = axes
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            let p = &a["points"];
            if let Some(v) = p.get("values") {
                json!(v.as_array().unwrap().len())
            } else {
                p["uniform"]["count"].clone()
            }
        })
        .collect();
    shape.push(json!(channels));
    if let Some(c) = h["channels"].as_array_mut() {
        c.truncate(channels);
    }
    let mut order: Vec<Value> = axes
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["name"].clone())
        .collect();
    order.push(json!("channel"));
    h["axes"] = axes;
    h["layout"]["shape"] = json!(shape);
    h["layout"]["axis_order"] = json!(order);
}

fn values_axis(name: &str, v: Value) -> Value {
    json!({"name": name, "unit": "1", "points": {"values": v}})
}

fn uniform_axis(name: &str, start: Value, step: Value, count: Value) -> Value {
    json!({"name": name, "unit": "1", "points": {"uniform": {"start": start, "step": step, "count": count}}})
}

/// One axis `x` replaced in the base table (the other axis and the channels stay).
fn with_first_axis(axis: Value, n: usize) -> Vec<u8> {
    let mut h = base_header();
    let second = h["axes"][1].clone();
    set_axes(&mut h, json!([axis, second]), 2);
    file_with(h, &floats(n * 3 * 2, |i| i as f32), |_| {})
}

/// Adds one case: its name, bytes and whether a reader must accept it.
type Add<'a> = dyn FnMut(&'static str, Vec<u8>, bool) + 'a;

/// Every crafted case.
pub fn cases() -> Vec<Case> {
    let mut v = Vec::new();
    let mut add =
        |name: &'static str, bytes: Vec<u8>, valid: bool| v.push(Case { name, bytes, valid });
    let raw = base_raw();
    add("valid_base", file_with(base_header(), &raw, |_| {}), true);
    structure_cases(&mut add);
    size_cases(&raw, &mut add);
    preamble_cases(&raw, &mut add);
    payload_frame_cases(&raw, &mut add);
    json_cases(&raw, &mut add);
    field_shape_cases(&raw, &mut add);
    v
}

/// Structure: axes and channels, and the axis count at and over the limit.
fn structure_cases(add: &mut Add) {
    let mut h = base_header();
    set_axes(&mut h, json!([]), 2);
    add("no_axes", file_with(h, &floats(2, |_| 1.0), |_| {}), false);
    add(
        "empty_values_axis",
        with_first_axis(values_axis("x", json!([])), 0),
        false,
    );
    add(
        "uniform_count_zero",
        with_first_axis(uniform_axis("x", json!(0.0), json!(1.0), json!(0)), 0),
        false,
    );
    let mut h = base_header();
    let axes = h["axes"].clone();
    set_axes(&mut h, axes, 0);
    h["channels"] = json!([]);
    add("no_channels", file_with(h, &[], |_| {}), false);
    add(
        "values_repeated",
        with_first_axis(values_axis("x", json!([1.0, 1.0, 2.0])), 3),
        false,
    );
    add(
        "values_decreasing",
        with_first_axis(values_axis("x", json!([3.0, 2.0, 1.0])), 3),
        false,
    );
    add(
        "values_single",
        with_first_axis(values_axis("x", json!([5.0])), 1),
        true,
    );
    add(
        "uniform_step_zero",
        with_first_axis(uniform_axis("x", json!(0.0), json!(0.0), json!(3)), 3),
        false,
    );
    add(
        "uniform_step_negative",
        with_first_axis(uniform_axis("x", json!(0.0), json!(-1.0), json!(3)), 3),
        false,
    );
    add(
        "uniform_overflows_to_inf",
        with_first_axis(uniform_axis("x", json!(1e308), json!(1e308), json!(3)), 3),
        false,
    );
    add(
        "uniform_step_below_resolution",
        with_first_axis(uniform_axis("x", json!(1e16), json!(0.5), json!(3)), 3),
        false,
    );
    add(
        "uniform_count_string",
        with_first_axis(uniform_axis("x", json!(0.0), json!(1.0), json!("3")), 3),
        false,
    );
    add(
        "uniform_count_float",
        with_first_axis(uniform_axis("x", json!(0.0), json!(1.0), json!(3.0)), 3),
        false,
    );
    add(
        "uniform_count_negative",
        with_first_axis(uniform_axis("x", json!(0.0), json!(1.0), json!(-3)), 3),
        false,
    );
    add(
        "both_values_and_uniform",
        with_first_axis(
            json!({"name": "x", "unit": "1", "points": {"values": [0.0, 1.0, 2.0],
                   "uniform": {"start": 0.0, "step": 1.0, "count": 3}}}),
            3,
        ),
        false,
    );
    // Axis count at and over the limit.
    let many = |n: usize, len: usize| {
        let mut h = base_header();
        let axes: Vec<Value> = (0..n)
            .map(|i| {
                values_axis(
                    &format!("a{i}"),
                    json!((0..len).map(|k| k as f64).collect::<Vec<_>>()),
                )
            })
            .collect();
        set_axes(&mut h, json!(axes), 1);
        let count = len.pow(n as u32);
        file_with(h, &floats(count, |i| (i % 7) as f32), |_| {})
    };
    add("axes_16_of_2", many(16, 2), true);
    add("axes_17_of_1", many(17, 1), false);
}

/// Sizes.
fn size_cases(raw: &[u8], add: &mut Add) {
    add(
        "shape_overflows_u64",
        file_with(base_header(), raw, |h| {
            let ax = json!([
                uniform_axis("x", json!(0.0), json!(1.0), json!(1u64 << 40)),
                uniform_axis("y", json!(0.0), json!(1.0), json!(1u64 << 40))
            ]);
            set_axes(h, ax, 2);
            h["payload"]["uncompressed_bytes"] = json!(0);
        }),
        false,
    );
    add(
        "declares_1tib",
        file_with(base_header(), raw, |h| {
            let ax = json!([uniform_axis("x", json!(0.0), json!(1.0), json!(1u64 << 38))]);
            set_axes(h, ax, 1);
            h["payload"]["uncompressed_bytes"] = json!(1u64 << 40);
        }),
        false,
    );
    add(
        "declares_1gib_backed_by_18_floats",
        file_with(base_header(), raw, |h| {
            let ax = json!([uniform_axis("x", json!(0.0), json!(1.0), json!(1u64 << 28))]);
            set_axes(h, ax, 1);
            h["payload"]["uncompressed_bytes"] = json!(1u64 << 30);
        }),
        false,
    );
    add(
        "uncompressed_bytes_disagree_with_shape",
        file_with(base_header(), raw, |h| {
            h["payload"]["uncompressed_bytes"] = json!(76);
        }),
        false,
    );
    add(
        "shape_disagrees_with_axes",
        file_with(base_header(), raw, |h| {
            h["layout"]["shape"] = json!([2, 3, 3]);
        }),
        false,
    );
    add(
        "axis_order_disagrees",
        file_with(base_header(), raw, |h| {
            h["layout"]["axis_order"] = json!(["scattering_angle", "wavelength", "channel"]);
        }),
        false,
    );
    add(
        "compressed_bytes_overflow",
        file_with(base_header(), raw, |h| {
            h["payload"]["compressed_bytes"] = json!(u64::MAX - 8);
        }),
        false,
    );
}

/// Preamble.
fn preamble_cases(raw: &[u8], add: &mut Add) {
    let (text, c) = header_text(raw);
    add(
        "flags_nonzero",
        assemble(1, 0, 1, text.as_bytes(), &c),
        false,
    );
    add(
        "flags_high_bit",
        assemble(1, 0, 1 << 31, text.as_bytes(), &c),
        false,
    );
    add("major_0", assemble(0, 0, 0, text.as_bytes(), &c), false);
    add("major_4", assemble(4, 0, 0, text.as_bytes(), &c), false);
    add(
        "minor_7_valid",
        assemble(1, 7, 0, text.as_bytes(), &c),
        true,
    );
    let mut f = assemble(1, 0, 0, text.as_bytes(), &c);
    f[16..24].copy_from_slice(&u64::MAX.to_le_bytes());
    add("header_len_u64_max", f, false);
    let mut f = assemble(1, 0, 0, text.as_bytes(), &c);
    f[16..24].copy_from_slice(&(1u64 << 30).to_le_bytes());
    add("header_len_1gib_in_small_file", f, false);
    add("zeros_1mib", vec![0u8; 1 << 20], false);
    add("empty_file", Vec::new(), false);
    add("magic_only", b"SBTABLE\0".to_vec(), false);
    let mut f = assemble(1, 0, 0, text.as_bytes(), &c);
    f.extend_from_slice(b"x");
    add("trailing_byte", f, false);
    let f = assemble(1, 0, 0, text.as_bytes(), &c);
    add("truncated_payload", f[..f.len() - 1].to_vec(), false);
}

/// Payload frames.
fn payload_frame_cases(raw: &[u8], add: &mut Add) {
    let two = [zstd_frame(&raw[..36]), zstd_frame(&raw[36..])].concat();
    add(
        "two_zstd_frames",
        file_with(base_header(), raw, |h| {
            h["payload"]["compressed_bytes"] = json!(two.len());
            h["payload"]["sha256_compressed"] = json!(sha_hex(&two));
        }),
        false,
    );
    let mut h = base_header();
    set_payload(&mut h, raw, &two);
    add(
        "two_zstd_frames_payload",
        assemble(1, 0, 0, &serde_json::to_vec(&h).unwrap(), &two),
        false,
    );
    let one_plus = [zstd_frame(raw), zstd_frame(&[])].concat();
    let mut h = base_header();
    set_payload(&mut h, raw, &one_plus);
    add(
        "frame_then_empty_frame",
        assemble(1, 0, 0, &serde_json::to_vec(&h).unwrap(), &one_plus),
        false,
    );
    let no_size = zstd_frame_unsized(raw);
    let mut h = base_header();
    set_payload(&mut h, raw, &no_size);
    add(
        "frame_without_content_size",
        assemble(1, 0, 0, &serde_json::to_vec(&h).unwrap(), &no_size),
        false,
    );
    let mut skippable = vec![0x50, 0x2A, 0x4D, 0x18, 4, 0, 0, 0, 1, 2, 3, 4];
    skippable.extend_from_slice(&zstd_frame(raw));
    let mut h = base_header();
    set_payload(&mut h, raw, &skippable);
    add(
        "skippable_frame_first",
        assemble(1, 0, 0, &serde_json::to_vec(&h).unwrap(), &skippable),
        false,
    );
    let short = zstd_frame(&raw[..64]);
    let mut h = base_header();
    set_payload(&mut h, raw, &short);
    add(
        "frame_content_shorter_than_header",
        assemble(1, 0, 0, &serde_json::to_vec(&h).unwrap(), &short),
        false,
    );
    add(
        "sha256_uppercase",
        file_with(base_header(), raw, |h| {
            let s = h["payload"]["sha256_compressed"]
                .as_str()
                .unwrap()
                .to_uppercase();
            h["payload"]["sha256_compressed"] = json!(s);
        }),
        false,
    );
    add(
        "nan_and_negative_values",
        file_with(
            base_header(),
            &floats(18, |i| match i % 4 {
                0 => f32::NAN,
                1 => -1.0,
                2 => f32::INFINITY,
                _ => 1.0,
            }),
            |_| {},
        ),
        true,
    );
}

/// JSON.
/// Fields of the right name in the wrong shape.
fn field_shape_cases(raw: &[u8], add: &mut Add) {
    // A typed decoder would build the uniform axis from `[start, step, count]`.
    let mut h = base_header();
    h["axes"][1]["points"]["uniform"] = json!([0.0, 90.0, 3]);
    add("uniform_as_array", file_with(h, raw, |_| {}), false);
    let mut h = base_header();
    h["provenance"]
        .as_object_mut()
        .unwrap()
        .remove("parameters");
    add(
        "provenance_parameters_missing",
        file_with(h, raw, |_| {}),
        false,
    );
}

fn json_cases(raw: &[u8], add: &mut Add) {
    let (text, c) = header_text(raw);
    let dup = text.replacen('{', "{\"description\":\"first\",", 1);
    add(
        "duplicate_top_key",
        assemble(1, 0, 0, dup.as_bytes(), &c),
        false,
    );
    let dup = text.replace("\"attributes\":{}", "\"attributes\":{\"a\":1,\"a\":2}");
    assert_ne!(dup, text);
    add(
        "duplicate_attribute_key",
        assemble(1, 0, 0, dup.as_bytes(), &c),
        false,
    );
    let deep = |n: usize| {
        text.replace(
            "\"attributes\":{}",
            &format!(
                "\"attributes\":{{\"d\":{}{}}}",
                "[".repeat(n),
                "]".repeat(n)
            ),
        )
    };
    // Depth counts the top-level object and `attributes`: 62 arrays make 64 levels.
    add(
        "nesting_64",
        assemble(1, 0, 0, deep(62).as_bytes(), &c),
        true,
    );
    add(
        "nesting_65",
        assemble(1, 0, 0, deep(63).as_bytes(), &c),
        false,
    );
    add(
        "nesting_100000",
        assemble(1, 0, 0, deep(100_000).as_bytes(), &c),
        false,
    );
    let mut bad_utf8 = text.clone().into_bytes();
    let at = text.find("crafted test table").unwrap();
    bad_utf8[at] = 0xFF;
    add("header_not_utf8", assemble(1, 0, 0, &bad_utf8, &c), false);
    let sur = text.replace("crafted test table", "\\ud800");
    add(
        "lone_surrogate",
        assemble(1, 0, 0, sur.as_bytes(), &c),
        false,
    );
    let nan = text.replace("[400.0,500.0,600.0]", "[NaN,500.0,600.0]");
    assert_ne!(nan, text);
    add("nan_literal", assemble(1, 0, 0, nan.as_bytes(), &c), false);
    let inf = text.replace("[400.0,500.0,600.0]", "[400.0,500.0,1e999]");
    add("number_1e999", assemble(1, 0, 0, inf.as_bytes(), &c), false);
    add(
        "header_not_object",
        assemble(1, 0, 0, b"[1,2,3]", &c),
        false,
    );
    add("header_empty", assemble(1, 0, 0, b"", &c), false);
    add(
        "header_trailing_garbage",
        assemble(1, 0, 0, format!("{text} x").as_bytes(), &c),
        false,
    );
    add(
        "missing_payload_field",
        file_with(base_header(), raw, |h| {
            h.as_object_mut().unwrap().remove("payload");
        }),
        false,
    );
    add(
        "schema_version_2_pow_32",
        file_with(base_header(), raw, |h| {
            h["schema"]["version"] = json!(1u64 << 32)
        }),
        false,
    );
    add(
        "channel_name_number",
        file_with(base_header(), raw, |h| h["channels"][0]["name"] = json!(7)),
        false,
    );
    add(
        "unknown_top_field_1_0",
        file_with(base_header(), raw, |h| h["extra"] = json!(1)),
        false,
    );
    let mut h = base_header();
    set_payload(&mut h, raw, &c);
    h["extra"] = json!({"nested": [1, 2]});
    add(
        "unknown_top_field_1_1",
        assemble(1, 1, 0, &serde_json::to_vec(&h).unwrap(), &c),
        true,
    );
}

/// A small valid tensor-train table (`fur-medulla-tt/1`) of a 3-D channel, with the dense
/// values it must reconstruct to (within the f32 core rounding).
pub fn tensor_train_table() -> (Table, Vec<f32>) {
    let (n0, n1, n2) = (4, 3, 5);
    let mut data = Vec::new();
    for i in 0..n0 {
        for j in 0..n1 {
            for k in 0..n2 {
                let (x, y, z) = (i as f32, j as f32, k as f32);
                data.push((1.0 + x) * (0.5 + y) * (0.3 * z).cos() + 0.1 * x * (z + 1.0));
            }
        }
    }
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("fur-medulla-azimuthal", 1),
        description: "crafted tensor-train source".into(),
        axes: vec![
            Axis::values("sigma", "1", vec![0.0, 1.0, 2.5, 4.0]),
            Axis::uniform("g", "1", 0.0, 0.4, 3),
            Axis::uniform("phi", "deg", -144.0, 72.0, 5),
        ],
        channels: vec![Channel::new("energy", "1", "test")],
        attributes: serde_json::Map::new(),
        data: data.clone(),
    };
    let (tt, _) = scatterbake::fur::tt::compress_table(&content, "energy", 1e-6, 16).unwrap();
    (
        Table::from_content(tt, Provenance::default()).unwrap(),
        data,
    )
}

/// Tensor-train tables that are valid `.sbt` files (every format reader opens them) but break
/// one rule of the tensor-train layout (`docs/table-format.md`, "Tensor-train tables"): every
/// reader that reconstructs (Rust `Table::open_reconstructed`, C `sbt_open_reconstructed`,
/// Python `open_table`) must refuse them with an error containing "tensor-train table is not
/// valid" and the case's fragment of the rule, and accept the valid one.
pub fn tensor_train_cases() -> Vec<(Case, &'static str)> {
    let (base, _) = tensor_train_table();
    let mut edits = tt_rank_edits();
    edits.extend(tt_layout_edits());
    edits.extend(tt_cost_edits());
    edits
        .into_iter()
        .map(|(name, valid, fragment, edit)| {
            let mut t = base.clone();
            edit(&mut t);
            let bytes = t.to_bytes().unwrap();
            (Case { name, bytes, valid }, fragment)
        })
        .collect()
}

/// One edit of the valid tensor-train table: name, whether it stays valid, the fragment of the
/// rule a reader's error must name, the edit.
type TtEdit = (&'static str, bool, &'static str, fn(&mut Table));

fn set_attr(t: &mut Table, k: &str, v: Value) {
    t.header.attributes.insert(k.into(), v);
}

fn tt_ranks(t: &Table) -> Vec<u64> {
    t.header.attributes["ranks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect()
}

/// The valid table and edits of its ranks.
fn tt_rank_edits() -> Vec<TtEdit> {
    vec![
        ("tt_valid", true, "", |_| {}),
        (
            "tt_ranks_one_short",
            false,
            "inconsistent ranks/dims",
            |t| {
                let mut r = tt_ranks(t);
                r.pop();
                set_attr(t, "ranks", json!(r));
            },
        ),
        ("tt_last_rank_not_one", false, "first and last rank", |t| {
            let mut r = tt_ranks(t);
            *r.last_mut().unwrap() = 2;
            set_attr(t, "ranks", json!(r));
        }),
        (
            "tt_inner_rank_changed",
            false,
            "inconsistent ranks/dims",
            |t| {
                let mut r = tt_ranks(t);
                r[1] += 1;
                set_attr(t, "ranks", json!(r));
            },
        ),
        (
            "tt_rank_exceeds_unfolding",
            false,
            "exceeds its unfolding",
            |t| {
                let mut r = tt_ranks(t);
                r[1] = 1_000_000_000;
                set_attr(t, "ranks", json!(r));
            },
        ),
    ]
}

/// Edits of the dims, offsets, source axes, values and other attributes.
fn tt_layout_edits() -> Vec<TtEdit> {
    vec![
        (
            "tt_dims_disagree_with_cores",
            false,
            "inconsistent ranks/dims",
            |t| {
                set_attr(t, "dims", json!([4, 3, 6]));
            },
        ),
        ("tt_dims_beyond_limit", false, "limit", |t| {
            set_attr(t, "dims", json!([1u64 << 40, 1u64 << 40, 5]));
        }),
        (
            "tt_dims_not_integers",
            false,
            "not a non-negative integer",
            |t| {
                set_attr(t, "dims", json!([4.5, 3, 5]));
            },
        ),
        ("tt_offsets_short_of_values", false, "core offsets", |t| {
            let mut o: Vec<u64> = t.header.attributes["core_offsets"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_u64().unwrap())
                .collect();
            *o.last_mut().unwrap() -= 1;
            set_attr(t, "core_offsets", json!(o));
        }),
        ("tt_source_axis_symmetry_ignored", true, "", |t| {
            // Not part of a source axis (the layout predates format 3.0): ignored, whatever
            // it holds.
            let mut a = t.header.attributes["source_axes"].clone();
            a[0]["symmetry"] = json!({"kind": "odd-periodic", "period": -1.0});
            set_attr(t, "source_axes", a);
        }),
        ("tt_source_axes_short", false, "source axes", |t| {
            let mut a = t.header.attributes["source_axes"]
                .as_array()
                .unwrap()
                .clone();
            a.pop();
            set_attr(t, "source_axes", json!(a));
        }),
        ("tt_nan_core_value", false, "non-finite", |t| {
            t.data[1] = f32::NAN;
        }),
        ("tt_negative_log_floor", false, "log_floor", |t| {
            set_attr(t, "log_floor", json!(-1.0));
        }),
        (
            "tt_missing_ranks",
            false,
            "missing attribute `ranks`",
            |t| {
                t.header.attributes.remove("ranks");
            },
        ),
    ]
}

/// Edits that make the reconstruction itself too costly or not finite: a 1 × 32768 × 32768
/// rank-1 train (a 4 GiB dense table, within the payload limit, whose output and f64
/// intermediates are not), a train of modest dense size whose ranks make it cost more
/// multiply-adds than the cap, and a logarithmic train whose exp overflows.
fn tt_cost_edits() -> Vec<TtEdit> {
    vec![
        (
            "tt_reconstruction_beyond_memory",
            false,
            "the reconstruction needs",
            |t| {
                zero_train(t, &[1, 32768, 32768], &[1, 1, 1, 1]);
            },
        ),
        (
            "tt_reconstruction_beyond_work",
            false,
            "multiply-adds, more than the limit",
            |t| {
                zero_train(t, &[128, 128, 128, 128], &[1, 64, 128, 64, 1]);
            },
        ),
        (
            "tt_reconstruction_not_finite",
            false,
            "is not finite",
            |t| {
                set_attr(t, "log_floor", json!(1e-30));
                let end = t.header.attributes["core_offsets"][1].as_u64().unwrap() as usize;
                for v in &mut t.data[..end] {
                    *v *= 1000.0;
                }
            },
        ),
    ]
}

/// Replace the valid table by a train of these dims and ranks whose cores are zeros (a valid
/// train of the zero tensor) and whose source axes are uniform of the dims' lengths.
fn zero_train(t: &mut Table, dims: &[usize], ranks: &[usize]) {
    let mut offsets = vec![0usize];
    for k in 0..dims.len() {
        offsets.push(offsets[k] + ranks[k] * dims[k] * ranks[k + 1]);
    }
    let n = offsets[dims.len()];
    let axes: Vec<Value> = dims
        .iter()
        .enumerate()
        .map(|(k, &count)| {
            json!({"name": format!("x{k}"), "unit": "1",
                   "points": {"uniform": {"start": 0.0, "step": 1.0, "count": count}}})
        })
        .collect();
    let mut attributes = t.header.attributes.clone();
    attributes.insert("dims".into(), json!(dims));
    attributes.insert("ranks".into(), json!(ranks));
    attributes.insert("core_offsets".into(), json!(offsets));
    attributes.insert("source_axes".into(), json!(axes));
    let content = TableContent {
        encoding: Default::default(),
        schema: t.header.schema.clone(),
        description: t.header.description.clone(),
        axes: vec![Axis::uniform("value", "1", 0.0, 1.0, n)],
        channels: t.header.channels.clone(),
        attributes,
        data: vec![0.0; n],
    };
    *t = Table::from_content(content, Provenance::default()).unwrap();
}

/// The valid format 2.0 table of [`top16_cases`]: axes `wavelength` (2) × `outgoing_polar` (3)
/// × `outgoing_azimuth` (4); channels `phase` (mean of `i_perp`, `i_par`), `i_perp`, `i_par`,
/// `dolp` (their normalised difference); `f32-top16le` with the previous-row predictor (one
/// polar row, 8 values; one entry, 24 values), as the compact ray-traced tables store them.
pub fn top16_table() -> Table {
    let n = 2 * 3 * 4;
    let mut data = Vec::with_capacity(4 * n);
    for i in 0..n {
        let (p, q) = (1.0 + 0.37 * i as f32, 0.5 + 0.11 * (i % 5) as f32);
        data.extend([0.0, p, q, 0.0]);
    }
    let axes = vec![
        Axis::values("wavelength", "nm", vec![400.0, 500.0]),
        Axis::values("outgoing_polar", "deg", vec![0.0, 90.0, 180.0]),
        Axis::uniform("outgoing_azimuth", "deg", 0.0, 90.0, 4),
    ];
    top16_table_with(axes, data)
}

/// A 16-bit table as the compact ray-traced tables store it: `axes` whose last two are the
/// polar and azimuth angles; channels `phase` (mean of `i_perp`, `i_par`), `i_perp`, `i_par`,
/// `dolp` (their normalised difference); `data` every channel of every point (the derived ones
/// are recomputed by the writer); the previous-row predictor over one polar row, restarting at
/// every entry (the last two axes).
pub fn top16_table_with(axes: Vec<Axis>, data: Vec<f32>) -> Table {
    use scatterbake::table::{PreviousRow, ValueEncoding};
    let row = 2 * axes[axes.len() - 1].len() as u64;
    let block = row * axes[axes.len() - 2].len() as u64;
    let content = TableContent {
        schema: Schema::new("crafted", 1),
        description: "crafted 16-bit table".into(),
        axes,
        channels: vec![
            Channel::derived("phase", "1/sr", "test", "mean", "i_perp", "i_par"),
            Channel::new("i_perp", "1/sr", "test"),
            Channel::new("i_par", "1/sr", "test"),
            Channel::derived(
                "dolp",
                "1",
                "test",
                "normalized-difference",
                "i_perp",
                "i_par",
            ),
        ],
        attributes: serde_json::Map::new(),
        data,
        encoding: ValueEncoding::Top16 {
            predictor: Some(PreviousRow { stride: row, block }),
        },
    };
    Table::from_content(content, Provenance::default()).unwrap()
}

/// Header and stored codes (after the predictor) of [`top16_table`].
fn top16_parts() -> (Value, Vec<u16>) {
    let bytes = top16_table().to_bytes().unwrap();
    let hlen = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    let header: Value = serde_json::from_slice(&bytes[56..56 + hlen]).unwrap();
    let raw = zstd::bulk::decompress(&bytes[56 + hlen..], 1 << 20).unwrap();
    let codes = raw
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    (header, codes)
}

/// One edit of the valid 16-bit table: name, whether it stays valid, the fragment of the rule a
/// reader's error must contain, and the edit of its version, header and stored codes.
type Top16Edit = (
    &'static str,
    bool,
    &'static str,
    fn(&mut (u16, u16), &mut Value, &mut Vec<u16>),
);

/// Format 2.0 files with 16-bit values and derived channels (`docs/table-format.md`, "16-bit
/// values"): the valid one and one case per rule, each with every checksum recomputed; a reader
/// of 2.0 accepts the valid ones and refuses the others with the rule's fragment.
pub fn top16_cases() -> Vec<(Case, &'static str)> {
    let mut edits = top16_layout_edits();
    edits.extend(top16_channel_edits());
    edits
        .into_iter()
        .map(|(name, valid, fragment, edit)| {
            let (mut header, mut codes) = top16_parts();
            let mut version = (2, 0);
            edit(&mut version, &mut header, &mut codes);
            let raw: Vec<u8> = codes.iter().flat_map(|c| c.to_le_bytes()).collect();
            let c = zstd_frame(&raw);
            let declared = header["payload"]["uncompressed_bytes"].clone();
            set_payload(&mut header, &raw, &c);
            if name == "top16_declared_values_over_limit" {
                header["payload"]["uncompressed_bytes"] = declared;
            }
            let header = serde_json::to_vec(&header).unwrap();
            let bytes = assemble(version.0, version.1, 0, &header, &c);
            (Case { name, bytes, valid }, fragment)
        })
        .collect()
}

fn predictor(h: &mut Value, stride: u64, block: u64) {
    h["layout"]["predictor"] = json!({"kind": "previous-row", "stride": stride, "block": block});
}

fn top16_layout_edits() -> Vec<Top16Edit> {
    vec![
        ("top16_valid", true, "", |_, _, _| {}),
        ("top16_newer_minor", true, "", |v, h, _| {
            *v = (2, 3);
            h["layout"]["future_field"] = json!(1);
        }),
        ("top16_without_predictor", true, "", |_, h, c| {
            h["layout"].as_object_mut().unwrap().remove("predictor");
            *c = top16_table()
                .data
                .chunks(4)
                .flat_map(|p| [p[1], p[2]])
                .map(|v| (v.to_bits() >> 15) as u16)
                .collect();
        }),
        (
            "top16_in_format_1",
            false,
            "unsupported layout",
            |v, _, _| *v = (1, 0),
        ),
        ("top16_stride_zero", false, "stride is 0", |_, h, _| {
            predictor(h, 0, 24)
        }),
        ("top16_stride_over_block", false, "exceeds", |_, h, _| {
            predictor(h, 48, 24)
        }),
        (
            "top16_block_not_multiple",
            false,
            "not a multiple",
            |_, h, _| predictor(h, 16, 24),
        ),
        (
            "top16_block_not_axes",
            false,
            "not the values of the last axes",
            |_, h, _| predictor(h, 4, 12),
        ),
        (
            "top16_predictor_kind",
            false,
            "is not `previous-row`",
            |_, h, _| h["layout"]["predictor"]["kind"] = json!("next-row"),
        ),
        (
            "top16_predictor_array",
            false,
            "must be an object",
            |_, h, _| h["layout"]["predictor"] = json!([8, 24]),
        ),
        (
            "top16_predictor_on_f32",
            false,
            "needs layout.dtype",
            |_, h, c| {
                h["layout"]["dtype"] = json!("f32le");
                *c = c.iter().flat_map(|&x| [x, 0]).collect();
            },
        ),
        (
            "top16_shape_counts_derived",
            false,
            "layout shape",
            |_, h, _| h["layout"]["shape"][3] = json!(4),
        ),
        (
            "top16_infinite_code",
            false,
            "not a finite value",
            |_, _, c| c[3] = 0xFF00,
        ),
        ("top16_nan_code", false, "not a finite value", |_, _, c| {
            c[0] = 0xFFFF
        }),
        (
            "top16_infinite_through_predictor",
            false,
            "not a finite value",
            |_, _, c| {
                // Stored value 8 (first of the second row) is its code minus that of value 0.
                c[8] = 0xFF00u16.wrapping_sub(c[0])
            },
        ),
        (
            "top16_declared_values_over_limit",
            false,
            "decoded values",
            |_, h, _| {
                // 2^28 points: a 1 GiB payload (within the 4 GiB limit) of 6 GiB decoded values.
                h["axes"][0]["points"] =
                    json!({"uniform": {"start": 0.0, "step": 1.0, "count": 1u64 << 25}});
                h["layout"]["shape"][0] = json!(1u64 << 25);
                h["payload"]["uncompressed_bytes"] = json!((1u64 << 25) * 24 * 2);
                for k in 0..2 {
                    let mut extra = h["channels"][0].clone();
                    extra["name"] = json!(format!("mean_{k}"));
                    h["channels"].as_array_mut().unwrap().push(extra);
                }
            },
        ),
    ]
}

fn top16_channel_edits() -> Vec<Top16Edit> {
    vec![
        ("top16_derived_on_f32", true, "", |_, h, c| {
            h["layout"]["dtype"] = json!("f32le");
            h["layout"].as_object_mut().unwrap().remove("predictor");
            *c = top16_table()
                .data
                .chunks(4)
                .flat_map(|p| [p[1], p[2]])
                .flat_map(|v| {
                    let b = v.to_bits();
                    [b as u16, (b >> 16) as u16]
                })
                .collect();
        }),
        (
            "top16_derived_of_derived",
            false,
            "which is not a stored channel",
            |_, h, _| h["channels"][3]["derived"]["of"] = json!(["phase", "i_par"]),
        ),
        (
            "top16_derived_of_missing",
            false,
            "which is not a stored channel",
            |_, h, _| h["channels"][3]["derived"]["of"] = json!(["i_perp", "i_orth"]),
        ),
        (
            "top16_derived_of_one",
            false,
            "must name two channels",
            |_, h, _| h["channels"][3]["derived"]["of"] = json!(["i_perp"]),
        ),
        (
            "top16_derived_op",
            false,
            "is not `mean` or `normalized-difference`",
            |_, h, _| h["channels"][0]["derived"]["op"] = json!("ratio"),
        ),
        (
            "top16_derived_array",
            false,
            "must be an object",
            |_, h, _| h["channels"][0]["derived"] = json!(["mean", "i_perp", "i_par"]),
        ),
        (
            "top16_duplicate_names",
            false,
            "must be unique",
            |_, h, _| h["channels"][3]["name"] = json!("i_perp"),
        ),
    ]
}

/// The valid format 3.0 table of [`symmetry_cases`]: axes `wavelength` (400, 500 nm) ×
/// `outgoing_azimuth` (uniform 0, 45, …, 180°, even and periodic of period 360°); channels
/// `phase` and `dolp`, plain f32 values.
pub fn symmetry_table() -> Table {
    use scatterbake::table::Symmetry;
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("crafted", 1),
        description: "crafted table with an even-periodic axis".into(),
        axes: vec![
            Axis::values("wavelength", "nm", vec![400.0, 500.0]),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, 45.0, 5)
                .with_symmetry(Symmetry::EvenPeriodic { period: 360.0 }),
        ],
        channels: vec![
            Channel::new("phase", "1/sr", "test"),
            Channel::new("dolp", "1", "test"),
        ],
        attributes: serde_json::Map::new(),
        data: (0..20).map(|i| 1.0 + 0.5 * i as f32).collect(),
    };
    Table::from_content(content, Provenance::default()).unwrap()
}

/// One edit of the valid symmetric table: name, whether it stays valid, the fragment of the
/// rule a reader's error must contain, and the edit of its version, header and values.
type SymmetryEdit = (
    &'static str,
    bool,
    &'static str,
    fn(&mut (u16, u16), &mut Value, &mut Vec<f32>),
);

/// Format 3.0 files with an even-periodic axis (`docs/table-format.md`, "Symmetric axes"):
/// the valid ones (newer minor, unknown key inside `symmetry`, an explicit axis, `symmetry` in
/// a 2.0 file, where it is not a field and is ignored, a 3.0 file without a symmetric axis)
/// and one case per rule, each with every checksum recomputed; every reader accepts the valid
/// ones with the values of [`symmetry_table`] and refuses the others with the rule's fragment.
pub fn symmetry_cases() -> Vec<(Case, &'static str)> {
    let mut edits = symmetry_valid_edits();
    edits.extend(symmetry_rule_edits());
    edits
        .into_iter()
        .map(|(name, valid, fragment, edit)| {
            let t = symmetry_table();
            let bytes = t.clone().to_bytes().unwrap();
            let hlen = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
            let mut header: Value = serde_json::from_slice(&bytes[56..56 + hlen]).unwrap();
            let mut values = t.data;
            let mut version = (3, 0);
            edit(&mut version, &mut header, &mut values);
            let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            let c = zstd_frame(&raw);
            set_payload(&mut header, &raw, &c);
            let header = serde_json::to_vec(&header).unwrap();
            let bytes = assemble(version.0, version.1, 0, &header, &c);
            (Case { name, bytes, valid }, fragment)
        })
        .collect()
}

/// `symmetry` of the azimuth axis (axis 1) of the symmetric table's header.
fn azimuth_symmetry(h: &mut Value) -> &mut Value {
    &mut h["axes"][1]["symmetry"]
}

/// The azimuth axis (axis 1) with these points, the layout and the values following.
fn azimuth_points(h: &mut Value, values: &mut Vec<f32>, points: Value) {
    let n = match points.get("values") {
        Some(v) => v.as_array().unwrap().len(),
        None => points["uniform"]["count"].as_u64().unwrap() as usize,
    };
    h["axes"][1]["points"] = points;
    h["layout"]["shape"][1] = json!(n);
    *values = (0..2 * n * 2).map(|i| 1.0 + 0.5 * i as f32).collect();
}

fn symmetry_valid_edits() -> Vec<SymmetryEdit> {
    vec![
        ("sym_valid", true, "", |_, _, _| {}),
        ("sym_newer_minor", true, "", |v, h, _| {
            *v = (3, 2);
            azimuth_symmetry(h)["future_phase_deg"] = json!(0.0);
            h["future_top_level"] = json!(1);
        }),
        ("sym_unknown_key_in_3_0", true, "", |_, h, _| {
            azimuth_symmetry(h)["note"] = json!("mirror plane of the sun");
        }),
        ("sym_period_integer", true, "", |_, h, _| {
            azimuth_symmetry(h)["period"] = json!(360);
        }),
        ("sym_explicit_axis", true, "", |_, h, _| {
            h["axes"][1]["points"] = json!({"values": [0.0, 10.0, 90.0, 170.0, 180.0]});
        }),
        ("sym_in_format_2", true, "", |v, _, _| *v = (2, 0)),
        ("sym_broken_in_format_1", true, "", |v, h, _| {
            *v = (1, 0);
            *azimuth_symmetry(h) = json!(["odd", -1]);
        }),
        ("sym_format_3_without_symmetry", true, "", |_, h, _| {
            h["axes"][1].as_object_mut().unwrap().remove("symmetry");
        }),
    ]
}

fn symmetry_rule_edits() -> Vec<SymmetryEdit> {
    vec![
        ("sym_kind", false, "is not `even-periodic`", |_, h, _| {
            azimuth_symmetry(h)["kind"] = json!("odd-periodic");
        }),
        (
            "sym_kind_missing",
            false,
            "missing field `kind`",
            |_, h, _| {
                azimuth_symmetry(h).as_object_mut().unwrap().remove("kind");
            },
        ),
        ("sym_kind_number", false, "", |_, h, _| {
            azimuth_symmetry(h)["kind"] = json!(1);
        }),
        (
            "sym_period_missing",
            false,
            "missing field `period`",
            |_, h, _| {
                azimuth_symmetry(h)
                    .as_object_mut()
                    .unwrap()
                    .remove("period");
            },
        ),
        ("sym_period_string", false, "", |_, h, _| {
            azimuth_symmetry(h)["period"] = json!("360");
        }),
        (
            "sym_period_zero",
            false,
            "is not finite and > 0",
            |_, h, _| {
                azimuth_symmetry(h)["period"] = json!(0.0);
            },
        ),
        (
            "sym_period_negative",
            false,
            "is not finite and > 0",
            |_, h, _| {
                azimuth_symmetry(h)["period"] = json!(-360.0);
            },
        ),
        ("sym_array", false, "must be an object", |_, h, _| {
            *azimuth_symmetry(h) = json!(["even-periodic", 360.0]);
        }),
        ("sym_string", false, "expected", |_, h, _| {
            *azimuth_symmetry(h) = json!("even-periodic");
        }),
        ("sym_one_sample", false, "at least 2 samples", |_, h, v| {
            azimuth_points(h, v, json!({"values": [0.0]}));
        }),
        ("sym_first_not_zero", false, "starts at 0", |_, h, v| {
            let points = json!({"uniform": {"start": 1.0, "step": 44.75, "count": 5}});
            azimuth_points(h, v, points);
        }),
        (
            "sym_last_not_half",
            false,
            "ends at half its period",
            |_, h, v| {
                let points = json!({"uniform": {"start": 0.0, "step": 40.0, "count": 5}});
                azimuth_points(h, v, points);
            },
        ),
        (
            "sym_period_not_twice_last",
            false,
            "ends at half its period",
            |_, h, _| {
                azimuth_symmetry(h)["period"] = json!(300.0);
            },
        ),
        (
            "sym_explicit_last_not_half",
            false,
            "ends at half its period",
            |_, h, _| {
                h["axes"][1]["points"] = json!({"values": [0.0, 10.0, 90.0, 170.0, 179.5]});
            },
        ),
    ]
}
