//! Whole-process speed of one sphere: `scatterbake mie --x X --n 1.333 --angles 0:180:0.05
//! --format json` (3601 angles) against a peer process that solves the same sphere with the
//! independent `scatrs` crate and prints the same eight JSON columns. Both are started as
//! processes, alternately, the same number of times in the same run; the table gives median wall
//! times and their ratio (peer / scatterbake), and checks that both print the same phase function.
//!
//! ```text
//! cargo build --release -p scatterbake-cli && cargo run --release --example mie_process_speed
//! cargo run --release --example mie_process_speed -- --runs 31 --cli target/release/scatterbake 100 1e4
//! ```
//! The peer mode (`mie_process_speed peer X`) is what the driver starts for scatrs.

use anyhow::{Context, Result, bail, ensure};
use num_complex::Complex64;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Instant;

const INDEX: f64 = 1.333;
const ANGLES: &str = "0:180:0.05";
const ANGLE_COUNT: usize = 3601;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("peer") {
        let x: f64 = args.get(1).context("peer X")?.parse()?;
        return peer(x);
    }
    let mut runs = 21usize;
    let mut cli = std::env::current_exe()?
        .parent()
        .and_then(|p| p.parent())
        .context("locating target/release")?
        .join("scatterbake");
    let mut xs = Vec::new();
    let mut it = args.into_iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--runs" => runs = it.next().context("--runs N")?.parse()?,
            "--cli" => cli = PathBuf::from(it.next().context("--cli PATH")?),
            _ => xs.push(
                a.parse::<f64>()
                    .with_context(|| format!("size parameter {a}"))?,
            ),
        }
    }
    if xs.is_empty() {
        xs = vec![1e2, 1e3, 1e4];
    }
    ensure!(
        cli.is_file(),
        "{} not found: build it with `cargo build --release -p scatterbake-cli`",
        cli.display()
    );
    let me = std::env::current_exe()?;
    println!("| x | scatterbake (ms) | scatrs peer (ms) | ratio | max rel. diff of phase |");
    println!("|---|---|---|---|---|");
    for x in xs {
        let ours = cli_command(&cli, x);
        let peer = peer_command(&me, x);
        let diff = phase_difference(&ours, &peer)?;
        let (mut t_ours, mut t_peer) = (Vec::new(), Vec::new());
        for _ in 0..runs {
            t_ours.push(time(&ours)?);
            t_peer.push(time(&peer)?);
        }
        let (a, b) = (median(&mut t_ours), median(&mut t_peer));
        println!("| {x:e} | {a:.1} | {b:.1} | {:.1}× | {diff:.1e} |", b / a);
    }
    Ok(())
}

fn cli_command(cli: &std::path::Path, x: f64) -> Vec<String> {
    let x = x.to_string();
    [
        cli.to_string_lossy().as_ref(),
        "mie",
        "--x",
        &x,
        "--n",
        &INDEX.to_string(),
    ]
    .into_iter()
    .chain(["--angles", ANGLES, "--format", "json"])
    .map(String::from)
    .collect()
}

fn peer_command(me: &std::path::Path, x: f64) -> Vec<String> {
    vec![
        me.to_string_lossy().into_owned(),
        "peer".into(),
        x.to_string(),
    ]
}

/// Wall time of one run in ms, its output discarded.
fn time(cmd: &[String]) -> Result<f64> {
    let t0 = Instant::now();
    let status = Command::new(&cmd[0])
        .args(&cmd[1..])
        .stdout(Stdio::null())
        .status()?;
    ensure!(status.success(), "{cmd:?} failed");
    Ok(t0.elapsed().as_secs_f64() * 1e3)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Largest relative difference of the `phase` columns the two processes print.
fn phase_difference(ours: &[String], peer: &[String]) -> Result<f64> {
    let phase = |cmd: &[String]| -> Result<Vec<f64>> {
        let out = Command::new(&cmd[0]).args(&cmd[1..]).output()?;
        if !out.status.success() {
            bail!("{cmd:?}: {}", String::from_utf8_lossy(&out.stderr));
        }
        let v: serde_json::Value = serde_json::from_slice(&out.stdout)?;
        let p = v.get("phase").context("no phase column")?;
        Ok(serde_json::from_value(p.clone())?)
    };
    let (a, b) = (phase(ours)?, phase(peer)?);
    ensure!(
        a.len() == ANGLE_COUNT && b.len() == ANGLE_COUNT,
        "angle counts differ"
    );
    Ok(a.iter()
        .zip(&b)
        .map(|(p, q)| (p - q).abs() / q.abs())
        .fold(0.0, f64::max))
}

/// The peer process: scatrs solves the sphere, the same columns are printed as JSON.
fn peer(x: f64) -> Result<()> {
    let m = Complex64::new(INDEX, 0.0);
    let opts = scatrs::mie::MieOptions::new().with_allow_unvalidated(x > 2e4);
    let mut ws = scatrs::mie::Mie::<f64>::new();
    let sol = ws
        .compute(x, m, &opts)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let angles: Vec<f64> = (0..ANGLE_COUNT).map(|k| k as f64 * 0.05).collect();
    let mu: Vec<f64> = angles.iter().map(|a| a.to_radians().cos()).collect();
    let zero = Complex64::new(0.0, 0.0);
    let (mut s1, mut s2) = (vec![zero; ANGLE_COUNT], vec![zero; ANGLE_COUNT]);
    let buffers = scatrs::mie::AmplitudeBuffers {
        s1: &mut s1,
        s2: &mut s2,
    };
    sol.amplitudes(&mu, buffers)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let norm = std::f64::consts::PI * x * x * sol.efficiencies().q_sca;
    let s1_sq: Vec<f64> = s1.iter().map(|v| v.norm_sqr()).collect();
    let s2_sq: Vec<f64> = s2.iter().map(|v| v.norm_sqr()).collect();
    let col = |f: &dyn Fn(usize) -> f64| (0..ANGLE_COUNT).map(f).collect::<Vec<f64>>();
    let json = serde_json::json!({
        "angle_deg": angles,
        "s1_sq": s1_sq,
        "s2_sq": s2_sq,
        "s11": col(&|j| (s1_sq[j] + s2_sq[j]) / 2.0),
        "i_perp": col(&|j| s1_sq[j] / norm),
        "i_par": col(&|j| s2_sq[j] / norm),
        "phase": col(&|j| (s1_sq[j] + s2_sq[j]) / (2.0 * norm)),
        "dolp": col(&|j| (s1_sq[j] - s2_sq[j]) / (s1_sq[j] + s2_sq[j])),
    });
    println!("{}", serde_json::to_string_pretty(&json)?);
    Ok(())
}
