//! Interpolation helpers (1-D and N-D multilinear) shared by stages, exporters and the table
//! reader. Clamping rule everywhere: coordinates outside an axis are clamped to its end points
//! (no extrapolation).

/// Locate `x` on a sorted, strictly increasing grid: returns `(i, t)` with
/// `x ≈ grid[i] + t (grid[i+1] − grid[i])`, `t ∈ [0, 1]`, clamped at both ends.
/// A grid of one point returns `(0, 0.0)`.
pub fn locate(grid: &[f64], x: f64) -> (usize, f64) {
    let n = grid.len();
    if n < 2 || x.is_nan() || x <= grid[0] {
        return (0, 0.0);
    }
    if x >= grid[n - 1] {
        return (n - 2, 1.0);
    }
    // partition_point: first index with grid[i] > x.
    let hi = grid.partition_point(|&g| g <= x);
    let i = hi - 1;
    let t = (x - grid[i]) / (grid[i + 1] - grid[i]);
    (i, t)
}

/// Locate `x` on a uniform grid `start + k·step`, `k = 0..n`, clamped.
pub fn locate_uniform(start: f64, step: f64, n: usize, x: f64) -> (usize, f64) {
    if n < 2 || x.is_nan() {
        return (0, 0.0);
    }
    let u = ((x - start) / step).clamp(0.0, (n - 1) as f64);
    let i = (u.floor() as usize).min(n - 2);
    (i, u - i as f64)
}

/// Linear interpolation of `values` on a uniform grid, clamped at the ends.
pub fn interp1_uniform(values: &[f64], start: f64, step: f64, x: f64) -> f64 {
    if values.len() == 1 {
        return values[0];
    }
    let (i, t) = locate_uniform(start, step, values.len(), x);
    values[i] * (1.0 - t) + values[i + 1] * t
}

/// Linear interpolation of `values` on the sorted grid `grid`, clamped at the ends.
pub fn interp1(grid: &[f64], values: &[f64], x: f64) -> f64 {
    debug_assert_eq!(grid.len(), values.len());
    if values.len() == 1 {
        return values[0];
    }
    let (i, t) = locate(grid, x);
    values[i] * (1.0 - t) + values[i + 1] * t
}

/// Multilinear interpolation over a row-major N-D array.
///
/// `positions[d] = (i_d, t_d)` are per-axis cells from [`locate`]; `shape[d]` the axis lengths;
/// `fetch(flat_index)` returns the stored value. Axes of length 1 contribute weight 1.
pub fn multilinear(
    positions: &[(usize, f64)],
    shape: &[usize],
    fetch: impl Fn(usize) -> f64,
) -> f64 {
    let dims = positions.len();
    debug_assert_eq!(dims, shape.len());
    let mut acc = 0.0;
    for corner in 0..(1usize << dims) {
        let mut weight = 1.0;
        let mut flat = 0usize;
        let mut skip = false;
        for d in 0..dims {
            let bit = (corner >> d) & 1;
            let (i, t) = positions[d];
            if shape[d] == 1 {
                if bit == 1 {
                    skip = true;
                    break;
                }
                flat *= 1;
                continue;
            }
            let w = if bit == 1 { t } else { 1.0 - t };
            weight *= w;
            flat = flat * shape[d] + i + bit;
        }
        if skip || weight == 0.0 {
            continue;
        }
        acc += weight * fetch(flat);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locate_clamps_and_interpolates() {
        let g = [0.0, 1.0, 3.0];
        assert_eq!(locate(&g, -1.0), (0, 0.0));
        assert_eq!(locate(&g, 5.0), (1, 1.0));
        let (i, t) = locate(&g, 2.0);
        assert_eq!(i, 1);
        assert!((t - 0.5).abs() < 1e-15);
        assert_eq!(interp1(&g, &[0.0, 2.0, 6.0], 2.0), 4.0);
    }

    #[test]
    fn multilinear_reproduces_bilinear_function() {
        // f(x, y) = 1 + 2x + 3y + 4xy is reproduced exactly by bilinear interpolation.
        let gx = [0.0, 1.0, 2.0];
        let gy = [0.0, 0.5, 1.0, 4.0];
        let f = |x: f64, y: f64| 1.0 + 2.0 * x + 3.0 * y + 4.0 * x * y;
        let mut data = vec![];
        for &x in &gx {
            for &y in &gy {
                data.push(f(x, y));
            }
        }
        for &(x, y) in &[(0.3, 0.7), (1.9, 3.0), (1.0, 0.5)] {
            let p = [locate(&gx, x), locate(&gy, y)];
            let v = multilinear(&p, &[3, 4], |k| data[k]);
            assert!((v - f(x, y)).abs() < 1e-12);
        }
    }
}
