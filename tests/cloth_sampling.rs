//! Pearson χ² test of the cloth tables' sampling CDFs: samples drawn by the documented procedure
//! (`cloth::tabulate::sample_view`: `cdf_half_x` picks a β_x interval, `cdf_half_y` a β_y
//! interval, uniform inside, ω_r the light reflected about the half vector) from the CDF
//! channels of a row the `cloth` stage writes (`tabulate_row`, stored as f32), histogrammed over
//! the table's half-vector cells, against the expected counts from the luminance-weighted cosine
//! BRDF integrated over each cell by an independent 6 × 6 midpoint rule of the model evaluated
//! directly (Y(f) cos θ_r · 4(ω_i·h) · J(β), zero where ω_r is below the horizon). Cells with
//! fewer than 5 expected samples are pooled. A CDF built without the cos θ_r factor must fail the
//! same test. Measured figures: docs/cloth.md §6.

use scatterbake::cloth::half::{half_direction, half_jacobian, reflect};
use scatterbake::cloth::tabulate::{
    CHANNELS, EnergyMode, GridSpec, HalfGrid, cdfs, luminance, sample_view, tabulate_row, view_pdf,
};
use scatterbake::cloth::{ClothModel, ModelOptions, direction, preset};
use scatterbake::math::rng::SplitMix64;
use scatterbake::math::vec3::dot;
use std::f64::consts::PI;

/// Samples per test and the p-value below which the sampler is rejected.
const SAMPLES: usize = 200_000;
const P_MIN: f64 = 1e-3;
/// Midpoints per cell and axis of the expected-count integrals.
const SUB: usize = 6;

/// ln Γ(x), x > 0 (Lanczos, g = 7, n = 9; relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let t = x + 7.5;
    let s = C[1..]
        .iter()
        .enumerate()
        .fold(C[0], |s, (k, c)| s + c / (x + k as f64 + 1.0));
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// Regularised upper incomplete gamma Q(a, x) (series below a + 1, Lentz's continued fraction
/// above; Press et al., Numerical Recipes §6.2).
fn gamma_q(a: f64, x: f64) -> f64 {
    let front = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        while term.abs() > sum.abs() * 1e-15 {
            n += 1.0;
            term *= x / n;
            sum += term;
        }
        return (1.0 - sum * front).max(0.0);
    }
    let tiny = 1e-300;
    let (mut b, mut c, mut d) = (x + 1.0 - a, 1.0 / tiny, 1.0 / (x + 1.0 - a));
    let mut h = d;
    for i in 1..10_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        d = if d.abs() < tiny { tiny } else { d };
        c = b + an / c;
        c = if c.abs() < tiny { tiny } else { c };
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    front * h
}

/// Pearson χ², degrees of freedom and p-value of `observed` against `expected` (same total),
/// cells of expected count < 5 pooled into one bin.
fn pearson(observed: &[f64], expected: &[f64]) -> (f64, usize, f64) {
    let (mut chi2, mut bins, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            chi2 += (o - e).powi(2) / e;
            bins += 1;
        }
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        bins += 1;
    } else if pool_o > 0.0 {
        return (f64::INFINITY, bins, 0.0);
    }
    let dof = bins - 1;
    (chi2, dof, gamma_q(0.5 * dof as f64, 0.5 * chi2))
}

/// ∫ Y(f(ω_i, ω_r)) cos θ_r dω_r over every half-vector cell of the grid, β_x-major.
fn model_cells(model: &ClothModel, grid: &HalfGrid, wi: [f64; 3], cosine: bool) -> Vec<f64> {
    let (xs, ys) = (&grid.half_x_deg, &grid.half_y_deg);
    let light = model.prepare(wi);
    let mut out = Vec::with_capacity((xs.len() - 1) * (ys.len() - 1));
    for a in 0..xs.len() - 1 {
        let dx = (xs[a + 1] - xs[a]) / SUB as f64;
        for b in 0..ys.len() - 1 {
            let dy = (ys[b + 1] - ys[b]) / SUB as f64;
            let mut sum = 0.0;
            for i in 0..SUB {
                for j in 0..SUB {
                    let bx = xs[a] + (i as f64 + 0.5) * dx;
                    let by = ys[b] + (j as f64 + 0.5) * dy;
                    let h = half_direction(bx, by);
                    let wr = reflect(wi, h);
                    if wr[2] <= 0.0 {
                        continue;
                    }
                    let f = model.eval_prepared(&light, &model.prepare(wr)).total();
                    let cos_r = if cosine { wr[2] } else { 1.0 };
                    let jac = cos_r * 4.0 * dot(wi, h) * half_jacobian(bx, by);
                    sum += luminance(f) * jac * dx.to_radians() * dy.to_radians();
                }
            }
            out.push(sum);
        }
    }
    out
}

/// The stored CDF channels of node (θ_i row `ti`, φ_i index `pi`) of the stage's row.
fn stored_cdfs(model: &ClothModel, grid: &HalfGrid, ti: usize, pi: usize) -> (Vec<f64>, Vec<f64>) {
    let row = tabulate_row(model, grid, ti, EnergyMode::AsPrinted);
    let (n_x, n_y, nc) = (grid.half_x_deg.len(), grid.half_y_deg.len(), CHANNELS.len());
    let node = &row.values[pi * n_x * n_y * nc..(pi + 1) * n_x * n_y * nc];
    let marginal = (0..n_x)
        .map(|a| f64::from(node[a * n_y * nc + 3]))
        .collect();
    let conditional = (0..n_x * n_y)
        .map(|j| f64::from(node[j * nc + 4]))
        .collect();
    (marginal, conditional)
}

