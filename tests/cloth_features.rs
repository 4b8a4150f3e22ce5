//! The fabrics' features, measured as numbers on the tables (rows the `cloth` stage writes on
//! its default 5° grid, `tabulate_row`) next to the model evaluated directly (`ClothModel`,
//! finer lines and an independent albedo quadrature):
//!
//! - satin (front) at near-normal incidence: the highlights in the warp's plane of incidence,
//!   where flat stretches of the warp's tangent curve at angle α reflect the light to θ_r ≈ 2α;
//! - velvet: the grazing sheen, its directional albedo growing from normal to grazing light;
//! - silk shot: the colour shift between the mirror and the backscatter directions (red weft
//!   threads and green warp threads, Sadeghi et al. 2013).
//!
//! `cargo test --test cloth_features -- --nocapture` prints the figures quoted in docs/cloth.md.

use scatterbake::cloth::tabulate::{AngleGrid, CHANNELS, EnergyMode, luminance, tabulate_row};
use scatterbake::cloth::{ClothModel, ModelOptions, direction, preset};

const STEP_DEG: f64 = 5.0;

fn model(name: &str) -> ClothModel {
    ClothModel::new(preset(name).unwrap(), ModelOptions::default())
}

fn grid(m: &ClothModel) -> AngleGrid {
    AngleGrid::new(m.fabric().symmetry(), STEP_DEG).unwrap()
}

/// The stored RGB of a row at φ_i node `pi`, θ_r node `a`, φ_r node `b`.
fn stored(values: &[f32], g: &AngleGrid, pi: usize, a: usize, b: usize) -> [f64; 3] {
    let (n_t, n_p, nc) = (g.theta_deg.len(), g.phi_r_deg.len(), CHANNELS.len());
    let k = ((pi * n_t + a) * n_p + b) * nc;
    [0, 1, 2].map(|c| f64::from(values[k + c]))
}

fn node(nodes: &[f64], v: f64) -> usize {
    (0..nodes.len())
        .min_by(|&a, &b| (nodes[a] - v).abs().total_cmp(&(nodes[b] - v).abs()))
        .unwrap()
}

/// Positions of the local maxima of a curve above `floor` × its maximum.
fn peaks(curve: &[(f64, f64)], floor: f64) -> Vec<f64> {
    let top = curve.iter().map(|p| p.1).fold(0.0, f64::max);
    (1..curve.len() - 1)
        .filter(|&k| {
            let y = curve[k].1;
            y > floor * top && y > curve[k - 1].1 && y >= curve[k + 1].1
        })
        .map(|k| curve[k].0)
        .collect()
}

/// Satin lit from near the normal along the warp: every highlight of the model's curve in the
/// plane of incidence is a highlight of the table's curve within one grid step, and the three
/// highlights of the warp's flat stretches are there (0° and ±2α).
#[test]
fn satin_highlights_sit_where_the_model_puts_them() {
    let m = model("polyester_satin_front");
    let g = grid(&m);
    let (ti, pi) = (0, 0);
    let theta_i = g.theta_deg[ti];
    let row = tabulate_row(&m, &g, ti, EnergyMode::AsPrinted);
    let (mirror, light) = (node(&g.phi_r_deg, 180.0), node(&g.phi_r_deg, 0.0));
    let n_t = g.theta_deg.len();
    let table: Vec<(f64, f64)> = (0..n_t)
        .rev()
        .map(|a| {
            (
                -g.theta_deg[a],
                luminance(stored(&row.values, &g, pi, a, light)),
            )
        })
        .chain((0..n_t).map(|a| {
            let v = stored(&row.values, &g, pi, a, mirror);
            (g.theta_deg[a], luminance(v))
        }))
        .collect();
    let fine: Vec<(f64, f64)> = (-899..=899)
        .map(|k| {
            let t = k as f64 * 0.1;
            let phi_r = if t >= 0.0 { 180f64 } else { 0.0 };
            let f = m.eval_angles(
                theta_i.to_radians(),
                0.0,
                t.abs().to_radians(),
                phi_r.to_radians(),
            );
            (t, luminance(f.total()))
        })
        .collect();
    let (model_peaks, table_peaks) = (peaks(&fine, 0.1), peaks(&table, 0.1));
    println!(
        "satin front, θ_i = {theta_i}°, warp plane: model highlights {model_peaks:?}°, table {table_peaks:?}°"
    );
    assert!(model_peaks.len() >= 3, "{model_peaks:?}");
    for p in &model_peaks {
        assert!(
            table_peaks.iter().any(|q| (q - p).abs() <= STEP_DEG),
            "model highlight at {p}° missing from the table's {table_peaks:?}"
        );
    }
    assert!(model_peaks.iter().any(|p| p.abs() < STEP_DEG));
    assert!(model_peaks.iter().any(|p| *p > 50.0) && model_peaks.iter().any(|p| *p < -50.0));
}

