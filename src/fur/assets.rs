//! The shipped compressed medulla tables (`assets/fur-medulla/`): the thesis-grid tables of
//! both families (Tseng 2015 App. A) as tensor trains (`fur-medulla-tt/1`, [`super::tt`]),
//! embedded in the library so that the far field's default lookup needs no build step.
//!
//! [`compress_asset`] turns a dense source table (built by
//! `manifests/full/fur-medulla-assets.toml`) into the asset with the settings of
//! [`AssetSpec::AZIMUTHAL`] / [`AssetSpec::LONGITUDINAL`] and records in the header the
//! reconstruction error next to the source's own error (the solver's discretisation error for
//! deterministic sources, the Monte Carlo standard errors otherwise). Decisions:
//! docs/decisions.md FUR-28 … FUR-31.

use super::FurError;
use super::tt::{channel_index, channel_values, compress_table, compress_table_log};
use crate::table::codec::round_mantissa;
use crate::table::{Header, Provenance, Table, TableContent};
use serde_json::json;

/// The azimuthal asset as committed (`assets/fur-medulla/fur-medulla-azimuthal.sbt`).
pub const AZIMUTHAL_BYTES: &[u8] =
    include_bytes!("../../assets/fur-medulla/fur-medulla-azimuthal.sbt");
/// The longitudinal asset as committed (`assets/fur-medulla/fur-medulla-longitudinal.sbt`).
pub const LONGITUDINAL_BYTES: &[u8] =
    include_bytes!("../../assets/fur-medulla/fur-medulla-longitudinal.sbt");
/// File names of the assets (in `assets/fur-medulla/`), azimuthal then longitudinal.
pub const ASSET_FILES: [&str; 2] = ["fur-medulla-azimuthal.sbt", "fur-medulla-longitudinal.sbt"];

/// Largest size of one asset file (bytes).
pub const MAX_ASSET_BYTES: usize = 150_000;

/// How one family is compressed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssetSpec {
    /// Source schema name.
    pub family: &'static str,
    /// Asset file name in `assets/fur-medulla/`.
    pub file: &'static str,
    /// Dense source table name in the assets manifest.
    pub source_table: &'static str,
    /// Channel compressed (the one the far field reads).
    pub channel: &'static str,
    /// TT-SVD tolerance (relative Frobenius; of the logarithm for the log form).
    pub rel_tol: f64,
    /// Rank cap.
    pub max_rank: usize,
    /// `Some(f)`: compress ln(max(value, f × max)) (`compress_table_log`).
    pub log_floor_rel: Option<f64>,
    /// Scale each azimuthal profile so that its bins sum to the analytic scattered fraction
    /// 1 − exp(−σ·2√(1 − h'²)) before compressing (a ratio estimator: removes the Monte Carlo
    /// noise of each entry's overall level, which the far field discards anyway; FUR-29).
    pub normalise_to_analytic_total: bool,
    /// `Some(b)`: round every stored core value to `b` of the 23 mantissa bits of an f32 (to
    /// nearest), so that the zero low bits compress; the reconstruction error is measured
    /// after the rounding. The file format and the readers are unchanged.
    pub core_mantissa_bits: Option<u32>,
}

impl AssetSpec {
    /// Azimuthal family: the logarithm of `energy` of the deterministic source, each profile
    /// scaled to its analytic total (FUR-29, FUR-32).
    pub const AZIMUTHAL: AssetSpec = AssetSpec {
        family: "fur-medulla-azimuthal",
        file: "fur-medulla-azimuthal.sbt",
        source_table: "fur-medulla-azimuthal-asset",
        channel: "energy",
        rel_tol: 6e-4,
        max_rank: 64,
        log_floor_rel: Some(1e-12),
        normalise_to_analytic_total: true,
        core_mantissa_bits: Some(13),
    };
    /// Longitudinal family: the logarithm of `pdf` (FUR-29).
    pub const LONGITUDINAL: AssetSpec = AssetSpec {
        family: "fur-medulla-longitudinal",
        file: "fur-medulla-longitudinal.sbt",
        source_table: "fur-medulla-longitudinal-asset",
        channel: "pdf",
        rel_tol: 5e-4,
        max_rank: 256,
        log_floor_rel: Some(1e-12),
        normalise_to_analytic_total: false,
        core_mantissa_bits: None,
    };
}