/// Histogram of `SAMPLES` draws over the cells of the drawn half vectors; the density of every
/// draw above the horizon checked against `view_pdf`.
fn histogram(
    grid: &HalfGrid,
    wi: [f64; 3],
    marginal: &[f64],
    conditional: &[f64],
    seed: u64,
) -> Vec<f64> {
    let n_y = grid.half_y_deg.len();
    let mut counts = vec![0.0; (grid.half_x_deg.len() - 1) * (n_y - 1)];
    let mut rng = SplitMix64::new(seed);
    for _ in 0..SAMPLES {
        let u = [rng.next_f64(), rng.next_f64()];
        let s = sample_view(grid, wi, marginal, conditional, u);
        if s.wr[2] > 0.0 {
            assert!(s.pdf_sr > 0.0 && s.pdf_sr.is_finite(), "{s:?}");
            let p = view_pdf(grid, wi, marginal, conditional, s.wr);
            assert!((p - s.pdf_sr).abs() <= 1e-9 * p, "{p} vs {s:?}");
        } else {
            assert_eq!(s.pdf_sr, 0.0);
        }
        counts[s.cell.0 * (n_y - 1) + s.cell.1] += 1.0;
    }
    counts
}

struct Case {
    fabric: &'static str,
    theta_i_row: usize,
    phi_i_index: usize,
}

/// (χ², dof, p) of the stage's CDFs and of a CDF built without cos θ_r, at one node.
fn run(case: &Case) -> [(f64, usize, f64); 2] {
    let model = ClothModel::new(preset(case.fabric).unwrap(), ModelOptions::default());
    let grid = HalfGrid::new(model.fabric(), GridSpec::default()).unwrap();
    let theta_i = grid.theta_i_deg[case.theta_i_row].to_radians();
    let wi = direction(theta_i, grid.phi_i_deg[case.phi_i_index].to_radians());
    let cells = model_cells(&model, &grid, wi, true);
    let total: f64 = cells.iter().sum();
    let expected: Vec<f64> = cells.iter().map(|c| c / total * SAMPLES as f64).collect();
    let (marginal, conditional) = stored_cdfs(&model, &grid, case.theta_i_row, case.phi_i_index);
    let observed = histogram(&grid, wi, &marginal, &conditional, 7);
    if std::env::var("CHI2_DEBUG").is_ok() {
        let n_y = grid.half_y_deg.len() - 1;
        let mut v: Vec<(f64, usize)> = observed
            .iter()
            .zip(&expected)
            .enumerate()
            .filter(|(_, (_, e))| **e >= 5.0)
            .map(|(k, (o, e))| ((o - e).powi(2) / e, k))
            .collect();
        v.sort_by(|a, b| b.0.total_cmp(&a.0));
        for (c, k) in &v[..10] {
            let (a, b) = (k / n_y, k % n_y);
            eprintln!(
                "cell ({}, {}) β ({:.2}, {:.2}) o {} e {:.1} χ² {c:.1}",
                a, b, grid.half_x_deg[a], grid.half_y_deg[b], observed[*k], expected[*k]
            );
        }
    }
    let good = pearson(&observed, &expected);
    // The deliberate error: the cells weigh f·4(ω_i·h)·J without the cosine of ω_r.
    let wrong: Vec<[f64; 3]> = model_cells(&model, &grid, wi, false)
        .iter()
        .map(|&c| [c; 3])
        .collect();
    let (wrong_m, wrong_c) = cdfs(&grid, &wrong);
    let bad = pearson(&histogram(&grid, wi, &wrong_m, &wrong_c, 7), &expected);
    eprintln!(
        "{}, θ_i {}°, φ_i {}°: stored CDFs χ² = {:.1}, dof {}, p = {:.3e}; \
         without cos θ_r: χ² = {:.1}, dof {}, p = {:.3e}",
        case.fabric,
        grid.theta_i_deg[case.theta_i_row],
        grid.phi_i_deg[case.phi_i_index],
        good.0,
        good.1,
        good.2,
        bad.0,
        bad.1,
        bad.2
    );
    [good, bad]
}

#[test]
fn p_value_of_known_chi2_values() {
    // χ²(10) = 18.307 is the 95 % quantile; χ²(1) = 10.828 the 99.9 % one.
    assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 1e-4);
    assert!((gamma_q(0.5, 10.828 / 2.0) - 0.001).abs() < 1e-5);
    assert!((gamma_q(500.0, 500.0) - 0.494).abs() < 2e-3);
}

/// Every fabric at θ_i = 35° and 55°, and at grazing light (θ_i = 83.125°, where the model
/// changes fastest with the light) for velvet and satin: the stored CDFs pass, a CDF built
/// without cos θ_r is rejected.
#[test]
fn stored_cdfs_pass_and_a_cdf_without_the_cosine_fails() {
    let mut cases = Vec::new();
    for fabric in scatterbake::cloth::PRESET_NAMES {
        cases.push((fabric, 3, 4));
        cases.push((fabric, 5, 6));
    }
    cases.extend([
        ("velvet", 7, 10),
        ("velvet", 10, 10),
        ("polyester_satin_front", 10, 4),
    ]);
    let results: Vec<_> = cases
        .iter()
        .map(|&(fabric, theta_i_row, phi_i_index)| {
            let r = run(&Case {
                fabric,
                theta_i_row,
                phi_i_index,
            });
            (fabric, theta_i_row, r)
        })
        .collect();
    for (fabric, row, [good, bad]) in results {
        assert!(good.1 > 150, "{fabric} row {row}: {good:?}");
        assert!(
            good.2 > P_MIN,
            "{fabric} row {row}: stored CDFs rejected: {good:?}"
        );
        assert!(
            bad.2 < P_MIN,
            "{fabric} row {row}: the wrong CDF passed: {bad:?}"
        );
    }
}
