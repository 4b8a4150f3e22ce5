//! Tests of the consumer commands through their clap `Args` + `run_*` entry points, on tables written
//! by the Rust writer: MiePlot export → validate round trip (zero error), Legendre export
//! reconstructs to the reported truncation error, Mitsuba snippet, plots and the renderer write
//! decodable images of the requested size that show what they should.

use crate::commands::export::{legendre, mieplot, mitsuba, rgb_lut};
use crate::commands::{plot, plot_raytrace, render, validate};
use clap::Parser;
use scatterbake::fixtures;
use scatterbake::table::write_table_atomic;
use std::path::{Path, PathBuf};

/// A `hair-dual/1` table of the stage parameters `toml_src`, written to `dir/name` (tests of the
/// hair commands).
pub(crate) fn write_hair_dual_table(dir: &Path, toml_src: &str, name: &str) -> PathBuf {
    use scatterbake::hair::tables::ThetaRowTable;
    use scatterbake::stages::hair::{HairDualParams, dual_table};
    use scatterbake::table::{Provenance, Table};
    let params: HairDualParams = toml::from_str(toml_src).unwrap();
    let content = dual_table(&params).unwrap().compute().unwrap();
    let mut table = Table::from_content(content, Provenance::default()).unwrap();
    let path = dir.join(name);
    write_table_atomic(&mut table, &path).unwrap();
    path
}

#[derive(Parser)]
struct Cli<A: clap::Args> {
    #[command(flatten)]
    args: A,
}

fn parse<A: clap::Args>(argv: &[&str]) -> A {
    Cli::<A>::try_parse_from(std::iter::once("test").chain(argv.iter().copied()))
        .unwrap_or_else(|e| panic!("{e}"))
        .args
}

fn hg_table(dir: &Path) -> PathBuf {
    let p = dir.join("hg.sbt");
    let mut t = fixtures::henyey_greenstein_table(
        &[450.0, 550.0, 650.0],
        &[100.0, 500.0],
        |k, r| 0.6 + 0.05 * k as f64 + 0.1 * r as f64,
        1801,
        0.3,
    );
    write_table_atomic(&mut t, &p).unwrap();
    p
}

fn decode_png(p: &Path) -> (u32, u32, Vec<u8>) {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn mieplot_export_then_validate_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let t = hg_table(dir.path());
    let out = dir.path().join("ref.txt");
    let (ts, os) = (t.to_str().unwrap(), out.to_str().unwrap());
    mieplot::run_mieplot(&parse(&[
        ts,
        "--entry",
        "radius=500",
        "--wavelength-nm",
        "550",
        "--out",
        os,
    ]))
    .unwrap();
    let r = scatterbake::consumers::export::mieplot::read_mieplot_file(&out).unwrap();
    assert_eq!(r.angle_deg.len(), 1801);
    assert_eq!(r.wavelength_nm, Some(550.0));
    let pt = scatterbake::consumers::read::phase::PhaseTable::open(&t).unwrap();
    let rep = scatterbake::consumers::export::mieplot::compare(
        &pt,
        &["radius=500".parse().unwrap()],
        550.0,
        &r,
        false,
    )
    .unwrap();
    assert_eq!(rep.max_rel_error, [0.0; 3], "{rep:?}");
    // validate with zero tolerance passes for the right entry and fails for another.
    validate::run_validate(&parse(&[
        ts,
        "--reference",
        os,
        "--entry",
        "radius=500",
        "--tolerance",
        "0",
    ]))
    .unwrap();
    assert!(
        validate::run_validate(&parse(&[
            ts,
            "--reference",
            os,
            "--entry",
            "radius=100",
            "--tolerance",
            "1e-3"
        ]))
        .is_err()
    );
}

