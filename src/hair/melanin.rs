//! Melanin concentration → absorption coefficient, the mapping used by pbrt-v3/v4
//! (`HairBSDF::SigmaAFromConcentration`) after Chiang et al. 2016, "A Practical and
//! Controllable Hair and Fur Model for Production Path Tracing" (constants fitted to the
//! eumelanin/pheomelanin spectra of d'Eon et al. 2011):
//!
//! `σ_a = c_eu · (0.419, 0.697, 1.37) + c_pheo · (0.187, 0.4, 1.05)` (linear sRGB channels),
//!
//! in units of 1/radius with the internal chord `2 cos γ_t / cos θ_t` (the convention of
//! [`super::fiber`], which is pbrt's: unit radius, `h ∈ [−1, 1]`). Typical concentrations:
//! blond ≈ 0.3, brown ≈ 1.3, black ≈ 8 (eumelanin); red hair adds pheomelanin ≈ 1–2.

/// Eumelanin absorption per unit concentration (R, G, B), per unit radius.
pub const EUMELANIN_SIGMA_A: [f64; 3] = [0.419, 0.697, 1.37];
/// Pheomelanin absorption per unit concentration (R, G, B), per unit radius.
pub const PHEOMELANIN_SIGMA_A: [f64; 3] = [0.187, 0.4, 1.05];

/// RGB absorption coefficient for eumelanin / pheomelanin concentrations (both ≥ 0).
pub fn sigma_a_from_melanin(eumelanin: f64, pheomelanin: f64) -> [f64; 3] {
    std::array::from_fn(|i| eumelanin * EUMELANIN_SIGMA_A[i] + pheomelanin * PHEOMELANIN_SIGMA_A[i])
}

/// Absorption axis remapping used by the LUTs: `u = 1 − exp(−2 σ_a)` (the transmittance loss of
/// one central TT pass), so `u ∈ [0, 1]` covers `σ_a ∈ [0, ∞]` and ā_f is nearly linear in `u`.
pub fn absorption_u_from_sigma_a(sigma_a: f64) -> f64 {
    -(-2.0 * sigma_a).exp_m1()
}

/// Inverse of [`absorption_u_from_sigma_a`]; `u = 1` maps to `+∞` (opaque interior).
pub fn sigma_a_from_absorption_u(u: f64) -> f64 {
    if u >= 1.0 {
        f64::INFINITY
    } else {
        -0.5 * (-u).ln_1p()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn melanin_mapping_is_linear_and_remap_round_trips() {
        let s = sigma_a_from_melanin(1.0, 0.0);
        assert_eq!(s, EUMELANIN_SIGMA_A);
        let s = sigma_a_from_melanin(2.0, 1.0);
        assert!((s[2] - (2.0 * 1.37 + 1.05)).abs() < 1e-12);
        for sa in [0.0, 1e-6, 0.3, 2.0, 5.0] {
            let u = absorption_u_from_sigma_a(sa);
            assert!((sigma_a_from_absorption_u(u) - sa).abs() <= 1e-6 * (1.0 + sa));
        }
        assert_eq!(sigma_a_from_absorption_u(1.0), f64::INFINITY);
    }
}
