//! Amplitude functions `S_1(θ)` (perpendicular) and `S_2(θ)` (parallel) at many angles at once.
//!
//! ```text
//! S_1 = Σ_n (2n+1)/(n(n+1)) (a_n π_n + b_n τ_n),   S_2 = Σ_n (2n+1)/(n(n+1)) (a_n τ_n + b_n π_n)
//! π_1 = 1, π_0 = 0, π_{n+1} = ((2n+1)/n) μ π_n − ((n+1)/n) π_{n−1},  τ_n = n μ π_n − (n+1) π_{n−1}
//! ```
//! (Bohren & Huffman Eq. 4.74 and 4.47; the upward π recurrence is stable, Wiscombe 1980).
//!
//! The hot loop. Angles are processed in blocks of [`LANES`] cosines held in structure-of-arrays
//! form (one `[f64; LANES]` per quantity, no allocation), and every block runs the whole series
//! over `n`. The mirror angle `π − θ` comes for free from `π_n(−μ) = (−1)^{n−1} π_n(μ)` and
//! `τ_n(−μ) = (−1)^n τ_n(μ)`: with parity-split partial sums
//! `P = Σ_odd c a π + Σ_even c b τ`, `Q = Σ_even c a π + Σ_odd c b τ`,
//! `R = Σ_even c a τ + Σ_odd c b π`, `T = Σ_odd c a τ + Σ_even c b π`,
//! one has `S_1(±μ) = P ± Q` and `S_2(±μ) = R ± T`, so each `(n, μ)` pair costs 8 fused
//! multiply-adds and a 5-operation recurrence for two angles. On x86-64 the kernel is compiled
//! twice and AVX2+FMA is selected at run time when the CPU has it.

use super::coefficients::MieCoefficients;
use num_complex::Complex64;
use rayon::prelude::*;

/// Number of cosines processed together by the kernel.
pub const LANES: usize = 16;

/// Per-order constants of the angular series: `[c a_n (re, im), c b_n (re, im), (2n+1)/n,
/// (n+1)/n]` with `c = (2n+1)/(n(n+1))`.
#[derive(Debug, Clone)]
pub struct AngularSeries {
    terms: Vec<[f64; 6]>,
}