#[test]
fn legendre_export_reconstructs_to_reported_error() {
    let dir = tempfile::tempdir().unwrap();
    let t = hg_table(dir.path());
    let out = dir.path().join("leg.txt");
    let (ts, os) = (t.to_str().unwrap(), out.to_str().unwrap());
    // g = 0.6 + 0.05 + 0.1 = 0.75 at 550 nm, radius 500.
    legendre::run_legendre(&parse(&[
        ts,
        "--entry",
        "radius=500",
        "--order",
        "40",
        "--wavelength-nm",
        "550",
        "--out",
        os,
    ]))
    .unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let reported: f64 = text
        .lines()
        .find(|l| l.starts_with("# truncation:"))
        .and_then(|l| l.split("max_rel_error ").nth(1))
        .and_then(|s| s.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    let chi: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split('\t').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(chi.len(), 41);
    for (l, c) in chi.iter().enumerate() {
        assert!((c - 0.75f64.powi(l as i32)).abs() < 2e-4, "chi_{l} = {c}");
    }
    // Reconstruct from the file and compare with the analytic HG: the largest relative error
    // equals the reported one (to its 4 printed digits, plus the grid's interpolation error).
    let mut worst: f64 = 0.0;
    for j in 0..=1800 {
        let t = j as f64 * 0.1;
        let mu = t.to_radians().cos();
        let exact = scatterbake::optics::henyey_greenstein::hg_density_sr(mu, 0.75) as f32 as f64;
        worst = worst.max(
            (scatterbake::consumers::export::legendre::reconstruct(&chi, mu) - exact).abs() / exact,
        );
    }
    assert!(
        (worst - reported).abs() < 1e-3 * reported + 1e-6,
        "worst {worst}, reported {reported}"
    );
    assert!(
        reported > 1e-4,
        "order 40 of HG(0.75) must leave a visible truncation error"
    );
}

#[test]
fn mitsuba_export_writes_three_rgb_lists() {
    let dir = tempfile::tempdir().unwrap();
    let t = hg_table(dir.path());
    let (xml, vals) = (dir.path().join("p.xml"), dir.path().join("p.txt"));
    mitsuba::run_mitsuba(&parse(&[
        t.to_str().unwrap(),
        "--samples",
        "512",
        "--out",
        xml.to_str().unwrap(),
        "--values-out",
        vals.to_str().unwrap(),
    ]))
    .unwrap();
    let x = std::fs::read_to_string(&xml).unwrap();
    assert_eq!(x.matches("<phase type=\"tabphase\"").count(), 3);
    let lists: Vec<Vec<f64>> = std::fs::read_to_string(&vals)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect();
    assert_eq!(lists.len(), 3);
    for l in &lists {
        assert_eq!(l.len(), 512);
        // Forward-peaked HG(g ≈ 0.6–0.7): p(+1)/p(−1) = ((1+g)/(1−g))³ ≥ 64.
        assert!(l[511] > 30.0 * l[0], "{} {}", l[511], l[0]);
    }
}

#[test]
fn plots_and_render_write_images_that_show_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let t = hg_table(dir.path());
    let ts = t.to_str().unwrap();
    for ext in ["png", "svg"] {
        let out = dir.path().join(format!("phase.{ext}"));
        plot::run_plot(&parse(&[
            ts,
            "--kind",
            "phase",
            "--polarised",
            "--width",
            "640",
            "--height",
            "400",
            "--out",
            out.to_str().unwrap(),
        ]))
        .unwrap();
        assert!(std::fs::metadata(&out).unwrap().len() > 1000);
    }
    let (w, h, px) = decode_png(&dir.path().join("phase.png"));
    assert_eq!((w, h), (640, 400));
    // The 650 nm curve is drawn in its own (red) colour.
    let red = scatterbake::consumers::plot::style::wavelength_colour(650.0);
    assert!(
        px.chunks(3).any(|p| p == [red.0, red.1, red.2]),
        "no pixel in the 650 nm colour"
    );
    let svg = std::fs::read_to_string(dir.path().join("phase.svg")).unwrap();
    assert!(svg.contains("scattering angle"));
    // Auto previews: phase, strip and Lee (the table has a radius axis).
    let prev = dir.path().join("previews");
    plot::run_plot(&parse(&[ts, "--out", prev.to_str().unwrap()])).unwrap();
    for k in ["phase", "strip", "lee"] {
        let (w, _, _) = decode_png(&prev.join(format!("hg-{k}.png")));
        assert!(w > 100);
    }
    // Renderer: a peak at 138° gives a ring; the PNG has the requested size and the ring is
    // the brightest thing in the picture.
    let peak = dir.path().join("peak.sbt");
    let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
    write_table_atomic(
        &mut fixtures::peak_table(&wl, |_| 138.0, 0.3, 1e-4, 1801),
        &peak,
    )
    .unwrap();
    let out = dir.path().join("sky.png");
    render::run_render_rainbow(&parse(&[
        "--table",
        peak.to_str().unwrap(),
        "--width",
        "300",
        "--height",
        "200",
        "--view-elevation-deg",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]))
    .unwrap();
    let (w, h, px) = decode_png(&out);
    assert_eq!((w, h), (300, 200));
    // Centre column: brightest pixel at elevation 42 − 25 = 17° (equidistant fisheye, 0.4°/px).
    let pix = 120.0 / 300.0;
    let col = 150usize;
    let (jbest, _) = (0..200usize)
        .map(|j| {
            let p = &px[(j * 300 + col) * 3..][..3];
            (j, p[0] as u32 + p[1] as u32 + p[2] as u32)
        })
        .max_by_key(|x| x.1)
        .unwrap();
    let elev = 5.0 + (100.0 - jbest as f64 - 0.5) * pix;
    assert!((elev - 17.0).abs() <= pix, "ring top at elevation {elev}");
}

