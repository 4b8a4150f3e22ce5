//! `cloth` stage: the microcylinder cloth BRDF of Sadeghi et al. 2013 (thesis ch. 5) of one
//! fabric preset on a 4-D angle grid, with sampling CDFs, the directional albedo in the header
//! and the energy verdict. Physics and grids: [`crate::cloth`]; layout: `docs/cloth.md`.

use crate::cloth::tabulate::{
    CHANNELS, CHECK_THETA_DEG, EnergyMode, GridSpec, HalfGrid, albedo_summary, interpolation_error,
    lookup_f, tabulate_row,
};
use crate::cloth::{ClothModel, ModelOptions, PRESET_NAMES, preset};
use crate::stages::{
    Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, check_chunks, stage_params,
};
use crate::table::{Axis, Channel, Schema, TableContent};

/// The stage.
pub struct ClothStage;

stage_params! {
    /// Parameters of `[table.params]`.
    pub struct ClothParams {
        /// Fabric preset.
        pub fabric: String = required, "string",
            "linen_plain, silk_crepe_de_chine, polyester_satin_front, polyester_satin_back, silk_shot or velvet";
        /// θ_i cell size below the grazing band, degrees.
        pub light_step_deg: f64 = default(10.0), "float, deg",
            "θ_i cell size below 90° − grazing_deg (cell centres); must divide it";
        /// Width of the grazing band of θ_i, degrees.
        pub grazing_deg: f64 = default(10.0), "float, deg",
            "θ_i above 90° − grazing_deg is split into cells of grazing_step_deg (0: none)";
        /// θ_i cell size in the grazing band, degrees.
        pub grazing_step_deg: f64 = default(1.25), "float, deg",
            "θ_i cell size in the grazing band; must divide grazing_deg";
        /// Step of the φ_i nodes, degrees.
        pub phi_i_step_deg: f64 = default(5.0), "float, deg",
            "step of the φ_i nodes over the fabric's fundamental domain; must divide 45";
        /// Half-angle spacing over the lobes, as a fraction of γ_s.
        pub half_fine: f64 = default(0.5), "float",
            "spacing of the half-angle axes over a family's lobes, as a fraction of its γ_s";
        /// Largest half-angle spacing, degrees.
        pub half_coarse_deg: f64 = default(7.5), "float, deg",
            "largest spacing of the half-angle axes, away from the lobes";
        /// End of the half-angle axes, degrees.
        pub half_max_deg: f64 = default(88.0), "float, deg",
            "the half-angle axes span [-half_max_deg, half_max_deg]";
        /// Tangent quadrature step, degrees.
        pub ramp_step_deg: f64 = default(1.0), "float, deg",
            "largest step in tangent elevation on the ramps of the tangent curves";
        /// Energy handling near grazing incidence.
        pub energy: String = default("as-printed".to_string()), "string",
            "as-printed (the thesis's model; albedo > 1 near grazing) or clamp (rows scaled to albedo ≤ 1)";
        /// Points of the interpolation-error estimate.
        pub check_points: usize = default(20000), "integer",
            "off-grid points where the table is compared with the model evaluated directly";
    }
}

