//! `build --plan`: what a build would compute, without computing it. For every planned table
//! its tasks, axes, channels, uncompressed size, estimated size on disk and estimated CPU time,
//! and the totals, so that a cluster job can be sized before it is spent.
//!
//! Sizes on disk are the uncompressed payload times the stored fraction measured for the
//! table's family ([`crate::stages::Job::estimated_stored_fraction`]), plus an estimated
//! header. CPU times come from each
//! stage's cost model ([`crate::stages::cost`]). docs/pipeline.md ("Planning a build") gives
//! both models' measured accuracy.

use crate::manifest::PlannedTable;
use crate::pipeline::{PipelineError, plan_manifests};
use serde::Serialize;
use std::path::PathBuf;

/// One axis of a planned table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlannedAxis {
    pub name: String,
    pub unit: String,
    pub len: usize,
    /// First and last coordinate.
    pub first: f64,
    pub last: f64,
}

/// One table of a build plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TablePlan {
    pub name: String,
    pub manifest: String,
    pub stage: String,
    /// Independent tasks (the unit of checkpoints, sharding and parallelism).
    pub tasks: usize,
    pub axes: Vec<PlannedAxis>,
    pub channels: usize,
    /// Values of the table (Π axis lengths × channels).
    pub values: u64,
    /// Uncompressed payload, 4 bytes per value.
    pub payload_bytes: u64,
    /// Estimated size of the `.sbt` file.
    pub estimated_bytes: u64,
    /// Estimated CPU seconds on one core.
    pub estimated_cpu_s: f64,
}

/// A build plan: every table and the totals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BuildPlan {
    pub tables: Vec<TablePlan>,
    pub total_tasks: usize,
    pub total_payload_bytes: u64,
    /// Estimated bytes on disk of every table.
    pub total_bytes: u64,
    pub total_cpu_s: f64,
}

/// Estimated header bytes: the parts known at plan time (axes and parameters as JSON, the
/// provenance, layout and payload records, a channel's name, unit and meaning) at the
/// writer's pretty-printed size, plus the job's estimate of its attributes. Axes the job
/// estimates itself (samples chosen while it runs, [`crate::stages::Job::estimated_header_axes`])
/// count at their exact pretty-printed size.
fn header_bytes(t: &PlannedTable, shape: &crate::stages::PlannedShape) -> u64 {
    /// Pretty-printed over compact JSON size of the known parts.
    const PRETTY: f64 = 1.25;
    /// Schema, description, layout, payload record and provenance other than the parameters.
    const FIXED: u64 = 1000;
    const PER_CHANNEL: u64 = 110;
    let (axes, estimated_axes) = match t.job.estimated_header_axes() {
        Some(axes) => (0, pretty_header_member_bytes(&axes)),
        None => (
            serde_json::to_vec(&shape.axes).map_or(0, |v| v.len() as u64),
            0,
        ),
    };
    let parameters = serde_json::to_vec(&t.job.parameters()).map_or(0, |v| v.len() as u64);
    let known = FIXED + axes + parameters + PER_CHANNEL * shape.channels as u64;
    (PRETTY * known as f64) as u64 + estimated_axes + t.job.estimated_attribute_bytes()
}

/// Bytes of `value` pretty-printed as a member of the header object: the writer's
/// two-space indentation, one level deeper than on its own.
fn pretty_header_member_bytes(value: &impl serde::Serialize) -> u64 {
    serde_json::to_vec_pretty(value).map_or(0, |v| {
        let lines = v.iter().filter(|&&b| b == b'\n').count();
        (v.len() + 2 * lines) as u64
    })
}

/// Plan one table.
pub fn plan_table(t: &PlannedTable) -> TablePlan {
    let shape = t.job.shape();
    let tasks = t.job.tasks().len();
    let payload_bytes = shape.payload_bytes();
    let stored = (payload_bytes as f64 * t.job.estimated_stored_fraction()).round() as u64;
    TablePlan {
        name: t.name.clone(),
        manifest: t.manifest.display().to_string(),
        stage: t.stage.name().to_string(),
        tasks,
        axes: shape
            .axes
            .iter()
            .map(|a| PlannedAxis {
                name: a.name.clone(),
                unit: a.unit.clone(),
                len: a.len(),
                first: a.coord(0),
                last: a.coord(a.len() - 1),
            })
            .collect(),
        channels: shape.channels,
        values: shape.values(),
        payload_bytes,
        estimated_bytes: stored.saturating_add(header_bytes(t, &shape)),
        estimated_cpu_s: t.job.estimated_cpu_seconds(),
    }
}

/// Plan every table of the manifests (the checks of a build's planning apply: unique names,
/// sizes within the reader's limit), computing nothing.
pub fn plan_build(manifests: &[PathBuf]) -> Result<BuildPlan, PipelineError> {
    let tables: Vec<TablePlan> = plan_manifests(manifests)?.iter().map(plan_table).collect();
    Ok(BuildPlan {
        total_tasks: tables.iter().map(|t| t.tasks).sum(),
        total_payload_bytes: tables
            .iter()
            .map(|t| t.payload_bytes)
            .fold(0, u64::saturating_add),
        total_bytes: tables
            .iter()
            .map(|t| t.estimated_bytes)
            .fold(0, u64::saturating_add),
        total_cpu_s: tables.iter().map(|t| t.estimated_cpu_s).sum(),
        tables,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plan counts an axes list the job estimates at the bytes it takes as a member of
    /// the pretty-printed header, where it sits one level deep.
    #[test]
    fn header_members_count_at_their_nested_pretty_size() {
        use crate::table::{Axis, Symmetry};
        let axes = vec![
            Axis::values("outgoing_polar", "deg", vec![0.0, 0.0125, 90.0, 180.0]),
            Axis::values("outgoing_azimuth", "deg", vec![0.0, 180.0])
                .with_symmetry(Symmetry::EvenPeriodic { period: 360.0 }),
        ];
        let header = serde_json::json!({ "schema": 1, "axes": axes });
        let text = serde_json::to_string_pretty(&header).unwrap();
        let around = "{\n  \"schema\": 1,\n  \"axes\": ".len() + "\n}".len();
        assert_eq!(
            pretty_header_member_bytes(&axes),
            (text.len() - around) as u64
        );
    }
}
