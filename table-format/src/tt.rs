//! Tensor-train tables (schema `fur-medulla-tt/1`): one channel of a dense table stored as the
//! cores of a tensor train (Oseledets 2011), reconstructed by the reader on load.
//! Layout and validation rules: `docs/table-format.md`, "Tensor-train tables".
//!
//! A d-way tensor A[i₁,…,i_d] is A ≈ G₁[:, i₁, :] · G₂[:, i₂, :] ⋯ G_d[:, i_d, :], core G_k of
//! shape r_{k−1} × n_k × r_k (r₀ = r_d = 1), row-major, all cores concatenated along the table's
//! single `value` axis at the offsets `core_offsets`. The header also carries the source
//! table's schema, axes, channel and attributes, so the reconstruction is a complete dense
//! table. The values reconstructed here are bit-identical in every reader built on this module
//! (the C library, the Python extension); the evaluation order is specified so that other
//! readers can reproduce it (the pure-Python reader does, see `docs/table-format.md`).
//!
//! Every rule is checked before anything is allocated from a declared size: the rank
//! conditions r_k ≤ r_{k−1}·n_k and r_k ≤ n_{k+1}·r_{k+1} bound every intermediate of the
//! contraction by the dense size, the dense size is bounded by the reader's payload limit, and
//! so is the reconstruction's peak memory (output, cores and one block's intermediates), while
//! its multiply-adds are capped by [`TT_MAX_MULTIPLY_ADDS`] (decision TF-2).

use crate::format::TableError;
use crate::model::{Axis, Channel, Header, Provenance, Schema, Table, TableContent};
use crate::read::ReadLimits;
use crate::validate::{MAX_AXES, check_axis_coords};
use std::path::Path;

/// Schema name of tensor-train tables.
pub const TT_SCHEMA: &str = "fur-medulla-tt";
/// Schema version of tensor-train tables this reader implements.
pub const TT_SCHEMA_VERSION: u32 = 1;
/// Largest number of tensor-train modes (the dense table's axes).
pub const TT_MAX_MODES: usize = MAX_AXES;

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
    ///
    /// Evaluation order (the specification other readers follow for bit-identical values):
    /// left to right, M₀ = `[1]` (1 × 1); M_k[(row, i), :] = Σ_{a = 0 … r_{k−1}−1, in order}
    /// M_{k−1}[row, a] · G_k[a, i, :], accumulated in f64 from 0 by separate multiply and add
    /// (no fused multiply-add).
    pub fn reconstruct(&self) -> Vec<f64> {
        // Left-to-right contraction: M has shape (n₁⋯n_k) × r_k.
        let mut m = vec![1.0];
        let mut rows = 1usize;
        for (k, core) in self.cores.iter().enumerate() {
            let n = self.dims[k];
            m = contract_step(&m, rows, core, self.ranks[k], n, self.ranks[k + 1], 0..n);
            rows *= n;
        }
        m
    }

    /// The reconstruction in row-major order, evaluated in blocks of fixed indices of the first
    /// `fixed` modes (the same operations in the same order as [`Self::reconstruct`], so the
    /// same bits), each value mapped by `value` and appended to `out`; the output is reserved
    /// fallibly (an allocation failure is an error, not an abort) and a non-finite value is an
    /// error naming its flat index.
    fn reconstruct_into(
        &self,
        fixed: usize,
        out: &mut Vec<f32>,
        value: impl Fn(f64) -> f32,
    ) -> Result<(), String> {
        let total: usize = self.dims.iter().product();
        out.try_reserve_exact(total).map_err(|_| {
            format!(
                "cannot allocate {} bytes for the reconstructed values",
                4 * total as u64
            )
        })?;
        let blocks: usize = self.dims[..fixed].iter().product();
        let mut idx = vec![0usize; fixed];
        for _ in 0..blocks {
            let mut m = vec![1.0];
            for (k, &i) in idx.iter().enumerate() {
                let (r0, n, r1) = (self.ranks[k], self.dims[k], self.ranks[k + 1]);
                m = contract_step(&m, 1, &self.cores[k], r0, n, r1, i..i + 1);
            }
            let mut rows = 1usize;
            for k in fixed..self.dims.len() {
                let n = self.dims[k];
                let (r0, r1) = (self.ranks[k], self.ranks[k + 1]);
                m = contract_step(&m, rows, &self.cores[k], r0, n, r1, 0..n);
                rows *= n;
            }
            for x in m {
                let v = value(x);
                if !v.is_finite() {
                    return Err(format!(
                        "reconstructed value {} is not finite (after exp and rounding to f32)",
                        out.len()
                    ));
                }
                out.push(v);
            }
            // Next block: the fixed indices in row-major order.
            for k in (0..fixed).rev() {
                idx[k] += 1;
                if idx[k] < self.dims[k] {
                    break;
                }
                idx[k] = 0;
            }
        }
        Ok(())
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

    /// The tensor train of the sub-tensor at the given indices of each mode (`None`: the whole
    /// mode). Its [`Self::reconstruct`] gives exactly (bit for bit) the selected entries of the
    /// full reconstruction. Indices must be in range (panics otherwise; callers check).
    pub fn select(&self, idx: &[Option<Vec<usize>>]) -> TensorTrain {
        let mut dims = Vec::with_capacity(self.dims.len());
        let mut cores = Vec::with_capacity(self.dims.len());
        for (k, core) in self.cores.iter().enumerate() {
            let (r0, n, r1) = (self.ranks[k], self.dims[k], self.ranks[k + 1]);
            match idx.get(k).and_then(Option::as_ref) {
                None => {
                    dims.push(n);
                    cores.push(core.clone());
                }
                Some(sel) => {
                    let mut c = Vec::with_capacity(r0 * sel.len() * r1);
                    for a in 0..r0 {
                        for &i in sel {
                            c.extend_from_slice(&core[(a * n + i) * r1..(a * n + i + 1) * r1]);
                        }
                    }
                    dims.push(sel.len());
                    cores.push(c);
                }
            }
        }
        TensorTrain {
            dims,
            ranks: self.ranks.clone(),
            cores,
        }
    }
}