#[test]
fn previews_of_non_phase_tables() {
    use scatterbake::table::{Axis, Channel, Provenance, Schema, Table, TableContent};
    let dir = tempfile::tempdir().unwrap();
    // 1-D table (like the water index table) → line plot.
    let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("test-1d", 1),
        description: "refractive index".into(),
        axes: vec![Axis::values("wavelength", "nm", wl.clone())],
        channels: vec![Channel::new("n", "1", "real index")],
        attributes: serde_json::Map::new(),
        data: wl
            .iter()
            .map(|l| (1.33 + 3000.0 / (l * l)) as f32)
            .collect(),
    };
    let p1 = dir.path().join("index.sbt");
    write_table_atomic(
        &mut Table::from_content(content, Provenance::default()).unwrap(),
        &p1,
    )
    .unwrap();
    // 2-D phase function layout → lat-long heatmap; bright spot at polar 40°, azimuth 90°.
    let (np, na) = (91, 72);
    let mut data = Vec::new();
    for _ in 0..2 {
        for i in 0..np {
            for j in 0..na {
                let (t, f) = (i as f32 * 2.0, j as f32 * 5.0);
                let v = 1e-3 + (-((t - 40.0).powi(2) + (f - 90.0).powi(2)) / 50.0).exp();
                data.extend_from_slice(&[v, v, v, 0.0]);
            }
        }
    }
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("test-2d", 1),
        description: "2-D".into(),
        axes: vec![
            Axis::values("wavelength", "nm", vec![450.0, 650.0]),
            Axis::uniform("outgoing_polar", "deg", 0.0, 2.0, np),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, 5.0, na),
        ],
        channels: ["phase", "i_perp", "i_par", "dolp"]
            .iter()
            .map(|n| Channel::new(n, "1/sr", "test"))
            .collect(),
        attributes: serde_json::Map::new(),
        data,
    };
    let p2 = dir.path().join("latlong.sbt");
    write_table_atomic(
        &mut Table::from_content(content, Provenance::default()).unwrap(),
        &p2,
    )
    .unwrap();
    let out = dir.path().join("prev");
    let w1 = scatterbake::consumers::plot::previews::previews(&p1, &out).unwrap();
    assert_eq!(w1, vec![out.join("index-line.png")]);
    let w2 = scatterbake::consumers::plot::previews::previews(&p2, &out).unwrap();
    assert_eq!(w2, vec![out.join("latlong-heatmap.png")]);
    // The heatmap's brightest colour (viridis top, yellow) appears: the spot is drawn.
    let (_, _, px) = decode_png(&w2[0]);
    assert!(
        px.chunks(3).any(|p| p[0] > 200 && p[1] > 200 && p[2] < 100),
        "no bright spot drawn"
    );
}

