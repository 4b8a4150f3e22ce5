//! `scatterbake raytrace`: the ray-traced phase function of one drop at one wavelength.
//!
//! Prints, for spheres, the columns `angle_deg, i_perp, i_par, phase, dolp` of the 1-D
//! ray-traced phase function (the exact 1-D geometric-optics-plus-phase path of the `raytrace`
//! stage; point values at the requested angles); for non-spherical drops the same columns
//! averaged over the outgoing azimuth about the incident direction (a 2-D trace at the requested
//! sun elevation, 5° azimuth steps). Same vocabulary as `mie` and the tables
//! (`docs/vocabulary.md`): `i_perp`, `i_par` are the normalised perpendicular and parallel
//! components (1/sr), `phase = (i_perp + i_par)/2` with ∫_{4π} phase dΩ = 1,
//! `dolp = (i_perp − i_par)/(i_perp + i_par)`. The refractive index options are those of `mie`
//! (water by IAPWS R9-97 by default).

use crate::args::{AngleRange, IndexArgs};
use anyhow::{Context, bail};
use scatterbake::raytrace::domain::{check_radius_um, check_rays, check_sun_elevation_deg};
use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::sphere1d::{DiffractionModel, sphere_phase_curves};
use scatterbake::raytrace::table2d::{Table2dOptions, azimuth_mean_curves};
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout};

/// Arguments of `scatterbake raytrace`.
#[derive(clap::Args, Debug, Clone)]
pub struct RaytraceArgs {
    /// Equal-volume drop radius (µm), 10–5000.
    #[arg(long)]
    pub radius_um: f64,
    /// Vacuum wavelength (nm).
    #[arg(long)]
    pub wavelength_nm: f64,
    /// Drop shape.
    #[arg(long, default_value = "sphere", value_parser = ["sphere", "beard-chuang"])]
    pub shape: String,
    /// Sun elevation above the horizon (deg), non-spherical drops.
    #[arg(long, default_value_t = 0.0)]
    pub sun_elevation_deg: f64,
    /// Rays per side of the ray grid (non-spherical drops).
    #[arg(long, default_value_t = 600)]
    pub rays: usize,
    /// Layout of the ray grid (non-spherical drops): `silhouette` maps the grid onto the drop's
    /// silhouette, refined towards its edge; `silhouette-bows` also warps its rings towards the
    /// impact parameters that feed the bows; `square` spreads it over the bounding box (thesis).
    #[arg(long, default_value = "silhouette", value_parser = ["silhouette", "silhouette-bows", "square"])]
    pub ray_grid: String,
    /// Scattering angles START:STOP:STEP in degrees (STEP must divide 180).
    #[arg(long, default_value = "0:180:0.1", value_parser = AngleRange::parse)]
    pub angles: AngleRange,
    /// Skip the diffraction model (print geometric optics + interference only).
    #[arg(long)]
    pub no_diffraction_filter: bool,
    /// Refractive index (real: the ray tracer treats non-absorbing drops; k must be 0).
    #[command(flatten)]
    pub refractive: IndexArgs,
    /// Output format.
    #[arg(long, default_value = "csv", value_parser = ["csv", "json"])]
    pub format: String,
}

/// What [`run_raytrace`] prints.
#[derive(Debug, Clone)]
pub struct RaytraceColumns {
    /// Relative refractive index used.
    pub n: f64,
    pub angle_deg: Vec<f64>,
    pub i_perp: Vec<f64>,
    pub i_par: Vec<f64>,
    pub phase: Vec<f64>,
    pub dolp: Vec<f64>,
}