/// One step of the left-to-right contraction, for the indices `sel` of mode k:
/// `next[(row, i), :] = Σ_{a in order} m[row, a] · core[a, i, :]`, accumulated in f64 from 0 by
/// separate multiply and add (terms with `m[row, a] = 0` add nothing and are skipped).
fn contract_step(
    m: &[f64],
    rows: usize,
    core: &[f64],
    r0: usize,
    n: usize,
    r1: usize,
    sel: std::ops::Range<usize>,
) -> Vec<f64> {
    let width = sel.len();
    let mut next = vec![0.0; rows * width * r1];
    for row in 0..rows {
        for a in 0..r0 {
            let v = m[row * r0 + a];
            if v == 0.0 {
                continue;
            }
            for (j, i) in sel.clone().enumerate() {
                let src = &core[(a * n + i) * r1..(a * n + i + 1) * r1];
                let dst = &mut next[(row * width + j) * r1..(row * width + j + 1) * r1];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += v * s;
                }
            }
        }
    }
    next
}

/// Largest number of multiply-adds a reconstruction may take: 2^34 ≈ 1.7·10^10, about a minute
/// of one core, 11 times the largest shipped table's (decision TF-2).
pub const TT_MAX_MULTIPLY_ADDS: u64 = 1 << 34;
/// Bytes of f64 intermediates one block of the reconstruction aims at: the leading modes are
/// fixed, block by block, until a block's two largest consecutive intermediates fit.
const BLOCK_BYTES: u64 = 8 << 20;

/// How a reconstruction is evaluated and what it costs (`docs/table-format.md`, "Tensor-train
/// tables", rules 5a and 5b).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReconstructionCost {
    /// Leading modes whose indices are fixed per block (0: one block, the whole train).
    pub fixed: usize,
    /// Peak bytes: the f32 values, the f64 cores, and the two largest consecutive f64
    /// intermediates M_k, M_{k+1} of a block (saturating at `u64::MAX`).
    pub bytes: u64,
    /// Multiply-adds of the whole reconstruction, every block (saturating).
    pub multiply_adds: u64,
}

