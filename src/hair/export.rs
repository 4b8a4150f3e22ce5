//! Engine exports of `hair-dual` tables (EXR LUT, 1-D JSON/CSV) and the CLI argument structs
//! (`scatterbake hair-lut`, `scatterbake dual-scattering` a.k.a. `hair-json`). Layouts and the
//! shader lookup formula: `docs/hair.md`. I/O happens only in the `run_*` functions.

use super::artist::ArtistParams;
use super::dual::DUAL_CHANNELS;
use super::fiber::FresnelModel;
use super::stage::{DUAL_TABLE_CHANNELS, HairDualJob, HairDualParams, HairModel};
use crate::stage::Job;
use crate::table::{Table, TableContent};
use anyhow::{Context, bail, ensure};
use rayon::prelude::*;
use serde_json::{Value, json};
use std::path::PathBuf;

/// A `hair-dual` table laid out as an engine texture: `width` = absorption (or colour) samples,
/// `height` = θ samples × roughness layers (layer `r` occupies rows `r·n_theta .. (r+1)·n_theta`,
/// θ increasing downwards from −90°), three RGBA groups `ds0..ds2` holding the twelve quantities in
/// [`DUAL_CHANNELS`] order (`ds0 = ā_f, ā_b, ᾱ_f, ᾱ_b`; `ds1 = β̄_f², β̄_b², Ā_b, Δ̄_b`;
/// `ds2 = σ̄_b², N^G_R, N^G_TT, N^G_TRT`). `parts[k][c]` is row-major `height × width`.
#[derive(Debug, Clone, PartialEq)]
pub struct DualLutLayout {
    pub width: usize,
    pub height: usize,
    pub n_theta: usize,
    pub n_roughness: usize,
    pub parts: [[Vec<f32>; 4]; 3],
    /// The column axis name (`absorption_u`, `sigma_a` or `colour_channel`).
    pub column_axis: String,
}

/// Turn a `hair-dual/1` table into the texture layout of [`DualLutLayout`].
pub fn dual_lut_layout(t: &TableContent) -> anyhow::Result<DualLutLayout> {
    ensure!(
        t.schema.name == "hair-dual" && t.schema.version == 1,
        "not a hair-dual/1 table ({})",
        t.schema
    );
    ensure!(
        t.channels.len() == DUAL_TABLE_CHANNELS,
        "unexpected channel count"
    );
    let (n_roughness, col_axis, theta_axis) = match t.axes.len() {
        3 => (t.axes[0].len(), &t.axes[1], &t.axes[2]),
        2 => (1, &t.axes[0], &t.axes[1]),
        n => bail!("hair-dual table with {n} axes"),
    };
    ensure!(theta_axis.name == "theta", "last axis must be theta");
    let width = col_axis.len();
    let n_theta = theta_axis.len();
    let height = n_theta * n_roughness;
    let mut parts: [[Vec<f32>; 4]; 3] =
        std::array::from_fn(|_| std::array::from_fn(|_| vec![0f32; width * height]));
    for ir in 0..n_roughness {
        for ia in 0..width {
            for it in 0..n_theta {
                let src = ((ir * width + ia) * n_theta + it) * DUAL_TABLE_CHANNELS;
                let pixel = (ir * n_theta + it) * width + ia;
                for q in 0..12 {
                    parts[q / 4][q % 4][pixel] = t.data[src + q];
                }
            }
        }
    }
    Ok(DualLutLayout {
        width,
        height,
        n_theta,
        n_roughness,
        parts,
        column_axis: col_axis.name.clone(),
    })
}

