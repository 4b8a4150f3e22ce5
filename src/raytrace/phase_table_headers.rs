//! The header texts of the ray-traced phase tables ([`super::phase_table`]): what each
//! channel is, the conventions every table states (orders, normalisation, focal-line rule,
//! diffraction model, Fresnel conventions), those of 1-D and 2-D tables, where the airy-local
//! model used the sphere's transfer, and the record of a compact table's compression.

use super::compact::{self, CompactEntry, SunDiscResampled};
use super::phase_table::PhaseTable;
use super::post::filter_sigma_deg;
use super::sphere1d::{DiffractionModel, SPHERE_MAX_ORDER};
use super::tracer::RayGridLayout;
use crate::table::{Axis, Channel, Schema, TableContent};
use serde_json::{Map, Value, json};

/// Unit and meaning of channel `name` ([`super::channel_names`]).
pub fn channel_meaning(name: &str) -> (&'static str, String) {
    match name {
        "phase" => ("1/sr", "unpolarised phase function (i_perp + i_par)/2, diffraction-filtered, with forward lobe".to_string()),
        "i_perp" => ("1/sr", "perpendicular component (dσ/dΩ)_perp/σ, for a sphere |S1|^2/(pi x^2 Q_sca); phase = (i_perp + i_par)/2".to_string()),
        "i_par" => ("1/sr", "parallel component (dσ/dΩ)_par/σ, for a sphere |S2|^2/(pi x^2 Q_sca); phase = (i_perp + i_par)/2".to_string()),
        "dolp" => ("1", "(i_perp − i_par)/(i_perp + i_par)".to_string()),
        "phase_unfiltered" => ("1/sr", "phase without the Gaussian diffraction filter (forward lobe included)".to_string()),
        "i_perp_unfiltered" => ("1/sr", "i_perp without the Gaussian filter".to_string()),
        "i_par_unfiltered" => ("1/sr", "i_par without the Gaussian filter".to_string()),
        other => ("1/sr", format!("unpolarised contribution of order p = {} alone (filtered, no lobe)", &other[7..])),
    }
}

impl PhaseTable {
    /// The channels with their units and meanings.
    pub fn channels(&self) -> Vec<Channel> {
        super::channel_names(self.spec.max_order, self.spec.diagnostic_channels)
            .into_iter()
            .map(|n| {
                let (unit, meaning) = channel_meaning(&n);
                Channel::new(&n, unit, &meaning)
            })
            .collect()
    }

    /// The attributes of 1-D and 2-D tables beside the phase-table contract's: orders,
    /// normalisation, focal-line rule, diffraction model and Fresnel conventions.
    pub(crate) fn insert_common_attributes(&self, at: &mut Map<String, Value>) {
        let s = &self.spec;
        at.insert("max_order".into(), s.max_order.into());
        at.insert("cross_section_normalization".into(), "p = (dσ/dΩ)/σ with σ = σ_GO (flux of the traced orders) + A (Fraunhofer forward lobe of the projected area A, added to i_perp and i_par as the exact bin average of a²J1(x sinθ)²/sin²θ)".into());
        at.insert("focal_line_rule".into(), "longer-path branch π/2 behind (docs/decisions.md RT-1): phase exp(i(k l − (π/2) f)), f = [dl/db > 0], b = u² + v²".into());
        let filter_text = match s.model {
            DiffractionModel::AiryUniform => "airy-uniform: uniform caustic (Airy) approximation of each order's rainbow (two-branch CUA on the bright side, Airy continuation on the dark side); GO elsewhere".to_string(),
            DiffractionModel::AiryLocal => "airy-local: the equal-volume sphere's uniform-caustic correction (1-D Airy-uniform minus GO channels, bin averages) added to each azimuth column, moved onto the column's own primary/secondary caustic (fold fit of the p = 2 / p = 3 GO intensity, smoothed over ±5° of azimuth) and scaled to its caustic strength (bright side 0.1–1.5°); primary correction above the Alexander-band midpoint, secondary below; GO elsewhere. Domain per column and bow: caustic inside the search range, strength 0.5–2 times the sphere's, no value below −5 % of the column's largest before clipping; columns with a column outside the domain within ±5° take the Gaussian filter instead, blended over ±5° of azimuth (docs/decisions.md RT-28, RT-33)".to_string(),
            DiffractionModel::Gaussian => format!("gaussian: thesis Table 3.3 Gaussian in polar angle (σ linear in radius, Airy a^(-2/3) outside 0.1–1 mm; σ = {:.4}° at the first radius) for θ above the Alexander-band midpoint, 2σ below, blended in only within a Gaussian window of half-width 2σ_local around each caustic (peaks of the p = 2 and p = 3 intensities)", filter_sigma_deg(s.radii_um[0] * 1e-3)),
        };
        at.insert(
            "diffraction_filter".into(),
            format!("{filter_text}; applied = {}", s.diffraction_filter).into(),
        );
        at.insert("fresnel".into(), "complex Fresnel amplitudes, Born–Wolf signs, power-consistent transmission (src/optics/fresnel.rs)".into());
        at.insert("cross_order_phase".into(), "orders summed coherently without per-order constant (axial focal line) phases, as in the thesis: the fine cross-order ripple of the unfiltered channels is not Mie-exact".into());
    }

