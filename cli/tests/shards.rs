//! Shards divide one global task list even when a table was written before a later shard
//! plans: the up-to-date table's tasks still count, so no shard computes another's tasks and
//! the last shard assembles everything.

use std::path::Path;
use std::process::{Command, Output};

fn run_shard(dir: &Path, shard: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args([
            "build",
            "m.toml",
            "--out",
            "out",
            "-q",
            "--no-previews",
            "--shard",
            shard,
        ])
        .current_dir(dir)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .expect("run scatterbake")
}

#[test]
fn a_table_written_by_an_earlier_shard_does_not_shift_the_others_tasks() {
    let d = tempfile::tempdir().unwrap();
    // Global tasks: a0 = 0, b0..b4 = 1..5. With 3 shards, shard 0 computes a0 and b2, so it
    // writes table `a`; shards 1 and 2 must still compute b0, b3 and b1, b4.
    std::fs::write(
        d.path().join("m.toml"),
        "[[table]]\nname = \"a\"\nstage = \"water-index\"\n[table.params]\n\
         wavelength_nm = [300.0, 1000.0, 1.0]\ntemperature_c = [20.0]\n\n\
         [[table]]\nname = \"b\"\nstage = \"water-index\"\n[table.params]\n\
         wavelength_nm = [300.0, 1000.0, 1.0]\ntemperature_c = [0.0, 10.0, 20.0, 30.0, 40.0]\n",
    )
    .unwrap();
    let mut last = String::new();
    for (i, shard) in ["0/3", "1/3", "2/3"].iter().enumerate() {
        let o = run_shard(d.path(), shard);
        last = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(o.status.success(), "{last}");
        assert!(last.contains("tasks: 2 computed"), "shard {i}: {last}");
        if i == 0 {
            assert!(last.contains("built 1 table"), "{last}");
        }
    }
    assert!(
        last.contains("built 1 table(s), 1 up to date, 0 pending"),
        "{last}"
    );
    assert!(d.path().join("out/b.sbt").exists());
    assert!(!d.path().join("out/.work").exists());
}
