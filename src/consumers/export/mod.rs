//! Exports: files other programs read.
//!
//! **Negative values.** Every export of a quantity that cannot be negative (a phase function,
//! a colour under sunlight) writes it clamped at 0 and says how many values it clamped and the
//! most negative one, on stderr and in the file's own metadata ([`NegativeClamp`]). Such values
//! come from colour matching (the CIE 1931 functions map a very uneven spectrum outside the
//! sRGB gamut) and never from the tables themselves, which `verify` checks. Signed quantities
//! (the longitudinal shifts of the hair tables) are written as computed.

pub mod cloth_lut;
pub mod dds;
pub mod generic;
pub mod hair_engine_lut;
pub mod hair_lut;
pub mod legendre;
pub mod lut;
pub mod mieplot;
pub mod mitsuba;

/// What clamping negative values at 0 changed (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NegativeClamp {
    /// Values that were negative and are written as 0.
    pub count: usize,
    /// The most negative value before clamping (0 when none was).
    pub most_negative: f64,
}

impl NegativeClamp {
    /// Clamp every value at 0 in place and count what changed.
    pub fn apply<'a>(values: impl IntoIterator<Item = &'a mut f64>) -> Self {
        let mut c = NegativeClamp::default();
        for v in values {
            if *v < 0.0 {
                c.count += 1;
                c.most_negative = c.most_negative.min(*v);
                *v = 0.0;
            }
        }
        c
    }

    /// Combine the records of two clamped sets.
    pub fn merge(self, other: Self) -> Self {
        NegativeClamp {
            count: self.count + other.count,
            most_negative: self.most_negative.min(other.most_negative),
        }
    }

    /// One line for stderr and metadata, e.g. "negative values: 26 clamped to 0 (most negative
    /// -3.6e-3; out of the sRGB gamut)" or "negative values: none".
    pub fn describe(&self) -> String {
        if self.count == 0 {
            "negative values: none".into()
        } else {
            format!(
                "negative values: {} clamped to 0 (most negative {:.3e}; colours outside the sRGB gamut)",
                self.count, self.most_negative
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::NegativeClamp;

    #[test]
    fn clamps_counts_and_reports_the_most_negative() {
        let mut v = vec![1.0, -0.5, 0.0, -2.0, 3.0];
        let c = NegativeClamp::apply(v.iter_mut());
        assert_eq!(v, [1.0, 0.0, 0.0, 0.0, 3.0]);
        assert_eq!(c.count, 2);
        assert_eq!(c.most_negative, -2.0);
        assert!(c.describe().contains("2 clamped"), "{}", c.describe());
        let none = NegativeClamp::apply([1.0f64].iter_mut());
        assert_eq!(none.describe(), "negative values: none");
        assert_eq!(c.merge(none), c);
    }
}
