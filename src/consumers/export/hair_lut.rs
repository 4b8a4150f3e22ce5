//! Engine exports of `hair-dual` tables (EXR LUT, 1-D JSON/CSV) and the CLI argument structs
//! (`scatterbake hair-lut`, `scatterbake dual-scattering` a.k.a. `hair-json`). Layouts and the
//! shader lookup formula: `docs/hair.md`. I/O happens only in the `run_*` functions.

use crate::hair::dual::DUAL_CHANNELS;

use crate::consumers::ConsumerError;
use crate::stages::hair::DUAL_TABLE_CHANNELS;
use crate::table::{Table, TableContent};
use serde_json::{Value, json};

/// A `hair-dual` table laid out as an engine texture: `width` = absorption (or colour) samples,
/// `height` = θ samples × roughness layers (layer `r` occupies rows `r·n_theta .. (r+1)·n_theta`,
/// θ increasing downwards from −90°), three RGBA groups `ds0..ds2` holding the twelve quantities in
/// [`DUAL_CHANNELS`] order (`ds0 = ā_f, ā_b, ᾱ_f, ᾱ_b`; `ds1 = β̄_f², β̄_b², Ā_b, Δ̄_b`;
/// `ds2 = σ̄_b², N^G_R, N^G_TT, N^G_TRT`). `parts[k][c]` is row-major `height × width`.
#[derive(Debug, Clone, PartialEq)]
pub struct DualLutLayout {
    pub width: usize,
    pub height: usize,
    pub n_theta: usize,
    pub n_roughness: usize,
    pub parts: [[Vec<f32>; 4]; 3],
    /// The column axis name (`absorption_u`, `sigma_a` or `colour_channel`).
    pub column_axis: String,
}

/// Turn a `hair-dual/1` table into the texture layout of [`DualLutLayout`].
pub fn dual_lut_layout(t: &TableContent) -> Result<DualLutLayout, ConsumerError> {
    let layout = |m: String| Err(ConsumerError::Layout(m));
    if t.schema.name != "hair-dual" || t.schema.version != 1 {
        return layout(format!("not a hair-dual/1 table ({})", t.schema));
    }
    if t.channels.len() != DUAL_TABLE_CHANNELS {
        return layout(format!(
            "hair-dual table with {} channels (expected {DUAL_TABLE_CHANNELS})",
            t.channels.len()
        ));
    }
    let (n_roughness, col_axis, theta_axis) = match t.axes.len() {
        3 => (t.axes[0].len(), &t.axes[1], &t.axes[2]),
        2 => (1, &t.axes[0], &t.axes[1]),
        n => return layout(format!("hair-dual table with {n} axes")),
    };
    if theta_axis.name != "theta" {
        return layout(format!(
            "last axis must be theta (found `{}`)",
            theta_axis.name
        ));
    }
    let width = col_axis.len();
    let n_theta = theta_axis.len();
    let height = n_theta * n_roughness;
    let mut parts: [[Vec<f32>; 4]; 3] =
        std::array::from_fn(|_| std::array::from_fn(|_| vec![0f32; width * height]));
    for ir in 0..n_roughness {
        for ia in 0..width {
            for it in 0..n_theta {
                let src = ((ir * width + ia) * n_theta + it) * DUAL_TABLE_CHANNELS;
                let pixel = (ir * n_theta + it) * width + ia;
                for q in 0..12 {
                    parts[q / 4][q % 4][pixel] = t.data[src + q];
                }
            }
        }
    }
    Ok(DualLutLayout {
        width,
        height,
        n_theta,
        n_roughness,
        parts,
        column_axis: col_axis.name.clone(),
    })
}

