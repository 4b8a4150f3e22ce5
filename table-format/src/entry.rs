//! One entry of a table: fixed indices of its leading axes select a contiguous run of the
//! row-major payload (`docs/table-format.md`, "Reading one entry").

use crate::model::{Axis, AxisPoints, Header};

/// The values `(first, count)` of the row-major payload that `entry` (indices of the first
/// `entry.len()` axes) selects: every sample of the remaining axes, all channels. Errors name
/// the axis.
pub(crate) fn entry_values(header: &Header, entry: &[usize]) -> Result<(u64, u64), String> {
    let axes = &header.axes;
    if entry.len() > axes.len() {
        let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
        return Err(format!(
            "{} indices {entry:?}, more than the table's axes ({})",
            entry.len(),
            names.join(", ")
        ));
    }
    // The header is verified: every product fits the 64-bit payload size.
    let mut first = 0u64;
    for (a, &i) in axes.iter().zip(entry) {
        if i >= a.len() {
            return Err(format!(
                "index {i} of axis `{}` is out of range (the axis has {} samples, indices 0 to {})",
                a.name,
                a.len(),
                a.len() - 1
            ));
        }
        first = first * a.len() as u64 + i as u64;
    }
    let count = axes[entry.len()..]
        .iter()
        .map(|a| a.len() as u64)
        .product::<u64>()
        * header.channels.len() as u64;
    Ok((first * count, count))
}

/// The header of the entry: each fixed axis holds its chosen sample alone (coordinate and label,
/// without the axis's symmetry), the layout's shape follows; everything else is the file's
/// header.
pub(crate) fn entry_header(header: &Header, entry: &[usize]) -> Header {
    let mut h = header.clone();
    for (a, &i) in h.axes.iter_mut().zip(entry) {
        *a = fixed_axis(a, i);
    }
    for (s, a) in h.layout.shape.iter_mut().zip(&h.axes) {
        *s = a.len();
    }
    h
}

/// Axis `a` reduced to its sample `i` (a uniform axis stays uniform, starting there).
fn fixed_axis(a: &Axis, i: usize) -> Axis {
    let points = match &a.points {
        AxisPoints::Values(v) => AxisPoints::Values(vec![v[i]]),
        AxisPoints::Uniform { step, .. } => AxisPoints::Uniform {
            start: a.coord(i),
            step: *step,
            count: 1,
        },
    };
    Axis {
        name: a.name.clone(),
        unit: a.unit.clone(),
        points,
        labels: a.label(i).map(|l| vec![l.to_string()]).unwrap_or_default(),
        // One sample is constant under any coordinate: the symmetry no longer applies.
        symmetry: None,
    }
}
