//! Low-rank shipping form of a medulla table channel: a tensor train (TT-SVD, Oseledets 2011).
//!
//! A d-way tensor A[i₁,…,i_d] is stored as cores G_k of shape r_{k−1} × n_k × r_k (r₀ = r_d = 1)
//! with A[i₁,…,i_d] ≈ G₁[:, i₁, :] · G₂[:, i₂, :] ⋯ G_d[:, i_d, :]. The cores come from d − 1
//! truncated SVDs of successive unfoldings; each truncation drops at most
//! `rel_tol/√(d−1)·‖A‖_F`, so the relative Frobenius error is ≤ `rel_tol` (plus the f32 rounding of
//! stored cores). Ranks may also be capped by `max_rank`, in which case the bound no longer
//! holds and the achieved error (always measured, see [`CompressionReport`]) is what counts.
//!
//! SVDs are computed from the Gram matrix of the smaller side of each unfolding (nalgebra's
//! symmetric eigensolver), which loses accuracy only for singular values below ~1e-7 of the
//! largest, far below any useful tolerance here.
//!
//! [`compress_table`] turns one channel of a dense table into a `fur-medulla-tt/1` table (one
//! axis `value` holding all cores, self-described in the attributes) and [`reconstruct_table`]
//! reverses it on load.

use super::FurError;
use crate::table::{Axis, Channel, Schema, TableContent};
use nalgebra::{DMatrix, SymmetricEigen};

/// A tensor train.
#[derive(Debug, Clone, PartialEq)]
pub struct TensorTrain {
    /// Mode sizes n_k.
    pub dims: Vec<usize>,
    /// TT ranks r₀..r_d (r₀ = r_d = 1).
    pub ranks: Vec<usize>,
    /// Cores, each row-major r_{k−1} × n_k × r_k.
    pub cores: Vec<Vec<f64>>,
}

impl TensorTrain {
    /// Number of stored values.
    pub fn parameter_count(&self) -> usize {
        self.cores.iter().map(Vec::len).sum()
    }

    /// Dense reconstruction, row-major over `dims`.
    pub fn reconstruct(&self) -> Vec<f64> {
        // Left-to-right contraction: M has shape (n₁⋯n_k) × r_k.
        let mut m = vec![1.0];
        let mut rows = 1usize;
        for (k, core) in self.cores.iter().enumerate() {
            let (r0, n, r1) = (self.ranks[k], self.dims[k], self.ranks[k + 1]);
            let mut next = vec![0.0; rows * n * r1];
            for row in 0..rows {
                for a in 0..r0 {
                    let v = m[row * r0 + a];
                    if v == 0.0 {
                        continue;
                    }
                    for i in 0..n {
                        let src = &core[(a * n + i) * r1..(a * n + i + 1) * r1];
                        let dst = &mut next[(row * n + i) * r1..(row * n + i + 1) * r1];
                        for (d, s) in dst.iter_mut().zip(src) {
                            *d += v * s;
                        }
                    }
                }
            }
            m = next;
            rows *= n;
        }
        m
    }

    /// One entry.
    pub fn get(&self, idx: &[usize]) -> f64 {
        let mut v = vec![1.0];
        for (k, core) in self.cores.iter().enumerate() {
            let (r0, n, r1) = (self.ranks[k], self.dims[k], self.ranks[k + 1]);
            let mut next = vec![0.0; r1];
            for (a, &va) in v.iter().enumerate().take(r0) {
                let s = &core[(a * n + idx[k]) * r1..(a * n + idx[k] + 1) * r1];
                for (d, x) in next.iter_mut().zip(s) {
                    *d += va * x;
                }
            }
            v = next;
        }
        v[0]
    }
}