/// The cost of reconstructing a train of these dims and ranks (which passed rules 1–5) in the
/// blocks `TensorTrain::reconstruct_into` uses: the fewest fixed leading modes whose blocks
/// keep their intermediates within `BLOCK_BYTES` (all but the last mode when none do).
pub fn reconstruction_cost(dims: &[usize], ranks: &[usize]) -> ReconstructionCost {
    let d = dims.len();
    let u = |x: usize| x as u64;
    let values = dims.iter().fold(1u64, |acc, &n| acc.saturating_mul(u(n)));
    let cores = (0..d).fold(0u64, |acc, k| {
        acc.saturating_add(
            u(ranks[k])
                .saturating_mul(u(dims[k]))
                .saturating_mul(u(ranks[k + 1])),
        )
    });
    let block = |fixed: usize| {
        let blocks = dims[..fixed]
            .iter()
            .fold(1u64, |acc, &n| acc.saturating_mul(u(n)));
        // The fixed modes: M is one row; each step costs r_k·r_{k+1}.
        let mut work = (0..fixed).fold(0u64, |acc, k| {
            acc.saturating_add(u(ranks[k]).saturating_mul(u(ranks[k + 1])))
        });
        let mut peak = (0..fixed).fold(1u64, |acc, k| acc.max(u(ranks[k]) + u(ranks[k + 1])));
        let mut rows = 1u64;
        for k in fixed..d {
            let next_rows = rows.saturating_mul(u(dims[k]));
            let step = rows
                .saturating_mul(u(ranks[k]))
                .saturating_mul(u(dims[k]))
                .saturating_mul(u(ranks[k + 1]));
            work = work.saturating_add(step);
            let live = rows
                .saturating_mul(u(ranks[k]))
                .saturating_add(next_rows.saturating_mul(u(ranks[k + 1])));
            peak = peak.max(live);
            rows = next_rows;
        }
        (peak.saturating_mul(8), blocks.saturating_mul(work))
    };
    let fixed = (0..d).find(|&f| block(f).0 <= BLOCK_BYTES).unwrap_or(d - 1);
    let (peak, multiply_adds) = block(fixed);
    ReconstructionCost {
        fixed,
        bytes: values
            .saturating_mul(4)
            .saturating_add(cores.saturating_mul(8))
            .saturating_add(peak),
        multiply_adds,
    }
}

/// A validated tensor-train table: the train and the description of the dense table it holds.
#[derive(Debug, Clone)]
pub struct DecodedTensorTrain {
    pub tt: TensorTrain,
    /// Schema of the dense table (from `source_schema`).
    pub schema: Schema,
    /// Description of the dense table.
    pub description: String,
    /// Axes of the dense table (one per mode, lengths = `dims`).
    pub axes: Vec<Axis>,
    /// The single channel of the dense table.
    pub channel: Channel,
    /// Attributes of the dense table: the source attributes plus `tt_*` entries (ranks,
    /// reconstruction errors, the compressed payload's SHA-256).
    pub attributes: serde_json::Map<String, serde_json::Value>,
    /// `Some(floor)`: the train holds ln(max(value, floor)); values are exp of it.
    pub log_floor: Option<f64>,
    /// The table's file (names it in errors of the reconstruction).
    pub path: std::path::PathBuf,
}

impl DecodedTensorTrain {
    /// Map reconstructed train values to table values (exp for the logarithmic form).
    fn value(&self, x: f64) -> f32 {
        match self.log_floor {
            None => x as f32,
            Some(_) => x.exp() as f32,
        }
    }

    /// The whole dense channel, row-major over the axes, reconstructed block by block
    /// ([`reconstruction_cost`]: the f64 intermediates stay small; bit-identical to a whole
    /// [`TensorTrain::reconstruct`]). A value that is not finite after the `exp` of the
    /// logarithmic form and the rounding to f32 is an error, as is an allocation failure.
    pub fn dense(&self) -> Result<Vec<f32>, TableError> {
        self.evaluate(&self.tt)
    }

