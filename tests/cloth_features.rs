//! The fabrics' features, measured as numbers on the tables (rows the `cloth` stage writes on
//! its default grid, `tabulate_row`, read by the table's lookup) next to the model evaluated
//! directly (`ClothModel`, finer lines and an independent albedo quadrature):
//!
//! - satin (front) at near-normal incidence: the highlights in the warp's plane of incidence,
//!   where flat stretches of the warp's tangent curve at angle α reflect the light to θ_r ≈ 2α;
//! - velvet: the grazing sheen, its directional albedo growing from normal to grazing light;
//! - silk shot: the colour shift between the mirror and the backscatter directions (red weft
//!   threads and green warp threads, Sadeghi et al. 2013).
//!
//! `cargo test --test cloth_features -- --nocapture` prints the figures quoted in docs/cloth.md.

use scatterbake::cloth::tabulate::{
    EnergyMode, GridSpec, HalfGrid, lookup_f, luminance, tabulate_row,
};
use scatterbake::cloth::{ClothModel, ModelOptions, direction, preset};

fn model(name: &str) -> ClothModel {
    ClothModel::new(preset(name).unwrap(), ModelOptions::default())
}

fn grid(m: &ClothModel) -> HalfGrid {
    HalfGrid::new(m.fabric(), GridSpec::default()).unwrap()
}

/// The table (one θ_i row filled, the others zero) and its lookup of f at (θ_i, φ_i, θ_r, φ_r).
fn row_table(m: &ClothModel, g: &HalfGrid, ti: usize) -> Vec<f32> {
    let row = tabulate_row(m, g, ti, EnergyMode::AsPrinted);
    let n = g.row_len();
    let mut data = vec![0.0f32; n * g.theta_i_deg.len()];
    data[ti * n..(ti + 1) * n].copy_from_slice(&row.values);
    data
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
/// plane of incidence is a highlight of the table's curve (its lookup on a 0.1° line) within
/// twice the largest β_x spacing over the warp's lobes (θ_r moves by 2Δβ_x per Δβ_x there), and
/// the three highlights of the warp's flat stretches are there (0° and ±2α).
#[test]
fn satin_highlights_sit_where_the_model_puts_them() {
    let m = model("polyester_satin_front");
    let g = grid(&m);
    let (ti, phi_i) = (0, 0.0);
    let theta_i = g.theta_i_deg[ti];
    let data = row_table(&m, &g, ti);
    let line = |f: &dyn Fn([f64; 4]) -> [f64; 3]| -> Vec<(f64, f64)> {
        (-899..=899)
            .map(|k| {
                let t = k as f64 * 0.1;
                let phi_r = if t >= 0.0 { 180f64 } else { 0.0 };
                (t, luminance(f([theta_i, phi_i, t.abs(), phi_r])))
            })
            .collect()
    };
    let fine = line(&|q| {
        let r = q.map(f64::to_radians);
        m.eval_angles(r[0], r[1], r[2], r[3]).total()
    });
    let table = line(&|q| lookup_f(&g, &data, q));
    let (model_peaks, table_peaks) = (peaks(&fine, 0.1), peaks(&table, 0.1));
    let xs = &g.half_x_deg;
    let spacing = xs
        .windows(2)
        .filter(|w| w[0] >= -32.0 && w[1] <= 32.0)
        .map(|w| w[1] - w[0])
        .fold(0.0, f64::max);
    println!(
        "satin front, θ_i = {theta_i}°, warp plane: model highlights {model_peaks:?}°, table {table_peaks:?}° (β_x spacing {spacing}°)"
    );
    assert!(model_peaks.len() >= 3, "{model_peaks:?}");
    for p in &model_peaks {
        assert!(
            table_peaks.iter().any(|q| (q - p).abs() <= 2.0 * spacing),
            "model highlight at {p}° missing from the table's {table_peaks:?}"
        );
    }
    assert!(model_peaks.iter().any(|p| p.abs() < 2.0 * theta_i));
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
    for theta_i in [5.0, 45.0, 75.0] {
        let ti = node(&g.theta_i_deg, theta_i);
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
/// colour (normalised RGB), in the table's lookup as in the model.
#[test]
fn silk_shot_changes_colour_between_mirror_and_backscatter() {
    let m = model("silk_shot");
    let g = grid(&m);
    let ti = node(&g.theta_i_deg, 32.5);
    let data = row_table(&m, &g, ti);
    let norm = |v: [f64; 3]| {
        let s = v[0] + v[1] + v[2];
        v.map(|c| c / s)
    };
    let mut colours = Vec::new();
    let theta = g.theta_i_deg[ti];
    for phi_i in [0.0, 90.0] {
        for (what, phi_r) in [("mirror", phi_i - 180.0), ("backscatter", phi_i)] {
            let q = [theta, phi_i, theta, phi_r];
            let table = norm(lookup_f(&g, &data, q));
            let r = q.map(f64::to_radians);
            let direct = norm(m.eval_angles(r[0], r[1], r[2], r[3]).total());
            println!(
                "silk shot θ_i = θ_r = {theta}°, φ_i = {phi_i}°, {what}: rgb/sum table {table:.3?}, model {direct:.3?}"
            );
            for c in 0..3 {
                assert!(
                    (table[c] - direct[c]).abs() < 0.01,
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