impl AngularSeries {
    /// Prepares the series of one sphere.
    pub fn new(coefficients: &MieCoefficients) -> Self {
        let terms = coefficients
            .a
            .iter()
            .zip(&coefficients.b)
            .enumerate()
            .map(|(i, (a, b))| {
                let n = (i + 1) as f64;
                let c = (2.0 * n + 1.0) / (n * (n + 1.0));
                [
                    c * a.re,
                    c * a.im,
                    c * b.re,
                    c * b.im,
                    (2.0 * n + 1.0) / n,
                    (n + 1.0) / n,
                ]
            })
            .collect();
        AngularSeries { terms }
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// True when the series has no terms.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
}

/// Amplitudes at a set of cosines `μ_j` and at their mirrors `−μ_j`.
#[derive(Debug, Clone, Default)]
pub struct MirroredAmplitudes {
    /// `S_1(μ_j)`.
    pub s1: Vec<Complex64>,
    /// `S_2(μ_j)`.
    pub s2: Vec<Complex64>,
    /// `S_1(−μ_j)`.
    pub s1_mirror: Vec<Complex64>,
    /// `S_2(−μ_j)`.
    pub s2_mirror: Vec<Complex64>,
}

/// Computes `S_1`, `S_2` at `μ_j` and `−μ_j` for every cosine in `mu` (single thread unless
/// `parallel`, which splits the angles over rayon's pool).
pub fn amplitudes_mirrored(
    series: &AngularSeries,
    mu: &[f64],
    parallel: bool,
) -> MirroredAmplitudes {
    let z = Complex64::new(0.0, 0.0);
    let mut out = MirroredAmplitudes {
        s1: vec![z; mu.len()],
        s2: vec![z; mu.len()],
        s1_mirror: vec![z; mu.len()],
        s2_mirror: vec![z; mu.len()],
    };
    if parallel {
        const CHUNK: usize = 4 * LANES;
        mu.par_chunks(CHUNK)
            .zip(out.s1.par_chunks_mut(CHUNK))
            .zip(out.s2.par_chunks_mut(CHUNK))
            .zip(out.s1_mirror.par_chunks_mut(CHUNK))
            .zip(out.s2_mirror.par_chunks_mut(CHUNK))
            .for_each(|((((m, a), b), c), d)| run(&series.terms, m, a, b, c, d));
    } else {
        run(
            &series.terms,
            mu,
            &mut out.s1,
            &mut out.s2,
            &mut out.s1_mirror,
            &mut out.s2_mirror,
        );
    }
    out
}

/// `S_1`, `S_2` at arbitrary cosines (the mirrored values are computed and dropped).
pub fn amplitudes(series: &AngularSeries, mu: &[f64]) -> (Vec<Complex64>, Vec<Complex64>) {
    let out = amplitudes_mirrored(series, mu, false);
    (out.s1, out.s2)
}

/// Two angles closer than this (degrees) are the same direction for the mirror pairing of
/// [`amplitudes_at_angles`]: far below any angle a grid states (a grid `start + k·step` and its
/// supplement differ by a few units in the last place of 180, ≈ 3e-14°), and at x = 10⁵ it moves
/// `S` by ≈ x·Δθ ≈ 2e-12 relative.
pub const MIRROR_PAIR_TOLERANCE_DEG: f64 = 1e-12;

/// Work (angles × terms) below which [`amplitudes_at_angles`] stays on the calling thread even
/// when asked to go parallel: a few hundred microseconds of series, less than waking the pool.
const PARALLEL_MIN_WORK: usize = 1 << 18;

/// Which cosines to sum for a list of scattering angles, and where each angle's amplitudes come
/// from: an angle θ ≤ 90° is summed at `cos θ`; an angle θ > 90° is the mirror of the summed
/// cosine of its supplement `180° − θ` when that angle is also asked for (to
/// [`MIRROR_PAIR_TOLERANCE_DEG`]), else the mirror of its own `−cos θ`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MirrorPlan {
    /// Cosines to sum (each also gives its mirror `−μ`).
    pub mu: Vec<f64>,
    /// Per requested angle: the index into `mu` and whether it is the mirror.
    pub source: Vec<(usize, bool)>,
}

impl MirrorPlan {
    pub fn new(angles_deg: &[f64]) -> Self {
        let mut mu = Vec::with_capacity(angles_deg.len());
        let mut source = vec![(0, false); angles_deg.len()];
        // Angles summed directly, sorted for the supplement look-up: (angle, index into mu).
        let mut direct: Vec<(f64, usize)> = Vec::new();
        for (j, &a) in angles_deg.iter().enumerate() {
            if a.is_nan() || a <= 90.0 {
                source[j] = (mu.len(), false);
                direct.push((a, mu.len()));
                mu.push(a.to_radians().cos());
            }
        }
        direct.sort_by(|p, q| p.0.total_cmp(&q.0));
        for (j, &a) in angles_deg.iter().enumerate() {
            if a.is_nan() || a <= 90.0 {
                continue;
            }
            let supplement = 180.0 - a;
            let k = direct.partition_point(|p| p.0 < supplement - MIRROR_PAIR_TOLERANCE_DEG);
            source[j] = match direct.get(k) {
                Some(&(d, i)) if (d - supplement).abs() <= MIRROR_PAIR_TOLERANCE_DEG => (i, true),
                _ => {
                    mu.push(-a.to_radians().cos());
                    (mu.len() - 1, true)
                }
            };
        }
        MirrorPlan { mu, source }
    }