    /// The values of `tt` (this train or a selection of it), as [`Self::dense`].
    fn evaluate(&self, tt: &TensorTrain) -> Result<Vec<f32>, TableError> {
        let cost = reconstruction_cost(&tt.dims, &tt.ranks);
        let mut out = Vec::new();
        tt.reconstruct_into(cost.fixed, &mut out, |x| self.value(x))
            .map_err(|m| tt_err(&self.path, m))?;
        Ok(out)
    }

    /// The dense table restricted to the given indices of each axis (`None`: the whole axis),
    /// as an in-memory table whose selected axes hold the selected coordinates. Values are
    /// bit-identical to those of [`Self::dense`] at the same grid points. Errors on an empty
    /// or out-of-range selection.
    pub fn sub_table(&self, idx: &[Option<Vec<usize>>]) -> Result<Table, TableError> {
        let mut axes = Vec::with_capacity(self.axes.len());
        for (k, a) in self.axes.iter().enumerate() {
            match idx.get(k).and_then(Option::as_ref) {
                None => axes.push(a.clone()),
                Some(sel) => {
                    if sel.is_empty()
                        || sel.iter().any(|&i| i >= a.len())
                        || sel.windows(2).any(|w| w[1] <= w[0])
                    {
                        return Err(TableError::Inconsistent(format!(
                            "selection on axis `{}` must be increasing indices below {}",
                            a.name,
                            a.len()
                        )));
                    }
                    let c = a.coords();
                    axes.push(Axis::values(
                        &a.name,
                        &a.unit,
                        sel.iter().map(|&i| c[i]).collect(),
                    ));
                }
            }
        }
        let data: Vec<f32> = if self.tt.dims.is_empty() {
            Vec::new()
        } else {
            self.evaluate(&self.tt.select(idx))?
        };
        self.table(axes, data)
    }

    /// The whole dense table in memory.
    pub fn dense_table(&self) -> Result<Table, TableError> {
        self.table(self.axes.clone(), self.dense()?)
    }

    fn table(&self, axes: Vec<Axis>, data: Vec<f32>) -> Result<Table, TableError> {
        Table::from_content(
            TableContent {
                encoding: Default::default(),
                schema: self.schema.clone(),
                description: self.description.clone(),
                axes,
                channels: vec![self.channel.clone()],
                attributes: self.attributes.clone(),
                data,
            },
            Provenance::default(),
        )
    }
}

fn tt_err(path: &Path, message: impl Into<String>) -> TableError {
    TableError::TensorTrain {
        path: path.into(),
        message: message.into(),
    }
}

/// A non-negative integer array attribute.
fn usize_array(
    at: &serde_json::Map<String, serde_json::Value>,
    key: &str,
    path: &Path,
) -> Result<Vec<usize>, TableError> {
    let v = at
        .get(key)
        .ok_or_else(|| tt_err(path, format!("missing attribute `{key}`")))?;
    let arr = v
        .as_array()
        .ok_or_else(|| tt_err(path, format!("attribute `{key}` is not an array")))?;
    if arr.len() > TT_MAX_MODES + 1 {
        return Err(tt_err(
            path,
            format!(
                "attribute `{key}` has {} entries (at most {})",
                arr.len(),
                TT_MAX_MODES + 1
            ),
        ));
    }
    arr.iter()
        .map(|x| {
            x.as_u64()
                .and_then(|u| usize::try_from(u).ok())
                .ok_or_else(|| {
                    tt_err(
                        path,
                        format!("attribute `{key}` holds {x}, not a non-negative integer"),
                    )
                })
        })
        .collect()
}

