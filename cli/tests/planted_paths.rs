//! Paths planted in an output directory: a build writes only inside `--out`, never follows a
//! symbolic link out of it, and never blocks on or reads a FIFO or a device planted under one
//! of its file names. Every build here runs under a 60 s watchdog, so a hang fails the test
//! instead of stalling the suite.
#![cfg(unix)]

mod common;
use common::text;

use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A water-index manifest of 6 tasks (one per temperature), table `w`.
fn manifest(dir: &Path) -> PathBuf {
    common::water_index_manifest(dir, 5.0)
}

/// `scatterbake build` of `m` into `dir/out` with `extra` arguments, killed (and the test
/// failed) if it runs longer than 60 s.
fn build(dir: &Path, m: &Path, extra: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(["build", m.to_str().unwrap(), "--out", "out", "-q"])
        .args(extra)
        .current_dir(dir)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .env_remove("SCATTERBAKE_CHECKPOINT_KEY_FILE")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("build hung (killed after 60 s): {extra:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

fn mkfifo(p: &Path) {
    let s = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(s.success(), "mkfifo {}", p.display());
}

#[test]
fn a_symlinked_previews_directory_is_refused_and_its_target_untouched() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let outside = d.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::create_dir_all(d.path().join("out")).unwrap();
    symlink(&outside, d.path().join("out/previews")).unwrap();
    let o = build(d.path(), &m, &[]);
    let t = text(&o);
    // previews are a convenience: the table is built, the previews refused with a warning
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("warning: previews of w") && t.contains("symbolic link"),
        "{t}"
    );
    assert_eq!(
        std::fs::read_dir(&outside).unwrap().count(),
        0,
        "wrote outside --out"
    );
}

#[test]
fn a_symlink_planted_under_a_preview_name_is_replaced_not_followed() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let victim = d.path().join("victim.txt");
    std::fs::write(&victim, "keep me").unwrap();
    let previews = d.path().join("out/previews");
    std::fs::create_dir_all(&previews).unwrap();
    symlink(&victim, previews.join("w-line.png")).unwrap();
    let o = build(d.path(), &m, &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");
    let meta = std::fs::symlink_metadata(previews.join("w-line.png")).unwrap();
    assert!(meta.is_file(), "the preview is not a regular file");
    let png = std::fs::read(previews.join("w-line.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"));
}

#[test]
fn fifos_planted_as_catalog_stamps_and_table_do_not_hang_the_build() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let out = d.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    for f in ["index.json", ".catalog-stamps.json", "w.sbt", "index.html"] {
        mkfifo(&out.join(f));
    }
    let o = build(d.path(), &m, &["--no-previews"]);
    assert!(o.status.success(), "{}", text(&o));
    for f in ["index.json", ".catalog-stamps.json", "w.sbt", "index.html"] {
        let meta = std::fs::symlink_metadata(out.join(f)).unwrap();
        assert!(meta.is_file(), "{f} was not replaced by a regular file");
    }
    let o = Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(["verify", "out/w.sbt"])
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn a_fifo_planted_as_the_lock_is_a_clear_error() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    std::fs::create_dir_all(d.path().join("out")).unwrap();
    mkfifo(&d.path().join("out/.lock"));
    let o = build(d.path(), &m, &["--no-previews"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains(".lock") && t.contains("not a regular file"),
        "{t}"
    );
    assert!(!t.contains("panicked"), "{t}");
}

#[test]
fn a_checkpoint_linked_to_dev_zero_is_named_and_recomputed() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let o = build(d.path(), &m, &["--no-previews", "--shard", "0/2"]);
    assert!(o.status.success(), "{}", text(&o));
    let chunk = std::fs::read_dir(d.path().join("out/.work/w"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "chunk"))
        .expect("a checkpoint");
    std::fs::remove_file(&chunk).unwrap();
    symlink("/dev/zero", &chunk).unwrap();
    let o = build(d.path(), &m, &["--no-previews"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("warning: checkpoint") && t.contains("not a regular file"),
        "{t}"
    );
    assert!(t.contains("built 1 table(s)"), "{t}");
}

/// A table overwritten in place and given back its modification time (what `touch -d` or
/// `File::set_modified` allow) is not taken as up to date: its status change time moved, so the
/// build checks it again, finds it corrupt and rebuilds it.
#[test]
fn an_in_place_edit_with_its_mtime_restored_is_rebuilt() {
    use std::io::{Seek, SeekFrom, Write};
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let o = build(d.path(), &m, &["--no-previews"]);
    assert!(o.status.success(), "{}", text(&o));
    let table = d.path().join("out/w.sbt");
    let good = std::fs::read(&table).unwrap();
    let meta = std::fs::metadata(&table).unwrap();
    std::thread::sleep(Duration::from_millis(20));
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .open(&table)
        .unwrap();
    f.seek(SeekFrom::Start(meta.len() - 4)).unwrap();
    f.write_all(&[0xff; 4]).unwrap();
    f.set_modified(meta.modified().unwrap()).unwrap();
    drop(f);
    assert_eq!(
        std::fs::metadata(&table).unwrap().modified().unwrap(),
        meta.modified().unwrap()
    );
    let o = build(d.path(), &m, &["--no-previews"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("built 1 table(s), 0 up to date"), "{t}");
    assert_eq!(std::fs::read(&table).unwrap(), good);
}

/// The content key a build compares is the table's own (its checksummed header), not the one
/// `index.json` states: an `index.json` edited to give a stale table the key of new parameters
/// does not make that table current.
#[test]
fn a_forged_index_key_does_not_make_a_stale_table_current() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path());
    let o = build(d.path(), &m, &["--no-previews"]);
    assert!(o.status.success(), "{}", text(&o));
    // New parameters; their key from a build of them elsewhere.
    let other = tempfile::tempdir().unwrap();
    let changed = std::fs::read_to_string(&m)
        .unwrap()
        .replace("75.0]", "75.0, 90.0]");
    for dir in [d.path(), other.path()] {
        std::fs::write(dir.join("w.toml"), &changed).unwrap();
    }
    let o = build(
        other.path(),
        &other.path().join("w.toml"),
        &["--no-previews"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let key = |dir: &Path| -> String {
        let index: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("out/index.json")).unwrap()).unwrap();
        index["tables"][0]["parameters_digest"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let (stale, new) = (key(d.path()), key(other.path()));
    assert_ne!(stale, new);
    let index = d.path().join("out/index.json");
    let forged = std::fs::read_to_string(&index)
        .unwrap()
        .replace(&stale, &new);
    std::fs::write(&index, forged).unwrap();
    let o = build(d.path(), &m, &["--no-previews"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("built 1 table(s), 0 up to date"), "{t}");
    assert_eq!(key(d.path()), new);
}
