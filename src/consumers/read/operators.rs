//! What a table has already done to the light, and what a consumer may still do.
//!
//! A phase-function table is not a point evaluation: the stages average it over the sun's disc
//! (attribute `sun_diameter_deg`) and over angle bins (attribute `angular_resampling`). A
//! consumer that convolves the disc again shows a sun twice as wide (the bows of a 0.5°
//! table drop by ~9 % at their peak). Every consumer therefore plans its disc with
//! [`SunDisc::plan`], applies only [`SunDisc::extra_deg`] and states [`SunDisc::describe`].
//!
//! Coarse entry axes are the other trap: blending the 400 µm and 500 µm curves, or the 0° and
//! 30° sun elevations of a ray-traced table, superimposes two bows that no drop shows. Tables
//! list the axes along which linear interpolation is meaningful in the attribute
//! `interpolable_axes` ([`INTERPOLABLE_AXES_ATTRIBUTE`]); along any other axis a consumer takes
//! a stored sample ([`resolve_axis_value`]): a value between samples is refused with the
//! nearest sample named, a value outside the axis is refused with the axis range.

// The errors carry the axis samples so that the message can name the nearest one; they are
// built only on the refusal path.
#![allow(clippy::result_large_err)]

use crate::table::Table;

/// Diameter of the real sun's disc (deg) shown when a table states no disc and the consumer
/// gets no request.
pub const SUN_DIAMETER_DEG: f64 = 0.5;

/// Largest disc a consumer convolves (deg).
pub const MAX_SUN_DIAMETER_DEG: f64 = 10.0;

/// Name of the header attribute listing the interpolable axes.
pub const INTERPOLABLE_AXES_ATTRIBUTE: &str = "interpolable_axes";

/// Axes taken as interpolable when a table has no `interpolable_axes` attribute (tables
/// written before it existed): the spectral and angular axes, which every stage samples
/// finely; entry axes (radius, sun elevation, …) are not.
pub const DEFAULT_INTERPOLABLE_AXES: [&str; 4] = [
    "wavelength",
    "scattering_angle",
    "outgoing_polar",
    "outgoing_azimuth",
];

/// Relative tolerance for "the value is a stored sample".
const SAMPLE_TOLERANCE: f64 = 1e-9;

/// Why an operator cannot be planned or an axis value cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OperatorError {
    #[error(
        "--sun-diameter-deg {requested} is smaller than the {applied} deg sun disc the table \
         already averaged over (attribute `sun_diameter_deg`); a disc average cannot be undone: \
         request {applied} deg or more (or omit the option), or rebuild the table with a \
         smaller `sun_diameter_deg`"
    )]
    DiscSmallerThanApplied { requested: f64, applied: f64 },
    #[error("--sun-diameter-deg {0} must be within 0…{MAX_SUN_DIAMETER_DEG} deg")]
    DiscOutOfRange(f64),
    #[error("attribute `sun_diameter_deg` is `{0}`, not a non-negative number of degrees")]
    BadDiscAttribute(String),
    #[error(
        "{axis}={value} {unit} is outside the table's `{axis}` range [{lo}, {hi}] {unit}; \
         values outside a table are not extrapolated"
    )]
    OutOfRange {
        axis: String,
        unit: String,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(
        "{axis}={value} {unit} lies between the samples {below} and {above} {unit} of `{axis}`, \
         an axis the table does not declare interpolable (attribute `interpolable_axes`: \
         {declared:?}); blending neighbouring samples would superimpose the entries at two \
         different values of `{axis}`. Choose a stored sample: the nearest is {nearest} {unit} (samples {samples:?})"
    )]
    NotASample {
        axis: String,
        unit: String,
        value: f64,
        below: f64,
        above: f64,
        nearest: f64,
        declared: Vec<String>,
        samples: Vec<f64>,
    },
}

/// The sun disc of a consumer's output: what the table already averaged over, what the output
/// shows, and what the consumer still convolves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunDisc {
    /// Disc the table already averaged over (attribute `sun_diameter_deg`, 0 when absent).
    pub applied_deg: f64,
    /// Whether the table states `sun_diameter_deg` at all.
    pub stated: bool,
    /// Disc the output shows.
    pub target_deg: f64,
    /// Disc the consumer convolves: 0 when the table already shows the target, the target
    /// when the table is a point-sun table, otherwise √(target² − applied²), the disc whose
    /// angular variance (D²/16 per axis) makes up the difference (two disc averages in a row
    /// are not exactly a disc average; they agree in their second moment).
    pub extra_deg: f64,
}

