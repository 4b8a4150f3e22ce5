//! Interpolation error of the cloth table layout against the model, per fabric, for a grid
//! given on the command line: `cargo run --release --example cloth_layout_error -- FABRIC
//! LIGHT_STEP HALF_FINE HALF_COARSE [POINTS]`.

use rayon::prelude::*;
use scatterbake::cloth::tabulate::{
    EnergyMode, GridSpec, HalfGrid, interpolation_error, lookup_f, tabulate_row,
};
use scatterbake::cloth::{ClothModel, ModelOptions, preset};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let num = |i: usize, d: f64| a.get(i).map_or(d, |s| s.parse().unwrap());
    let model = ClothModel::new(preset(&a[1]).unwrap(), ModelOptions::default());
    let spec = GridSpec {
        light_step_deg: num(2, 5.0),
        half_fine: num(3, 0.35),
        half_coarse_deg: num(4, 5.0),
        phi_i_step_deg: num(6, 5.0),
        grazing_deg: num(7, 10.0),
        grazing_step_deg: num(8, 1.25),
        ..GridSpec::default()
    };
    let points = num(5, 20000.0) as usize;
    let grid = HalfGrid::new(model.fabric(), spec).unwrap();
    let t0 = std::time::Instant::now();
    let rows: Vec<Vec<f32>> = (0..grid.theta_i_deg.len())
        .into_par_iter()
        .map(|ti| tabulate_row(&model, &grid, ti, EnergyMode::AsPrinted).values)
        .collect();
    let data: Vec<f32> = rows.concat();
    let build = t0.elapsed().as_secs_f64();
    let dom = (grid.phi_i_deg[0], grid.phi_i_deg[grid.phi_i_deg.len() - 1]);
    if std::env::var("PROBE").is_ok() {
        probe(&model, [85.57, 11.85, 21.03, -179.8]);
        return;
    }
    if std::env::var("WORST").is_ok() {
        worst(&model, &grid, &data);
    }
    let (l2, max) = interpolation_error(
        &model,
        dom,
        points,
        |q| lookup_f(&grid, &data, q),
        |_, _| 1.0,
    );
    println!(
        "{} light {} fine {} coarse {} phi {} grazing {}/{}: axes {}x{}x{}x{}, {:.1} MB f32, build {:.1} s, L2 {:.4}, max/peak {:.4}",
        a[1],
        spec.light_step_deg,
        spec.half_fine,
        spec.half_coarse_deg,
        spec.phi_i_step_deg,
        spec.grazing_deg,
        spec.grazing_step_deg,
        grid.theta_i_deg.len(),
        grid.phi_i_deg.len(),
        grid.half_x_deg.len(),
        grid.half_y_deg.len(),
        data.len() as f64 * 4e-6,
        build,
        l2,
        max
    );
}

#[allow(dead_code)]
fn worst(model: &ClothModel, grid: &HalfGrid, data: &[f32]) {
    use scatterbake::cloth::tabulate::{halton4, luminance};
    let mut v = Vec::new();
    for k in 0..20000 {
        let u = halton4(k);
        let mut q = [
            2.5 + 85.0 * u[0],
            grid.phi_i_deg[0]
                + u[1] * (grid.phi_i_deg[grid.phi_i_deg.len() - 1] - grid.phi_i_deg[0]),
            2.5 + 85.0 * u[2],
            -180.0 + 360.0 * u[3],
        ];
        let r = q.map(f64::to_radians);
        let e = luminance(model.eval_angles(r[0], r[1], r[2], r[3]).total());
        let t = luminance(lookup_f(grid, data, q));
        v.push(((t - e).abs(), q, e, t));
    }
    v.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (n, d) = v
        .iter()
        .fold((0.0, 0.0), |a, x| (a.0 + x.0 * x.0, a.1 + x.2 * x.2));
    println!("worst-loop L2 {:.4}", (n / d as f64).sqrt());
    for x in &v[..8] {
        println!("{:?}", x);
    }
}

/// K(θ_i) at the fixed half vector of one pair (probe).
#[allow(dead_code)]
pub fn probe(model: &ClothModel, q: [f64; 4]) {
    use scatterbake::cloth::direction;
    use scatterbake::cloth::half::{half_of, reflect};
    use scatterbake::cloth::tabulate::luminance;
    let r = q.map(f64::to_radians);
    let (wi, wr) = (direction(r[0], r[1]), direction(r[2], r[3]));
    let h = half_of(wi, wr).unwrap();
    for k in 0..=20 {
        let t = 77.5 + 0.5 * k as f64;
        let wi = direction(t.to_radians(), r[1]);
        let wr = reflect(wi, h);
        let f = luminance(model.eval(wi, wr).total());
        println!(
            "theta_i {t:5.1} theta_r {:6.2} f {f:.4} K {:.4}",
            wr[2].acos().to_degrees(),
            f * wi[2]
        );
    }
}
