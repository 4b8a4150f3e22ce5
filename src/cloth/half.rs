//! Half-vector coordinates of the cloth tables (decision CLOTH-18).
//!
//! The half vector of a light/view pair is `h = (ω_i + ω_r)/|ω_i + ω_r|`. Its two **projected
//! half angles** are `β_x = atan2(h_x, h_z)` (its tilt toward the warp, `+x`) and
//! `β_y = atan2(h_y, h_z)` (toward the weft, `+y`), so `h ∝ (tan β_x, tan β_y, 1)`. A tangent
//! sample of the warp at elevation α (`t = (cos α, 0, sin α)`) reflects the light specularly
//! where the thread-frame `θ_h` of eq. 5.7 vanishes, i.e. `asin(ω_i·t) = −asin(ω_r·t)`, i.e.
//! `h·t = 0`, i.e. `β_x = −α` exactly, whatever the light; a weft sample does so at `β_y = −α`.
//! In `(β_x, β_y)` every highlight of a flat stretch is a line parallel to an axis and does not
//! move with the light, which is why the tables use them as their view axes. The lobe width in
//! `β` is at least the thread's γ (it is `γ cos θ_i,t / (cos θ_d |h_xz|)` near the lobe, with
//! `θ_d` the angle between `ω_i` and `h`).

use crate::math::vec3::dot;

/// Unit half vector of projected half angles `(β_x, β_y)` (degrees, each in (−90°, 90°)).
pub fn half_direction(beta_x_deg: f64, beta_y_deg: f64) -> [f64; 3] {
    let (a, b) = (beta_x_deg.to_radians().tan(), beta_y_deg.to_radians().tan());
    let n = (1.0 + a * a + b * b).sqrt();
    [a / n, b / n, 1.0 / n]
}

/// Projected half angles `(β_x, β_y)` (degrees) of a direction with `h_z > 0`.
pub fn half_angles_deg(h: [f64; 3]) -> (f64, f64) {
    (h[0].atan2(h[2]).to_degrees(), h[1].atan2(h[2]).to_degrees())
}

/// Solid angle of `h` per unit `dβ_x dβ_y` (sr per rad²):
/// `sec²β_x sec²β_y / (1 + tan²β_x + tan²β_y)^{3/2}` (the gnomonic map onto `z = 1`).
pub fn half_jacobian(beta_x_deg: f64, beta_y_deg: f64) -> f64 {
    let (x, y) = (beta_x_deg.to_radians(), beta_y_deg.to_radians());
    let (a, b) = (x.tan(), y.tan());
    let sec2 = (1.0 + a * a) * (1.0 + b * b);
    sec2 / (1.0 + a * a + b * b).powf(1.5)
}

/// The half vector of a pair, `None` when `ω_i + ω_r` is zero or does not point above the
/// cloth plane.
pub fn half_of(wi: [f64; 3], wr: [f64; 3]) -> Option<[f64; 3]> {
    let s = [wi[0] + wr[0], wi[1] + wr[1], wi[2] + wr[2]];
    let n = dot(s, s).sqrt();
    (n > 0.0 && s[2] > 0.0).then(|| s.map(|x| x / n))
}

/// The view direction whose half vector with `wi` is `h`: `2 (ω_i·h) h − ω_i`.
pub fn reflect(wi: [f64; 3], h: [f64; 3]) -> [f64; 3] {
    let c = 2.0 * dot(wi, h);
    [c * h[0] - wi[0], c * h[1] - wi[1], c * h[2] - wi[2]]
}

/// Growth of the axis spacing per degree away from the lobe range.
const SPACING_GROWTH: f64 = 0.3;

/// Nodes of one half-angle axis on `[−max, max]` (degrees), 0 included: spacing `fine` over
/// `lobes` (the β range of a family's flat stretches and ramps) growing by
/// `SPACING_GROWTH` per degree away from it, at most `coarse`; the last step on each side is
/// stretched or shrunk to end exactly at `±max`.
pub fn half_axis(lobes: (f64, f64), fine: f64, coarse: f64, max: f64) -> Vec<f64> {
    let spacing = |b: f64| {
        let d = (lobes.0 - b).max(b - lobes.1).max(0.0);
        (fine + SPACING_GROWTH * d).min(coarse)
    };
    let side = |sign: f64| {
        let (mut out, mut x) = (Vec::new(), 0.0f64);
        loop {
            let s = spacing(sign * x);
            let s = s.min(spacing(sign * (x + s)));
            if x + 1.5 * s >= max {
                out.push(sign * max);
                return out;
            }
            x += s;
            out.push(sign * x);
        }
    };
    let mut axis: Vec<f64> = side(-1.0).into_iter().rev().collect();
    axis.push(0.0);
    axis.extend(side(1.0));
    axis
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_angles_round_trip_and_the_jacobian_integrates_to_the_hemisphere() {
        for (x, y) in [(0.0, 0.0), (30.0, -20.0), (-75.0, 60.0)] {
            let (a, b) = half_angles_deg(half_direction(x, y));
            assert!((a - x).abs() < 1e-12 && (b - y).abs() < 1e-12);
        }
        let n = 400;
        let d = 180.0 / n as f64;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (-90.0 + (i as f64 + 0.5) * d, -90.0 + (j as f64 + 0.5) * d);
                sum += half_jacobian(x, y) * d.to_radians() * d.to_radians();
            }
        }
        assert!(
            (sum / (2.0 * std::f64::consts::PI) - 1.0).abs() < 2e-3,
            "{sum}"
        );
    }

    #[test]
    fn a_warp_sample_reflects_at_minus_alpha() {
        let alpha = 20f64.to_radians();
        let t = [alpha.cos(), 0.0, alpha.sin()];
        let wi = crate::cloth::direction(0.6, 0.4);
        let wr = reflect(wi, half_direction(-20.0, 13.0));
        let (si, sr) = (dot(wi, t), dot(wr, t));
        assert!((si + sr).abs() < 1e-12, "{si} {sr}");
    }

    #[test]
    fn axes_are_fine_on_the_lobes_and_end_at_the_limits() {
        let a = half_axis((-32.0, 32.0), 0.8, 5.0, 88.0);
        assert_eq!((a[0], a[a.len() - 1]), (-88.0, 88.0));
        assert!(a.contains(&0.0));
        assert!(a.windows(2).all(|w| w[1] > w[0]));
        let widest_inside = a
            .windows(2)
            .filter(|w| w[0] >= -32.0 && w[1] <= 32.0)
            .map(|w| w[1] - w[0])
            .fold(0.0, f64::max);
        assert!(widest_inside <= 0.8 + 1e-9, "{widest_inside}");
        let widest = a.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
        assert!(widest <= 1.5 * 5.0, "{widest}");
    }
}
