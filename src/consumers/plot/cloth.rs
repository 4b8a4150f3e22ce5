//! Preview of cloth BRDF tables (`cloth-brdf/1`): the BRDF in the plane of incidence, as the
//! cloth chapter of Sadeghi's thesis (2012) plots its fits, read from the table's stored samples.
//!
//! One panel per light azimuth (along the warp, φ_i = 0°, and the stored azimuth nearest 90°,
//! across it), one curve per light elevation (the stored θ_i nearest 15°, 45° and 75°). The
//! x axis is the signed viewing angle in the plane of incidence: θ_r on the mirror side
//! (φ_r = φ_i + 180°) positive, on the light's side (φ_r = φ_i) negative. The y axis is the
//! luminance `0.2126 r + 0.7152 g + 0.0722 b` of the linear-sRGB channels (1/sr). Only stored
//! nodes are drawn, no interpolation: the grid's coarseness shows as it is.

use super::figure::{Dash, Figure, Legend, LinePanel, Panel, Series};
use super::view::View;
use crate::consumers::ConsumerError;
use plotters::style::RGBColor;

/// Light elevations (deg) drawn, each at its nearest stored θ_i.
const THETA_I_DEG: [f64; 3] = [15.0, 45.0, 75.0];
/// Curve colours, one per light elevation.
const COLOURS: [RGBColor; 3] = [
    RGBColor(30, 90, 200),
    RGBColor(40, 150, 60),
    RGBColor(210, 60, 30),
];

/// The incidence-plane figure of a `cloth-brdf` table.
pub fn incidence_plane(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let axes = [
        v.ax("theta_i")?,
        v.ax("phi_i")?,
        v.ax("theta_r")?,
        v.ax("phi_r")?,
    ];
    let rgb = [v.ch("r")?, v.ch("g")?, v.ch("b")?];
    let mut azimuths = vec![0, v.nearest(axes[1], 90.0)];
    azimuths.dedup();
    let panels = azimuths
        .iter()
        .map(|&phi_i| panel(v, axes, rgb, phi_i))
        .collect::<Vec<_>>();
    Ok(vec![(
        "incidence",
        Figure {
            title: v.title("cloth BRDF in the plane of incidence"),
            cols: panels.len(),
            size: (700 * panels.len() as u32, 560),
            panels,
        },
    )])
}

/// The luminance `0.2126 r + 0.7152 g + 0.0722 b` at grid index `idx`.
fn luminance(v: &View, idx: &[usize], rgb: [usize; 3]) -> f64 {
    let [r, g, b] = rgb.map(|c| f64::from(v.t.at(idx, c)));
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// Curves of one light azimuth (index `phi_i` of its axis).
fn panel(v: &View, axes: [usize; 4], rgb: [usize; 3], phi_i: usize) -> Panel {
    let [ti, pi, tr, pr] = axes;
    let phi_i_deg = v.coord(pi, phi_i);
    let wrap = |a: f64| (a + 180.0).rem_euclid(360.0) - 180.0;
    let mirror = v.nearest(pr, wrap(phi_i_deg + 180.0));
    let back = v.nearest(pr, wrap(phi_i_deg));
    let mut thetas: Vec<usize> = THETA_I_DEG.iter().map(|&t| v.nearest(ti, t)).collect();
    thetas.dedup();
    let series = thetas
        .iter()
        .zip(COLOURS)
        .map(|(&theta_i, colour)| {
            let at = |theta_r: usize, phi_r: usize| {
                let mut idx = [0; 4];
                (idx[ti], idx[pi], idx[tr], idx[pr]) = (theta_i, phi_i, theta_r, phi_r);
                luminance(v, &idx, rgb)
            };
            let n = v.len(tr);
            let light_side = (0..n).rev().map(|k| (-v.coord(tr, k), at(k, back)));
            let mirror_side = (0..n).map(|k| (v.coord(tr, k), at(k, mirror)));
            Series {
                label: v.at_text(ti, theta_i, "θ_i"),
                colour,
                dash: Dash::Solid,
                points: light_side.chain(mirror_side).collect(),
            }
        })
        .collect();
    Panel::Lines(LinePanel {
        title: format!(
            "{}: light's side ← θ_r → mirror side",
            v.at_text(pi, phi_i, "φ_i")
        ),
        x_label: "signed viewing angle θ_r in the plane of incidence (deg)".into(),
        y_label: "BRDF luminance (1/sr)".into(),
        series,
        log_y: false,
        legend: Legend::UpperLeft,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::{Stage, table_from_lines};
    use crate::table::{Provenance, Table};

    /// Satin lit along the warp: the incidence-plane curve at θ_i peaks on the mirror side at
    /// θ_r = θ_i (the specular cone meets the plane of incidence there), and every drawn value is
    /// a stored one.
    #[test]
    fn satin_peaks_at_the_mirror_angle() {
        let stage = crate::stages::cloth::ClothStage;
        let content = table_from_lines(
            &stage as &dyn Stage,
            "fabric = \"polyester_satin_front\"\nstep_deg = 5.0\ncheck_points = 20",
        );
        let t = Table::from_content(content, Provenance::default()).unwrap();
        let v = View::new(&t, "satin");
        let figures = incidence_plane(&v).unwrap();
        assert_eq!(figures.len(), 1);
        let Panel::Lines(along) = &figures[0].1.panels[0] else {
            panic!("a line panel")
        };
        assert_eq!(along.series.len(), 3);
        for s in &along.series {
            let theta_i: f64 = s
                .label
                .trim_start_matches("θ_i = ")
                .trim_end_matches('°')
                .parse()
                .unwrap();
            let (x_peak, y_peak) = s
                .points
                .iter()
                .copied()
                .fold((0.0, f64::MIN), |a, p| if p.1 > a.1 { p } else { a });
            assert!(y_peak > 0.0);
            if theta_i > 60.0 {
                assert_eq!(x_peak, theta_i, "{}: peak at {x_peak}", s.label);
            }
            assert!(s.points.windows(2).all(|w| w[0].0 < w[1].0));
        }
        assert_eq!(figures[0].1.panels.len(), 2);
    }
}