impl SunDisc {
    /// Plan the disc for a table and an optional request. Without a request the output shows
    /// the table's own disc, or the real sun ([`SUN_DIAMETER_DEG`]) for a point-sun table.
    pub fn plan(table: &Table, requested: Option<f64>) -> Result<Self, OperatorError> {
        let (applied_deg, stated) = match table.header.attributes.get("sun_diameter_deg") {
            None => (0.0, false),
            Some(v) => match v.as_f64() {
                Some(d) if d >= 0.0 && d.is_finite() => (d, true),
                _ => return Err(OperatorError::BadDiscAttribute(v.to_string())),
            },
        };
        Self::from_applied(applied_deg, stated, requested)
    }

    /// [`SunDisc::plan`] for a known applied disc.
    pub fn from_applied(
        applied_deg: f64,
        stated: bool,
        requested: Option<f64>,
    ) -> Result<Self, OperatorError> {
        if let Some(r) = requested
            && !(0.0..=MAX_SUN_DIAMETER_DEG).contains(&r)
        {
            return Err(OperatorError::DiscOutOfRange(r));
        }
        let target_deg = match requested {
            Some(r) => r,
            None if applied_deg > 0.0 => applied_deg,
            None => SUN_DIAMETER_DEG,
        };
        let tol = 1e-9 * applied_deg.max(1.0);
        let extra_deg = if (target_deg - applied_deg).abs() <= tol {
            0.0
        } else if target_deg < applied_deg {
            return Err(OperatorError::DiscSmallerThanApplied {
                requested: target_deg,
                applied: applied_deg,
            });
        } else {
            (target_deg * target_deg - applied_deg * applied_deg).sqrt()
        };
        Ok(SunDisc {
            applied_deg,
            stated,
            target_deg,
            extra_deg,
        })
    }

    /// One line saying what the consumer did, e.g. "sun disc 0.5 deg: already averaged by the
    /// table (sun_diameter_deg = 0.5), none applied".
    pub fn describe(&self) -> String {
        let table = if self.stated {
            format!("sun_diameter_deg = {}", self.applied_deg)
        } else {
            "the table states no sun_diameter_deg: taken as a point sun".into()
        };
        if self.extra_deg == 0.0 {
            if self.target_deg == 0.0 {
                format!("point sun ({table}), no disc applied")
            } else {
                format!(
                    "sun disc {} deg: already averaged by the table ({table}), none applied",
                    self.target_deg
                )
            }
        } else if self.applied_deg == 0.0 {
            format!(
                "sun disc {} deg: applied by this command ({table})",
                self.target_deg
            )
        } else {
            format!(
                "sun disc {} deg: the table averaged {} deg ({table}); this command applied a \
                 further {:.4} deg disc (matching the second moment of the difference)",
                self.target_deg, self.applied_deg, self.extra_deg
            )
        }
    }
}

/// The axes of `table` along which linear interpolation is meaningful: the attribute
/// `interpolable_axes` (an array of axis names) or, without it, [`DEFAULT_INTERPOLABLE_AXES`].
pub fn interpolable_axes(table: &Table) -> Vec<String> {
    match table
        .header
        .attributes
        .get(INTERPOLABLE_AXES_ATTRIBUTE)
        .and_then(|v| v.as_array())
    {
        Some(a) => a
            .iter()
            .filter_map(|v| v.as_str().map(str::to_string))
            .collect(),
        None => DEFAULT_INTERPOLABLE_AXES
            .iter()
            .map(|s| s.to_string())
            .collect(),
    }
}

