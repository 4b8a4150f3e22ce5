//! Checkpoints that must not become tables: truncated, of the wrong length, of an earlier
//! checkpoint format, forged (values changed, hash recomputed without the output directory's
//! secret) or copied from another output directory. Each is named in a warning, its task recomputed, and the table is
//! byte-identical to a clean build.

mod common;
use common::text;

use scatterbake::pipeline::{read_checkpoint, write_checkpoint};
use scatterbake::stages::Chunk;
use scatterbake::workdir::{CheckpointKey, checkpoint_key};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(args)
        .current_dir(cwd)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .env_remove("SCATTERBAKE_CHECKPOINT_KEY_FILE")
        .output()
        .expect("run scatterbake")
}

/// A water-index manifest of 6 tasks (one per temperature).
fn manifest(dir: &Path) -> PathBuf {
    common::water_index_manifest(dir, 0.5)
}

/// Build `manifest` into `out` (relative to `dir`), asserting success; returns the output.
fn build(dir: &Path, manifest: &Path, out: &str, extra: &[&str]) -> String {
    let mut args = vec!["build", manifest.to_str().unwrap(), "--out", out, "-q"];
    args.extend(extra);
    args.push("--no-previews");
    let o = run(&args, dir);
    assert!(o.status.success(), "{}", text(&o));
    text(&o)
}

/// The checkpoint files of table `w` in `out`, sorted, with their task keys.
fn checkpoints(out: &Path) -> Vec<(PathBuf, String)> {
    let mut v: Vec<(PathBuf, String)> = std::fs::read_dir(out.join(".work/w"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "chunk"))
        .map(|p| {
            let key = p.file_stem().unwrap().to_str().unwrap().to_string();
            (p, key)
        })
        .collect();
    v.sort();
    v
}

/// A half-built output directory: shard 0/2 leaves checkpoints of tasks 0, 2 and 4.
fn half_built(dir: &Path, m: &Path, out: &str) -> Vec<(PathBuf, String)> {
    let t = build(dir, m, out, &["--shard", "0/2"]);
    assert!(t.contains("1 pending"), "{t}");
    let c = checkpoints(&dir.join(out));
    assert_eq!(c.len(), 3);
    c
}

fn assert_same_table(dir: &Path, out: &str) {
    assert_eq!(
        std::fs::read(dir.join(out).join("w.sbt")).unwrap(),
        std::fs::read(dir.join("ref/w.sbt")).unwrap(),
        "{out}/w.sbt differs from the clean build"
    );
}

#[test]
fn truncated_and_wrong_length_checkpoints_are_named_and_recomputed() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    build(d.path(), &m, "ref", &[]);
    let c = half_built(d.path(), &m, "out");
    // A truncated file.
    let bytes = std::fs::read(&c[0].0).unwrap();
    std::fs::write(&c[0].0, &bytes[..bytes.len() - 3]).unwrap();
    // A well-formed checkpoint under the right secret with the wrong number of values (as a
    // build of another layout would leave).
    let secret = checkpoint_key(&d.path().join("out")).unwrap();
    write_checkpoint(&c[1].0, &c[1].1, &secret, &Chunk::values(vec![1.0, 2.0])).unwrap();
    let t = build(d.path(), &m, "out", &[]);
    for (path, why) in [(&c[0].0, "truncated"), (&c[1].0, "wrong length: 2 values")] {
        let line = t
            .lines()
            .find(|l| l.contains(path.file_name().unwrap().to_str().unwrap()))
            .unwrap_or_else(|| panic!("no warning names {}: {t}", path.display()));
        assert!(line.starts_with("warning: checkpoint"), "{line}");
        assert!(line.contains(why), "{line}");
        assert!(line.contains("recomputed"), "{line}");
    }
    assert!(t.contains("built 1 table"), "{t}");
    assert_same_table(d.path(), "out");
}