/// TT-SVD of a row-major tensor.
pub fn tt_svd(data: &[f64], dims: &[usize], rel_tol: f64, max_rank: usize) -> TensorTrain {
    let d = dims.len();
    assert_eq!(data.len(), dims.iter().product::<usize>());
    let norm2: f64 = data.iter().map(|x| x * x).sum();
    let delta2 = if d > 1 {
        rel_tol * rel_tol * norm2 / (d - 1) as f64
    } else {
        0.0
    };
    let mut ranks = vec![1usize];
    let mut cores = Vec::new();
    // Current remainder C, shape (r·n_k) × rest, row-major.
    let mut c = data.to_vec();
    let mut r = 1usize;
    for &n_k in &dims[..d - 1] {
        let m = r * n_k;
        let ncols = c.len() / m;
        // Row-major m × ncols is column-major ncols × m: A = Cᵀ in nalgebra's storage.
        let a = DMatrix::from_column_slice(ncols, m, &c);
        let (u, rest, rk) = if m <= ncols {
            // Gram of rows: C Cᵀ = Aᵀ A (m × m).
            // U: m × rk (orthonormal columns); rest = Uᵀ C (rk × ncols).
            let (u, rk) = leading_eigenvectors(a.transpose() * &a, delta2, max_rank);
            let rest = a * &u; // ncols × rk = (Uᵀ C)ᵀ
            (u, rest, rk)
        } else {
            // Gram of columns: Cᵀ C = A Aᵀ (ncols × ncols).
            let (v, rk) = leading_eigenvectors(&a * a.transpose(), delta2, max_rank);
            // C ≈ (C V) Vᵀ: core = C V (m × rk), rest = Vᵀ (rk × ncols).
            let u = a.transpose() * &v;
            (u, v, rk)
        };
        // Core k: r × n_k × rk row-major = U (m × rk) row-major.
        let mut core = vec![0.0; m * rk];
        for i in 0..m {
            for j in 0..rk {
                core[i * rk + j] = u[(i, j)];
            }
        }
        cores.push(core);
        ranks.push(rk);
        // Remainder rk × ncols row-major from `rest` (ncols × rk, i.e. its transpose).
        let mut next = vec![0.0; rk * ncols];
        for j in 0..rk {
            for col in 0..ncols {
                next[j * ncols + col] = rest[(col, j)];
            }
        }
        c = next;
        r = rk;
    }
    cores.push(c);
    ranks.push(1);
    TensorTrain {
        dims: dims.to_vec(),
        ranks,
        cores,
    }
}

/// Eigenvectors of the symmetric Gram matrix `g` for its largest eigenvalues, as columns, with
/// the rank chosen by [`choose_rank`] (truncation error δ², at most `max_rank`).
fn leading_eigenvectors(g: DMatrix<f64>, delta2: f64, max_rank: usize) -> (DMatrix<f64>, usize) {
    let n = g.nrows();
    let eig = SymmetricEigen::new(g);
    let order = sorted_desc(eig.eigenvalues.as_slice());
    let desc: Vec<f64> = order.iter().map(|&i| eig.eigenvalues[i]).collect();
    let rk = choose_rank(&desc, delta2, max_rank);
    let mut vecs = DMatrix::zeros(n, rk);
    for (j, &i) in order.iter().take(rk).enumerate() {
        vecs.set_column(j, &eig.eigenvectors.column(i));
    }
    (vecs, rk)
}

fn sorted_desc(v: &[f64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[b].total_cmp(&v[a]));
    idx
}

/// Smallest rank whose discarded eigenvalue (σ²) tail is ≤ `delta2`, at least 1.
fn choose_rank(eig_desc: &[f64], delta2: f64, max_rank: usize) -> usize {
    let mut tail: f64 = eig_desc.iter().map(|x| x.max(0.0)).sum();
    let mut r = 0;
    while r < eig_desc.len() && tail > delta2 {
        tail -= eig_desc[r].max(0.0);
        r += 1;
    }
    r.clamp(1, max_rank.max(1))
}

/// Reconstruction accuracy of a compressed table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompressionReport {
    /// ‖A − Ã‖_F / ‖A‖_F.
    pub rel_frobenius_error: f64,
    /// max |A − Ã|.
    pub max_abs_error: f64,
    /// max |A − Ã| / max |A|.
    pub max_abs_error_rel_to_max: f64,
    /// Stored values (cores) and dense values.
    pub parameters: usize,
    pub dense_values: usize,
}

/// Encode a header attribute of a `fur-medulla-tt/1` table.
fn to_json<T: serde::Serialize>(
    key: &'static str,
    value: &T,
) -> Result<serde_json::Value, FurError> {
    serde_json::to_value(value).map_err(|source| FurError::TensorTrainAttribute { key, source })
}

/// Decode a header attribute of a `fur-medulla-tt/1` table.
fn from_json<T: serde::de::DeserializeOwned>(
    key: &'static str,
    value: &serde_json::Value,
) -> Result<T, FurError> {
    T::deserialize(value).map_err(|source| FurError::TensorTrainAttribute { key, source })
}

