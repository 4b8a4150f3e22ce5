//! `scatterbake medulla`: one medulla profile on the command line. Option names are the keys
//! of the `fur-medulla-*` stages (`photons`, `seed`, `bins`).

use scatterbake::fur::medulla::{Estimator, Geometry, McSettings, Profile, simulate};
use serde_json::json;
use std::io::Write;

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MedullaFormat {
    Csv,
    Json,
}

/// Estimator choice on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MedullaEstimator {
    Expected,
    Histogram,
}

/// Arguments of `scatterbake medulla`.
#[derive(Debug, Clone, clap::Args)]
#[command(group(clap::ArgGroup::new("entry").required(true).args(["h", "theta_i_deg"])))]
pub struct MedullaArgs {
    /// Scattering coefficient per unit MEDULLA radius (dimensionless).
    #[arg(long)]
    pub sigma: f64,
    /// Planar Henyey–Greenstein anisotropy, 0 ≤ g < 1.
    #[arg(long)]
    pub g: f64,
    /// Azimuthal family: entry offset h' ∈ [−1, 1] on the unit medulla circle.
    #[arg(long, allow_hyphen_values = true)]
    pub h: Option<f64>,
    /// Longitudinal family: entry inclination θ'_i in degrees, in (−90, 90).
    #[arg(long, allow_hyphen_values = true)]
    pub theta_i_deg: Option<f64>,
    /// Photons (Monte Carlo paths), as the manifest key `photons`.
    #[arg(long, default_value_t = 10_000)]
    pub photons: u64,
    /// Random seed of the Monte Carlo paths.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Exit bins over the full circle (even; bins/2 per lobe for the slab).
    #[arg(long, default_value_t = 720)]
    pub bins: usize,
    /// Estimator: expected (next-event, lower noise) or histogram (exit bins of the paths).
    #[arg(long, value_enum, default_value_t = MedullaEstimator::Expected)]
    pub estimator: MedullaEstimator,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = MedullaFormat::Csv)]
    pub format: MedullaFormat,
}

/// Run `scatterbake medulla`, printing to stdout.
pub fn run_medulla(args: &MedullaArgs) -> anyhow::Result<()> {
    let out = medulla_report(args)?;
    std::io::stdout().lock().write_all(out.as_bytes())?;
    Ok(())
}

/// The text `run_medulla` prints.
pub fn medulla_report(args: &MedullaArgs) -> anyhow::Result<String> {
    let geom = checked_geometry(args)?;
    let s = McSettings {
        photons: args.photons,
        seed: args.seed,
        estimator: match args.estimator {
            MedullaEstimator::Expected => Estimator::Expected,
            MedullaEstimator::Histogram => Estimator::Histogram,
        },
        bins: args.bins,
        max_order: None,
    };
    let p = simulate(args.sigma, args.g, geom, &s);
    Ok(match args.format {
        MedullaFormat::Json => json_report(args, geom, &s, &p)?,
        MedullaFormat::Csv => csv_report(args, geom, &s, &p),
    })
}

/// The geometry the arguments select, after checking every argument's range.
fn checked_geometry(args: &MedullaArgs) -> anyhow::Result<Geometry> {
    anyhow::ensure!(
        args.sigma >= 0.0 && args.sigma.is_finite(),
        "--sigma must be ≥ 0"
    );
    anyhow::ensure!((0.0..1.0).contains(&args.g), "--g must be in [0, 1)");
    anyhow::ensure!(
        args.bins >= 4 && args.bins.is_multiple_of(4),
        "--bins must be a multiple of 4"
    );
    match (args.h, args.theta_i_deg) {
        (Some(h), None) => {
            anyhow::ensure!((-1.0..=1.0).contains(&h), "--h must be in [−1, 1]");
            Ok(Geometry::Azimuthal { h })
        }
        (None, Some(t)) => {
            anyhow::ensure!(t > -90.0 && t < 90.0, "--theta-i-deg must be in (−90, 90)");
            Ok(Geometry::Longitudinal {
                theta_i_rad: t.to_radians(),
            })
        }
        _ => anyhow::bail!("give exactly one of --h and --theta-i-deg"),
    }
}

/// The bin convention (in words) and the bin centres (deg) of a profile with `bins` bins.
fn bin_convention(geom: Geometry, bins: usize) -> (&'static str, Vec<f64>) {
    let dw = 360.0 / bins as f64;
    match geom {
        Geometry::Azimuthal { .. } => (
            "phi' in deg of the exit direction from the entering direction (0 = unscattered continuation), counter-clockwise towards +h'; bin k covers [-180 + k*w, -180 + (k+1)*w)",
            (0..bins).map(|k| -180.0 + (k as f64 + 0.5) * dw).collect(),
        ),
        Geometry::Longitudinal { .. } => (
            "bins 0..bins/2: back lobe (exits the entry face), bins/2..bins: forward lobe; theta_r in deg from the exit face normal, sin(theta_r) = exit direction along the fiber axis, unscattered continuation at theta_r = -theta_i; bin j of a lobe covers [-90 + j*w, -90 + (j+1)*w)",
            (0..bins)
                .map(|k| -90.0 + ((k % (bins / 2)) as f64 + 0.5) * dw)
                .collect(),
        ),
    }
}

