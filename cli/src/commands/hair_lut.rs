//! `scatterbake hair-lut`: a `hair-dual/1` table as the scatterbake EXR LUT or an engine's DDS
//! LUTs (glue for [`scatterbake::consumers::export::hair_lut`] and `hair_engine_lut`).

use scatterbake::consumers::export::hair_lut::*;
use scatterbake::table::Table;
use std::path::PathBuf;

/// `scatterbake hair-lut --table T.sbt --out X.exr` (or `--engine unreal|hdrp --out X.dds`).
#[derive(clap::Args, Debug, Clone)]
pub struct HairLutArgs {
    /// A `hair-dual/1` table.
    #[arg(long)]
    pub table: PathBuf,
    /// Output file: OpenEXR for `--engine exr`, DDS otherwise.
    #[arg(long)]
    pub out: PathBuf,
    /// Layout: exr (scatterbake tiled EXR), unreal (3-D Dual Scattering LUT), hdrp (3-D fiber
    /// scattering LUT + 2-D N^G LUT).
    #[arg(long, value_enum, default_value = "exr")]
    pub engine: EngineArg,
    /// Texture size X,Y,Z (default: unreal 64,64,16; hdrp 64,64,64).
    #[arg(long, value_delimiter = ',', num_args = 3)]
    pub size: Option<Vec<usize>>,
    /// HDRP N^G LUT output (default: `<out stem>-azimuthal.dds` next to --out).
    #[arg(long)]
    pub out_azimuthal: Option<PathBuf>,
    /// Roughness β_R (deg) of the HDRP N^G LUT (default: the table's first roughness).
    #[arg(long)]
    pub ng_roughness_deg: Option<f64>,
}

/// Texture layout of `hair-lut`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum EngineArg {
    Exr,
    Unreal,
    Hdrp,
}

/// Runner of `hair-lut`.
pub fn run_hair_lut(args: &HairLutArgs) -> anyhow::Result<()> {
    use scatterbake::consumers::export::hair_engine_lut as eng;
    // The output's extension must be the format written, checked before reading the table.
    let wanted = if args.engine == EngineArg::Exr {
        "exr"
    } else {
        "dds"
    };
    anyhow::ensure!(
        args.out
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case(wanted)),
        "{}: hair-lut --engine {} writes {}; the output must end in .{wanted}",
        crate::display::path(&args.out),
        if args.engine == EngineArg::Exr {
            "exr"
        } else if args.engine == EngineArg::Unreal {
            "unreal"
        } else {
            "hdrp"
        },
        if wanted == "exr" { "OpenEXR" } else { "DDS" },
    );
    let t = content_of(Table::open(&args.table)?);
    let size = |default: [usize; 3]| {
        args.size
            .as_ref()
            .map(|s| [s[0], s[1], s[2]])
            .unwrap_or(default)
    };
    match args.engine {
        EngineArg::Exr => {
            let layout = dual_lut_layout(&t)?;
            write_dual_lut_exr(&layout, &args.out)?;
            eprintln!(
                "wrote {} ({}×{} texels, {} roughness layers, channels ds0–ds2.RGBA)",
                crate::display::path(&args.out),
                layout.width,
                layout.height,
                layout.n_roughness
            );
        }
        EngineArg::Unreal => {
            let view = eng::DualTableView::new(&t)?;
            let tex = eng::unreal_dual_scattering(&view, size([64, 64, 16]))?;
            eng::write_dds(&tex, &args.out)?;
            eprintln!(
                "wrote {} (Unreal Dual Scattering LUT {:?}: |sin θ|, roughness, sqrt(colour) → ā_f, ā_b, β̄_f², β̄_b²)",
                crate::display::path(&args.out),
                tex.size
            );
        }
        EngineArg::Hdrp => {
            let view = eng::DualTableView::new(&t)?;
            let tex = eng::hdrp_fiber_scattering(&view, size([64, 64, 64]))?;
            eng::write_dds(&tex, &args.out)?;
            let beta = args.ng_roughness_deg.unwrap_or(view.roughness_deg()[0]);
            let s = size([64, 64, 64]);
            let ng = eng::hdrp_average_azimuthal(&view, [s[1], s[2]], beta)?;
            let ng_path = args.out_azimuthal.clone().unwrap_or_else(|| {
                let stem = args
                    .out
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "hair".into());
                args.out.with_file_name(format!("{stem}-azimuthal.dds"))
            });
            eng::write_dds(&ng, &ng_path)?;
            eprintln!(
                "wrote {} (HDRP fiber scattering LUT {:?}) and {} (N^G LUT {:?} at β_R = {beta}°)",
                crate::display::path(&args.out),
                tex.size,
                crate::display::path(&ng_path),
                ng.size
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// End to end through the `.sbt` format: the runner reads a written table.
    #[test]
    fn runner_works_from_sbt_files() {
        let dir = tempfile::tempdir().unwrap();
        let lut = crate::consumer_tests::write_hair_dual_table(
            dir.path(),
            "roughness_deg = [5.0, 10.0]\nabsorption_count = 4\ntheta_count = 5",
            "lut.sbt",
        );
        let exr_path = dir.path().join("lut.exr");
        run_hair_lut(&HairLutArgs {
            table: lut.clone(),
            out: exr_path.clone(),
            engine: EngineArg::Exr,
            size: None,
            out_azimuthal: None,
            ng_roughness_deg: None,
        })
        .unwrap();
        let dds_path = dir.path().join("hdrp.dds");
        run_hair_lut(&HairLutArgs {
            table: lut.clone(),
            out: dds_path.clone(),
            engine: EngineArg::Hdrp,
            size: Some(vec![4, 5, 6]),
            out_azimuthal: None,
            ng_roughness_deg: None,
        })
        .unwrap();
        let ng = std::fs::read(dir.path().join("hdrp-azimuthal.dds")).unwrap();
        assert_eq!(ng.len(), 148 + 16 * 5 * 6);
        assert_eq!(
            std::fs::read(&dds_path).unwrap().len(),
            148 + 16 * 4 * 5 * 6
        );
        let err = run_hair_lut(&HairLutArgs {
            table: lut.clone(),
            out: dir.path().join("hair.png"),
            engine: EngineArg::Exr,
            size: None,
            out_azimuthal: None,
            ng_roughness_deg: None,
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("must end in .exr"), "{err}");
        assert!(!dir.path().join("hair.png").exists());
        let img = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
        assert_eq!(img.layer_data[0].size.0, 4);
        assert_eq!(img.layer_data[0].size.1, 10);
    }
}
