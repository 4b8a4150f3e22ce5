//! Shared look of every figure: wavelength colours, XYZ → sRGB fills, axis labels, numbers and
//! the line palette.

use crate::optics::colour::{cie1931_xyz_bar, srgb_encode, xyz_to_linear_srgb};
use plotters::style::RGBColor;

/// Display colour of a monochromatic wavelength: CIE 1931 → linear sRGB, desaturated toward
/// white until in gamut, scaled to a maximum of 1, sRGB-encoded; darkened toward the ends of
/// the visible range where the eye's response fades.
pub fn wavelength_colour(wavelength_nm: f64) -> RGBColor {
    let xyz = cie1931_xyz_bar(wavelength_nm.clamp(380.0, 780.0));
    let mut rgb = xyz_to_linear_srgb(xyz);
    let min = rgb.iter().cloned().fold(f64::INFINITY, f64::min);
    if min < 0.0 {
        for c in &mut rgb {
            *c -= min;
        }
    }
    let max = rgb.iter().cloned().fold(0.0, f64::max).max(1e-12);
    let fade = (xyz[1] / 0.2).clamp(0.35, 1.0);
    let e = |c: f64| (srgb_encode(c / max * fade) * 255.0).round() as u8;
    RGBColor(e(rgb[0]), e(rgb[1]), e(rgb[2]))
}

/// XYZ → 8-bit sRGB colour after scaling by `scale` (clipped).
pub fn xyz_colour(xyz: [f64; 3], scale: f64) -> RGBColor {
    let l = xyz_to_linear_srgb([xyz[0] * scale, xyz[1] * scale, xyz[2] * scale]);
    let e = |c: f64| (srgb_encode(c) * 255.0).round() as u8;
    RGBColor(e(l[0]), e(l[1]), e(l[2]))
}

/// `name (unit)` of an axis, `name` when dimensionless.
pub fn axis_label(name: &str, unit: &str) -> String {
    if unit.is_empty() || unit == "1" {
        name.to_string()
    } else {
        format!("{name} ({unit})")
    }
}

/// Shortest readable form of a coordinate (up to 4 significant decimals).
pub fn short_number(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// Distinguishable line colours.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(0, 0, 0),
];
