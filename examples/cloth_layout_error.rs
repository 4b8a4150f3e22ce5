//! Interpolation error, size and build time of a cloth table grid, for choosing the stage's
//! defaults (docs/cloth.md §4, decision CLOTH-19): the table of one fabric is built in memory
//! and its lookup compared with the model evaluated directly, as the stage's header does.
//!
//! `cargo run --release --example cloth_layout_error -- FABRIC [LIGHT_STEP HALF_FINE
//! HALF_COARSE POINTS PHI_STEP GRAZING GRAZING_STEP]` (defaults: the stage's).

use rayon::prelude::*;
use scatterbake::cloth::tabulate::{
    EnergyMode, GridSpec, HalfGrid, interpolation_error, lookup_f, tabulate_row,
};
use scatterbake::cloth::{ClothModel, ModelOptions, preset};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let Some(fabric) = args.get(1) else {
        return Err("usage: cloth_layout_error FABRIC [LIGHT_STEP HALF_FINE HALF_COARSE POINTS PHI_STEP GRAZING GRAZING_STEP]".into());
    };
    let num = |i: usize, d: f64| -> Result<f64, std::num::ParseFloatError> {
        args.get(i).map_or(Ok(d), |s| s.parse())
    };
    let model = ClothModel::new(preset(fabric)?, ModelOptions::default());
    let d = GridSpec::default();
    let spec = GridSpec {
        light_step_deg: num(2, d.light_step_deg)?,
        half_fine: num(3, d.half_fine)?,
        half_coarse_deg: num(4, d.half_coarse_deg)?,
        phi_i_step_deg: num(6, d.phi_i_step_deg)?,
        grazing_deg: num(7, d.grazing_deg)?,
        grazing_step_deg: num(8, d.grazing_step_deg)?,
        ..d
    };
    let points = num(5, 20000.0)? as usize;
    let grid = HalfGrid::new(model.fabric(), spec)?;
    let start = std::time::Instant::now();
    let rows: Vec<Vec<f32>> = (0..grid.theta_i_deg.len())
        .into_par_iter()
        .map(|ti| tabulate_row(&model, &grid, ti, EnergyMode::AsPrinted).values)
        .collect();
    let data: Vec<f32> = rows.concat();
    let build_s = start.elapsed().as_secs_f64();
    let domain = (grid.phi_i_deg[0], grid.phi_i_deg[grid.phi_i_deg.len() - 1]);
    let lookup = |q| lookup_f(&grid, &data, q);
    let (l2, max) = interpolation_error(&model, domain, points, lookup, |_, _| 1.0);
    println!(
        "{fabric} {spec:?}: axes {}x{}x{}x{}, {:.1} MB f32, build {build_s:.1} s, L2 {l2:.4}, max/peak {max:.4}",
        grid.theta_i_deg.len(),
        grid.phi_i_deg.len(),
        grid.half_x_deg.len(),
        grid.half_y_deg.len(),
        data.len() as f64 * 4e-6,
    );
    Ok(())
}
