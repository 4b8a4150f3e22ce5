//! Figure data for docs/fur.md (plots are made elsewhere):
//! `cargo run --release --example fur_profiles -- docs/data/fur`
//! Writes CSVs: expected vs histogram at equal photon count, single-scatter check, and a
//! longitudinal profile with its lobe pdf/cdf.
use scatterbake::fur::medulla::*;
use std::fmt::Write;

fn main() -> anyhow::Result<()> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).expect("output dir"));
    std::fs::create_dir_all(&dir)?;
    let set = |n, est, max_order| McSettings {
        photons: n,
        seed: 9,
        estimator: est,
        bins: 720,
        max_order,
    };
    // 1. Equal photon count, azimuthal σ = 2.5, g = 0.4, h' = 0.5.
    let geom = Geometry::Azimuthal { h: 0.5 };
    let a = simulate(2.5, 0.4, geom, &set(2000, Estimator::Expected, None));
    let b = simulate(2.5, 0.4, geom, &set(2000, Estimator::Histogram, None));
    let r = simulate(2.5, 0.4, geom, &set(40_000, Estimator::Expected, None));
    let mut s = String::from(
        "# azimuthal sigma=2.5 g=0.4 h=0.5, 720 bins; energy per bin; N=2000 photons each; reference = expected estimator with 40000 photons\nphi_deg,expected,expected_se,histogram,histogram_se,reference,reference_se,path_length\n",
    );
    for k in 0..720 {
        writeln!(
            s,
            "{:.2},{:.6e},{:.3e},{:.6e},{:.3e},{:.6e},{:.3e},{:.5}",
            -180.0 + (k as f64 + 0.5) * 0.5,
            a.energy[k],
            a.std_error[k],
            b.energy[k],
            b.std_error[k],
            r.energy[k],
            r.std_error[k],
            r.path_length[k]
        )?;
    }
    std::fs::write(dir.join("azimuthal_expected_vs_histogram.csv"), s)?;
    // 2. Single scattering: order-1 Monte Carlo and full transport at small σ vs analytic.
    let mut s = String::from(
        "# azimuthal g=0 h=0.3: analytic single-scatter energy per bin vs order-1 expected MC (sigma=1) and full MC at sigma=0.02\nphi_deg,analytic_s1,mc_order1_s1,analytic_s002,mc_full_s002\n",
    );
    let g1 = Geometry::Azimuthal { h: 0.3 };
    let an1 = single_scatter_energy(1.0, 0.0, g1, 720, 64);
    let mc1 = simulate(1.0, 0.0, g1, &set(2000, Estimator::Expected, Some(1)));
    let an2 = single_scatter_energy(0.02, 0.0, g1, 720, 64);
    let mc2 = simulate(0.02, 0.0, g1, &set(2000, Estimator::Expected, None));
    for k in 0..720 {
        writeln!(
            s,
            "{:.2},{:.6e},{:.6e},{:.6e},{:.6e}",
            -180.0 + (k as f64 + 0.5) * 0.5,
            an1[k],
            mc1.energy[k],
            an2[k],
            mc2.energy[k]
        )?;
    }
    std::fs::write(dir.join("azimuthal_single_scatter.csv"), s)?;
    // 3. Longitudinal lobes, σ = 2, g = 0.5, θ'_i = 30°.
    let gl = Geometry::Longitudinal {
        theta_i_rad: 30f64.to_radians(),
    };
    let p = simulate(2.0, 0.5, gl, &set(5000, Estimator::Expected, None));
    let (pdf, cdf) = normalise_lobes(&p.energy);
    let mut s = String::from(
        "# longitudinal sigma=2 g=0.5 theta_i=30 deg, 5000 photons: lobe, theta_r (deg, bin centre), energy per bin, se, lobe pdf (1/rad), lobe cdf (upper edge), path length\nlobe,theta_r_deg,energy,se,pdf,cdf,path_length\n",
    );
    for k in 0..720 {
        writeln!(
            s,
            "{},{:.2},{:.6e},{:.3e},{:.6e},{:.6},{:.5}",
            if k < 360 { "back" } else { "forward" },
            -90.0 + ((k % 360) as f64 + 0.5) * 0.5,
            p.energy[k],
            p.std_error[k],
            pdf[k],
            cdf[k],
            p.path_length[k]
        )?;
    }
    std::fs::write(dir.join("longitudinal_lobes.csv"), s)?;
    Ok(())
}
