//! `scatterbake medulla-assets`: compress the dense thesis-grid medulla tables into the shipped
//! tensor-train assets (`docs/fur.md`).

/// Arguments of `scatterbake medulla-assets`.
#[derive(clap::Args, Debug)]
pub struct MedullaAssetsArgs {
    /// Directory holding the dense source tables built by
    /// `scatterbake build manifests/full/fur-medulla-assets.toml --out DIR`.
    #[arg(long, default_value = "tables/assets")]
    pub tables: std::path::PathBuf,
    /// Output directory of the assets.
    #[arg(long, default_value = "assets/fur-medulla")]
    pub out: std::path::PathBuf,
    /// Override the azimuthal TT tolerance (exploration; the shipped value is the default).
    #[arg(long)]
    pub azimuthal_tol: Option<f64>,
    /// Override the longitudinal TT tolerance (exploration; the shipped value is the default).
    #[arg(long)]
    pub longitudinal_tol: Option<f64>,
    /// Override the azimuthal rank cap (exploration).
    #[arg(long)]
    pub azimuthal_max_rank: Option<usize>,
    /// Override the azimuthal log floor (relative to the maximum; 0 = linear form; exploration).
    #[arg(long)]
    pub azimuthal_log_floor: Option<f64>,
    /// Override the mantissa bits kept in the azimuthal cores (23 = all; exploration).
    #[arg(long)]
    pub azimuthal_mantissa_bits: Option<u32>,
    /// Only the azimuthal asset (exploration).
    #[arg(long)]
    pub azimuthal_only: bool,
}

/// Compress the dense thesis-grid medulla tables into the shipped tensor-train assets
/// (`scatterbake::fur::assets`), print their sizes and errors; refuses an asset above the size
/// limit or whose reconstruction error is not below the source's own error.
pub fn run_medulla_assets(a: &MedullaAssetsArgs) -> anyhow::Result<()> {
    use anyhow::Context;
    use scatterbake::fur::assets::{AssetSpec, MAX_ASSET_BYTES, compress_asset};
    std::fs::create_dir_all(&a.out).with_context(|| crate::display::path(&a.out))?;
    let mut az = AssetSpec::AZIMUTHAL;
    if let Some(r) = a.azimuthal_max_rank {
        az.max_rank = r;
    }
    if let Some(f) = a.azimuthal_log_floor {
        az.log_floor_rel = (f > 0.0).then_some(f);
    }
    if let Some(b) = a.azimuthal_mantissa_bits {
        anyhow::ensure!(
            (1..=23).contains(&b),
            "--azimuthal-mantissa-bits {b}: must be 1 to 23"
        );
        az.core_mantissa_bits = Some(b);
    }
    let mut specs = vec![(az, a.azimuthal_tol)];
    if !a.azimuthal_only {
        specs.push((AssetSpec::LONGITUDINAL, a.longitudinal_tol));
    }
    for (mut spec, tol) in specs {
        if let Some(t) = tol {
            spec.rel_tol = t;
        }
        let src = a.tables.join(format!("{}.sbt", spec.source_table));
        let t0 = std::time::Instant::now();
        let source = scatterbake::table::Table::open(&src)?;
        let mut asset = compress_asset(&source, &spec)?;
        drop(source);
        let bytes = asset.to_bytes()?;
        let at = &asset.header.attributes;
        println!(
            "{}: {} B, ranks {}, rel_tol {}; reconstruction error {}; source error {}; {:.1} s",
            spec.file,
            bytes.len(),
            at["ranks"],
            spec.rel_tol,
            at["reconstruction_error"],
            at["source_error"],
            t0.elapsed().as_secs_f64()
        );
        anyhow::ensure!(
            bytes.len() <= MAX_ASSET_BYTES,
            "{}: {} bytes exceed the limit of {MAX_ASSET_BYTES}",
            spec.file,
            bytes.len()
        );
        // The tensor train's own error (against the values it compressed, after the
        // normalisation of the azimuthal profiles), FUR-29.
        let re = &at["reconstruction_error"];
        let rec = re["tensor_train_only"]["rel_frobenius"]
            .as_f64()
            .or_else(|| re["rel_frobenius"].as_f64())
            .unwrap_or(f64::INFINITY);
        if let Some(z) = re["per_bin_in_std_errors"]["median"].as_f64() {
            anyhow::ensure!(
                z < 1.0,
                "{}: median per-bin reconstruction error {z:.2} standard errors is not below 1",
                spec.file
            );
        }
        // Monte Carlo source: the relative Frobenius error of the tensor train below that of the
        // standard errors; deterministic source (no noise): the median per-bin relative error
        // below the solver's discretisation error (its median form where the source states
        // one; the Frobenius error is recorded; FUR-29).
        let solver = at["source_error"]["solver_error_median"]
            .as_f64()
            .or_else(|| at["source_error"]["solver_error"].as_f64());
        let (rec, limit) = match solver {
            Some(solver) => (
                re["per_bin_rel_on_bins_above_1e-3_of_profile_max"]["median"]
                    .as_f64()
                    .unwrap_or(f64::INFINITY),
                solver,
            ),
            None => (
                rec,
                at["source_error"]["rel_frobenius"].as_f64().unwrap_or(0.0),
            ),
        };
        anyhow::ensure!(
            rec < limit,
            "{}: reconstruction error {rec:.3e} is not below the source's error {limit:.3e}",
            spec.file
        );
        scatterbake::table::format::write_atomic(&a.out.join(spec.file), &bytes)
            .with_context(|| crate::display::path(&a.out.join(spec.file)))?;
    }
    Ok(())
}
