//! 2-D volumetric Monte Carlo of light scattered by the fur medulla (Tseng 2015 §5 / App. A).
//!
//! Model: a purely scattering 2-D medium (no absorption) with scattering coefficient `sigma`
//! **per unit medulla radius** (dimensionless optical coefficient), planar Henyey–Greenstein
//! phase function with anisotropy `g` (see [`crate::optics::henyey_greenstein`]), and an
//! index-matched boundary (no reflection/refraction: a photon leaves as soon as it crosses it).
//! Unit energy enters; only the *scattered* energy is binned (the ballistic part is analytic:
//! `exp(−σ·chord)`).
//!
//! Two geometries ([`Geometry`]):
//! - **Azimuthal** (C^N): the unit disc, entered at `(−√(1−h'²), h')` moving along +x. The exit
//!   direction angle φ' = atan2(d_y, d_x) is measured from the entering propagation direction
//!   (φ' = 0 is the unscattered continuation), counter-clockwise (towards +y, the side of
//!   positive h'). `bins` equal cells cover [−π, π): bin k is [−π + kΔ, −π + (k+1)Δ), Δ = 2π/bins,
//!   centre −π + (k+½)Δ. Mirror symmetry: C^N(bin k; −h') = C^N(bin bins−1−k; h').
//! - **Longitudinal** (C^M): the slab 0 ≤ x ≤ 2 (x = depth along the slab normal, y = fiber axis),
//!   entered at x = 0 with propagation direction (cos θ'_i, −sin θ'_i): θ'_i is the inclination
//!   of the direction *towards the source* (Marschner convention), so the unscattered
//!   continuation leaves at θ'_r = −θ'_i. The exit inclination θ'_r satisfies sin θ'_r = d_y of
//!   the exit direction, measured from the outward normal of the exit face. Bins 0..bins/2 are
//!   the **back** lobe (exit through x = 0, the entry face), bins bins/2..bins the **forward**
//!   lobe (exit through x = 2); within a lobe bin j covers θ'_r ∈ [−π/2 + jΔ, −π/2 + (j+1)Δ),
//!   Δ = 2π/bins. Mirror symmetry: C^M(j; −θ'_i) = C^M(bins/2−1−j; θ'_i) within each lobe.
//!
//! Estimators ([`Estimator`]):
//! - `Expected` (default): the first collision is forced inside the entry chord (weight
//!   1 − e^{−σL}, the scattered fraction, exactly); at **every** collision the analytic
//!   probability of scattering into each bin's direction and escaping without further collision,
//!   w·ρ(ω_k − d)·Δ·exp(−σ·s(x, ω_k)), is scored to every bin (next-event / expected-value
//!   estimation to the boundary, midpoint rule in the bin). The photon then never escapes: its
//!   next direction is importance-sampled from ρ·(1 − e^{−σs}) (bin by the tabulated weights,
//!   uniform inside the bin, exact weight ratio), its next collision is forced before the
//!   boundary, and its weight carries the non-escaping fraction (survival biasing); Russian
//!   roulette (survival ½) plays it once its weight falls below 5 % of the initial weight. Deep
//!   inside the medium (optical depth τ > 3 to the nearest boundary) the O(bins) estimate is
//!   itself evaluated only with probability e^{3−τ} and weighted by its inverse. The per-photon
//!   total is then almost constant, so the energy identity holds far below the per-bin noise.
//!   Unbiased up to the O(Δ²) midpoint rule of the scoring (measured ≲ 1e-4 of the total).
//! - `Histogram`: plain analog tracking; a photon is scored once, in the bin of its exit
//!   direction. Kept as the independent reference for tests.
//!
//! Path lengths are in medulla radii (multiply by the medulla radius in the renderer's unit).

use crate::math::rng::{SplitMix64, derive_seed};
use crate::optics::henyey_greenstein::{planar_hg_density_cos, sample_planar_hg};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// Which 2-D geometry (and therefore which table family) to simulate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Geometry {
    /// Unit disc entered at signed offset `h` ∈ [−1, 1] (C^N).
    Azimuthal { h: f64 },
    /// Slab of thickness 2 entered at inclination `theta_i_rad` ∈ (−π/2, π/2) (C^M).
    Longitudinal { theta_i_rad: f64 },
}

impl Geometry {
    /// Entry position and propagation direction.
    fn entry(&self) -> ([f64; 2], [f64; 2]) {
        match *self {
            Geometry::Azimuthal { h } => ([-(1.0 - h * h).max(0.0).sqrt(), h], [1.0, 0.0]),
            Geometry::Longitudinal { theta_i_rad } => {
                ([0.0, 0.0], [theta_i_rad.cos(), -theta_i_rad.sin()])
            }
        }
    }

