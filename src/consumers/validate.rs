//! Like-with-like validation of a phase-function table against a reference curve.
//!
//! A table of the `mie` or `debye` stage is not a point evaluation: each value is the
//! solid-angle average over its angle bin of the sphere's curve after the sun's disc (and an
//! optional Gaussian) was applied (header attributes `angular_resampling`, `sun_diameter_deg`,
//! `gaussian_sigma_deg`). A reference printed by `scatterbake mie`, MiePlot or miepython is a
//! point evaluation: at a 400 µm drop its ripple has a period of ~0.05°, so comparing it
//! point by point with 0.05° bins disagrees by orders of magnitude although both are right.
//!
//! [`apply_table_operators`] therefore takes a point reference through the table's own
//! operators, in the order the stages apply them:
//!
//! 1. point values → cell averages on the reference's own uniform grid (step `δ`): each cell
//!    `[θ_j − δ/2, θ_j + δ/2]` integrates the quadratic through the three nearest samples
//!    times `sin θ` with a 4-point Gauss–Legendre rule (fourth order in `δ`: exact for cubics
//!    in the interior, by symmetry);
//! 2. cell averages → the table's intermediate grid (the one its disc acts on), the sun-disc
//!    operator with the table's diameter, the Gaussian with the table's σ, and the solid-angle
//!    average over the table's bins — the same operators (`crate::mie::filters`) with the same
//!    grids the stage used, so the only difference left is the physics and the reference's own
//!    sampling.
//!
//! The reference's sampling error is estimated by doing step 1 again on every other sample
//! (step `2δ`): for a fourth-order rule the error at `δ` is about `|A(δ) − A(2δ)|/15`
//! (Richardson), reported as [`OperatedReference::resolution_error`]. Bins whose support
//! (bin plus disc and Gaussian) is not covered by the reference are left out and counted.

use crate::consumers::ConsumerError;
use crate::consumers::export::mieplot::MiePlotData;
use crate::consumers::read::phase::{EntrySelection, PhaseTable};
use crate::mie::filters::FilterSettings;
use crate::mie::filters::{PolarisedPhase, SunDiscOperator, gaussian_blur, resample_bins};
use std::f64::consts::PI;

/// Table schemas whose angular operators [`apply_table_operators`] reproduces.
pub const OPERATOR_SCHEMAS: [&str; 2] = ["mie-phase", "debye-phase"];

/// What a reference file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceKind {
    /// Values of the curve at its angles (`scatterbake mie`, MiePlot, miepython): the table's
    /// operators are applied to it before comparing.
    Point,
    /// Values already averaged like the table's (an export of a table, `# table:` line):
    /// compared as they are.
    Binned,
}

/// What the comment and title lines of a reference file say about it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReferenceMetadata {
    /// Drop radius (µm): `# radius_um: R`, `# entry: radius=R um`, or a MiePlot-style
    /// `Radius = R µm` line (µm, um, nm or mm).
    pub radius_um: Option<f64>,
    /// Vacuum wavelength (nm): `# wavelength_nm: L` or `Wavelength = L µm` (µm, um or nm).
    pub wavelength_nm: Option<f64>,
    /// Size parameter and relative index from a `scatterbake mie` first line
    /// (`x = …, m = n + ki`).
    pub size_parameter: Option<f64>,
    pub relative_index: Option<(f64, f64)>,
    /// Entry coordinates from `# entry: name=value unit, …` lines of a table export.
    pub entry: Vec<EntrySelection>,
    /// The table a `# table:` line names (the file is an export of that table).
    pub source_table: Option<String>,
}

/// The number after `key` (`=` or `:` separated) on `line`, with its unit word if any.
fn number_after(line: &str, key: &str) -> Option<(f64, String)> {
    let lower = line.to_lowercase();
    let at = lower.find(key)? + key.len();
    let rest = line[at..].trim_start();
    let rest = rest
        .strip_prefix('=')
        .or_else(|| rest.strip_prefix(':'))?
        .trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '-' | '+')))
        .unwrap_or(rest.len());
    let value: f64 = rest[..end].parse().ok()?;
    let unit = rest[end..]
        .trim_start()
        .split(|c: char| c.is_whitespace() || c == ',' || c == ';')
        .next()
        .unwrap_or("")
        .to_string();
    Some((value, unit))
}

