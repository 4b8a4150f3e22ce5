//! Synthetic phase-function tables that follow the phase contract, with analytically known
//! properties, for tests, demos and the readers of other languages:
//! - [`henyey_greenstein_table`]: p(θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})
//!   ([`hg_density_sr`]), whose Legendre moments are exactly g^l;
//! - [`peak_table`]: a narrow Gaussian peak in scattering angle on a weak isotropic floor, with a
//!   wavelength-dependent peak position, normalised numerically to ∫_{4π} p dΩ = 1; a peak at
//!   138° must render as a ring of radius 42° around the antisolar point.
//!
//! Polarisation: i_perp = p (1 + d), i_par = p (1 − d) with d(θ) = `dolp_max` sin²θ / (1 + cos²θ)
//! (Rayleigh-like shape), so phase = (i_perp + i_par)/2 and dolp = d exactly.

use crate::optics::henyey_greenstein::hg_density_sr;
use crate::table::{Axis, Channel, Provenance, Schema, Table, TableContent};
use std::f64::consts::PI;

fn dolp_shape(dolp_max: f64, theta_deg: f64) -> f64 {
    let c = theta_deg.to_radians().cos();
    dolp_max * (1.0 - c * c) / (1.0 + c * c)
}

fn attributes(kind: &str) -> serde_json::Map<String, serde_json::Value> {
    let mut a = serde_json::Map::new();
    let mut put = |k: &str, v: serde_json::Value| {
        a.insert(k.into(), v);
    };
    put("normalization", "integral over 4pi sr equals 1".into());
    put("angle_convention", "scattering angle, 0 deg forward".into());
    put("water_index_model", "none (synthetic)".into());
    put("medium", "water drops in air (outside index 1.0)".into());
    put("sun_diameter_deg", 0.0.into());
    put(
        "angular_resampling",
        "point samples of an analytic function".into(),
    );
    put(
        "validated_domain",
        format!("synthetic {kind} table, exact by construction").into(),
    );
    a
}

fn channels() -> Vec<Channel> {
    vec![
        Channel::new(
            "phase",
            "1/sr",
            "unpolarised phase function, integral over 4pi = 1",
        ),
        Channel::new("i_perp", "1/sr", "perpendicular part, same normalisation"),
        Channel::new("i_par", "1/sr", "parallel part, same normalisation"),
        Channel::new("dolp", "1", "(i_perp - i_par)/(i_perp + i_par)"),
    ]
}

fn push_point(data: &mut Vec<f32>, p: f64, d: f64) {
    data.extend_from_slice(&[
        p as f32,
        (p * (1.0 + d)) as f32,
        (p * (1.0 - d)) as f32,
        d as f32,
    ]);
}

/// A `radius × wavelength × scattering_angle` table (the Mie stage's axis order) of
/// Henyey–Greenstein phase functions: asymmetry `g(k, r)` at wavelength k and radius r,
/// `n_angle` uniform angles over [0, 180].
pub fn henyey_greenstein_table(
    wavelengths_nm: &[f64],
    radii_um: &[f64],
    g: impl Fn(usize, usize) -> f64,
    n_angle: usize,
    dolp_max: f64,
) -> Table {
    let step = 180.0 / (n_angle - 1) as f64;
    let mut data = Vec::new();
    for r in 0..radii_um.len() {
        for k in 0..wavelengths_nm.len() {
            let gk = g(k, r);
            for j in 0..n_angle {
                let t = step * j as f64;
                push_point(
                    &mut data,
                    hg_density_sr(t.to_radians().cos(), gk),
                    dolp_shape(dolp_max, t),
                );
            }
        }
    }
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("synthetic-hg-phase", 1),
        description: "Henyey-Greenstein phase functions (synthetic)".into(),
        axes: vec![
            Axis::values("radius", "um", radii_um.to_vec()),
            Axis::values("wavelength", "nm", wavelengths_nm.to_vec()),
            Axis::uniform("scattering_angle", "deg", 0.0, step, n_angle),
        ],
        channels: channels(),
        attributes: attributes("Henyey-Greenstein"),
        data,
    };
    Table::from_content(content, Provenance::default()).expect("consistent synthetic table")
}