    /// The header record of where airy-local used the sphere's transfer (decision RT-33), per
    /// (wavelength, sun elevation) entry and bow, from the weights of each task's chunk
    /// (`[primary, secondary]` per azimuth column), classified at f32 precision.
    pub fn domain_attribute(&self, weights: &[&[f64]]) -> Value {
        let step = self.spec.azimuth_step_deg;
        let bow = |w: &[f64], b: usize| {
            let col: Vec<f32> = w.chunks_exact(2).map(|p| p[b] as f32).collect();
            let transfer = col.iter().filter(|&&x| x >= 1.0).count();
            let gaussian = col.iter().filter(|&&x| x <= 0.0).count();
            // Azimuth ranges (deg, inclusive) of the columns that did not take the transfer
            // alone (blended or Gaussian).
            let mut ranges: Vec<[f64; 2]> = Vec::new();
            let mut start = None;
            for (k, &x) in col.iter().chain([&1.0f32]).enumerate() {
                match (x < 1.0, start) {
                    (true, None) => start = Some(k),
                    (false, Some(k0)) => {
                        ranges.push([k0 as f64 * step, (k - 1) as f64 * step]);
                        start = None;
                    }
                    _ => {}
                }
            }
            json!({
                "transfer_columns": transfer,
                "blended_columns": col.len() - transfer - gaussian,
                "gaussian_columns": gaussian,
                "not_transfer_azimuth_ranges_deg": ranges,
            })
        };
        let entries: Vec<Value> = self
            .entries()
            .iter()
            .zip(weights)
            .map(|(&(l, e), w)| {
                json!({
                    "wavelength_nm": l,
                    "sun_elevation_deg": e,
                    "primary": bow(w, 0),
                    "secondary": bow(w, 1),
                })
            })
            .collect();
        json!({
            "what": "where the airy-local caustic model used the equal-volume sphere's transfer (the model validated against Lorenz–Mie on spheres) and where the Gaussian filter, per (wavelength, sun elevation) entry and bow (primary: rows above the Alexander-band midpoint, secondary: below): counts of azimuth columns with transfer weight 1 (transfer), 0 (Gaussian filter) or between (blended over ±5° of azimuth), and the azimuth ranges (deg, inclusive) of the columns with weight below 1 (docs/decisions.md RT-33)",
            "entries": entries,
        })
    }

