//! The `debye` stage (schema `debye-phase/1`): Lorenz–Mie phase functions of monodisperse water
//! drops split into Debye-series orders. Follows the phase-function table contract
//! (`docs/consumers.md`): axes `radius` (µm) × `wavelength` (nm) × `scattering_angle` (deg);
//! channels `phase`, `i_perp`, `i_par`, `dolp` of the coherent sum of the chosen orders, then
//! `phase_p<k>` for each chosen order alone.
//!
//! Normalisation: every channel is divided by the full sphere's `π x² Q_sca` (Mie), so that the
//! per-order curves are on one scale and the full Debye sum integrates to 1; a subset of orders
//! integrates to its share of the scattered energy (plus cross-order interference terms).
//! Filters as in the `mie` stage: cell averages on a fine grid, uniform sun disc, bin averages.

use crate::debye::{DebyeCoefficients, OrderSet};
use crate::mie::filters::{
    FINE_CELL_POINTS, PolarisedPhase, SunDiscOperator, fine_intervals, resample_bins,
};
use crate::mie::{check_domain, size_parameter};
use crate::optics::water::{SADEGHI_WAVELENGTHS_NM, WaterIndexModel};
use crate::stages::mie::FilterSettings;
use crate::stages::{
    Job, ParamDoc, PlanError, Stage, TaskSpec, checks, join_f64, parse_params, split_f64,
};
use crate::table::phase_contract;
use crate::table::{Axis, Channel, Schema, TableContent};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// The stage.
pub struct DebyeStage;

/// Parameters of `[table.params]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DebyeParams {
    /// Vacuum wavelengths (nm), strictly increasing; default: 33 samples 380–700 nm.
    #[serde(default = "default_wavelengths")]
    pub wavelengths_nm: Vec<f64>,
    /// Drop radii (µm), strictly increasing.
    pub radii_um: Vec<f64>,
    /// Debye orders `p` to tabulate (0 = diffraction + external reflection, 1 = transmission,
    /// 2 = primary bow, 3 = secondary bow, …); distinct.
    #[serde(default = "default_orders")]
    pub orders: Vec<usize>,
    /// `iapws1997` or `sadeghi-table-3.2`.
    #[serde(default = "default_model")]
    pub water_index_model: String,
    /// Water temperature for `iapws1997` (°C).
    #[serde(default = "default_temperature")]
    pub temperature_c: f64,
    /// Output angular step (deg); 180/step must be an integer.
    #[serde(default = "default_step")]
    pub angle_step_deg: f64,
    /// Angular diameter of the sun's disc (deg); 0 disables the convolution.
    #[serde(default = "default_sun")]
    pub sun_diameter_deg: f64,
}

fn default_wavelengths() -> Vec<f64> {
    SADEGHI_WAVELENGTHS_NM.to_vec()
}
fn default_orders() -> Vec<usize> {
    vec![0, 1, 2, 3]
}
fn default_model() -> String {
    "iapws1997".into()
}
fn default_temperature() -> f64 {
    20.0
}
fn default_step() -> f64 {
    0.05
}
fn default_sun() -> f64 {
    0.5
}

const PARAMS: &[ParamDoc] = &[
    ParamDoc {
        name: "wavelengths_nm",
        kind: "list of float, nm",
        default: "33 samples 380–700 nm",
        description: "vacuum wavelengths",
    },
    ParamDoc {
        name: "radii_um",
        kind: "list of float, µm",
        default: "required",
        description: "monodisperse drop radii, strictly increasing",
    },
    ParamDoc {
        name: "orders",
        kind: "list of integer",
        default: "[0, 1, 2, 3]",
        description: "Debye orders p (0 diffraction+reflection, 1 transmission, 2 primary, 3 secondary, ...); channels phase/i_perp/i_par/dolp hold their coherent sum, phase_p<k> each order",
    },
    ParamDoc {
        name: "water_index_model",
        kind: "string",
        default: "iapws1997",
        description: "iapws1997 | sadeghi-table-3.2",
    },
    ParamDoc {
        name: "temperature_c",
        kind: "float, °C",
        default: "20",
        description: "water temperature (iapws1997)",
    },
    ParamDoc {
        name: "angle_step_deg",
        kind: "float, deg",
        default: "0.05",
        description: "output bin width; 180/step integer; values are bin averages",
    },
    ParamDoc {
        name: "sun_diameter_deg",
        kind: "float, deg",
        default: "0.5",
        description: "uniform solar disc convolution (0 = off)",
    },
];

