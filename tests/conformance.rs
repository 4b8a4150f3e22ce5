//! The reader conformance suite: every crafted file (`tests/common/crafted.rs`, the format 3.0
//! files of `symmetry_cases` among them, grown with tables whose samples are NaN or infinite) and every synthetic table of a real layout goes
//! through every reader and every command of the command line that reads a table, each run as
//! its own process under a 3 GiB address-space limit and a 20 s timeout:
//!
//! - the Rust reader (`Table::open`, or `Table::open_reconstructed` for tensor-train cases),
//!   in-process, is the reference verdict;
//! - the C library (`c/example.c`), the pure-Python reader (`python/test_reader.py`) and the
//!   command line (`verify`, `inspect`, `inspect --json`, `inspect --entry 0`, `export` in every
//!   format, `plot`, `plot-raytrace`, `render rainbow`, `hair-lut`, `cloth-lut`, `validate`). The
//!   command line reads a tensor-train table as the table file it is, except `verify`, which also
//!   checks its layout by reconstructing it.
//!
//! What must hold, for every file and every run: no panic (exit 101 or a "panicked" message), no
//! abort or crash (death by a signal), no hang (the timeout); a file the Rust reader refuses is
//! refused by every other reader and every command, with an error naming the file; the C library
//! gives the Rust reader's message, and the Python reader names the same rule (its message equals
//! the Rust one once the file name is taken off); a file the Rust reader accepts is read by C and
//! Python to the same bits (no silent wrong result), and `verify` accepts it. Commands that need a
//! particular kind of table (a phase function for `mitsuba`, a Dual Scattering table for
//! `hair-lut`, a cloth table for `cloth-lut`) may refuse an accepted file, but only with an
//! error. The Python package reads through the Rust reader; `python/tests/test_tables.py` checks
//! that it turns every refusal into `TableError`.
//!
//! The C executable, the command line and the Python environment are built or provisioned on
//! first use (`tests/common/c.rs`, `tests/common/python.rs`); a missing C compiler or
//! `python3` fails the test.

mod common;

use common::crafted::Case;
use scatterbake::fixtures::henyey_greenstein_table;
use scatterbake::table::{ReadLimits, Table};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The address-space limit of every run (`ulimit -v`, KiB): 3 GiB.
const ADDRESS_LIMIT_KIB: u64 = 3 << 20;
/// The wall-clock limit of every run.
const TIMEOUT: Duration = Duration::from_secs(20);

/// How one run of a reader or a command ended.
#[derive(Debug)]
enum Outcome {
    Exit { code: i32, stderr: String },
    Signal(String),
    Timeout,
}

/// Run `program args` under the address-space limit and the timeout.
fn run_limited(program: &Path, args: &[String]) -> Outcome {
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg(format!(
            "ulimit -v {ADDRESS_LIMIT_KIB} && exec \"$0\" \"$@\""
        ))
        .arg(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("sh runs");
    let (mut out, mut err) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut out, &mut b).ok();
        b
    });
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut err, &mut s).ok();
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if start.elapsed() > TIMEOUT {
            child.kill().ok();
            child.wait().ok();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    reader.join().unwrap();
    let stderr = err_reader.join().unwrap();
    match status {
        None => Outcome::Timeout,
        Some(s) => match s.code() {
            Some(code) => Outcome::Exit { code, stderr },
            None => Outcome::Signal(format!("{s} ({stderr})")),
        },
    }
}

/// A reader's verdict on a file: its samples, or its message with the path taken off.
type Verdict = Result<Vec<f32>, String>;

/// One file of the suite: its name, path, whether it is a tensor-train case, and the Rust
/// reader's verdicts: as a table file (`Table::open`, what the command line reads) and
/// reconstructed (`Table::open_reconstructed`, what the C and Python readers are asked for
/// on tensor-train cases; the same as the first for any other file).
struct Subject {
    name: String,
    path: PathBuf,
    tensor_train: bool,
    file_verdict: Verdict,
    verdict: Verdict,
}

/// The Rust reader's message without the path it starts with (every reader names the file first).
fn without_path(message: &str, path: &Path) -> String {
    message.replace(&path.display().to_string(), "FILE")
}

fn rust_verdict(path: &Path, tensor_train: bool) -> Verdict {
    let t = if tensor_train {
        Table::open_reconstructed(path, &ReadLimits::default())
    } else {
        Table::open(path)
    };
    t.map(|t| t.data)
        .map_err(|e| without_path(&e.to_string(), path))
}