/// Check every rule of a tensor-train table (`docs/table-format.md`, "Tensor-train tables")
/// and decode it. `path` names the table in errors; `limits.max_payload_bytes` bounds the
/// dense reconstruction (4 bytes per value). The rules are checked in the order of the steps
/// below, so a file breaking several is refused for the first.
pub fn decode_tensor_train(
    table: &Table,
    path: &Path,
    limits: &ReadLimits,
) -> Result<DecodedTensorTrain, TableError> {
    let h = &table.header;
    check_tt_header(h, path)?;
    let at = &h.attributes;
    let TrainShape {
        dims,
        ranks,
        offsets,
    } = train_shape(at, path, limits)?;
    let cores = split_cores(&table.data, &dims, &ranks, &offsets, path)?;
    let axes = source_axes(at, &dims, path)?;
    let channel = source_channel(at, path)?;
    let schema = source_schema(at, path)?;
    let log_floor = log_floor(at, path)?;
    let attributes = dense_attributes(at, &h.payload.sha256_uncompressed, path)?;
    let description = format!(
        "{} (reconstructed from tensor train)",
        at.get("source_description")
            .and_then(|v| v.as_str())
            .unwrap_or("")
    );
    Ok(DecodedTensorTrain {
        tt: TensorTrain { dims, ranks, cores },
        schema,
        description,
        axes,
        channel,
        attributes,
        log_floor,
        path: path.into(),
    })
}

/// The tensor-train table's own schema and its single axis and channel.
fn check_tt_header(h: &Header, path: &Path) -> Result<(), TableError> {
    if h.schema.name != TT_SCHEMA {
        return Err(tt_err(
            path,
            format!("schema {} is not {TT_SCHEMA}", h.schema),
        ));
    }
    if h.schema.version != TT_SCHEMA_VERSION {
        return Err(tt_err(
            path,
            format!(
                "schema version {} is not supported (this reader knows {TT_SCHEMA}/{TT_SCHEMA_VERSION})",
                h.schema.version
            ),
        ));
    }
    if h.axes.len() != 1 || h.channels.len() != 1 {
        return Err(tt_err(
            path,
            format!(
                "needs exactly one axis and one channel (has {} and {})",
                h.axes.len(),
                h.channels.len()
            ),
        ));
    }
    Ok(())
}

/// Mode sizes, ranks and core offsets of a train, checked against each other.
struct TrainShape {
    dims: Vec<usize>,
    ranks: Vec<usize>,
    offsets: Vec<usize>,
}

/// The attributes `dims`, `ranks` and `core_offsets`: as many modes as a table may have axes,
/// one rank and one offset more than modes, no empty mode, end ranks 1, a dense size within
/// the reader's limit and ranks within what each unfolding allows.
fn train_shape(
    at: &serde_json::Map<String, serde_json::Value>,
    path: &Path,
    limits: &ReadLimits,
) -> Result<TrainShape, TableError> {
    let dims = usize_array(at, "dims", path)?;
    let ranks = usize_array(at, "ranks", path)?;
    let offsets = usize_array(at, "core_offsets", path)?;
    let d = dims.len();
    if d == 0 || d > TT_MAX_MODES {
        return Err(tt_err(
            path,
            format!("{d} modes in `dims` (1 to {TT_MAX_MODES})"),
        ));
    }
    if ranks.len() != d + 1 || offsets.len() != d + 1 {
        return Err(tt_err(
            path,
            format!(
                "inconsistent ranks/dims: {d} dims need {} ranks and {} core offsets, found {} and {}",
                d + 1,
                d + 1,
                ranks.len(),
                offsets.len()
            ),
        ));
    }
    if let Some(k) = dims.iter().position(|&n| n == 0) {
        return Err(tt_err(path, format!("dims[{k}] is 0")));
    }
    if ranks[0] != 1 || ranks[d] != 1 {
        return Err(tt_err(
            path,
            format!("inconsistent ranks: the first and last rank must be 1 (ranks {ranks:?})"),
        ));
    }
    dims.iter()
        .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
        .filter(|&v| {
            v.checked_mul(4)
                .is_some_and(|b| b <= limits.max_payload_bytes)
        })
        .ok_or_else(|| {
            tt_err(
                path,
                format!(
                    "dims {dims:?} describe more than the reader's limit of {} bytes",
                    limits.max_payload_bytes
                ),
            )
        })?;
    check_ranks(&dims, &ranks, path)?;
    check_cost(&dims, &ranks, path, limits)?;
    Ok(TrainShape {
        dims,
        ranks,
        offsets,
    })
}