fn quantiles(mut v: Vec<f64>) -> serde_json::Value {
    if v.is_empty() {
        return json!(null);
    }
    v.sort_by(f64::total_cmp);
    let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
    json!({"median": q(0.5), "p90": q(0.9), "p99": q(0.99), "max": q(1.0), "count": v.len()})
}

/// The errors of a reconstruction `approx` of `dense` (values per profile `profile`):
/// relative Frobenius error, per-bin relative errors on bins ≥ 1e-3 of their profile's maximum,
/// and, when `std_error` is given, the error in units of the per-bin standard error.
pub fn reconstruction_errors(
    dense: &[f64],
    approx: &[f64],
    profile: usize,
    std_error: Option<&[f64]>,
) -> serde_json::Value {
    let (mut e2, mut n2) = (0.0f64, 0.0f64);
    let mut rel = Vec::new();
    let mut z = Vec::new();
    for (p, (a, b)) in dense
        .chunks(profile)
        .zip(approx.chunks(profile))
        .enumerate()
    {
        let max = a.iter().cloned().fold(0.0f64, f64::max);
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            e2 += (x - y) * (x - y);
            n2 += x * x;
            if max > 0.0 && *x >= 1e-3 * max {
                rel.push(((x - y) / x).abs());
                if let Some(se) = std_error {
                    let s = se[p * profile + k];
                    if s > 0.0 {
                        z.push(((x - y) / s).abs());
                    }
                }
            }
        }
    }
    let rms_z = if z.is_empty() {
        None
    } else {
        Some((z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt())
    };
    let mut out = json!({
        "rel_frobenius": if n2 > 0.0 { (e2 / n2).sqrt() } else { 0.0 },
        "per_bin_rel_on_bins_above_1e-3_of_profile_max": quantiles(rel),
    });
    if let Some(r) = rms_z {
        out["per_bin_in_std_errors"] = quantiles(z);
        out["rms_in_std_errors"] = r.into();
    }
    out
}

/// Scale every azimuthal profile (last axis) to the analytic scattered fraction.
fn normalise_azimuthal(t: &mut TableContent, channel: &str) -> Result<(), FurError> {
    let nc = t.channels.len();
    let ci = channel_index(t, channel)?;
    let sig = t.axes[0].coords();
    let ng = t.axes[1].len();
    let hs = t.axes[2].coords();
    let bins = t.axes[3].len();
    for (e, row) in t.data.chunks_mut(bins * nc).enumerate() {
        let sigma = sig[e / (ng * hs.len())];
        let h = hs[e % hs.len()];
        let want = 1.0 - (-sigma * 2.0 * (1.0 - h * h).max(0.0).sqrt()).exp();
        let have: f64 = row.iter().skip(ci).step_by(nc).map(|&v| f64::from(v)).sum();
        if have > 0.0 && want > 0.0 {
            let f = want / have;
            for v in row.iter_mut().skip(ci).step_by(nc) {
                *v = (f64::from(*v) * f) as f32;
            }
        }
    }
    Ok(())
}

/// The manifest that builds the dense source tables of the assets.
const SOURCE_MANIFEST: &str = "manifests/full/fur-medulla-assets.toml";

/// Compress the dense source table of one family into its asset (a sealed-ready table with
/// provenance; write it with [`Table::to_bytes`]). The header records the source's content key
/// and errors, the compression settings and the measured reconstruction errors.
pub fn compress_asset(source: &Table, spec: &AssetSpec) -> Result<Table, FurError> {
    let h = &source.header;
    if h.schema.name != spec.family {
        return Err(FurError::WrongSchema {
            expected: spec.family,
            found: h.schema.name.clone(),
        });
    }
    // The source as built, and the values compressed (normalised when the spec says so).
    let raw = TableContent {
        encoding: Default::default(),
        schema: h.schema.clone(),
        description: h.description.clone(),
        axes: h.axes.clone(),
        channels: h.channels.clone(),
        attributes: h.attributes.clone(),
        data: source.data.clone(),
    };
    let mut content = raw.clone();
    if spec.normalise_to_analytic_total {
        normalise_azimuthal(&mut content, spec.channel)?;
    }
    let mut tt = compress_channel(&content, spec)?;
    let raw_dense = channel_values(&raw, spec.channel)?;
    let std_error = source_std_error(&content, h, spec)?;
    let recon = asset_errors(&raw_dense, &content, &tt, spec, std_error.as_deref())?;
    let source_error = match &std_error {
        Some(se) => monte_carlo_error(h, se, &raw_dense),
        None => solver_error(h),
    };
    record_source(&mut tt.attributes, h, spec, recon, source_error);
    let parameters = asset_parameters(h, spec);
    Table::from_content(tt, asset_provenance(h, spec, parameters))
        .map_err(|e| FurError::TensorTrain(e.to_string()))
}

