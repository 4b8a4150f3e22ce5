//! Measurements of a rendered rainbow against the table it came from, as plain values for the
//! command to print: bow radii along the centre column (image vs the table's disc-averaged
//! maximum), supernumerary fringes inside the primary, and Alexander's dark band.

use super::rainbow::{
    BowMeasurement, Rendered, centre_column, column_mean_luminance, measure_bow, prominent_maxima,
    table_bow_radius, table_bow_radius_2d,
};

/// The centre column's luminance as (radius from the antisolar point in deg, linear sRGB Y),
/// sorted by radius; empty for lenses other than the fisheye.
fn column_luminance(r: &Rendered, sun_elevation_deg: f64) -> Vec<(f64, f64)> {
    let mut column: Vec<(f64, f64)> = centre_column(r, sun_elevation_deg)
        .unwrap_or_default()
        .into_iter()
        .map(|(radius, p)| (radius, linear_srgb_luminance(p)))
        .collect();
    column.sort_by(|a, b| a.0.total_cmp(&b.0));
    column
}

/// The prominent maxima of `column` in `[lo, hi]` at ≥ [`WINDOW_MAXIMA_FLOOR`] of the
/// window's largest luminance, outermost first, with their relative luminance.
fn window_maxima(column: &[(f64, f64)], lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let top = column
        .iter()
        .filter(|(r, _)| (lo..=hi).contains(r))
        .map(|p| p.1)
        .fold(0.0, f64::max);
    if top <= 0.0 {
        return Vec::new();
    }
    let mut out: Vec<(f64, f64)> = prominent_maxima(column, lo, hi, 0.02)
        .into_iter()
        .filter_map(|r| {
            let y = column.iter().find(|p| p.0 == r)?.1 / top;
            (y >= WINDOW_MAXIMA_FLOOR).then_some((r, y))
        })
        .collect();
    out.reverse();
    out
}
use crate::consumers::read::phase2d::PhaseSlice;
use crate::consumers::read::spectrum::THETA_STEP_DEG;
use crate::optics::colour::linear_srgb_luminance;

/// Windows (deg from the antisolar point) in which the bows are looked for.
pub const BOW_WINDOWS: [(&str, f64, f64); 2] = [("primary", 36.0, 46.0), ("secondary", 48.0, 56.0)];

