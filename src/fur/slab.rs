//! Deterministic longitudinal medulla profiles C^M(θ'_r; θ'_i, σ, g): adding–doubling
//! (van de Hulst 1980; diamond initialisation and flux conservation after Wiscombe 1976) for the
//! 2-D slab of [`crate::fur::medulla`], all incidence angles and all σ of one g at once.
//!
//! **Same quantity as the Monte Carlo.** The slab 0 ≤ x ≤ 2 (medulla radii), purely scattering
//! with coefficient σ, planar Henyey–Greenstein phase function ρ (Tseng 2015 Eq. A.1),
//! index-matched faces. Unit energy enters at x = 0 with propagation direction
//! (cos θ'_i, −sin θ'_i); the result is the scattered energy leaving through each face per exit
//! bin (bins/2 equal cells of θ'_r ∈ [−90°, 90°) per face, sin θ'_r = d_y; lobe 0 = back, exit
//! through x = 0; lobe 1 = forward, exit through x = 2), the layout of
//! [`crate::fur::medulla::Profile`] for [`crate::fur::medulla::Geometry::Longitudinal`].
//!
//! **Discretisation.** Directions are the 2-D circle. Each half circle (down: d_x > 0, up:
//! d_x < 0) is cut into `bins/2 · nodes_per_bin` equal cells of θ = asin(d_y); the cell edges
//! include θ = ±90°, so the discontinuity of the radiance at grazing directions falls on cell
//! edges. The unknowns are the energy fluxes through a plane x = const carried by each cell
//! (radiance × |cos θ| × cell width). Scattering redistributes them with the phase function
//! **integrated over each target cell** (exact, from the planar HG CDF), so redistribution is
//! exactly normalised; attenuation uses the cell-centre cosine. Per unit optical depth:
//!
//! dE⁺/dτ = −(I − P_s)K E⁺ + P_c K E⁻ + S⁺,  −dE⁻/dτ = −(I − P_s)K E⁻ + P_c K E⁺ + S⁻,
//!
//! with K = diag(1/|cos θ_j|), P_s the same-half and P_c the cross-half cell probabilities and
//! S± the first-collision source of the incident beam. The beam itself is never put on a node:
//! its direction is exact (any θ'_i), its first scattering uses the exact cell integrals of ρ and
//! its attenuation exp(−τ/cos θ'_i) is carried analytically through the adding equations, so the
//! incidence grid is independent of the exit bins.
//!
//! **Layers.** A thin layer (optical thickness ≤ `thin_layer`) is initialised with the diamond
//! scheme, which conserves energy exactly for a non-absorbing layer; doubling then builds
//! the increments of the σ grid and the adding equations stack them, so a uniform σ grid costs
//! one adding step per σ. The slab is symmetric about its mid-plane and about d_y → −d_y; the
//! second symmetry makes every operator centrosymmetric, which splits it into an even and an odd
//! block of half size (4× fewer operations).
//!
//! **Path lengths.** The mean in-medulla path length per bin is the derivative of the exiting
//! energy with respect to an absorption coefficient at zero absorption, −∂E/∂σ_a / E, carried
//! exactly through the initialisation and the adding equations (forward-mode differentiation).
//!
//! Pure: no I/O, no threads.

use crate::optics::henyey_greenstein::planar_hg_cdf;
use nalgebra::DMatrix;
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI, SQRT_2};

/// Discretisation settings.
#[derive(Debug, Clone, Copy)]
pub struct SlabSettings {
    /// Exit bins over both faces (bins/2 per face); a multiple of 4.
    pub bins: usize,
    /// Direction cells per exit bin (1 = the bins themselves).
    pub nodes_per_bin: usize,
    /// Extra refinement of the bins next to grazing (θ = ±90°): the d-th bin from either end
    /// is cut into at least `edge_refinement[d]` equal cells. The radiance varies fastest
    /// there (exp(−τ/cos θ) inside a single bin).
    pub edge_refinement: &'static [usize],
    /// Largest optical thickness of the diamond-initialised thin layer.
    pub thin_layer: f64,
}

impl Default for SlabSettings {
    fn default() -> Self {
        SlabSettings {
            bins: 720,
            nodes_per_bin: 1,
            edge_refinement: DEFAULT_EDGE_REFINEMENT,
            thin_layer: DEFAULT_THIN_LAYER,
        }
    }
}

