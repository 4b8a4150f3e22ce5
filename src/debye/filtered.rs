//! Table curves of one drop split into Debye orders: the coherent sum of chosen orders and each
//! order alone, through the filters of the phase-function tables (cell averages on the fine
//! grid, sun disc, bin averages; [`crate::mie::filters`]).

use super::{DebyeCoefficients, OrderSet};
use crate::mie::filters::{
    FINE_CELL_POINTS, FilterSettings, PolarisedPhase, SunDiscOperator, resample_bins,
};
use crate::mie::{MieError, size_parameter};
use num_complex::Complex64;

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
) -> Result<DebyeEntry, MieError> {
    let x = size_parameter(radius_um, wavelength_nm);
    let d = DebyeCoefficients::new(x, m)?;
    let mid = settings.intermediate_intervals();
    let fine = FilterSettings::fine_grid_intervals(mid, d.n_stop());
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