/// The first checkpoint format (bincode of the task key, a keyed hash and the values, without a
/// format field): a build that finds one names it and recomputes its task, never reads it.
#[test]
fn checkpoints_of_the_first_format_are_named_and_recomputed() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    build(d.path(), &m, "ref", &[]);
    let c = half_built(d.path(), &m, "out");
    let secret = checkpoint_key(&d.path().join("out")).unwrap();
    let values = read_checkpoint(&c[0].0, &c[0].1, &secret)
        .unwrap()
        .expect("a valid checkpoint")
        .values;
    // bincode (standard configuration): strings and sequences are their length (one byte below
    // 251, else 251 and a u16 little-endian) followed by their elements; f32 little-endian.
    let len = |n: usize| -> Vec<u8> {
        match u8::try_from(n) {
            Ok(b) if b < 251 => vec![b],
            _ => [&[251u8][..], &u16::try_from(n).unwrap().to_le_bytes()].concat(),
        }
    };
    let mut old = len(64);
    old.extend(c[0].1.as_bytes());
    old.extend(len(64));
    old.extend("0".repeat(64).as_bytes());
    old.extend(len(values.len()));
    old.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(&c[0].0, old).unwrap();
    let t = build(d.path(), &m, "out", &[]);
    let line = t
        .lines()
        .find(|l| l.contains(c[0].0.file_name().unwrap().to_str().unwrap()))
        .unwrap_or_else(|| panic!("no warning names {}: {t}", c[0].0.display()));
    assert!(line.starts_with("warning: checkpoint"), "{line}");
    assert!(line.contains("checkpoint format 2"), "{line}");
    assert!(line.contains("recomputed"), "{line}");
    assert_same_table(d.path(), "out");
}

#[test]
fn forged_or_foreign_checkpoints_are_not_used() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    build(d.path(), &m, "ref", &[]);

    // Forged: values changed, hash recomputed by someone without the directory's secret.
    let c = half_built(d.path(), &m, "forged");
    let secret = checkpoint_key(&d.path().join("forged")).unwrap();
    let mut values = read_checkpoint(&c[0].0, &c[0].1, &secret)
        .unwrap()
        .expect("a valid checkpoint");
    values.values[0] *= 2.0;
    let guess = CheckpointKey::from_bytes([0; 32]);
    write_checkpoint(&c[0].0, &c[0].1, &guess, &values).unwrap();
    let t = build(d.path(), &m, "forged", &[]);
    assert!(
        t.lines().any(|l| l.starts_with("warning: checkpoint")
            && l.contains(c[0].0.file_name().unwrap().to_str().unwrap())
            && l.contains("keyed hash does not match")),
        "{t}"
    );
    assert_same_table(d.path(), "forged");

    // Control: the same forgery under the right secret is used, so the test's change matters.
    let c = half_built(d.path(), &m, "control");
    let secret = checkpoint_key(&d.path().join("control")).unwrap();
    write_checkpoint(&c[0].0, &c[0].1, &secret, &values).unwrap();
    let t = build(d.path(), &m, "control", &[]);
    assert!(!t.contains("warning: checkpoint"), "{t}");
    assert_ne!(
        std::fs::read(d.path().join("control/w.sbt")).unwrap(),
        std::fs::read(d.path().join("ref/w.sbt")).unwrap()
    );

    // Foreign: valid checkpoints of the same tasks copied from another output directory.
    let mine = half_built(d.path(), &m, "mine");
    let other = half_built(d.path(), &m, "other");
    for ((dst, _), (src, _)) in mine.iter().zip(&other) {
        std::fs::copy(src, dst).unwrap();
    }
    let t = build(d.path(), &m, "mine", &[]);
    let warned = t
        .lines()
        .filter(|l| l.starts_with("warning: checkpoint") && l.contains("keyed hash"))
        .count();
    assert_eq!(warned, 3, "{t}");
    assert!(t.contains("6 computed, 0 reused"), "{t}");
    assert_same_table(d.path(), "mine");
}

/// Checkpoints left beside a finished table (a build killed after sealing the table, before
/// removing its work directory) are removed by the next build, which finds the table up to date.
#[test]
fn checkpoints_left_beside_a_finished_table_are_removed() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let left = half_built(d.path(), &m, "out");
    assert!(!left.is_empty());
    let keep: Vec<(PathBuf, Vec<u8>)> = left
        .iter()
        .map(|(p, _)| (p.clone(), std::fs::read(p).unwrap()))
        .collect();
    build(d.path(), &m, "out", &[]);
    assert!(!d.path().join("out/.work/w").exists());
    // As a kill just after the table was renamed into place leaves them.
    std::fs::create_dir_all(d.path().join("out/.work/w")).unwrap();
    for (p, bytes) in &keep {
        std::fs::write(p, bytes).unwrap();
    }
    let t = build(d.path(), &m, "out", &[]);
    assert!(t.contains("built 0 table(s), 1 up to date"), "{t}");
    assert!(!d.path().join("out/.work/w").exists(), "{t}");
    assert!(!d.path().join("out/.work").exists(), "{t}");
}