/// Maximum Debye order accepted.
pub const MAX_ORDER: usize = 1000;

/// One (wavelength, radius) result: the summed curve, each order's curve, and the
/// efficiencies (Mie `Q_sca`, then each order's own `Q^{(p)}`).
#[derive(Debug, Clone)]
pub struct DebyeEntry {
    pub sum: PolarisedPhase,
    pub orders: Vec<PolarisedPhase>,
    pub q_sca: f64,
    pub order_efficiency: Vec<f64>,
}

/// Computes one entry (pure): the coherent sum of `orders` and each order alone, as cell
/// averages on the fine grid of the sphere, resampled to the intermediate grid, convolved with
/// the sun's disc (`sun`, built on `settings.intermediate_intervals()`) and integrated over the
/// output bins; normalised by the Mie `π x² Q_sca`.
pub fn compute_debye_entry(
    radius_um: f64,
    wavelength_nm: f64,
    m: Complex64,
    orders: &[usize],
    settings: &FilterSettings,
    sun: &SunDiscOperator,
) -> Result<DebyeEntry, crate::mie::MieError> {
    let x = size_parameter(radius_um, wavelength_nm);
    let d = DebyeCoefficients::new(x, m)?;
    let mid = settings.intermediate_intervals();
    let need = fine_intervals(d.n_stop(), mid);
    let mut k = need.div_ceil(mid);
    if k.is_multiple_of(2) {
        k += 1;
    }
    let fine = mid * k;
    let finish = |c: PolarisedPhase| {
        let c = resample_bins(&c, mid);
        let c = sun.apply(&c);
        resample_bins(&c, settings.output_intervals)
    };
    let sum = finish(d.curve(
        &OrderSet::Orders(orders.to_vec()),
        fine,
        FINE_CELL_POINTS,
        false,
    ));
    let mut curves = Vec::with_capacity(orders.len());
    let mut eff = Vec::with_capacity(orders.len());
    for &p in orders {
        let (a, b) = d.coefficients(&OrderSet::Orders(vec![p]));
        eff.push(d.efficiency_of(&a, &b));
        curves.push(finish(d.curve_of(a, b, fine, FINE_CELL_POINTS, false)));
    }
    Ok(DebyeEntry {
        sum,
        orders: curves,
        q_sca: d.mie.efficiencies().q_sca,
        order_efficiency: eff,
    })
}

struct DebyeJob {
    p: DebyeParams,
    model: WaterIndexModel,
    indices: Vec<f64>,
    settings: FilterSettings,
    /// Sun-disc operator on the intermediate grid, built once per job.
    sun: std::sync::OnceLock<SunDiscOperator>,
}

impl Stage for DebyeStage {
    fn name(&self) -> &'static str {
        "debye"
    }
    /// 2: axes radius × wavelength × angle, efficiencies kept in f64.
    fn algorithm_version(&self) -> u32 {
        2
    }
    fn summary(&self) -> &'static str {
        "Mie phase functions of water drops split into Debye-series orders (p = 0 reflection+diffraction, 1, 2 primary, 3 secondary, ...)"
    }
    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMS
    }
    fn plan(&self, params: toml::de::ValueDeserializer<'_>) -> Result<Box<dyn Job>, PlanError> {
        let p: DebyeParams = parse_params(params)?;
        Ok(Box::new(plan_job(p)?))
    }
}