    /// Length of the unscattered chord (medulla radii).
    pub fn chord(&self) -> f64 {
        match *self {
            Geometry::Azimuthal { h } => 2.0 * (1.0 - h * h).max(0.0).sqrt(),
            Geometry::Longitudinal { theta_i_rad } => {
                let c = theta_i_rad.cos();
                if c > 0.0 { 2.0 / c } else { f64::INFINITY }
            }
        }
    }

    /// Distance from `p` (inside) along unit `d` to the boundary.
    #[inline]
    fn dist(&self, p: [f64; 2], d: [f64; 2]) -> f64 {
        match self {
            Geometry::Azimuthal { .. } => disc_distance(p, d),
            Geometry::Longitudinal { .. } => {
                if d[0] > 0.0 {
                    (2.0 - p[0]).max(0.0) / d[0]
                } else if d[0] < 0.0 {
                    -p[0].max(0.0) / d[0]
                } else {
                    f64::INFINITY
                }
            }
        }
    }

    /// Distance from `p` to the nearest boundary point.
    #[inline]
    fn depth(&self, p: [f64; 2]) -> f64 {
        match self {
            Geometry::Azimuthal { .. } => (1.0 - (p[0] * p[0] + p[1] * p[1]).sqrt()).max(0.0),
            Geometry::Longitudinal { .. } => p[0].min(2.0 - p[0]).max(0.0),
        }
    }

    /// Bin of an exit direction, for `bins` bins.
    #[inline]
    fn bin_of(&self, d: [f64; 2], bins: usize) -> usize {
        let dw = 2.0 * PI / bins as f64;
        match self {
            Geometry::Azimuthal { .. } => {
                let psi = d[1].atan2(d[0]);
                (((psi + PI) / dw) as usize).min(bins - 1)
            }
            Geometry::Longitudinal { .. } => {
                let half = bins / 2;
                let tr = d[1].clamp(-1.0, 1.0).asin();
                let j = (((tr + FRAC_PI_2) / dw) as usize).min(half - 1);
                if d[0] < 0.0 { j } else { half + j }
            }
        }
    }

    /// Unit direction at fraction `frac` ∈ [0, 1) across bin `k` (uniform in angle).
    #[inline]
    fn direction_in_bin(&self, k: usize, frac: f64, bins: usize) -> [f64; 2] {
        let dw = 2.0 * PI / bins as f64;
        match self {
            Geometry::Azimuthal { .. } => {
                let a = -PI + (k as f64 + frac) * dw;
                [a.cos(), a.sin()]
            }
            Geometry::Longitudinal { .. } => {
                let half = bins / 2;
                let (sign, j) = if k < half { (-1.0, k) } else { (1.0, k - half) };
                let t = -FRAC_PI_2 + (j as f64 + frac) * dw;
                [sign * t.cos(), t.sin()]
            }
        }
    }

    /// Unit direction at the centre of every bin.
    pub fn bin_directions(&self, bins: usize) -> Vec<[f64; 2]> {
        let dw = 2.0 * PI / bins as f64;
        match self {
            Geometry::Azimuthal { .. } => (0..bins)
                .map(|k| {
                    let a = -PI + (k as f64 + 0.5) * dw;
                    [a.cos(), a.sin()]
                })
                .collect(),
            Geometry::Longitudinal { .. } => {
                let half = bins / 2;
                (0..bins)
                    .map(|k| {
                        let (sign, j) = if k < half { (-1.0, k) } else { (1.0, k - half) };
                        let t = -FRAC_PI_2 + (j as f64 + 0.5) * dw;
                        [sign * t.cos(), t.sin()]
                    })
                    .collect()
            }
        }
    }
}

/// Estimator choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// Next-event (expected-value) estimation at every collision, forced first collision.
    #[default]
    Expected,
    /// Plain analog histogram of exit directions.
    Histogram,
}

/// Monte Carlo settings for one entry.
#[derive(Debug, Clone, Copy)]
pub struct McSettings {
    /// Number of photons (paths) entering.
    pub photons: u64,
    /// User seed; the stream is derived from it and the entry parameters.
    pub seed: u64,
    pub estimator: Estimator,
    /// Number of exit bins over the full circle of directions (even for the slab).
    pub bins: usize,
    /// Keep only paths with at most this many scattering events (tests); `None` = all orders.
    pub max_order: Option<u32>,
}

