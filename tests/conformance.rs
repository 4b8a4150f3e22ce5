//! The reader conformance suite: every crafted file (`tests/common/crafted.rs`, grown with
//! tables whose samples are NaN or infinite) and every synthetic table of a real layout goes
//! through every reader and every command of the command line that reads a table, each run as
//! its own process under a 3 GiB address-space limit and a 20 s timeout:
//!
//! - the Rust reader (`Table::open`, or `Table::open_reconstructed` for tensor-train cases),
//!   in-process, is the reference verdict;
//! - the C library (`c/example.c`), the pure-Python reader (`python/test_reader.py`) and the
//!   command line (`verify`, `inspect`, `inspect --json`, `inspect --entry 0`, `export` in
//!   every format, `plot`, `plot-raytrace`, `render rainbow`, `hair-lut`, `validate`). The
//!   command line reads a tensor-train table as the table file it is, except `verify`, which
//!   also checks its layout by reconstructing it.
//!
//! What must hold, for every file and every run: no panic (exit 101 or a "panicked" message),
//! no abort or crash (death by a signal), no hang (the timeout); a file the Rust reader refuses
//! is refused by every other reader and every command, with an error naming the file; the C
//! library gives the Rust reader's message, and the Python reader names the same rule (its
//! message equals the Rust one once the file name is taken off); a file the Rust reader
//! accepts is read by C and Python to the same bits (no silent wrong result), and `verify`
//! accepts it. Commands that need a particular kind of table (a phase function for `mitsuba`,
//! a Dual Scattering table for `hair-lut`) may refuse an accepted file, but only with an
//! error. The Python package reads through the Rust reader; `python/tests/test_tables.py`
//! checks that it turns every refusal into `TableError`.
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

/// The Rust reader's message without the leading path (every reader starts with it).
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
    let mut files: Vec<(String, Vec<u8>, bool)> = common::crafted::cases()
        .into_iter()
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

/// The suite. Prints the count of files per verdict and of runs; fails with every broken run.
#[test]
fn every_file_through_every_reader_and_command() {
    let dir = tempfile::tempdir().unwrap();
    let subjects = subjects(dir.path());
    let refused = subjects.iter().filter(|s| s.verdict.is_err()).count();
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