fn plan_job(p: DebyeParams) -> Result<DebyeJob, PlanError> {
    checks::increasing("wavelengths_nm", &p.wavelengths_nm, true)?;
    let r = &p.radii_um;
    checks::increasing("radii_um", r, true)?;
    let mut sorted = p.orders.clone();
    sorted.sort_unstable();
    sorted.dedup();
    if p.orders.is_empty()
        || sorted.len() != p.orders.len()
        || sorted.iter().any(|&o| o > MAX_ORDER)
    {
        return Err(PlanError::invalid(
            "orders",
            format!("must be a non-empty list of distinct orders 0..={MAX_ORDER}"),
        ));
    }
    let (model, indices) = checks::water_indices(
        &p.water_index_model,
        Some(p.temperature_c),
        "wavelengths_nm",
        &p.wavelengths_nm,
    )?;
    let output_intervals = checks::angle_step_intervals("angle_step_deg", p.angle_step_deg)?;
    if !(0.0..=5.0).contains(&p.sun_diameter_deg) {
        return Err(PlanError::invalid(
            "sun_diameter_deg",
            "must be within 0–5 deg",
        ));
    }
    for &radius in r {
        for (l, n) in p.wavelengths_nm.iter().zip(&indices) {
            check_domain(size_parameter(radius, *l), Complex64::new(*n, 0.0)).map_err(|err| {
                PlanError::invalid("radii_um", format!("radius {radius} µm at {l} nm: {err}"))
            })?;
        }
    }
    let settings = FilterSettings {
        output_intervals,
        sun_diameter_deg: p.sun_diameter_deg,
        gaussian_sigma_deg: 0.0,
        radius_points: 4,
    };
    Ok(DebyeJob {
        p,
        model,
        indices,
        settings,
        sun: std::sync::OnceLock::new(),
    })
}

impl DebyeJob {
    fn channels_per_angle(&self) -> usize {
        4 + self.p.orders.len()
    }
    /// f32 values after the angular data: Q_sca and each order's efficiency, as
    /// [`split_f64`] pairs.
    fn tail(&self) -> usize {
        2 * (1 + self.p.orders.len())
    }
}

