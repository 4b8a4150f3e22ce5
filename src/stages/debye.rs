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

use crate::debye::filtered::compute_debye_entry;
use crate::stages::common::{
    CONTRACT_CHANNELS, FilteredPhase, filtered_phase_params, phase_chunk, scalar_arrays,
};
use crate::stages::phase_contract;
use crate::stages::{Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, checks};
use crate::table::{Axis, Channel, Schema, TableContent};

/// The stage.
pub struct DebyeStage;

filtered_phase_params! {
    /// Parameters of `[table.params]`.
    pub struct DebyeParams {
        /// Drop radii (µm), strictly increasing.
        pub radii_um: Vec<f64> = required,
            "list of float, µm", "monodisperse drop radii, strictly increasing";
        /// Debye orders `p` to tabulate (0 = diffraction + external reflection, 1 = transmission,
        /// 2 = primary bow, 3 = secondary bow, …); distinct.
        pub orders: Vec<usize> = default(vec![0, 1, 2, 3]),
            "list of integer",
            "Debye orders p (0 diffraction+reflection, 1 transmission, 2 primary, 3 secondary, ...); channels phase/i_perp/i_par/dolp hold their coherent sum, phase_p<k> each order";
    }
}

/// Maximum Debye order accepted.
pub const MAX_ORDER: usize = 1000;

/// Gauss–Legendre points of the filter settings; unused (monodisperse entries only).
const RADIUS_POINTS_UNUSED: usize = 4;

struct DebyeJob {
    p: DebyeParams,
    filter: FilteredPhase,
}

impl StageSpec for DebyeStage {
    const NAME: &'static str = "debye";
    /// 2: axes radius × wavelength × angle, efficiencies kept in f64. 3: `sadeghi-table-3.2`
    /// corrected at 580–650 nm; attribute `sun_diameter_deg`. 4: the surface coefficients are
    /// regular where sin(mx) vanishes (mx = kπ: the orders were wrong there).
    const VERSION: u32 = 4;
    const SUMMARY: &'static str = "Mie phase functions of water drops split into Debye-series orders (p = 0 reflection+diffraction, 1, 2 primary, 3 secondary, ...)";
    type Params = DebyeParams;
    fn plan_params(&self, p: DebyeParams) -> Result<Box<dyn Job>, PlanError> {
        checks::increasing("wavelengths_nm", &p.wavelengths_nm, true)?;
        checks::increasing("radii_um", &p.radii_um, true)?;
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
        let filter = FilteredPhase::plan(p.filter_keys(0.0, RADIUS_POINTS_UNUSED))?;
        filter.check_domain("radii_um", &p.radii_um, 1.0)?;
        Ok(Box::new(DebyeJob { p, filter }))
    }
}

impl DebyeJob {
    fn radius_axis(&self) -> Axis {
        Axis::values("radius", "um", self.p.radii_um.clone())
    }
}