/// Write the layout as a single-part OpenEXR file (32-bit float, lossless compression) with
/// twelve channels named `ds0.R … ds2.A` (the classic layer.channel naming every OpenEXR reader
/// understands; no multi-part support needed). A header comment records the layout.
pub fn write_dual_lut_exr(
    layout: &DualLutLayout,
    path: &std::path::Path,
) -> Result<(), ConsumerError> {
    use exr::prelude::*;
    let size = (layout.width, layout.height);
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for k in 0..3 {
        for (c, n) in ["R", "G", "B", "A"].iter().enumerate() {
            channels.push(AnyChannel::new(
                format!("ds{k}.{n}").as_str(),
                FlatSamples::F32(layout.parts[k][c].clone()),
            ));
        }
    }
    let mut attrs = LayerAttributes::named("hair-dual");
    let groups: Vec<String> = (0..3)
        .map(|k| format!("ds{k} = ({})", DUAL_CHANNELS[4 * k..4 * k + 4].join(", ")))
        .collect();
    attrs.comments = Some(Text::from(
        format!(
            "scatterbake hair-dual/1 LUT: {}; columns = {} ({} samples), rows = theta -90..90 deg ({} samples) x {} roughness layers (docs/hair.md)",
            groups.join("; "),
            layout.column_axis,
            layout.width,
            layout.n_theta,
            layout.n_roughness
        )
        .as_str(),
    ));
    let layer = Layer::new(
        size,
        attrs,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|source| ConsumerError::Exr {
            what: format!("writing {}", path.display()),
            source,
        })?;
    Ok(())
}

/// JSON of the 1-D set (RGB triples per θ) from a `hair-dual/1` table whose column axis is
/// `colour_channel` and which has one roughness.
pub fn dual_json(t: &TableContent) -> Result<Value, ConsumerError> {
    let layout = dual_lut_layout(t)?;
    if layout.column_axis != "colour_channel" {
        return Err(ConsumerError::layout(
            "the JSON export needs a one-colour table (sigma_a_rgb, melanin or the artist model)",
        ));
    }
    if layout.n_roughness != 1 {
        return Err(ConsumerError::layout(
            "the JSON export needs a single roughness",
        ));
    }
    let nt = layout.n_theta;
    let theta_axis = t.axes.last().expect("axes");
    let theta_deg: Vec<f64> = theta_axis.coords();
    let mut obj = serde_json::Map::new();
    obj.insert("schema".into(), json!("hair-dual-1d/1"));
    obj.insert("theta_deg".into(), json!(theta_deg));
    let rgb = |ch: usize, it: usize| -> [f64; 3] {
        std::array::from_fn(|c| t.data[((c * nt) + it) * DUAL_TABLE_CHANNELS + ch] as f64)
    };
    for (q, name) in DUAL_CHANNELS.iter().enumerate() {
        let v: Vec<[f64; 3]> = (0..nt).map(|it| rgb(q, it)).collect();
        obj.insert((*name).into(), json!(v));
    }
    let mut lobes = serde_json::Map::new();
    for (k, name) in ["R", "TT", "TRT", "residual"].iter().enumerate() {
        let v: Vec<[f64; 3]> = (0..nt).map(|it| rgb(12 + k, it)).collect();
        lobes.insert((*name).into(), json!(v));
    }
    obj.insert("lobe_energy".into(), Value::Object(lobes));
    let mut conventions = t.attributes.clone();
    conventions.insert("units".into(), json!("theta_deg in degrees; alpha_*, delta_b in rad; beta_*2, sigma_b2 in rad²; N_G_* per rad; triples are (R, G, B)"));
    obj.insert("conventions".into(), Value::Object(conventions));
    Ok(Value::Object(obj))
}

/// CSV of the same 1-D set: `theta_deg`, then `<quantity>_r,_g,_b` for the twelve quantities and
/// the lobe energies.
pub fn dual_csv(t: &TableContent) -> Result<String, ConsumerError> {
    let j = dual_json(t)?;
    let theta = j["theta_deg"].as_array().expect("theta").clone();
    let mut cols: Vec<(String, &Value)> = DUAL_CHANNELS
        .iter()
        .map(|n| (n.to_string(), &j[*n]))
        .collect();
    for n in ["R", "TT", "TRT", "residual"] {
        cols.push((format!("E_{n}"), &j["lobe_energy"][n]));
    }
    let mut s = String::from("theta_deg");
    for (n, _) in &cols {
        for c in ["r", "g", "b"] {
            s.push_str(&format!(",{n}_{c}"));
        }
    }
    s.push('\n');
    for (i, th) in theta.iter().enumerate() {
        s.push_str(&format!("{}", th.as_f64().unwrap_or(f64::NAN)));
        for (_, v) in &cols {
            for c in 0..3 {
                s.push_str(&format!(",{}", v[i][c].as_f64().unwrap_or(f64::NAN)));
            }
        }
        s.push('\n');
    }
    Ok(s)
}