/// A phase-function table (the Henyey–Greenstein fixture) with `poison` applied to its samples:
/// formally valid files whose values are not finite.
fn poisoned(poison: fn(usize, &mut f32)) -> Vec<u8> {
    let mut t = henyey_greenstein_table(&[550.0], &[10.0], |_, _| 0.5, 181, 0.5);
    t.data
        .iter_mut()
        .enumerate()
        .for_each(|(i, v)| poison(i, v));
    t.to_bytes().unwrap()
}

/// The valid base file with its header checksum broken, and with a wrong checksum of the
/// decompressed payload (the header re-sealed, so only rule 7 catches it).
fn checksum_cases() -> Vec<(String, Vec<u8>, bool)> {
    let base = common::crafted::cases().swap_remove(0).bytes;
    let mut header_flipped = base.clone();
    header_flipped[60] ^= 0x01;
    let h_len = u64::from_le_bytes(base[16..24].try_into().unwrap()) as usize;
    let mut header: serde_json::Value = serde_json::from_slice(&base[56..56 + h_len]).unwrap();
    header["payload"]["sha256_uncompressed"] = "0".repeat(64).into();
    let header = serde_json::to_vec(&header).unwrap();
    let resealed = common::crafted::assemble(1, 0, 0, &header, &base[56 + h_len..]);
    vec![
        ("header_checksum_wrong".into(), header_flipped, false),
        ("uncompressed_checksum_wrong".into(), resealed, false),
    ]
}

/// Every file of the suite, written into `dir`.
fn subjects(dir: &Path) -> Vec<Subject> {
    let symmetry = common::crafted::symmetry_cases()
        .into_iter()
        .map(|(c, _)| c);
    let mut files: Vec<(String, Vec<u8>, bool)> = common::crafted::cases()
        .into_iter()
        .chain(symmetry)
        .map(|Case { name, bytes, .. }| (name.to_string(), bytes, false))
        .collect();
    files.extend(
        common::crafted::tensor_train_cases()
            .into_iter()
            .map(|(c, _)| (format!("tt_{}", c.name), c.bytes, true)),
    );
    files.extend(checksum_cases());
    files.push((
        "values_one_nan".into(),
        poisoned(|i, v| {
            if i == 7 {
                *v = f32::NAN
            }
        }),
        false,
    ));
    files.push((
        "values_all_nan".into(),
        poisoned(|_, v| *v = f32::NAN),
        false,
    ));
    files.push((
        "values_all_inf".into(),
        poisoned(|_, v| *v = f32::INFINITY),
        false,
    ));
    let mut subjects: Vec<Subject> = files
        .into_iter()
        .map(|(name, bytes, tensor_train)| {
            let path = dir.join(format!("{name}.sbt"));
            std::fs::write(&path, bytes).unwrap();
            Subject {
                file_verdict: rust_verdict(&path, false),
                verdict: rust_verdict(&path, tensor_train),
                name,
                path,
                tensor_train,
            }
        })
        .collect();
    let fixtures = dir.join("fixtures");
    std::fs::create_dir_all(&fixtures).unwrap();
    for path in common::synthetic_tables(&fixtures) {
        let verdict = rust_verdict(&path, false);
        subjects.push(Subject {
            name: path.file_stem().unwrap().to_string_lossy().into_owned(),
            path,
            tensor_train: false,
            file_verdict: verdict.clone(),
            verdict,
        });
    }
    subjects
}

/// The command lines that read a table, `{f}` the table and `{o}` a fresh output prefix.
const COMMANDS: &[&[&str]] = &[
    &["verify", "{f}"],
    &["inspect", "{f}"],
    &["inspect", "--json", "{f}"],
    &["inspect", "--entry", "0", "{f}"],
    &["export", "--format", "csv", "--out", "{o}.csv", "{f}"],
    &["export", "--format", "json", "--out", "{o}.json", "{f}"],
    &["export", "--format", "exr", "--out", "{o}.exr", "{f}"],
    &["export", "--format", "mitsuba", "--out", "{o}.xml", "{f}"],
    &["export", "--format", "legendre", "--out", "{o}.txt", "{f}"],
    &["export", "--format", "mieplot", "--out", "{o}.mp", "{f}"],
    &["export", "--format", "rgb-lut", "--out", "{o}.png", "{f}"],
    &["plot", "--out", "{o}-plot", "{f}"],
    &["plot-raytrace", "--out", "{o}-bows.png", "{f}"],
    &[
        "render", "rainbow", "--width", "48", "--steps", "4", "--table", "{f}", "--out", "{o}.png",
    ],
    &["hair-lut", "--table", "{f}", "--out", "{o}-lut.exr"],
    &["cloth-lut", "--table", "{f}", "--out", "{o}-cloth.dds"],
    &["validate", "--reference", "{r}", "{f}"],
];