/// A length in `unit` (µm, um, nm, mm; none = `default_unit`) in nm.
fn length_nm(value: f64, unit: &str, default_nm_per_unit: f64) -> Option<f64> {
    let per = match unit.trim_end_matches('.').to_lowercase().as_str() {
        "nm" => 1.0,
        "µm" | "um" | "μm" | "micron" | "microns" => 1e3,
        "mm" => 1e6,
        "" => default_nm_per_unit,
        _ => return None,
    };
    Some(value * per)
}

impl ReferenceMetadata {
    /// Reads the header lines of a reference file (as kept by
    /// [`crate::consumers::export::mieplot::read_mieplot_layout`]).
    pub fn parse(header: &[String]) -> Self {
        let mut m = ReferenceMetadata::default();
        for raw in header {
            let line = raw.trim_start_matches('#').trim();
            let lower = line.to_lowercase();
            if let Some(v) = line.strip_prefix("table:") {
                m.source_table = Some(v.trim().to_string());
            } else if let Some(v) = line.strip_prefix("entry:") {
                for part in v.split(',') {
                    let mut words = part.split_whitespace();
                    if let Some(Ok(sel)) = words.next().map(|w| w.parse::<EntrySelection>()) {
                        m.entry.push(sel);
                    }
                }
            } else if let Some((v, _)) = number_after(line, "radius_um") {
                m.radius_um = Some(v);
            } else if let Some((v, _)) = number_after(line, "wavelength_nm") {
                m.wavelength_nm = Some(v);
            } else if lower.starts_with("lorenz-mie") {
                m.size_parameter = number_after(line, "x").map(|(v, _)| v);
                m.relative_index = parse_index_after(line, "m =");
            } else if lower.starts_with("radius") || lower.starts_with("particle radius") {
                if let Some((v, u)) = number_after(line, "radius") {
                    m.radius_um = length_nm(v, &u, 1e3).map(|nm| nm / 1e3);
                }
            } else if lower.starts_with("wavelength")
                && let Some((v, u)) = number_after(line, "wavelength")
            {
                m.wavelength_nm = length_nm(v, &u, 1e3);
            }
        }
        if m.radius_um.is_none()
            && let Some(r) = m.entry.iter().find(|e| e.axis == "radius")
        {
            m.radius_um = Some(r.value);
        }
        m
    }

    /// Point or binned, from the file's own lines: a `# table:` line marks an export of a
    /// table.
    pub fn kind(&self) -> ReferenceKind {
        if self.source_table.is_some() {
            ReferenceKind::Binned
        } else {
            ReferenceKind::Point
        }
    }

    /// The entry the reference describes, as selections on `pt`'s entry axes: `# entry:` lines
    /// first, else the radius on a `radius` axis.
    pub fn entry_for(&self, pt: &PhaseTable) -> Vec<EntrySelection> {
        if !self.entry.is_empty() {
            return self.entry.clone();
        }
        let axes = pt.table.axes();
        match self.radius_um {
            Some(r) if pt.entry_axes.iter().any(|&i| axes[i].name == "radius") => {
                vec![EntrySelection {
                    axis: "radius".into(),
                    value: r,
                }]
            }
            _ => Vec::new(),
        }
    }
}

/// `n + ki` after `key` (e.g. `m = 1.33 + 0i`).
fn parse_index_after(line: &str, key: &str) -> Option<(f64, f64)> {
    let at = line.find(key)? + key.len();
    let rest: String = line[at..].chars().filter(|c| !c.is_whitespace()).collect();
    let rest = rest.split(['(', ',']).next()?;
    let body = rest.strip_suffix('i').unwrap_or(rest);
    let bytes = body.as_bytes();
    let split = (1..bytes.len())
        .rev()
        .find(|&p| matches!(bytes[p], b'+' | b'-') && !matches!(bytes[p - 1], b'e' | b'E'))?;
    let (re, im) = body.split_at(split);
    Some((re.parse().ok()?, im.trim_start_matches('+').parse().ok()?))
}

