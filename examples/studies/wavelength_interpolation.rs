//! Could the wavelengths of a Beard–Chuang entry share one trace? The rays' outgoing direction
//! and optical path depend on the wavelength only through the drop's index, smoothly where the
//! ray keeps its history (figures for docs/studies/raytrace-performance.md, "Rays shared across
//! wavelengths"; a measurement, not a test).
//!
//! `cargo run --release --example wavelength_interpolation -- RADIUS_MM SUN_DEG [NODES]` traces
//! rays at 2000 impact parameters along 24 directions ψ on the silhouette (`outgoing_rays`) at
//! the 33 wavelengths 380–700 nm (Table 3.2 indices), and interpolates each ray's direction
//! and optical path in the index through `NODES` (default 3) wavelengths spread evenly
//! over the range (Lagrange). Printed per order p = 0…3, over the wavelengths not among the
//! nodes: the rays whose outgoing order exists at some wavelengths and not at others, and of
//! the rest the 99th percentile and the largest error of the direction (degrees of arc) and of
//! the phase (2π/λ times the path's error, radians).

use scatterbake::math::vec3::{cross, dot, norm};
use scatterbake::optics::water::WaterIndexModel;
use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::tracer::{OutgoingRay, RayGridLayout, TraceConfig, outgoing_rays};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

const ORDERS: usize = 4;

/// Lagrange weights of the nodes `xs` at `x`.
fn lagrange(xs: &[f64], x: f64) -> Vec<f64> {
    (0..xs.len())
        .map(|i| {
            (0..xs.len())
                .filter(|&j| j != i)
                .map(|j| (x - xs[j]) / (xs[i] - xs[j]))
                .product()
        })
        .collect()
}

/// The unit vector at polar angle `t` and azimuth `p` (radians).
fn unit(t: f64, p: f64) -> [f64; 3] {
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// Angle between the direction `a` (any length) and the unit vector `b` (radians).
fn arc(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b))
}

/// The value at the 99th percentile and the largest of `v`.
fn p99_and_max(mut v: Vec<f64>) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    (v[(v.len() - 1) * 99 / 100], v[v.len() - 1])
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (a_mm, sun): (f64, f64) = match args.as_slice() {
        [a, s, ..] => (a.parse()?, s.parse()?),
        _ => return Err("usage: wavelength_interpolation RADIUS_MM SUN_DEG [NODES]".into()),
    };
    let nodes: usize = args.get(2).map_or(Ok(3), |n| n.parse())?;
    let wavelengths: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
    let node_of = |i: usize| i * (wavelengths.len() - 1) / (nodes - 1);
    let node_idx: Vec<usize> = (0..nodes).map(node_of).collect();
    let model = WaterIndexModel::SadeghiTable32;
    let index: Vec<f64> = (wavelengths.iter())
        .map(|&l| model.index(l))
        .collect::<Result<_, _>>()?;
    let shape = DropShape::beard_chuang(a_mm);
    let bs: Vec<f64> = (0..2000).map(|i| (i as f64 + 0.5) / 2000.0).collect();
    // rays[wavelength][psi × b][order]
    let rays: Vec<Vec<Vec<Option<OutgoingRay>>>> = (wavelengths.iter().zip(&index))
        .map(|(&wavelength_nm, &n)| {
            let cfg = TraceConfig {
                rays: 2,
                max_order: ORDERS - 1,
                sun_elevation_rad: sun.to_radians(),
                wavelength_nm,
                n,
                ray_grid: RayGridLayout::Silhouette,
            };
            (0..24)
                .flat_map(|s| outgoing_rays(&shape, &cfg, (s as f64 * 15.0).to_radians(), &bs))
                .collect()
        })
        .collect();
    let xs: Vec<f64> = node_idx.iter().map(|&i| index[i]).collect();
    println!(
        "{a_mm} mm, sun {sun}°, {} rays, index nodes at {:?} nm",
        rays[0].len(),
        node_idx.iter().map(|&i| wavelengths[i]).collect::<Vec<_>>()
    );
    println!(
        "order,rays_changing_history,direction_p99_deg,direction_max_deg,phase_p99_rad,phase_max_rad"
    );
    for p in 0..ORDERS {
        let (mut changing, mut dir_err, mut phase_err) = (0, vec![], vec![]);
        for r in 0..rays[0].len() {
            let all: Vec<Option<OutgoingRay>> = rays.iter().map(|w| w[r][p]).collect();
            let present = all.iter().filter(|x| x.is_some()).count();
            if present == 0 {
                continue;
            }
            if present < all.len() {
                changing += 1;
                continue;
            }
            let at = |i: usize| all[i].expect("present at every wavelength");
            for (i, &x) in index.iter().enumerate() {
                if node_idx.contains(&i) {
                    continue;
                }
                let w = lagrange(&xs, x);
                let mix = |f: &dyn Fn(OutgoingRay) -> f64| {
                    (node_idx.iter().zip(&w))
                        .map(|(&k, wk)| wk * f(at(k)))
                        .sum::<f64>()
                };
                // The direction as a unit vector (the azimuth is undefined at the poles).
                let v = |r: OutgoingRay, c: usize| unit(r.polar_rad, r.azimuth_rad)[c];
                let guess = [0, 1, 2].map(|c| mix(&|r| v(r, c)));
                let truth = at(i);
                dir_err.push(arc(guess, unit(truth.polar_rad, truth.azimuth_rad)).to_degrees());
                let k = std::f64::consts::TAU / (wavelengths[i] * 1e-3);
                phase_err.push(k * (mix(&|r| r.path_um) - truth.path_um).abs());
            }
        }
        let (d99, dmax) = p99_and_max(dir_err);
        let (f99, fmax) = p99_and_max(phase_err);
        println!("{p},{changing},{d99:.2e},{dmax:.2e},{f99:.2e},{fmax:.2e}");
    }
    Ok(())
}
