//! A real Slurm job array: `deploy/slurm/single-node-test.sh` starts a single-node Slurm on this
//! machine (its own munge key, configuration and daemons, stopped afterwards), submits
//! `deploy/slurm/array.sbatch` as `--array=0-3` over the debye and hair-dual manifests, and
//! checks that every table is assembled by the array, the catalog is current, and every table is
//! byte-identical to an unsharded build; then again with `REFERENCE=0` (no unsharded build, the
//! tables expected taken from the plan) as `--array=0-1`.
//!
//! It starts daemons and needs root, so it runs only when asked (`--ignored`); when asked, a
//! missing Slurm is a failure, not a skip. CI (`.ci/run`) installs Slurm and runs it:
//!
//! ```sh
//! apt-get install -y slurmctld slurmd slurm-client munge
//! cargo test -p scatterbake-cli --test slurm -- --ignored
//! ```

use std::path::Path;
use std::process::Command;

#[test]
#[ignore = "starts a single-node Slurm (root, Debian packages slurmctld slurmd slurm-client \
            munge); about a minute on 2 cores: cargo test -p scatterbake-cli --test slurm -- \
            --ignored"]
fn job_array_assembles_every_table_identical_to_an_unsharded_build() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let found = Command::new("sh")
        .args(["-c", "command -v sbatch"])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        found,
        "Slurm is not installed (no sbatch on PATH): apt-get install -y slurmctld slurmd \
         slurm-client munge"
    );
    let out = single_node_test(&repo, &[("SHARDS", "4")]);
    assert!(out.contains("slurm-test: PASS"), "{out}");
    for line in [
        "ok: 4 of 4 array tasks COMPLETED with exit code 0",
        "ok: no work directory left",
        "ok: catalog current",
    ] {
        assert!(out.contains(line), "missing `{line}`:\n{out}");
    }
    // debye (1 table) + hair-dual (8 tables): all assembled by the array, all byte-identical.
    let summary = out
        .lines()
        .find(|l| l.starts_with("slurm-test: summary:"))
        .expect("a summary line");
    assert!(
        summary.contains("tables 9/9 assembled by the array, 9/9 byte-identical"),
        "{summary}"
    );
    // Without the unsharded build (for manifests too costly to build twice): the tables
    // expected are the plan's, every one assembled by the array, nothing compared.
    let out = single_node_test(&repo, &[("SHARDS", "2"), ("REFERENCE", "0")]);
    let summary = out
        .lines()
        .find(|l| l.starts_with("slurm-test: summary:"))
        .expect("a summary line");
    assert!(
        out.contains("ok: 2 of 2 array tasks COMPLETED with exit code 0")
            && summary.contains("unsharded build skipped")
            && summary.contains("tables 9/9 assembled by the array, no byte comparison")
            && !out.contains("byte comparison:"),
        "{out}"
    );
}

/// `deploy/slurm/single-node-test.sh` with `env`, its output; the script must pass.
fn single_node_test(repo: &Path, env: &[(&str, &str)]) -> String {
    let o = Command::new(repo.join("deploy/slurm/single-node-test.sh"))
        .current_dir(repo)
        .env("SCATTERBAKE_BIN", env!("CARGO_BIN_EXE_scatterbake"))
        .envs(env.iter().copied())
        .output()
        .expect("run deploy/slurm/single-node-test.sh");
    let out = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    println!("{out}");
    assert!(o.status.success(), "single-node Slurm test failed:\n{out}");
    out
}