    /// The 1-D table of spheres: radius × wavelength × scattering angle (`ints`: the entries'
    /// bin-sums).
    pub(crate) fn content_1d(
        &self,
        data: Vec<f32>,
        ints: &[f64],
        mut at: Map<String, Value>,
    ) -> TableContent {
        at.insert(
            "integral_check".into(),
            json!({"what": "bin-sum of phase over 4π per entry", "values": ints}),
        );
        at.insert("angular_resampling".into(), format!("point samples of the GO+phase field on an internal grid of step ≤ λ/(10a); filtered channels are Gaussian averages of it; the forward lobe is the exact average over each {}° bin", self.spec.angle_step_deg).into());
        at.insert("method".into(), "exact 1-D geometric optics plus phase for spheres (two-branch phasor sum of Airy theory), validated against the 2-D patch tracer and Lorenz–Mie (docs/raytrace.md)".into());
        at.insert("validated_domain".into(), "spheres of radius 0.1–1 mm in 380–700 nm (x ≳ 1000): supernumerary positions within 0.02° (primary) and 0.05° (secondary) of Lorenz–Mie; not valid within ~1° of 0° (forward lobe only approximate) and near 180° (glory, axial caustic clamped at a quarter bin)".into());
        TableContent {
            encoding: Default::default(),
            schema: Schema::new("raytrace-phase", 2),
            description: "ray-traced (geometric optics + phase) phase function of water spheres"
                .into(),
            axes: self.axes(),
            channels: self.channels(),
            attributes: at,
            data,
        }
    }

    /// The 2-D table's content from its renormalised values, on `axes`, with the attributes of
    /// every 2-D table (`ints`: the entries' bin-sums before renormalisation).
    pub(crate) fn content_2d(
        &self,
        data: Vec<f32>,
        ints: &[f64],
        mut at: Map<String, Value>,
        axes: Vec<Axis>,
    ) -> TableContent {
        let s = &self.spec;
        at.insert("integral_check".into(), json!({"what": "bin-sum of phase over 4π per entry before renormalisation (below 1 by the flux of triangles discarded at the silhouette, above 1 where cusp caustics are point-sampled); every channel but dolp was divided by it, so the stored table integrates to 1 on its grid", "values": ints}));
        at.insert("angular_resampling".into(), "point samples of the coherent patch sum at the grid directions; filtered channels are Gaussian averages along the polar angle per azimuth column; the forward lobe is the exact average over each polar bin".into());
        if s.sphere_higher_orders && s.max_order < SPHERE_MAX_ORDER {
            at.insert(
                "sphere_higher_orders".into(),
                json!({
                    "orders": [s.max_order + 1, SPHERE_MAX_ORDER],
                    "what": "phase, i_perp, i_par and their unfiltered channels include these orders of the equal-volume sphere (1-D path: Airy rainbows, grazing waves), bin averages along the polar angle, the same at every azimuth; the per-order channels hold the traced orders only"
                }),
            );
        }
        at.insert("mirror_symmetrisation".into(), self.mirror_text().into());
        at.insert("frame".into(), "drop axis vertical (z up); sun at elevation e in the +x half-space, incident direction d = (−cos e, 0, −sin e); outgoing_polar = angle from d; outgoing_azimuth about d from e1 = (−sin e, 0, cos e) (vertical plane, upwards) towards e2 = +y".into());
        at.insert("shape".into(), s.shape_name.clone().into());
        at.insert("radius_um".into(), s.radii_um[0].into());
        at.insert("rays_per_side".into(), s.rays.into());
        at.insert(
            "ray_grid".into(),
            match s.ray_grid {
                RayGridLayout::Square => "square: rays_per_side² rays evenly spaced over the silhouette's bounding box",
                RayGridLayout::Silhouette => "silhouette: rays_per_side² rays, the index square mapped onto the silhouette (Shirley–Chiu concentric map, ρ = R(ψ) sin(π s / 2)), refined towards the edge; docs/decisions.md RT-31",
                RayGridLayout::SilhouetteBows => "silhouette-bows: rays_per_side² rays on the silhouette grid with its rings warped, ρ = R(ψ) b(s), half of the rings as the silhouette grid's asin profile and half in Gaussian bands about the equal-volume sphere's primary and secondary rainbow rays; docs/decisions.md RT-40",
            }
            .into(),
        );
        at.insert("beard_chuang".into(), "r(θ) = a[1 + Σ c_n cos nθ], θ from the downward pole, thesis Table 3.1 linear in a; sphere for a ≤ 0.4 mm; clamped to the 3 mm row above 3 mm".into());
        if let Some(res) = s.profile_fit_residual {
            at.insert("profile_fit_rms_relative".into(), res.into());
        }
        at.insert("forward_lobe".into(), "Fraunhofer lobe of the equal-projected-area disc (azimuthally symmetric approximation for non-circular silhouettes)".into());
        at.insert("method".into(), "patch-based wave-optics ray tracer (Sadeghi 2012, ch. 3) with 3-D complex field vectors, spherical-triangle patches, coherent sums; see docs/raytrace.md".into());
        at.insert("validated_domain".into(), "validated on spheres (0.4 mm, 650 nm) against the exact 1-D path and Lorenz–Mie; Beard–Chuang results checked for volume, axis ratios, symmetry and energy; accuracy depends on rays_per_side (docs/raytrace.md)".into());
        if self.sphere_from_1d_path() {
            at.insert("method".into(), "a sphere: the 1-D path's exact geometric optics plus phase (orders up to 6, uniform caustic approximation at each rainbow, axial focal-line phases, grazing waves, forward lobe; validated against Lorenz–Mie, docs/raytrace.md), the same at every outgoing_azimuth and sun_elevation; rays_per_side and ray_grid are not used (docs/decisions.md RT-43)".into());
            at.insert(
                "angular_resampling".into(),
                "bin averages along the polar angle (1-D path), the same at every azimuth".into(),
            );
            at.insert("cross_order_phase".into(), "orders summed coherently with their axial focal-line phases (the Lorenz–Mie cross-order phases, docs/decisions.md RT-38)".into());
        }
        TableContent {
            encoding: Default::default(),
            schema: Schema::new("raytrace-phase-2d", 2),
            description: format!(
                "ray-traced phase function of a {} drop, a = {} µm, over outgoing directions",
                s.shape_name, s.radii_um[0]
            ),
            axes,
            channels: self.channels(),
            attributes: at,
            data,
        }
    }

