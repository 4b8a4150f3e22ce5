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

pub fn content_of(table: Table) -> TableContent {
    TableContent {
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
