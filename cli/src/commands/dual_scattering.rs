//! `scatterbake dual-scattering` (alias `hair-json`): the 1-D Dual Scattering set of one hair
//! parameter set (or of a one-colour `hair-dual/1` table) as JSON, CSV, RSL or a C header.

use anyhow::{Context, bail};
use scatterbake::consumers::export::hair_lut::*;
use scatterbake::hair::{
    artist::{ArtistNormalisation, ArtistParams},
    fiber::FresnelModel,
    tables::ThetaRowTable,
};
use scatterbake::stages::hair::{HairDualParams, HairModel, dual_table};
use scatterbake::table::Table;
use std::path::PathBuf;

/// Fibre model choice on the command line.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelArg {
    Physical,
    Artist,
}

/// Eq. 4.17 normalisation of the artist model on the command line.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum NormalisationArg {
    PerInclination,
    NormalIncidence,
}

impl From<NormalisationArg> for ArtistNormalisation {
    fn from(a: NormalisationArg) -> Self {
        match a {
            NormalisationArg::PerInclination => ArtistNormalisation::PerInclination,
            NormalisationArg::NormalIncidence => ArtistNormalisation::NormalIncidence,
        }
    }
}

/// Output format of `dual-scattering`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormatArg {
    Json,
    Csv,
    /// RenderMan Shading Language arrays and lookup for the thesis's App. C shader.
    Rsl,
    /// A C99 header with the same arrays and lookup.
    C,
}

/// `scatterbake dual-scattering` (alias `hair-json`): the 1-D Dual Scattering set of one
/// parameter set, or of a one-colour `hair-dual` table given with `--table`.
#[derive(clap::Args, Debug, Clone)]
pub struct DualScatteringArgs {
    /// Fibre model: physical (Marschner/Zinke fibre) or artist (Sadeghi et al. 2010).
    #[arg(long, value_enum, default_value = "physical")]
    pub model: ModelArg,
    /// Fibre index of refraction (physical fibre).
    #[arg(long, default_value_t = 1.55)]
    pub eta: f64,
    /// σ_a per unit radius for R,G,B, as `R,G,B` or three values (default: 0.2,0.3,0.5, the
    /// thesis RSL default).
    #[arg(long, value_delimiter = ',', num_args = 1..=3)]
    pub absorption: Option<Vec<f64>>,
    /// Eumelanin,pheomelanin concentrations instead of --absorption.
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1..=2,
        conflicts_with = "absorption"
    )]
    pub melanin: Option<Vec<f64>>,
    /// Cuticle tilt α (deg).
    #[arg(long, default_value_t = 5.0)]
    pub alpha_deg: f64,
    /// Longitudinal width β_R (deg).
    #[arg(long, default_value_t = 7.5)]
    pub beta_deg: f64,
    /// Azimuthal roughness w_φ / β_R (0 = smooth).
    #[arg(long, default_value_t = 1.0)]
    pub azimuthal_width_ratio: f64,
    /// three-d or bravais.
    #[arg(long, default_value = "three-d")]
    pub fresnel: String,
    /// Samples of the light inclination θ_i over [−90°, 90°], endpoints included.
    #[arg(long, default_value_t = 64)]
    pub theta_samples: usize,
    /// Backscattering density factor d_b in σ̄_b (Zinke et al. 2008).
    #[arg(long, default_value_t = 0.7)]
    pub d_b: f64,
    /// ā_f, ā_b are clamped to at most this before Ā_b, Δ̄_b, σ̄_b² (0.5–1).
    #[arg(long, default_value_t = 0.99)]
    pub clamp: f64,
    /// Lambertian-cylinder term: BRDF value k_d of an opaque Lambertian fibre surface (BCSDF
    /// (k_d/4)(sin|φ| + (π−|φ|) cos φ), albedo π k_d; 0–1/π). Physical model.
    #[arg(long)]
    pub lambertian_kd: Option<f64>,
    /// Higher-order diffuse constant k_d of Zinke & Weber eq. 52 (BCSDF 2k_d, albedo 2π² k_d;
    /// 0–1/(2π²)). Physical model.
    #[arg(long)]
    pub higher_order_kd: Option<f64>,
    /// Elliptic cross-section: minor/major semi-axis ratio a, 0.85–1 (1 = circular; TRT uses
    /// Marschner's η*, averaged over the major-axis orientation). Physical model.
    #[arg(long)]
    pub axis_ratio: Option<f64>,
    /// TOML file with artist-friendly parameters (model = artist), keys as in `[table.params.artist]`.
    #[arg(long)]
    pub artist_params: Option<PathBuf>,
    /// Eq. 4.17 normalisation of the artist model (overrides `normalisation` of --artist-params):
    /// per-inclination (one scalar per θ_i, ā_f + ā_b ≤ 1) or normal-incidence (one constant).
    #[arg(long, value_enum)]
    pub artist_normalisation: Option<NormalisationArg>,
    /// Read a one-colour `hair-dual` table instead of computing.
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Output format: json, csv, rsl (shader arrays) or c (C99 header).
    #[arg(long, value_enum, default_value = "json")]
    pub format: FormatArg,
    /// Output file (stdout when absent).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The `hair-dual` parameters corresponding to the CLI arguments (pure).