/// Compress channel `channel` of `table` into a `fur-medulla-tt/1` table (cores stored as f32;
/// the reported errors are those of the f32 cores as stored).
pub fn compress_table(
    table: &TableContent,
    channel: &str,
    rel_tol: f64,
    max_rank: usize,
) -> Result<(TableContent, CompressionReport), FurError> {
    let nc = table.channels.len();
    let ci = table
        .channels
        .iter()
        .position(|c| c.name == channel)
        .ok_or_else(|| FurError::NoChannel(channel.to_string()))?;
    let dims: Vec<usize> = table.axes.iter().map(Axis::len).collect();
    let dense: Vec<f64> = table
        .data
        .iter()
        .skip(ci)
        .step_by(nc)
        .map(|&v| v as f64)
        .collect();
    let mut tt = tt_svd(&dense, &dims, rel_tol, max_rank);
    for core in &mut tt.cores {
        for v in core.iter_mut() {
            *v = *v as f32 as f64;
        }
    }
    let approx = tt.reconstruct();
    let report = error_report(&dense, &approx, tt.parameter_count());
    let mut offsets = vec![0usize];
    let mut data = Vec::with_capacity(tt.parameter_count());
    for core in &tt.cores {
        data.extend(core.iter().map(|&v| v as f32));
        offsets.push(data.len());
    }
    let mut a = serde_json::Map::new();
    a.insert("codec".into(), "tensor-train (TT-SVD, Oseledets 2011): A[i1..id] = G1[:,i1,:] G2[:,i2,:] ... Gd[:,id,:], core k row-major r_{k-1} x n_k x r_k, cores concatenated in the `value` axis at core_offsets".into());
    a.insert("source_schema".into(), table.schema.to_string().into());
    a.insert(
        "source_description".into(),
        table.description.clone().into(),
    );
    a.insert("source_axes".into(), to_json("source_axes", &table.axes)?);
    a.insert(
        "source_channel".into(),
        to_json("source_channel", &table.channels[ci])?,
    );
    a.insert(
        "source_attributes".into(),
        serde_json::Value::Object(table.attributes.clone()),
    );
    a.insert("dims".into(), to_json("dims", &tt.dims)?);
    a.insert("ranks".into(), to_json("ranks", &tt.ranks)?);
    a.insert("core_offsets".into(), to_json("core_offsets", &offsets)?);
    a.insert("rel_tol".into(), rel_tol.into());
    a.insert("max_rank".into(), max_rank.into());
    a.insert(
        "rel_frobenius_error".into(),
        report.rel_frobenius_error.into(),
    );
    a.insert("max_abs_error".into(), report.max_abs_error.into());
    a.insert(
        "max_abs_error_rel_to_max".into(),
        report.max_abs_error_rel_to_max.into(),
    );
    let n = data.len();
    Ok((
        TableContent {
            schema: Schema::new("fur-medulla-tt", 1),
            description: format!(
                "tensor-train compressed channel `{channel}` of {}",
                table.schema
            ),
            axes: vec![Axis::uniform("value", "1", 0.0, 1.0, n)],
            channels: vec![Channel::new(
                "core_value",
                "1",
                "TT core entries (see attributes)",
            )],
            attributes: a,
            data,
        },
        report,
    ))
}

fn error_report(dense: &[f64], approx: &[f64], parameters: usize) -> CompressionReport {
    let (mut e2, mut n2, mut emax, mut amax) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (a, b) in dense.iter().zip(approx) {
        e2 += (a - b) * (a - b);
        n2 += a * a;
        emax = emax.max((a - b).abs());
        amax = amax.max(a.abs());
    }
    CompressionReport {
        rel_frobenius_error: if n2 > 0.0 { (e2 / n2).sqrt() } else { 0.0 },
        max_abs_error: emax,
        max_abs_error_rel_to_max: if amax > 0.0 { emax / amax } else { 0.0 },
        parameters,
        dense_values: dense.len(),
    }
}