/// Default thin-layer optical thickness (2⁻¹⁵); see the convergence test.
pub const DEFAULT_THIN_LAYER: f64 = 1.0 / 32_768.0;

/// Default refinement of the bins next to grazing (see [`SlabSettings::edge_refinement`]).
pub const DEFAULT_EDGE_REFINEMENT: &[usize] = &[16, 8, 4, 2, 2, 2, 2, 2];

/// One entry (σ, g, θ'_i).
#[derive(Debug, Clone)]
pub struct SlabProfile {
    /// Scattered energy per exit bin per unit incident energy (back lobe, then forward lobe).
    pub energy: Vec<f64>,
    /// Mean in-medulla path length (medulla radii) of the energy in each bin; 0 where empty.
    pub path_length: Vec<f64>,
    /// Unscattered fraction exp(−2σ/cos θ'_i).
    pub ballistic: f64,
    /// Sum of `energy`.
    pub scattered: f64,
}

/// Solve every (σ, θ'_i) of one g. `sigma` ≥ 0 in any order (per unit medulla radius),
/// `theta_i_rad` ∈ (−π/2, π/2). Returns `[σ index][θ'_i index]`.
pub fn solve_slab(
    g: f64,
    sigma: &[f64],
    theta_i_rad: &[f64],
    s: &SlabSettings,
) -> Vec<Vec<SlabProfile>> {
    assert!(
        s.bins >= 8 && s.bins.is_multiple_of(4),
        "bins must be a multiple of 4"
    );
    assert!(s.nodes_per_bin >= 1 && s.thin_layer > 0.0);
    assert!((0.0..1.0).contains(&g), "g must be in [0, 1)");
    assert!(
        theta_i_rad.iter().all(|t| t.abs() < FRAC_PI_2),
        "θ'_i must be inside (−π/2, π/2)"
    );
    let d = Discretisation::new(g, s, theta_i_rad);
    let zero = |theta: f64| SlabProfile {
        energy: vec![0.0; s.bins],
        path_length: vec![0.0; s.bins],
        ballistic: if theta.cos() > 0.0 { 1.0 } else { 0.0 },
        scattered: 0.0,
    };
    let mut out: Vec<Vec<SlabProfile>> = sigma
        .iter()
        .map(|_| theta_i_rad.iter().map(|&t| zero(t)).collect())
        .collect();
    // Ascending positive σ; equal values share one solve.
    let mut order: Vec<usize> = (0..sigma.len()).filter(|&i| sigma[i] > 0.0).collect();
    order.sort_by(|&a, &b| sigma[a].total_cmp(&sigma[b]));
    let mut increments: HashMap<u64, Layer> = HashMap::new();
    let mut current: Option<Layer> = None;
    let mut last_sigma = f64::NAN;
    for &i in &order {
        let sg = sigma[i];
        if sg != last_sigma {
            let target = 2.0 * sg;
            let have = current.as_ref().map_or(0.0, |l| l.tau);
            let step = target - have;
            // Reuse an increment of (relatively) the same thickness: uniform grids differ
            // only by rounding in the last bits.
            let key = increments
                .keys()
                .copied()
                .find(|&k| (f64::from_bits(k) - step).abs() <= 1e-10 * step)
                .unwrap_or_else(|| {
                    increments.insert(step.to_bits(), d.layer(step));
                    step.to_bits()
                });
            let inc = &increments[&key];
            current = Some(match current.take() {
                None => inc.clone(),
                Some(c) => d.add(&c, inc),
            });
            last_sigma = sg;
        }
        let layer = current.as_ref().expect("layer built");
        for (b, prof) in out[i].iter_mut().enumerate() {
            *prof = d.profile(layer, b, sg);
        }
    }
    out
}

/// σ → 0 limit of the longitudinal profile's shape (any scale): single scattering uniformly
/// along the entry chord with every escape probability → 1, i.e. the phase function integrated
/// over each exit bin (back lobe, then forward lobe). Used for the lobe pdf/cdf at σ = 0.
pub fn limit_shape(g: f64, theta_i_rad: f64, bins: usize) -> Vec<f64> {
    let half = bins / 2;
    let bw = PI / half as f64;
    let from = -theta_i_rad;
    let mut e = vec![0.0; bins];
    for j in 0..half {
        let (lo, hi) = (-FRAC_PI_2 + j as f64 * bw, -FRAC_PI_2 + (j + 1) as f64 * bw);
        e[j] = cell_probability(from, PI - hi, PI - lo, g);
        e[half + j] = cell_probability(from, lo, hi, g);
    }
    e
}

