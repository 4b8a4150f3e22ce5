//! The cloth engine LUT (`consumers::export::cloth_lut`, docs/cloth.md §7) read back from its
//! files and looked up by the shader code of the documentation, written out here on its own:
//! DDS parsing, R9G9B9E5 / half decoding, texel-centre addressing with clamp-to-edge bilinear
//! filtering, the warp rows, the mirrors, the two θ_i slabs. The result is compared with the
//! table's own lookup (`cloth::tabulate::lookup_f` after `Symmetry::reduce_deg`) and with the
//! model evaluated directly (`ClothModel::eval`) at random direction pairs over the whole
//! hemisphere (every azimuth, so that the mirrors are exercised).
//!
//! `cargo test -p scatterbake --test cloth_lut -- --nocapture` prints the figures.

use scatterbake::cloth::half::{half_direction, reflect};
use scatterbake::cloth::tabulate::{HalfGrid, lookup_f, luminance};
use scatterbake::cloth::{ClothModel, ModelOptions, Symmetry, direction, preset};
use scatterbake::consumers::export::cloth_lut::{
    ClothTableView, LutPrecision, build_lut, lut_paths, metadata, write_lut,
};
use scatterbake::math::rng::SplitMix64;
use scatterbake::stages::cloth::{ClothParams, ClothStage};
use scatterbake::stages::{StageSpec, run_in_memory};
use scatterbake::table::{Provenance, Table};
use serde_json::Value;
use std::path::Path;

/// A cloth table on a grid coarser in θ_i and φ_i than the default (the half-angle axes are the
/// default ones).
fn cloth_table(fabric: &str) -> Table {
    let text = format!(
        "fabric = \"{fabric}\"\ngrazing_step_deg = 2.5\nphi_i_step_deg = 15.0\ncheck_points = 2000"
    );
    let params: ClothParams = toml::from_str(&text).unwrap();
    let job = ClothStage.plan_params(params).unwrap();
    Table::from_content(run_in_memory(job.as_ref()).unwrap(), Provenance::default()).unwrap()
}

/// One texture as the GPU sees it: size and RGBA texels (x fastest, then y, then z).
struct Texture {
    size: [usize; 3],
    texels: Vec<[f64; 4]>,
}

fn word(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap())
}

/// f32 of an IEEE 754 binary16.
fn from_half(h: u16) -> f64 {
    let (sign, exp, frac) = (
        (h >> 15) as i32,
        ((h >> 10) & 0x1f) as i32,
        (h & 0x3ff) as f64,
    );
    let v = match exp {
        0 => frac * 2f64.powi(-24),
        31 => f64::INFINITY,
        e => (1.0 + frac / 1024.0) * 2f64.powi(e - 15),
    };
    if sign == 1 { -v } else { v }
}

/// A DDS file read from its header fields (width at byte 16, height 12, depth 24, DXGI format
/// at 128, texels from 148).
fn read_dds(path: &Path) -> Texture {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..4], b"DDS ");
    assert_eq!(&b[84..88], b"DX10");
    let volume = word(&b, 33) == 4;
    let size = [
        word(&b, 4) as usize,
        word(&b, 3) as usize,
        if volume { word(&b, 6) as usize } else { 1 },
    ];
    let n: usize = size.iter().product();
    let body = &b[148..];
    let bytes_per_texel = match word(&b, 32) {
        2 => 16,
        10 => 8,
        _ => 4,
    };
    assert_eq!(body.len(), n * bytes_per_texel, "{}", path.display());
    let texels = match word(&b, 32) {
        67 => (0..n)
            .map(|k| {
                let w = word(body, k);
                let scale = 2f64.powi((w >> 27) as i32 - 15 - 9);
                let m = |s: u32| f64::from((w >> s) & 511) * scale;
                [m(0), m(9), m(18), 1.0]
            })
            .collect(),
        10 => (0..n)
            .map(|k| {
                std::array::from_fn(|c| {
                    let o = 8 * k + 2 * c;
                    from_half(u16::from_le_bytes([body[o], body[o + 1]]))
                })
            })
            .collect(),
        2 => (0..n)
            .map(|k| std::array::from_fn(|c| f64::from(f32::from_bits(word(body, 4 * k + c)))))
            .collect(),
        f => panic!("DXGI format {f}"),
    };
    Texture { size, texels }
}