/// Result for one entry (σ, g, geometry), of every estimator (this module's and
/// [`crate::fur::medulla_fast`]'s).
#[derive(Debug, Clone)]
pub struct Profile {
    /// Scattered energy per bin, per unit incident energy (sums to the scattered fraction).
    pub energy: Vec<f64>,
    /// Mean in-medulla path length (medulla radii) of the energy in each bin; 0 where empty.
    pub path_length: Vec<f64>,
    /// Standard error of `energy` per bin.
    pub std_error: Vec<f64>,
    /// Unscattered (ballistic) fraction, analytic exp(−σ·chord).
    pub ballistic: f64,
    /// Monte Carlo estimate of the ballistic fraction (`Histogram` only; `Expected` forces the
    /// first collision and reports the analytic value).
    pub ballistic_mc: f64,
    /// Sum of `energy`.
    pub scattered: f64,
    /// Standard error of `scattered`.
    pub scattered_std_error: f64,
}

impl Profile {
    /// No scattered energy in any of `bins` bins; `ballistic` passes unscattered.
    pub fn unscattered(bins: usize, ballistic: f64) -> Profile {
        Profile {
            energy: vec![0.0; bins],
            path_length: vec![0.0; bins],
            std_error: vec![0.0; bins],
            ballistic,
            ballistic_mc: ballistic,
            scattered: 0.0,
            scattered_std_error: 0.0,
        }
    }
}

/// Stream key of an entry, so that every (seed, family, σ, g, h/θ) has its own stream.
fn stream_seed(seed: u64, sigma: f64, g: f64, geom: &Geometry) -> u64 {
    let (family, x) = match *geom {
        Geometry::Azimuthal { h } => (1u64, h),
        Geometry::Longitudinal { theta_i_rad } => (2u64, theta_i_rad),
    };
    // +0.0 and −0.0 give the same stream.
    let bits = |v: f64| (v + 0.0).to_bits();
    derive_seed(seed, &[family, bits(sigma), bits(g), bits(x)])
}

/// `d` rotated counter-clockwise by `angle`.
#[inline]
pub(super) fn rotate(d: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    [c * d[0] - s * d[1], s * d[0] + c * d[1]]
}

/// Distance from `p` inside the unit disc along unit `d` to the boundary.
#[inline]
pub(super) fn disc_distance(p: [f64; 2], d: [f64; 2]) -> f64 {
    let b = p[0] * d[0] + p[1] * d[1];
    let c = 1.0 - (p[0] * p[0] + p[1] * p[1]);
    -b + (b * b + c.max(0.0)).sqrt()
}

/// Simulate one table entry. `sigma` ≥ 0 per unit medulla radius, `g` ∈ [0, 1).
pub fn simulate(sigma: f64, g: f64, geom: Geometry, s: &McSettings) -> Profile {
    let bins = s.bins;
    assert!(bins >= 2 && bins.is_multiple_of(2), "bins must be even");
    let chord = geom.chord();
    let ballistic = (-sigma * chord).exp();
    if sigma <= 0.0 || chord <= 0.0 || s.photons == 0 {
        return Profile::unscattered(bins, if chord <= 0.0 { 1.0 } else { ballistic });
    }
    let mut rng = SplitMix64::new(stream_seed(s.seed, sigma, g, &geom));
    match s.estimator {
        Estimator::Expected => simulate_expected(sigma, g, geom, s, chord, ballistic, &mut rng),
        Estimator::Histogram => simulate_histogram(sigma, g, geom, s, ballistic, &mut rng),
    }
}

/// Next-event estimation of the expected-value estimator: scores the escape toward every exit
/// bin from a collision and samples the next direction among the bins.
struct NextEvent {
    /// Centre direction of each exit bin.
    dirs: Vec<[f64; 2]>,
    /// Bin width (rad).
    dw: f64,
    g: f64,
    sigma: f64,
    geom: Geometry,
    /// Cumulative "scatter and collide again" masses of the last score, per bin.
    q: Vec<f64>,
}