/// The angular operators a table applied, read from its header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableOperators {
    /// Step of the table's angle bins (deg).
    pub bin_step_deg: f64,
    /// Sun-disc diameter the table averaged over (deg; 0 = none).
    pub sun_diameter_deg: f64,
    /// Gaussian σ the table applied after the disc (deg; 0 = none).
    pub gaussian_sigma_deg: f64,
}

impl TableOperators {
    /// The operators of a `mie-phase` or `debye-phase` table; other tables are refused with the
    /// reason (their angular resampling is not a bin average of a point curve).
    pub fn of(pt: &PhaseTable) -> Result<Self, ConsumerError> {
        let h = &pt.table.header;
        if !OPERATOR_SCHEMAS.contains(&h.schema.name.as_str()) {
            let how = h
                .attributes
                .get("angular_resampling")
                .and_then(|v| v.as_str())
                .unwrap_or("not stated");
            return Err(ConsumerError::invalid(format!(
                "a point reference can be taken through the angular operators of {OPERATOR_SCHEMAS:?} \
                 tables only; `{}` tables resample as follows: {how}. Compare against a reference \
                 exported from a table of the same kind, or pass --reference-kind binned to \
                 compare the values as they are (not like with like)",
                h.schema.name
            )));
        }
        let number = |key: &str| -> Result<f64, ConsumerError> {
            match h.attributes.get(key) {
                None => Ok(0.0),
                Some(v) => v
                    .as_f64()
                    .filter(|d| *d >= 0.0 && d.is_finite())
                    .ok_or_else(|| {
                        ConsumerError::layout(format!(
                            "attribute `{key}` is `{v}`, not a non-negative number of degrees"
                        ))
                    }),
            }
        };
        let angles = pt.angles_deg();
        let intervals = angles.len() - 1;
        let step = 180.0 / intervals as f64;
        if angles
            .iter()
            .enumerate()
            .any(|(j, a)| (a - step * j as f64).abs() > 1e-9 * step.max(1.0))
        {
            return Err(ConsumerError::layout(
                "the table's scattering_angle axis is not a uniform grid over [0, 180] deg",
            ));
        }
        Ok(TableOperators {
            bin_step_deg: step,
            sun_diameter_deg: number("sun_diameter_deg")?,
            gaussian_sigma_deg: number("gaussian_sigma_deg")?,
        })
    }

    /// Number of bins.
    pub fn intervals(&self) -> usize {
        (180.0 / self.bin_step_deg).round() as usize
    }

    fn settings(&self) -> FilterSettings {
        FilterSettings {
            output_intervals: self.intervals(),
            sun_diameter_deg: self.sun_diameter_deg,
            gaussian_sigma_deg: self.gaussian_sigma_deg,
            radius_points: 1,
            radius_tolerance: 0.0,
        }
    }

    /// One line saying what the operators are.
    pub fn describe(&self) -> String {
        let mut s = format!("solid-angle average over {} deg bins", self.bin_step_deg);
        if self.sun_diameter_deg > 0.0 {
            s += &format!(
                " of the curve averaged over a {} deg uniform sun disc",
                self.sun_diameter_deg
            );
        }
        if self.gaussian_sigma_deg > 0.0 {
            s += &format!(" and a Gaussian of sigma {} deg", self.gaussian_sigma_deg);
        }
        s
    }

    /// Half-width (deg) of the angles one bin depends on.
    pub fn support_half_width_deg(&self) -> f64 {
        0.5 * self.bin_step_deg + 0.5 * self.sun_diameter_deg + 5.0 * self.gaussian_sigma_deg
    }
}