/// Shader language of [`dual_shader_tables`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShaderLanguage {
    /// RenderMan Shading Language, the language of Sadeghi 2012 App. C.
    Rsl,
    /// C99 (a header: `static const` arrays and an inline lookup), also a model for GLSL/HLSL.
    C,
}

/// The 1-D set of a one-colour `hair-dual` table as arrays for the thesis's App. C shader
/// (Sadeghi 2012): one RGB array per quantity under the App. C names (`a_f`, `a_b`, `alpha_f`,
/// `alpha_b`, `beta_f2`, `beta_b2`, `A_b`, `delta_b`, `sigma_b2`, `N_G_R`, `N_G_TT`, `N_G_TRT`),
/// the angle grid `ds_theta_deg`, the unit-area Gaussian `g(x, variance)` and a linear lookup
/// `ds_lookup(table, angle_rad)` clamped at ±90°. App. C indexes some arrays `[θ_h]` and others
/// `[θ_d]`; the tables are functions of the light inclination θ_i (decision DS-1). Calling
/// `ds_lookup` with the angle App. C names runs its pseudo-code unchanged; calling it with θ_i is
/// the tables' own convention (DS-31). Both are stated in the file's comment.
pub fn dual_shader_tables(
    t: &TableContent,
    language: ShaderLanguage,
) -> Result<String, ConsumerError> {
    use std::fmt::Write as _;
    let j = dual_json(t)?;
    let theta: Vec<f64> = j["theta_deg"]
        .as_array()
        .expect("theta")
        .iter()
        .map(|v| v.as_f64().unwrap_or(f64::NAN))
        .collect();
    let n = theta.len();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "/* Dual Scattering tables (scatterbake, schema hair-dual/1) for the shader of Sadeghi 2012\n \
         * App. C. {n} samples of the light inclination theta_i, -90..90 deg (ds_theta_deg, uniform).\n \
         * App. C indexes a_f, a_b, alpha_*, beta_*2, N_G_* by theta_h and A_b, delta_b, sigma_b2\n \
         * by theta_d: ds_lookup(table, angle_rad) with those angles runs its pseudo-code unchanged;\n \
         * with theta_i it follows the tables' own convention (the quantities are functions of the\n \
         * light inclination). Angles in rad, variances in rad^2, N_G per rad; RGB triples.\n \
         * Model: {} */",
        t.attributes
            .get("model")
            .and_then(|v| v.as_str())
            .unwrap_or("?")
    );
    write_shader_grid(&mut s, &theta, language);
    write_shader_arrays(&mut s, &j, n, language);
    write_shader_lookup(&mut s, &theta, language);
    Ok(s)
}

/// The number list of a shader array initialiser.
fn shader_list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The angle grid `ds_theta_deg` (and, in C, `DS_N` and `<math.h>`).
fn write_shader_grid(s: &mut String, theta: &[f64], language: ShaderLanguage) {
    use std::fmt::Write as _;
    let n = theta.len();
    let list = shader_list;
    match language {
        ShaderLanguage::Rsl => {
            let _ = writeln!(
                s,
                "uniform float ds_theta_deg[{n}] = {{ {} }};",
                list(theta)
            );
        }
        ShaderLanguage::C => {
            let _ = writeln!(s, "#include <math.h>");
            let _ = writeln!(s, "#define DS_N {n}");
            let _ = writeln!(
                s,
                "static const double ds_theta_deg[DS_N] = {{ {} }};",
                list(theta)
            );
        }
    }
}

/// One RGB array per Dual Scattering quantity, from the JSON export `j` with `n` angles.
fn write_shader_arrays(s: &mut String, j: &Value, n: usize, language: ShaderLanguage) {
    use std::fmt::Write as _;
    for name in DUAL_CHANNELS {
        let rows: Vec<[f64; 3]> = (0..n)
            .map(|i| std::array::from_fn(|c| j[name][i][c].as_f64().unwrap_or(f64::NAN)))
            .collect();
        match language {
            ShaderLanguage::Rsl => {
                let body: Vec<String> = rows
                    .iter()
                    .map(|v| format!("color({:e}, {:e}, {:e})", v[0], v[1], v[2]))
                    .collect();
                let _ = writeln!(s, "uniform color {name}[{n}] = {{ {} }};", body.join(", "));
            }
            ShaderLanguage::C => {
                let body: Vec<String> = rows
                    .iter()
                    .map(|v| format!("{{{:e}, {:e}, {:e}}}", v[0], v[1], v[2]))
                    .collect();
                let _ = writeln!(
                    s,
                    "static const double {name}[DS_N][3] = {{ {} }};",
                    body.join(", ")
                );
            }
        }
    }
}

