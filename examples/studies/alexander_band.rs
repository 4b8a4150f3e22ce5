//! Alexander's dark band of the 1-D ray-traced sphere against Lorenz–Mie (scatrs), per highest
//! traced order: mean phase over the band (point values, no sun disc).
//!
//! `cargo run --release --example alexander_band`
#[path = "common/curves.rs"]
#[allow(dead_code)] // maxima serves other examples
mod curves;
use curves::window_mean;
#[path = "common/mie_reference.rs"]
#[allow(dead_code)] // sun_disc is used by the other example
mod mie_reference;
use mie_reference::mie_phase;
use scatterbake::raytrace::sphere1d::{Phase1dOptions, SphereGo, sphere_phase_1d};

fn main() {
    let (lambda, n) = (650.0, 1.331);
    let step = 0.01;
    let ang: Vec<f64> = (0..=3200).map(|i| 118.0 + step * i as f64).collect();
    let mean = |v: &[f64], lo: f64, hi: f64| window_mean(&ang, v, lo, hi);
    for a_mm in [0.1, 0.2, 0.4, 1.0] {
        let a = a_mm * 1e3;
        let m = mie_phase(a, lambda, n, &ang);
        // band between the geometric secondary (≈129.5°) and primary (≈137.8°), away from both
        let (lo, hi) = (131.0, 136.0);
        let mb = mean(&m, lo, hi);
        print!("a = {a_mm} mm: Mie band {mb:.4e}");
        for p in [2usize, 3, 4, 5, 6, 7, 8] {
            let go = SphereGo::new(a, lambda, n, p);
            let (ch, _) = sphere_phase_1d(&go, &ang, Phase1dOptions::default());
            let b = mean(&ch[0], lo, hi);
            print!("  p≤{p}: {:.3}", b / mb);
            if p == 6 {
                let w: Vec<String> = (0..6)
                    .map(|k| {
                        let l = 130.5 + k as f64;
                        format!("{:.3}", mean(&ch[0], l, l + 1.0) / mean(&m, l, l + 1.0))
                    })
                    .collect();
                print!(" [1° windows from 130.5°: {}]", w.join(" "));
            }
        }
        println!();
    }
}
