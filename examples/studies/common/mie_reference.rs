//! Shared by the examples that compare ray-traced phase functions with Lorenz–Mie: the scatrs
//! (independent code) phase function and a uniform sun-disc convolution.
use num_complex::Complex;
use scatrs::mie::{AmplitudeBuffers, Mie, MieOptions};
use std::f64::consts::PI;

/// Unpolarised Mie phase function normalised to ∫ p dΩ = 1 (sr⁻¹) at `angles_deg`.
pub fn mie_phase(a_um: f64, lambda_nm: f64, n: f64, angles_deg: &[f64]) -> Vec<f64> {
    let k = 2.0 * PI / (lambda_nm * 1e-3);
    let mut m = Mie::<f64>::new();
    let sol = m
        .compute(k * a_um, Complex::new(n, 0.0), &MieOptions::new())
        .expect("mie");
    let q = sol.efficiencies().q_sca;
    let mu: Vec<f64> = angles_deg.iter().map(|d| d.to_radians().cos()).collect();
    let mut s1 = vec![Complex::new(0.0, 0.0); mu.len()];
    let mut s2 = vec![Complex::new(0.0, 0.0); mu.len()];
    sol.amplitudes(
        &mu,
        AmplitudeBuffers {
            s1: &mut s1,
            s2: &mut s2,
        },
    )
    .expect("amplitudes");
    let norm = k * k * q * PI * a_um * a_um;
    s1.iter()
        .zip(&s2)
        .map(|(a, b)| 0.5 * (a.norm_sqr() + b.norm_sqr()) / norm)
        .collect()
}

/// Uniform sun disc of angular diameter `diam_deg` (chord-length weights) on a uniform grid.
pub fn sun_disc(v: &[f64], step_deg: f64, diam_deg: f64) -> Vec<f64> {
    let r = 0.5 * diam_deg / step_deg;
    let h = r.ceil() as i64;
    let w: Vec<f64> = (-h..=h)
        .map(|d| (r * r - (d as f64).powi(2)).max(0.0).sqrt())
        .collect();
    (0..v.len() as i64)
        .map(|i| {
            let (mut s, mut ws) = (0.0, 0.0);
            for (k, d) in (-h..=h).enumerate() {
                let j = i + d;
                if j >= 0 && (j as usize) < v.len() {
                    s += w[k] * v[j as usize];
                    ws += w[k];
                }
            }
            s / ws
        })
        .collect()
}
