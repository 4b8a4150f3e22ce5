//! Stages `hair-dual` (Dual Scattering averages, schema `hair-dual/1`, `hair_dual.rs`) and
//! `hair-azimuthal` (azimuthal functions `N_p(θ, φ)`, schema `hair-azimuthal/1`,
//! `hair_azimuthal.rs`): manifest parameters, their checks, and one task per inclination θ;
//! what both share (fibre keys, checks, the job) is in `hair_job.rs`. The tables (rows,
//! layout, header) are [`crate::hair::dual_table`] and [`crate::hair::azimuthal_table`]. See
//! `docs/hair.md`.

#[path = "hair_azimuthal.rs"]
mod azimuthal;
#[path = "hair_dual.rs"]
mod dual;
#[path = "hair_job.rs"]
mod job;

pub use crate::hair::absorption::AbsorptionAxis;
pub use crate::hair::rows::DUAL_TABLE_CHANNELS;
pub use azimuthal::{HairAzimuthalJob, HairAzimuthalParams, HairAzimuthalStage};
pub use dual::{HairDualJob, HairDualParams, HairDualStage, HairModel, dual_table};
pub use job::HairJob;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::table_from_lines as build;

    #[test]
    fn dual_sweep_is_consistent_and_lossless_column_conserves_energy() {
        let t = build(
            &HairDualStage,
            "roughness_deg = [3.0, 10.0]\nabsorption_count = 5\ntheta_count = 9",
        );
        assert_eq!(t.axes.len(), 3);
        // absorption_u = 0 (lossless): a_f + a_b = Σ E = 1 for every θ and roughness.
        for ir in 0..2 {
            for it in 0..9 {
                let base = ((ir * 5) * 9 + it) * DUAL_TABLE_CHANNELS;
                let v = &t.data[base..base + DUAL_TABLE_CHANNELS];
                let e: f32 = v[12..16].iter().sum();
                assert!(
                    (v[0] + v[1] - 1.0).abs() < 1e-5 && (e - 1.0).abs() < 1e-5,
                    "{v:?}"
                );
            }
        }
        // u = 1 (opaque): only R remains.
        let base = ((4) * 9 + 4) * DUAL_TABLE_CHANNELS;
        assert_eq!(t.data[base + 13], 0.0);
        let dbl = t.attributes["quadrature"]["doubling_max_abs_change"]
            .as_f64()
            .unwrap();
        assert!(dbl < 1e-5, "{dbl}");
    }

    /// The whole table at once (`ThetaRowTable::compute`, what `scatterbake dual-scattering`
    /// runs) is the table the stage's tasks build: values, axes, channels and header.
    #[test]
    fn computed_at_once_equals_the_stage_table() {
        use crate::hair::tables::ThetaRowTable;
        for lines in [
            "sigma_a_rgb = [0.2, 0.3, 0.5]\ntheta_count = 7",
            "sigma_a = [0.0, 0.4]\nroughness_deg = [5.0, 9.0]\ntheta_count = 5\naxis_ratio = 0.9\nhigher_order_kd = 0.01",
            "model = \"artist\"\ntheta_count = 6",
        ] {
            let staged = build(&HairDualStage, lines);
            let p: HairDualParams = toml::from_str(lines).unwrap();
            let at_once = dual_table(&p).unwrap().compute().unwrap();
            assert_eq!(staged, at_once, "{lines}");
        }
    }

    #[test]
    fn dual_rejects_bad_parameters() {
        crate::stages::assert_planning(
            &HairDualStage,
            &[
                "absorption_count = 5\nsigma_a = [0.1]",
                "absorption_count = 5\nroughness_deg = [10.0, 5.0]",
                "absorption_count = 5\neta = 0.9",
                "absorption_count = 5\nbogus = 1",
                "model = \"artist\"\nmelanin = [1.0, 0.0]",
            ],
            &["absorption_count = 5"],
        );
    }

    #[test]
    fn dual_artist_and_melanin_tables_build() {
        let t = build(&HairDualStage, "model = \"artist\"\ntheta_count = 5");
        assert_eq!(t.axes[0].name, "colour_channel");
        let t = build(&HairDualStage, "melanin = [0.3, 0.0]\ntheta_count = 5");
        assert_eq!(t.axes[1].name, "colour_channel");
        assert_eq!(t.attributes["sigma_a_rgb"][2].as_f64().unwrap(), 0.3 * 1.37);
    }

    /// Physically invalid diffuse terms and axis ratios are refused at plan time with an error
    /// naming the key; the artist model refuses the physical-fibre keys.
    #[test]
    fn fibre_feature_keys_are_checked_at_plan_time() {
        use crate::stages::plan_from_lines;
        for (stage, base) in [
            (
                &HairDualStage as &dyn crate::stages::Stage,
                "absorption_count = 3\ntheta_count = 3",
            ),
            (
                &HairAzimuthalStage,
                "sigma_a = [0.1]\ntheta_count = 2\nphi_count = 5",
            ),
        ] {
            for (extra, key) in [
                ("lambertian_kd = 0.4", "lambertian_kd"),
                ("lambertian_kd = -0.01", "lambertian_kd"),
                ("higher_order_kd = 0.06", "higher_order_kd"),
                ("higher_order_kd = nan", "higher_order_kd"),
                (
                    "lambertian_kd = 0.2\nhigher_order_kd = 0.03",
                    "higher_order_kd",
                ),
                ("axis_ratio = 0.8", "axis_ratio"),
                ("axis_ratio = 1.2", "axis_ratio"),
            ] {
                let err = match plan_from_lines(stage, &format!("{base}\n{extra}")) {
                    Ok(_) => panic!("{extra} accepted"),
                    Err(e) => e.to_string(),
                };
                assert!(err.contains(&format!("`{key}`")), "{extra}: {err}");
            }
            for ok in [
                "lambertian_kd = 0.3",
                "higher_order_kd = 0.05",
                "axis_ratio = 0.85",
                "axis_ratio = 1.0",
            ] {
                assert!(
                    plan_from_lines(stage, &format!("{base}\n{ok}")).is_ok(),
                    "{ok}"
                );
            }
        }
        for key in [
            "lambertian_kd = 0.1",
            "higher_order_kd = 0.01",
            "axis_ratio = 0.9",
        ] {
            let err = plan_from_lines(&HairDualStage, &format!("model = \"artist\"\n{key}"))
                .err()
                .expect("refused")
                .to_string();
            assert!(err.contains(key.split(' ').next().unwrap()), "{err}");
        }
    }

    /// Without the new keys the parameters recorded in the header are those of earlier
    /// versions (no new entries), and a = 1 written explicitly gives the same data.
    #[test]
    fn defaults_leave_tables_unchanged() {
        let job =
            HairDualJob::new(toml::from_str("absorption_count = 3\ntheta_count = 5").unwrap())
                .unwrap();
        let p = crate::stages::Job::parameters(&job);
        for key in ["lambertian_kd", "higher_order_kd", "axis_ratio"] {
            assert!(p.get(key).is_none(), "{key} in {p}");
        }
        let a = build(&HairDualStage, "absorption_count = 3\ntheta_count = 5");
        let b = build(
            &HairDualStage,
            "absorption_count = 3\ntheta_count = 5\naxis_ratio = 1.0\nlambertian_kd = 0.0",
        );
        assert_eq!(a.data, b.data);
        assert!(b.attributes.get("diffuse").is_none() && b.attributes.get("elliptic").is_none());
    }

    /// hair-azimuthal with an elliptic fibre and diffuse terms: the lossless lobes still
    /// integrate to 1, TRT moves, the `diffuse` channel holds f_d with ∫ f_d dφ =
    /// 2 lambertian_kd + 4π higher_order_kd.
    #[test]
    fn azimuthal_table_with_fibre_features() {
        let np = 721;
        let t = build(
            &HairAzimuthalStage,
            "sigma_a = [0.0]\ntheta_count = 2\nphi_count = 721\nazimuthal_width_deg = 3.0\naxis_ratio = 0.9\nlambertian_kd = 0.2\nhigher_order_kd = 0.01",
        );
        let c0 = build(
            &HairAzimuthalStage,
            "sigma_a = [0.0]\ntheta_count = 2\nphi_count = 721\nazimuthal_width_deg = 3.0",
        );
        assert_eq!(t.channels.len(), 6);
        assert_eq!(t.channels[5].name, "diffuse");
        let step = std::f64::consts::PI / 720.0;
        let integral = |data: &[f32], nc: usize, c: usize| {
            (0..np)
                .map(|j| {
                    let w = if j == 0 || j == np - 1 { 0.5 } else { 1.0 };
                    2.0 * w * step * data[j * nc + c] as f64
                })
                .sum::<f64>()
        };
        let sum = integral(&t.data, 6, 4);
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
        let d = integral(&t.data, 6, 5);
        let want = 2.0 * 0.2 + 4.0 * std::f64::consts::PI * 0.01;
        assert!((d - want).abs() < 1e-5, "{d} vs {want}");
        let moved = (0..np)
            .map(|j| (t.data[j * 6 + 2] - c0.data[j * 5 + 2]).abs())
            .fold(0.0f32, f32::max);
        assert!(moved > 1e-3, "{moved}");
        for j in 0..np {
            assert_eq!(t.data[j * 6], c0.data[j * 5]);
            assert_eq!(t.data[j * 6 + 1], c0.data[j * 5 + 1]);
        }
        assert!(t.attributes["elliptic"]["axis_ratio"].as_f64() == Some(0.9));
        // Quadrature doubling (h panels halved and 16 instead of 8 orientation nodes).
        let dbl = t.attributes["quadrature"]["doubling_max_rel_change"]
            .as_f64()
            .unwrap();
        println!("hair-azimuthal, axis_ratio 0.9, w_φ = 3°: doubling_max_rel_change {dbl:.2e}");
        assert!(dbl < 1e-6, "{dbl}");
        // hair-dual with the smallest axis ratio, smooth and rough fibre.
        for ratio in ["0.0", "1.0"] {
            let t = build(
                &HairDualStage,
                &format!(
                    "sigma_a = [0.0, 0.3]\ntheta_count = 13\naxis_ratio = 0.85\nazimuthal_width_ratio = {ratio}\nroughness_deg = [5.0]"
                ),
            );
            let dbl = t.attributes["quadrature"]["doubling_max_abs_change"]
                .as_f64()
                .unwrap();
            println!(
                "hair-dual, axis_ratio 0.85, w_φ/β_R = {ratio}: doubling_max_abs_change {dbl:.2e}"
            );
            assert!(dbl < 1e-6, "{dbl}");
            // Lossless column: ā_f + ā_b = 1 (no clamp reached at β_R = 5°? checked via E_p).
            for it in 0..13 {
                let v = &t.data[it * DUAL_TABLE_CHANNELS..(it + 1) * DUAL_TABLE_CHANNELS];
                let e: f32 = v[12..16].iter().sum();
                assert!((e - 1.0).abs() < 1e-5, "{v:?}");
            }
        }
    }

    #[test]
    fn azimuthal_table_is_normalised() {
        let t = build(
            &HairAzimuthalStage,
            "sigma_a = [0.0, 0.5]\ntheta_count = 4\nphi_count = 721\nazimuthal_width_deg = 3.0",
        );
        // σ_a = 0: ∫_{−π}^{π} sum dφ = 1 (trapezoid over [0, π], doubled).
        let np = 721;
        let step = std::f64::consts::PI / 720.0;
        for it in 0..4 {
            let mut s = 0.0;
            for j in 0..np {
                let w = if j == 0 || j == np - 1 { 0.5 } else { 1.0 };
                s += 2.0 * w * step * t.data[(it * np + j) * 5 + 4] as f64;
            }
            assert!((s - 1.0).abs() < 1e-5, "θ index {it}: {s}");
        }
    }
}