/// A short MiePlot-style reference for `validate`.
fn reference_file(dir: &Path) -> PathBuf {
    let p = dir.join("reference.txt");
    let mut text = String::from("# wavelength_nm: 550\nangle perpendicular parallel\n");
    for a in 0..=180 {
        text.push_str(&format!("{a} 1.0 1.0\n"));
    }
    std::fs::write(&p, text).unwrap();
    p
}

/// Why `outcome` breaks the rules for a reader or command `what` on `s`, whose reference
/// verdict is `verdict`, if it does. `must_accept`: refusing a file the reference accepts is
/// a break (readers, `verify`); other commands may refuse a kind of table they do not draw.
fn broken(
    what: &str,
    s: &Subject,
    verdict: &Verdict,
    outcome: &Outcome,
    must_accept: bool,
) -> Option<String> {
    let tag = format!("{} through {what}", s.name);
    match outcome {
        Outcome::Timeout => Some(format!("{tag}: hung (no exit within {TIMEOUT:?})")),
        Outcome::Signal(how) => Some(format!("{tag}: killed by a signal: {how}")),
        Outcome::Exit { code, stderr, .. } => {
            if *code == 101 || stderr.contains("panicked") {
                return Some(format!("{tag}: panicked: {stderr}"));
            }
            match (verdict, *code) {
                (Err(_), 0) => Some(format!("{tag}: accepted a file the Rust reader refuses")),
                (Err(_), _) if !stderr.contains(&s.name) => {
                    Some(format!("{tag}: refused without naming the file: {stderr}"))
                }
                (Ok(_), c) if c != 0 && must_accept => Some(format!(
                    "{tag}: refused a file the Rust reader accepts: {stderr}"
                )),
                _ => None,
            }
        }
    }
}

/// Every command line on every file; returns the broken runs and the count of runs.
fn command_line_breaks(exe: &Path, subjects: &[Subject], dir: &Path) -> (Vec<String>, usize) {
    let reference = reference_file(dir);
    let jobs: Vec<(&Subject, &[&str])> = subjects
        .iter()
        .flat_map(|s| COMMANDS.iter().map(move |c| (s, *c)))
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let found = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..4 {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some((s, command)) = jobs.get(k) else {
                        break;
                    };
                    let out = dir.join(format!("out-{k}"));
                    let args: Vec<String> = command
                        .iter()
                        .map(|a| {
                            a.replace("{f}", &s.path.display().to_string())
                                .replace("{o}", &out.display().to_string())
                                .replace("{r}", &reference.display().to_string())
                        })
                        .collect();
                    let must_accept = command[0] == "verify";
                    let what = format!("`scatterbake {}`", command.join(" "));
                    let start = Instant::now();
                    let outcome = run_limited(exe, &args);
                    let took = start.elapsed();
                    // `verify` checks a tensor-train table's layout by reconstructing it.
                    let v = if must_accept {
                        &s.verdict
                    } else {
                        &s.file_verdict
                    };
                    if let Some(b) = broken(&what, s, v, &outcome, must_accept) {
                        found.lock().unwrap().push(b);
                    }
                    if took > Duration::from_secs(2) {
                        eprintln!("slow: {what} on {}: {took:?}", s.name);
                    }
                }
            });
        }
    });
    (found.into_inner().unwrap(), jobs.len())
}

