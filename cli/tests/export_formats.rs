//! `scatterbake export` on one small table of every kind the default manifests build: every
//! format that applies succeeds and its output reads back (CSV rows, JSON header and rows, EXR
//! channels, size and header text, Mitsuba lists, Legendre moments, MiePlot rows, RGB LUT in
//! each of its file types); every format that does not apply is refused, naming the table's
//! schema and the formats that do.
//!
//! The tables are the entries of `manifests/*.toml` with their grids shrunk (a few seconds in
//! all), one per stage and parameter layout: a default manifest entry of a stage or layout this
//! file does not know fails the test, so a new kind of table cannot go untested.

mod common;
use common::text;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scatterbake(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(args)
        .current_dir(cwd)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .expect("run scatterbake")
}

fn succeed(args: &[&str], cwd: &Path) -> String {
    let o = scatterbake(args, cwd);
    assert!(o.status.success(), "scatterbake {args:?}: {}", text(&o));
    text(&o)
}

/// Schemas whose tables follow the phase-function contract (the phase formats apply).
const PHASE_SCHEMAS: [&str; 4] = [
    "mie-phase",
    "debye-phase",
    "raytrace-phase",
    "mixture-phase",
];

/// Formats that need a phase-function table.
const PHASE_FORMATS: [&str; 4] = ["mitsuba", "legendre", "mieplot", "rgb-lut"];

type Params = toml::Table;

fn set(p: &mut Params, key: &str, value: toml::Value) {
    p.insert(key.into(), value);
}

fn floats(v: &[f64]) -> toml::Value {
    toml::Value::Array(v.iter().map(|&x| toml::Value::Float(x)).collect())
}

fn range(start: f64, stop: f64, count: i64) -> toml::Value {
    let mut t = toml::Table::new();
    t.insert("start".into(), toml::Value::Float(start));
    t.insert("stop".into(), toml::Value::Float(stop));
    t.insert("count".into(), toml::Value::Integer(count));
    toml::Value::Table(t)
}

/// The kind of a default manifest entry (stage and the parameters that choose the table's
/// layout) and its parameters with small grids; `None` for a stage this test does not know.
fn shrink(stage: &str, p: &Params) -> Option<(String, Params)> {
    let mut q = p.clone();
    let wl = || floats(&[450.0, 650.0]);
    let kind = match stage {
        "water-index" => {
            set(&mut q, "wavelength_nm", floats(&[400.0, 700.0, 50.0]));
            stage.to_string()
        }
        "mie" => {
            set(&mut q, "radii_um", floats(&[5.0, 10.0]));
            set(&mut q, "wavelengths_nm", wl());
            set(&mut q, "angle_step_deg", toml::Value::Float(0.5));
            stage.to_string()
        }
        "debye" => {
            set(&mut q, "radii_um", floats(&[10.0]));
            set(&mut q, "wavelengths_nm", wl());
            set(&mut q, "angle_step_deg", toml::Value::Float(0.5));
            stage.to_string()
        }
        "raytrace" => {
            set(&mut q, "wavelengths_nm", wl());
            let shape = p.get("shape")?.as_str()?.to_string();
            if shape == "sphere" {
                set(&mut q, "angle_step_deg", toml::Value::Float(0.5));
            } else {
                set(&mut q, "rays", toml::Value::Integer(40));
                set(&mut q, "polar_step_deg", toml::Value::Float(1.0));
                set(&mut q, "azimuth_step_deg", toml::Value::Float(30.0));
            }
            format!("raytrace {shape}")
        }
        "hair-dual" => {
            set(&mut q, "theta_count", toml::Value::Integer(5));
            if q.contains_key("roughness_deg") {
                set(&mut q, "roughness_deg", floats(&[5.0, 10.0]));
            }
            if q.contains_key("absorption_count") {
                set(&mut q, "absorption_count", toml::Value::Integer(3));
            }
            let mut keys: Vec<&String> = p.keys().collect();
            keys.sort();
            format!("hair-dual {keys:?}")
        }
        "hair-azimuthal" => {
            set(&mut q, "absorption_count", toml::Value::Integer(2));
            set(&mut q, "theta_count", toml::Value::Integer(3));
            set(&mut q, "phi_count", toml::Value::Integer(9));
            stage.to_string()
        }
        "fur-medulla-azimuthal" | "fur-medulla-longitudinal" => {
            set(&mut q, "sigma", floats(&[0.0, 1.0]));
            set(&mut q, "g", floats(&[0.0, 0.4]));
            set(&mut q, "bins", toml::Value::Integer(16));
            if q.contains_key("h") {
                set(&mut q, "h", range(-1.0, 1.0, 3));
            }
            if let Some(toml::Value::Table(t)) = q.get_mut("theta_i_deg") {
                t.insert("count".into(), toml::Value::Integer(2));
            }
            stage.to_string()
        }
        "fur-farfield" => {
            set(&mut q, "samples", toml::Value::Array(vec!["cat".into()]));
            set(&mut q, "theta_i_deg", floats(&[-40.0]));
            set(&mut q, "theta_r_cells", toml::Value::Integer(6));
            set(&mut q, "phi_cells", toml::Value::Integer(8));
            set(&mut q, "h_samples", toml::Value::Integer(16));
            set(&mut q, "photons", toml::Value::Integer(100));
            stage.to_string()
        }
        "cloth" => {
            set(&mut q, "light_step_deg", toml::Value::Float(30.0));
            set(&mut q, "grazing_deg", toml::Value::Float(0.0));
            set(&mut q, "phi_i_step_deg", toml::Value::Float(45.0));
            set(&mut q, "half_fine", toml::Value::Float(5.0));
            set(&mut q, "half_coarse_deg", toml::Value::Float(30.0));
            set(&mut q, "check_points", toml::Value::Integer(10));
            stage.to_string()
        }
        _ => return None,
    };
    Some((kind, q))
}