impl Job for DebyeJob {
    /// Known at plan time (checked against the reader's limit before any task runs).
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(
            self.filter.axes(self.radius_axis()),
            CONTRACT_CHANNELS + self.p.orders.len(),
        )
    }
    /// One sphere per radius and wavelength, with the Debye orders' extra recurrences
    /// (`DEBYE_COST_FACTOR`).
    fn estimated_cpu_seconds(&self) -> f64 {
        let spheres: f64 = (self.p.radii_um.iter())
            .map(|&r| self.filter.estimated_entry_cpu_s(r, 1.0))
            .sum();
        crate::stages::cost::DEBYE_COST_FACTOR * spheres
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_DEBYE
    }
    /// Per task: cross-sections, asymmetry and the water index in the header.
    fn estimated_attribute_bytes(&self) -> u64 {
        use crate::stages::cost::{ATTRIBUTE_BYTES, ATTRIBUTE_BYTES_PER_SCALAR};
        ATTRIBUTE_BYTES + ATTRIBUTE_BYTES_PER_SCALAR * 5 * self.tasks().len() as u64
    }
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.filter.tasks(self.p.radii_um.len(), |e, l, n| {
            let r = self.p.radii_um[e];
            TaskSpec {
                label: format!("λ={l} nm r={r} µm orders {:?}", self.p.orders),
                params: serde_json::json!({ "wavelength_nm": l, "n": n, "radius_um": r, "orders": self.p.orders }),
            }
        })
    }
    /// Chunk: per angle the contract channels of the sum of the orders, then each order's
    /// phase; then Q_sca and each order's efficiency.
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let (e, wavelength_nm, m) = self.filter.task(index);
        let r = compute_debye_entry(
            self.p.radii_um[e],
            wavelength_nm,
            m,
            &self.p.orders,
            &self.filter.settings,
            self.filter.sun(),
        )?;
        let per_order: Vec<Vec<f64>> = r.orders.iter().map(|c| c.phase()).collect();
        let mut scalars = vec![r.q_sca];
        scalars.extend(&r.order_efficiency);
        Ok(phase_chunk(&r.sum, &per_order, &scalars))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let (data, tails) = self.filter.split_chunks(
            chunks,
            self.p.radii_um.len(),
            CONTRACT_CHANNELS + self.p.orders.len(),
            1 + self.p.orders.len(),
        )?;
        let q_sca = scalar_arrays(&tails, 0);
        let q_orders: Vec<Vec<Vec<f64>>> = tails
            .iter()
            .map(|row| row.iter().map(|t| t[1..].to_vec()).collect())
            .collect();
        let mut a = self.filter.attributes(
            "integral over 4pi sr equals 1 for the full sphere: every channel (the sum of the chosen orders and each order alone) is divided by the full Mie pi x^2 Q_sca, so a subset of orders integrates to its energy share",
        );
        let s = |v: &str| serde_json::Value::from(v);
        a.insert("validated_domain".into(), s("1e-3 <= x <= 1e5, 1.05 <= Re m <= 2.5, 0 <= Im m <= 1 (the Mie domain); closed-form sum over all orders equals Mie to <= 5e-12 relative in s11 at x = 100, 1000, 1e4 (see docs/debye.md)"));
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
            encoding: Default::default(),
            schema: Schema::new("debye-phase", 1),
            description: "Lorenz-Mie phase functions of water drops split into Debye-series orders"
                .into(),
            axes: self.filter.axes(self.radius_axis()),
            channels,
            attributes: a,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::common::bin_integrals;

    #[test]
    fn rejects_bad_params() {
        crate::stages::assert_planning(
            &DebyeStage,
            &[
                "radii_um = [10.0]\nangle_step_deg = 0.07",
                "radii_um = [10.0]\norders = [2, 2]",
                "radii_um = [10.0]\norders = []",
                "radii_um = [1e5]\nwavelengths_nm = [380.0]",
                "radii_um = [10.0]\nunknown = 1",
            ],
            &["radii_um = [10.0]"],
        );
    }

    /// End to end: shape and channels; all orders 0..=60 together integrate to ≈ 1 (the rest is
    /// the tail p > 60 of the grazing waves); the per-order integrals equal the order
    /// efficiencies over Q_sca (an independent coefficient sum), and phase = (i_perp + i_par)/2.
    #[test]
    fn small_job_orders_add_up() {
        let all: Vec<String> = (0..=60).map(|p| p.to_string()).collect();
        let t = crate::stages::table_from_lines(
            &DebyeStage,
            &format!(
                "radii_um = [20.0]\nwavelengths_nm = [650.0]\nangle_step_deg = 0.5\nsun_diameter_deg = 0.0\norders = [{}]",
                all.join(", ")
            ),
        );
        assert_eq!(t.data.len(), t.expected_len());
        assert_eq!(t.channels[4].name, "phase_p0");
        let nc = t.channels.len();
        let cells = crate::mie::filters::cell_solid_angles(360);
        let integral = |c: usize| -> f64 { bin_integrals(&t.data, nc, c, &cells)[0] };
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
            let t = crate::stages::table_from_lines(
                &DebyeStage,
                &format!(
                    "radii_um = [50.0]\nwavelengths_nm = [550.0]\nangle_step_deg = 0.25\nsun_diameter_deg = {sun}\norders = [0, 2]"
                ),
            );
            let cells = crate::mie::filters::cell_solid_angles(720);
            let nc = t.channels.len();
            (0..nc)
                .map(|c| bin_integrals(&t.data, nc, c, &cells)[0])
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
