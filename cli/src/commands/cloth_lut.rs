//! `scatterbake cloth-lut`: a `cloth-brdf/2` table as engine textures (DDS) with the lookup's
//! constants in a JSON file (glue for [`scatterbake::consumers::export::cloth_lut`]; layout and
//! shader code in docs/cloth.md §7).

use scatterbake::consumers::export::cloth_lut::{self as lut, ClothTableView, LutPrecision};
use scatterbake::table::Table;
use std::path::PathBuf;
use std::time::Instant;

/// Storage of the BRDF texture.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrecisionArg {
    /// DXGI_FORMAT_R9G9B9E5_SHAREDEXP, 4 bytes per texel.
    Rgb9e5,
    /// DXGI_FORMAT_R16G16B16A16_FLOAT, 8 bytes per texel.
    Half,
    /// DXGI_FORMAT_R32G32B32A32_FLOAT, 16 bytes per texel.
    Float,
}

/// `scatterbake cloth-lut --table T.sbt --out X.dds`: writes X.dds (K = f cos θ_i as a 3-D
/// texture), X-warp.dds, X-albedo.dds and X.json.
#[derive(clap::Args, Debug, Clone)]
pub struct ClothLutArgs {
    /// A `cloth-brdf/2` table (stage `cloth`).
    #[arg(long)]
    pub table: PathBuf,
    /// Output BRDF texture (.dds); the warp, albedo and JSON files go next to it.
    #[arg(long)]
    pub out: PathBuf,
    /// Storage of the BRDF texture.
    #[arg(long, value_enum, default_value = "rgb9e5")]
    pub precision: PrecisionArg,
    /// Check points of the measured errors written to the JSON file (0: none).
    #[arg(long, default_value_t = 20000)]
    pub check_points: usize,
}

/// Runner of `cloth-lut`.
pub fn run_cloth_lut(args: &ClothLutArgs) -> anyhow::Result<()> {
    let paths = lut::lut_paths(&args.out)?;
    let start = Instant::now();
    let table = Table::open(&args.table)?;
    let view = ClothTableView::new(&table)?;
    let precision = match args.precision {
        PrecisionArg::Rgb9e5 => LutPrecision::Rgb9e5,
        PrecisionArg::Half => LutPrecision::Half,
        PrecisionArg::Float => LutPrecision::Float,
    };
    let built = lut::build_lut(&view, precision)?;
    let export_s = start.elapsed().as_secs_f64();
    let check = Instant::now();
    let errors = (args.check_points > 0)
        .then(|| lut::lut_errors(&view, &built, args.check_points))
        .transpose()?;
    let check_s = check.elapsed().as_secs_f64();
    let meta = lut::metadata(&view, &built, &paths, errors.as_ref());
    let write = Instant::now();
    let bytes = lut::write_lut(&built, &meta, &paths)?;
    eprintln!(
        "wrote {}, {}, {}, {} ({} bytes; BRDF {:?} {}); read and build {export_s:.3} s, write \
         {:.3} s",
        crate::display::path(&paths.brdf),
        crate::display::path(&paths.warp),
        crate::display::path(&paths.albedo),
        crate::display::path(&paths.metadata),
        bytes,
        built.size,
        built.precision.format().name(),
        write.elapsed().as_secs_f64(),
    );
    if let Some(e) = errors {
        let pair = |p: (f64, f64)| format!("L2 {:.3e}, max/peak {:.3e}", p.0, p.1);
        eprintln!(
            "errors at {} check points ({check_s:.2} s): LUT vs table {} (8-bit weights {}); \
             LUT vs model {} (8-bit weights {}); table vs model {}",
            e.points,
            pair(e.lut_vs_table),
            pair(e.lut_8bit_vs_table),
            pair(e.lut_vs_model),
            pair(e.lut_8bit_vs_model),
            pair(e.table_vs_model),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// End to end through the `.sbt` format: the runner reads a written cloth table and writes
    /// the four files; a bad output is refused before the table is read.
    #[test]
    fn runner_writes_the_four_files_and_refuses_bad_outputs() {
        use scatterbake::stages::cloth::{ClothParams, ClothStage};
        use scatterbake::stages::{StageSpec, run_in_memory};
        use scatterbake::table::{Provenance, write_table_atomic};
        let dir = tempfile::tempdir().unwrap();
        let params: ClothParams = toml::from_str(
            "fabric = \"linen_plain\"\nlight_step_deg = 15.0\ngrazing_deg = 0.0\nphi_i_step_deg = 15.0\nhalf_fine = 1.0\nhalf_coarse_deg = 15.0\ncheck_points = 50",
        )
        .unwrap();
        let job = ClothStage.plan_params(params).unwrap();
        let content = run_in_memory(job.as_ref()).unwrap();
        let mut table = Table::from_content(content, Provenance::default()).unwrap();
        let path = dir.path().join("linen.sbt");
        write_table_atomic(&mut table, &path).unwrap();
        let args = |out: PathBuf| ClothLutArgs {
            table: path.clone(),
            out,
            precision: PrecisionArg::Half,
            check_points: 100,
        };
        run_cloth_lut(&args(dir.path().join("linen.dds"))).unwrap();
        for name in [
            "linen.dds",
            "linen-warp.dds",
            "linen-albedo.dds",
            "linen.json",
        ] {
            assert!(dir.path().join(name).is_file(), "{name}");
        }
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("linen.json")).unwrap()).unwrap();
        assert_eq!(json["errors"]["check_points"], 100);
        let err = run_cloth_lut(&args(dir.path().join("linen.png")))
            .unwrap_err()
            .to_string();
        assert!(err.contains("must end in .dds"), "{err}");
        let mut missing = args(dir.path().join("out.dds"));
        missing.table = dir.path().join("missing.sbt");
        let err = format!("{:#}", run_cloth_lut(&missing).unwrap_err());
        assert!(err.contains("missing.sbt"), "{err}");
    }
}
