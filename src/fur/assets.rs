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
use crate::table::{Provenance, Table, TableContent};
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

/// `v` rounded to nearest with `bits` (≤ 23) mantissa bits kept (ties away from zero in the
/// magnitude); finite values stay finite.
fn round_mantissa(v: f32, bits: u32) -> f32 {
    if bits >= 23 || !v.is_finite() {
        return v;
    }
    let drop = 23 - bits;
    let b = v.to_bits();
    let rounded = (b + (1 << (drop - 1))) & !((1u32 << drop) - 1);
    let r = f32::from_bits(rounded);
    if r.is_finite() { r } else { v }
}

/// The source header's attributes with each per-entry array replaced by its quantiles (under
/// `per_entry_arrays_summary`), so that the asset's header stays small.
fn summarised_attributes(
    attributes: &serde_json::Map<String, serde_json::Value>,
) -> serde_json::Map<String, serde_json::Value> {
    let mut src_attrs = attributes.clone();
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
    src_attrs
}

/// The error of the source table, from its header `attributes`: Monte Carlo sources carry
/// standard errors (`std_error`, summarised against the source values `raw_dense`);
/// deterministic ones a discretisation error in `solver_error`.
fn source_error(
    attributes: &serde_json::Map<String, serde_json::Value>,
    std_error: Option<&[f64]>,
    raw_dense: &[f64],
) -> serde_json::Value {
    match std_error {
        Some(se) => {
            let (mut s2, mut n2) = (0.0f64, 0.0f64);
            for (s, v) in se.iter().zip(raw_dense) {
                s2 += s * s;
                n2 += v * v;
            }
            json!({
                "kind": "Monte Carlo standard error of the source table (channel std_error)",
                "rel_frobenius": if n2 > 0.0 { (s2 / n2).sqrt() } else { 0.0 },
                "per_entry_worst_rel_std_error": attributes.get("worst_rel_std_error")
                    .and_then(|v| v.as_array())
                    .map(|arr| quantiles(arr.iter().filter_map(|x| x.as_f64()).filter(|x| *x > 0.0).collect()))
                    .unwrap_or(json!(null)),
            })
        }
        None => {
            let method = attributes
                .get("method")
                .and_then(|m| m.as_str())
                .unwrap_or("deterministic");
            let median = attributes.get("solver_error_median");
            let mut e = json!({
                "kind": format!(
                    "discretisation error of the {method} solver (source header solver_error{}); no sampling noise",
                    if median.is_some() { ", solver_error_median" } else { "" }
                ),
                "solver_error": attributes.get("solver_error").cloned().unwrap_or(json!(null)),
            });
            if let Some(m) = median {
                e["solver_error_median"] = m.clone();
            }
            e
        }
    }
}

/// The errors recorded in the header of the asset `tt`, compressed from `content` (the source
/// table `source` after any normalisation): the reconstruction errors against the source as
/// built (with the normalisation, also of each step alone) and the source's own error.
fn asset_errors(
    source: &Table,
    content: &TableContent,
    tt: &TableContent,
    spec: &AssetSpec,
) -> Result<(serde_json::Value, serde_json::Value), FurError> {
    let h = &source.header;
    let dense = channel_values(content, spec.channel)?;
    // The source as built (before any normalisation): the asset's error against it.
    let raw = TableContent {
        data: source.data.clone(),
        ..content.clone()
    };
    let raw_dense = channel_values(&raw, spec.channel)?;
    let back = super::tt::reconstruct_table(tt)?;
    let approx: Vec<f64> = back.data.iter().map(|&v| f64::from(v)).collect();
    let profile = if spec.family == "fur-medulla-longitudinal" {
        2 * h.axes.last().map_or(1, |a| a.len())
    } else {
        h.axes.last().map_or(1, |a| a.len())
    };
    // Monte Carlo sources carry standard errors; deterministic ones (adding-doubling,
    // characteristics) a discretisation error in `solver_error`.
    let deterministic = h.attributes.contains_key("solver_error");
    let std_error = if spec.family == "fur-medulla-azimuthal" && !deterministic {
        Some(channel_values(content, "std_error")?)
    } else {
        None
    };
    let mut recon = reconstruction_errors(&raw_dense, &approx, profile, std_error.as_deref());
    if spec.normalise_to_analytic_total {
        recon["tensor_train_only"] = reconstruction_errors(&dense, &approx, profile, None);
        recon["normalisation_only"] =
            reconstruction_errors(&raw_dense, &dense, profile, std_error.as_deref());
    }
    let source_err = source_error(&h.attributes, std_error.as_deref(), &raw_dense);
    Ok((recon, source_err))
}

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
    let mut content = TableContent {
        schema: h.schema.clone(),
        description: h.description.clone(),
        axes: h.axes.clone(),
        channels: h.channels.clone(),
        attributes: h.attributes.clone(),
        data: source.data.clone(),
    };
    if spec.normalise_to_analytic_total {
        normalise_azimuthal(&mut content, spec.channel)?;
    }
    let (mut tt, _) = match spec.log_floor_rel {
        Some(f) => compress_table_log(&content, spec.channel, spec.rel_tol, spec.max_rank, f)?,
        None => compress_table(&content, spec.channel, spec.rel_tol, spec.max_rank)?,
    };
    if let Some(bits) = spec.core_mantissa_bits {
        for v in &mut tt.data {
            *v = round_mantissa(*v, bits);
        }
    }
    let (recon, source_err) = asset_errors(source, &content, &tt, spec)?;
    let a = &mut tt.attributes;
    a.insert(
        "source_attributes".into(),
        serde_json::Value::Object(summarised_attributes(&h.attributes)),
    );
    a.insert("reconstruction_error".into(), recon);
    if spec.normalise_to_analytic_total {
        a.insert("value_normalisation".into(), "each profile (sigma, g, h') of the source channel was scaled so that its bins sum to the analytic scattered fraction 1 - exp(-sigma 2 sqrt(1 - h'^2)) before compression (ratio estimator; removes the error of the profile's overall level: Monte Carlo noise or the solver's energy-identity deviation); reconstruction_error is against the source as built, tensor_train_only against the scaled values".into());
    }
    a.insert("source_error".into(), source_err);
    a.insert(
        "source_parameters_digest".into(),
        h.provenance.parameters_digest.clone().into(),
    );
    a.insert(
        "source_manifest".into(),
        "manifests/full/fur-medulla-assets.toml".into(),
    );
    a.insert("source_entry".into(), spec.source_table.into());
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
    let digest = {
        use sha2::{Digest, Sha256};
        hex::encode(Sha256::digest(
            crate::pipeline::canonical_json(&json!({
                "stage": "fur-medulla-tt",
                "algorithm_version": 1,
                "parameters": parameters,
            }))
            .as_bytes(),
        ))
    };
    let provenance = Provenance {
        tool: "scatterbake".into(),
        tool_version: env!("CARGO_PKG_VERSION").into(),
        // No commit: the asset's bytes depend on its inputs only (reproducible).
        git_commit: None,
        manifest: Some("manifests/full/fur-medulla-assets.toml".into()),
        entry: Some(spec.file.trim_end_matches(".sbt").into()),
        stage: Some("fur-medulla-tt@1".into()),
        parameters,
        parameters_digest: digest,
        created_utc: h.provenance.created_utc.clone(),
    };
    Table::from_content(tt, provenance).map_err(|e| FurError::TensorTrain(e.to_string()))
}
