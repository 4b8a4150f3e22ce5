//! The Python interpreter of the tests that run Python (the Python reader, the documentation's
//! Python examples): a virtual environment under the target directory
//! (`target/tmp/python-test-venv`, so `cargo clean` removes it), created on first use with
//! `python3 -m venv --system-site-packages` and `pip install numpy zstandard`, then reused.
//! With the system's site packages visible, a machine whose `python3` already has numpy and
//! zstandard needs no download; one without them gets them from the package index once. A
//! missing `python3`, a missing `venv` module or a failed installation fails the test with the
//! command that failed, its output and the fix. Test binaries and threads share one environment
//! (a file lock serialises its creation; a marker file says it is complete).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The modules the Python code under test imports.
pub const MODULES: [&str; 2] = ["numpy", "zstandard"];

/// The environment's interpreter, provisioned on first call.
pub fn python() -> PathBuf {
    static PYTHON: OnceLock<PathBuf> = OnceLock::new();
    PYTHON.get_or_init(provision).clone()
}

fn interpreter(venv: &Path) -> PathBuf {
    if cfg!(windows) {
        venv.join("Scripts").join("python.exe")
    } else {
        venv.join("bin").join("python")
    }
}

/// Run `cmd` (described as `what`); panic with its output and `fix` when it fails.
fn run(cmd: &mut Command, what: &str, fix: &str) {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot run it ({e}). {fix}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}{}\n{fix}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn provision() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    std::fs::create_dir_all(dir).unwrap();
    let venv = dir.join("python-test-venv");
    let python = interpreter(&venv);
    let ready = venv.join(".provisioned");
    let lock = std::fs::File::create(dir.join("python-test-venv.lock")).unwrap();
    lock.lock().unwrap();
    if !ready.exists() {
        let start = std::time::Instant::now();
        eprintln!(
            "creating the tests' Python environment {} (python3 -m venv, pip install {})",
            venv.display(),
            MODULES.join(" ")
        );
        if venv.exists() {
            std::fs::remove_dir_all(&venv).unwrap();
        }
        run(
            Command::new("python3")
                .args(["-m", "venv", "--system-site-packages"])
                .arg(&venv),
            "python3 -m venv --system-site-packages",
            "The tests that run Python need Python 3 with its venv module on PATH as `python3` \
             (Debian/Ubuntu: apt-get install python3 python3-venv).",
        );
        run(
            Command::new(&python)
                .args([
                    "-m",
                    "pip",
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                ])
                .args(MODULES),
            &format!("pip install {} into {}", MODULES.join(" "), venv.display()),
            "Without network access, install them for the system's python3 (Debian/Ubuntu: \
             apt-get install python3-numpy python3-zstandard; the environment sees the \
             system's packages), then run the tests again.",
        );
        let probe = format!("import {}", MODULES.join(", "));
        run(
            Command::new(&python).args(["-c", &probe]),
            &format!("{} -c '{probe}'", python.display()),
            "The environment was created but cannot import the modules; remove it and retry.",
        );
        std::fs::write(&ready, b"").unwrap();
        eprintln!(
            "created {} in {:.1} s",
            venv.display(),
            start.elapsed().as_secs_f64()
        );
    }
    lock.unlock().unwrap();
    python
}