/// The tensor train of channel `spec.channel` of `content` (of its logarithm when the spec
/// says so), its cores rounded to `spec.core_mantissa_bits`.
fn compress_channel(content: &TableContent, spec: &AssetSpec) -> Result<TableContent, FurError> {
    let (mut tt, _) = match spec.log_floor_rel {
        Some(f) => compress_table_log(content, spec.channel, spec.rel_tol, spec.max_rank, f)?,
        None => compress_table(content, spec.channel, spec.rel_tol, spec.max_rank)?,
    };
    if let Some(bits) = spec.core_mantissa_bits {
        for v in &mut tt.data {
            *v = round_mantissa(*v, bits);
        }
    }
    Ok(tt)
}

/// The per-bin standard errors of an azimuthal Monte Carlo source (channel `std_error`), or
/// `None`: deterministic sources (adding-doubling, characteristics) carry a discretisation
/// error in the attribute `solver_error` instead.
fn source_std_error(
    content: &TableContent,
    h: &Header,
    spec: &AssetSpec,
) -> Result<Option<Vec<f64>>, FurError> {
    let deterministic = h.attributes.contains_key("solver_error");
    if spec.family == "fur-medulla-azimuthal" && !deterministic {
        channel_values(content, "std_error").map(Some)
    } else {
        Ok(None)
    }
}

/// The reconstruction errors of the tensor train `tt` against the source as built
/// (`raw_dense`), and for a normalised source also of the tensor train alone (against the
/// normalised `content`) and of the normalisation alone.
fn asset_errors(
    raw_dense: &[f64],
    content: &TableContent,
    tt: &TableContent,
    spec: &AssetSpec,
    std_error: Option<&[f64]>,
) -> Result<serde_json::Value, FurError> {
    let back = super::tt::reconstruct_table(tt)?;
    let approx: Vec<f64> = back.data.iter().map(|&v| f64::from(v)).collect();
    let bins = content.axes.last().map_or(1, |a| a.len());
    // A longitudinal profile holds both halves of the last axis.
    let profile = if spec.family == "fur-medulla-longitudinal" {
        2 * bins
    } else {
        bins
    };
    let mut recon = reconstruction_errors(raw_dense, &approx, profile, std_error);
    if spec.normalise_to_analytic_total {
        let dense = channel_values(content, spec.channel)?;
        recon["tensor_train_only"] = reconstruction_errors(&dense, &approx, profile, None);
        recon["normalisation_only"] = reconstruction_errors(raw_dense, &dense, profile, std_error);
    }
    Ok(recon)
}

/// The error of a Monte Carlo source: its standard errors `se` relative to its values.
fn monte_carlo_error(h: &Header, se: &[f64], raw_dense: &[f64]) -> serde_json::Value {
    let (mut s2, mut n2) = (0.0f64, 0.0f64);
    for (s, v) in se.iter().zip(raw_dense) {
        s2 += s * s;
        n2 += v * v;
    }
    let worst = h
        .attributes
        .get("worst_rel_std_error")
        .and_then(|v| v.as_array())
        .map(|arr| {
            quantiles(
                arr.iter()
                    .filter_map(|x| x.as_f64())
                    .filter(|x| *x > 0.0)
                    .collect(),
            )
        })
        .unwrap_or(json!(null));
    json!({
        "kind": "Monte Carlo standard error of the source table (channel std_error)",
        "rel_frobenius": if n2 > 0.0 { (s2 / n2).sqrt() } else { 0.0 },
        "per_entry_worst_rel_std_error": worst,
    })
}

/// The error of a deterministic source: its solver's discretisation error, as its header
/// states it.
fn solver_error(h: &Header) -> serde_json::Value {
    let method = h
        .attributes
        .get("method")
        .and_then(|m| m.as_str())
        .unwrap_or("deterministic");
    let median = h.attributes.get("solver_error_median");
    let mut e = json!({
        "kind": format!(
            "discretisation error of the {method} solver (source header solver_error{}); no sampling noise",
            if median.is_some() { ", solver_error_median" } else { "" }
        ),
        "solver_error": h.attributes.get("solver_error").cloned().unwrap_or(json!(null)),
    });
    if let Some(m) = median {
        e["solver_error_median"] = m.clone();
    }
    e
}

