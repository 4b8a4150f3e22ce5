//! Compact 2-D phase tables (decision RT-39): each dense entry renormalised, seen through the
//! sun's disc and resampled onto its own adaptive knots ([`super::compact`]); the table holds
//! the entries on the union of their knots, with the header's record of the operator and the
//! errors measured ([`super::phase_table_headers`]).

use super::compact::{self, CompactEntry, Components, StoredValues, SunDiscResampled};
use super::phase_table::PhaseTable;
use crate::table::codec::{MEAN, NORMALIZED_DIFFERENCE, TOP16_MAX_RELATIVE_ERROR};
use crate::table::{Axis, AxisPoints, Derived, PreviousRow, Symmetry, TableContent, ValueEncoding};
use serde_json::{Map, Value, json};

/// One compact entry with its dense entry's bin-sum and the airy-local transfer weights of its
/// azimuth columns (empty for the other models).
pub struct CompactPart {
    pub integral: f64,
    pub entry: CompactEntry,
    pub domain_weights: Vec<f64>,
}

impl PhaseTable {
    /// A dense 2-D entry's `values` divided by its bin-sum `integral` (checked by the caller),
    /// seen through the sun's disc of `spec` and compacted; the caller compares its measured
    /// error ([`compact::entry_error`]) with the tolerance.
    pub fn compact_entry(
        &self,
        mut values: Vec<f32>,
        integral: f64,
        spec: &SunDiscResampled,
    ) -> CompactEntry {
        let grid = self.direction_grid();
        let nch = self.n_channels();
        self.renormalise_entry(&mut values, integral);
        let mirror = self.compact_mirror();
        let filtered = |c: usize| {
            let v: Vec<f64> = values
                .iter()
                .skip(c)
                .step_by(nch)
                .map(|&x| x as f64)
                .collect();
            compact::disc_filter_symmetric(&v, grid, spec.sigma_deg(), mirror)
        };
        let (i_perp, i_par) = (filtered(1), filtered(2));
        drop(values);
        let c = Components {
            grid,
            i_perp: &i_perp,
            i_par: &i_par,
            mirror,
        };
        compact::compact_entry(&c, spec)
    }

    /// Whether compact entries store 0°–180° of azimuth only: the dense entries are mirror
    /// symmetric (`mirror_half`, or `mirror_symmetrise`, the default) and 180° is a sample of
    /// their grid (an even azimuth count). The exact table has the symmetry (the drop is a
    /// surface of revolution about the vertical, the sun in the plane φ = 0; decision RT-24), so
    /// the other half is its mirror image, which the table's symmetric azimuth axis tells every
    /// reader's lookup (table format 3.0).
    pub fn compact_mirror(&self) -> bool {
        let s = &self.spec;
        self.two_d()
            && (s.mirror_half || s.mirror_symmetrise)
            && self.direction_grid().n_azimuth.is_multiple_of(2)
    }

    /// The compact table from its entries in table order, on top of the phase-table
    /// contract's `attributes`: the entries on the union of their knots.
    pub fn compact_content(
        &self,
        parts: Vec<CompactPart>,
        spec: SunDiscResampled,
        attributes: Map<String, Value>,
    ) -> TableContent {
        let mut at = attributes;
        self.insert_common_attributes(&mut at);
        let (mut ints, mut entries, mut weights) = (vec![], vec![], vec![]);
        for p in parts {
            ints.push(p.integral);
            entries.push(p.entry);
            weights.push(p.domain_weights);
        }
        let (polar, azimuth, data) = compact::merge_entries(&entries);
        if spec.values == StoredValues::Top16 {
            widen_for_merged_rounding(&mut entries, &polar, &azimuth);
        }
        if self.domain_values() > 0 {
            let w: Vec<&[f64]> = weights.iter().map(Vec::as_slice).collect();
            at.insert("airy_local_domain".into(), self.domain_attribute(&w));
        }
        let mut axes = self.axes();
        let step = |axis: &Axis| match axis.points {
            AxisPoints::Uniform { step, .. } => step,
            AxisPoints::Values(_) => unreachable!("the dense grid is uniform"),
        };
        let (dp, da) = (step(&axes[3]), step(&axes[4]));
        axes[3] = Axis::values(
            "outgoing_polar",
            "deg",
            polar.iter().map(|&j| j as f64 * dp).collect(),
        );
        let mut az: Vec<f64> = azimuth.iter().map(|&k| k as f64 * da).collect();
        axes[4] = if self.compact_mirror() {
            // The knots end at the dense grid's 180° sample, exactly 180° (period/2).
            *az.last_mut().expect("two knots at least") = 180.0;
            Axis::values("outgoing_azimuth", "deg", az)
                .with_symmetry(Symmetry::EvenPeriodic { period: 360.0 })
        } else {
            Axis::values("outgoing_azimuth", "deg", az)
        };
        let mut t = self.content_2d(data, &ints, at, axes);
        t.attributes.insert("integral_check".into(), json!({"what": "bin-sum of phase over 4π per entry of the dense table before renormalisation; every channel but dolp of the dense entry was divided by it, then seen through the sun's disc and resampled (compression)", "values": ints}));
        t.attributes.insert("angular_resampling".into(), "compact: the dense entries (point samples of the coherent patch sum on the uniform grid of the compression's dense_grid, renormalised) seen through the sun's disc, then sampled at the outgoing_polar and outgoing_azimuth knots (compression); bilinear interpolation between knots is the table's value".into());
        t.attributes.insert(
            "compression".into(),
            self.compression_attribute(spec, &entries, &polar, &azimuth),
        );
        // The disc consumers find already applied (docs/consumers.md): they convolve only the
        // difference to the disc they show.
        t.attributes
            .insert("sun_diameter_deg".into(), spec.sun_diameter_deg.into());
        if spec.values == StoredValues::Top16 {
            store_top16(&mut t, polar.len(), azimuth.len());
        }
        t
    }
}

/// i_perp and i_par stored as 16-bit codes, one polar row of knots predicting the next within
/// an entry; phase and dolp derived from them (`docs/table-format.md`, "16-bit values").
fn store_top16(t: &mut TableContent, n_polar: usize, n_azimuth: usize) {
    let row = 2 * n_azimuth as u64;
    t.encoding = ValueEncoding::Top16 {
        predictor: Some(PreviousRow {
            stride: row,
            block: row * n_polar as u64,
        }),
    };
    for c in &mut t.channels {
        let op = match c.name.as_str() {
            "phase" => MEAN,
            "dolp" => NORMALIZED_DIFFERENCE,
            _ => continue,
        };
        c.derived = Some(Derived {
            op: op.into(),
            of: vec!["i_perp".into(), "i_par".into()],
        });
    }
}

/// The errors of entries whose knots are fewer than the table's (`polar`, `azimuth`): at the
/// other knots their interpolant is rounded to 16-bit codes once more, which moves a lookup by
/// at most 2^−9 of the interpolated i_perp or i_par, i.e. of (2 + e) × phase for an entry of
/// error e; the stated errors grow by that bound (measured on the entry's own knots, where the
/// codes are those measured).
fn widen_for_merged_rounding(entries: &mut [CompactEntry], polar: &[usize], azimuth: &[usize]) {
    for e in entries {
        if e.polar_rows == polar && e.azimuth_positions == azimuth {
            continue;
        }
        for w in &mut e.errors {
            w.rms_relative += TOP16_MAX_RELATIVE_ERROR * (2.0 + w.max_relative);
            w.max_relative += TOP16_MAX_RELATIVE_ERROR * (2.0 + w.max_relative);
        }
    }
}