/// Write the layout as a single-part OpenEXR file (32-bit float, lossless compression) with
/// twelve channels named `ds0.R … ds2.A` (the classic layer.channel naming every OpenEXR reader
/// understands; no multi-part support needed). A header comment records the layout.
pub fn write_dual_lut_exr(layout: &DualLutLayout, path: &std::path::Path) -> anyhow::Result<()> {
    use exr::prelude::*;
    let size = (layout.width, layout.height);
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for k in 0..3 {
        for (c, n) in ["R", "G", "B", "A"].iter().enumerate() {
            channels.push(AnyChannel::new(
                format!("ds{k}.{n}").as_str(),
                FlatSamples::F32(layout.parts[k][c].clone()),
            ));
        }
    }
    let mut attrs = LayerAttributes::named("hair-dual");
    let groups: Vec<String> = (0..3)
        .map(|k| format!("ds{k} = ({})", DUAL_CHANNELS[4 * k..4 * k + 4].join(", ")))
        .collect();
    attrs.comments = Some(Text::from(
        format!(
            "scatterbake hair-dual/1 LUT: {}; columns = {} ({} samples), rows = theta -90..90 deg ({} samples) x {} roughness layers (docs/hair.md)",
            groups.join("; "),
            layout.column_axis,
            layout.width,
            layout.n_theta,
            layout.n_roughness
        )
        .as_str(),
    ));
    let layer = Layer::new(
        size,
        attrs,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// JSON of the 1-D set (RGB triples per θ) from a `hair-dual/1` table whose column axis is
/// `colour_channel` and which has one roughness.
pub fn dual_json(t: &TableContent) -> anyhow::Result<Value> {
    let layout = dual_lut_layout(t)?;
    ensure!(
        layout.column_axis == "colour_channel",
        "the JSON export needs a one-colour table (sigma_a_rgb, melanin or the artist model)"
    );
    ensure!(
        layout.n_roughness == 1,
        "the JSON export needs a single roughness"
    );
    let nt = layout.n_theta;
    let theta_axis = t.axes.last().expect("axes");
    let theta_deg: Vec<f64> = theta_axis.coords();
    let mut obj = serde_json::Map::new();
    obj.insert("schema".into(), json!("hair-dual-1d/1"));
    obj.insert("theta_deg".into(), json!(theta_deg));
    let rgb = |ch: usize, it: usize| -> [f64; 3] {
        std::array::from_fn(|c| t.data[((c * nt) + it) * DUAL_TABLE_CHANNELS + ch] as f64)
    };
    for (q, name) in DUAL_CHANNELS.iter().enumerate() {
        let v: Vec<[f64; 3]> = (0..nt).map(|it| rgb(q, it)).collect();
        obj.insert((*name).into(), json!(v));
    }
    let mut lobes = serde_json::Map::new();
    for (k, name) in ["R", "TT", "TRT", "residual"].iter().enumerate() {
        let v: Vec<[f64; 3]> = (0..nt).map(|it| rgb(12 + k, it)).collect();
        lobes.insert((*name).into(), json!(v));
    }
    obj.insert("lobe_energy".into(), Value::Object(lobes));
    let mut conventions = t.attributes.clone();
    conventions.insert("units".into(), json!("theta_deg in degrees; alpha_*, delta_b in rad; beta_*2, sigma_b2 in rad²; N_G_* per rad; triples are (R, G, B)"));
    obj.insert("conventions".into(), Value::Object(conventions));
    Ok(Value::Object(obj))
}

/// CSV of the same 1-D set: `theta_deg`, then `<quantity>_r,_g,_b` for the twelve quantities and
/// the lobe energies.
pub fn dual_csv(t: &TableContent) -> anyhow::Result<String> {
    let j = dual_json(t)?;
    let theta = j["theta_deg"].as_array().expect("theta").clone();
    let mut cols: Vec<(String, &Value)> = DUAL_CHANNELS
        .iter()
        .map(|n| (n.to_string(), &j[*n]))
        .collect();
    for n in ["R", "TT", "TRT", "residual"] {
        cols.push((format!("E_{n}"), &j["lobe_energy"][n]));
    }
    let mut s = String::from("theta_deg");
    for (n, _) in &cols {
        for c in ["r", "g", "b"] {
            s.push_str(&format!(",{n}_{c}"));
        }
    }
    s.push('\n');
    for (i, th) in theta.iter().enumerate() {
        s.push_str(&format!("{}", th.as_f64().unwrap_or(f64::NAN)));
        for (_, v) in &cols {
            for c in 0..3 {
                s.push_str(&format!(",{}", v[i][c].as_f64().unwrap_or(f64::NAN)));
            }
        }
        s.push('\n');
    }
    Ok(s)
}

/// Run a planned job in memory (rayon over tasks).
pub fn run_job_in_memory(job: &dyn Job) -> anyhow::Result<TableContent> {
    let n = job.tasks().len();
    let chunks: anyhow::Result<Vec<Vec<f32>>> =
        (0..n).into_par_iter().map(|i| job.run_task(i)).collect();
    job.assemble(chunks?)
}

/// `scatterbake hair-lut --table T.sbt --out X.exr`.
#[derive(clap::Args, Debug, Clone)]
pub struct HairLutArgs {
    /// A `hair-dual/1` table.
    #[arg(long)]
    pub table: PathBuf,
    /// Output OpenEXR file.
    #[arg(long)]
    pub out: PathBuf,
}

fn content_of(table: Table) -> TableContent {
    TableContent {
        schema: table.header.schema,
        description: table.header.description,
        axes: table.header.axes,
        channels: table.header.channels,
        attributes: table.header.attributes,
        data: table.data,
    }
}

/// Runner of `hair-lut`.
pub fn run_hair_lut(args: &HairLutArgs) -> anyhow::Result<()> {
    let t = content_of(Table::open(&args.table)?);
    let layout = dual_lut_layout(&t)?;
    write_dual_lut_exr(&layout, &args.out)?;
    eprintln!(
        "wrote {} ({}×{} texels, {} roughness layers, channels ds0–ds2.RGBA)",
        args.out.display(),
        layout.width,
        layout.height,
        layout.n_roughness
    );
    Ok(())
}

/// Fibre model choice on the command line.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelArg {
    Physical,
    Artist,
}

/// Output format of `dual-scattering`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormatArg {
    Json,
    Csv,
}