impl NextEvent {
    /// Score weight `ws` from position `p` after travelling `len` in direction `d`: per bin the
    /// phase-function mass times the transmittance to the boundary into `e` (and the path
    /// length into `sum_len`), the cumulative "scatter and collide again" masses into `q`.
    /// Returns (scored total, Σ q).
    fn score(
        &mut self,
        p: [f64; 2],
        d: [f64; 2],
        ws: f64,
        len: f64,
        e: &mut [f64],
        sum_len: &mut [f64],
    ) -> (f64, f64) {
        let mut total = 0.0;
        let mut acc_q = 0.0;
        let q = &mut self.q;
        for (k, wk) in self.dirs.iter().enumerate() {
            let rho_dw = planar_hg_density_cos(wk[0] * d[0] + wk[1] * d[1], self.g) * self.dw;
            let sk = self.geom.dist(p, *wk);
            let tr = (-self.sigma * sk).exp();
            let c = ws * rho_dw * tr;
            e[k] += c;
            sum_len[k] += c * (len + sk);
            total += c;
            acc_q += rho_dw * (1.0 - tr);
            q[k] = acc_q;
        }
        (total, acc_q)
    }

    /// A direction with probability proportional to the bin masses of the last score (total
    /// `acc_q`), uniform inside its bin; returns it with its density.
    fn sample_direction(&self, acc_q: f64, rng: &mut SplitMix64) -> ([f64; 2], f64) {
        let (bins, q) = (self.dirs.len(), &self.q);
        let u = rng.next_f64() * acc_q;
        let k = q.partition_point(|&c| c <= u).min(bins - 1);
        let qk = q[k] - if k > 0 { q[k - 1] } else { 0.0 };
        (
            self.geom.direction_in_bin(k, rng.next_f64(), bins),
            qk / (acc_q * self.dw),
        )
    }
}

fn simulate_expected(
    sigma: f64,
    g: f64,
    geom: Geometry,
    s: &McSettings,
    chord: f64,
    ballistic: f64,
    rng: &mut SplitMix64,
) -> Profile {
    let bins = s.bins;
    let mut nee = NextEvent {
        dirs: geom.bin_directions(bins),
        dw: 2.0 * PI / bins as f64,
        g,
        sigma,
        geom,
        q: vec![0.0; bins],
    };
    let n = s.photons as f64;
    // Scattered fraction, accurately for small σ·L.
    let w0 = -(-sigma * chord).exp_m1();
    let roulette_below = ROULETTE_THRESHOLD * w0;
    let (p0, d0) = geom.entry();
    let mut sum = vec![0.0; bins];
    let mut sum2 = vec![0.0; bins];
    let mut sum_len = vec![0.0; bins];
    let mut e = vec![0.0; bins];
    let mut tot_sum = 0.0;
    let mut tot_sum2 = 0.0;
    for _ in 0..s.photons {
        e.iter_mut().for_each(|v| *v = 0.0);
        // Forced first collision: t ~ σe^{−σt}/(1−e^{−σL}) on [0, L], weight w0.
        let t = -(-rng.next_f64() * w0).ln_1p() / sigma;
        let mut p = [p0[0] + t * d0[0], p0[1] + t * d0[1]];
        let mut d = d0;
        let mut w = w0;
        let mut len = t;
        let mut order = 1u32;
        let mut photon_total = 0.0;
        loop {
            // Next-event estimate to every bin, and the cumulative "scatter and collide again"
            // weights q used to sample the next direction. Deep inside the medium every
            // escape probability is below e^{−σ·d_min}: the estimate is then evaluated only
            // with probability π = min(1, e^{NEE_DEPTH − σ·d_min}) and scored with weight
            // 1/π (unbiased roulette on the estimate; saves the O(bins) work where it is
            // negligible).
            let depth = sigma * geom.depth(p);
            let pi_nee = (NEE_DEPTH - depth).exp().min(1.0);
            let evaluate = pi_nee >= 1.0 || rng.next_f64() < pi_nee;
            let acc_q = if evaluate {
                let scored = nee.score(p, d, w / pi_nee, len, &mut e, &mut sum_len);
                photon_total += scored.0;
                scored.1
            } else {
                0.0
            };
            if s.max_order.is_some_and(|m| order >= m) {
                break;
            }
            // Next direction. Near the boundary (estimate evaluated, π = 1): bin k with
            // probability q_k / Σq, uniform inside the bin. Otherwise: the planar HG itself.
            // Either way the weight takes the exact ratio ρ(ω)(1 − e^{−σ s(ω)}) / pdf(ω), so
            // that the collision-before-escape event is forced without bias.
            let (nd, pdf) = if evaluate && pi_nee >= 1.0 && acc_q > 0.0 {
                nee.sample_direction(acc_q, rng)
            } else {
                let nd = rotate(d, sample_planar_hg(rng.next_f64(), g));
                (nd, planar_hg_density_cos(nd[0] * d[0] + nd[1] * d[1], g))
            };
            if pdf <= 0.0 {
                break;
            }
            let sd = geom.dist(p, nd);
            let not_escape = -(-sigma * sd).exp_m1();
            w *= planar_hg_density_cos(nd[0] * d[0] + nd[1] * d[1], g) * not_escape / pdf;
            if w < roulette_below {
                if rng.next_f64() < ROULETTE_SURVIVAL {
                    w /= ROULETTE_SURVIVAL;
                } else {
                    break;
                }
            }
            d = nd;
            // Collision distance conditioned on colliding before the boundary.
            let t = -(-rng.next_f64() * not_escape).ln_1p() / sigma;
            p = [p[0] + t * d[0], p[1] + t * d[1]];
            len += t;
            order += 1;
        }
        for k in 0..bins {
            sum[k] += e[k];
            sum2[k] += e[k] * e[k];
        }
        tot_sum += photon_total;
        tot_sum2 += photon_total * photon_total;
    }
    let tallies = Tallies {
        sum,
        sum2,
        sum_len,
        total: tot_sum,
        total2: tot_sum2,
    };
    tallies.profile(n, ballistic, ballistic)
}

