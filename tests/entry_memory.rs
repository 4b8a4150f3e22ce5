//! Memory of the entry readers (`docs/table-format.md`, "Reading one entry"): opening one
//! 16 MiB entry of a table whose payload is 128 MiB of hard-to-compress values costs the entry,
//! not the table. Each reader runs in a child process whose peak resident memory (`wait4`) is
//! compared with the same reader's peak on a small table (the baseline: program, libraries,
//! buffers), measured by the small launcher `tests/data/peak_rss.c` (needs `cc`): the Rust reader through the format crate's example `open_entry`, the C library
//! through `c/example.c`, and the pure-Python reader through `python/test_reader.py` (skipped
//! with `SCATTERBAKE_SKIP_PYTHON=1`). The figures are printed (`--nocapture`).

mod common;

#[cfg(target_os = "linux")]
#[test]
fn entry_readers_keep_memory_to_the_entry() {
    use common::entries::{LARGE_ENTRY_BYTES, exit_and_peak_rss};
    // Beyond twice the entry: the zstd decoder's window and the readers' chunk buffers.
    const MARGIN_BYTES: u64 = 16 << 20;
    const MIB: f64 = (1 << 20) as f64;
    let dir = tempfile::tempdir().unwrap();
    let small = common::entries::entries_table(dir.path());
    let large = common::entries::large_entries_table(dir.path());
    let dump = dir.path().join("dump.bin");
    let rust = common::c::open_entry_exe();
    let c = common::c::example_exe(dir.path());
    let skip_python = std::env::var("SCATTERBAKE_SKIP_PYTHON").is_ok_and(|v| v == "1");
    let python_script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("python/test_reader.py");
    let launcher = common::entries::peak_rss_launcher(dir.path());
    let run = |reader: &str, table: &std::path::Path, entry: Option<&str>| -> u64 {
        let mut args: Vec<std::ffi::OsString> = Vec::new();
        let program = match reader {
            "rust" => {
                args.push(table.into());
                args.extend(entry.map(Into::into));
                rust.clone()
            }
            "c" => {
                args.push(table.into());
                if let Some(e) = entry {
                    args.extend(["--entry".into(), e.into()]);
                }
                c.clone()
            }
            _ => {
                args.extend([
                    python_script.clone().into(),
                    table.into(),
                    dump.clone().into(),
                ]);
                if let Some(e) = entry {
                    args.extend(["--entry".into(), e.into()]);
                }
                common::python::python()
            }
        };
        let (code, peak) = exit_and_peak_rss(&launcher, &program, &args);
        assert_eq!(code, Some(0), "{reader} on {}", table.display());
        peak
    };
    let readers: &[&str] = if skip_python {
        &["rust", "c"]
    } else {
        &["rust", "c", "python"]
    };
    let payload = 8 * LARGE_ENTRY_BYTES;
    for &reader in readers {
        let base = run(reader, &small, Some("1,1,1"));
        let entry = run(reader, &large, Some("1,0,1"));
        let whole = run(reader, &large, None);
        println!(
            "{reader}: peak RSS {:.1} MiB on the small table, {:.1} MiB for one {:.0} MiB entry of \
             the {:.0} MiB payload (+{:.1} MiB), {:.1} MiB for the whole table",
            base as f64 / MIB,
            entry as f64 / MIB,
            LARGE_ENTRY_BYTES as f64 / MIB,
            payload as f64 / MIB,
            (entry as f64 - base as f64) / MIB,
            whole as f64 / MIB
        );
        assert!(
            entry <= base + 2 * LARGE_ENTRY_BYTES + MARGIN_BYTES,
            "{reader}: one entry costs {entry} bytes at peak, baseline {base}"
        );
        // The measurement sees the samples a reader keeps: the whole table costs its payload.
        assert!(
            whole >= base + payload,
            "{reader}: the whole table costs only {whole} bytes at peak"
        );
    }
}