impl Texture {
    /// `texture(sampler, uvw)` with linear filtering and clamp to edge: texel i at (i + 0.5)/n.
    fn sample(&self, uvw: [f64; 3]) -> [f64; 4] {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        let mut t = [0.0; 3];
        for k in 0..3 {
            let n = self.size[k] as i64;
            let x = uvw[k] * n as f64 - 0.5;
            let i = x.floor() as i64;
            t[k] = x - i as f64;
            lo[k] = i.clamp(0, n - 1) as usize;
            hi[k] = (i + 1).clamp(0, n - 1) as usize;
        }
        let mut out = [0.0; 4];
        for (z, wz) in [(lo[2], 1.0 - t[2]), (hi[2], t[2])] {
            for (y, wy) in [(lo[1], 1.0 - t[1]), (hi[1], t[1])] {
                for (x, wx) in [(lo[0], 1.0 - t[0]), (hi[0], t[0])] {
                    let v = self.texels[(z * self.size[1] + y) * self.size[0] + x];
                    for c in 0..4 {
                        out[c] += wx * wy * wz * v[c];
                    }
                }
            }
        }
        out
    }
}

/// The exported LUT read back: the three textures and the JSON constants.
struct Lut {
    k: Texture,
    warp: Texture,
    albedo: Texture,
    json: Value,
}

fn read_lut(out: &Path) -> Lut {
    let stem = out.file_stem().unwrap().to_str().unwrap();
    let side = |s: &str| out.with_file_name(format!("{stem}{s}"));
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(side(".json")).unwrap()).unwrap();
    Lut {
        k: read_dds(out),
        warp: read_dds(&side("-warp.dds")),
        albedo: read_dds(&side("-albedo.dds")),
        json,
    }
}

impl Lut {
    fn num(&self, key: &str) -> f64 {
        self.json[key].as_f64().unwrap()
    }

    fn flag(&self, key: &str) -> bool {
        self.json["symmetry"][key].as_bool().unwrap()
    }

    /// `clothNodeIndex(row, range, x)` of the documentation (the range from `X.json`).
    fn node_index(&self, row: usize, x: f64) -> f64 {
        let range = &self.json["warp_texture"]["range_deg"][row];
        let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
        let m = self.warp.size[0];
        let x = x.clamp(lo, hi);
        let bin = (((x - lo) / (hi - lo) * m as f64) as usize).min(m - 1);
        let w = self.warp.texels[row * m + bin];
        if x < w[2] {
            w[0] + (x - w[1]) / (w[2] - w[1])
        } else {
            w[0] + 1.0 + (x - w[2]) / (w[3] - w[2])
        }
    }

    /// `clothBrdf(wi, wo)` of the documentation, line by line.
    fn brdf(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        let (mut wi, mut wo) = (wi, wo);
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        if self.flag("mirror_y") && wi[1] < 0.0 {
            (wi[1], wo[1]) = (-wi[1], -wo[1]);
        }
        if self.flag("mirror_x") && wi[0] < 0.0 {
            (wi[0], wo[0]) = (-wi[0], -wo[0]);
        }
        if self.flag("swap_xy") && self.flag("mirror_y") && wi[1] > wi[0] {
            (wi[0], wi[1], wo[0], wo[1]) = (wi[1], wi[0], wo[1], wo[0]);
        }
        let deg = 180.0 / std::f64::consts::PI;
        let theta_i = wi[2].min(1.0).acos() * deg;
        let phi_i = wi[1].atan2(wi[0]) * deg;
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let (bx, by) = (s[0].atan2(s[2]) * deg, s[1].atan2(s[2]) * deg);
        let (jt, jx, jy) = (
            self.node_index(0, theta_i),
            self.node_index(1, bx),
            self.node_index(2, by),
        );
        let (n_theta, n_phi) = (self.num("n_theta_i"), self.num("n_phi_i"));
        let jp = ((phi_i - self.num("phi_i_lo_deg")) / self.num("phi_i_step_deg"))
            .clamp(0.0, n_phi - 1.0);
        let s0 = jt.floor().min(n_theta - 1.0);
        let s1 = (s0 + 1.0).min(n_theta - 1.0);
        let wt = jt - s0;
        let size = self.k.size.map(|n| n as f64);
        let uv = [(jx + 0.5) / size[0], (jy + 0.5) / size[1]];
        let k = |s: f64| {
            self.k
                .sample([uv[0], uv[1], (s * n_phi + jp + 0.5) / size[2]])
        };
        let (k0, k1) = (k(s0), k(s1));
        [0, 1, 2].map(|c| ((1.0 - wt) * k0[c] + wt * k1[c]) / wi[2])
    }