    /// The requested angles' amplitudes from the sums at [`Self::mu`].
    pub fn gather(&self, amp: &MirroredAmplitudes) -> (Vec<Complex64>, Vec<Complex64>) {
        self.source
            .iter()
            .map(|&(i, mirror)| match mirror {
                false => (amp.s1[i], amp.s2[i]),
                true => (amp.s1_mirror[i], amp.s2_mirror[i]),
            })
            .unzip()
    }
}

/// `S_1`, `S_2` at scattering angles in degrees, summing each pair of supplementary angles
/// (θ and 180° − θ, both asked for) once through the mirror identity: a grid over 0–180° costs
/// about half its angles. `parallel` splits the sum over rayon's pool when the work is large
/// enough to gain from it. Same values as [`amplitudes`] at `cos θ` up to rounding (and, for a
/// paired angle, the ≤ [`MIRROR_PAIR_TOLERANCE_DEG`] between θ and its partner's supplement).
pub fn amplitudes_at_angles(
    series: &AngularSeries,
    angles_deg: &[f64],
    parallel: bool,
) -> (Vec<Complex64>, Vec<Complex64>) {
    let plan = MirrorPlan::new(angles_deg);
    let parallel = parallel && plan.mu.len() * series.len() >= PARALLEL_MIN_WORK;
    plan.gather(&amplitudes_mirrored(series, &plan.mu, parallel))
}

fn run(
    terms: &[[f64; 6]],
    mu: &[f64],
    s1: &mut [Complex64],
    s2: &mut [Complex64],
    s1m: &mut [Complex64],
    s2m: &mut [Complex64],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            unsafe { run_avx2_fma(terms, mu, s1, s2, s1m, s2m) };
            return;
        }
    }
    run_generic::<false>(terms, mu, s1, s2, s1m, s2m);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_avx2_fma(
    terms: &[[f64; 6]],
    mu: &[f64],
    s1: &mut [Complex64],
    s2: &mut [Complex64],
    s1m: &mut [Complex64],
    s2m: &mut [Complex64],
) {
    run_generic::<true>(terms, mu, s1, s2, s1m, s2m);
}

/// State of one block of [`LANES`] cosines between tiles of the series.
#[derive(Clone)]
struct BlockState {
    mu: [f64; LANES],
    pi: [f64; LANES],
    pi_prev: [f64; LANES],
    acc: [[f64; LANES]; 8],
}

/// Orders per tile: every block runs one tile of the series before the next tile is loaded,
/// so the tile's constants stay in L1 while the block states (1.4 KB each) stream from L2.
/// Even, so that every tile starts at an odd order.
const TILE: usize = 256;

#[inline(always)]
fn run_generic<const FMA: bool>(
    terms: &[[f64; 6]],
    mu: &[f64],
    s1: &mut [Complex64],
    s2: &mut [Complex64],
    s1m: &mut [Complex64],
    s2m: &mut [Complex64],
) {
    let mut states: Vec<BlockState> = mu
        .chunks(LANES)
        .map(|c| {
            let mut m = [0.0; LANES];
            m[..c.len()].copy_from_slice(c);
            BlockState {
                mu: m,
                pi: [1.0; LANES],
                pi_prev: [0.0; LANES],
                acc: [[0.0; LANES]; 8],
            }
        })
        .collect();
    for (t, tile) in terms.chunks(TILE).enumerate() {
        let nf = (t * TILE + 1) as f64;
        for st in states.iter_mut() {
            run_tile::<FMA>(tile, nf, st);
        }
    }
    for (b, st) in states.iter().enumerate() {
        let start = b * LANES;
        let count = (mu.len() - start).min(LANES);
        let acc = &st.acc;
        for j in 0..count {
            let p = Complex64::new(acc[0][j], acc[1][j]);
            let q = Complex64::new(acc[2][j], acc[3][j]);
            let r = Complex64::new(acc[4][j], acc[5][j]);
            let t = Complex64::new(acc[6][j], acc[7][j]);
            s1[start + j] = p + q;
            s1m[start + j] = p - q;
            s2[start + j] = r + t;
            s2m[start + j] = r - t;
        }
    }
}

