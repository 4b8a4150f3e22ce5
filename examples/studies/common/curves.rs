//! Shared by the examples that read features off sampled phase curves: window means and
//! local maxima on a uniform angle grid (degrees).

/// Mean of `v` over the samples whose angle lies in [lo, hi].
pub fn window_mean(angles: &[f64], v: &[f64], lo: f64, hi: f64) -> f64 {
    let w: Vec<f64> = angles
        .iter()
        .zip(v)
        .filter(|(a, _)| (lo..=hi).contains(*a))
        .map(|(_, x)| *x)
        .collect();
    w.iter().sum::<f64>() / w.len() as f64
}

/// Local maxima of `v` within [lo, hi] above `floor`, refined by a parabola through the
/// maximum and its two neighbours.
pub fn maxima(angles: &[f64], v: &[f64], lo: f64, hi: f64, floor: f64) -> Vec<f64> {
    (1..v.len() - 1)
        .filter(|&i| {
            angles[i] >= lo
                && angles[i] <= hi
                && v[i] > v[i - 1]
                && v[i] >= v[i + 1]
                && v[i] > floor
        })
        .map(|i| {
            let (a, b, c) = (v[i - 1], v[i], v[i + 1]);
            let den = a - 2.0 * b + c;
            let off = if den != 0.0 { 0.5 * (a - c) / den } else { 0.0 };
            angles[i] + off * (angles[1] - angles[0])
        })
        .collect()
}