    /// The header's `mirror_symmetrisation` of a 2-D table (decisions RT-24, RT-34).
    fn mirror_text(&self) -> &'static str {
        let s = &self.spec;
        if s.mirror_half {
            "by construction: only the outgoing_azimuth range 0°–180° was computed and each value copied to 360° − φ (mirror_half); the drop (a surface of revolution about the vertical axis) and the sun (in the vertical plane φ = 0) are symmetric under y → −y, so the exact table has this symmetry; the ray noise is that of the half traced, not averaged with its mirror image (docs/decisions.md RT-34)"
        } else if s.mirror_symmetrise {
            "applied: the values at outgoing_azimuth φ and 360° − φ were replaced by their mean (every channel but dolp, which was recomputed from the mean i_perp and i_par); the drop (a surface of revolution about the vertical axis) and the sun (in the vertical plane φ = 0) are symmetric under y → −y, so the exact table has this symmetry and the averaging removes ray noise only (docs/decisions.md RT-24)"
        } else {
            "not applied: values at φ and 360° − φ differ by ray noise"
        }
    }

    /// The header's `compression` record: the operator applied, the error's definition and
    /// the errors measured per entry and window.
    pub(crate) fn compression_attribute(
        &self,
        spec: SunDiscResampled,
        entries: &[CompactEntry],
        polar: &[usize],
        azimuth: &[usize],
    ) -> Value {
        let grid = self.direction_grid();
        let windows: Map<String, Value> = (compact::ERROR_WINDOWS.iter())
            .map(|&(name, lo, hi)| (name.to_string(), json!([lo, hi])))
            .collect();
        let per_entry: Vec<Value> = (self.entries().iter().zip(entries))
            .map(|(&(l, e), entry)| {
                let errors: Map<String, Value> = (compact::ERROR_WINDOWS.iter())
                    .zip(&entry.errors)
                    .map(|(w, x)| {
                        (
                            w.0.to_string(),
                            json!({"rms_relative": x.rms_relative, "max_relative": x.max_relative}),
                        )
                    })
                    .collect();
                json!({
                    "wavelength_nm": l,
                    "sun_elevation_deg": e,
                    "polar_knots": entry.polar_rows.len(),
                    "azimuth_knots": entry.azimuth_positions.len(),
                    "errors": errors,
                })
            })
            .collect();
        let max = (entries.iter())
            .map(|e| compact::entry_error(&e.errors, compact::ErrorNorm::Max))
            .fold(0.0, f64::max);
        let rms = (entries.iter())
            .map(|e| compact::entry_error(&e.errors, compact::ErrorNorm::Rms))
            .fold(0.0, f64::max);
        let mut v = json!({
            "kind": compact::SUN_DISC_RESAMPLED,
            "tolerance": spec.tolerance,
            "norm": spec.norm,
            "max_relative_error": max,
            "max_window_rms_relative": rms,
            "sun_diameter_deg": spec.sun_diameter_deg,
            "sun_disc": format!("applied: every entry is the dense entry convolved with the sun's disc, a uniform disc of diameter {d}° taken as the Gaussian of its second moment, σ = {s}° of arc per axis, separably: along outgoing_polar with σ, reflected across the poles onto the opposite azimuth; along outgoing_azimuth with σ/sin(outgoing_polar), wrapped around the circle (the row's mean at the poles). A renderer must not convolve this table with the sun's disc again", d = spec.sun_diameter_deg, s = spec.sigma_deg()),
            "error_definition": "the table's bilinear interpolation between knots (what Table::sample returns) against the dense entry seen through the same disc, at every direction of the dense grid (where outgoing_azimuth is even-periodic and stores 0°–180°, the directions beyond 180° looked up at their mirror image 360° − φ, as every reader's lookup folds them, and compared with the dense entry there): max_relative is the largest |compact − dense| of phase, i_perp and i_par divided by the dense phase at that direction; rms_relative is the root mean square of that relative error, weighted by solid angle (sin θ), over a window of outgoing_polar (= scattering angle); norm says which the tolerance bounds (max: max_relative over all directions; rms: rms_relative in every window). The entry errors are measured at build time on the stored f32 values; entries of a table share the union of their knots, each evaluated there from its own bilinear interpolant, which adds one f32 rounding (< 1e-7 relative). dolp follows from i_perp and i_par (error up to about 2 × tolerance, absolute)",
            "windows_deg": windows,
            "dense_grid": {
                "outgoing_polar_step_deg": self.spec.polar_step_deg,
                "outgoing_azimuth_step_deg": self.spec.azimuth_step_deg,
                "directions": grid.n_polar * grid.n_azimuth,
            },
            "knots": {"outgoing_polar": polar.len(), "outgoing_azimuth": azimuth.len()},
            "entries": per_entry,
        });
        if spec.values == compact::StoredValues::Top16 {
            let m = spec.mantissa_bits;
            v["values"] = json!(spec.values);
            v["mantissa_bits"] = json!(m);
            v["values_definition"] = format!("i_perp and i_par are stored as 16-bit codes (layout.dtype f32-top16le: the f32 rounded to 8 exponent and 8 mantissa bits), here first rounded to {m} mantissa bits (codes whose low {low} bits are zero; relative rounding at most 2^-{r}), phase and dolp derived from them by the reader (mean, normalized-difference); the entry errors are measured with these decoded values. Where an entry's knots are fewer than the table's, its interpolant is rounded once more (to 8 mantissa bits) at the other knots and its stated errors include the bound of that rounding, 2^-9 × (2 + max_relative)", low = 8 - m, r = m + 1).into();
        }
        v
    }
}