/// `render rainbow` and `plot-raytrace` on a 2-D (`raytrace-phase-2d/1`) table: a sphere's
/// 1-D peak replicated over azimuth renders its ring at the same place as the 1-D table; sun
/// elevations outside the table's axis are refused with the range; previews are written.
#[test]
fn render_and_plot_two_d_tables() {
    let dir = tempfile::tempdir().unwrap();
    let wl: Vec<f64> = (0..5).map(|i| 450.0 + 50.0 * i as f64).collect();
    let t1 = fixtures::peak_table(&wl, |_| 138.0, 0.3, 1e-4, 1801);
    let mut t2 = fixtures::lat_long_from_1d(&t1, &[0.0, 10.0, 20.0], 10.0, |_, _| 1.0);
    let p2 = dir.path().join("sphere2d.sbt");
    write_table_atomic(&mut t2, &p2).unwrap();
    let out = dir.path().join("sky2d.png");
    let args = |e: &str| {
        parse::<render::RenderRainbowArgs>(&[
            "--table",
            p2.to_str().unwrap(),
            "--sun-elevation-deg",
            e,
            "--width",
            "300",
            "--height",
            "200",
            "--view-elevation-deg",
            "5",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let err = render::run_render_rainbow(&args("25"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("`sun_elevation` range [0, 20] deg"), "{err}");
    // Between two traced elevations: refused (blending 10° and 20° would draw two bows),
    // naming the nearest traced elevation.
    let err = format!("{:#}", render::run_render_rainbow(&args("14")).unwrap_err());
    assert!(
        err.contains("between the samples 10 and 20 deg") && err.contains("nearest is 10 deg"),
        "{err}"
    );
    render::run_render_rainbow(&args("10")).unwrap();
    let (w, h, px) = decode_png(&out);
    assert_eq!((w, h), (300, 200));
    // Centre column: brightest pixel at elevation 42 − 10 = 32° (0.4°/px).
    let pix = 120.0 / 300.0;
    let (jbest, _) = (0..200usize)
        .map(|j| {
            let p = &px[(j * 300 + 150) * 3..][..3];
            (j, p[0] as u32 + p[1] as u32 + p[2] as u32)
        })
        .max_by_key(|x| x.1)
        .unwrap();
    let elev = 5.0 + (100.0 - jbest as f64 - 0.5) * pix;
    assert!((elev - 32.0).abs() <= pix, "ring top at elevation {elev}");
    // Previews (lat-long + bows) and the bows plot of two tables.
    let prev = dir.path().join("previews");
    let written = scatterbake::consumers::plot::previews::previews(&p2, &prev).unwrap();
    assert_eq!(written.len(), 2);
    for f in &written {
        assert!(decode_png(f).0 > 100);
    }
    let bows = dir.path().join("bows.png");
    plot_raytrace::run_plot_raytrace(&parse(&[
        p2.to_str().unwrap(),
        p2.to_str().unwrap(),
        "--kind",
        "bows",
        "--sun-elevation-deg",
        "20",
        "--out",
        bows.to_str().unwrap(),
    ]))
    .unwrap();
    assert!(decode_png(&bows).0 == 1500);
}

/// A narrow peak (σ = 0.3°) at 138° written twice with the same data: once stating that the
/// 0.5° sun disc is already applied, once as a point-sun table.
fn peak_pair(dir: &Path) -> (PathBuf, PathBuf) {
    let wl: Vec<f64> = (0..9).map(|i| 380.0 + 40.0 * i as f64).collect();
    let mut pair = vec![];
    for (name, sun) in [("disc.sbt", 0.5), ("point.sbt", 0.0)] {
        let mut t = fixtures::peak_table(&wl, |w| 137.0 + w / 500.0, 0.3, 1e-4, 3601);
        t.header
            .attributes
            .insert("sun_diameter_deg".into(), sun.into());
        let p = dir.join(name);
        write_table_atomic(&mut t, &p).unwrap();
        pair.push(p);
    }
    (pair[0].clone(), pair[1].clone())
}

fn csv_rows(p: &Path) -> Vec<String> {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(str::to_string)
        .collect()
}

/// rgb-lut of a table that already averaged the 0.5° disc equals the disc-free conversion of
/// the same data (no second disc); the point-sun table gets the disc (its bow peak drops);
/// a request below the table's disc is refused naming it; a format is refused before any work.
#[test]
fn rgb_lut_applies_only_the_disc_the_table_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let (disc, point) = peak_pair(dir.path());
    let run = |t: &Path, extra: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut argv = vec![t.to_str().unwrap(), "--samples", "3601", "--out"];
        argv.push(out.to_str().unwrap());
        argv.extend_from_slice(extra);
        rgb_lut::run_lut(&parse::<rgb_lut::LutArgs>(&argv)).map(|_| out)
    };
    let a = run(&disc, &[], "disc.csv").unwrap();
    let b = run(&point, &["--sun-diameter-deg", "0"], "point0.csv").unwrap();
    assert_eq!(csv_rows(&a), csv_rows(&b));
    let first = std::fs::read_to_string(&a).unwrap();
    assert!(
        first.starts_with("# sun_disc: sun disc 0.5 deg: already averaged"),
        "{first}"
    );
    // The point-sun table by default shows the 0.5° sun: the peak's red maximum drops.
    let c = run(&point, &[], "point.csv").unwrap();
    let peak = |p: &Path| {
        csv_rows(p)[1..]
            .iter()
            .map(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap())
            .fold(0.0, f64::max)
    };
    let ratio = peak(&c) / peak(&a);
    assert!(
        ratio < 0.97,
        "disc applied to the point-sun table: ratio {ratio}"
    );
    let err = run(&disc, &["--sun-diameter-deg", "0.25"], "x.csv")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("0.5 deg sun disc the table already averaged"),
        "{err}"
    );
    let err = run(Path::new("/nonexistent.sbt"), &[], "x.tiff")
        .unwrap_err()
        .to_string();
    assert!(err.contains("must end in .exr, .csv or .png"), "{err}");
}

/// render rainbow of the disc-averaged table equals, pixel for pixel, the point-sun render of
/// the same data; with its default disc the point-sun table renders differently.
#[test]
fn render_applies_only_the_disc_the_table_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let (disc, point) = peak_pair(dir.path());
    let run = |t: &Path, extra: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut argv = vec![
            "--table",
            t.to_str().unwrap(),
            "--width",
            "150",
            "--height",
            "100",
            "--view-elevation-deg",
            "5",
            "--exposure",
            "1e-2",
            "--out",
        ];
        argv.push(out.to_str().unwrap());
        argv.extend_from_slice(extra);
        render::run_render_rainbow(&parse(&argv)).map(|_| decode_png(&out).2)
    };
    let a = run(&disc, &[], "disc.png").unwrap();
    let b = run(&point, &["--sun-diameter-deg", "0"], "point0.png").unwrap();
    assert!(a == b, "disc-averaged table rendered with a second disc");
    let c = run(&point, &[], "point.png").unwrap();
    assert!(a != c, "the point-sun table must get the 0.5 deg disc");
    let err = run(&disc, &[], "sky.jpg").unwrap_err().to_string();
    assert!(err.contains("must end in .png"), "{err}");
}