pub fn dual_params_from_args(
    args: &DualScatteringArgs,
    artist: Option<ArtistParams>,
) -> anyhow::Result<HairDualParams> {
    let fresnel = match args.fresnel.as_str() {
        "three-d" => FresnelModel::ThreeD,
        "bravais" => FresnelModel::Bravais,
        f => bail!("unknown --fresnel {f} (three-d or bravais)"),
    };
    let physical = args.model == ModelArg::Physical;
    if let Some(a) = &args.absorption
        && a.len() != 3
    {
        bail!("--absorption needs three values R,G,B (got {})", a.len());
    }
    if let Some(m) = &args.melanin
        && m.len() != 2
    {
        bail!(
            "--melanin needs two values eumelanin,pheomelanin (got {})",
            m.len()
        );
    }
    let (sigma_a_rgb, melanin) = match (&args.absorption, &args.melanin) {
        _ if !physical => (None, None),
        (Some(a), _) => (Some([a[0], a[1], a[2]]), None),
        (None, Some(m)) => (None, Some([m[0], m[1]])),
        (None, None) => (Some([0.2, 0.3, 0.5]), None),
    };
    Ok(HairDualParams {
        model: if physical {
            HairModel::Physical
        } else {
            HairModel::Artist
        },
        eta: args.eta,
        fresnel,
        cuticle_tilt_deg: args.alpha_deg,
        roughness_deg: vec![args.beta_deg],
        azimuthal_width_ratio: args.azimuthal_width_ratio,
        absorption_count: None,
        sigma_a: None,
        sigma_a_rgb,
        melanin,
        theta_count: args.theta_samples,
        d_b: args.d_b,
        clamp: args.clamp,
        quadrature_order: 8,
        lambertian_kd: args.lambertian_kd,
        higher_order_kd: args.higher_order_kd,
        axis_ratio: args.axis_ratio,
        artist: if physical {
            None
        } else {
            let mut a = artist.unwrap_or_default();
            if let Some(n) = args.artist_normalisation {
                a.normalisation = n.into();
            }
            Some(a)
        },
    })
}