#[inline(always)]
fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

/// One series step at order `n` (value `nf`) for all lanes. `ODD` selects which parity-split
/// sums receive the `a` and `b` terms (see the module doc).
#[inline(always)]
fn step<const FMA: bool, const ODD: bool>(
    t: &[f64; 6],
    nf: f64,
    mu: &[f64; LANES],
    pi: &mut [f64; LANES],
    pi_prev: &mut [f64; LANES],
    acc: &mut [[f64; LANES]; 8],
) {
    let [car, cai, cbr, cbi, r1, r2] = *t;
    let n1 = nf + 1.0;
    // acc layout: P(re, im), Q(re, im), R(re, im), T(re, im).
    let (ia, ib, ja, jb) = if ODD { (0, 2, 6, 4) } else { (2, 0, 4, 6) };
    for l in 0..LANES {
        let p = pi[l];
        let pp = pi_prev[l];
        let s = mu[l] * p;
        let tau = madd::<FMA>(nf, s, -n1 * pp);
        // a π into P (odd) / Q (even); b τ into Q (odd) / P (even)
        acc[ia][l] = madd::<FMA>(car, p, acc[ia][l]);
        acc[ia + 1][l] = madd::<FMA>(cai, p, acc[ia + 1][l]);
        acc[ib][l] = madd::<FMA>(cbr, tau, acc[ib][l]);
        acc[ib + 1][l] = madd::<FMA>(cbi, tau, acc[ib + 1][l]);
        // a τ into T (odd) / R (even); b π into R (odd) / T (even)
        acc[ja][l] = madd::<FMA>(car, tau, acc[ja][l]);
        acc[ja + 1][l] = madd::<FMA>(cai, tau, acc[ja + 1][l]);
        acc[jb][l] = madd::<FMA>(cbr, p, acc[jb][l]);
        acc[jb + 1][l] = madd::<FMA>(cbi, p, acc[jb + 1][l]);
        pi_prev[l] = p;
        pi[l] = madd::<FMA>(r1, s, -r2 * pp);
    }
}

/// Runs orders `nf, nf + 1, …` (the first one odd) of one tile on one block.
#[inline(always)]
fn run_tile<const FMA: bool>(terms: &[[f64; 6]], nf: f64, st: &mut BlockState) {
    let BlockState {
        mu,
        pi,
        pi_prev,
        acc,
    } = st;
    let mut pairs = terms.chunks_exact(2);
    let mut nf = nf;
    for pair in &mut pairs {
        step::<FMA, true>(&pair[0], nf, mu, pi, pi_prev, acc);
        step::<FMA, false>(&pair[1], nf + 1.0, mu, pi, pi_prev, acc);
        nf += 2.0;
    }
    if let [last] = pairs.remainder() {
        step::<FMA, true>(last, nf, mu, pi, pi_prev, acc);
    }
}

/// Orders per tile of the batched kernel ([`amplitudes_mirrored_batch`]): the tile's `π_n`,
/// `τ_n` at one block of [`LANES`] cosines (2 × 64 × 16 values, 16 KB) stay in L1 while every
/// sphere of the batch runs over them. Even, so that every tile starts at an odd order.
const BATCH_TILE: usize = 64;

/// `π_n`, `τ_n` of one tile of orders at one block of [`LANES`] cosines.
struct OrderTable {
    pi: Vec<[f64; LANES]>,
    tau: Vec<[f64; LANES]>,
    /// The block's cosines and the recurrence state `π_n`, `π_{n−1}` after the tile (kept in
    /// memory like the tables, which lets the compiler vectorise the recurrence over lanes).
    state: Vec<[[f64; LANES]; 3]>,
}

/// The eight partial sums (layout of [`step`]) of one sphere at the cosines of one block.
type BlockSums = [[f64; LANES]; 8];