/// A `wavelength × scattering_angle` table with a Gaussian peak of standard deviation
/// `sigma_deg` at `peak_deg(λ)` on an isotropic floor `floor` (relative to the peak height),
/// normalised so that ∫_{4π} p dΩ = 1 (trapezoid rule on the grid, which is how every consumer
/// integrates it).
pub fn peak_table(
    wavelengths_nm: &[f64],
    peak_deg: impl Fn(f64) -> f64,
    sigma_deg: f64,
    floor: f64,
    n_angle: usize,
) -> Table {
    let step = 180.0 / (n_angle - 1) as f64;
    let mut data = Vec::new();
    for &wl in wavelengths_nm {
        let t0 = peak_deg(wl);
        let raw: Vec<f64> = (0..n_angle)
            .map(|j| {
                let t = step * j as f64;
                floor + (-(t - t0).powi(2) / (2.0 * sigma_deg * sigma_deg)).exp()
            })
            .collect();
        // 2π ∫ p sinθ dθ by the trapezoid rule in θ.
        let mut integral = 0.0;
        for j in 1..n_angle {
            let (a, b) = (
                (step * (j - 1) as f64).to_radians(),
                (step * j as f64).to_radians(),
            );
            integral += 0.5 * (raw[j - 1] * a.sin() + raw[j] * b.sin()) * (b - a);
        }
        integral *= 2.0 * PI;
        for (j, v) in raw.iter().enumerate() {
            push_point(&mut data, v / integral, dolp_shape(0.3, step * j as f64));
        }
    }
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("synthetic-peak-phase", 1),
        description: "Gaussian peak in scattering angle (synthetic)".into(),
        axes: vec![
            Axis::values("wavelength", "nm", wavelengths_nm.to_vec()),
            Axis::uniform("scattering_angle", "deg", 0.0, step, n_angle),
        ],
        channels: channels(),
        attributes: attributes("Gaussian peak"),
        data,
    };
    Table::from_content(content, Provenance::default()).expect("consistent synthetic table")
}

/// A ray-traced-style 2-D table in the version 1 layout, which readers still accept (schema
/// `raytrace-phase-2d/1`: wavelength × sun_elevation × outgoing_polar × outgoing_azimuth,
/// channel `phase`) made from a 1-D phase table
/// (wavelength × scattering_angle): p(λ, e, θ, φ) = p_1d(λ, θ) · `factor(θ, φ)` at every
/// elevation in `elevations_deg`, azimuth samples 0, step, … < 360. With `factor ≡ 1` this is
/// what the ray tracer writes for a sphere; an azimuth-dependent factor mimics a flattened drop
/// (normalisation is then not preserved — test use only).
pub fn lat_long_from_1d(
    table_1d: &Table,
    elevations_deg: &[f64],
    azimuth_step_deg: f64,
    factor: impl Fn(f64, f64) -> f64,
) -> Table {
    let axes = table_1d.axes();
    let (wl, th) = (&axes[0], &axes[axes.len() - 1]);
    let ch = table_1d.channel_index("phase").expect("phase channel");
    let na = (360.0 / azimuth_step_deg).round() as usize;
    let mut data = Vec::with_capacity(wl.len() * elevations_deg.len() * th.len() * na);
    for k in 0..wl.len() {
        for _ in elevations_deg {
            for j in 0..th.len() {
                let p = table_1d.at(&[k, j], ch) as f64;
                for i in 0..na {
                    data.push((p * factor(th.coord(j), i as f64 * azimuth_step_deg)) as f32);
                }
            }
        }
    }
    let content = TableContent {
        encoding: Default::default(),
        schema: Schema::new("raytrace-phase-2d", 1),
        description: "1-D phase function replicated over outgoing azimuth (synthetic)".into(),
        axes: vec![
            wl.clone(),
            Axis::values("sun_elevation", "deg", elevations_deg.to_vec()),
            Axis::values("outgoing_polar", "deg", th.coords()),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, azimuth_step_deg, na),
        ],
        channels: vec![Channel::new("phase", "1/sr", "1-D phase × azimuth factor")],
        attributes: attributes("lat-long replica"),
        data,
    };
    Table::from_content(content, Provenance::default()).expect("consistent synthetic table")
}