/// Record in the asset's attributes `a` where it comes from: the source's attributes (each
/// per-entry array summarised by its quantiles, not copied: size), key, manifest and entry,
/// the source's error and the asset's reconstruction error.
fn record_source(
    a: &mut serde_json::Map<String, serde_json::Value>,
    h: &Header,
    spec: &AssetSpec,
    recon: serde_json::Value,
    source_error: serde_json::Value,
) {
    let mut src_attrs = h.attributes.clone();
    let mut summaries = serde_json::Map::new();
    src_attrs.retain(|k, v| match v.as_array() {
        Some(arr) => {
            let vals: Vec<f64> = arr.iter().filter_map(|x| x.as_f64()).collect();
            summaries.insert(k.clone(), quantiles(vals));
            false
        }
        None => true,
    });
    src_attrs.insert(
        "per_entry_arrays_summary".into(),
        serde_json::Value::Object(summaries),
    );
    a.insert(
        "source_attributes".into(),
        serde_json::Value::Object(src_attrs),
    );
    a.insert("reconstruction_error".into(), recon);
    if spec.normalise_to_analytic_total {
        a.insert("value_normalisation".into(), "each profile (sigma, g, h') of the source channel was scaled so that its bins sum to the analytic scattered fraction 1 - exp(-sigma 2 sqrt(1 - h'^2)) before compression (ratio estimator; removes the error of the profile's overall level: Monte Carlo noise or the solver's energy-identity deviation); reconstruction_error is against the source as built, tensor_train_only against the scaled values".into());
    }
    a.insert("source_error".into(), source_error);
    a.insert(
        "source_parameters_digest".into(),
        h.provenance.parameters_digest.clone().into(),
    );
    a.insert("source_manifest".into(), SOURCE_MANIFEST.into());
    a.insert("source_entry".into(), spec.source_table.into());
}

/// The asset's parameters: its source's key and parameters and the compression settings.
fn asset_parameters(h: &Header, spec: &AssetSpec) -> serde_json::Value {
    let mut parameters = json!({
        "source_parameters_digest": h.provenance.parameters_digest,
        "source_parameters": h.provenance.parameters,
        "channel": spec.channel,
        "rel_tol": spec.rel_tol,
        "max_rank": spec.max_rank,
        "log_floor_rel": spec.log_floor_rel,
        "normalise_to_analytic_total": spec.normalise_to_analytic_total,
    });
    if let Some(b) = spec.core_mantissa_bits {
        parameters["core_mantissa_bits"] = b.into();
    }
    parameters
}