/// [`amplitudes_mirrored`] of several spheres at the same cosines, on the calling thread: the
/// angular functions `π_n(μ)`, `τ_n(μ)` are computed once per order and cosine for the whole
/// batch (a tile of orders at a time) and every sphere's parity-split sums run over the stored
/// values with its sums held in registers, so a sphere costs the 8 fused multiply-adds per
/// `(n, μ)` and the recurrence is shared. The spheres may have different numbers of terms. The
/// arithmetic of each sum is that of [`amplitudes_mirrored`] in the same order (same values).
pub fn amplitudes_mirrored_batch(series: &[&AngularSeries], mu: &[f64]) -> Vec<MirroredAmplitudes> {
    let z = Complex64::new(0.0, 0.0);
    let mut out: Vec<MirroredAmplitudes> = series
        .iter()
        .map(|_| MirroredAmplitudes {
            s1: vec![z; mu.len()],
            s2: vec![z; mu.len()],
            s1_mirror: vec![z; mu.len()],
            s2_mirror: vec![z; mu.len()],
        })
        .collect();
    run_batch(series, mu, &mut out);
    out
}

/// The batched kernel with the widest vectors the CPU has: on x86-64 AVX-512 (8 cosines per
/// register) or AVX2 (4), both with FMA; the per-sphere sums live in registers either way, and
/// the fused multiply-adds are those of [`run`] (same values).
fn run_batch(series: &[&AngularSeries], mu: &[f64], out: &mut [MirroredAmplitudes]) {
    #[cfg(target_arch = "x86_64")]
    {
        let fma = std::arch::is_x86_feature_detected!("fma");
        if fma && std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F and FMA (checked just above).
            unsafe { run_batch_avx512_fma(series, mu, out) };
            return;
        }
        if fma && std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            unsafe { run_batch_avx2_fma(series, mu, out) };
            return;
        }
    }
    run_batch_generic::<false, 4>(series, mu, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_batch_avx2_fma(series: &[&AngularSeries], mu: &[f64], out: &mut [MirroredAmplitudes]) {
    run_batch_generic::<true, 4>(series, mu, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
fn run_batch_avx512_fma(series: &[&AngularSeries], mu: &[f64], out: &mut [MirroredAmplitudes]) {
    run_batch_generic::<true, 8>(series, mu, out);
}

/// The batched kernel with vectors of `W` cosines (a divisor of [`LANES`]).
#[inline(always)]
fn run_batch_generic<const FMA: bool, const W: usize>(
    series: &[&AngularSeries],
    mu: &[f64],
    out: &mut [MirroredAmplitudes],
) {
    // The recurrence constants (2n+1)/n, (n+1)/n are the same in every series: the longest
    // one supplies them for every order of the batch.
    let Some(longest) = series.iter().max_by_key(|s| s.len()) else {
        return;
    };
    let mut table = OrderTable {
        pi: vec![[0.0; LANES]; BATCH_TILE],
        tau: vec![[0.0; LANES]; BATCH_TILE],
        state: vec![[[0.0; LANES]; 3]],
    };
    let zero: BlockSums = [[0.0; LANES]; 8];
    let mut acc = vec![zero; series.len()];
    for (b, block) in mu.chunks(LANES).enumerate() {
        let mut m = [0.0; LANES];
        m[..block.len()].copy_from_slice(block);
        table.state[0] = [m, [1.0; LANES], [0.0; LANES]];
        acc.iter_mut().for_each(|a| *a = zero);
        for (t, tile) in longest.terms.chunks(BATCH_TILE).enumerate() {
            let n0 = t * BATCH_TILE;
            tabulate::<FMA, W>(tile, (n0 + 1) as f64, &mut table);
            for (s, a) in series.iter().zip(acc.iter_mut()) {
                let terms = s.terms.get(n0..).unwrap_or_default();
                let terms = &terms[..terms.len().min(BATCH_TILE)];
                if !terms.is_empty() {
                    for v in (0..LANES).step_by(W) {
                        sum_tile::<FMA, W>(terms, &table, v, a);
                    }
                }
            }
        }
        for (a, o) in acc.iter().zip(out.iter_mut()) {
            for (j, at) in (b * LANES..).take(block.len()).enumerate() {
                let sum = |q: usize| Complex64::new(a[q][j], a[q + 1][j]);
                let (p, q, r, t) = (sum(0), sum(2), sum(4), sum(6));
                o.s1[at] = p + q;
                o.s1_mirror[at] = p - q;
                o.s2[at] = r + t;
                o.s2_mirror[at] = r - t;
            }
        }
    }
}

/// `π_n`, `τ_n` for the orders `nf, nf + 1, …` of `terms` at the table's cosines, continuing its
/// recurrence state `(π_n, π_{n−1})` (the same arithmetic as [`step`]).
#[inline(always)]
fn tabulate<const FMA: bool, const W: usize>(terms: &[[f64; 6]], nf: f64, table: &mut OrderTable) {
    let [mu, pi, pi_prev] = &mut table.state[0];
    let mut nf = nf;
    for ((t, tp), tt) in terms.iter().zip(&mut table.pi).zip(&mut table.tau) {
        let (r1, r2) = (t[4], t[5]);
        let n1 = nf + 1.0;
        // vector by vector, each a value the compiler keeps in one register
        for v in (0..LANES).step_by(W) {
            let at = |a: &[f64; LANES]| -> [f64; W] { std::array::from_fn(|l| a[v + l]) };
            let (p, pp, m) = (at(pi), at(pi_prev), at(mu));
            let s: [f64; W] = std::array::from_fn(|l| m[l] * p[l]);
            let tau: [f64; W] = std::array::from_fn(|l| madd::<FMA>(nf, s[l], -n1 * pp[l]));
            let next: [f64; W] = std::array::from_fn(|l| madd::<FMA>(r1, s[l], -r2 * pp[l]));
            tp[v..v + W].copy_from_slice(&p);
            tt[v..v + W].copy_from_slice(&tau);
            pi_prev[v..v + W].copy_from_slice(&p);
            pi[v..v + W].copy_from_slice(&next);
        }
        nf += 1.0;
    }
}

/// Adds one tile of a sphere's series (its `terms` from an odd order on, at most
/// [`BATCH_TILE`]) at the `W` cosines from lane `v` of the block to its partial sums `acc`
/// (`acc[q]` the `q`-th sum of the layout of [`step`]), held in registers meanwhile.
#[inline(always)]
fn sum_tile<const FMA: bool, const W: usize>(
    terms: &[[f64; 6]],
    table: &OrderTable,
    v: usize,
    acc: &mut BlockSums,
) {
    assert!(v + W <= LANES, "vector within the block");
    let lanes = |row: &[f64; LANES]| -> [f64; W] { std::array::from_fn(|l| row[v + l]) };
    let mut r: [[f64; W]; 8] = std::array::from_fn(|q| lanes(&acc[q]));
    let mut pairs = terms.chunks_exact(2);
    let mut tabled = table.pi.chunks_exact(2).zip(table.tau.chunks_exact(2));
    for (pair, (pi, tau)) in (&mut pairs).zip(&mut tabled) {
        add_order::<FMA, true, W>(&pair[0], &lanes(&pi[0]), &lanes(&tau[0]), &mut r);
        add_order::<FMA, false, W>(&pair[1], &lanes(&pi[1]), &lanes(&tau[1]), &mut r);
    }
    if let ([last], Some((pi, tau))) = (pairs.remainder(), tabled.next()) {
        add_order::<FMA, true, W>(last, &lanes(&pi[0]), &lanes(&tau[0]), &mut r);
    }
    for (q, sums) in r.iter().enumerate() {
        acc[q][v..v + W].copy_from_slice(sums);
    }
}

/// One order's eight fused multiply-adds into the parity-split sums (layout of [`step`]).
#[inline(always)]
fn add_order<const FMA: bool, const ODD: bool, const W: usize>(
    t: &[f64; 6],
    pi: &[f64; W],
    tau: &[f64; W],
    r: &mut [[f64; W]; 8],
) {
    let [car, cai, cbr, cbi, _, _] = *t;
    let (ia, ib, ja, jb) = if ODD { (0, 2, 6, 4) } else { (2, 0, 4, 6) };
    for l in 0..W {
        r[ia][l] = madd::<FMA>(car, pi[l], r[ia][l]);
        r[ia + 1][l] = madd::<FMA>(cai, pi[l], r[ia + 1][l]);
        r[ib][l] = madd::<FMA>(cbr, tau[l], r[ib][l]);
        r[ib + 1][l] = madd::<FMA>(cbi, tau[l], r[ib + 1][l]);
        r[ja][l] = madd::<FMA>(car, tau[l], r[ja][l]);
        r[ja + 1][l] = madd::<FMA>(cai, tau[l], r[ja + 1][l]);
        r[jb][l] = madd::<FMA>(cbr, pi[l], r[jb][l]);
        r[jb + 1][l] = madd::<FMA>(cbi, pi[l], r[jb + 1][l]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct evaluation of the series (scalar, no symmetry) for comparison.
    fn direct(c: &MieCoefficients, mu: f64) -> (Complex64, Complex64) {
        let (mut s1, mut s2) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
        let (mut pp, mut p) = (0.0, 1.0);
        for i in 0..c.n_stop() {
            let n = (i + 1) as f64;
            let tau = n * mu * p - (n + 1.0) * pp;
            let w = (2.0 * n + 1.0) / (n * (n + 1.0));
            s1 += w * (c.a[i] * p + c.b[i] * tau);
            s2 += w * (c.a[i] * tau + c.b[i] * p);
            let next = ((2.0 * n + 1.0) * mu * p - (n + 1.0) * pp) / n;
            pp = p;
            p = next;
        }
        (s1, s2)
    }

    /// Angles paired with their supplements give the direct sums, and a 0–180° grid sums
    /// only its half.
    #[test]
    fn angles_paired_by_mirror_match_direct_sums() {
        let c = MieCoefficients::new(731.0, Complex64::new(1.333, 1e-4)).unwrap();
        let series = AngularSeries::new(&c);
        let grid: Vec<f64> = (0..=3600).map(|k| 0.0 + k as f64 * 0.05).collect();
        let plan = MirrorPlan::new(&grid);
        assert_eq!(plan.mu.len(), 1801);
        // Unpaired angles beyond 90° (no supplement asked for), unsorted, with a repeat.
        let loose = [170.3, 12.0, 95.5, 90.0, 170.3, 179.999, 0.0];
        let loose_plan = MirrorPlan::new(&loose);
        assert_eq!(loose_plan.mu.len(), loose.len());
        for angles in [&grid[..], &loose[..]] {
            for parallel in [false, true] {
                let (s1, s2) = amplitudes_at_angles(&series, angles, parallel);
                let mu: Vec<f64> = angles.iter().map(|a| a.to_radians().cos()).collect();
                let (d1, d2) = amplitudes(&series, &mu);
                let scale = d1.iter().chain(&d2).map(|v| v.norm()).fold(0.0, f64::max);
                for j in 0..angles.len() {
                    let e = (s1[j] - d1[j]).norm().max((s2[j] - d2[j]).norm()) / scale;
                    assert!(e < 1e-11, "angle {}: {e:e}", angles[j]);
                }
            }
        }
    }

    #[test]
    fn kernel_matches_direct_sum_and_mirror() {
        let c = MieCoefficients::new(57.3, Complex64::new(1.33, 0.01)).unwrap();
        let series = AngularSeries::new(&c);
        let mu: Vec<f64> = (0..37)
            .map(|k| (k as f64 * 2.5f64).to_radians().cos())
            .collect();
        for parallel in [false, true] {
            let out = amplitudes_mirrored(&series, &mu, parallel);
            for (j, &m) in mu.iter().enumerate() {
                let (d1, d2) = direct(&c, m);
                let (e1, e2) = direct(&c, -m);
                let scale = d1.norm().max(1.0);
                assert!((out.s1[j] - d1).norm() < 1e-12 * scale);
                assert!((out.s2[j] - d2).norm() < 1e-12 * scale);
                assert!((out.s1_mirror[j] - e1).norm() < 1e-12 * scale);
                assert!((out.s2_mirror[j] - e2).norm() < 1e-12 * scale);
            }
        }
    }

    /// The batched kernel gives the per-sphere sums: spheres of different lengths (odd and even,
    /// across tiles of orders), a cosine count that is not a multiple of the block, mirrors.
    #[test]
    fn batch_matches_per_sphere_kernel() {
        let m = Complex64::new(1.333, 0.0);
        let spheres: Vec<AngularSeries> = [3.1, 57.3, 200.5, 731.0, 64.0]
            .iter()
            .map(|&x| AngularSeries::new(&MieCoefficients::new(x, m).unwrap()))
            .collect();
        assert!(
            spheres.iter().any(|s| s.len() % 2 == 1) && spheres.iter().any(|s| s.len() % 2 == 0)
        );
        let mu: Vec<f64> = (0..37)
            .map(|k| (k as f64 * 2.5f64).to_radians().cos())
            .collect();
        let refs: Vec<&AngularSeries> = spheres.iter().collect();
        let empty = amplitudes_mirrored_batch(&[], &mu);
        assert!(empty.is_empty());
        let mut batches = vec![amplitudes_mirrored_batch(&refs, &mu)];
        // every x86-64 path the CPU has, beside the one chosen
        #[cfg(target_arch = "x86_64")]
        {
            let fma = std::arch::is_x86_feature_detected!("fma");
            type Path = unsafe fn(&[&AngularSeries], &[f64], &mut [MirroredAmplitudes]);
            let paths: [(bool, Path); 2] = [
                (
                    std::arch::is_x86_feature_detected!("avx2"),
                    run_batch_avx2_fma,
                ),
                (
                    std::arch::is_x86_feature_detected!("avx512f"),
                    run_batch_avx512_fma,
                ),
            ];
            for (_, path) in paths.into_iter().filter(|p| fma && p.0) {
                let mut out = amplitudes_mirrored_batch(&refs, &mu);
                out.iter_mut()
                    .for_each(|o| o.s1.fill(Complex64::new(0.0, 0.0)));
                // SAFETY: the CPU has the path's features (filtered above).
                unsafe { path(&refs, &mu, &mut out) };
                batches.push(out);
            }
        }
        for (s, b) in batches.iter().flat_map(|batch| spheres.iter().zip(batch)) {
            let one = amplitudes_mirrored(s, &mu, false);
            let pairs = [
                (&one.s1, &b.s1),
                (&one.s2, &b.s2),
                (&one.s1_mirror, &b.s1_mirror),
                (&one.s2_mirror, &b.s2_mirror),
            ];
            for (x, y) in pairs {
                for (u, w) in x.iter().zip(y.iter()) {
                    assert!((u - w).norm() <= 1e-12 * u.norm(), "{u} {w}");
                }
            }
        }
    }

    /// S_1 = S_2 at θ = 0 and S_1 = −S_2 at θ = 180° (BH Eq. 4.74 with π_n(±1), τ_n(±1)).
    #[test]
    fn forward_and_backward_identities() {
        let c = MieCoefficients::new(123.4, Complex64::new(1.5, 0.0)).unwrap();
        let out = amplitudes_mirrored(&AngularSeries::new(&c), &[1.0], false);
        assert!((out.s1[0] - out.s2[0]).norm() < 1e-10 * out.s1[0].norm());
        assert!((out.s1_mirror[0] + out.s2_mirror[0]).norm() < 1e-10 * out.s1_mirror[0].norm());
    }
}