    /// E(ω) of the documentation: the albedo texture at the light direction ω's (θ, φ).
    fn albedo_e(&self, w: [f64; 3]) -> [f64; 3] {
        let (mut x, mut y) = (w[0], w[1]);
        if self.flag("mirror_y") && y < 0.0 {
            y = -y;
        }
        if self.flag("mirror_x") && x < 0.0 {
            x = -x;
        }
        if self.flag("swap_xy") && self.flag("mirror_y") && y > x {
            (x, y) = (y, x);
        }
        let deg = 180.0 / std::f64::consts::PI;
        let jt = self.node_index(0, w[2].min(1.0).acos() * deg);
        let (n_theta, n_phi) = (self.num("n_theta_i"), self.num("n_phi_i"));
        let jp = ((y.atan2(x) * deg - self.num("phi_i_lo_deg")) / self.num("phi_i_step_deg"))
            .clamp(0.0, n_phi - 1.0);
        let e = self
            .albedo
            .sample([(jp + 0.5) / n_phi, (jt + 0.5) / n_theta, 0.5]);
        [e[0], e[1], e[2]]
    }
}

/// The table's grid, data and symmetry, as the stage wrote them.
fn table_parts(t: &Table) -> (HalfGrid, Symmetry) {
    let c = |k: usize| t.header.axes[k].coords();
    let grid = HalfGrid {
        theta_i_deg: c(0),
        phi_i_deg: c(1),
        half_x_deg: c(2),
        half_y_deg: c(3),
    };
    let s = &t.header.attributes["symmetry"];
    let sym = Symmetry {
        mirror_x: s["mirror_x"].as_bool().unwrap(),
        mirror_y: s["mirror_y"].as_bool().unwrap(),
        swap_xy: s["swap_xy"].as_bool().unwrap(),
    };
    (grid, sym)
}

/// Export `table` to `dir/name.dds` in `precision` and read it back.
fn export(table: &Table, dir: &Path, name: &str, precision: LutPrecision) -> Lut {
    let view = ClothTableView::new(table).unwrap();
    let lut = build_lut(&view, precision).unwrap();
    let paths = lut_paths(&dir.join(format!("{name}.dds"))).unwrap();
    write_lut(&lut, &metadata(&view, &lut, &paths, None), &paths).unwrap();
    read_lut(&paths.brdf)
}

/// (relative L2, max |Δ| / peak) of luminances `(reference, approx)`.
fn errors(pairs: &[(f64, f64)]) -> (f64, f64) {
    let num: f64 = pairs.iter().map(|(r, a)| (a - r).powi(2)).sum();
    let den: f64 = pairs.iter().map(|(r, _)| r * r).sum();
    let peak = pairs.iter().map(|p| p.0).fold(0.0, f64::max);
    let max = pairs.iter().map(|(r, a)| (a - r).abs()).fold(0.0, f64::max);
    ((num / den).sqrt(), max / peak)
}

/// Values (1/sr) below which the node check compares absolute differences: R9G9B9E5 stores
/// values down to 2⁻²⁴ ≈ 6·10⁻⁸, and velvet's K falls to 10⁻¹⁹ away from its sheen.
const NODE_FLOOR_SR: f64 = 1e-3;