/// Compute the printed columns (no I/O).
pub fn raytrace_columns(args: &RaytraceArgs) -> anyhow::Result<RaytraceColumns> {
    let AngleRange { start, stop, step } = args.angles;
    // The trace covers the whole 0–180° grid of this step; the range selects from it.
    AngleRange::full(step).context("--angles")?;
    let n_polar = (180.0 / step).round() as usize + 1;
    check_radius_um(args.radius_um).map_err(|why| anyhow::anyhow!("--radius-um {why}"))?;
    let n = args
        .refractive
        .resolve_real(args.wavelength_nm, "ray tracing")?;
    if args.refractive.explicit()?.is_some() && !(n > 1.0 && n < 2.0) {
        bail!("--n {n} is outside (1, 2), where the primary bow exists");
    }
    let curves = if args.shape == "sphere" {
        sphere_phase_curves(
            args.radius_um,
            args.wavelength_nm,
            n,
            step,
            !args.no_diffraction_filter,
        )
    } else {
        check_rays(args.rays).map_err(|why| anyhow::anyhow!("--rays {why}"))?;
        check_sun_elevation_deg(args.sun_elevation_deg)
            .map_err(|why| anyhow::anyhow!("--sun-elevation-deg {why}"))?;
        let opts = Table2dOptions {
            rays: args.rays,
            ray_grid: match args.ray_grid.as_str() {
                "square" => RayGridLayout::Square,
                "silhouette-bows" => RayGridLayout::SilhouetteBows,
                _ => RayGridLayout::Silhouette,
            },
            max_order: 3,
            grid: DirectionGrid {
                n_polar,
                n_azimuth: 72,
            },
            diffraction_filter: !args.no_diffraction_filter,
            model: DiffractionModel::AiryLocal,
            sphere_higher_orders: true,
            diagnostic_channels: true,
            mirror_symmetrise: true,
            mirror_half: false,
        };
        let shape = DropShape::beard_chuang(args.radius_um * 1e-3);
        azimuth_mean_curves(&shape, args.wavelength_nm, n, args.sun_elevation_deg, &opts)
    };
    let mut out = RaytraceColumns {
        n,
        angle_deg: vec![],
        i_perp: vec![],
        i_par: vec![],
        phase: vec![],
        dolp: vec![],
    };
    for (j, &th) in curves.angle_deg.iter().enumerate() {
        if th < start - 1e-9 || th > stop + 1e-9 {
            continue;
        }
        let (ip, ipar) = (curves.i_perp[j], curves.i_par[j]);
        out.angle_deg.push(th);
        out.i_perp.push(ip);
        out.i_par.push(ipar);
        out.phase.push(curves.phase[j]);
        out.dolp.push(if ip + ipar > 0.0 {
            (ip - ipar) / (ip + ipar)
        } else {
            0.0
        });
    }
    Ok(out)
}