/// The step of `docs/table-format.md` ("Reading and verification", and the rules of
/// "Tensor-train tables") a refusal names, read from its message; `None` for a message that
/// names none (a break of its own). Readers word a rule's details differently (the Rust
/// reader reports JSON type errors as its parser words them, the Python reader names the
/// field), so readers must agree on the step, and the C library, which is the Rust reader,
/// on the whole message.
fn rule_of(message: &str) -> Option<&'static str> {
    let m = message;
    let has = |k: &str| m.contains(k);
    let step = if has("tensor-train table is not valid") {
        "tensor-train layout"
    } else if has("not a scatterbake table") {
        "1: magic"
    } else if has("is newer than this reader") || has("major version 0") || has("reserved flags") {
        "1: version and flags"
    } else if has("header length") || has("file truncated: header") || has("preamble") {
        "2: header length"
    } else if has("header checksum mismatch") {
        "2: header checksum"
    } else if has("header is not valid: JSON:") || is_field_type_error(m) {
        "3: JSON and field types"
    } else if has("payload.compressed_bytes")
        || has("file truncated: payload")
        || has("after the payload")
    {
        "5: file length"
    } else if has("payload compressed checksum") {
        "5: compressed checksum"
    } else if has("zstd frame") {
        "6: frame"
    } else if has("decompress") || has("uncompressed checksum") {
        "7: decompression"
    } else if has("header is not valid:") {
        "4 and 8: structure and coordinates"
    } else {
        return None;
    };
    Some(step)
}

/// A field of the wrong type, missing or unknown (rule 3), as the Rust reader's JSON parser
/// or the Python reader words it.
fn is_field_type_error(m: &str) -> bool {
    [
        "invalid type",
        "invalid value",
        "missing field",
        "unknown field",
        "unknown variant",
        "expected value",
        "expected a string",
        "expected a number",
        "expected an object",
        "expected an array",
        "expected an unsigned integer",
        "expected exactly one",
        "is not a JSON object",
        "invalid length",
    ]
    .iter()
    .any(|k| m.contains(k))
}

/// The samples a reader dumped (raw f32 little-endian) against the Rust reader's.
fn dump_differs(dump: &Path, want: &[f32]) -> bool {
    let got = std::fs::read(dump).unwrap_or_default();
    let want: Vec<u8> = want.iter().flat_map(|v| v.to_le_bytes()).collect();
    got != want
}

/// The C library and the pure-Python reader on `s`: same verdict, same message (C) or same
/// rule (Python), same bits when accepted.
fn reader_breaks(c_exe: &Path, python: &Path, s: &Subject, dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/test_reader.py");
    let path = s.path.display().to_string();
    let (c_dump, py_dump) = (
        dir.join(format!("{}.c.bin", s.name)),
        dir.join(format!("{}.py.bin", s.name)),
    );
    let mut c_args = vec![path.clone()];
    if s.tensor_train {
        c_args.push("--reconstruct".into());
    }
    c_args.extend(["--dump".into(), c_dump.display().to_string()]);
    let py_args = vec![
        script.display().to_string(),
        path.clone(),
        py_dump.display().to_string(),
    ];
    for (what, outcome, dump) in [
        ("the C library", run_limited(c_exe, &c_args), &c_dump),
        ("the Python reader", run_limited(python, &py_args), &py_dump),
    ] {
        if let Some(b) = broken(what, s, &s.verdict, &outcome, true) {
            found.push(b);
            continue;
        }
        let Outcome::Exit { code, stderr, .. } = &outcome else {
            unreachable!()
        };
        match &s.verdict {
            Ok(values) if dump_differs(dump, values) => found.push(format!(
                "{} through {what}: samples differ from the Rust reader's",
                s.name
            )),
            Err(message) => {
                let said = without_path(stderr.trim().trim_start_matches("error: "), &s.path);
                let same = if what == "the C library" {
                    said == *message
                } else {
                    rule_of(&said).is_some() && rule_of(&said) == rule_of(message)
                };
                if *code == 0 || !same {
                    found.push(format!(
                        "{} through {what}: says `{said}`, the Rust reader `{message}`",
                        s.name
                    ));
                }
            }
            Ok(_) => {}
        }
    }
    found
}

/// Where the suite leaves its files and the Rust reader's verdicts for the Python package's
/// tests (`python/tests/test_conformance.py`), which run after `cargo test` (as in `.ci/run`)
/// and read the package's verdicts against these: `target/tmp/conformance-corpus/<set>/`.
fn export_for_python(set: &str, subjects: &[Subject]) {
    use sha2::{Digest, Sha256};
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("conformance-corpus")
        .join(set);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut verdicts = Vec::new();
    for (k, s) in subjects.iter().enumerate() {
        let file = format!("{k:05}.sbt");
        let path = dir.join(&file);
        std::fs::copy(&s.path, &path).unwrap();
        // The package reports a refusal as the error and its causes, like the command line.
        let verdict = if s.tensor_train {
            Table::open_reconstructed(&path, &ReadLimits::default())
        } else {
            Table::open(&path)
        };
        let v = match verdict {
            Ok(t) => {
                let bytes: Vec<u8> = t.data.iter().flat_map(|v| v.to_le_bytes()).collect();
                serde_json::json!({"file": file, "name": s.name, "sha256": hex::encode(Sha256::digest(&bytes))})
            }
            Err(e) => {
                let message = scatterbake::error::error_chain(&e);
                serde_json::json!({"file": file, "name": s.name,
                                   "error": message.replace(&path.display().to_string(), "FILE")})
            }
        };
        verdicts.push(v);
    }
    std::fs::write(
        dir.join("verdicts.json"),
        serde_json::to_vec_pretty(&verdicts).unwrap(),
    )
    .unwrap();
}