/// What the image is compared with.
pub enum TableReference<'a> {
    /// XYZ vs scattering angle of a 1-D table on the [`THETA_STEP_DEG`] grid, with the same
    /// sun disc as the render.
    OneD(&'a [[f64; 3]]),
    /// A 2-D slice and the disc the render convolved (deg).
    TwoD(&'a PhaseSlice, f64),
}

/// One bow: the image maximum and the table's within a window.
#[derive(Debug, Clone, PartialEq)]
pub struct BowReport {
    pub name: &'static str,
    pub window_deg: (f64, f64),
    pub image: BowMeasurement,
    pub table_max_deg: f64,
    /// The image maximum lies within a pixel of the window's edge: no maximum inside.
    pub at_window_edge: bool,
    /// Every prominent luminance maximum of the centre column in the window (prominence 2 %,
    /// as [`prominent_maxima`]) at ≥ [`WINDOW_MAXIMA_FLOOR`] of the window's largest, outermost
    /// first, as (radius in deg, luminance over the window's largest): the twins of a twinned
    /// bow, the supernumeraries.
    pub maxima: Vec<(f64, f64)>,
}

/// Smallest luminance, relative to the window's largest, of the maxima listed in
/// [`BowReport::maxima`].
pub const WINDOW_MAXIMA_FLOOR: f64 = 0.3;

/// Supernumerary fringes inside the primary, outermost first.
#[derive(Debug, Clone, PartialEq)]
pub struct Supernumeraries {
    pub window_deg: (f64, f64),
    pub image_deg: Vec<f64>,
    pub table_deg: Vec<f64>,
}

/// Alexander's dark band against the sky inside the primary (mean luminance of the centre
/// column).
#[derive(Debug, Clone, PartialEq)]
pub struct DarkBand {
    pub band_deg: (f64, f64),
    pub band_luminance: f64,
    pub inside_deg: (f64, f64),
    pub inside_luminance: f64,
}

/// Everything measured on one render.
#[derive(Debug, Clone, PartialEq)]
pub struct RainbowMeasurements {
    pub bows: Vec<BowReport>,
    pub supernumeraries: Option<Supernumeraries>,
    pub dark_band: Option<DarkBand>,
}

/// Measure a render (sun at `sun_elevation_deg`) against `reference`.
pub fn measure_rainbow(
    r: &Rendered,
    sun_elevation_deg: f64,
    reference: &TableReference,
) -> RainbowMeasurements {
    let bows = measure_bows(r, sun_elevation_deg, reference);
    // Radii of real bows (inside their windows) for the fringe and band measurements.
    let radius = |name: &str| {
        bows.iter()
            .find(|b| b.name == name && !b.at_window_edge)
            .map(|b| b.image.radius_deg)
    };
    let (primary, secondary) = (radius("primary"), radius("secondary"));
    let supernumeraries = match (reference, primary) {
        (TableReference::OneD(xyz), Some(p)) => Some(supernumeraries(r, sun_elevation_deg, xyz, p)),
        _ => None,
    };
    let dark_band = match (primary, secondary) {
        (Some(p), Some(s)) if s - p > 3.0 => dark_band(r, sun_elevation_deg, p, s),
        _ => None,
    };
    RainbowMeasurements {
        bows,
        supernumeraries,
        dark_band,
    }
}

/// The brightest pixel of the centre column within each of [`BOW_WINDOWS`]; a 2-D table's bow
/// may lie outside it (flattened drops move the top of the bow), which `at_window_edge` says.
pub fn measure_bows(
    r: &Rendered,
    sun_elevation_deg: f64,
    reference: &TableReference,
) -> Vec<BowReport> {
    let pixel = r.camera.pixel_deg();
    let column = column_luminance(r, sun_elevation_deg);
    BOW_WINDOWS
        .iter()
        .filter_map(|&(name, lo, hi)| {
            let m = measure_bow(r, sun_elevation_deg, lo, hi)?;
            let table_max_deg = match reference {
                TableReference::OneD(xyz) => table_bow_radius(xyz, lo, hi),
                TableReference::TwoD(slice, disc) => table_bow_radius_2d(slice, *disc, lo, hi),
            };
            Some(BowReport {
                name,
                window_deg: (lo, hi),
                image: m,
                table_max_deg,
                at_window_edge: m.radius_deg - lo < pixel || hi - m.radius_deg < pixel,
                maxima: window_maxima(&column, lo, hi),
            })
        })
        .collect()
}

/// Prominent maxima up to 5° inside the primary's maximum, image column vs the disc-averaged
/// table luminance.
pub fn supernumeraries(
    r: &Rendered,
    sun_elevation_deg: f64,
    xyz: &[[f64; 3]],
    primary_deg: f64,
) -> Supernumeraries {
    let (lo, hi) = (primary_deg - 5.0, primary_deg - 0.3);
    let column = column_luminance(r, sun_elevation_deg);
    let mut table: Vec<(f64, f64)> = xyz
        .iter()
        .enumerate()
        .map(|(i, v)| (180.0 - i as f64 * THETA_STEP_DEG, v[1]))
        .collect();
    table.sort_by(|a, b| a.0.total_cmp(&b.0));
    let outermost_first = |mut v: Vec<f64>| {
        v.reverse();
        v
    };
    Supernumeraries {
        window_deg: (lo, hi),
        image_deg: outermost_first(prominent_maxima(&column, lo, hi, 0.02)),
        table_deg: outermost_first(prominent_maxima(&table, lo, hi, 0.02)),
    }
}

/// Between the bows (1° clear of each maximum) against the sky inside the primary (from 10°
/// to 2° inside its maximum), centre column.
pub fn dark_band(
    r: &Rendered,
    sun_elevation_deg: f64,
    primary_deg: f64,
    secondary_deg: f64,
) -> Option<DarkBand> {
    let band_deg = (primary_deg + 1.0, secondary_deg - 1.0);
    let inside_deg = (primary_deg - 10.0, primary_deg - 2.0);
    Some(DarkBand {
        band_deg,
        band_luminance: column_mean_luminance(r, sun_elevation_deg, band_deg.0, band_deg.1)?,
        inside_deg,
        inside_luminance: column_mean_luminance(r, sun_elevation_deg, inside_deg.0, inside_deg.1)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two bows (a twin) and a faint fringe: the twins are listed outermost first with their
    /// relative luminance, the fringe below the floor is not.
    #[test]
    fn window_maxima_list_the_twins_above_the_floor() {
        let peak = |r: f64, at: f64, h: f64| h * (-((r - at) / 0.3).powi(2)).exp();
        let column: Vec<(f64, f64)> = (0..=1800)
            .map(|i| {
                let r = 36.0 + 0.005 * i as f64;
                (
                    r,
                    0.05 + peak(r, 39.36, 1.0) + peak(r, 41.7, 0.8) + peak(r, 37.5, 0.2),
                )
            })
            .collect();
        let m = window_maxima(&column, 36.0, 45.0);
        assert_eq!(m.len(), 2, "{m:?}");
        assert!(
            (m[0].0 - 41.7).abs() < 0.01 && (m[0].1 - 0.85 / 1.05).abs() < 0.01,
            "{m:?}"
        );
        assert!(
            (m[1].0 - 39.36).abs() < 0.01 && (m[1].1 - 1.0).abs() < 1e-9,
            "{m:?}"
        );
        assert!(window_maxima(&column, 50.0, 55.0).is_empty());
    }
}