fn json_report(
    args: &MedullaArgs,
    geom: Geometry,
    s: &McSettings,
    p: &Profile,
) -> anyhow::Result<String> {
    let (convention, centres) = bin_convention(geom, args.bins);
    let mut v = json!({
        "sigma": args.sigma,
        "g": args.g,
        "bins": args.bins,
        "bin_width_deg": 360.0 / args.bins as f64,
        "bin_convention": convention,
        "estimator": format!("{:?}", s.estimator).to_lowercase(),
        "photons": args.photons,
        "seed": args.seed,
        "bin_centre_deg": centres,
        "profile": p.energy,
        "path_length": p.path_length,
        "std_error": p.std_error,
        "ballistic": p.ballistic,
        "ballistic_mc": p.ballistic_mc,
        "scattered": p.scattered,
        "scattered_std_error": p.scattered_std_error,
    });
    match geom {
        Geometry::Azimuthal { h } => v["h"] = json!(h),
        Geometry::Longitudinal { .. } => v["theta_i_deg"] = json!(args.theta_i_deg),
    }
    Ok(serde_json::to_string_pretty(&v)? + "\n")
}

fn csv_report(args: &MedullaArgs, geom: Geometry, s: &McSettings, p: &Profile) -> String {
    let (convention, centres) = bin_convention(geom, args.bins);
    let entry = match geom {
        Geometry::Azimuthal { h } => format!("h={h}"),
        Geometry::Longitudinal { .. } => {
            format!("theta_i_deg={}", args.theta_i_deg.unwrap_or(0.0))
        }
    };
    let mut o = format!(
        "# sigma={} g={} {entry} photons={} seed={} estimator={:?}\n# ballistic={:.8} ballistic_mc={:.8} scattered={:.8} scattered_std_error={:.3e}\n# {convention}\n",
        args.sigma,
        args.g,
        args.photons,
        args.seed,
        s.estimator,
        p.ballistic,
        p.ballistic_mc,
        p.scattered,
        p.scattered_std_error
    );
    o.push_str(match geom {
        Geometry::Azimuthal { .. } => "bin,phi_deg,energy,path_length,std_error\n",
        Geometry::Longitudinal { .. } => "bin,lobe,theta_r_deg,energy,path_length,std_error\n",
    });
    for (k, centre) in centres.iter().enumerate() {
        let lobe = match geom {
            Geometry::Azimuthal { .. } => String::new(),
            Geometry::Longitudinal { .. } if k < args.bins / 2 => "back,".into(),
            Geometry::Longitudinal { .. } => "forward,".into(),
        };
        o.push_str(&format!(
            "{k},{lobe}{:.3},{:.6e},{:.6e},{:.3e}\n",
            centre, p.energy[k], p.path_length[k], p.std_error[k]
        ));
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        m: MedullaArgs,
    }

    #[test]
    fn json_profile_sums_to_scattered_fraction() {
        let cli = Cli::parse_from([
            "x",
            "--sigma",
            "1.5",
            "--g",
            "0.4",
            "--h",
            "-0.3",
            "--photons",
            "200",
            "--format",
            "json",
        ]);
        let v: serde_json::Value = serde_json::from_str(&medulla_report(&cli.m).unwrap()).unwrap();
        let sum: f64 = v["profile"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .sum();
        let expect = 1.0 - (-2.0 * 1.5 * (1.0f64 - 0.09).sqrt()).exp();
        let se = v["scattered_std_error"].as_f64().unwrap();
        assert!(
            (sum - expect).abs() < 5.0 * se + 1e-9,
            "{sum} vs {expect} (se {se})"
        );
        assert_eq!(v["h"], json!(-0.3));
        assert_eq!(v["profile"].as_array().unwrap().len(), 720);
        // One name with the manifest key: `photons`, not `paths`.
        assert_eq!(v["photons"], json!(200));
        let old = ["x", "--sigma", "1", "--g", "0", "--h", "0", "--paths", "20"];
        assert!(Cli::try_parse_from(old).is_err());
        assert!(Cli::try_parse_from(["x", "--sigma", "1", "--g", "0"]).is_err());
        let csv = Cli::parse_from([
            "x",
            "--sigma",
            "1",
            "--g",
            "0",
            "--theta-i-deg",
            "30",
            "--photons",
            "20",
            "--bins",
            "8",
        ]);
        assert_eq!(
            medulla_report(&csv.m)
                .unwrap()
                .lines()
                .filter(|l| !l.starts_with('#'))
                .count(),
            9
        );
    }
}