/// No rank is 0, and r_{k+1} ≤ r_k·n_k and r_k ≤ n_k·r_{k+1}: no rank exceeds what its
/// unfolding allows, which bounds every intermediate of the contraction by the dense size.
fn check_ranks(dims: &[usize], ranks: &[usize], path: &Path) -> Result<(), TableError> {
    for k in 0..dims.len() {
        if ranks[k] == 0 {
            return Err(tt_err(path, format!("inconsistent ranks: ranks[{k}] is 0")));
        }
        let left = (ranks[k] as u64).saturating_mul(dims[k] as u64);
        let right = (dims[k] as u64).saturating_mul(ranks[k + 1] as u64);
        if ranks[k + 1] as u64 > left || ranks[k] as u64 > right {
            return Err(tt_err(
                path,
                format!(
                    "inconsistent ranks/dims: core {k} is {} x {} x {}, a rank exceeds its unfolding",
                    ranks[k],
                    dims[k],
                    ranks[k + 1]
                ),
            ));
        }
    }
    Ok(())
}

/// The reconstruction's peak memory (the f32 values, the f64 cores and a block's f64
/// intermediates) within the reader's limit, and its multiply-adds within
/// [`TT_MAX_MULTIPLY_ADDS`]: checked before anything is allocated.
fn check_cost(
    dims: &[usize],
    ranks: &[usize],
    path: &Path,
    limits: &ReadLimits,
) -> Result<(), TableError> {
    let cost = reconstruction_cost(dims, ranks);
    if cost.bytes > limits.max_payload_bytes {
        return Err(tt_err(
            path,
            format!(
                "the reconstruction needs {} bytes (f32 values, f64 cores and intermediates), \
                 more than the reader's limit of {} bytes",
                cost.bytes, limits.max_payload_bytes
            ),
        ));
    }
    if cost.multiply_adds > TT_MAX_MULTIPLY_ADDS {
        return Err(tt_err(
            path,
            format!(
                "the reconstruction takes {} multiply-adds, more than the limit of \
                 {TT_MAX_MULTIPLY_ADDS} (dims {dims:?}, ranks {ranks:?})",
                cost.multiply_adds
            ),
        ));
    }
    Ok(())
}

/// The cores, cut from the stored values at the offsets (which must cover them all, each core
/// of its r_{k−1} × n_k × r_k values, all finite), widened to f64.
fn split_cores(
    data: &[f32],
    dims: &[usize],
    ranks: &[usize],
    offsets: &[usize],
    path: &Path,
) -> Result<Vec<Vec<f64>>, TableError> {
    let d = dims.len();
    let n_values = data.len();
    if offsets[0] != 0 || offsets[d] != n_values {
        return Err(tt_err(
            path,
            format!(
                "core offsets must run from 0 to the {n_values} stored values (found {} .. {})",
                offsets[0], offsets[d]
            ),
        ));
    }
    let mut cores = Vec::with_capacity(d);
    for k in 0..d {
        let size = (ranks[k] as u64)
            .checked_mul(dims[k] as u64)
            .and_then(|v| v.checked_mul(ranks[k + 1] as u64));
        let stored = offsets[k + 1].checked_sub(offsets[k]);
        if size.is_none() || stored.map(|s| s as u64) != size {
            return Err(tt_err(
                path,
                format!(
                    "inconsistent ranks/dims: core {k} holds {} values, ranks and dims imply {} x {} x {}",
                    stored.map_or("a negative number of".to_string(), |s| s.to_string()),
                    ranks[k],
                    dims[k],
                    ranks[k + 1]
                ),
            ));
        }
        let core = &data[offsets[k]..offsets[k + 1]];
        if let Some(j) = core.iter().position(|v| !v.is_finite()) {
            return Err(tt_err(
                path,
                format!("core {k} holds a non-finite value at {j}"),
            ));
        }
        cores.push(core.iter().map(|&v| f64::from(v)).collect());
    }
    Ok(cores)
}