/// Angular grid, phase matrices and beam sources of one g.
struct Discretisation {
    /// Direction cells per half circle.
    n: usize,
    /// Half of `n` (size of a parity block).
    k: usize,
    bins: usize,
    /// Exit bin (within a lobe) of each cell.
    cell_bin: Vec<usize>,
    thin_layer: f64,
    /// |cos θ_j| of the first k cells (the rest mirror them).
    mu: Vec<f64>,
    /// Per parity (even, odd): P_s and P_c blocks (k × k).
    ps: [DMatrix<f64>; 2],
    pc: [DMatrix<f64>; 2],
    /// Beam directions: cos θ'_i and, per parity, the cell probabilities of the first
    /// scattering into the down (k × beams) and up (k × beams) halves.
    mu0: Vec<f64>,
    beam_down: [DMatrix<f64>; 2],
    beam_up: [DMatrix<f64>; 2],
}

/// Layer operators of one parity block (k × k) and its beam columns (k × beams). `d*` are
/// path-length moments: −∂/∂κ at κ = 0, κ an absorption coefficient per unit optical depth.
#[derive(Clone)]
struct Block {
    r: DMatrix<f64>,
    t: DMatrix<f64>,
    dr: DMatrix<f64>,
    dt: DMatrix<f64>,
    br: DMatrix<f64>,
    bt: DMatrix<f64>,
    dbr: DMatrix<f64>,
    dbt: DMatrix<f64>,
}

/// A homogeneous layer of optical thickness `tau`.
#[derive(Clone)]
struct Layer {
    tau: f64,
    blocks: [Block; 2],
    /// Direct (unscattered) beam transmission per beam and its path moment.
    e: Vec<f64>,
    de: Vec<f64>,
}

/// ∫_0^δ ρ(θ) dθ for any real δ (unwrapped cumulative planar HG).
fn hg_cumulative(delta: f64, g: f64) -> f64 {
    let turns = (delta / (2.0 * PI)).round();
    let r = delta - turns * 2.0 * PI;
    turns + planar_hg_cdf(r, g) - 0.5
}

/// Probability that a planar-HG deflection of a photon travelling at angle `from` lands in
/// the direction cell [lo, hi].
fn cell_probability(from: f64, lo: f64, hi: f64, g: f64) -> f64 {
    (hg_cumulative(hi - from, g) - hg_cumulative(lo - from, g)).max(0.0)
}

/// Even (p = 0) or odd (p = 1) block of a centrosymmetric n × n matrix given by `f(i, j)`.
fn parity_block(k: usize, n: usize, p: usize, f: impl Fn(usize, usize) -> f64) -> DMatrix<f64> {
    let sign = if p == 0 { 1.0 } else { -1.0 };
    DMatrix::from_fn(k, k, |i, j| f(i, j) + sign * f(i, n - 1 - j))
}

/// Even or odd half of a vector given by `f(i)` (orthonormal transform).
fn parity_vector(k: usize, n: usize, p: usize, f: impl Fn(usize) -> f64) -> Vec<f64> {
    let sign = if p == 0 { 1.0 } else { -1.0 };
    (0..k)
        .map(|i| (f(i) + sign * f(n - 1 - i)) / SQRT_2)
        .collect()
}