/// One small manifest entry per kind of table in `manifests/*.toml`: (name, stage, params).
fn small_entries() -> Vec<(String, String, Params)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../manifests");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let mut kinds: BTreeMap<String, (String, String, Params)> = BTreeMap::new();
    for f in &files {
        let doc: toml::Table = std::fs::read_to_string(f).unwrap().parse().unwrap();
        for t in doc["table"].as_array().unwrap() {
            let name = t["name"].as_str().unwrap();
            let stage = t["stage"].as_str().unwrap();
            let params = t.get("params").and_then(|p| p.as_table()).cloned();
            let (kind, small) = shrink(stage, &params.unwrap_or_default()).unwrap_or_else(|| {
                panic!(
                    "{}: table `{name}` of stage `{stage}`: give this stage small parameters in \
                     shrink() so that its exports are tested",
                    f.display()
                )
            });
            kinds
                .entry(kind)
                .or_insert_with(|| (name.to_string(), stage.to_string(), small));
        }
    }
    kinds.into_values().collect()
}

fn write_manifest(path: &Path, entries: &[(String, String, Params)]) {
    let tables: Vec<toml::Value> = entries
        .iter()
        .map(|(name, stage, params)| {
            let mut t = toml::Table::new();
            t.insert("name".into(), name.as_str().into());
            t.insert("stage".into(), stage.as_str().into());
            t.insert("params".into(), toml::Value::Table(params.clone()));
            toml::Value::Table(t)
        })
        .collect();
    let mut doc = toml::Table::new();
    doc.insert("table".into(), toml::Value::Array(tables));
    std::fs::write(path, toml::to_string(&doc).unwrap()).unwrap();
}

/// CSV: one header line naming every axis and channel, then one row per grid point.
fn check_csv(path: &Path, header: &scatterbake::table::Header) {
    let csv = std::fs::read_to_string(path).unwrap();
    let mut lines = csv.lines();
    let columns = lines.next().unwrap().split(',').count();
    assert_eq!(columns, header.axes.len() + header.channels.len());
    let points: usize = header.axes.iter().map(|a| a.len()).product();
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), points, "{}", path.display());
    assert!(rows.iter().all(|r| r.split(',').count() == columns));
}

/// JSON: the header as written and one object per grid point.
fn check_json(path: &Path, header: &scatterbake::table::Header) {
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let back: scatterbake::table::Header = serde_json::from_value(v["header"].clone()).unwrap();
    assert_eq!(&back, header);
    let points: usize = header.axes.iter().map(|a| a.len()).product();
    assert_eq!(v["rows"].as_array().unwrap().len(), points);
}

