//! `scatterbake cloth`: the microcylinder cloth BRDF (Sadeghi et al. 2013) of one fabric preset
//! at one direction pair, for checking against other implementations (docs/cloth.md).

use scatterbake::cloth::PRESET_NAMES;
use scatterbake::cloth::query::{DirectionPairDeg, brdf_at_deg, brdf_record};
use std::io::Write;

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ClothFormat {
    Text,
    Json,
}

/// Arguments of `scatterbake cloth`. Angles in degrees in the cloth's frame: θ from the cloth
/// normal, φ from the warp (+x, the first thread family of the thesis's tables) toward the weft
/// (+y); ω_i points toward the light, ω_r toward the viewer.
#[derive(Debug, Clone, clap::Args)]
#[command(
    after_help = "Fabric presets (thesis Tables 5.2 and E.1): linen_plain, \
silk_crepe_de_chine, polyester_satin_front, polyester_satin_back, silk_shot, velvet."
)]
pub struct ClothArgs {
    /// Fabric preset.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(PRESET_NAMES))]
    pub fabric: String,
    /// Light direction: angle from the cloth normal, degrees in [0, 90).
    #[arg(long, allow_hyphen_values = true)]
    pub theta_i: f64,
    /// Light direction: azimuth from the warp, degrees.
    #[arg(long, allow_hyphen_values = true)]
    pub phi_i: f64,
    /// View direction: angle from the cloth normal, degrees in [0, 90).
    #[arg(long, allow_hyphen_values = true)]
    pub theta_r: f64,
    /// View direction: azimuth from the warp, degrees.
    #[arg(long, allow_hyphen_values = true)]
    pub phi_r: f64,
    /// Largest step in tangent elevation of the tangent-curve quadrature, degrees.
    #[arg(long, default_value_t = 1.0)]
    pub ramp_step_deg: f64,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = ClothFormat::Text)]
    pub format: ClothFormat,
}

/// Run `scatterbake cloth`, printing to stdout.
pub fn run_cloth(args: &ClothArgs) -> anyhow::Result<()> {
    let out = cloth_report(args)?;
    std::io::stdout().lock().write_all(out.as_bytes())?;
    Ok(())
}

/// The text `run_cloth` prints. The checks and the JSON record are the library's
/// (`cloth::query`), shared with the Python package's `cloth_brdf`.
pub fn cloth_report(args: &ClothArgs) -> anyhow::Result<String> {
    let q = DirectionPairDeg {
        theta_i_deg: args.theta_i,
        phi_i_deg: args.phi_i,
        theta_r_deg: args.theta_r,
        phi_r_deg: args.phi_r,
    };
    Ok(match args.format {
        ClothFormat::Json => {
            let value = brdf_record(&args.fabric, q, args.ramp_step_deg)?;
            format!("{}\n", serde_json::to_string_pretty(&value)?)
        }
        ClothFormat::Text => {
            let v = brdf_at_deg(&args.fabric, q, args.ramp_step_deg)?;
            let brdf = v.total();
            format!(
                "{} (theta_i {}, phi_i {}) -> (theta_r {}, phi_r {}) deg: brdf RGB {:.6e} {:.6e} {:.6e} 1/sr (surface {:.6e}, volume {:.6e} {:.6e} {:.6e})\n",
                args.fabric,
                args.theta_i,
                args.phi_i,
                args.theta_r,
                args.phi_r,
                brdf[0],
                brdf[1],
                brdf[2],
                v.surface,
                v.volume[0],
                v.volume[1],
                v.volume[2]
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(format: ClothFormat) -> ClothArgs {
        ClothArgs {
            fabric: "linen_plain".into(),
            theta_i: 0.0,
            phi_i: 0.0,
            theta_r: 0.0,
            phi_r: 0.0,
            ramp_step_deg: 1.0,
            format,
        }
    }

    #[test]
    fn json_carries_the_brdf_and_its_lobes() {
        let out = cloth_report(&args(ClothFormat::Json)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let brdf: Vec<f64> = serde_json::from_value(v["brdf"].clone()).unwrap();
        // Linen at normal incidence and view (a separate evaluation, six digits).
        for (b, e) in brdf.iter().zip([0.0206762, 0.0446231, 0.0526054]) {
            assert!((b - e).abs() < 1e-6 * e, "{b} vs {e}");
        }
        let s = v["surface"][0].as_f64().unwrap();
        let vol = v["volume"][1].as_f64().unwrap();
        assert!((s + vol - brdf[1]).abs() < 1e-15);
    }

    #[test]
    fn below_the_horizon_is_refused() {
        let mut a = args(ClothFormat::Text);
        a.theta_r = 95.0;
        assert!(cloth_report(&a).is_err());
    }
}