/// The LUT at exact table nodes (θ_i, φ_i and the reflected view of a (β_x, β_y) node) equals
/// the table's f to the storage precision: catches a transposed axis, an off-by-one slab or a
/// wrong texel centre.
fn check_nodes(lut: &Lut, table: &Table, rel: f64, name: &str) {
    let (grid, _) = table_parts(table);
    let mut rng = SplitMix64::new(17);
    let mut worst = 0.0f64;
    for _ in 0..300 {
        let pick = |v: &[f64], u: f64| v[((u * v.len() as f64) as usize).min(v.len() - 1)];
        let ti = pick(&grid.theta_i_deg, rng.next_f64());
        let pi = pick(&grid.phi_i_deg, rng.next_f64());
        let bx = pick(&grid.half_x_deg, rng.next_f64());
        let by = pick(&grid.half_y_deg, rng.next_f64());
        let wi = direction(ti.to_radians(), pi.to_radians());
        let wo = reflect(wi, half_direction(bx, by));
        if wo[2] < 0.05 {
            continue;
        }
        let got = lut.brdf(wi, wo);
        let pr = wo[1].atan2(wo[0]).to_degrees();
        let want = lookup_f(&grid, &table.data, [ti, pi, wo[2].acos().to_degrees(), pr]);
        let peak = want.iter().cloned().fold(0.0, f64::max);
        for c in 0..3 {
            worst = worst.max((got[c] - want[c]).abs() / peak.max(NODE_FLOOR_SR));
        }
    }
    println!("{name}: at 300 table nodes max |Δ| / max(max channel, 10⁻³ sr⁻¹) {worst:.2e}");
    assert!(worst < rel, "{name}: nodes {worst:e}");
}

/// LUT against the table's lookup and the model at `n` random direction pairs (θ uniform in
/// angle over [2.5°, 87.5°], azimuths over the circle): (LUT vs table, LUT vs model, table vs
/// model).
fn random_pairs(lut: &Lut, table: &Table, n: usize) -> [(f64, f64); 3] {
    let (grid, sym) = table_parts(table);
    let fabric = table.header.attributes["fabric"].as_str().unwrap();
    let model = ClothModel::new(preset(fabric).unwrap(), ModelOptions::default());
    let mut rng = SplitMix64::new(0x0c10_7a11);
    let (mut vs_table, mut vs_model, mut table_model) = (vec![], vec![], vec![]);
    for _ in 0..n {
        let q: [f64; 4] = std::array::from_fn(|k| {
            let u = rng.next_f64();
            if k % 2 == 0 {
                2.5 + 85.0 * u
            } else {
                -180.0 + 360.0 * u
            }
        });
        let r = q.map(f64::to_radians);
        let (wi, wo) = (direction(r[0], r[1]), direction(r[2], r[3]));
        let got = luminance(lut.brdf(wi, wo));
        let (pi, pr) = sym.reduce_deg(q[1], q[3]);
        let table_f = luminance(lookup_f(&grid, &table.data, [q[0], pi, q[2], pr]));
        let model_f = luminance(model.eval(wi, wo).total());
        vs_table.push((table_f, got));
        vs_model.push((model_f, got));
        table_model.push((model_f, table_f));
    }
    [errors(&vs_table), errors(&vs_model), errors(&table_model)]
}

#[test]
fn exported_lut_looked_up_as_documented_matches_the_table_and_the_model() {
    let dir = tempfile::tempdir().unwrap();
    for fabric in ["polyester_satin_front", "linen_plain", "velvet"] {
        let table = cloth_table(fabric);
        let lut = export(&table, dir.path(), fabric, LutPrecision::Rgb9e5);
        check_nodes(&lut, &table, 2.0 / 512.0, fabric);
        let [vs_table, vs_model, table_model] = random_pairs(&lut, &table, 20_000);
        println!(
            "{fabric} {:?}: 20 000 random pairs: LUT vs table L2 {:.2e}, max/peak {:.2e}; LUT vs \
             model L2 {:.4}, max/peak {:.4}; table vs model L2 {:.4}, max/peak {:.4}",
            lut.k.size,
            vs_table.0,
            vs_table.1,
            vs_model.0,
            vs_model.1,
            table_model.0,
            table_model.1
        );
        // R9G9B9E5 rounds each channel by at most 2⁻⁹ of the texel's largest channel; the
        // lookup is otherwise the table's interpolant (measured: L2 3.0–3.6·10⁻⁴).
        assert!(
            vs_table.0 < 1e-3 && vs_table.1 < 3e-3,
            "{fabric}: {vs_table:?}"
        );
        assert!(
            vs_model.0 < table_model.0 + 1e-3 && vs_model.1 < table_model.1 + 3e-3,
            "{fabric}: LUT vs model {vs_model:?}, table vs model {table_model:?}"
        );
        check_albedo(&lut, &table, fabric);
    }
}