impl Job for DebyeJob {
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        let mut out = Vec::new();
        for r in &self.p.radii_um {
            for (l, n) in self.p.wavelengths_nm.iter().zip(&self.indices) {
                out.push(TaskSpec {
                    label: format!("λ={l} nm r={r} µm orders {:?}", self.p.orders),
                    params: serde_json::json!({ "wavelength_nm": l, "n": n, "radius_um": r, "orders": self.p.orders }),
                });
            }
        }
        out
    }
    fn run_task(&self, index: usize) -> anyhow::Result<Vec<f32>> {
        let n_w = self.p.wavelengths_nm.len();
        let (e, w) = (index / n_w, index % n_w);
        let m = Complex64::new(self.indices[w], 0.0);
        let r = compute_debye_entry(
            self.p.radii_um[e],
            self.p.wavelengths_nm[w],
            m,
            &self.p.orders,
            &self.settings,
            self.sun.get_or_init(|| self.settings.sun_operator()),
        )?;
        let (phase, dolp) = (r.sum.phase(), r.sum.dolp());
        let per_order: Vec<Vec<f64>> = r.orders.iter().map(|c| c.phase()).collect();
        let mut out = Vec::with_capacity(phase.len() * self.channels_per_angle() + self.tail());
        for j in 0..phase.len() {
            out.extend([
                phase[j] as f32,
                r.sum.i_perp[j] as f32,
                r.sum.i_par[j] as f32,
                dolp[j] as f32,
            ]);
            out.extend(per_order.iter().map(|c| c[j] as f32));
        }
        out.extend(split_f64(r.q_sca));
        for &v in &r.order_efficiency {
            out.extend(split_f64(v));
        }
        Ok(out)
    }
    fn assemble(&self, chunks: Vec<Vec<f32>>) -> anyhow::Result<TableContent> {
        let n_w = self.p.wavelengths_nm.len();
        let n_a = self.settings.output_intervals + 1;
        let per = n_a * self.channels_per_angle();
        anyhow::ensure!(
            chunks.len() == n_w * self.p.radii_um.len(),
            "wrong number of chunks"
        );
        let mut data = Vec::with_capacity(chunks.len() * per);
        let mut q_sca: Vec<Vec<f64>> = Vec::new();
        let mut q_orders: Vec<Vec<Vec<f64>>> = Vec::new();
        for (i, c) in chunks.iter().enumerate() {
            anyhow::ensure!(
                c.len() == per + self.tail(),
                "chunk {i} has {} values, expected {}",
                c.len(),
                per + self.tail()
            );
            data.extend_from_slice(&c[..per]);
            if i % n_w == 0 {
                q_sca.push(Vec::new());
                q_orders.push(Vec::new());
            }
            let tail: Vec<f64> = c[per..]
                .chunks_exact(2)
                .map(|p| join_f64(p[0], p[1]))
                .collect();
            q_sca.last_mut().expect("row").push(tail[0]);
            q_orders.last_mut().expect("row").push(tail[1..].to_vec());
        }
        let mut a = serde_json::Map::new();
        let s = |v: &str| serde_json::Value::from(v);
        a.extend(phase_contract::attributes(
            "integral over 4pi sr equals 1 for the full sphere: every channel (the sum of the chosen orders and each order alone) is divided by the full Mie pi x^2 Q_sca, so a subset of orders integrates to its energy share",
            &self.model,
            self.p.sun_diameter_deg,
        ));
        a.insert("refractive_index_real".into(), self.indices.clone().into());
        a.insert(
            "sun_disc_model".into(),
            s("uniform disc (no limb darkening), exact 2-D average on the sphere"),
        );
        a.insert("angular_resampling".into(), s("each value is the solid-angle average over its bin [theta - step/2, theta + step/2] (clipped at 0 and 180 deg) of the single-sphere curve, computed as cell averages with 6 Gauss points per cell of at most 180/n_stop deg; no point sampling"));
        a.insert("validated_domain".into(), s("1e-3 <= x <= 1e5, 1.05 <= Re m <= 2.5, 0 <= Im m <= 1 (debye::VALIDATED_DOMAIN); closed-form sum over all orders equals Mie to <= 5e-12 relative in s11 at x = 100, 1000, 1e4 (see docs/debye.md)"));
        a.insert("debye_orders".into(), serde_json::to_value(&self.p.orders)?);
        a.insert("debye_convention".into(), s("Bohren & Huffman exp(-i omega t); a_n = 1/2 (1 - R22) for p = 0 (diffraction + external reflection), a_n = -1/2 T21 T12 R11^(p-1) for p >= 1 (p chords through the drop); p = 2 primary bow, p = 3 secondary"));
        a.insert("conventions".into(), s("i_perp = |S1|^2, i_par = |S2|^2 of the coherent sum of the chosen orders, over (pi x^2 Q_sca); phase = (i_perp + i_par)/2; dolp = (i_perp - i_par)/(i_perp + i_par); phase_p<k> = (|S1_p|^2 + |S2_p|^2)/2 over (pi x^2 Q_sca)"));
        a.insert("q_sca".into(), serde_json::to_value(q_sca)?);
        a.insert("order_efficiency".into(), serde_json::to_value(q_orders)?);
        a.insert("scalar_layout".into(), s("q_sca: [radius][wavelength] (Mie, f64); order_efficiency: [radius][wavelength][order] = (2/x^2) sum (2n+1)(|a_n^(p)|^2 + |b_n^(p)|^2), the efficiency of each order alone (p = 0 includes diffraction, about 1)"));
        let mut channels = phase_contract::channels(
            "of the coherent sum of the chosen orders, over the full Mie pi x^2 Q_sca",
        );
        for &o in &self.p.orders {
            channels.push(Channel::new(
                &format!("phase_p{o}"),
                "1/sr",
                &format!(
                    "Debye order p = {o} alone, (|S1|^2 + |S2|^2)/2 over the full Mie pi x^2 Q_sca"
                ),
            ));
        }
        Ok(TableContent {
            schema: Schema::new("debye-phase", 1),
            description: "Lorenz-Mie phase functions of water drops split into Debye-series orders"
                .into(),
            axes: vec![
                Axis::values("radius", "um", self.p.radii_um.clone()),
                Axis::values("wavelength", "nm", self.p.wavelengths_nm.clone()),
                Axis::uniform("scattering_angle", "deg", 0.0, self.p.angle_step_deg, n_a),
            ],
            channels,
            attributes: a,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(toml_lines: &str) -> Result<Box<dyn Job>, PlanError> {
        crate::stages::plan_from_lines(&DebyeStage, toml_lines)
    }

    #[test]
    fn rejects_bad_params() {
        assert!(plan("radii_um = [10.0]\nangle_step_deg = 0.07").is_err());
        assert!(plan("radii_um = [10.0]\norders = [2, 2]").is_err());
        assert!(plan("radii_um = [10.0]\norders = []").is_err());
        assert!(plan("radii_um = [1e5]\nwavelengths_nm = [380.0]").is_err());
        assert!(plan("radii_um = [10.0]\nunknown = 1").is_err());
        assert!(plan("radii_um = [10.0]").is_ok());
    }

    /// End to end: shape and channels; all orders 0..=60 together integrate to ≈ 1 (the rest is
    /// the tail p > 60 of the grazing waves); the per-order integrals equal the order
    /// efficiencies over Q_sca (an independent coefficient sum), and phase = (i_perp + i_par)/2.
    #[test]
    fn small_job_orders_add_up() {
        let all: Vec<String> = (0..=60).map(|p| p.to_string()).collect();
        let job = plan(&format!("radii_um = [20.0]\nwavelengths_nm = [650.0]\nangle_step_deg = 0.5\nsun_diameter_deg = 0.0\norders = [{}]", all.join(", "))).unwrap();
        let chunks: Vec<Vec<f32>> = (0..job.tasks().len())
            .map(|i| job.run_task(i).unwrap())
            .collect();
        let t = job.assemble(chunks).unwrap();
        assert_eq!(t.data.len(), t.expected_len());
        assert_eq!(t.channels[4].name, "phase_p0");
        let nc = t.channels.len();
        let cells = crate::mie::filters::cell_solid_angles(360);
        let integral = |c: usize| -> f64 {
            t.data
                .chunks(nc)
                .zip(&cells)
                .map(|(v, w)| v[c] as f64 * w)
                .sum()
        };
        let total = integral(0);
        assert!(
            (total - 1.0).abs() < 2e-3,
            "sum of orders 0..=60 integrates to {total}"
        );
        let q_sca = t.attributes["q_sca"][0][0].as_f64().unwrap();
        for p in [0usize, 1, 2, 3] {
            let share = t.attributes["order_efficiency"][0][0][p].as_f64().unwrap() / q_sca;
            let got = integral(4 + p);
            assert!((got / share - 1.0).abs() < 1e-4, "p={p}: {got} vs {share}");
        }
        assert!(
            t.data
                .chunks(nc)
                .all(|c| (c[0] - 0.5 * (c[1] + c[2])).abs() <= 1e-6 * c[0].abs())
        );
    }

    /// The sun disc (0.5°) keeps each order's energy: ∫ phase_p<k> dΩ with and without it agree.
    #[test]
    fn sun_disc_preserves_order_energy() {
        let run = |sun: f64| {
            let job = plan(&format!("radii_um = [50.0]\nwavelengths_nm = [550.0]\nangle_step_deg = 0.25\nsun_diameter_deg = {sun}\norders = [0, 2]")).unwrap();
            let t = job.assemble(vec![job.run_task(0).unwrap()]).unwrap();
            let cells = crate::mie::filters::cell_solid_angles(720);
            let nc = t.channels.len();
            (0..nc)
                .map(|c| {
                    t.data
                        .chunks(nc)
                        .zip(&cells)
                        .map(|(v, w)| v[c] as f64 * w)
                        .sum::<f64>()
                })
                .collect::<Vec<f64>>()
        };
        let (off, on) = (run(0.0), run(0.5));
        for c in [0usize, 4, 5] {
            assert!(
                (on[c] / off[c] - 1.0).abs() < 1e-4,
                "channel {c}: {} vs {}",
                on[c],
                off[c]
            );
        }
    }
}