impl StageSpec for ClothStage {
    const NAME: &'static str = "cloth";
    const VERSION: u32 = 3;
    const SUMMARY: &'static str = "microcylinder cloth BRDF (Sadeghi et al. 2013) of a fabric preset, with sampling CDFs and albedo";
    type Params = ClothParams;
    fn plan_params(&self, p: ClothParams) -> Result<Box<dyn Job>, PlanError> {
        let fabric = preset(&p.fabric).map_err(|e| PlanError::invalid("fabric", e.to_string()))?;
        let spec = GridSpec {
            light_step_deg: p.light_step_deg,
            grazing_deg: p.grazing_deg,
            grazing_step_deg: p.grazing_step_deg,
            phi_i_step_deg: p.phi_i_step_deg,
            half_fine: p.half_fine,
            half_coarse_deg: p.half_coarse_deg,
            half_max_deg: p.half_max_deg,
        };
        let grid = HalfGrid::new(&fabric, spec).map_err(|e| {
            let key = match e {
                crate::cloth::tabulate::GridError::ThetaI(..) => "light_step_deg",
                crate::cloth::tabulate::GridError::PhiI(_) => "phi_i_step_deg",
                crate::cloth::tabulate::GridError::HalfFine(_) => "half_fine",
                crate::cloth::tabulate::GridError::HalfCoarse(_) => "half_coarse_deg",
                crate::cloth::tabulate::GridError::HalfMax(_) => "half_max_deg",
            };
            PlanError::invalid(key, e.to_string())
        })?;
        if !(p.ramp_step_deg > 0.0 && p.ramp_step_deg <= 10.0) {
            return Err(PlanError::invalid("ramp_step_deg", "must be in (0, 10]"));
        }
        let energy = match p.energy.as_str() {
            "as-printed" => EnergyMode::AsPrinted,
            "clamp" => EnergyMode::Clamp,
            _ => return Err(PlanError::invalid("energy", "must be as-printed or clamp")),
        };
        let options = ModelOptions {
            ramp_step_deg: p.ramp_step_deg,
            ..ModelOptions::default()
        };
        Ok(Box::new(ClothJob {
            model: ClothModel::new(fabric, options),
            grid,
            energy,
            p,
        }))
    }
}

/// A planned cloth table.
pub struct ClothJob {
    p: ClothParams,
    model: ClothModel,
    grid: HalfGrid,
    energy: EnergyMode,
}

impl ClothJob {
    /// Values of one task: the θ_i row, then per φ_i the albedo (RGB) and the energy scale.
    /// Scalars of a task: the RGB directional albedo and the energy scale per φ_i.
    fn scalars_len(&self) -> usize {
        4 * self.grid.phi_i_deg.len()
    }
}

impl ClothJob {
    /// Axes: θ_i × φ_i × β_x × β_y (degrees).
    fn table_axes(&self) -> Vec<Axis> {
        let g = &self.grid;
        let s = self.p.phi_i_step_deg;
        vec![
            Axis::values("theta_i", "deg", g.theta_i_deg.clone()),
            Axis::uniform("phi_i", "deg", g.phi_i_deg[0], s, g.phi_i_deg.len()),
            Axis::values("half_x", "deg", g.half_x_deg.clone()),
            Axis::values("half_y", "deg", g.half_y_deg.clone()),
        ]
    }
}

impl Job for ClothJob {
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.grid
            .theta_i_deg
            .iter()
            .map(|t| TaskSpec {
                label: format!("{} θ_i={t}°", self.p.fabric),
                params: serde_json::json!({ "theta_i_deg": t }),
            })
            .collect()
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let row = tabulate_row(&self.model, &self.grid, index, self.energy);
        let mut scalars = Vec::with_capacity(self.scalars_len());
        for (a, s) in row.albedo.iter().zip(&row.scale) {
            scalars.extend(a);
            scalars.push(*s);
        }
        Ok(Chunk::new(row.values, scalars))
    }
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.table_axes(), channels().len())
    }
    /// Every node of the grid: its view prepared and the BRDF evaluated, plus the cell
    /// integrals, measured at 3.6 × `cost::CLOTH_VALUE_CPU_S` per node (25.4 s user for the
    /// 3.2·10⁶ nodes of `manifests/cloth.toml`).
    fn estimated_cpu_seconds(&self) -> f64 {
        let nodes = self.grid.theta_i_deg.len() * self.grid.row_len() / CHANNELS.len();
        3.6 * crate::stages::cost::CLOTH_VALUE_CPU_S * nodes as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_CLOTH
    }
    /// The directional albedo (RGB) and sampling scale of every (θ_i, φ_i).
    fn estimated_attribute_bytes(&self) -> u64 {
        use crate::stages::cost::{ATTRIBUTE_BYTES, ATTRIBUTE_BYTES_PER_SCALAR};
        let n = (self.grid.theta_i_deg.len() * self.grid.phi_i_deg.len()) as u64;
        ATTRIBUTE_BYTES + ATTRIBUTE_BYTES_PER_SCALAR * 4 * n
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let n = self.grid.row_len();
        check_chunks(&chunks, self.grid.theta_i_deg.len(), n, self.scalars_len())?;
        let mut data = Vec::with_capacity(n * chunks.len());
        let (mut albedo, mut scale) = (Vec::new(), Vec::new());
        for c in &chunks {
            data.extend_from_slice(&c.values);
            let tail: Vec<[f64; 4]> = c
                .scalars
                .chunks(4)
                .map(|x| [x[0], x[1], x[2], x[3]])
                .collect();
            albedo.push(tail.iter().map(|x| [x[0], x[1], x[2]]).collect::<Vec<_>>());
            scale.push(tail.iter().map(|x| x[3]).collect::<Vec<_>>());
        }
        let attributes = self.attributes(&data, &albedo, &scale)?;
        Ok(TableContent {
            encoding: Default::default(),
            schema: Schema::new("cloth-brdf", 2),
            description: format!(
                "cloth BRDF f(omega_i -> omega_r) of {} (Sadeghi et al. 2013), 1/sr, with sampling CDFs",
                self.p.fabric
            ),
            axes: self.table_axes(),
            channels: channels(),
            attributes,
            data,
        })
    }
}