impl Discretisation {
    fn new(g: f64, s: &SlabSettings, theta_i_rad: &[f64]) -> Self {
        // Cell edges in θ = asin(d_y) over [−π/2, π/2], symmetric about 0.
        let half = s.bins / 2;
        let bw = PI / half as f64;
        let mut edges = vec![-FRAC_PI_2];
        let mut cell_bin = Vec::new();
        for j in 0..half {
            let from_edge = j.min(half - 1 - j);
            let m = s
                .edge_refinement
                .get(from_edge)
                .copied()
                .unwrap_or(1)
                .max(s.nodes_per_bin);
            for c in 0..m {
                edges.push(-FRAC_PI_2 + (j as f64 + (c + 1) as f64 / m as f64) * bw);
                cell_bin.push(j);
            }
        }
        let n = cell_bin.len();
        edges[n] = FRAC_PI_2;
        let k = n / 2;
        let theta: Vec<f64> = (0..n).map(|j| 0.5 * (edges[j] + edges[j + 1])).collect();
        let mu: Vec<f64> = theta[..k].iter().map(|t| t.cos()).collect();
        // Down cell i: angles [θ_lo, θ_hi]; up cell i: [π − θ_hi, π − θ_lo].
        let down = |i: usize| (edges[i], edges[i + 1]);
        let up = |i: usize| (PI - edges[i + 1], PI - edges[i]);
        let p_same = |i: usize, j: usize| {
            let (lo, hi) = down(i);
            cell_probability(theta[j], lo, hi, g)
        };
        let p_cross = |i: usize, j: usize| {
            let (lo, hi) = down(i);
            cell_probability(PI - theta[j], lo, hi, g)
        };
        let ps = [0, 1].map(|p| parity_block(k, n, p, p_same));
        let pc = [0, 1].map(|p| parity_block(k, n, p, p_cross));
        let mu0: Vec<f64> = theta_i_rad.iter().map(|t| t.cos()).collect();
        let nb = theta_i_rad.len();
        let beam = |cell: &dyn Fn(usize) -> (f64, f64)| {
            [0, 1].map(|p| {
                let mut m = DMatrix::zeros(k, nb);
                for (b, &ti) in theta_i_rad.iter().enumerate() {
                    // Beam propagation angle −θ'_i (d = (cos θ'_i, −sin θ'_i)).
                    let v = parity_vector(k, n, p, |i| {
                        let (lo, hi) = cell(i);
                        cell_probability(-ti, lo, hi, g)
                    });
                    m.column_mut(b).copy_from_slice(&v);
                }
                m
            })
        };
        let beam_down = beam(&down);
        let beam_up = beam(&up);
        Discretisation {
            n,
            k,
            bins: s.bins,
            cell_bin,
            thin_layer: s.thin_layer,
            mu,
            ps,
            pc,
            mu0,
            beam_down,
            beam_up,
        }
    }

    /// A layer of optical thickness `tau`: diamond initialisation, then doubling.
    fn layer(&self, tau: f64) -> Layer {
        let doublings = (tau / self.thin_layer).log2().ceil().max(0.0) as i32;
        let tau0 = tau / 2f64.powi(doublings);
        let mut l = self.thin(tau0);
        for _ in 0..doublings {
            l = self.add(&l, &l);
        }
        l.tau = tau;
        l
    }

