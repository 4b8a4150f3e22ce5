//! Preview of cloth BRDF tables (`cloth-brdf/2`): the BRDF in the plane of incidence, as the
//! cloth chapter of Sadeghi's thesis (2012) plots its fits, read from the table by its
//! documented lookup.
//!
//! One panel per light azimuth (along the warp, φ_i = 0°, and the stored azimuth nearest 90°,
//! across it), one curve per light elevation (the stored θ_i nearest 15°, 45° and 75°). The
//! x axis is the signed viewing angle in the plane of incidence: θ_r on the mirror side
//! (φ_r = φ_i + 180°) positive, on the light's side (φ_r = φ_i) negative. The y axis is the
//! luminance `0.2126 r + 0.7152 g + 0.0722 b` of the linear-sRGB BRDF (1/sr). The light is at
//! stored (θ_i, φ_i) nodes; each view direction (every 0.25°) is looked up as the table says:
//! its half vector's projected angles (β_x, β_y), multilinear interpolation of `K = f cos θ_i`
//! over the half-angle axes, `f = K / cos θ_i`.

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

/// Step of the viewing angle along the curves, degrees.
const VIEW_STEP_DEG: f64 = 0.25;

/// The incidence-plane figure of a `cloth-brdf` table.
pub fn incidence_plane(v: &View) -> Result<Vec<(&'static str, Figure)>, ConsumerError> {
    let axes = [
        v.ax("theta_i")?,
        v.ax("phi_i")?,
        v.ax("half_x")?,
        v.ax("half_y")?,
    ];
    v.ch("k_r")?;
    let mut azimuths = vec![0, v.nearest(axes[1], 90.0)];
    azimuths.dedup();
    let panels = azimuths
        .iter()
        .map(|&phi_i| panel(v, axes, phi_i))
        .collect::<Result<Vec<_>, _>>()?;
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

/// The luminance of the table's BRDF for light (θ_i, φ_i) and view (θ_r, φ_r), degrees, φ_i
/// a stored node: the table's lookup in half-vector coordinates.
fn brdf_luminance(v: &View, q: [f64; 4]) -> Result<f64, ConsumerError> {
    use crate::cloth::direction;
    use crate::cloth::half::{half_angles_deg, half_of};
    let r = q.map(f64::to_radians);
    let (wi, wr) = (direction(r[0], r[1]), direction(r[2], r[3]));
    let Some(h) = half_of(wi, wr).filter(|_| wi[2] > 0.0 && wr[2] > 0.0) else {
        return Ok(0.0);
    };
    let (bx, by) = half_angles_deg(h);
    let k = v.t.sample(&[q[0], q[1], bx, by])?;
    Ok((0.2126 * k[0] + 0.7152 * k[1] + 0.0722 * k[2]) / wi[2])
}

/// Curves of one light azimuth (index `phi_i` of its axis).
fn panel(v: &View, axes: [usize; 4], phi_i: usize) -> Result<Panel, ConsumerError> {
    let [ti, pi, _, _] = axes;
    let phi_i_deg = v.coord(pi, phi_i);
    let mut thetas: Vec<usize> = THETA_I_DEG.iter().map(|&t| v.nearest(ti, t)).collect();
    thetas.dedup();
    let n = (90.0 / VIEW_STEP_DEG) as i64 - 1;
    let mut series = Vec::new();
    for (&theta_i, colour) in thetas.iter().zip(COLOURS) {
        let theta_i_deg = v.coord(ti, theta_i);
        let mut points = Vec::new();
        for k in -n..=n {
            let x = k as f64 * VIEW_STEP_DEG;
            let phi_r = if x > 0.0 {
                phi_i_deg + 180.0
            } else {
                phi_i_deg
            };
            let y = brdf_luminance(v, [theta_i_deg, phi_i_deg, x.abs(), phi_r])?;
            points.push((x, y));
        }
        series.push(Series {
            label: v.at_text(ti, theta_i, "θ_i"),
            colour,
            dash: Dash::Solid,
            points,
        });
    }
    Ok(Panel::Lines(LinePanel {
        title: format!(
            "{}: light's side ← θ_r → mirror side",
            v.at_text(pi, phi_i, "φ_i")
        ),
        x_label: "signed viewing angle θ_r in the plane of incidence (deg)".into(),
        y_label: "BRDF luminance (1/sr)".into(),
        series,
        log_y: false,
        legend: Legend::UpperLeft,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::{Stage, table_from_lines};
    use crate::table::{Provenance, Table};

    /// Satin lit along the warp: the incidence-plane curve at θ_i peaks on the mirror side at
    /// θ_r = θ_i (the specular cone meets the plane of incidence there).
    #[test]
    fn satin_peaks_at_the_mirror_angle() {
        let stage = crate::stages::cloth::ClothStage;
        let content = table_from_lines(
            &stage as &dyn Stage,
            "fabric = \"polyester_satin_front\"\nphi_i_step_deg = 45.0\ncheck_points = 20",
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
                assert!(
                    (x_peak - theta_i).abs() <= 0.5,
                    "{}: peak at {x_peak}",
                    s.label
                );
            }
            assert!(s.points.windows(2).all(|w| w[0].0 < w[1].0));
        }
        assert_eq!(figures[0].1.panels.len(), 2);
    }
}
