//! The rules of a table's axes, applied alike by the writer (`Table::from_content`), the
//! reader and the tensor-train decoder.

use crate::model::{Axis, AxisPoints};

/// Largest number of axes (a lookup touches up to 2^axes grid points).
pub const MAX_AXES: usize = 16;

/// At least one axis and at most [`MAX_AXES`].
pub(crate) fn check_axis_count(n: usize) -> Result<(), String> {
    if n == 0 {
        return Err("a table needs at least one axis".into());
    }
    if n > MAX_AXES {
        return Err(format!("{n} axes, more than the limit of {MAX_AXES}"));
    }
    Ok(())
}

/// Coordinates finite and strictly increasing; a uniform axis has a finite start and a finite
/// step > 0, and `start + k·step` (computed in f64) is finite and strictly increasing.
pub(crate) fn check_axis_coords(a: &Axis) -> Result<(), String> {
    if a.is_empty() {
        return Err(format!("axis `{}` is empty", a.name));
    }
    if let AxisPoints::Uniform { start, step, .. } = a.points {
        check_uniform_params(a, start, step)?;
    }
    if !a.labels.is_empty() && a.labels.len() != a.len() {
        return Err(format!(
            "axis `{}` has {} labels for {} samples",
            a.name,
            a.labels.len(),
            a.len()
        ));
    }
    let mut prev = f64::NEG_INFINITY;
    for k in 0..a.len() {
        let x = a.coord(k);
        if !x.is_finite() {
            return Err(format!(
                "axis `{}`: coordinate {k} ({x}) is not finite",
                a.name
            ));
        }
        if k > 0 && x <= prev {
            return Err(format!(
                "axis `{}`: coordinates are not strictly increasing at index {k} ({prev} then {x})",
                a.name
            ));
        }
        prev = x;
    }
    Ok(())
}

pub(crate) fn check_uniform_params(a: &Axis, start: f64, step: f64) -> Result<(), String> {
    if !start.is_finite() {
        return Err(format!(
            "axis `{}`: uniform start {start} is not finite",
            a.name
        ));
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(format!(
            "axis `{}`: uniform step {step} is not finite and > 0",
            a.name
        ));
    }
    Ok(())
}

/// The rules of a symmetric axis (format 3.0, `docs/table-format.md`, "Symmetric axes"): the
/// period is > 0 (a JSON number is finite), the axis has at least 2 samples, its first
/// coordinate is 0 and its last is period/2, both computed in f64 as every reader does.
pub(crate) fn check_symmetry(a: &Axis) -> Result<(), String> {
    let Some(symmetry) = a.symmetry else {
        return Ok(());
    };
    let period = symmetry.period();
    if !(period.is_finite() && period > 0.0) {
        return Err(format!(
            "axis `{}`: symmetry.period {period} is not finite and > 0",
            a.name
        ));
    }
    let n = a.len();
    if n < 2 {
        return Err(format!(
            "axis `{}`: an even-periodic axis needs at least 2 samples (it has {n})",
            a.name
        ));
    }
    let (first, last, half) = (a.coord(0), a.coord(n - 1), 0.5 * period);
    if first != 0.0 {
        return Err(format!(
            "axis `{}`: an even-periodic axis starts at 0 (its first coordinate is {first})",
            a.name
        ));
    }
    if last != half {
        return Err(format!(
            "axis `{}`: an even-periodic axis ends at half its period, {half} (its last \
             coordinate is {last})",
            a.name
        ));
    }
    Ok(())
}