/// Velvet's grazing sheen: the directional albedo the table states (integrated from its stored
/// row) grows by more than an order of magnitude from normal to grazing light, and agrees with
/// an independent quadrature of the model.
#[test]
fn velvet_sheen_grows_toward_grazing() {
    let m = model("velvet");
    let g = grid(&m);
    let mut albedo = Vec::new();
    for theta_i in [2.5, 42.5, 77.5] {
        let ti = node(&g.theta_deg, theta_i);
        let row = tabulate_row(&m, &g, ti, EnergyMode::AsPrinted);
        let table = luminance(row.albedo[0]);
        let direct =
            luminance(m.directional_albedo(direction(theta_i.to_radians(), 0.0), 180, 720));
        println!(
            "velvet θ_i = {theta_i}°: albedo (luminance) table {table:.4e}, model {direct:.4e}"
        );
        assert!(
            (table - direct).abs() <= 0.1 * direct + 1e-4,
            "{table} vs {direct}"
        );
        albedo.push(table);
    }
    assert!(albedo[2] > 20.0 * albedo[0], "{albedo:?}");
    assert!(albedo[1] > albedo[0] && albedo[2] > albedo[1], "{albedo:?}");
}

/// Silk shot lit across the warp: the mirror direction and the backscatter direction differ in
/// colour (normalised RGB), on the table's nodes as in the model.
#[test]
fn silk_shot_changes_colour_between_mirror_and_backscatter() {
    let m = model("silk_shot");
    let g = grid(&m);
    let ti = node(&g.theta_deg, 32.5);
    let row = tabulate_row(&m, &g, ti, EnergyMode::AsPrinted);
    let norm = |v: [f64; 3]| {
        let s = v[0] + v[1] + v[2];
        v.map(|c| c / s)
    };
    let mut colours = Vec::new();
    for phi_i in [0.0, 90.0] {
        let pi = node(&g.phi_i_deg, phi_i);
        let theta = g.theta_deg[ti];
        for (what, phi_r) in [("mirror", phi_i - 180.0), ("backscatter", phi_i)] {
            let b = node(&g.phi_r_deg, phi_r);
            let table = norm(stored(&row.values, &g, pi, ti, b));
            let direct = norm(
                m.eval_angles(
                    theta.to_radians(),
                    phi_i.to_radians(),
                    theta.to_radians(),
                    phi_r.to_radians(),
                )
                .total(),
            );
            println!(
                "silk shot θ_i = θ_r = {theta}°, φ_i = {phi_i}°, {what}: rgb/sum table {table:.3?}, model {direct:.3?}"
            );
            for c in 0..3 {
                assert!(
                    (table[c] - direct[c]).abs() < 1e-5,
                    "{table:?} vs {direct:?}"
                );
            }
            colours.push(table);
        }
    }
    // The colour moves: some pair of directions differs by more than 0.2 in a channel share.
    let spread = (0..3)
        .map(|c| {
            let v = colours.iter().map(|x| x[c]);
            v.clone().fold(f64::MIN, f64::max) - v.fold(f64::MAX, f64::min)
        })
        .fold(0.0, f64::max);
    assert!(spread > 0.2, "{colours:?}");
    // Across the warp (φ_i = 90°) the mirror is red (the weft) and the backscatter green.
    let (mirror, back) = (colours[2], colours[3]);
    assert!(mirror[0] > mirror[1] && back[1] > back[0], "{colours:?}");
}