/// The value a consumer may use on axis `axis` of `table` for a requested `value`: inside the
/// axis range (else [`OperatorError::OutOfRange`]); on an axis that is not interpolable, a
/// stored sample (snapped exactly to it; a value between samples is
/// [`OperatorError::NotASample`], naming the nearest).
pub fn resolve_axis_value(table: &Table, axis: usize, value: f64) -> Result<f64, OperatorError> {
    let a = &table.axes()[axis];
    let c = a.coords();
    let (lo, hi) = (c[0], c[c.len() - 1]);
    let scale = lo.abs().max(hi.abs()).max(1.0);
    let tol = SAMPLE_TOLERANCE * scale;
    if value < lo - tol || value > hi + tol {
        return Err(OperatorError::OutOfRange {
            axis: a.name.clone(),
            unit: a.unit.clone(),
            value,
            lo,
            hi,
        });
    }
    let declared = interpolable_axes(table);
    if declared.contains(&a.name) {
        return Ok(value.clamp(lo, hi));
    }
    let nearest = c
        .iter()
        .copied()
        .min_by(|x, y| (x - value).abs().total_cmp(&(y - value).abs()))
        .unwrap_or(lo);
    if (nearest - value).abs() <= tol {
        return Ok(nearest);
    }
    let above = c.iter().copied().find(|&x| x > value).unwrap_or(hi);
    let below = c.iter().rev().copied().find(|&x| x < value).unwrap_or(lo);
    Err(OperatorError::NotASample {
        axis: a.name.clone(),
        unit: a.unit.clone(),
        value,
        below,
        above,
        nearest,
        declared,
        samples: c,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::henyey_greenstein_table;

    fn table(sun: Option<f64>) -> Table {
        let mut t = henyey_greenstein_table(&[550.0], &[400.0, 500.0], |_, _| 0.5, 181, 0.0);
        match sun {
            Some(d) => t
                .header
                .attributes
                .insert("sun_diameter_deg".into(), d.into()),
            None => t.header.attributes.remove("sun_diameter_deg"),
        };
        t
    }

    #[test]
    fn disc_already_applied_is_not_applied_again() {
        let d = SunDisc::plan(&table(Some(0.5)), None).unwrap();
        assert_eq!((d.applied_deg, d.target_deg, d.extra_deg), (0.5, 0.5, 0.0));
        assert!(d.describe().contains("none applied"), "{}", d.describe());
        let same = SunDisc::plan(&table(Some(0.5)), Some(0.5)).unwrap();
        assert_eq!(same.extra_deg, 0.0);
    }

    #[test]
    fn point_sun_tables_get_the_request_or_the_real_sun() {
        assert_eq!(
            SunDisc::plan(&table(Some(0.0)), None).unwrap().extra_deg,
            SUN_DIAMETER_DEG
        );
        assert_eq!(
            SunDisc::plan(&table(Some(0.0)), Some(0.0))
                .unwrap()
                .extra_deg,
            0.0
        );
        let unstated = SunDisc::plan(&table(None), Some(1.0)).unwrap();
        assert_eq!(unstated.extra_deg, 1.0);
        assert!(unstated.describe().contains("states no sun_diameter_deg"));
    }

    #[test]
    fn larger_request_applies_the_second_moment_difference_and_smaller_is_refused() {
        let d = SunDisc::plan(&table(Some(0.3)), Some(0.5)).unwrap();
        assert!((d.extra_deg - 0.4).abs() < 1e-12, "{}", d.extra_deg);
        let e = SunDisc::plan(&table(Some(0.5)), Some(0.25)).unwrap_err();
        assert_eq!(
            e,
            OperatorError::DiscSmallerThanApplied {
                requested: 0.25,
                applied: 0.5
            }
        );
        assert!(e.to_string().contains("0.5 deg sun disc the table already"));
        assert!(SunDisc::plan(&table(Some(0.5)), Some(11.0)).is_err());
    }

    #[test]
    fn coarse_axes_take_samples_and_fine_axes_interpolate() {
        let t = table(Some(0.0));
        let radius = t.axis_index("radius").unwrap();
        let angle = t.axis_index("scattering_angle").unwrap();
        assert_eq!(resolve_axis_value(&t, radius, 500.0), Ok(500.0));
        match resolve_axis_value(&t, radius, 450.0).unwrap_err() {
            e @ OperatorError::NotASample { nearest, .. } => {
                assert!(nearest == 400.0 || nearest == 500.0);
                assert!(e.to_string().contains("between the samples 400 and 500"));
            }
            e => panic!("{e}"),
        }
        let e = resolve_axis_value(&t, radius, 99999.0).unwrap_err();
        assert!(
            e.to_string()
                .contains("outside the table's `radius` range [400, 500] um"),
            "{e}"
        );
        assert_eq!(resolve_axis_value(&t, angle, 12.3), Ok(12.3));
        assert!(resolve_axis_value(&t, angle, 181.0).is_err());
        // A table that declares radius interpolable is interpolated along it.
        let mut u = table(Some(0.0));
        u.header.attributes.insert(
            INTERPOLABLE_AXES_ATTRIBUTE.into(),
            serde_json::json!(["radius", "scattering_angle"]),
        );
        assert_eq!(resolve_axis_value(&u, radius, 450.0), Ok(450.0));
    }
}