    /// Diamond-difference thin layer (Wiscombe 1976), with its κ-derivative.
    fn thin(&self, tau0: f64) -> Layer {
        let k = self.k;
        let id = DMatrix::<f64>::identity(k, k);
        let kdiag = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            k,
            self.mu.iter().map(|m| 1.0 / m),
        ));
        let h = 0.5 * tau0;
        let x: Vec<f64> = self.mu0.iter().map(|m| tau0 / m).collect();
        // Beam source per unit incident energy scattered inside the layer, f = 1 − e^{−x},
        // and its κ-derivative (absorption per unit optical depth).
        let f: Vec<f64> = x.iter().map(|&x| -(-x).exp_m1()).collect();
        let dfk: Vec<f64> = x
            .iter()
            .zip(&f)
            .map(|(&x, &f)| x * (-x).exp() - f)
            .collect();
        let blocks = [0, 1].map(|p| {
            let a = (&id - &self.ps[p]) * &kdiag * h;
            let b = &self.pc[p] * &kdiag * h;
            let da = &kdiag * h; // ∂A/∂κ
            let c = (&id + &a).try_inverse().expect("I + A invertible");
            let dc = -(&c * &da * &c);
            let cb = &c * &b;
            let dcb = &dc * &b;
            let q = &cb * &cb;
            let dq = &dcb * &cb + &cb * &dcb;
            let wm = (&id - &q).try_inverse().expect("I − CBCB invertible");
            let dw = &wm * &dq * &wm;
            let t = (&wm * &c) * 2.0 - &id;
            let dtk = (&dw * &c + &wm * &dc) * 2.0;
            let cbw = &cb * &wm;
            let r = &cbw * &c * 2.0;
            let drk = (&dcb * &wm * &c + &cb * &dw * &c + &cbw * &dc) * 2.0;
            // Beam columns.
            let nb = self.mu0.len();
            let sp = scale_columns(&self.beam_down[p], &f);
            let sm = scale_columns(&self.beam_up[p], &f);
            let dsp = scale_columns(&self.beam_down[p], &dfk);
            let dsm = scale_columns(&self.beam_up[p], &dfk);
            let cbc = &cb * &c;
            let dcbc = &dcb * &c + &cb * &dc;
            let rhs = &cbc * &sp + &c * &sm;
            let br = &wm * &rhs;
            let drhs = &dcbc * &sp + &cbc * &dsp + &dc * &sm + &c * &dsm;
            let dbrk = &dw * &rhs + &wm * &drhs;
            let bt = &c * (&b * &br + &sp);
            let dbtk = &dc * (&b * &br + &sp) + &c * (&b * &dbrk + &dsp);
            debug_assert_eq!(br.ncols(), nb);
            Block {
                r,
                t,
                dr: -drk,
                dt: -dtk,
                br,
                bt,
                dbr: -dbrk,
                dbt: -dbtk,
            }
        });
        Layer {
            tau: tau0,
            blocks,
            e: x.iter().map(|&x| (-x).exp()).collect(),
            de: x.iter().map(|&x| x * (-x).exp()).collect(),
        }
    }

    /// Layer `a` on top of layer `b` (adding equations with path moments). Both layers are
    /// homogeneous, hence symmetric about their mid-planes: reflection and transmission from
    /// below equal those from above in this cell indexing.
    fn add(&self, a: &Layer, b: &Layer) -> Layer {
        let id = DMatrix::<f64>::identity(self.k, self.k);
        let blocks = [0, 1].map(|p| add_blocks(&a.blocks[p], &b.blocks[p], &a.e, &a.de, &id));
        Layer {
            tau: a.tau + b.tau,
            blocks,
            e: a.e.iter().zip(&b.e).map(|(x, y)| x * y).collect(),
            de: (0..a.e.len())
                .map(|i| a.de[i] * b.e[i] + a.e[i] * b.de[i])
                .collect(),
        }
    }

    /// Profile of beam `b` for the layer (τ = 2σ).
    fn profile(&self, layer: &Layer, b: usize, sigma: f64) -> SlabProfile {
        let (n, k) = (self.n, self.k);
        let half = self.bins / 2;
        // Back-transform parity halves to cells.
        let cells = |even: &DMatrix<f64>, odd: &DMatrix<f64>| -> Vec<f64> {
            let mut v = vec![0.0; n];
            for i in 0..k {
                let (e, o) = (even[(i, b)], odd[(i, b)]);
                v[i] = (e + o) / SQRT_2;
                v[n - 1 - i] = (e - o) / SQRT_2;
            }
            v
        };
        let [be, bo] = &layer.blocks;
        let back = cells(&be.br, &bo.br);
        let dback = cells(&be.dbr, &bo.dbr);
        let fwd = cells(&be.bt, &bo.bt);
        let dfwd = cells(&be.dbt, &bo.dbt);
        let mut energy = vec![0.0; self.bins];
        let mut moment = vec![0.0; self.bins];
        for (lobe, (e, de)) in [(&back, &dback), (&fwd, &dfwd)].into_iter().enumerate() {
            for (c, &j) in self.cell_bin.iter().enumerate() {
                energy[lobe * half + j] += e[c];
                moment[lobe * half + j] += de[c];
            }
        }
        // Cells carry non-negative energy; rounding-level negatives are clamped.
        for v in energy.iter_mut() {
            *v = v.max(0.0);
        }
        let path_length = energy
            .iter()
            .zip(&moment)
            .map(|(&e, &m)| if e > 0.0 { m / e / sigma } else { 0.0 })
            .collect();
        SlabProfile {
            scattered: energy.iter().sum(),
            energy,
            path_length,
            ballistic: layer.e[b],
        }
    }
}