/// Optical depth below which the next-event estimate is always evaluated (see
/// `simulate_expected`); deeper collisions evaluate it with probability e^{NEE_DEPTH − τ}.
const NEE_DEPTH: f64 = 3.0;

/// Russian roulette starts when a photon's weight drops below this fraction of its initial
/// (scattered-fraction) weight.
const ROULETTE_THRESHOLD: f64 = 0.05;
/// Survival probability in Russian roulette.
const ROULETTE_SURVIVAL: f64 = 0.5;

fn simulate_histogram(
    sigma: f64,
    g: f64,
    geom: Geometry,
    s: &McSettings,
    ballistic: f64,
    rng: &mut SplitMix64,
) -> Profile {
    let bins = s.bins;
    let (p0, d0) = geom.entry();
    let mut sum = vec![0.0; bins];
    let mut sum_len = vec![0.0; bins];
    let mut n_ballistic = 0u64;
    for _ in 0..s.photons {
        let mut p = p0;
        let mut d = d0;
        let mut len = 0.0;
        let mut order = 0u32;
        loop {
            let to_boundary = geom.dist(p, d);
            let t = -rng.next_f64_open0().ln() / sigma;
            if t >= to_boundary {
                if order == 0 {
                    n_ballistic += 1;
                } else {
                    let k = geom.bin_of(d, bins);
                    sum[k] += 1.0;
                    sum_len[k] += len + to_boundary;
                }
                break;
            }
            if s.max_order.is_some_and(|m| order >= m) {
                break; // the path would scatter once more: not of the requested orders
            }
            p = [p[0] + t * d[0], p[1] + t * d[1]];
            len += t;
            order += 1;
            d = rotate(d, sample_planar_hg(rng.next_f64(), g));
        }
    }
    // Unit weights: sum² = sum.
    let total: f64 = sum.iter().sum();
    let n = s.photons as f64;
    let tallies = Tallies {
        sum2: sum.clone(),
        sum,
        sum_len,
        total,
        total2: total,
    };
    tallies.profile(n, ballistic, n_ballistic as f64 / n)
}

/// Sums over the photons of one entry: per bin the scored energy, its square and its
/// path-length moment; over the photons' scored totals, the same two sums.
struct Tallies {
    sum: Vec<f64>,
    sum2: Vec<f64>,
    sum_len: Vec<f64>,
    total: f64,
    total2: f64,
}

impl Tallies {
    /// The profile of `n` photons, with the analytic and Monte Carlo ballistic fractions.
    fn profile(self, n: f64, ballistic: f64, ballistic_mc: f64) -> Profile {
        let se = |s: f64, s2: f64| {
            if n > 1.0 {
                ((s2 - s * s / n).max(0.0) / (n * (n - 1.0))).sqrt()
            } else {
                0.0
            }
        };
        let std_error = self
            .sum
            .iter()
            .zip(&self.sum2)
            .map(|(&s, &s2)| se(s, s2))
            .collect();
        let path_length = self
            .sum
            .iter()
            .zip(&self.sum_len)
            .map(|(&s, &l)| if s > 0.0 { l / s } else { 0.0 })
            .collect();
        let energy: Vec<f64> = self.sum.iter().map(|s| s / n).collect();
        Profile {
            scattered: energy.iter().sum(),
            energy,
            path_length,
            std_error,
            ballistic,
            ballistic_mc,
            scattered_std_error: se(self.total, self.total2),
        }
    }
}