/// The attribute `source_axes`: one valid axis per mode, of the mode's length.
fn source_axes(
    at: &serde_json::Map<String, serde_json::Value>,
    dims: &[usize],
    path: &Path,
) -> Result<Vec<Axis>, TableError> {
    let json = at
        .get("source_axes")
        .ok_or_else(|| tt_err(path, "missing attribute `source_axes`"))?;
    // The typed decoder would also build an axis from an array; the format has objects.
    let objects = |v: Option<&serde_json::Value>| v.is_none_or(serde_json::Value::is_object);
    if let Some(list) = json.as_array()
        && !list.iter().all(|a| {
            a.is_object()
                && objects(a.get("points"))
                && objects(a.get("points").and_then(|p| p.get("uniform")))
        })
    {
        return Err(tt_err(
            path,
            "attribute `source_axes`: an axis, its points and a uniform axis's points are \
             objects, not arrays",
        ));
    }
    // `symmetry` (format 3.0) is not part of a source axis: ignored, as every reader does.
    let mut json = json.clone();
    if let Some(list) = json.as_array_mut() {
        for a in list.iter_mut().filter_map(|a| a.as_object_mut()) {
            a.remove("symmetry");
        }
    }
    let axes: Vec<Axis> = serde_json::from_value(json)
        .map_err(|e| tt_err(path, format!("attribute `source_axes`: {e}")))?;
    if axes.len() != dims.len() || axes.iter().zip(dims).any(|(a, &n)| a.len() != n) {
        return Err(tt_err(
            path,
            format!(
                "inconsistent ranks/dims: source axes of lengths {:?} for dims {dims:?}",
                axes.iter().map(Axis::len).collect::<Vec<_>>()
            ),
        ));
    }
    for a in &axes {
        check_axis_coords(a).map_err(|m| tt_err(path, format!("source axis: {m}")))?;
    }
    Ok(axes)
}

/// The attribute `source_channel`.
fn source_channel(
    at: &serde_json::Map<String, serde_json::Value>,
    path: &Path,
) -> Result<Channel, TableError> {
    serde_json::from_value(
        at.get("source_channel")
            .cloned()
            .ok_or_else(|| tt_err(path, "missing attribute `source_channel`"))?,
    )
    .map_err(|e| tt_err(path, format!("attribute `source_channel`: {e}")))
}

/// The attribute `source_schema`, `NAME/VERSION`.
fn source_schema(
    at: &serde_json::Map<String, serde_json::Value>,
    path: &Path,
) -> Result<Schema, TableError> {
    let schema_str = at
        .get("source_schema")
        .and_then(|v| v.as_str())
        .ok_or_else(|| tt_err(path, "attribute `source_schema` is not a string"))?;
    schema_str
        .rsplit_once('/')
        .and_then(|(n, v)| Some(Schema::new(n, v.parse().ok()?)))
        .filter(|s| !s.name.is_empty())
        .ok_or_else(|| {
            tt_err(
                path,
                format!("attribute `source_schema` is `{schema_str}`, not NAME/VERSION"),
            )
        })
}

/// The optional attribute `log_floor`, a positive number.
fn log_floor(
    at: &serde_json::Map<String, serde_json::Value>,
    path: &Path,
) -> Result<Option<f64>, TableError> {
    match at.get("log_floor") {
        None => Ok(None),
        Some(v) => v
            .as_f64()
            .filter(|f| f.is_finite() && *f > 0.0)
            .map(Some)
            .ok_or_else(|| tt_err(path, format!("`log_floor` is {v}, not a positive number"))),
    }
}

/// Attributes of the dense table: `source_attributes` (an object when present), the train's
/// ranks and errors as `tt_*` entries, and `tt_payload_sha256`, the SHA-256 of the train's
/// uncompressed payload.
fn dense_attributes(
    at: &serde_json::Map<String, serde_json::Value>,
    payload_sha256: &str,
    path: &Path,
) -> Result<serde_json::Map<String, serde_json::Value>, TableError> {
    let mut attributes = match at.get("source_attributes") {
        Some(serde_json::Value::Object(m)) => m.clone(),
        None => serde_json::Map::new(),
        Some(_) => {
            return Err(tt_err(
                path,
                "attribute `source_attributes` is not an object",
            ));
        }
    };
    for k in [
        "rel_frobenius_error",
        "max_abs_error",
        "max_abs_error_rel_to_max",
        "ranks",
        "rel_tol",
        "reconstruction_error",
    ] {
        if let Some(v) = at.get(k) {
            attributes.insert(format!("tt_{k}"), v.clone());
        }
    }
    attributes.insert("tt_payload_sha256".into(), payload_sha256.into());
    Ok(attributes)
}