/// EXR: last axis along x, the others along y, one f32 channel per table channel, and the
/// header text, decoded as UTF-8, equal to the table's header.
fn check_exr(path: &Path, table: &scatterbake::table::Table) {
    let h = &table.header;
    let img = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let layer = &img.layer_data[0];
    let shape = &table.grid_shape();
    assert_eq!(layer.size.width(), *shape.last().unwrap());
    assert_eq!(
        layer.size.height(),
        shape[..shape.len() - 1].iter().product::<usize>().max(1)
    );
    assert_eq!(layer.channel_data.list.len(), h.channels.len());
    let first = &h.channels[0].name;
    let ch = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.bytes() == first.as_bytes())
        .unwrap_or_else(|| panic!("{}: no channel `{first}`", path.display()));
    let stride = h.channels.len();
    for (k, v) in ch.sample_data.values_as_f32().enumerate() {
        assert_eq!(v.to_bits(), table.data[k * stride].to_bits(), "texel {k}");
    }
    let attr = &layer.attributes.other[&exr::meta::attribute::Text::from("scatterbake_header")];
    let exr::meta::attribute::AttributeValue::Text(t) = attr else {
        panic!("{}: scatterbake_header is not text", path.display());
    };
    let json = std::str::from_utf8(t.bytes()).expect("header text is UTF-8");
    let back: scatterbake::table::Header = serde_json::from_str(json).unwrap();
    assert_eq!(&back, h, "{}", path.display());
    let read = scatterbake::consumers::export::generic::read_exr_header(path).unwrap();
    assert_eq!(&read, h);
}

/// Numeric rows of a text export (lines not starting with `#`), split at tabs or commas.
fn numeric_rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .filter_map(|l| {
            l.split(['\t', ','])
                .map(|x| x.trim().parse::<f64>().ok())
                .collect::<Option<Vec<f64>>>()
        })
        .collect()
}

/// The phase formats of one phase-function table, each read back.
fn check_phase_formats(dir: &Path, name: &str, table: &Path) {
    let t = table.to_str().unwrap();
    let out = |ext: &str| dir.join(format!("{name}.{ext}"));
    let xml = out("xml");
    succeed(
        &[
            "export",
            t,
            "--format",
            "mitsuba",
            "--samples",
            "64",
            "--out",
            xml.to_str().unwrap(),
        ],
        dir,
    );
    let xml = std::fs::read_to_string(xml).unwrap();
    let lists: Vec<usize> = xml
        .lines()
        .filter_map(|l| l.trim().strip_prefix("<string name=\"values\" value=\""))
        .map(|v| {
            v.trim_end_matches("\"/>")
                .split([',', ' '])
                .filter(|x| !x.is_empty())
                .count()
        })
        .collect();
    assert_eq!(lists, [64, 64, 64], "{name}: three RGB lists of 64 values");

    let leg = out("legendre.txt");
    succeed(
        &[
            "export",
            t,
            "--format",
            "legendre",
            "--order",
            "8",
            "--out",
            leg.to_str().unwrap(),
        ],
        dir,
    );
    let rows = numeric_rows(&leg);
    assert_eq!(rows.len(), 9, "{name}: orders 0..=8");
    assert!(rows.iter().all(|r| r.len() == 3 && r[0] as usize <= 8));
    // χ_0 = 2π ∫ p dμ of the table's curve, linear between samples: 1 up to how well the
    // shrunk 0.5° grid resolves the forward peak (17 % high for the 0.4 mm sphere).
    assert!(
        rows[0][1..].iter().all(|chi0| (chi0 - 1.0).abs() < 0.25),
        "{name}: chi_0 {:?}",
        rows[0]
    );

    let mp = out("mieplot.txt");
    succeed(
        &[
            "export",
            t,
            "--format",
            "mieplot",
            "--out",
            mp.to_str().unwrap(),
        ],
        dir,
    );
    let rows = numeric_rows(&mp);
    assert!(
        rows.len() > 100 && rows.iter().all(|r| r.len() == 4),
        "{name}: mieplot rows"
    );

    check_rgb_lut(dir, name, t);
}