/// The Gaussian `g` and the linear lookup `ds_lookup` on the uniform grid `theta` (deg).
fn write_shader_lookup(s: &mut String, theta: &[f64], language: ShaderLanguage) {
    use std::fmt::Write as _;
    let n = theta.len();
    let (first, step) = (theta[0], (theta[n - 1] - theta[0]) / (n - 1) as f64);
    match language {
        ShaderLanguage::Rsl => {
            let _ = writeln!(
                s,
                "float g(float x; float variance) {{ return exp(-x * x / (2 * variance)) / sqrt(2 * PI * variance); }}\n\
                 color ds_lookup(uniform color tab[]; float angle) {{\n    \
                 float u = clamp((degrees(angle) - ({first:e})) / {step:e}, 0, {last});\n    \
                 float i = min(floor(u), {last_cell});\n    \
                 return mix(tab[i], tab[i + 1], u - i);\n}}",
                last = n - 1,
                last_cell = n - 2
            );
        }
        ShaderLanguage::C => {
            let _ = writeln!(
                s,
                "static inline double g(double x, double variance) {{ return exp(-x * x / (2 * variance)) / sqrt(2 * M_PI * variance); }}\n\
                 /* Channel c (0 = R, 1 = G, 2 = B) of table tab at angle (rad), linear, clamped at +-90 deg. */\n\
                 static inline double ds_lookup(const double tab[DS_N][3], double angle, int c) {{\n    \
                 double u = (angle * 180.0 / M_PI - ({first:e})) / {step:e};\n    \
                 if (u < 0) u = 0;\n    \
                 if (u > DS_N - 1) u = DS_N - 1;\n    \
                 int i = (int)floor(u);\n    \
                 if (i > DS_N - 2) i = DS_N - 2;\n    \
                 double t = u - i;\n    \
                 return (1 - t) * tab[i][c] + t * tab[i + 1][c];\n}}"
            );
        }
    }
}

pub fn content_of(table: Table) -> TableContent {
    TableContent {
        encoding: Default::default(),
        schema: table.header.schema,
        description: table.header.description,
        axes: table.header.axes,
        channels: table.header.channels,
        attributes: table.header.attributes,
        data: table.data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::hair::HairDualJob;
    use crate::stages::hair::HairDualParams;

    fn params(toml_src: &str) -> HairDualParams {
        toml::from_str(toml_src).unwrap()
    }

    #[test]
    fn exr_lut_round_trips_and_matches_table() {
        let job = HairDualJob::new(params(
            "roughness_deg = [4.0, 9.0]\nabsorption_count = 6\ntheta_count = 7",
        ))
        .unwrap();
        let t = crate::stages::run_in_memory(&job).unwrap();
        let layout = dual_lut_layout(&t).unwrap();
        assert_eq!((layout.width, layout.height), (6, 14));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lut.exr");
        write_dual_lut_exr(&layout, &path).unwrap();
        use exr::prelude::*;
        let img = read_all_flat_layers_from_file(&path).unwrap();
        assert_eq!(img.layer_data.len(), 1);
        let chans = &img.layer_data[0].channel_data.list;
        assert_eq!(chans.len(), 12);
        let b = chans
            .iter()
            .find(|c| c.name.to_string() == "ds1.B")
            .unwrap();
        // Texel (x = absorption 3, y = roughness 1, θ index 5) holds Ā_b of that table cell.
        let x = 3;
        let y = 7 + 5;
        let tex = b.sample_data.value_by_flat_index(y * 6 + x).to_f32();
        let cell = ((6 + 3) * 7 + 5) * DUAL_TABLE_CHANNELS + 6;
        assert_eq!(tex, t.data[cell]);
    }
}
