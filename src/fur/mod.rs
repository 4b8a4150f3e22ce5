//! Fur: medulla scattering tables of the coaxial-cylinder fur model (Tseng 2015; Yan et al.
//! 2015) and their compact low-rank form. Conventions: `docs/fur.md`;
//! decisions (FUR-n): `docs/decisions.md`.
//!
//! - [`medulla`]: 2-D volumetric Monte Carlo (planar Henyey–Greenstein, no absorption,
//!   index-matched boundary) for the azimuthal C^N and longitudinal C^M families, with a
//!   next-event (expected-value) estimator and a plain histogram estimator.
//! - [`medulla_fast`]: adaptive C^N: closed-form single scattering, vectorised next-event
//!   Monte Carlo of the higher orders until a target error, batch-based error bars.
//! - [`slab`]: deterministic C^M by adding–doubling on the circle of directions (all θ'_i and
//!   all σ of one g at once, no noise).
//! - [`medulla_table`]: the medulla tables' layout (row packing, mirrored rows, axes, channels)
//!   and header, shared by every method; [`medulla_headers`]: what each method writes about
//!   itself (settings, estimator, measured solver errors).
//! - [`farfield`]: far-field profiles of the practical shading model for the Table 4.2 samples.
//! - [`farfield_table`]: the far-field table (values per sample, layout, header) and the
//!   medulla tables it looks its profiles up in.
//! - [`tt`]: tensor-train (TT-SVD) compression and reconstruction of a table channel.
//!
//! Their stages (`fur-medulla-azimuthal`, `fur-medulla-longitudinal`, `fur-farfield`) are
//! [`crate::stages::fur_medulla`] and [`crate::stages::fur_farfield`]: parameters, their checks
//! and the task grid.

pub mod assets;
pub mod chief_ray;
pub mod disc;
pub mod farfield;
pub mod farfield_table;
pub mod medulla;
pub mod medulla_fast;
pub mod medulla_headers;
pub mod medulla_table;
pub mod slab;
pub mod tt;

use crate::table::SampleError;

/// Why a fur computation that reads tables failed: a medulla table that does not fit the far
/// field, or a tensor-train table that cannot be reconstructed.
#[derive(Debug, thiserror::Error)]
pub enum FurError {
    /// A table of another schema than the one expected.
    #[error("expected a {expected} table, got {found}")]
    WrongSchema {
        expected: &'static str,
        found: String,
    },
    /// A lookup coordinate outside the axis range of a medulla table.
    #[error(
        "{schema}: {axis} = {value} is outside the table's range [{lo}, {hi}]; use the on-the-fly Monte Carlo or a table whose grid covers it"
    )]
    OutsideTable {
        schema: String,
        axis: String,
        value: f64,
        lo: f64,
        hi: f64,
    },
    /// A lookup in a medulla table (missing axis or channel, NaN coordinate).
    #[error("lookup in the {schema} table")]
    Lookup {
        schema: String,
        #[source]
        source: SampleError,
    },
    /// A channel to compress that the table does not have.
    #[error("table has no channel `{0}`")]
    NoChannel(String),
    /// A `fur-medulla-tt/1` table whose header does not describe its cores.
    #[error("fur-medulla-tt table: {0}")]
    TensorTrain(String),
    /// A `fur-medulla-tt/1` header attribute that does not decode (or encode).
    #[error("fur-medulla-tt table: attribute `{key}`")]
    TensorTrainAttribute {
        key: &'static str,
        #[source]
        source: serde_json::Error,
    },
}
