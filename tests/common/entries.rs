//! Tables of several entries for the entry readers (`docs/table-format.md`, "Reading one
//! entry"): a small one in the layout of `raytrace-phase-2d/2` (radius × wavelength ×
//! sun_elevation × outgoing_polar × outgoing_azimuth, four channels) and a large one of
//! hard-to-compress values whose payload is many times one entry; and the peak memory of a
//! child process.

use scatterbake::table::{
    Axis, Channel, Provenance, Schema, Table, TableContent, write_table_atomic,
};
use std::path::{Path, PathBuf};

/// The channels of a `raytrace-phase-2d` table.
fn channels() -> Vec<Channel> {
    ["phase", "i_perp", "i_par", "dolp"]
        .iter()
        .map(|n| Channel::new(n, "1/sr", "test"))
        .collect()
}

/// Leading axes with 2, `wavelengths.len()` and 2 samples (explicit with labels, explicit,
/// uniform), then the outgoing directions, and `f(flat index)` as the values.
fn content(
    wavelengths: &[f64],
    n_polar: usize,
    n_azimuth: usize,
    f: impl FnMut(usize) -> f32,
) -> TableContent {
    let axes = vec![
        Axis::labelled(
            "radius",
            "um",
            vec![500.0, 1500.0],
            vec!["small drop".into(), "large drop".into()],
        ),
        Axis::values("wavelength", "nm", wavelengths.to_vec()),
        Axis::uniform("sun_elevation", "deg", 0.0, 20.0, 2),
        // Steps exact in binary in the small table (30° and 72°), so that the coordinate of a
        // sample locates exactly on it.
        Axis::uniform(
            "outgoing_polar",
            "deg",
            0.0,
            180.0 / (n_polar - 1) as f64,
            n_polar,
        ),
        Axis::uniform(
            "outgoing_azimuth",
            "deg",
            0.0,
            360.0 / n_azimuth as f64,
            n_azimuth,
        ),
    ];
    let n: usize = axes.iter().map(Axis::len).product::<usize>() * 4;
    TableContent {
        encoding: Default::default(),
        schema: Schema::new("raytrace-phase-2d", 2),
        description: "entries of a ray-traced layout".into(),
        axes,
        channels: channels(),
        attributes: serde_json::Map::new(),
        data: (0..n).map(f).collect(),
    }
}

fn write(dir: &Path, name: &str, content: TableContent) -> PathBuf {
    let mut t = Table::from_content(content, Provenance::default()).unwrap();
    let p = dir.join(name);
    write_table_atomic(&mut t, &p).unwrap();
    p
}

/// The small table: 12 entries of 7 × 5 directions, every value distinct (and one NaN).
pub fn entries_table(dir: &Path) -> PathBuf {
    write(
        dir,
        "entries.sbt",
        content(&[450.0, 550.0, 650.0], 7, 5, |i| {
            if i == 100 {
                f32::NAN
            } else {
                1e-3 * (1.0 + i as f32) * if i % 3 == 0 { -1.0 } else { 1.0 }
            }
        }),
    )
}

/// Every full entry (one index per leading axis) of the small table, then some partial ones
/// and the empty one (the whole table).
pub fn entries() -> Vec<Vec<usize>> {
    let mut v = Vec::new();
    for r in 0..2 {
        for w in 0..3 {
            for e in 0..2 {
                v.push(vec![r, w, e]);
            }
        }
    }
    v.extend([
        vec![1],
        vec![0, 2],
        vec![1, 1, 0, 3],
        vec![1, 2, 1, 6, 4],
        vec![],
    ]);
    v
}

/// A lookup point for an entry: the fixed coordinate on each fixed axis, between the first two
/// samples on the others.
pub fn lookup_point(whole: &Table, entry: &[usize]) -> Vec<f64> {
    whole
        .axes()
        .iter()
        .enumerate()
        .map(|(k, a)| match entry.get(k) {
            Some(&i) => a.coord(i),
            None if a.len() > 1 => 0.37 * a.coord(0) + 0.63 * a.coord(1),
            None => a.coord(0),
        })
        .collect()
}

/// The crafted corpus (`crafted::cases`) written into `dir` and run through a reader as
/// `run(file, first_entry)`: the cases where opening the first entry (`true`) and the whole
/// table (`false`) exit differently or print different messages.
pub fn crafted_entry_mismatches(
    dir: &Path,
    run: impl Fn(&Path, bool) -> std::process::Output,
) -> Vec<String> {
    let mut wrong = Vec::new();
    for case in super::crafted::cases() {
        let p = dir.join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        let (whole, first) = (run(&p, false), run(&p, true));
        if whole.status.code() != first.status.code() || whole.stderr != first.stderr {
            wrong.push(format!(
                "{}: whole exit {:?} {}, entry exit {:?} {}",
                case.name,
                whole.status.code(),
                String::from_utf8_lossy(&whole.stderr),
                first.status.code(),
                String::from_utf8_lossy(&first.stderr)
            ));
        }
    }
    wrong
}

/// Bytes of one entry of the large table.
pub const LARGE_ENTRY_BYTES: u64 = 16 << 20;

/// The large table: 8 entries of 1024 × 1024 directions × 4 channels (16 MiB each, 128 MiB of
/// payload) of random mantissas, which zstd cannot shrink much.
pub fn large_entries_table(dir: &Path) -> PathBuf {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let p = write(
        dir,
        "large.sbt",
        content(&[450.0, 650.0], 1024, 1024, |_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            1e-3 * (1.0 + (state >> 40) as f32 / (1u64 << 24) as f32)
        }),
    );
    let t = scatterbake::table::read_header_only(&p).unwrap();
    assert_eq!(t.payload.uncompressed_bytes, 8 * LARGE_ENTRY_BYTES);
    p
}

/// Compile `tests/data/peak_rss.c` (with `cc`) into `dir`.
#[cfg(target_os = "linux")]
pub fn peak_rss_launcher(dir: &Path) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/peak_rss.c");
    let exe = dir.join("peak_rss");
    let out = std::process::Command::new("cc")
        .args(["-O1", "-Wall", "-Werror"])
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("the memory tests need a C compiler `cc` on PATH");
    assert!(
        out.status.success(),
        "cc failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

/// Run `program args` to its end through the launcher of [`peak_rss_launcher`] and return its
/// exit code and its own peak resident memory in bytes.
#[cfg(target_os = "linux")]
pub fn exit_and_peak_rss(
    launcher: &Path,
    program: &Path,
    args: &[std::ffi::OsString],
) -> (Option<i32>, u64) {
    let out = std::process::Command::new(launcher)
        .arg(program)
        .args(args)
        .stderr(std::process::Stdio::inherit())
        .output()
        .expect("the launcher runs");
    let text = String::from_utf8_lossy(&out.stdout);
    let f: Vec<i64> = text
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    assert!(out.status.success() && f.len() == 2, "launcher: {text}");
    let code = (f[0] >= 0).then_some(f[0] as i32);
    (code, f[1] as u64 * 1024)
}