/// The suite. Prints the count of files per verdict and of runs; fails with every broken run.
#[test]
fn every_file_through_every_reader_and_command() {
    let dir = tempfile::tempdir().unwrap();
    let subjects = subjects(dir.path());
    let refused = subjects.iter().filter(|s| s.verdict.is_err()).count();
    export_for_python("crafted", &subjects);
    let c_exe = common::c::example_exe(dir.path());
    let python = common::python::python();
    let exe = common::c::cli_exe();
    let mut found: Vec<String> = subjects
        .iter()
        .flat_map(|s| reader_breaks(&c_exe, &python, s, dir.path()))
        .collect();
    let (cli_found, cli_runs) = command_line_breaks(&exe, &subjects, dir.path());
    found.extend(cli_found);
    eprintln!(
        "conformance: {} files ({} refused, {} read), {} reader runs, {cli_runs} command runs, \
         {} broken",
        subjects.len(),
        refused,
        subjects.len() - refused,
        2 * subjects.len(),
        found.len()
    );
    let mut per_rule = std::collections::BTreeMap::new();
    for s in &subjects {
        let rule = s
            .verdict
            .as_ref()
            .err()
            .map(|m| rule_of(m).unwrap_or("(no rule named)"));
        *per_rule.entry(rule.unwrap_or("read")).or_insert(0) += 1;
    }
    for (rule, n) in &per_rule {
        eprintln!("  {n:3} {rule}");
    }
    assert!(
        found.is_empty(),
        "{} broken runs:\n{}",
        found.len(),
        found.join("\n")
    );
}

/// The values every field of a header is replaced by in the mutants.
fn replacement_values() -> Vec<Option<serde_json::Value>> {
    use serde_json::json;
    vec![
        None,
        Some(json!(null)),
        Some(json!(0)),
        Some(json!(-1)),
        Some(json!(1.5)),
        Some(json!(9007199254740993u64)),
        Some(json!(1e300)),
        Some(json!("x")),
        Some(json!([])),
        Some(json!([1, 2, 3])),
        Some(json!({})),
    ]
}

/// Every JSON pointer of `v` (objects' fields, arrays' first three elements).
fn pointers(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => m.iter().for_each(|(k, x)| {
            let p = format!("{at}/{}", k.replace('~', "~0").replace('/', "~1"));
            out.push(p.clone());
            pointers(x, p, out);
        }),
        serde_json::Value::Array(a) => a.iter().take(3).enumerate().for_each(|(i, x)| {
            let p = format!("{at}/{i}");
            out.push(p.clone());
            pointers(x, p, out);
        }),
        _ => {}
    }
}

/// `header` with the field at `pointer` replaced by `value` (removed when `None`).
fn edited(
    header: &serde_json::Value,
    pointer: &str,
    value: &Option<serde_json::Value>,
) -> serde_json::Value {
    let mut h = header.clone();
    let (parent, key) = pointer.rsplit_once('/').unwrap();
    let key = key.replace("~1", "/").replace("~0", "~");
    match (h.pointer_mut(parent).unwrap(), value) {
        (serde_json::Value::Object(m), None) => {
            m.remove(&key);
        }
        (serde_json::Value::Object(m), Some(v)) => {
            m.insert(key, v.clone());
        }
        (serde_json::Value::Array(a), None) => {
            a.remove(key.parse::<usize>().unwrap());
        }
        (serde_json::Value::Array(a), Some(v)) => a[key.parse::<usize>().unwrap()] = v.clone(),
        _ => unreachable!("pointers() lists fields of objects and arrays"),
    }
    h
}