/// Rebuild the dense single-channel table from a `fur-medulla-tt/1` table.
pub fn reconstruct_table(tt_table: &TableContent) -> Result<TableContent, FurError> {
    if tt_table.schema.name != "fur-medulla-tt" {
        return Err(FurError::WrongSchema {
            expected: "fur-medulla-tt",
            found: tt_table.schema.name.clone(),
        });
    }
    let at = &tt_table.attributes;
    let get = |k: &'static str| {
        at.get(k)
            .ok_or_else(|| FurError::TensorTrain(format!("missing attribute `{k}`")))
    };
    let dims: Vec<usize> = from_json("dims", get("dims")?)?;
    let ranks: Vec<usize> = from_json("ranks", get("ranks")?)?;
    let offsets: Vec<usize> = from_json("core_offsets", get("core_offsets")?)?;
    if ranks.len() != dims.len() + 1 || offsets.len() != dims.len() + 1 {
        return Err(FurError::TensorTrain(format!(
            "inconsistent header: {} dims, {} ranks, {} core offsets",
            dims.len(),
            ranks.len(),
            offsets.len()
        )));
    }
    let mut cores = Vec::new();
    for k in 0..dims.len() {
        if offsets[k + 1] - offsets[k] != ranks[k] * dims[k] * ranks[k + 1] {
            return Err(FurError::TensorTrain(format!("core {k} size mismatch")));
        }
        cores.push(
            tt_table.data[offsets[k]..offsets[k + 1]]
                .iter()
                .map(|&v| v as f64)
                .collect(),
        );
    }
    let tt = TensorTrain { dims, ranks, cores };
    let axes: Vec<Axis> = from_json("source_axes", get("source_axes")?)?;
    let channel: Channel = from_json("source_channel", get("source_channel")?)?;
    let schema_str = get("source_schema")?
        .as_str()
        .unwrap_or_default()
        .to_string();
    let (name, ver) = schema_str
        .rsplit_once('/')
        .unwrap_or((schema_str.as_str(), "1"));
    let mut attributes = match get("source_attributes")? {
        serde_json::Value::Object(m) => m.clone(),
        _ => serde_json::Map::new(),
    };
    for k in [
        "rel_frobenius_error",
        "max_abs_error",
        "max_abs_error_rel_to_max",
        "ranks",
    ] {
        attributes.insert(format!("tt_{k}"), get(k)?.clone());
    }
    Ok(TableContent {
        schema: Schema::new(name, ver.parse().unwrap_or(1)),
        description: format!(
            "{} (reconstructed from tensor train)",
            get("source_description")?.as_str().unwrap_or("")
        ),
        axes,
        channels: vec![channel],
        attributes,
        data: tt.reconstruct().into_iter().map(|v| v as f32).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_low_rank_tensor_is_recovered_and_rank_detected() {
        // Sum of two separable terms: TT ranks ≤ 2 everywhere.
        let dims = [5, 4, 6, 7];
        let mut a = vec![0.0; dims.iter().product()];
        let mut n = 0;
        for i in 0..5 {
            for j in 0..4 {
                for k in 0..6 {
                    for l in 0..7 {
                        let (x, y, z, w) = (i as f64, j as f64, k as f64, l as f64);
                        a[n] = (1.0 + x) * (0.5 + y).sqrt() * (z * 0.3).cos() * (-w * 0.2).exp()
                            + 0.3 * x.sin() * (y + 1.0) * (z + 2.0).ln() * w;
                        n += 1;
                    }
                }
            }
        }
        // Tolerance above the Gram-matrix noise floor (~1e-8 relative).
        let tt = tt_svd(&a, &dims, 1e-6, 64);
        assert_eq!(tt.ranks, vec![1, 2, 2, 2, 1]);
        let b = tt.reconstruct();
        let err = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-7, "{err}");
        assert!((tt.get(&[3, 2, 5, 6]) - a[((3 * 4 + 2) * 6 + 5) * 7 + 6]).abs() < 1e-7);
    }

    #[test]
    fn truncation_error_respects_tolerance() {
        // A smooth function of 4 variables (not exactly low rank).
        let dims = [8, 6, 9, 30];
        let mut a = Vec::new();
        for i in 0..8 {
            for j in 0..6 {
                for k in 0..9 {
                    for l in 0..30 {
                        let (x, y, z, w) = (
                            i as f64 / 8.0,
                            j as f64 / 6.0,
                            k as f64 / 9.0,
                            l as f64 / 30.0,
                        );
                        a.push(1.0 / (1.0 + x + y * z + (w - 0.5 * x).powi(2) * 4.0));
                    }
                }
            }
        }
        for tol in [1e-2, 1e-4] {
            let tt = tt_svd(&a, &dims, tol, 1000);
            let b = tt.reconstruct();
            let rep = error_report(&a, &b, tt.parameter_count());
            assert!(rep.rel_frobenius_error <= tol * 1.0001, "{tol}: {rep:?}");
            assert!(rep.parameters < a.len());
        }
    }

    #[test]
    fn table_round_trip_through_tt_table() {
        let axes = vec![
            Axis::uniform("a", "1", 0.0, 1.0, 6),
            Axis::uniform("b", "deg", 0.0, 1.0, 10),
        ];
        let mut data = Vec::new();
        for i in 0..6 {
            for j in 0..10 {
                data.push((i as f32 + 1.0) * (j as f32 * 0.1).cos());
                data.push(-1.0);
            }
        }
        let t = TableContent {
            schema: Schema::new("x", 3),
            description: "test".into(),
            axes,
            channels: vec![Channel::new("e", "1", "e"), Channel::new("f", "1", "f")],
            attributes: serde_json::Map::new(),
            data,
        };
        let (c, rep) = compress_table(&t, "e", 1e-6, 16).unwrap();
        assert_eq!(c.attributes["ranks"], serde_json::json!([1, 1, 1]));
        assert!(rep.rel_frobenius_error < 1e-6);
        let r = reconstruct_table(&c).unwrap();
        assert_eq!(r.schema, Schema::new("x", 3));
        assert_eq!(r.axes, t.axes);
        for (k, v) in r.data.iter().enumerate() {
            assert!((v - t.data[2 * k]).abs() < 1e-5);
        }
    }
}
