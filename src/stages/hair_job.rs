//! What the `hair-dual` and `hair-azimuthal` stages share: the fibre keys of their
//! parameters, their checks, and the job that runs a table's rows (one per inclination θ) as
//! tasks.

use crate::hair::diffuse::DiffuseTerms;
use crate::hair::elliptic::validate_axis_ratio;
use crate::hair::tables::ThetaRowTable;
use crate::stages::{Chunk, Job, JobError, PlanError, TaskSpec, check_chunks, checks};
use crate::table::TableContent;
use serde::Serialize;
use serde_json::{Value, json};

/// Fibre index of refraction, shared by both stages.
pub(super) const DEFAULT_ETA: f64 = 1.55;
/// Gauss–Legendre nodes per h panel, shared by both stages.
pub(super) const DEFAULT_QUADRATURE_ORDER: usize = 8;

/// Declares the parameter struct of a hair stage with
/// [`stage_params!`](crate::stages::stage_params): the fibre keys both
/// stages read (`eta`, `fresnel`, `quadrature_order`, `absorption_count`, `sigma_a`) followed
/// by the stage's own fields.
macro_rules! hair_params {
    (
        $(#[$sattr:meta])*
        pub struct $name:ident { $($fields:tt)* }
    ) => {
        crate::stages::stage_params! {
            $(#[$sattr])*
            pub struct $name {
                pub eta: f64 = default(crate::stages::hair::job::DEFAULT_ETA), "float",
                    "fibre index of refraction, 1.1–2.5 (physical fibre)";
                pub fresnel: crate::hair::fiber::FresnelModel = default(crate::hair::fiber::FresnelModel::ThreeD), "string",
                    "three-d (exact unpolarised at the 3-D incidence angle) or bravais (Marschner two-index)";
                /// Gauss–Legendre nodes per panel of the h integral.
                pub quadrature_order: usize = default(crate::stages::hair::job::DEFAULT_QUADRATURE_ORDER), "int",
                    "Gauss–Legendre nodes per h panel (2–32)";
                pub absorption_count: Option<usize> = optional("—"), "int",
                    "absorption_u = 1 − exp(−2σ_a) uniform on [0, 1] (LUT mode; give exactly one absorption key)";
                pub sigma_a: Option<Vec<f64>> = optional("—"), "list of float, 1/radius",
                    "explicit absorption values, strictly increasing";
                /// Lambertian surface BRDF k_d of an opaque fibre (FIB-21).
                #[serde(skip_serializing_if = "Option::is_none")]
                pub lambertian_kd: Option<f64> = optional("0 (none)"), "float",
                    "Lambertian-cylinder term: BRDF value k_d of an opaque Lambertian fibre surface, BCSDF (k_d/4)(sin|φ| + (π−|φ|) cos φ), albedo π k_d; 0–1/π (physical fibre)";
                /// Zinke & Weber eq. 52 higher-order diffuse constant (FIB-21).
                #[serde(skip_serializing_if = "Option::is_none")]
                pub higher_order_kd: Option<f64> = optional("0 (none)"), "float",
                    "higher-order diffuse constant k_d of Zinke & Weber eq. 52: BCSDF 2k_d, albedo 2π² k_d; 0–1/(2π²) (physical fibre)";
                /// Minor/major axis ratio of an elliptic fibre (FIB-22).
                #[serde(skip_serializing_if = "Option::is_none")]
                pub axis_ratio: Option<f64> = optional("1 (circular)"), "float",
                    "elliptic cross-section: minor/major semi-axis ratio a (Marschner's \"eccentricity\"), 0.85–1; TRT uses η* = ½(η*₁+η*₂) − ½cos 2ψ (η*₁−η*₂), averaged over the major-axis orientation (physical fibre)";
                $($fields)*
            }
        }
    };
}

pub(super) use hair_params;

/// Checks shared by both stages: the fibre index and the quadrature order.
pub(super) fn check_fibre(eta: f64, quadrature_order: usize) -> Result<(), PlanError> {
    checks::within("eta", eta, 1.1, 2.5, "")?;
    checks::within("quadrature_order", quadrature_order, 2, 32, "")
}

/// A physics check's `(key, message)` as a plan error.
pub(super) fn invalid((key, message): (&str, String)) -> PlanError {
    PlanError::invalid(key, message)
}

/// The diffuse terms and the axis ratio from the optional keys, validated (both stages).
pub(super) fn fibre_features(
    lambertian_kd: Option<f64>,
    higher_order_kd: Option<f64>,
    axis_ratio: Option<f64>,
) -> Result<(DiffuseTerms, f64), PlanError> {
    let diffuse = DiffuseTerms {
        lambertian_kd: lambertian_kd.unwrap_or(0.0),
        higher_order_kd: higher_order_kd.unwrap_or(0.0),
    };
    diffuse.validate().map_err(invalid)?;
    let a = axis_ratio.unwrap_or(1.0);
    validate_axis_ratio(a).map_err(|m| PlanError::invalid("axis_ratio", m))?;
    Ok((diffuse, a))
}

/// A planned hair table: its parameters and the table whose rows, one per inclination θ, are
/// the tasks (each chunk: a row, and its quadrature-doubling change as its one scalar).
pub struct HairJob<P, T> {
    pub params: P,
    table: T,
    /// See [`Job::estimated_stored_fraction`].
    stored_fraction: f64,
}

impl<P, T> HairJob<P, T> {
    /// The job of `table`, planned from `params`.
    pub(super) fn planned(params: P, table: T, stored_fraction: f64) -> Self {
        HairJob {
            params,
            table,
            stored_fraction,
        }
    }
}

impl<P: Serialize + Send + Sync, T: ThetaRowTable + Send> Job for HairJob<P, T> {
    fn parameters(&self) -> Value {
        serde_json::to_value(&self.params).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.table
            .theta_deg()
            .iter()
            .map(|t| TaskSpec {
                label: format!("θ={t:.3}°"),
                params: json!({ "theta_deg": t }),
            })
            .collect()
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let theta = self.table.theta_deg()[index].to_radians();
        let (row, change) = self.table.row_with_change(theta);
        Ok(Chunk::new(
            row.iter().map(|&v| v as f32).collect(),
            vec![change],
        ))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let nt = self.table.theta_deg().len();
        check_chunks(&chunks, nt, self.table.row_len(), 1)?;
        let change = chunks.iter().fold(0.0, |m: f64, c| m.max(c.scalars[0]));
        let rows: Vec<&[f32]> = chunks.iter().map(|c| c.values.as_slice()).collect();
        Ok(self.table.content(&rows, change)?)
    }
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.table.axes(), self.table.channel_count())
    }
    /// A set-up, then every value of every row computed twice (the quadrature-doubling
    /// check), `cost::HAIR_CPU_S`.
    fn estimated_cpu_seconds(&self) -> f64 {
        let [table, per_value] = crate::stages::cost::HAIR_CPU_S;
        table + per_value * (self.table.theta_deg().len() * self.table.row_len()) as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        self.stored_fraction
    }
}