/// A point reference taken through a table's operators.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatedReference {
    /// The reference on the table's bin centres that it covers.
    pub data: MiePlotData,
    /// Step of the reference's angle grid (deg).
    pub reference_step_deg: f64,
    /// Estimated relative error of the operated reference from its own sampling: max over the
    /// compared bins of `|A(δ) − A(2δ)| / (15 |A(δ)|)` (phase column).
    pub resolution_error: f64,
    /// Table bins left out because the reference does not cover their support.
    pub bins_left_out: usize,
}

/// Uniform grid of a reference: `(intervals M of [0°, 180°], index of the first sample)`.
fn uniform_grid(angles: &[f64]) -> Result<(usize, usize), ConsumerError> {
    let n = angles.len();
    if n < 5 {
        return Err(ConsumerError::invalid(format!(
            "a point reference needs at least 5 angles on a uniform grid to be averaged over bins; it has {n}"
        )));
    }
    let step = (angles[n - 1] - angles[0]) / (n - 1) as f64;
    let m_f = 180.0 / step;
    let m = m_f.round() as usize;
    let not_uniform = || {
        ConsumerError::invalid(format!(
            "the reference's angles are not a uniform grid whose step divides 180 deg (first {}, last {}, {} rows); \
             a point reference is averaged over the table's bins from a uniform grid (e.g. \
             `scatterbake mie --angle-step-deg 0.001`)",
            angles[0],
            angles[n - 1],
            n
        ))
    };
    if !(step > 0.0) || (m_f - m as f64).abs() > 1e-6 * m_f {
        return Err(not_uniform());
    }
    let delta = 180.0 / m as f64;
    let first = (angles[0] / delta).round() as usize;
    // printed angles are rounded: accept a quarter step
    if angles
        .iter()
        .enumerate()
        .any(|(j, a)| (a - delta * (first + j) as f64).abs() > 0.25 * delta)
    {
        return Err(not_uniform());
    }
    Ok((m, first))
}

/// 4-point Gauss–Legendre nodes and weights on [−1, 1].
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

/// Point samples `v[i]` at `θ = (first + i)·δ`, `δ = π/m` (radians), integrated against
/// `sin θ` over any interval by the quadratic through the three samples nearest each piece.
struct PointSamples<'a> {
    v: &'a [f64],
    m: usize,
    first: usize,
}

impl PointSamples<'_> {
    fn delta(&self) -> f64 {
        PI / self.m as f64
    }

    /// The three samples around grid node `k` as (previous, centre, next); at the poles the
    /// curve is even in θ (and in π − θ), so the missing neighbour is the mirror of the
    /// present one. `None` when the reference does not cover them.
    fn around(&self, k: usize) -> Option<[f64; 3]> {
        let at = |node: usize| {
            node.checked_sub(self.first)
                .and_then(|i| self.v.get(i))
                .copied()
        };
        let centre = at(k)?;
        let prev = if k == 0 { at(1)? } else { at(k - 1)? };
        let next = if k == self.m { at(k - 1)? } else { at(k + 1)? };
        Some([prev, centre, next])
    }

    /// `∫_a^b p(θ) sin θ dθ` for `0 ≤ a < b ≤ π`, split at the cell boundaries of the
    /// sample grid (each piece uses the quadratic of its own cell's centre); NaN when a piece
    /// is not covered.
    fn integral(&self, a: f64, b: f64) -> f64 {
        let d = self.delta();
        let k0 = ((a / d) + 0.5).floor().max(0.0) as usize;
        let k1 = (((b / d) + 0.5).floor() as usize).min(self.m);
        let mut total = 0.0;
        for k in k0..=k1 {
            let tc = k as f64 * d;
            let lo = (tc - 0.5 * d).max(a);
            let hi = (tc + 0.5 * d).min(b);
            if hi <= lo {
                continue;
            }
            let Some([pm, p0, pp]) = self.around(k) else {
                return f64::NAN;
            };
            let (h, c) = (0.5 * (hi - lo), 0.5 * (hi + lo));
            for (x, w) in GL4 {
                let t = c + h * x;
                let u = (t - tc) / d;
                let q = p0 + 0.5 * u * (pp - pm) + 0.5 * u * u * (pp - 2.0 * p0 + pm);
                total += w * h * q * t.sin();
            }
        }
        total
    }

    /// Averages over the cells `[θ_j − Δ/2, θ_j + Δ/2] ∩ [0, π]` of a grid of `intervals`
    /// cells (`Δ = π/intervals`).
    fn cell_averages(&self, intervals: usize) -> Vec<f64> {
        let d = PI / intervals as f64;
        (0..=intervals)
            .map(|j| {
                let lo = ((j as f64 - 0.5) * d).max(0.0);
                let hi = ((j as f64 + 0.5) * d).min(PI);
                self.integral(lo, hi) / (lo.cos() - hi.cos())
            })
            .collect()
    }
}