/// The albedo texture at the table's nodes is the header's directional albedo, and the JSON's
/// average is the header's.
fn check_albedo(lut: &Lut, table: &Table, fabric: &str) {
    let (grid, _) = table_parts(table);
    let header = &table.header.attributes["albedo_rgb_as_printed"];
    for (s, ti) in grid.theta_i_deg.iter().enumerate() {
        for (p, pi) in grid.phi_i_deg.iter().enumerate() {
            let e = lut.albedo_e(direction(ti.to_radians(), pi.to_radians()));
            for c in 0..3 {
                let want = header[s][p][c].as_f64().unwrap();
                assert!(
                    (e[c] - want).abs() <= 1e-5 * want.max(1e-3),
                    "{fabric} {s} {p}"
                );
            }
        }
    }
    let avg = &table.header.attributes["albedo_average_rgb_as_printed"];
    for c in 0..3 {
        let (got, want) = (
            lut.json["albedo_average_rgb"][c].as_f64().unwrap(),
            avg[c].as_f64().unwrap(),
        );
        assert!(
            (got - want).abs() <= 1e-12 * want,
            "{fabric} E_avg {got} {want}"
        );
    }
}

/// Half and float storage: the same lookup, tighter at the nodes.
#[test]
fn half_and_float_textures_hold_the_nodes_to_their_precision() {
    let dir = tempfile::tempdir().unwrap();
    let table = cloth_table("silk_shot");
    for (precision, rel, random_l2, name) in [
        (LutPrecision::Half, 2e-3, 3e-4, "half"),
        (LutPrecision::Float, 1e-5, 1e-6, "float"),
    ] {
        let lut = export(&table, dir.path(), name, precision);
        assert_eq!(lut.k.texels[0][3], 1.0, "{name}: alpha");
        check_nodes(&lut, &table, rel, name);
        let [vs_table, _, _] = random_pairs(&lut, &table, 2000);
        println!(
            "{name}: 2000 random pairs: LUT vs table L2 {:.2e}, max/peak {:.2e}",
            vs_table.0, vs_table.1
        );
        assert!(vs_table.0 < random_l2, "{name}: {vs_table:?}");
    }
}

#[test]
fn bad_inputs_give_clear_errors() {
    let hg = scatterbake::fixtures::henyey_greenstein_table(&[550.0], &[1.0], |_, _| 0.5, 19, 0.0);
    let e = ClothTableView::new(&hg).err().unwrap().to_string();
    assert!(e.contains("not a cloth BRDF table"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let e = lut_paths(&dir.path().join("lut.png"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("must end in .dds"), "{e}");
    let e = lut_paths(&dir.path().join("missing/lut.dds"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("directory does not exist"), "{e}");
    let table = cloth_table("linen_plain");
    let mut renamed = table.clone();
    renamed.header.axes[2].name = "beta_x".into();
    let e = ClothTableView::new(&renamed).err().unwrap().to_string();
    assert!(e.contains("not the cloth-brdf/2 layout"), "{e}");
    let mut reversed = table.clone();
    let mut nodes = reversed.header.axes[3].coords();
    nodes.reverse();
    reversed.header.axes[3] = scatterbake::table::Axis::values("half_y", "deg", nodes);
    let e = ClothTableView::new(&reversed).err().unwrap().to_string();
    assert!(
        e.contains("axis half_y must have two or more increasing nodes"),
        "{e}"
    );
    // Two half_x nodes 1e-6° apart: the warp row would need ~10⁸ bins.
    let mut crowded = table.clone();
    let mut nodes = crowded.header.axes[2].coords();
    nodes[1] = nodes[0] + 1e-6;
    crowded.header.axes[2] = scatterbake::table::Axis::values("half_x", "deg", nodes);
    let view = ClothTableView::new(&crowded).unwrap();
    let e = build_lut(&view, LutPrecision::Rgb9e5)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("axis `half_x` has nodes") && e.contains("16384"),
        "{e}"
    );
    let mut negative = table;
    negative.data[0] = -1.0;
    let view = ClothTableView::new(&negative).unwrap();
    let e = build_lut(&view, LutPrecision::Rgb9e5)
        .unwrap_err()
        .to_string();
    assert!(e.contains("negative or not finite"), "{e}");
}