/// Header mutants of a plain table, a tensor-train table, a phase-function table and a format
/// 3.0 table with an even-periodic axis:
/// every field replaced by each of `replacement_values` or removed, the header re-sealed
/// (payload and its checksums unchanged), so each mutant is refused by a rule past the
/// checksums or read.
fn header_mutants(dir: &Path) -> Vec<Subject> {
    let plain = common::crafted::cases().swap_remove(0).bytes;
    let tensor_train = common::crafted::tensor_train_table().0.to_bytes().unwrap();
    let phase = henyey_greenstein_table(&[450.0, 650.0], &[10.0, 20.0], |_, _| 0.6, 19, 0.5)
        .to_bytes()
        .unwrap();
    let symmetric = common::crafted::symmetry_table().to_bytes().unwrap();
    let mut out = Vec::new();
    for (base_name, bytes, is_tt, (major, minor)) in [
        ("plain", plain, false, (1, 0)),
        ("tt", tensor_train, true, (1, 0)),
        ("phase", phase, false, (1, 0)),
        ("symmetric", symmetric, false, (3, 0)),
    ] {
        let h_len = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
        let header: serde_json::Value = serde_json::from_slice(&bytes[56..56 + h_len]).unwrap();
        let payload = &bytes[56 + h_len..];
        let mut paths = Vec::new();
        pointers(&header, String::new(), &mut paths);
        for (i, p) in paths.iter().enumerate() {
            for (j, v) in replacement_values().iter().enumerate() {
                let h = serde_json::to_vec(&edited(&header, p, v)).unwrap();
                let name = format!("mutant_{base_name}_{i}_{j}");
                let path = dir.join(format!("{name}.sbt"));
                let file = common::crafted::assemble(major, minor, 0, &h, payload);
                std::fs::write(&path, file).unwrap();
                out.push(Subject {
                    file_verdict: rust_verdict(&path, false),
                    verdict: rust_verdict(&path, is_tt),
                    name: format!("{name} ({p} = {v:?})"),
                    path,
                    tensor_train: is_tt,
                });
            }
        }
    }
    out
}

/// The pure-Python reader on many files in one process: one JSON line per file, the SHA-256
/// of the samples (float32 little-endian) or the message of its `TableError`; any other
/// exception is reported as such.
const PYTHON_BATCH: &str = r#"
import hashlib, json, sys, traceback
sys.path.insert(0, sys.argv[1])
import numpy as np, scatterbake_table as sbt
for path in sys.stdin.read().splitlines():
    try:
        t = sbt.open_table(path)
        d = np.ascontiguousarray(np.asarray(t.data, dtype="<f4")).tobytes()
        print(json.dumps({"ok": hashlib.sha256(d).hexdigest()}))
    except sbt.TableError as e:
        print(json.dumps({"err": str(e)}))
    except BaseException as e:
        print(json.dumps({"crash": traceback.format_exc()}))
"#;

/// Header mutants through the Rust and the pure-Python reader: the same verdict, the same
/// samples (by SHA-256) when read, a refusal for the same step of the spec when refused.
#[test]
fn header_mutants_rust_and_python_agree() {
    use sha2::{Digest, Sha256};
    let dir = tempfile::tempdir().unwrap();
    let mutants = header_mutants(dir.path());
    export_for_python("mutants", &mutants);
    let list: String = mutants
        .iter()
        .map(|s| format!("{}\n", s.path.display()))
        .collect();
    let mut child = Command::new(common::python::python())
        .args(["-c", PYTHON_BATCH])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("python"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    std::io::Write::write_all(&mut child.stdin.take().unwrap(), list.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "the Python batch failed");
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), mutants.len());
    let mut broken = Vec::new();
    let mut read = 0;
    for (s, py) in mutants.iter().zip(&lines) {
        let agree = match (&s.verdict, py.get("ok"), py.get("err")) {
            (Ok(values), Some(sha), _) => {
                read += 1;
                let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
                *sha == hex::encode(Sha256::digest(&bytes))
            }
            (Err(message), _, Some(said)) => {
                let said = without_path(said.as_str().unwrap(), &s.path);
                rule_of(&said).is_some() && rule_of(&said) == rule_of(message)
            }
            _ => false,
        };
        if !agree {
            broken.push(format!(
                "{}: Rust {:?}, Python {py}",
                s.name,
                s.verdict.as_ref().map(|v| v.len())
            ));
        }
    }
    eprintln!(
        "header mutants: {} files, {read} read by both, {} disagree",
        mutants.len(),
        broken.len()
    );
    assert!(
        broken.is_empty(),
        "{} disagreements:\n{}",
        broken.len(),
        broken.join("\n")
    );
}