/// The table's operators on a point reference (grid of `m` intervals from sample `first`,
/// every `stride`-th sample): cell averages on the table's intermediate grid, the disc `sun`, the
/// Gaussian, the bins. NaN propagates to every bin whose support touches an uncovered piece.
fn operate(
    r: &MiePlotData,
    m: usize,
    first: usize,
    stride: usize,
    ops: &TableOperators,
    sun: Option<&SunDiscOperator>,
) -> PolarisedPhase {
    let mid = ops.settings().intermediate_intervals();
    let cells = |v: &[f64]| {
        let picked: Vec<f64> = v.iter().step_by(stride).copied().collect();
        PointSamples {
            v: &picked,
            m: m / stride,
            first: first / stride,
        }
        .cell_averages(mid)
    };
    let mut c = PolarisedPhase {
        step_deg: 180.0 / mid as f64,
        i_perp: cells(&r.i_perp),
        i_par: cells(&r.i_par),
    };
    if let Some(sun) = sun {
        c = sun.apply(&c);
    }
    let c = gaussian_blur(&c, ops.gaussian_sigma_deg);
    resample_bins(&c, ops.intervals())
}

/// Take a point reference through the table's operators (see the module doc). The reference
/// must sample a uniform grid whose step divides 180° and is at most the table's bin step.
pub fn apply_table_operators(
    r: &MiePlotData,
    ops: &TableOperators,
) -> Result<OperatedReference, ConsumerError> {
    let (m, first) = uniform_grid(&r.angle_deg)?;
    let delta = 180.0 / m as f64;
    if delta > ops.bin_step_deg * (1.0 + 1e-9) {
        return Err(ConsumerError::invalid(format!(
            "the reference's angle step {delta} deg is coarser than the table's {} deg bins: a bin \
             average needs several samples per bin (e.g. `scatterbake mie --angle-step-deg 0.001`)",
            ops.bin_step_deg
        )));
    }
    // the disc operator depends only on the grid and the diameter: built once for both passes
    let sun = (ops.sun_diameter_deg > 0.0).then(|| ops.settings().sun_operator());
    let fine = operate(r, m, first, 1, ops, sun.as_ref());
    // the coarse estimate needs the grid of every other sample
    let coarse = (m.is_multiple_of(2) && first.is_multiple_of(2))
        .then(|| operate(r, m, first, 2, ops, sun.as_ref()));
    let phase = fine.phase();
    let coarse_phase = coarse.as_ref().map(|c| c.phase());
    let mut data = MiePlotData {
        wavelength_nm: r.wavelength_nm,
        ..Default::default()
    };
    let (mut left_out, mut resolution) = (0usize, 0.0f64);
    for j in 0..phase.len() {
        let values = [fine.i_perp[j], fine.i_par[j], phase[j]];
        if values.iter().any(|v| !v.is_finite()) {
            left_out += 1;
            continue;
        }
        if let Some(cp) = &coarse_phase
            && cp[j].is_finite()
            && phase[j] != 0.0
        {
            resolution = resolution.max((phase[j] - cp[j]).abs() / (15.0 * phase[j].abs()));
        }
        data.angle_deg.push(fine.angle_deg(j));
        data.i_perp.push(values[0]);
        data.i_par.push(values[1]);
        data.phase.push(values[2]);
    }
    if data.angle_deg.is_empty() {
        return Err(ConsumerError::invalid(format!(
            "the reference (angles {} … {} deg) covers no whole bin support of the table ({}: \
             each bin needs the reference within ±{} deg of its centre)",
            r.angle_deg[0],
            r.angle_deg[r.angle_deg.len() - 1],
            ops.describe(),
            ops.support_half_width_deg()
        )));
    }
    Ok(OperatedReference {
        data,
        reference_step_deg: delta,
        resolution_error: if coarse.is_some() {
            resolution
        } else {
            f64::NAN
        },
        bins_left_out: left_out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_of_our_outputs_and_of_mieplot_style_titles() {
        let h: Vec<String> = [
            "# Lorenz-Mie (Bohren & Huffman conventions), x = 3866.57, m = 1.3316 + 0.5e-8i (relative to the medium)",
            "# radius_um: 400",
            "# wavelength_nm: 650",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let m = ReferenceMetadata::parse(&h);
        assert_eq!(m.radius_um, Some(400.0));
        assert_eq!(m.wavelength_nm, Some(650.0));
        assert_eq!(m.size_parameter, Some(3866.57));
        assert_eq!(m.relative_index, Some((1.3316, 0.5e-8)));
        assert_eq!(m.kind(), ReferenceKind::Point);
        let t: Vec<String> = ["MiePlot v4.6", "Radius = 0.4 mm", "Wavelength = 0.65 µm"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let m = ReferenceMetadata::parse(&t);
        assert!((m.radius_um.unwrap() - 400.0).abs() < 1e-9);
        assert!((m.wavelength_nm.unwrap() - 650.0).abs() < 1e-9);
        let e: Vec<String> = ["# table: tables/x.sbt", "# entry: radius=500 um"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let m = ReferenceMetadata::parse(&e);
        assert_eq!(m.kind(), ReferenceKind::Binned);
        assert_eq!(m.radius_um, Some(500.0));
        assert_eq!(m.entry.len(), 1);
    }

    /// Cell averages of a smooth curve of cos θ, on a target grid that does not nest in the
    /// sample grid, against the exact integral: fourth order, poles included.
    #[test]
    fn cell_averages_are_fourth_order() {
        let f = |t: f64| {
            let mu = t.cos();
            2.0 + (6.0 * mu).sin() + mu * mu
        };
        // exact ∫ f sin over a cell, by a fine Gauss rule
        let exact = |lo: f64, hi: f64| {
            let (x, w) = crate::math::quadrature::gauss_legendre(40);
            let (h, c) = (0.5 * (hi - lo), 0.5 * (hi + lo));
            x.iter()
                .zip(&w)
                .map(|(x, w)| {
                    let t = c + h * x;
                    w * h * f(t) * t.sin()
                })
                .sum::<f64>()
                / (lo.cos() - hi.cos())
        };
        let target = 70;
        let err = |m: usize| {
            let d = PI / m as f64;
            let v: Vec<f64> = (0..=m).map(|j| f(j as f64 * d)).collect();
            let c = PointSamples { v: &v, m, first: 0 }.cell_averages(target);
            let dt = PI / target as f64;
            (0..=target)
                .map(|k| {
                    let lo = ((k as f64 - 0.5) * dt).max(0.0);
                    let hi = ((k as f64 + 0.5) * dt).min(PI);
                    (c[k] - exact(lo, hi)).abs()
                })
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(180), err(360));
        assert!(e1 < 1e-5, "{e1}");
        assert!(e1 / e2 > 12.0, "order: {e1} / {e2}");
    }

    /// A point curve taken through the operators equals the stage's own chain on the same
    /// sphere, where the stage integrates cells with Gauss points of the exact series.
    #[test]
    fn operated_point_curve_matches_the_stage_chain() {
        use crate::mie::Sphere;
        use crate::mie::filters::{FINE_CELL_POINTS, fine_intervals};
        use num_complex::Complex64;
        let sphere = Sphere::new(300.0, Complex64::new(1.333, 0.0)).unwrap();
        let ops = TableOperators {
            bin_step_deg: 0.5,
            sun_diameter_deg: 2.0,
            gaussian_sigma_deg: 0.0,
        };
        // the stage: exact cell averages, intermediate grid, disc, bins
        let mid = ops.settings().intermediate_intervals();
        let fine_m = mid * fine_intervals(sphere.coefficients.n_stop(), mid).div_ceil(mid);
        let exact = PolarisedPhase::from_sphere(&sphere, fine_m, FINE_CELL_POINTS, false);
        let exact = resample_bins(&exact, mid);
        let exact = SunDiscOperator::new(mid, ops.sun_diameter_deg).apply(&exact);
        let table = resample_bins(&exact, ops.intervals());
        // the reference: point values every 0.01 deg, normalised like the table
        let m = 18_000;
        let angles: Vec<f64> = (0..=m).map(|j| 180.0 * j as f64 / m as f64).collect();
        let (s1, s2) = sphere.amplitudes_deg(&angles);
        let norm = sphere.phase_normalisation();
        let i_perp: Vec<f64> = s1.iter().map(|s| s.norm_sqr() / norm).collect();
        let i_par: Vec<f64> = s2.iter().map(|s| s.norm_sqr() / norm).collect();
        let phase = i_perp
            .iter()
            .zip(&i_par)
            .map(|(a, b)| 0.5 * (a + b))
            .collect();
        let r = MiePlotData {
            wavelength_nm: None,
            angle_deg: angles,
            i_perp,
            i_par,
            phase,
        };
        let o = apply_table_operators(&r, &ops).unwrap();
        assert_eq!(o.bins_left_out, 0);
        assert_eq!(o.data.angle_deg.len(), 361);
        let tp = table.phase();
        let worst = o
            .data
            .phase
            .iter()
            .zip(&tp)
            .map(|(a, b)| (a - b).abs() / b)
            .fold(0.0, f64::max);
        assert!(worst < 1e-7, "worst relative difference {worst}");
        assert!(o.resolution_error < 1e-6, "{}", o.resolution_error);
        // and point-by-point comparison would not have agreed (the test can fail)
        let point_gap = r
            .phase
            .iter()
            .step_by(50)
            .zip(&tp)
            .map(|(a, b)| (a - b).abs() / b)
            .fold(0.0, f64::max);
        assert!(point_gap > 1e-2, "{point_gap}");
    }

    #[test]
    fn partial_and_bad_references() {
        let ops = TableOperators {
            bin_step_deg: 0.5,
            sun_diameter_deg: 1.0,
            gaussian_sigma_deg: 0.0,
        };
        let part = |lo: usize, hi: usize, step: f64| {
            let angles: Vec<f64> = (lo..=hi).map(|j| j as f64 * step).collect();
            let ones = vec![1.0; angles.len()];
            MiePlotData {
                wavelength_nm: None,
                angle_deg: angles,
                i_perp: ones.clone(),
                i_par: ones.clone(),
                phase: ones,
            }
        };
        // 100–120 deg at 0.01: bins from 101 to 119 are covered (support ±0.75 deg)
        let o = apply_table_operators(&part(10_000, 12_000, 0.01), &ops).unwrap();
        let first = o.data.angle_deg[0];
        let last = *o.data.angle_deg.last().unwrap();
        assert!((100.5..=101.0).contains(&first), "{first}");
        assert!((119.0..=119.5).contains(&last), "{last}");
        let worst = o
            .data
            .phase
            .iter()
            .map(|p| (p - 1.0).abs())
            .fold(0.0, f64::max);
        // the disc operator keeps a constant to its discretisation (~2e-7 on this grid)
        assert!(worst < 1e-6, "{worst}");
        assert!(o.bins_left_out > 300);
        let coarse = apply_table_operators(&part(0, 180, 1.0), &ops).unwrap_err();
        assert!(coarse.to_string().contains("coarser"), "{coarse}");
        let mut odd = part(0, 1800, 0.1);
        odd.angle_deg[7] += 0.04;
        let e = apply_table_operators(&odd, &ops).unwrap_err();
        assert!(e.to_string().contains("uniform"), "{e}");
    }
}
