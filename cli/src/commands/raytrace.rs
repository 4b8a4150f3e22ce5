//! `scatterbake raytrace`: one drop at one wavelength.
//!
//! Prints, for spheres, the columns `angles_deg, i_perp, i_par, phase` of the 1-D ray-traced
//! phase function (contract normalisation: ∫ p dΩ = 1, `phase = (i_perp + i_par)/2`); for
//! non-spherical drops the same columns averaged over the outgoing azimuth about the incident
//! direction (a 2-D trace at the requested sun elevation, 5° azimuth steps).

use anyhow::{Context, bail};
use scatterbake::stages::Job;
use scatterbake::stages::raytrace::{RaytraceJob, RaytraceParams};
#[allow(unused_imports)]
use scatterbake::table::Table;

/// Arguments of `scatterbake raytrace`.
#[derive(clap::Args, Debug, Clone)]
pub struct RaytraceArgs {
    /// Equal-volume drop radius (mm).
    #[arg(long)]
    pub radius_mm: f64,
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
    /// Scattering angles START:STOP:STEP in degrees (STEP must divide 180).
    #[arg(long, default_value = "0:180:0.1")]
    pub angles: String,
    /// Skip the diffraction model (print geometric optics + interference only).
    #[arg(long)]
    pub no_diffraction_filter: bool,
    /// Water index model: sadeghi-table-3.2 or iapws1997.
    #[arg(long, default_value = "sadeghi-table-3.2")]
    pub water_index_model: String,
    /// Output format.
    #[arg(long, default_value = "csv", value_parser = ["csv", "json"])]
    pub format: String,
}

/// Columns printed by [`run_raytrace`]: (angles_deg, i_perp, i_par, phase).
pub type RaytraceColumns = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// Compute the printed columns (no I/O).
pub fn raytrace_columns(args: &RaytraceArgs) -> anyhow::Result<RaytraceColumns> {
    let parts: Vec<f64> = args
        .angles
        .split(':')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .context("--angles must be START:STOP:STEP in degrees")?;
    let [start, stop, step] = parts[..] else {
        bail!("--angles must be START:STOP:STEP in degrees");
    };
    if !(0.0..=180.0).contains(&start) || !(start..=180.0).contains(&stop) {
        bail!("--angles must satisfy 0 <= START <= STOP <= 180");
    }
    let sphere = args.shape == "sphere";
    let params = RaytraceParams {
        shape: args.shape.clone(),
        radius_mm: vec![args.radius_mm],
        wavelength_nm: vec![args.wavelength_nm],
        water_index_model: args.water_index_model.clone(),
        temperature_c: None,
        max_order: 3,
        angle_step_deg: step,
        sun_elevation_deg: vec![args.sun_elevation_deg],
        rays: args.rays,
        polar_step_deg: step,
        azimuth_step_deg: 5.0,
        diffraction_filter: !args.no_diffraction_filter,
        diffraction_model: None,
        profile_theta_deg: None,
        profile_r: None,
    };
    let job = RaytraceJob::new(params).map_err(|e| anyhow::anyhow!("{e}"))?;
    let chunk = job.run_task(0)?;
    let nch = scatterbake::raytrace::channel_names(3).len();
    let n_polar = (180.0 / step).round() as usize + 1;
    let n_az = if sphere { 1 } else { 72 };
    let (mut ang, mut ip, mut ipar, mut ph) = (vec![], vec![], vec![], vec![]);
    for j in 0..n_polar {
        let th = step * j as f64;
        if th < start - 1e-9 || th > stop + 1e-9 {
            continue;
        }
        let mean = |c: usize| -> f64 {
            (0..n_az)
                .map(|k| chunk[(j * n_az + k) * nch + c] as f64)
                .sum::<f64>()
                / n_az as f64
        };
        ang.push(th);
        ip.push(mean(1));
        ipar.push(mean(2));
        ph.push(mean(0));
    }
    Ok((ang, ip, ipar, ph))
}

/// Run the command: compute and print.
pub fn run_raytrace(args: &RaytraceArgs) -> anyhow::Result<()> {
    let (ang, ip, ipar, ph) = raytrace_columns(args)?;
    if args.format == "json" {
        let v = serde_json::json!({
            "angles_deg": ang, "i_perp": ip, "i_par": ipar, "phase": ph,
            "normalization": "integral over 4pi sr equals 1",
            "azimuth_average": args.shape != "sphere",
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("angles_deg,i_perp,i_par,phase");
        for i in 0..ang.len() {
            println!("{},{:.6e},{:.6e},{:.6e}", ang[i], ip[i], ipar[i], ph[i]);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_columns_cover_the_requested_angles() {
        let args = RaytraceArgs {
            radius_mm: 0.4,
            wavelength_nm: 650.0,
            shape: "sphere".into(),
            sun_elevation_deg: 0.0,
            rays: 100,
            angles: "130:145:0.05".into(),
            no_diffraction_filter: false,
            water_index_model: "sadeghi-table-3.2".into(),
            format: "csv".into(),
        };
        let (a, ip, ipar, ph) = raytrace_columns(&args).unwrap();
        assert_eq!(a.len(), 301);
        assert!((a[0] - 130.0).abs() < 1e-9 && (a[300] - 145.0).abs() < 1e-9);
        for i in 0..a.len() {
            assert!((ph[i] - 0.5 * (ip[i] + ipar[i])).abs() <= 1e-6 * ph[i].abs() + 1e-12);
        }
        assert!(
            raytrace_columns(&RaytraceArgs {
                angles: "1:2".into(),
                ..args
            })
            .is_err()
        );
    }
}