/// Runner of `dual-scattering` / `hair-json`.
pub fn run_dual_scattering(args: &DualScatteringArgs) -> anyhow::Result<()> {
    let t = if let Some(path) = &args.table {
        content_of(Table::open(path)?)
    } else {
        let artist = match &args.artist_params {
            Some(p) => Some(toml::from_str::<ArtistParams>(&std::fs::read_to_string(
                p,
            )?)?),
            None => None,
        };
        let params = dual_params_from_args(args, artist)?;
        let table = dual_table(&params).map_err(|e| anyhow::anyhow!("{e}"))?;
        table.compute()?
    };
    let text = match args.format {
        FormatArg::Json => serde_json::to_string_pretty(&dual_json(&t)?)?,
        FormatArg::Csv => dual_csv(&t)?,
        FormatArg::Rsl => dual_shader_tables(&t, ShaderLanguage::Rsl)?,
        FormatArg::C => dual_shader_tables(&t, ShaderLanguage::C)?,
    };
    match &args.out {
        Some(p) => std::fs::write(p, text)
            .with_context(|| format!("writing {}", crate::display::path(p)))?,
        None => println!("{text}"),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// End to end through the `.sbt` format: the runner reads a written one-colour table.
    #[test]
    fn runner_works_from_sbt_files() {
        let dir = tempfile::tempdir().unwrap();
        let one = crate::consumer_tests::write_hair_dual_table(
            dir.path(),
            "sigma_a_rgb = [0.1, 0.2, 0.4]\ntheta_count = 5",
            "one.sbt",
        );
        let json_path = dir.path().join("one.json");
        let mut args = DualScatteringArgs {
            model: ModelArg::Physical,
            eta: 1.55,
            absorption: None,
            melanin: None,
            alpha_deg: 5.0,
            beta_deg: 7.5,
            azimuthal_width_ratio: 1.0,
            fresnel: "three-d".into(),
            theta_samples: 5,
            d_b: 0.7,
            clamp: 0.99,
            lambertian_kd: None,
            higher_order_kd: None,
            axis_ratio: None,
            artist_params: None,
            artist_normalisation: None,
            table: Some(one),
            format: FormatArg::Json,
            out: Some(json_path.clone()),
        };
        run_dual_scattering(&args).unwrap();
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json_path).unwrap()).unwrap();
        assert_eq!(j["theta_deg"][2].as_f64().unwrap(), 0.0);
        // A LUT table is not a one-colour table: the JSON export refuses it.
        let lut = crate::consumer_tests::write_hair_dual_table(
            dir.path(),
            "roughness_deg = [5.0, 10.0]\nabsorption_count = 4\ntheta_count = 5",
            "lut.sbt",
        );
        args.table = Some(lut);
        assert!(run_dual_scattering(&args).is_err());
    }

    #[test]
    fn json_has_rgb_triples_and_conventions() {
        let args = DualScatteringArgs {
            model: ModelArg::Physical,
            eta: 1.55,
            absorption: None,
            melanin: Some(vec![0.3, 0.0]),
            alpha_deg: 5.0,
            beta_deg: 7.5,
            azimuthal_width_ratio: 1.0,
            fresnel: "three-d".into(),
            theta_samples: 9,
            d_b: 0.7,
            clamp: 0.99,
            lambertian_kd: None,
            higher_order_kd: None,
            axis_ratio: None,
            artist_params: None,
            artist_normalisation: None,
            table: None,
            format: FormatArg::Json,
            out: None,
        };
        let table = dual_table(&dual_params_from_args(&args, None).unwrap()).unwrap();
        let t = table.compute().unwrap();
        let j = dual_json(&t).unwrap();
        assert_eq!(j["theta_deg"].as_array().unwrap().len(), 9);
        assert_eq!(j["a_f"][4].as_array().unwrap().len(), 3);
        assert!(j["conventions"]["energy_measure"].is_string());
        // Blond: red is absorbed least, so ā_f(R) > ā_f(B).
        assert!(j["a_f"][4][0].as_f64().unwrap() > j["a_f"][4][2].as_f64().unwrap());
        let csv = dual_csv(&t).unwrap();
        assert_eq!(csv.lines().count(), 10);
        assert_eq!(csv.lines().next().unwrap().split(',').count(), 1 + 16 * 3);

        // The fibre-feature options carry the manifest keys' names and checks.
        let mut with = args.clone();
        with.higher_order_kd = Some(0.01);
        with.axis_ratio = Some(0.9);
        let table = dual_table(&dual_params_from_args(&with, None).unwrap()).unwrap();
        let t2 = table.compute().unwrap();
        let j2 = dual_json(&t2).unwrap();
        // θ = 0 (index 4): ā_b rises by π² k_d in every channel (below the clamp).
        let pi2 = std::f64::consts::PI.powi(2);
        for c in 0..3 {
            let d = j2["a_b"][4][c].as_f64().unwrap() - j["a_b"][4][c].as_f64().unwrap();
            assert!((d - pi2 * 0.01).abs() < 1e-6, "{d}");
        }
        for (lambertian, axis, key) in [
            (Some(0.5), None, "lambertian_kd"),
            (None, Some(0.5), "axis_ratio"),
        ] {
            let mut bad = args.clone();
            bad.lambertian_kd = lambertian;
            bad.axis_ratio = axis;
            let err = dual_table(&dual_params_from_args(&bad, None).unwrap())
                .expect_err("refused")
                .to_string();
            assert!(err.contains(key), "{err}");
        }
    }
}