/// The RGB LUT as CSV, EXR and PNG, each read back.
fn check_rgb_lut(dir: &Path, name: &str, t: &str) {
    let out = |ext: &str| dir.join(format!("{name}.{ext}"));
    for ext in ["csv", "exr", "png"] {
        let lut = out(&format!("lut.{ext}"));
        succeed(
            &[
                "export",
                t,
                "--format",
                "rgb-lut",
                "--samples",
                "181",
                "--out",
                lut.to_str().unwrap(),
            ],
            dir,
        );
        match ext {
            "csv" => assert_eq!(numeric_rows(&lut).len(), 181),
            "exr" => {
                let img = exr::prelude::read_all_flat_layers_from_file(&lut).unwrap();
                assert_eq!(img.layer_data[0].size.width(), 181);
                let h = scatterbake::consumers::export::generic::read_exr_header(&lut).unwrap();
                assert!(
                    h.attributes.contains_key("sun_disc"),
                    "{name}: {:?}",
                    h.attributes
                );
            }
            _ => {
                let dec =
                    png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&lut).unwrap()));
                let reader = dec.read_info().unwrap();
                assert_eq!(reader.info().width, 181);
            }
        }
    }
}

/// A phase format asked of a table that is not a 1-D phase function: refused before any
/// output, naming the format, the table's schema and the formats that apply.
fn check_refused(dir: &Path, table: &Path, schema: &str) {
    for format in PHASE_FORMATS {
        let out = dir.join(format!("refused-{format}.out"));
        let o = scatterbake(
            &[
                "export",
                table.to_str().unwrap(),
                "--format",
                format,
                "--out",
                out.to_str().unwrap(),
            ],
            dir,
        );
        let t = text(&o);
        assert!(
            !o.status.success(),
            "{format} of a {schema} table must fail: {t}"
        );
        assert!(!t.contains("panicked"), "{t}");
        for m in [
            &format!("--format {format} applies to 1-D phase-function tables"),
            schema,
            "csv, json, exr",
        ] {
            assert!(
                t.contains(m),
                "{format} of {schema}: message should name `{m}`: {t}"
            );
        }
        assert!(!out.exists(), "{format}: nothing written");
    }
}

#[test]
fn every_default_kind_of_table_exports_in_every_format_that_applies() {
    let d = tempfile::tempdir().unwrap();
    let entries = small_entries();
    let manifest = d.path().join("small.toml");
    write_manifest(&manifest, &entries);
    succeed(
        &["build", manifest.to_str().unwrap(), "--out", "tables", "-q"],
        d.path(),
    );
    let mut schemas = Vec::new();
    for (name, _, _) in &entries {
        let path = d.path().join(format!("tables/{name}.sbt"));
        let table = scatterbake::table::Table::open(&path).unwrap();
        let schema = table.header.schema.to_string();
        for format in ["csv", "json", "exr"] {
            let out = d.path().join(format!("{name}.{format}"));
            succeed(
                &[
                    "export",
                    path.to_str().unwrap(),
                    "--format",
                    format,
                    "--out",
                    out.to_str().unwrap(),
                ],
                d.path(),
            );
            match format {
                "csv" => check_csv(&out, &table.header),
                "json" => check_json(&out, &table.header),
                _ => check_exr(&out, &table),
            }
        }
        if PHASE_SCHEMAS.contains(&table.header.schema.name.as_str()) {
            check_phase_formats(d.path(), name, &path);
        } else {
            check_refused(d.path(), &path, &schema);
        }
        schemas.push(schema);
    }
    schemas.sort();
    schemas.dedup();
    // Every schema of the default build is among them (a stage that changes its schema must
    // be looked at here).
    for s in [
        "water-index/1",
        "mie-phase/1",
        "debye-phase/1",
        "raytrace-phase/2",
        "raytrace-phase-2d/2",
        "hair-dual/1",
        "hair-azimuthal/1",
        "fur-medulla-azimuthal/1",
        "fur-medulla-longitudinal/1",
        "fur-farfield/1",
        "cloth-brdf/2",
    ] {
        assert!(schemas.iter().any(|x| x == s), "{s} not built: {schemas:?}");
    }
}