/// The asset's provenance: stage `fur-medulla-tt@1`, keyed by its parameters like any table,
/// created when its source was.
fn asset_provenance(h: &Header, spec: &AssetSpec, parameters: serde_json::Value) -> Provenance {
    Provenance {
        tool: crate::provenance::TOOL.into(),
        tool_version: crate::provenance::TOOL_VERSION.into(),
        // No commit: the asset's bytes depend on its inputs only (reproducible).
        git_commit: None,
        manifest: Some(SOURCE_MANIFEST.into()),
        entry: Some(spec.file.trim_end_matches(".sbt").into()),
        stage: Some("fur-medulla-tt@1".into()),
        parameters_digest: crate::provenance::content_key("fur-medulla-tt", 1, &parameters),
        parameters,
        created_utc: h.provenance.created_utc.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Axis, Channel, Schema};

    /// A small dense source table of `family` (σ × g × h' × bins) with a smooth positive
    /// channel `spec.channel`, a `std_error` channel, and the given header attributes.
    fn source(spec: &AssetSpec, attributes: serde_json::Map<String, serde_json::Value>) -> Table {
        let (ns, ng, nh, nb) = (3, 2, 4, 12);
        let mut data = Vec::new();
        for s in 0..ns {
            for g in 0..ng {
                for h in 0..nh {
                    for b in 0..nb {
                        let x = b as f64 / nb as f64;
                        let v = (0.2 + s as f64) * (-(x - 0.3 * g as f64).powi(2) * 6.0).exp()
                            / (1.0 + 0.5 * h as f64);
                        data.extend([v as f32, (0.01 * v) as f32]);
                    }
                }
            }
        }
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new(spec.family, 1),
            description: "synthetic source".into(),
            axes: vec![
                Axis::values("sigma", "1", vec![0.5, 1.0, 2.0]),
                Axis::uniform("g", "1", 0.0, 0.5, ng),
                Axis::uniform("h", "1", 0.0, 0.25, nh),
                Axis::uniform("bin", "1", 0.0, 1.0, nb),
            ],
            channels: vec![
                Channel::new(spec.channel, "1", "synthetic"),
                Channel::new("std_error", "1", "synthetic"),
            ],
            attributes,
            data,
        };
        let provenance = Provenance {
            parameters: json!({"grid": "synthetic"}),
            parameters_digest: "ab".repeat(32),
            created_utc: "2024-01-01T00:00:00Z".into(),
            ..Default::default()
        };
        Table::from_content(content, provenance).unwrap()
    }

    fn monte_carlo_attributes() -> serde_json::Map<String, serde_json::Value> {
        let mut a = serde_json::Map::new();
        a.insert("worst_rel_std_error".into(), json!([0.01, 0.02, 0.0, 0.05]));
        a.insert("method".into(), "monte carlo".into());
        a
    }

    fn solver_attributes() -> serde_json::Map<String, serde_json::Value> {
        let mut a = serde_json::Map::new();
        a.insert("solver_error".into(), json!(2e-3));
        a.insert("solver_error_median".into(), json!(1e-4));
        a.insert("method".into(), "characteristics".into());
        a
    }

    #[test]
    fn asset_of_another_family_is_refused() {
        let t = source(&AssetSpec::LONGITUDINAL, solver_attributes());
        let e = compress_asset(&t, &AssetSpec::AZIMUTHAL).unwrap_err();
        assert!(matches!(e, FurError::WrongSchema { .. }), "{e}");
    }

    /// The asset records the source's key and errors, the settings, its own reconstruction
    /// error, and is keyed by its parameters like any table.
    #[test]
    fn asset_header_states_source_settings_and_errors() {
        for (spec, attributes) in [
            (AssetSpec::AZIMUTHAL, monte_carlo_attributes()),
            (AssetSpec::AZIMUTHAL, solver_attributes()),
            (AssetSpec::LONGITUDINAL, solver_attributes()),
        ] {
            let src = source(&spec, attributes);
            let asset = compress_asset(&src, &spec).unwrap();
            let h = &asset.header;
            assert_eq!(h.schema.name, "fur-medulla-tt");
            let p = &h.provenance;
            assert_eq!(
                p.parameters_digest,
                crate::provenance::content_key("fur-medulla-tt", 1, &p.parameters)
            );
            assert_eq!(p.parameters["source_parameters_digest"], "ab".repeat(32));
            assert_eq!(p.created_utc, "2024-01-01T00:00:00Z");
            assert_eq!(p.git_commit, None);
            let a = &h.attributes;
            assert_eq!(a["source_entry"], spec.source_table);
            // A normalised source differs from the values compressed: the tensor train's own
            // error is the one bounded by its tolerance.
            let recon = &a["reconstruction_error"];
            let tt_error = if spec.normalise_to_analytic_total {
                &recon["tensor_train_only"]
            } else {
                recon
            };
            let frob = tt_error["rel_frobenius"].as_f64().unwrap();
            assert!(frob < 0.05, "{}: {frob}", spec.family);
            let summary = &a["source_attributes"]["per_entry_arrays_summary"];
            let deterministic = src.header.attributes.contains_key("solver_error");
            if deterministic {
                assert_eq!(a["source_error"]["solver_error"], 2e-3);
                assert_eq!(a["source_error"]["solver_error_median"], 1e-4);
            } else {
                assert_eq!(summary["worst_rel_std_error"]["count"], 4);
                let se = &a["source_error"];
                assert_eq!(se["per_entry_worst_rel_std_error"]["count"], 3);
                assert!((se["rel_frobenius"].as_f64().unwrap() - 0.01).abs() < 1e-6);
                assert!(a["reconstruction_error"]["rms_in_std_errors"].is_number());
            }
            let normalised = spec.normalise_to_analytic_total;
            assert_eq!(a.contains_key("value_normalisation"), normalised);
            assert_eq!(
                a["reconstruction_error"].get("tensor_train_only").is_some(),
                normalised
            );
        }
    }
}