/// Run the command: compute and print.
pub fn run_raytrace(args: &RaytraceArgs) -> anyhow::Result<()> {
    let c = raytrace_columns(args)?;
    if args.format == "json" {
        let model = match args.refractive.explicit()? {
            Some(_) => "none".to_string(),
            None => args.refractive.water_index_model.clone(),
        };
        let v = serde_json::json!({
            "m": [c.n, 0.0],
            "water_index_model": model,
            "angle_deg": c.angle_deg, "i_perp": c.i_perp, "i_par": c.i_par, "phase": c.phase,
            "dolp": c.dolp,
            "normalization": "integral over 4pi sr of phase equals 1; phase = (i_perp + i_par)/2",
            "azimuth_average": args.shape != "sphere",
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("angle_deg,i_perp,i_par,phase,dolp");
        for i in 0..c.angle_deg.len() {
            println!(
                "{},{:.6e},{:.6e},{:.6e},{:.6}",
                c.angle_deg[i], c.i_perp[i], c.i_par[i], c.phase[i], c.dolp[i]
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: RaytraceArgs,
    }

    #[test]
    fn sphere_columns_cover_the_requested_angles() {
        let args = Cli::parse_from([
            "t",
            "--radius-um",
            "400",
            "--wavelength-nm",
            "650",
            "--rays",
            "100",
            "--angles",
            "130:145:0.05",
            "--water-index-model",
            "sadeghi-table-3.2",
        ])
        .args;
        let c = raytrace_columns(&args).unwrap();
        assert_eq!(c.n, 1.331);
        let (a, ip, ipar, ph) = (&c.angle_deg, &c.i_perp, &c.i_par, &c.phase);
        assert_eq!(a.len(), 301);
        assert!((a[0] - 130.0).abs() < 1e-9 && (a[300] - 145.0).abs() < 1e-9);
        for i in 0..a.len() {
            assert!((ph[i] - 0.5 * (ip[i] + ipar[i])).abs() <= 1e-6 * ph[i].abs() + 1e-12);
        }
        // An explicit index replaces the water model; absorption is refused.
        let with_n = |extra: &[&str]| {
            let mut v = vec!["t", "--radius-um", "400", "--wavelength-nm", "650"];
            v.extend(["--angles", "130:145:0.05"]);
            v.extend(extra);
            Cli::parse_from(v).args
        };
        let c = raytrace_columns(&with_n(&["--n", "1.34"])).unwrap();
        assert_eq!(c.n, 1.34);
        let c2 = raytrace_columns(&with_n(&["--index", "1.34"])).unwrap();
        assert_eq!(c.i_perp, c2.i_perp);
        assert!(raytrace_columns(&with_n(&["--index", "1.34+0.01i"])).is_err());
        assert!(raytrace_columns(&with_n(&["--n", "2.5"])).is_err());
        let default = raytrace_columns(&with_n(&[])).unwrap();
        let iapws = scatterbake::optics::water::WaterIndexModel::default()
            .index(650.0)
            .unwrap();
        assert_eq!(default.n, iapws);
        // One parser for every `--angles`: a malformed range is refused by clap, a step that
        // does not divide 180 (the grid of the trace) when the columns are computed.
        let parse = |angles: &str| {
            let v = [
                "t",
                "--radius-um",
                "400",
                "--wavelength-nm",
                "650",
                "--angles",
                angles,
            ];
            Cli::try_parse_from(v).map(|c| c.args)
        };
        for bad in ["1:2", "0:180:0", "0:180:-0.1", "150:140:1", "130:145:0.07"] {
            assert!(parse(bad).is_err(), "{bad}");
        }
        let err = raytrace_columns(&parse("130:144.7:0.7").unwrap()).unwrap_err();
        assert!(format!("{err:#}").contains("must divide 180"), "{err:#}");
    }

    /// A Beard–Chuang drop prints the azimuth means of its 2-D table: the bows where they
    /// belong, the polarisation of the primary.
    #[test]
    fn beard_chuang_columns_are_azimuth_means_of_the_table_values() {
        let args = Cli::parse_from([
            "t",
            "--radius-um",
            "1000",
            "--wavelength-nm",
            "650",
            "--shape",
            "beard-chuang",
            "--rays",
            "120",
            "--angles",
            "0:180:0.5",
        ])
        .args;
        let c = raytrace_columns(&args).unwrap();
        assert_eq!(c.angle_deg.len(), 361);
        let at = |deg: f64| ((deg / 0.5).round()) as usize;
        let band = |lo: f64, hi: f64| c.phase[at(lo)..=at(hi)].iter().sum::<f64>();
        for i in 0..c.angle_deg.len() {
            let (ip, ipar, ph) = (c.i_perp[i], c.i_par[i], c.phase[i]);
            assert!(ip >= 0.0 && ipar >= 0.0 && ip.is_finite() && ipar.is_finite());
            assert!(
                (ph - 0.5 * (ip + ipar)).abs() <= 1e-6 * ph + 1e-12,
                "{i}: {ph}"
            );
        }
        // The primary (137–142°) outshines Alexander's band (131–134°), and is polarised
        // perpendicular to the scattering plane.
        assert!(band(137.0, 142.0) > 3.0 * band(131.0, 134.0));
        assert!(c.dolp[at(139.0)] > 0.3, "{}", c.dolp[at(139.0)]);
    }
}
