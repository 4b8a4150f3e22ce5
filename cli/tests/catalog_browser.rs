//! The browsable catalog `index.html` in a real headless browser (Debian's `chromium`): a build
//! of a small manifest writes the page; Chromium loads it from the file system and the test
//! checks that the page's script ran without an error or a console message (a script error, a
//! blocked request or a content-security violation would print one), drew one plot per table,
//! loaded every preview picture, lists every table, and that the filter (`#filter=TEXT`) shows
//! only the matching tables. A screenshot is written to `target/tmp/catalog-browser/page.png`.
//!
//! It needs Chromium, so it runs only when asked; when asked, a missing Chromium is a failure,
//! not a skip. CI (`.ci/run`) installs it and runs this test:
//!
//! ```sh
//! apt-get install -y chromium
//! cargo test -p scatterbake-cli --test catalog_browser -- --ignored
//! ```

use std::path::{Path, PathBuf};
use std::process::Command;

const MANIFEST: &str = r#"
[[table]]
name = "water-index"
stage = "water-index"
[table.params]
wavelength_nm = [380.0, 700.0, 10.0]
temperature_c = [0.0, 20.0]

[[table]]
name = "drops"
stage = "mie"
[table.params]
radii_um = [10.0, 100.0]
wavelengths_nm = [450.0, 650.0]
angle_step_deg = 0.5
"#;

/// Chromium's flags for a headless run as root on a machine without a network.
const CHROMIUM_FLAGS: &[&str] = &[
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-logging=stderr",
    "--v=0",
    "--virtual-time-budget=10000",
];

fn chromium() -> PathBuf {
    let found = Command::new("sh")
        .args(["-c", "command -v chromium"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    found.expect("Chromium is not installed (no chromium on PATH): apt-get install -y chromium")
}

/// Load `url` in headless Chromium with `extra` flags; returns (stdout, stderr).
fn load(url: &str, extra: &[String], profile: &Path) -> (String, String) {
    let o = Command::new(chromium())
        .args(CHROMIUM_FLAGS)
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(url)
        .output()
        .expect("run chromium");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "chromium failed:\n{err}");
    (out, err)
}

/// The value of attribute `name` of the `<body>` tag of a dumped DOM.
fn body_attribute(dom: &str, name: &str) -> Option<String> {
    let start = dom.find("<body")?;
    let tag = &dom[start..start + dom[start..].find('>')?];
    let key = format!("{name}=\"");
    let at = tag.find(&key)? + key.len();
    Some(tag[at..at + tag[at..].find('"')?].to_string())
}

#[test]
#[ignore = "runs Debian's chromium (apt-get install -y chromium); about a minute: cargo test \
            -p scatterbake-cli --test catalog_browser -- --ignored"]
fn the_catalog_page_loads_without_errors_and_shows_every_table_in_chromium() {
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("catalog-browser");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).unwrap();
    let manifest = work.join("page.toml");
    std::fs::write(&manifest, MANIFEST).unwrap();
    let out = work.join("tables");
    let o = Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(["build", "-q"])
        .arg(&manifest)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{said}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(said.contains("index.html: 2 table(s), 2 plotted"), "{said}");
    let page = std::fs::canonicalize(out.join("index.html")).unwrap();
    let url = format!("file://{}", page.display());

    let (dom, log) = load(&url, &["--dump-dom".into()], &work.join("profile-1"));
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(
        console.is_empty(),
        "console messages:\n{}",
        console.join("\n")
    );
    assert_eq!(body_attribute(&dom, "data-errors"), None, "script errors");
    assert_eq!(
        body_attribute(&dom, "data-rendered").as_deref(),
        Some("2"),
        "plots drawn"
    );
    assert_eq!(
        body_attribute(&dom, "data-broken-images").as_deref(),
        Some("0")
    );
    assert_eq!(body_attribute(&dom, "data-shown").as_deref(), Some("2"));
    for name in ["water-index", "drops"] {
        assert!(
            dom.contains(&format!("data-name=\"{name}\"")),
            "{name} not listed"
        );
    }
    // every plot is an SVG with one path per curve (drops: 2 wavelengths; water-index: 1)
    assert_eq!(dom.matches("<svg").count(), 2, "{dom}");
    assert!(dom.matches("<path").count() >= 3);
    assert!(dom.contains("wavelength = 650 nm"));

    let (dom, _) = load(
        &format!("{url}#filter=water"),
        &["--dump-dom".into()],
        &work.join("profile-2"),
    );
    assert_eq!(body_attribute(&dom, "data-shown").as_deref(), Some("1"));

    let shot = work.join("page.png");
    load(
        &url,
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1200,1600".into(),
        ],
        &work.join("profile-3"),
    );
    let png = std::fs::read(&shot).unwrap();
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 20_000,
        "{} bytes",
        png.len()
    );
}