impl Table {
    /// Open and verify a table; a tensor-train table (`fur-medulla-tt/1`) is checked
    /// ([`decode_tensor_train`]) and reconstructed into the dense table it holds (its payload
    /// limited by `limits` as well), any other table is returned as read.
    pub fn open_reconstructed(
        path: impl AsRef<Path>,
        limits: &ReadLimits,
    ) -> Result<Table, TableError> {
        let path = path.as_ref();
        let t = Table::open_with_limits(path, limits)?;
        t.reconstructed(path, limits)
    }

    /// [`Table::open_reconstructed`] for a table already in memory (`path` names it in errors).
    pub fn reconstructed(self, path: &Path, limits: &ReadLimits) -> Result<Table, TableError> {
        if self.header.schema.name != TT_SCHEMA {
            return Ok(self);
        }
        let provenance = self.header.provenance.clone();
        let mut dense = decode_tensor_train(&self, path, limits)?.dense_table()?;
        dense.header.provenance = provenance;
        Ok(dense)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A train of mixed-sign values with every rank above 1 inside.
    fn train() -> TensorTrain {
        let (dims, ranks) = (vec![3, 4, 2, 5], vec![1, 3, 5, 4, 1]);
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let cores = (0..dims.len())
            .map(|k| {
                (0..ranks[k] * dims[k] * ranks[k + 1])
                    .map(|_| {
                        seed ^= seed << 13;
                        seed ^= seed >> 7;
                        seed ^= seed << 17;
                        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    })
                    .collect()
            })
            .collect();
        TensorTrain { dims, ranks, cores }
    }

    /// Every blocking (0 to d − 1 fixed leading modes) gives the whole reconstruction's bits.
    #[test]
    fn blocks_reproduce_the_whole_reconstruction() {
        let tt = train();
        let whole: Vec<u32> = tt
            .reconstruct()
            .iter()
            .map(|&x| (x as f32).to_bits())
            .collect();
        for fixed in 0..tt.dims.len() {
            let mut out = Vec::new();
            tt.reconstruct_into(fixed, &mut out, |x| x as f32).unwrap();
            let bits: Vec<u32> = out.iter().map(|v| v.to_bits()).collect();
            assert_eq!(bits, whole, "{fixed} fixed modes");
        }
    }

    /// The cost counts what the blocks hold and do: the small train fits one block, whose
    /// multiply-adds are those of the whole contraction; the 1 × 32768 × 32768 rank-1 train is
    /// cut into rows and needs its 4 GiB of output plus cores and a block.
    #[test]
    fn cost_counts_output_cores_intermediates_and_work() {
        let tt = train();
        let c = reconstruction_cost(&tt.dims, &tt.ranks);
        assert_eq!(c.fixed, 0);
        // Steps: 1·1·3·3, 3·3·4·5, 12·5·2·4, 24·4·5·1 multiply-adds.
        assert_eq!(c.multiply_adds, 9 + 180 + 480 + 480);
        let cores: usize = tt.cores.iter().map(Vec::len).sum();
        // Largest two consecutive intermediates: M_3 (24 × 4) and M_4 (120 × 1).
        assert_eq!(c.bytes, 4 * 120 + 8 * cores as u64 + 8 * (96 + 120));
        let big = reconstruction_cost(&[1, 32768, 32768], &[1, 1, 1, 1]);
        assert_eq!(big.fixed, 2);
        assert!(big.bytes > 4 << 30 && big.bytes < (4 << 30) + (1 << 20));
        // 32768 blocks, each two 1 × 1 prefix steps and a row of 32768.
        assert_eq!(big.multiply_adds, 32768 * (2 + 32768));
    }
}