/// Adding equations for one parity block: `a` on top of `b`; `ea`, `dea` are the direct beam
/// transmission of `a` and its path moment.
///
/// Diffuse: M = I − R_b R_a, X = M⁻¹ R_b T_a, Y = T_a + R_a X (downward at the interface),
/// R = R_a + T_a X, T = T_b Y. Beam: U = M⁻¹ (R_b t_a + e_a r_b) (upward at the interface),
/// D = t_a + R_a U, r = r_a + T_a U, t = T_b D + e_a t_b. Path moments by the product rule.
fn add_blocks(a: &Block, b: &Block, ea: &[f64], dea: &[f64], id: &DMatrix<f64>) -> Block {
    let minv = (id - &b.r * &a.r)
        .try_inverse()
        .expect("I − R_b R_a is invertible for a scattering slab");
    let x = &minv * (&b.r * &a.t);
    let y = &a.t + &a.r * &x;
    let dx = &minv * (&b.dr * &y + &b.r * (&a.dt + &a.dr * &x));
    let dy = &a.dt + &a.dr * &x + &a.r * &dx;
    let r = &a.r + &a.t * &x;
    let dr = &a.dr + &a.dt * &x + &a.t * &dx;
    let t = &b.t * &y;
    let dt = &b.dt * &y + &b.t * &dy;
    let u = &minv * (&b.r * &a.bt + scale_columns(&b.br, ea));
    let d = &a.bt + &a.r * &u;
    let du = &minv
        * (&b.dr * &d
            + &b.r * (&a.dbt + &a.dr * &u)
            + scale_columns(&b.dbr, ea)
            + scale_columns(&b.br, dea));
    let dd = &a.dbt + &a.dr * &u + &a.r * &du;
    Block {
        br: &a.br + &a.t * &u,
        dbr: &a.dbr + &a.dt * &u + &a.t * &du,
        bt: &b.t * &d + scale_columns(&b.bt, ea),
        dbt: &b.dt * &d + &b.t * &dd + scale_columns(&b.dbt, ea) + scale_columns(&b.bt, dea),
        r,
        t,
        dr,
        dt,
    }
}