/// Strips and Lee diagrams: the colours of the disc-averaged table (default request) are the
/// disc-free colours of the same data; the command's default request is "the table's disc".
#[test]
fn plot_strip_applies_only_the_disc_the_table_lacks() {
    use scatterbake::consumers::read::operators::SunDisc;
    use scatterbake::consumers::read::phase::PhaseTable;
    let dir = tempfile::tempdir().unwrap();
    let (disc, point) = peak_pair(dir.path());
    let (a, b) = (
        PhaseTable::open(&disc).unwrap(),
        PhaseTable::open(&point).unwrap(),
    );
    let args: plot::PlotArgs =
        parse(&[disc.to_str().unwrap(), "--kind", "strip", "--out", "x.png"]);
    assert_eq!(args.sun_diameter_deg, None);
    let plan = SunDisc::plan(&a.table, args.sun_diameter_deg).unwrap();
    let xa = scatterbake::consumers::plot::tables::strip_xyz(&a, &[], &plan).unwrap();
    let xb = scatterbake::consumers::read::spectrum::xyz_vs_angle(&b, &[], 0.0).unwrap();
    assert_eq!(xa, xb);
    let out = dir.path().join("strip.png");
    let got = scatterbake::consumers::plot::tables::plot_strip(
        &a,
        &[],
        None,
        (120.0, 145.0),
        &out,
        (400, 100),
    )
    .unwrap();
    assert_eq!(got.extra_deg, 0.0);
    assert_eq!(decode_png(&out).0, 400);
}

/// Entry axes a table does not declare interpolable take stored samples: radius=450 between
/// 100 and 500 µm is refused naming the nearest, radius=99999 names the axis range.
#[test]
fn coarse_entry_axes_are_not_interpolated() {
    let dir = tempfile::tempdir().unwrap();
    let t = hg_table(dir.path());
    let out = dir.path().join("sky.png");
    let run = |e: &str| {
        render::run_render_rainbow(&parse(&[
            "--table",
            t.to_str().unwrap(),
            "--entry",
            e,
            "--width",
            "60",
            "--out",
            out.to_str().unwrap(),
        ]))
        .map_err(|e| format!("{e:#}"))
    };
    let err = run("radius=450").unwrap_err();
    assert!(
        err.contains("between the samples 100 and 500 um") && err.contains("nearest is 500 um"),
        "{err}"
    );
    let err = run("radius=99999").unwrap_err();
    assert!(
        err.contains("outside the table's `radius` range [100, 500] um"),
        "{err}"
    );
    run("radius=500").unwrap();
    // rgb-lut reads entries the same way.
    let err = rgb_lut::run_lut(&parse::<rgb_lut::LutArgs>(&[
        t.to_str().unwrap(),
        "--entry",
        "radius=450",
        "--out",
        dir.path().join("l.csv").to_str().unwrap(),
    ]))
    .unwrap_err()
    .to_string();
    assert!(err.contains("nearest is 500 um"), "{err}");
}