/// `scatterbake dual-scattering` (alias `hair-json`): the 1-D Dual Scattering set of one
/// parameter set, or of a one-colour `hair-dual` table given with `--table`.
#[derive(clap::Args, Debug, Clone)]
pub struct DualScatteringArgs {
    #[arg(long, value_enum, default_value = "physical")]
    pub model: ModelArg,
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
    #[arg(long, default_value_t = 64)]
    pub theta_samples: usize,
    #[arg(long, default_value_t = 0.7)]
    pub d_b: f64,
    #[arg(long, default_value_t = 0.99)]
    pub clamp: f64,
    /// TOML file with artist-friendly parameters (model = artist), keys as in `[table.params.artist]`.
    #[arg(long)]
    pub artist_params: Option<PathBuf>,
    /// Read a one-colour `hair-dual` table instead of computing.
    #[arg(long)]
    pub table: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "json")]
    pub format: FormatArg,
    /// Output file (stdout when absent).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Alias matching the lead's brief (`scatterbake hair-json`).
pub type HairJsonArgs = DualScatteringArgs;

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
        artist: if physical {
            None
        } else {
            Some(artist.unwrap_or_default())
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
        let job = HairDualJob::new(params).map_err(|e| anyhow::anyhow!("{e}"))?;
        run_job_in_memory(&job)?
    };
    let text = match args.format {
        FormatArg::Json => serde_json::to_string_pretty(&dual_json(&t)?)?,
        FormatArg::Csv => dual_csv(&t)?,
    };
    match &args.out {
        Some(p) => std::fs::write(p, text).with_context(|| format!("writing {}", p.display()))?,
        None => println!("{text}"),
    }
    Ok(())
}