/// Analytic single-scattering energy per bin (midpoint in the bin, Gauss–Legendre along the
/// entry chord with `nodes` points): ∫₀^L σe^{−σt} ρ(ω_k − d₀) Δ e^{−σ s(x(t), ω_k)} dt.
/// Independent of the Monte Carlo; the small-σ limit of the full profile.
pub fn single_scatter_energy(
    sigma: f64,
    g: f64,
    geom: Geometry,
    bins: usize,
    nodes: usize,
) -> Vec<f64> {
    let dw = 2.0 * PI / bins as f64;
    let chord = geom.chord();
    let (p0, d0) = geom.entry();
    let (ts, ws) = crate::math::quadrature::gauss_legendre_interval(nodes, 0.0, chord);
    geom.bin_directions(bins)
        .iter()
        .map(|w| {
            let rho = planar_hg_density_cos(w[0] * d0[0] + w[1] * d0[1], g);
            ts.iter()
                .zip(&ws)
                .map(|(&t, &wt)| {
                    let p = [p0[0] + t * d0[0], p0[1] + t * d0[1]];
                    wt * sigma * (-sigma * t).exp() * (-sigma * geom.dist(p, *w)).exp()
                })
                .sum::<f64>()
                * rho
                * dw
        })
        .collect()
}