/// Multiply column b of `m` by `s[b]`.
fn scale_columns(m: &DMatrix<f64>, s: &[f64]) -> DMatrix<f64> {
    let mut out = m.clone();
    for (b, &v) in s.iter().enumerate() {
        out.column_mut(b).scale_mut(v);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fur::medulla::{Estimator, Geometry, McSettings, simulate, single_scatter_energy};

    fn solve_one(sigma: f64, g: f64, theta_deg: f64, s: &SlabSettings) -> SlabProfile {
        solve_slab(g, &[sigma], &[theta_deg.to_radians()], s)
            .pop()
            .unwrap()
            .pop()
            .unwrap()
    }

    /// Bins that are not among the `edge` outermost of either lobe end.
    fn interior(k: usize, edge: usize) -> bool {
        let j = k % 360;
        j >= edge && j < 360 - edge
    }

    #[test]
    fn energy_is_conserved_and_zero_sigma_is_empty() {
        // No absorption: scattered + ballistic = 1 for every incidence, to rounding.
        let th: Vec<f64> = [-80.0f64, -10.0, 0.0, 45.0, 88.59375]
            .iter()
            .map(|t| t.to_radians())
            .collect();
        for g in [0.0, 0.45, 0.8] {
            let r = solve_slab(g, &[0.0, 0.05, 3.0, 20.0], &th, &SlabSettings::default());
            for (si, row) in r.iter().enumerate() {
                for (ti, p) in row.iter().enumerate() {
                    let chord = 2.0 / th[ti].cos();
                    let sigma = [0.0, 0.05, 3.0, 20.0][si];
                    assert!((p.ballistic - (-sigma * chord).exp()).abs() < 1e-12);
                    let dev = p.scattered + p.ballistic - 1.0;
                    // Rounding accumulates over ~20 doublings of a 2⁻¹⁵ layer.
                    assert!(dev.abs() < 1e-8, "g={g} σ={sigma} θ={}: {dev:e}", th[ti]);
                    assert!(p.energy.iter().all(|&e| e >= 0.0));
                    if si == 0 {
                        assert!(p.energy.iter().all(|&e| e == 0.0));
                    }
                }
            }
        }
    }

    #[test]
    fn mirror_incidence_gives_the_mirrored_profile() {
        let r = solve_slab(0.6, &[2.0], &[0.7, -0.7], &SlabSettings::default());
        let (a, b) = (&r[0][0], &r[0][1]);
        let mut asym: f64 = 0.0;
        for lobe in 0..2 {
            for j in 0..360 {
                let (x, y) = (a.energy[lobe * 360 + j], b.energy[lobe * 360 + 359 - j]);
                assert!(
                    (x - y).abs() <= 1e-12 * x.max(1e-300),
                    "{lobe} {j}: {x} {y}"
                );
                asym = asym.max((x - a.energy[lobe * 360 + 359 - j]).abs() / x);
            }
        }
        // Not trivially symmetric: the profile itself is lopsided.
        assert!(asym > 0.1, "{asym}");
    }

    #[test]
    fn reflection_and_transmission_are_reciprocal() {
        // Reciprocity of the slab: E(θ_r; θ_i)/cos θ_r = E(θ_i; θ_r)/cos θ_i for both lobes,
        // with θ_i and θ_r on bin centres. The beam enters at its exact direction while exit
        // energies are bin integrals over the discrete cells, so this checks the two against
        // each other (agreement to the discretisation error).
        let bins = [100usize, 170, 250, 300];
        let centre = |j: usize| (-90.0 + (j as f64 + 0.5) * 0.5f64).to_radians();
        // The incident direction for a bin centre θ is propagation angle −θ.
        let th: Vec<f64> = bins.iter().map(|&j| -centre(j)).collect();
        for g in [0.0, 0.7] {
            let r = solve_slab(g, &[1.3], &th, &SlabSettings::default());
            let p = &r[0];
            let mut worst: f64 = 0.0;
            for (a, &ja) in bins.iter().enumerate() {
                for (b, &jb) in bins.iter().enumerate() {
                    // Back lobe exit at bin jb from incidence of bin ja (exit θ_r = θ_jb).
                    for lobe in 0..2 {
                        let ab = p[a].energy[lobe * 360 + jb] / centre(jb).cos();
                        let ba = p[b].energy[lobe * 360 + ja] / centre(ja).cos();
                        worst = worst.max((ab - ba).abs() / ab);
                    }
                }
            }
            assert!(worst < 2e-3, "g={g}: reciprocity defect {worst:e}");
        }
    }

    #[test]
    fn small_sigma_tends_to_the_single_scattering_integral() {
        // The multiply scattered remainder is O(σ): the relative gap to the analytic
        // single-scattering integral halves with σ. Bins next to grazing are excluded: the
        // analytic integral uses the bin midpoint (see `single_scatter_energy`).
        for (g, theta) in [(0.0, 20.0), (0.8, -55.0)] {
            let geom = Geometry::Longitudinal {
                theta_i_rad: f64::to_radians(theta),
            };
            let gap = |sigma: f64| {
                let p = solve_one(sigma, g, theta, &SlabSettings::default());
                let ss = single_scatter_energy(sigma, g, geom, 720, 64);
                let max = ss.iter().cloned().fold(0.0, f64::max);
                (0..720)
                    .filter(|&k| interior(k, 8) && ss[k] > 1e-3 * max)
                    .map(|k| (p.energy[k] - ss[k]) / ss[k])
                    .fold(0.0, |a: f64, x| a.max(x.abs()))
            };
            let (a, b) = (gap(1e-3), gap(5e-4));
            assert!(a < 0.03, "g={g}: gap at σ = 1e-3 is {a}");
            assert!((a / b - 2.0).abs() < 0.25, "g={g}: gap ratio {}", a / b);
        }
    }

    #[test]
    fn agrees_with_the_analog_monte_carlo() {
        // Plain analog tracking (one exit bin per photon, exact bin integrals) on 4° groups,
        // all bins including grazing ones.
        for (sigma, g, theta) in [(1.7, 0.3, 25.0), (6.0, 0.8, -70.0)] {
            let p = solve_one(sigma, g, theta, &SlabSettings::default());
            let geom = Geometry::Longitudinal {
                theta_i_rad: f64::to_radians(theta),
            };
            let n = 400_000u64;
            let mc = simulate(
                sigma,
                g,
                geom,
                &McSettings {
                    photons: n,
                    seed: 9,
                    estimator: Estimator::Histogram,
                    bins: 720,
                    max_order: None,
                },
            );
            let mut worst: f64 = 0.0;
            for c in 0..90 {
                let r = c * 8..(c + 1) * 8;
                let a: f64 = p.energy[r.clone()].iter().sum();
                let b: f64 = mc.energy[r].iter().sum();
                let se = (a * (1.0 - a) / n as f64).sqrt().max(1e-12);
                worst = worst.max(((a - b) / se).abs());
            }
            // 90 groups; 4.5σ is a 7e-6 two-sided tail per group.
            assert!(worst < 4.5, "σ={sigma} g={g} θ={theta}: worst z {worst}");
        }
    }

    #[test]
    fn agrees_per_bin_with_the_next_event_monte_carlo() {
        // The expected-value estimator scores bin midpoints, biased next to grazing where the
        // exit energy varies fastest: those 8 bins per end are excluded here.
        let (sigma, g, theta) = (2.5, 0.5, 40.0);
        let p = solve_one(sigma, g, theta, &SlabSettings::default());
        let geom = Geometry::Longitudinal {
            theta_i_rad: f64::to_radians(theta),
        };
        let mc = simulate(
            sigma,
            g,
            geom,
            &McSettings {
                photons: 1500,
                seed: 4,
                estimator: Estimator::Expected,
                bins: 720,
                max_order: None,
            },
        );
        let mut worst: f64 = 0.0;
        let mut n = 0;
        for k in (0..720).filter(|&k| interior(k, 8)) {
            let z = (p.energy[k] - mc.energy[k]) / mc.std_error[k].max(1e-300);
            worst = worst.max(z.abs());
            n += 1;
        }
        // 688 correlated bins; 5σ bounds the maximum.
        assert!(n == 688 && worst < 5.0, "worst z {worst}");
    }

    #[test]
    fn mean_path_length_theorem() {
        // Invariance of the mean path length (Blanco & Fournier 2003, here in 2-D): for
        // cosine-weighted incidence on a non-absorbing, index-matched medium the mean path
        // length is π·area/perimeter, independent of σ and g; for the slab of thickness 2 per
        // unit length of both faces, π. Checks the path-length moments of the solver
        // (scattered part) together with the analytic ballistic part.
        let (x, w) = crate::math::quadrature::gauss_legendre_interval(48, 0.0, FRAC_PI_2);
        for (sigma, g) in [(0.4, 0.0), (3.0, 0.8)] {
            let r = solve_slab(g, &[sigma], &x, &SlabSettings::default());
            let mut mean = 0.0;
            for (b, p) in r[0].iter().enumerate() {
                let chord = 2.0 / x[b].cos();
                let scattered: f64 = p
                    .energy
                    .iter()
                    .zip(&p.path_length)
                    .map(|(e, l)| e * l)
                    .sum();
                // Weight cos θ / 2 over (−π/2, π/2), folded onto (0, π/2).
                mean += w[b] * x[b].cos() * (scattered + p.ballistic * chord);
            }
            assert!((mean / PI - 1.0).abs() < 2e-3, "σ={sigma} g={g}: {mean}");
        }
    }

    #[test]
    fn converged_in_thin_layer_and_directions() {
        // Discretisation error of the default settings, measured against a finer solve: the
        // thin layer (to 1e-5) and the direction cells (to 1e-3 on bins above 1e-3 of the
        // maximum; the documented solver error).
        let th = [0.5, 1.5];
        let fine = SlabSettings {
            nodes_per_bin: 2,
            edge_refinement: &[32, 16, 8, 4, 4, 2, 2, 2],
            ..SlabSettings::default()
        };
        let thin = SlabSettings {
            thin_layer: DEFAULT_THIN_LAYER / 8.0,
            ..SlabSettings::default()
        };
        // σ = 20: its doubling chain passes through every thinner layer.
        for g in [0.0, 0.8] {
            let a = solve_slab(g, &[20.0], &th, &SlabSettings::default());
            let b = solve_slab(g, &[20.0], &th, &fine);
            let c = solve_slab(g, &[20.0], &th, &thin);
            for si in 0..1 {
                for ti in 0..2 {
                    let (e, f, h) = (&a[si][ti].energy, &b[si][ti].energy, &c[si][ti].energy);
                    let max = f.iter().cloned().fold(0.0, f64::max);
                    for k in (0..720).filter(|&k| f[k] > 1e-3 * max) {
                        let rel = (e[k] - f[k]).abs() / f[k];
                        assert!(rel < 1e-3, "g={g} bin {k}: {rel:e} against finer cells");
                        let rel = (e[k] - h[k]).abs() / f[k];
                        assert!(rel < 1e-5, "g={g} bin {k}: {rel:e} against a thinner layer");
                    }
                }
            }
        }
    }
}