/// Alias of [`run_dual_scattering`].
pub fn run_hair_json(args: &HairJsonArgs) -> anyhow::Result<()> {
    run_dual_scattering(args)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hair::stage::HairDualJob;

    fn params(toml_src: &str) -> HairDualParams {
        toml::from_str(toml_src).unwrap()
    }

    #[test]
    fn exr_lut_round_trips_and_matches_table() {
        let job = HairDualJob::new(params(
            "roughness_deg = [4.0, 9.0]\nabsorption_count = 6\ntheta_count = 7",
        ))
        .unwrap();
        let t = run_job_in_memory(&job).unwrap();
        let layout = dual_lut_layout(&t).unwrap();
        assert_eq!((layout.width, layout.height), (6, 14));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lut.exr");
        write_dual_lut_exr(&layout, &path).unwrap();
        use exr::prelude::*;
        let img = read_all_flat_layers_from_file(&path).unwrap();
        assert_eq!(img.layer_data.len(), 1);
        let chans = &img.layer_data[0].channel_data.list;
        assert_eq!(chans.len(), 12);
        let b = chans
            .iter()
            .find(|c| c.name.to_string() == "ds1.B")
            .unwrap();
        // Texel (x = absorption 3, y = roughness 1, θ index 5) holds Ā_b of that table cell.
        let x = 3;
        let y = 7 + 5;
        let tex = b.sample_data.value_by_flat_index(y * 6 + x).to_f32();
        let cell = ((6 + 3) * 7 + 5) * DUAL_TABLE_CHANNELS + 6;
        assert_eq!(tex, t.data[cell]);
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
            artist_params: None,
            table: None,
            format: FormatArg::Json,
            out: None,
        };
        let job = HairDualJob::new(dual_params_from_args(&args, None).unwrap()).unwrap();
        let t = run_job_in_memory(&job).unwrap();
        let j = dual_json(&t).unwrap();
        assert_eq!(j["theta_deg"].as_array().unwrap().len(), 9);
        assert_eq!(j["a_f"][4].as_array().unwrap().len(), 3);
        assert!(j["conventions"]["energy_measure"].is_string());
        // Blond: red is absorbed least, so ā_f(R) > ā_f(B).
        assert!(j["a_f"][4][0].as_f64().unwrap() > j["a_f"][4][2].as_f64().unwrap());
        let csv = dual_csv(&t).unwrap();
        assert_eq!(csv.lines().count(), 10);
        assert_eq!(csv.lines().next().unwrap().split(',').count(), 1 + 16 * 3);
    }

    /// End to end through the `.sbt` format: the CLI runners read a written table.
    #[test]
    fn runners_work_from_sbt_files() {
        use crate::table::{Provenance, write_table_atomic};
        let dir = tempfile::tempdir().unwrap();
        let write = |src: &str, name: &str| {
            let job = HairDualJob::new(params(src)).unwrap();
            let content = run_job_in_memory(&job).unwrap();
            let mut table = Table::from_content(content, Provenance::default()).unwrap();
            let path = dir.path().join(name);
            write_table_atomic(&mut table, &path).unwrap();
            path
        };
        let lut = write(
            "roughness_deg = [5.0, 10.0]\nabsorption_count = 4\ntheta_count = 5",
            "lut.sbt",
        );
        let exr_path = dir.path().join("lut.exr");
        run_hair_lut(&HairLutArgs {
            table: lut.clone(),
            out: exr_path.clone(),
        })
        .unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
        assert_eq!(img.layer_data[0].size.0, 4);
        assert_eq!(img.layer_data[0].size.1, 10);
        let one = write("sigma_a_rgb = [0.1, 0.2, 0.4]\ntheta_count = 5", "one.sbt");
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
            artist_params: None,
            table: Some(one),
            format: FormatArg::Json,
            out: Some(json_path.clone()),
        };
        run_dual_scattering(&args).unwrap();
        let j: Value = serde_json::from_str(&std::fs::read_to_string(&json_path).unwrap()).unwrap();
        assert_eq!(j["theta_deg"][2].as_f64().unwrap(), 0.0);
        // The LUT table is not a one-colour table: the JSON export refuses it.
        args.table = Some(lut);
        assert!(run_dual_scattering(&args).is_err());
    }
}