fn channels() -> Vec<Channel> {
    let meaning = [
        "K = f(omega_i -> omega_r) cos theta_i, red (linear Rec. 709), 1/sr; f = K / cos theta_i",
        "K = f cos theta_i, green, 1/sr",
        "K = f cos theta_i, blue, 1/sr",
        "marginal CDF over half_x intervals of the luminance of f cos theta_r domega_r (value at this half_x node: weight of the intervals before it)",
        "conditional CDF over half_y intervals, given the half_x interval that starts at this half_x node (value at this half_y node); the last half_x node repeats the previous one",
    ];
    CHANNELS
        .iter()
        .zip(meaning)
        .map(|(n, m)| Channel::new(n, if n.starts_with("cdf") { "1" } else { "1/sr" }, m))
        .collect()
}

impl ClothJob {
    /// Header attributes: frame, readings, symmetry, albedo grid, energy verdict and the
    /// measured interpolation error.
    fn attributes(
        &self,
        data: &[f32],
        albedo: &[Vec<[f64; 3]>],
        scale: &[Vec<f64>],
    ) -> Result<serde_json::Map<String, serde_json::Value>, JobError> {
        use crate::table::interp::{locate, multilinear};
        let g = &self.grid;
        let summary = albedo_summary(g, albedo);
        let clamp = self.energy == EnergyMode::Clamp;
        let scale_at = |t: f64, p: f64| {
            let pos = [locate(&g.theta_i_deg, t), locate(&g.phi_i_deg, p)];
            let n_p = g.phi_i_deg.len();
            multilinear(&pos, &[g.theta_i_deg.len(), n_p], |k| {
                scale[k / n_p][k % n_p]
            })
        };
        let domain = (g.phi_i_deg[0], g.phi_i_deg[g.phi_i_deg.len() - 1]);
        let (l2, max) = interpolation_error(
            &self.model,
            domain,
            self.p.check_points,
            |q| lookup_f(g, data, q),
            scale_at,
        );
        let sym = self.model.fabric().symmetry();
        let value = serde_json::json!({
            "model": "Sadeghi, Bisker, De Deken & Jensen 2013 microcylinder cloth model (thesis ch. 5, eqs. 5.6-5.20); readings CLOTH-1..CLOTH-12 of docs/decisions.md",
            "fabric": self.p.fabric,
            "presets": PRESET_NAMES,
            "frame": "cloth normal +z, warp (family 1) +x, weft +y; theta from the normal, phi from +x toward +y; omega_i toward the light (the model is not reciprocal: do not swap)",
            "symmetry": {
                "mirror_x": sym.mirror_x, "mirror_y": sym.mirror_y, "swap_xy": sym.swap_xy,
                "phi_i_domain_deg": [domain.0, domain.1],
                "reduce": "apply the same mirrors to phi_i and phi_r until phi_i lies in the domain: y->-y (phi -> -phi), x->-x (phi -> 180-phi), x<->y (phi -> 90-phi)",
            },
            "grid": "theta_i at the centres of cells tiling [0, 90] deg (light_step_deg, then grazing_step_deg over the last grazing_deg), phi_i nodes over the domain; half_x, half_y: projected half angles of h = (omega_i + omega_r)/|omega_i + omega_r|, half_x = atan2(h_x, h_z), half_y = atan2(h_y, h_z), non-uniform nodes (fine over the thread families' specular lines half_x = -alpha (warp), half_y = -alpha (weft))",
            "half_axes": {
                "half_fine_over_gamma_s": self.p.half_fine,
                "half_coarse_deg": self.p.half_coarse_deg,
                "half_max_deg": self.p.half_max_deg,
            },
            "lookup": "reduce (phi_i, phi_r) by the mirrors; 0 unless both directions are above the horizon; h from the reduced directions; K by multilinear interpolation in (theta_i, phi_i, half_x, half_y), clamped at the axis ends; f = K / cos theta_i",
            "interpolation": "multilinear",
            "interpolation_error_l2_relative": l2,
            "interpolation_error_max_over_peak": max,
            "interpolation_check_points": self.p.check_points,
            "interpolation_check": format!(
                "luminance of f from the lookup against the model evaluated directly at {} Halton points uniform in angle: theta_i, theta_r in [{}, {}] deg, phi_i over the domain, phi_r in [-180, 180] deg; l2 = sqrt(sum d^2 / sum f^2), max = max |d| / max f",
                self.p.check_points, CHECK_THETA_DEG.0, CHECK_THETA_DEG.1
            ),
            "energy": if clamp { "clamp" } else { "as-printed" },
            "energy_conserving": clamp || summary.max <= 1.0,
            "albedo_max_as_printed": summary.max,
            "albedo_above_one_from_theta_i_deg": summary.above_one_from_theta_i_deg,
            "albedo_average_rgb_as_printed": summary.average,
            "albedo_rgb_as_printed": albedo,
            "albedo_layout": "[theta_i][phi_i][rgb] at the table's theta_i and phi_i nodes, directional albedo of the model as printed (trapezoid sum over the half-vector cells)",
            "energy_scale": scale,
            "sampling": "at the (theta_i, phi_i) node nearest the light: pick a half_x interval by cdf_half_x, a half_y interval by cdf_half_y, place (half_x, half_y) uniformly inside, omega_r = 2 (omega_i.h) h - omega_i (lost below the horizon); pdf = w_cell / (W dhalf_x dhalf_y J 4 (omega_i.h)), J = sec^2 half_x sec^2 half_y / (1 + tan^2 half_x + tan^2 half_y)^1.5",
            "tangent_nodes": [self.model.nodes()[0].len(), self.model.nodes()[1].len()],
        });
        match value {
            serde_json::Value::Object(m) => Ok(m),
            _ => unreachable!("json! of an object literal is an object"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::run_in_memory;

    fn plan(toml_text: &str) -> Result<Box<dyn Job>, PlanError> {
        let params: ClothParams = toml::from_str(toml_text).map_err(PlanError::from)?;
        ClothStage.plan_params(params)
    }

    #[test]
    fn bad_parameters_are_refused() {
        assert!(plan("fabric = \"denim\"").is_err());
        assert!(plan("fabric = \"velvet\"\nlight_step_deg = 7.0").is_err());
        assert!(plan("fabric = \"velvet\"\nhalf_max_deg = 90.0").is_err());
        assert!(plan("fabric = \"velvet\"\nenergy = \"fudge\"").is_err());
    }

    #[test]
    fn coarse_table_of_linen() {
        let job = plan(
            "fabric = \"linen_plain\"\nlight_step_deg = 15.0\ngrazing_deg = 0.0\nphi_i_step_deg = 15.0\nhalf_fine = 1.0\nhalf_coarse_deg = 15.0\ncheck_points = 50",
        )
        .unwrap();
        let t = run_in_memory(job.as_ref()).unwrap();
        let lens: Vec<usize> = t.axes.iter().map(|a| a.len()).collect();
        assert_eq!(lens[..2], [6, 4]);
        assert_eq!(lens[2], lens[3]);
        assert!(t.data.iter().all(|v| v.is_finite() && *v >= 0.0));
        assert_eq!(t.attributes["energy_conserving"], true);
        assert!(
            t.attributes["interpolation_error_l2_relative"]
                .as_f64()
                .unwrap()
                > 0.0
        );
    }
}