/// Per-lobe normalisation of a longitudinal profile: returns (pdf per radian, CDF at each bin's
/// upper edge) for the back and forward halves; a lobe without energy gets zeros.
pub fn normalise_lobes(energy: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let bins = energy.len();
    let half = bins / 2;
    let dw = 2.0 * PI / bins as f64;
    let mut pdf = vec![0.0; bins];
    let mut cdf = vec![0.0; bins];
    for lobe in 0..2 {
        let r = lobe * half..(lobe + 1) * half;
        let total: f64 = energy[r.clone()].iter().sum();
        if total <= 0.0 {
            continue;
        }
        let mut acc = 0.0;
        for k in r {
            acc += energy[k];
            pdf[k] = energy[k] / (total * dw);
            cdf[k] = acc / total;
        }
    }
    (pdf, cdf)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(photons: u64, est: Estimator) -> McSettings {
        McSettings {
            photons,
            seed: 11,
            estimator: est,
            bins: 720,
            max_order: None,
        }
    }

    #[test]
    fn zero_tables_at_sigma_zero_and_grazing_entry() {
        let s = settings(100, Estimator::Expected);
        let p = simulate(0.0, 0.5, Geometry::Azimuthal { h: 0.3 }, &s);
        assert!(p.energy.iter().all(|&v| v == 0.0) && p.ballistic == 1.0);
        let p = simulate(5.0, 0.5, Geometry::Azimuthal { h: 1.0 }, &s);
        assert!(p.energy.iter().all(|&v| v == 0.0) && p.ballistic == 1.0);
        let p = simulate(0.0, 0.5, Geometry::Longitudinal { theta_i_rad: 0.3 }, &s);
        assert!(p.energy.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn energy_identity_azimuthal_and_longitudinal() {
        // No absorption: all scattered energy exits, Σ bins = 1 − exp(−σ·chord).
        for &(sigma, g, geom) in &[
            (0.5, 0.0, Geometry::Azimuthal { h: 0.2 }),
            (3.0, 0.6, Geometry::Azimuthal { h: -0.7 }),
            (10.0, 0.8, Geometry::Azimuthal { h: 0.95 }),
            (1.0, 0.3, Geometry::Longitudinal { theta_i_rad: 0.4 }),
            (6.0, 0.8, Geometry::Longitudinal { theta_i_rad: -1.2 }),
        ] {
            for est in [Estimator::Expected, Estimator::Histogram] {
                let n = if est == Estimator::Expected {
                    60
                } else {
                    40_000
                };
                let p = simulate(sigma, g, geom, &settings(n, est));
                let expect = 1.0 - (-sigma * geom.chord()).exp();
                let dev = (p.scattered - expect).abs();
                assert!(
                    dev < 5.0 * p.scattered_std_error + 1e-9,
                    "{geom:?} σ={sigma} g={g} {est:?}: {} vs {expect} (se {})",
                    p.scattered,
                    p.scattered_std_error
                );
                if est == Estimator::Histogram {
                    let se_b = (p.ballistic * (1.0 - p.ballistic) / n as f64).sqrt();
                    assert!((p.ballistic_mc - p.ballistic).abs() < 5.0 * se_b + 1e-12);
                }
            }
        }
    }

    #[test]
    fn expected_and_histogram_agree_per_bin() {
        // Compare on 8° super-bins so the histogram has enough counts.
        for &(sigma, g, geom) in &[
            (2.0, 0.5, Geometry::Azimuthal { h: 0.4 }),
            (2.0, 0.3, Geometry::Longitudinal { theta_i_rad: 0.5 }),
        ] {
            let a = simulate(sigma, g, geom, &settings(400, Estimator::Expected));
            let b = simulate(sigma, g, geom, &settings(200_000, Estimator::Histogram));
            let group = 16;
            let mut worst: f64 = 0.0;
            for c in 0..720 / group {
                let r = c * group..(c + 1) * group;
                let ea: f64 = a.energy[r.clone()].iter().sum();
                let eb: f64 = b.energy[r.clone()].iter().sum();
                let va: f64 = a.std_error[r.clone()].iter().map(|x| x * x).sum::<f64>();
                let vb = eb / 200_000.0; // Poisson
                let z = (ea - eb) / (va * group as f64 + vb).sqrt().max(1e-12);
                worst = worst.max(z.abs());
            }
            // 45 groups; 4.5σ is a 3e-4 two-sided tail per group.
            assert!(worst < 4.5, "{geom:?}: worst z {worst}");
        }
    }

    #[test]
    fn mirror_symmetries_hold_statistically() {
        // Independent runs at +entry and −entry (different streams), 16 replicate seeds each,
        // compared on 8° groups with a replicate-based t statistic.
        let reps = 16;
        let group = 16;
        for (a, b) in [
            (
                Geometry::Azimuthal { h: 0.5 },
                Geometry::Azimuthal { h: -0.5 },
            ),
            (
                Geometry::Longitudinal { theta_i_rad: 0.6 },
                Geometry::Longitudinal { theta_i_rad: -0.6 },
            ),
        ] {
            let half = 360;
            let mirror = |k: usize| match a {
                Geometry::Azimuthal { .. } => 719 - k,
                Geometry::Longitudinal { .. } => {
                    if k < half {
                        half - 1 - k
                    } else {
                        half + (2 * half - 1 - k)
                    }
                }
            };
            let run = |geom: Geometry, seed: u64| -> Vec<f64> {
                let mut s = settings(50, Estimator::Expected);
                s.seed = seed;
                simulate(2.0, 0.6, geom, &s).energy
            };
            let grouped = |e: &[f64], flip: bool| -> Vec<f64> {
                let e: Vec<f64> = (0..720)
                    .map(|k| e[if flip { mirror(k) } else { k }])
                    .collect();
                e.chunks(group).map(|c| c.iter().sum()).collect()
            };
            let ng = 720 / group;
            let (mut ma, mut va, mut mb, mut vb) =
                (vec![0.0; ng], vec![0.0; ng], vec![0.0; ng], vec![0.0; ng]);
            let mut asym = 0.0;
            for r in 0..reps {
                let ea = run(a, 100 + r);
                let ga = grouped(&ea, false);
                let gb = grouped(&run(b, 200 + r), true);
                let ga_flipped = grouped(&ea, true);
                for i in 0..ng {
                    ma[i] += ga[i] / reps as f64;
                    va[i] += ga[i] * ga[i] / reps as f64;
                    mb[i] += gb[i] / reps as f64;
                    vb[i] += gb[i] * gb[i] / reps as f64;
                    asym += (ga[i] - ga_flipped[i]).abs() / reps as f64;
                }
            }
            let mut worst: f64 = 0.0;
            for i in 0..ng {
                let sa = (va[i] - ma[i] * ma[i]).max(0.0) / (reps - 1) as f64;
                let sb = (vb[i] - mb[i] * mb[i]).max(0.0) / (reps - 1) as f64;
                let t = (ma[i] - mb[i]) / (sa + sb).sqrt().max(1e-12);
                worst = worst.max(t.abs());
            }
            assert!(worst < 6.0, "{a:?}: worst t {worst}");
            // The mirror is not trivially satisfied: the profile itself is asymmetric.
            assert!(asym > 0.05, "{a:?}: asymmetry {asym}");
        }
    }

    #[test]
    fn single_scatter_matches_analytic_integral() {
        // Order-1 paths only: both estimators against the analytic single-scatter integral.
        for &(sigma, g, geom) in &[
            (1.0, 0.0, Geometry::Azimuthal { h: 0.3 }),
            (0.8, 0.5, Geometry::Longitudinal { theta_i_rad: 0.7 }),
        ] {
            let exact = single_scatter_energy(sigma, g, geom, 720, 64);
            let mut s = settings(300, Estimator::Expected);
            s.max_order = Some(1);
            let a = simulate(sigma, g, geom, &s);
            s.estimator = Estimator::Histogram;
            s.photons = 400_000;
            let b = simulate(sigma, g, geom, &s);
            let tot: f64 = exact.iter().sum();
            assert!((a.scattered - tot).abs() < 4.0 * a.scattered_std_error + 1e-6);
            assert!((b.scattered - tot).abs() < 4.0 * b.scattered_std_error);
            for c in 0..45 {
                let r = c * 16..(c + 1) * 16;
                let ex: f64 = exact[r.clone()].iter().sum();
                let ea: f64 = a.energy[r.clone()].iter().sum();
                let eb: f64 = b.energy[r.clone()].iter().sum();
                let sea: f64 = a.std_error[r.clone()].iter().sum(); // fully correlated bound
                assert!(
                    (ea - ex).abs() < 4.0 * sea + 1e-9,
                    "{geom:?} group {c}: {ea} vs {ex}"
                );
                let seb = (ex / 400_000.0).sqrt();
                assert!(
                    (eb - ex).abs() < 4.5 * seb + 1e-9,
                    "{geom:?} group {c}: {eb} vs {ex}"
                );
            }
        }
        // Full transport at small σ, g = 0: multiple scattering is O(σ) of the single term.
        let geom = Geometry::Azimuthal { h: 0.0 };
        let sigma = 0.01;
        let exact = single_scatter_energy(sigma, 0.0, geom, 720, 64);
        let a = simulate(sigma, 0.0, geom, &settings(2_000, Estimator::Expected));
        let rel = (a.scattered - exact.iter().sum::<f64>()).abs() / a.scattered;
        assert!(rel < 3.0 * sigma, "{rel}");
        let max_rel = (0..720)
            .map(|k| (a.energy[k] - exact[k]).abs() / exact[k])
            .fold(0.0, f64::max);
        assert!(max_rel < 0.05, "max per-bin relative deviation {max_rel}");
    }

    #[test]
    fn expected_estimator_has_lower_variance_at_equal_photon_count() {
        for &(sigma, g, geom) in &[
            (0.5, 0.0, Geometry::Azimuthal { h: 0.3 }),
            (2.0, 0.5, Geometry::Azimuthal { h: 0.3 }),
            (2.0, 0.5, Geometry::Longitudinal { theta_i_rad: 0.3 }),
        ] {
            let a = simulate(sigma, g, geom, &settings(2_000, Estimator::Expected));
            let b = simulate(sigma, g, geom, &settings(2_000, Estimator::Histogram));
            // Mean per-bin variance over all bins (histogram variance estimated from the
            // better-resolved expected profile: Poisson p/N, so empty bins do not flatter it).
            let va: f64 = a.std_error.iter().map(|x| x * x).sum::<f64>() / 720.0;
            let vb: f64 = a
                .energy
                .iter()
                .map(|p| p * (1.0 - p) / 2_000.0)
                .sum::<f64>()
                / 720.0;
            let vb_direct: f64 = b.std_error.iter().map(|x| x * x).sum::<f64>() / 720.0;
            assert!(
                va * 30.0 < vb,
                "{geom:?} σ={sigma}: variance ratio {}",
                vb / va
            );
            assert!((vb_direct / vb - 1.0).abs() < 0.2, "{vb_direct} vs {vb}");
        }
    }

    #[test]
    fn deterministic_per_seed_and_entry() {
        let s = settings(50, Estimator::Expected);
        let a = simulate(2.0, 0.4, Geometry::Azimuthal { h: 0.1 }, &s);
        let b = simulate(2.0, 0.4, Geometry::Azimuthal { h: 0.1 }, &s);
        assert_eq!(a.energy, b.energy);
        let mut s2 = s;
        s2.seed = 12;
        let c = simulate(2.0, 0.4, Geometry::Azimuthal { h: 0.1 }, &s2);
        assert_ne!(a.energy, c.energy);
    }

    #[test]
    fn small_sigma_limit_is_chord_weighted_isotropic_lobe() {
        // σ → 0: the single-scatter shape is the planar HG lobe about the entry direction
        // weighted by the chord; at g = 0 the azimuthal profile is uniform to O(σ).
        let geom = Geometry::Azimuthal { h: 0.5 };
        let e = single_scatter_energy(1e-6, 0.0, geom, 720, 32);
        let mean = e.iter().sum::<f64>() / 720.0;
        assert!(e.iter().all(|v| (v / mean - 1.0).abs() < 1e-4));
        assert!((e.iter().sum::<f64>() / (1e-6 * geom.chord()) - 1.0).abs() < 1e-5);
    }
}
