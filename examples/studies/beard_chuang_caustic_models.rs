//! The two caustic models of 2-D tables (`gaussian`, the thesis's Table 3.3 filter, and
//! `airy-local`, decision RT-28) on Beard–Chuang drops, where no wave-exact reference exists:
//! what each does to the energy, the sign and the shape of the bows, per radius and sun
//! elevation.
//!
//! Per case and model it prints
//! - `∫p dΩ`: the bin sum of the phase over 4π before the table's renormalisation (the
//!   caustic model must not create or remove flux: both should give the same value);
//! - the most negative phase value relative to the table's maximum (must be ≥ 0);
//! - per azimuth column φ = 0°, 90°, 180° (φ = 180° is the top of the bow for a low sun): the
//!   GO primary caustic (peak of the unfiltered p = 2 intensity, a fraction of a row) and the
//!   primary maximum of the filtered phase after a 0.5° sun disc along θ, and their offset; on
//!   a sphere Airy theory puts the maximum a fixed fraction of an Airy unit inside the caustic,
//!   so a model that follows the local caustic gives offsets that vary smoothly with φ;
//! - the largest jump of the primary maximum between adjacent azimuth columns (over all
//!   columns), a measure of how smoothly each model follows the deformed caustic.
//!
//! `cargo run --release --example beard_chuang_caustic_models -- [rays] [azimuth_step_deg]`
//! (default 800 1; radii 0.4 (a sphere), 0.5, 1, 2 mm at 650 nm, sun 0°, 20°, 40°).
#[path = "common/mie_reference.rs"]
#[allow(dead_code)] // only the sun disc is used here
mod mie_reference;
use mie_reference::sun_disc;
use scatterbake::stages::raytrace::{RaytraceJob, RaytraceParams};

/// Position (deg) of the largest value in `v` over rows `lo..=hi`, refined by a parabola.
fn peak(v: &[f64], step: f64, lo: usize, hi: usize) -> f64 {
    let i = (lo..=hi)
        .max_by(|&a, &b| v[a].total_cmp(&v[b]))
        .unwrap_or(lo);
    let (a, b, c) = (v[i - 1], v[i], v[i + 1]);
    let den = a - 2.0 * b + c;
    let off = if den != 0.0 { 0.5 * (a - c) / den } else { 0.0 };
    (i as f64 + off) * step
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rays: usize = args.first().map_or(Ok(800), |s| s.parse())?;
    let astep: f64 = args.get(1).map_or(Ok(1.0), |s| s.parse())?;
    let (pstep, lambda): (f64, f64) = (0.0125, 650.0);
    println!("Beard–Chuang, {lambda} nm, {rays}² rays, {pstep}° × {astep}°");
    println!(
        "a_mm,sun_deg,model,integral,min_over_max,go_caustic_phi0,max_phi0,go_caustic_phi90,max_phi90,go_caustic_phi180,max_phi180,largest_jump_deg"
    );
    for a_um in [400.0, 500.0, 1000.0, 2000.0] {
        for elev in [0.0, 20.0, 40.0] {
            for model in ["gaussian", "airy-local"] {
                let toml = format!(
                    "shape = \"beard-chuang\"\nradii_um = [{a_um}]\nwavelengths_nm = [{lambda}]\nwater_index_model = \"sadeghi-table-3.2\"\nsun_elevation_deg = [{elev}]\nrays = {rays}\npolar_step_deg = {pstep}\nazimuth_step_deg = {astep}\ndiffraction_model = \"{model}\"\nmirror_symmetrise = false"
                );
                let p: RaytraceParams = toml::from_str(&toml)?;
                let job = RaytraceJob::new(p)?;
                let (values, _sigma) = job.trace_2d(lambda, elev)?;
                let np = (180.0 / pstep).round() as usize + 1;
                let na = (360.0 / astep).round() as usize;
                let nch = values.len() / (np * na);
                let (dth, dph) = (pstep.to_radians(), astep.to_radians());
                let at = |j: usize, k: usize, c: usize| values[(j * na + k) * nch + c] as f64;
                // Channels: phase, i_perp, i_par, dolp, then per-order GO intensities p0…p3.
                let mut integral = 0.0;
                let (mut vmin, mut vmax) = (f64::INFINITY, 0.0f64);
                for j in 0..np {
                    let th = j as f64 * dth;
                    let om = ((th - 0.5 * dth).max(0.0).cos()
                        - (th + 0.5 * dth).min(std::f64::consts::PI).cos())
                        * dph;
                    for k in 0..na {
                        let v = at(j, k, 0);
                        integral += v * om;
                        vmin = vmin.min(v);
                        vmax = vmax.max(v);
                    }
                }
                // Primary bow window (scattering angle 134–146°).
                let (lo, hi) = (
                    (134.0 / pstep).round() as usize,
                    (146.0 / pstep).round() as usize,
                );
                let column =
                    |k: usize, c: usize| -> Vec<f64> { (0..np).map(|j| at(j, k, c)).collect() };
                let maxima: Vec<f64> = (0..na)
                    .map(|k| peak(&sun_disc(&column(k, 0), pstep, 0.5), pstep, lo, hi))
                    .collect();
                let jump = (0..na)
                    .map(|k| (maxima[(k + 1) % na] - maxima[k]).abs())
                    .fold(0.0, f64::max);
                let mut row = format!(
                    "{},{elev},{model},{integral:.5},{:.2e}",
                    a_um * 1e-3,
                    vmin / vmax
                );
                for phi in [0.0, 90.0, 180.0] {
                    let k = ((phi / astep) as usize).min(na - 1);
                    // p = 2 is channel 6 (phase, i_perp, i_par, dolp, p0, p1, p2, p3).
                    let go = peak(&column(k, 6), pstep, lo, hi);
                    row += &format!(",{go:.3},{:.3}", maxima[k]);
                }
                row += &format!(",{jump:.3}");
                println!("{row}");
            }
        }
    }
    Ok(())
}
