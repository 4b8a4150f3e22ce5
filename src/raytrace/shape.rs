//! Drop shapes: spheres and axisymmetric star-shaped drops `r(θ) = a[1 + Σ c_n cos nθ]`.
//!
//! Frame: the drop centre is the origin, its symmetry (fall) axis is `z` pointing up. The polar
//! angle θ of the profile is measured from the **downward** pole (`−z`, towards the oncoming air;
//! decision RT-12 in `docs/decisions.md`): `cos θ = −z/|p|`. `a` is the radius of the
//! equal-volume sphere.
//!
//! Since `cos nθ = T_n(cos θ)` (Chebyshev polynomials), `r` and `r′/sin θ` are polynomials of
//! `cos θ = −z/|p|`: no trigonometry is evaluated and the normal is analytic and smooth at the
//! poles (decision RT-13: analytic implicit surface, never facets).
//!
//! Intersection: spheres analytically; cosine-series drops by bracketing the implicit function
//! `g(p) = |p| − r(θ(p))` along the chord through the bounding sphere (uniform samples; those
//! outside a spheroid that holds the drop, or inside one that the drop holds, are decided
//! without evaluating `g`), then Newton's method on the bracket with the analytic slope of `g`
//! along the ray, safeguarded by bisection. A ray that starts on the surface and points
//! inwards always has a bracket (g < 0 inside, g > 0 at the bounding-sphere exit), so every
//! entering ray exits (no leaks at grazing incidence or at the poles); a grazing chord shorter
//! than the sampling step degenerates to an exit at the start point.

use std::f64::consts::PI;

/// Beard & Chuang (1987) cosine-series coefficients c0..c7, as in Table 3.1 of the thesis, for
/// equivalent radii 0.4 (sphere, added by the thesis), 1.0, 1.5, 2.0, 2.5 and 3.0 mm.
pub const BEARD_CHUANG_TABLE_3_1: [(f64, [f64; 8]); 6] = [
    (0.4, [0.0; 8]),
    (
        1.0,
        [
            -0.0131, -0.0120, -0.0376, -0.0096, -0.0004, 0.0015, 0.0005, 0.0,
        ],
    ),
    (
        1.5,
        [
            -0.0282, -0.0230, -0.0779, -0.0175, 0.0021, 0.0046, 0.0011, -0.0006,
        ],
    ),
    (
        2.0,
        [
            -0.0458, -0.0335, -0.1211, -0.0227, 0.0083, 0.0089, 0.0012, -0.0021,
        ],
    ),
    (
        2.5,
        [
            -0.0644, -0.0416, -0.1629, -0.0246, 0.0176, 0.0131, 0.0002, -0.0044,
        ],
    ),
    (
        3.0,
        [
            -0.0840, -0.0480, -0.2034, -0.0237, 0.0297, 0.0166, -0.0021, -0.0072,
        ],
    ),
];

/// Beard–Chuang coefficients at equivalent radius `radius_mm`: linear in `a` between the rows
/// of Table 3.1; a ≤ 0.4 mm is a sphere (thesis parity); a > 3 mm is clamped to the 3 mm row
/// (decision RT-12).
pub fn beard_chuang_coefficients(radius_mm: f64) -> [f64; 8] {
    let t = &BEARD_CHUANG_TABLE_3_1;
    if radius_mm <= t[0].0 {
        return t[0].1;
    }
    if radius_mm >= t[5].0 {
        return t[5].1;
    }
    let k = t.iter().rposition(|r| r.0 <= radius_mm).unwrap_or(0).min(4);
    let w = (radius_mm - t[k].0) / (t[k + 1].0 - t[k].0);
    let mut c = [0.0; 8];
    for (n, cn) in c.iter_mut().enumerate() {
        *cn = t[k].1[n] * (1.0 - w) + t[k + 1].1[n] * w;
    }
    c
}

/// Surface hit.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f64,
    /// Hit point.
    pub point: [f64; 3],
    /// Outward unit normal.
    pub normal: [f64; 3],
}

/// Rays intersected together by [`DropShape::intersect_lanes`].
pub const LANES: usize = 8;

/// A ray `(o, d)`: origin and unit direction.
pub type Ray = ([f64; 3], [f64; 3]);

/// Where a ray may cross a cosine-series surface ([`CosineSeries::crossing`]).
enum Crossing {
    /// It misses the bounding sphere.
    None,
    /// Between the spheroids, the iteration ready to start.
    Bracketed(BracketedNewton),
    /// Somewhere on the bounding sphere's chord `[t0, t1]`.
    Chord(f64, f64),
}

/// A drop shape (radius in µm).
#[derive(Debug, Clone)]
pub enum DropShape {
    /// Sphere of radius `radius_um`.
    Sphere { radius_um: f64 },
    /// Axisymmetric cosine-series drop.
    Series(CosineSeries),
}

/// `r(θ) = a [1 + Σ_n c_n cos nθ]`, θ from the downward pole.
#[derive(Debug, Clone)]
pub struct CosineSeries {
    /// Equal-volume radius `a` (µm).
    pub radius_um: f64,
    /// c_0, c_1, ...
    pub coeffs: Vec<f64>,
    /// Bounding-sphere radius (µm), slightly above max r.
    pub r_max_um: f64,
    /// Spheroids about the centre that hold the drop (`outer`) and that the drop holds
    /// (`inner`), each 0.1 % clear of the surface: outside `outer` g > 0, inside `inner` g < 0,
    /// so the march of [`DropShape::intersect`] skips evaluating g there.
    pub outer: Spheroid,
    pub inner: Spheroid,
    /// Whether the drop is convex (its meridian turns one way throughout), which lets
    /// [`DropShape::intersect`] bracket a crossing between the two spheroids.
    pub convex: bool,
    /// `r(c)` and `r′/sin θ` as polynomials in `c = cos θ` (µm; coefficients of `c⁰ … c⁷`) for
    /// series of degree ≤ 7 (every Beard–Chuang drop), evaluated by Estrin's scheme: half the
    /// dependent operations of the recurrences. `None` for longer series, which keep them.
    monomials: Option<Box<Monomials>>,
}

/// The spheroid `ρ²/A² + z²/C² = 1` about the origin (ρ the distance from the `z` axis), kept
/// as `1/A²` and `1/C²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spheroid {
    inv_a2: f64,
    inv_c2: f64,
}

impl Spheroid {
    /// Semi-axes `a` (horizontal) and `c` (vertical).
    pub fn new(a: f64, c: f64) -> Self {
        Spheroid {
            inv_a2: 1.0 / (a * a),
            inv_c2: 1.0 / (c * c),
        }
    }

    /// A placeholder outer bound that no point is outside (`A = C = ∞`): the march never skips
    /// a sample for it.
    pub const fn everything() -> Self {
        Spheroid {
            inv_a2: 0.0,
            inv_c2: 0.0,
        }
    }

    /// A placeholder inner bound that no point is inside (`A = C = 0`: its level is ∞ or NaN,
    /// never below 1): the march never skips a sample for it.
    pub const fn nothing() -> Self {
        Spheroid {
            inv_a2: f64::INFINITY,
            inv_c2: f64::INFINITY,
        }
    }

    /// `ρ²/A² + z²/C²` at `p`: below 1 inside, above 1 outside.
    #[inline]
    pub fn level(&self, p: [f64; 3]) -> f64 {
        (p[0] * p[0] + p[1] * p[1]) * self.inv_a2 + p[2] * p[2] * self.inv_c2
    }

    /// The chord of the ray `o + t d` (unit `d`) through the spheroid: the parameters `(t_in,
    /// t_out)` where its level crosses 1, or `None` when the ray misses it or only touches it.
    #[inline]
    pub fn chord(&self, o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
        let a = (d[0] * d[0] + d[1] * d[1]) * self.inv_a2 + d[2] * d[2] * self.inv_c2;
        let b = (o[0] * d[0] + o[1] * d[1]) * self.inv_a2 + o[2] * d[2] * self.inv_c2;
        let c = self.level(o) - 1.0;
        let disc = b * b - a * c;
        if !(disc > 0.0 && a > 0.0 && a.is_finite()) {
            return None;
        }
        let sq = disc.sqrt();
        // The root of larger magnitude first, the other from the product of the roots.
        let q = -b - b.signum() * sq;
        let (t1, t2) = (q / a, c / q);
        Some((t1.min(t2), t1.max(t2)))
    }

    /// Its radius in the direction at polar angle θ (any origin of θ on the axis): `1/√(sin²θ/A²
    /// + cos²θ/C²)`, from `cos θ`.
    fn radius_at(&self, c: f64) -> f64 {
        1.0 / ((1.0 - c * c) * self.inv_a2 + c * c * self.inv_c2).sqrt()
    }
}

/// The profile of a [`CosineSeries`] at a point `p`: `|p|` and its reciprocal, `c = −p_z/|p|`
/// (the cosine of the polar angle from the downward pole), `r(c)` and `r′/sin θ`.
#[derive(Debug, Clone, Copy)]
struct AtPoint {
    p: [f64; 3],
    len: f64,
    inv_len: f64,
    c: f64,
    r: f64,
    rs: f64,
}

impl AtPoint {
    /// The outward unit normal of the surface through the point's polar angle, at the point.
    #[inline]
    fn normal(&self) -> [f64; 3] {
        let AtPoint {
            p,
            inv_len,
            c,
            r,
            rs,
            ..
        } = *self;
        let radial = r - rs * c;
        let nz_prime = r * c + rs * (1.0 - c * c);
        normalize([p[0] * inv_len * radial, p[1] * inv_len * radial, -nz_prime])
    }
}

impl CosineSeries {
    /// Build a series drop; fails if `r(θ) ≤ 0` somewhere.
    pub fn new(radius_um: f64, coeffs: Vec<f64>) -> Result<Self, String> {
        let mut s = CosineSeries {
            radius_um,
            coeffs,
            r_max_um: 0.0,
            outer: Spheroid::everything(),
            inner: Spheroid::nothing(),
            convex: false,
            monomials: None,
        };
        s.monomials = monomial_coefficients(s.radius_um, &s.coeffs);
        let profile: Vec<(f64, f64)> = (0..=4096)
            .map(|k| {
                let c = (PI * k as f64 / 4096.0).cos();
                (c, s.r_and_rs(c).0)
            })
            .collect();
        if profile.iter().any(|&(_, r)| r <= 0.0) {
            return Err("profile radius must stay positive".into());
        }
        let rmax = profile.iter().map(|p| p.1).fold(0.0, f64::max);
        s.r_max_um = rmax * 1.001 + 1e-9;
        (s.outer, s.inner) = bounding_spheroids(&profile);
        s.convex = meridian_is_convex(&profile);
        Ok(s)
    }

    /// Beard–Chuang drop of equivalent radius `radius_mm` (see [`beard_chuang_coefficients`]).
    pub fn beard_chuang(radius_mm: f64) -> Self {
        Self::new(
            radius_mm * 1e3,
            beard_chuang_coefficients(radius_mm).to_vec(),
        )
        .expect("Table 3.1 profiles are positive")
    }

    /// Least-squares cosine-series fit (order ≤ 12) of a tabulated profile `r(θ)` (θ in degrees
    /// from the downward pole, any positive unit), rescaled to the equal-volume radius
    /// `radius_um`. Returns the series and the RMS relative residual of the fit.
    pub fn fit_table(radius_um: f64, theta_deg: &[f64], r: &[f64]) -> Result<(Self, f64), String> {
        if theta_deg.len() != r.len() || theta_deg.len() < 3 {
            return Err("profile table needs ≥ 3 (θ, r) pairs of equal length".into());
        }
        if r.iter().any(|&x| x.is_nan() || x <= 0.0) {
            return Err("profile radii must be positive".into());
        }
        let order = ((theta_deg.len() - 1) / 2).min(12);
        let m = order + 1;
        let mut ata = vec![0.0; m * m];
        let mut atb = vec![0.0; m];
        for (th, rv) in theta_deg.iter().zip(r) {
            let t = th.to_radians();
            let basis: Vec<f64> = (0..m).map(|n| (n as f64 * t).cos()).collect();
            for i in 0..m {
                atb[i] += basis[i] * rv;
                for j in 0..m {
                    ata[i * m + j] += basis[i] * basis[j];
                }
            }
        }
        let d = solve_dense(&mut ata, &mut atb, m).ok_or("singular profile fit")?;
        // Volume of the fitted profile, to rescale to the requested equal-volume radius.
        let unit = CosineSeries {
            radius_um: 1.0,
            coeffs: {
                let mut c = d.clone();
                c[0] -= 1.0;
                c
            },
            r_max_um: 0.0,
            outer: Spheroid::everything(),
            inner: Spheroid::nothing(),
            convex: false,
            monomials: None,
        };
        let v = unit.volume_um3();
        let a0 = (3.0 * v / (4.0 * PI)).cbrt();
        let mut coeffs: Vec<f64> = d.iter().map(|x| x / a0).collect();
        coeffs[0] -= 1.0;
        let s = CosineSeries::new(radius_um, coeffs)?;
        let mut res = 0.0;
        for (th, rv) in theta_deg.iter().zip(r) {
            let (rf, _) = unit.r_and_rs(th.to_radians().cos());
            res += ((rf - rv) / rv).powi(2);
        }
        Ok((s, (res / r.len() as f64).sqrt()))
    }

    /// `(r, r′/sin θ)` at `c = cos θ` (µm).
    #[inline]
    pub fn r_and_rs(&self, c: f64) -> (f64, f64) {
        match &self.monomials {
            Some(m) => (estrin7(&m.0, c), estrin7(&m.1, c)),
            None => self.r_and_rs_by_recurrence(c),
        }
    }

    /// [`Self::r_and_rs`] by the Chebyshev recurrences, for any length of series.
    fn r_and_rs_by_recurrence(&self, c: f64) -> (f64, f64) {
        // T_n(c) and U_{n-1}(c) by recurrence; r' = dr/dθ = −a Σ n c_n sin nθ,
        // sin nθ = sin θ U_{n−1}(c).
        let mut t_prev = 1.0; // T_0
        let mut t_cur = c; // T_1
        let mut u_prev = 0.0; // U_{-1}
        let mut u_cur = 1.0; // U_0
        let mut sum = self.coeffs.first().copied().unwrap_or(0.0);
        let mut dsum = 0.0;
        for (n, &cn) in self.coeffs.iter().enumerate().skip(1) {
            sum += cn * t_cur;
            dsum += n as f64 * cn * u_cur;
            let t_next = 2.0 * c * t_cur - t_prev;
            t_prev = t_cur;
            t_cur = t_next;
            let u_next = 2.0 * c * u_cur - u_prev;
            u_prev = u_cur;
            u_cur = u_next;
        }
        (self.radius_um * (1.0 + sum), -self.radius_um * dsum)
    }

    /// Profile radius at polar angle θ (radians from the downward pole).
    pub fn r_at(&self, theta: f64) -> f64 {
        self.r_and_rs(theta.cos()).0
    }

    /// Where the ray `o + t d` (unit `d`) may cross the surface (from outside, or from a
    /// surface point inwards when `inside`): nowhere when it misses the bounding sphere; between
    /// the spheroids when the drop is convex and the ray's chords through both allow (g's signs
    /// at the ends are the spheroids', so g is not evaluated there, and Newton starts from the
    /// middle of a bracket ≈ 0.2 % of the radius wide); otherwise somewhere on the bounding
    /// sphere's chord `[t0, t1]`, to be marched.
    fn crossing(&self, o: [f64; 3], d: [f64; 3], inside: bool) -> Crossing {
        let rb = self.r_max_um;
        let b = dot(o, d);
        let disc = b * b - (dot(o, o) - rb * rb);
        if disc <= 0.0 {
            return Crossing::None;
        }
        let sq = disc.sqrt();
        // On a convex drop the ray stays on one side of the surface until it reaches the
        // spheroids: g > 0 outside the outer one, g < 0 inside the inner one.
        let chords = self
            .convex
            .then(|| self.outer.chord(o, d).zip(self.inner.chord(o, d)));
        if let Some(((oi, oo), (ii, io))) = chords.flatten() {
            let (ta, tb) = if inside { (io, oo) } else { (oi, ii) };
            if tb > ta && ta >= 0.0 {
                return Crossing::Bracketed(BracketedNewton::new(
                    (ta, !inside),
                    tb,
                    0.5 * (ta + tb),
                ));
            }
        }
        let (t0, t1) = if inside {
            (0.0, -b + sq)
        } else {
            (-b - sq, -b + sq)
        };
        if t1 <= t0 {
            Crossing::None
        } else {
            Crossing::Chord(t0, t1)
        }
    }

    /// The hit at `t` on the ray `o + t d`, its normal from Newton's last evaluation `last`
    /// (at most the tolerance, 1e-13 of the position, from the root), which spares evaluating
    /// the series once more.
    #[inline]
    fn hit_at(&self, o: [f64; 3], d: [f64; 3], t: f64, last: Option<AtPoint>) -> Hit {
        let p = add(o, scale(d, t));
        let normal = match last {
            Some(q) if q.len > 0.0 => q.normal(),
            _ => self.normal(p),
        };
        Hit {
            t,
            point: p,
            normal,
        }
    }

    /// The profile at `p`: `|p|`, `c = −p_z/|p|`, and `(r, r′/sin θ)` there (NaN `c` at the
    /// centre).
    #[inline]
    fn at_point(&self, p: [f64; 3]) -> AtPoint {
        let len = norm(p);
        let inv_len = 1.0 / len;
        let c = -p[2] * inv_len;
        let (r, rs) = self.r_and_rs(c);
        AtPoint {
            p,
            len,
            inv_len,
            c,
            r,
            rs,
        }
    }

    /// `g` at `p` and its derivative along the unit direction `d` (µm per µm): with
    /// `c = −p_z/|p|`, `dg/dt = p·d/|p| − (dr/dc)(dc/dt)` and `dr/dc = −r′/sin θ`.
    #[cfg(test)]
    fn g_and_slope(&self, p: [f64; 3], d: [f64; 3]) -> (f64, f64) {
        self.g_and_slope_at(&self.at_point(p), d)
    }

    /// [`Self::g_and_slope`] from the profile at the point.
    #[inline]
    fn g_and_slope_at(&self, q: &AtPoint, d: [f64; 3]) -> (f64, f64) {
        if q.len == 0.0 {
            return (-self.radius_um, 1.0);
        }
        // One division per evaluation: the reciprocal of |p| multiplies instead.
        let radial = dot(q.p, d) * q.inv_len;
        let dc_dt = (-d[2] + q.p[2] * radial * q.inv_len) * q.inv_len;
        (q.len - q.r, radial + q.rs * dc_dt)
    }

    #[inline]
    fn g(&self, p: [f64; 3]) -> f64 {
        let len = norm(p);
        if len == 0.0 {
            return -self.radius_um;
        }
        len - self.r_and_rs(-p[2] / len).0
    }

    /// Outward unit normal at a surface point.
    pub fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        self.at_point(p).normal()
    }

    /// Volume (µm³): (2π/3) ∫ r³ sin θ dθ.
    pub fn volume_um3(&self) -> f64 {
        2.0 * PI / 3.0
            * crate::math::quadrature::integrate(
                |th| self.r_and_rs(th.cos()).0.powi(3) * th.sin(),
                0.0,
                PI,
                200,
            )
    }

    /// Vertical / horizontal axis ratio: (r(0) + r(π)) / (2 max ρ).
    pub fn axis_ratio(&self) -> f64 {
        let h = self.r_and_rs(1.0).0 + self.r_and_rs(-1.0).0;
        (h / 2.0) / self.max_rho()
    }

    /// Largest distance from the symmetry axis (µm).
    pub fn max_rho(&self) -> f64 {
        (0..=8192)
            .map(|k| {
                let th = PI * k as f64 / 8192.0;
                self.r_and_rs(th.cos()).0 * th.sin()
            })
            .fold(0.0, f64::max)
    }
}

/// Gaussian elimination with partial pivoting (small dense systems).
fn solve_dense(a: &mut [f64], b: &mut [f64], n: usize) -> Option<Vec<f64>> {
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[piv * n + col].abs() < 1e-300 {
            return None;
        }
        for k in 0..n {
            a.swap(col * n + k, piv * n + k);
        }
        b.swap(col, piv);
        for row in col + 1..n {
            let f = a[row * n + col] / a[col * n + col];
            for k in col..n {
                a[row * n + k] -= f * a[col * n + k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let mut s = b[row];
        for k in row + 1..n {
            s -= a[row * n + k] * x[k];
        }
        x[row] = s / a[row * n + row];
    }
    Some(x)
}

impl DropShape {
    /// Beard–Chuang drop of equivalent radius `radius_mm`; a sphere when all coefficients
    /// vanish (a ≤ 0.4 mm), which uses the exact analytic intersection.
    pub fn beard_chuang(radius_mm: f64) -> Self {
        let c = beard_chuang_coefficients(radius_mm);
        if c.iter().all(|x| *x == 0.0) {
            DropShape::Sphere {
                radius_um: radius_mm * 1e3,
            }
        } else {
            DropShape::Series(CosineSeries::beard_chuang(radius_mm))
        }
    }

    /// Bounding-sphere radius (µm).
    pub fn bounding_radius_um(&self) -> f64 {
        match self {
            DropShape::Sphere { radius_um } => *radius_um,
            DropShape::Series(s) => s.r_max_um,
        }
    }

    /// Equal-volume radius (µm).
    pub fn radius_um(&self) -> f64 {
        match self {
            DropShape::Sphere { radius_um } => *radius_um,
            DropShape::Series(s) => s.radius_um,
        }
    }

    /// Half-extents (W1, W2) of the silhouette bounding box centred on the projected drop
    /// centre, in the plane spanned by `e1 = (−sin e, 0, cos e)` and `e2 = y` (sun elevation e).
    pub fn silhouette_half_extents(&self, sun_elevation_rad: f64) -> (f64, f64) {
        match self {
            DropShape::Sphere { radius_um } => (*radius_um, *radius_um),
            DropShape::Series(s) => {
                let (se, ce) = sun_elevation_rad.sin_cos();
                let mut w1: f64 = 0.0;
                let mut w2: f64 = 0.0;
                for k in 0..=8192 {
                    let th = PI * k as f64 / 8192.0;
                    let r = s.r_at(th);
                    let rho = r * th.sin();
                    let z = -r * th.cos();
                    w2 = w2.max(rho);
                    w1 = w1
                        .max((se * rho + ce * z).abs())
                        .max((-se * rho + ce * z).abs());
                }
                (w1 * 1.002, w2 * 1.002)
            }
        }
    }

    /// First intersection of the ray `o + t d` (unit `d`) with the surface: from outside
    /// (`inside = false`) the entry point, from a point on the surface going inwards
    /// (`inside = true`) the exit point.
    pub fn intersect(&self, o: [f64; 3], d: [f64; 3], inside: bool) -> Option<Hit> {
        match self {
            DropShape::Sphere { radius_um } => sphere_intersect(*radius_um, o, d, inside),
            DropShape::Series(s) => self.series_intersect(s, o, d, inside),
        }
    }

    /// [`Self::intersect`] for a cosine-series surface: bracketed between the inner and outer
    /// spheroids when the drop is convex and the chord allows, otherwise marched in 32 steps
    /// across the bounding sphere; the root is refined by Newton's method safeguarded by the
    /// bracket.
    fn series_intersect(
        &self,
        s: &CosineSeries,
        o: [f64; 3],
        d: [f64; 3],
        inside: bool,
    ) -> Option<Hit> {
        self.hit_of_crossing(s, (o, d), inside, s.crossing(o, d, inside))
    }

    /// [`Self::series_intersect`] from the ray's [`CosineSeries::crossing`].
    fn hit_of_crossing(
        &self,
        s: &CosineSeries,
        (o, d): Ray,
        inside: bool,
        crossing: Crossing,
    ) -> Option<Hit> {
        match crossing {
            Crossing::None => self.miss(s, o, inside),
            Crossing::Bracketed(mut newton) => loop {
                let q = s.at_point(add(o, scale(d, newton.t)));
                let (g, slope) = s.g_and_slope_at(&q, d);
                if let Some(t) = newton.step(g, slope, newton_tolerance) {
                    return Some(s.hit_at(o, d, t, Some(q)));
                }
            },
            Crossing::Chord(t0, t1) => {
                let last = Cell::new(None::<AtPoint>);
                let g_slope_at = |t: f64| {
                    let q = s.at_point(add(o, scale(d, t)));
                    last.set(Some(q));
                    s.g_and_slope_at(&q, d)
                };
                match march(s, o, d, inside, (t0, t1)) {
                    Some((ta, ga, tb, gb)) => {
                        let t = newton_bracketed(g_slope_at, ta, ga, tb, gb);
                        Some(s.hit_at(o, d, t, last.get()))
                    }
                    None => self.miss(s, o, inside),
                }
            }
        }
    }

    /// [`Self::intersect`] of the rays `(o, d)` of `rays` (`None` lanes are skipped), with the
    /// same hits bit for bit: the Newton iterations of the rays whose crossing the spheroids
    /// bracket advance in turn, one evaluation per ray, so that the processor overlaps the
    /// evaluations of different rays instead of waiting on each one's chain of dependent
    /// operations (the iteration is latency-bound).
    pub fn intersect_lanes(
        &self,
        rays: [Option<Ray>; LANES],
        inside: bool,
    ) -> [Option<Hit>; LANES] {
        let DropShape::Series(s) = self else {
            return rays.map(|ray| ray.and_then(|(o, d)| self.intersect(o, d, inside)));
        };
        let mut hits = [None; LANES];
        let mut pending: [Option<(BracketedNewton, Ray)>; LANES] = [None; LANES];
        for ((hit, slot), ray) in hits.iter_mut().zip(&mut pending).zip(rays) {
            let Some((o, d)) = ray else { continue };
            match s.crossing(o, d, inside) {
                Crossing::Bracketed(newton) => *slot = Some((newton, (o, d))),
                other => *hit = self.hit_of_crossing(s, (o, d), inside, other),
            }
        }
        loop {
            let mut running = false;
            for (hit, slot) in hits.iter_mut().zip(&mut pending) {
                let Some((newton, (o, d))) = slot else {
                    continue;
                };
                let q = s.at_point(add(*o, scale(*d, newton.t)));
                let (g, slope) = s.g_and_slope_at(&q, *d);
                match newton.step(g, slope, newton_tolerance) {
                    Some(t) => {
                        *hit = Some(s.hit_at(*o, *d, t, Some(q)));
                        *slot = None;
                    }
                    None => running = true,
                }
            }
            if !running {
                return hits;
            }
        }
    }

    /// No crossing: none from outside, the degenerate exit at `o` from inside.
    fn miss(&self, s: &CosineSeries, o: [f64; 3], inside: bool) -> Option<Hit> {
        inside.then(|| self.degenerate_exit(s, o))
    }

    fn degenerate_exit(&self, s: &CosineSeries, o: [f64; 3]) -> Hit {
        Hit {
            t: 0.0,
            point: o,
            normal: s.normal(o),
        }
    }
}

/// [`newton_bracketed`] to a step below 1e-13 of the position (relative), the accuracy of the
/// regula falsi it replaces, in typically 3–5 evaluations where the regula falsi needed about
/// twice as many.
fn newton_bracketed(gd: impl Fn(f64) -> (f64, f64), a: f64, ga: f64, b: f64, gb: f64) -> f64 {
    roots::newton_bracketed(gd, (a, ga), (b, gb), newton_tolerance)
}

/// The step below which the intersection's Newton iteration stops: 1e-13 of the position.
fn newton_tolerance(t: f64) -> f64 {
    1e-13 * (1.0 + t.abs())
}

use crate::math::roots::{self, BracketedNewton};
pub(crate) use crate::math::vec3::{add, cross, dot, norm, normalize, scale, sub};
use std::cell::Cell;

/// Samples along the bounding sphere's chord `[t0, t1]` of the ray `o + t d`.
const MARCH_STEPS: usize = 32;

/// The step between the march's samples of the chord `[t0, t1]`.
fn march_step((t0, t1): (f64, f64)) -> f64 {
    (t1 - t0) / MARCH_STEPS as f64
}

/// Sample `k` (1 … [`MARCH_STEPS`]) of the march along the chord `[t0, t1]`; the last is `t1`.
fn march_sample((t0, t1): (f64, f64), k: usize) -> f64 {
    if k == MARCH_STEPS {
        t1
    } else {
        t0 + march_step((t0, t1)) * k as f64
    }
}

/// The first of [`MARCH_STEPS`] uniform samples of the chord `[t0, t1]` where g changes sign
/// (from outside, `g ≤ 0`; from the surface inwards, `g ≥ 0`) and the sample before it, as the
/// bracket `(ta, g(ta), tb, g(tb))`; the first sample of an inward ray counts as
/// `g = −0.01·step`; `None` when no sample crosses. A sample outside the drop's outer
/// spheroid (from outside) or inside its inner one (inwards) cannot cross, so g is not evaluated
/// there unless it becomes the bracket's first end: the bracket, and so the hit, are those of
/// evaluating every sample, bit for bit.
fn march(
    s: &CosineSeries,
    o: [f64; 3],
    d: [f64; 3],
    inside: bool,
    (t0, t1): (f64, f64),
) -> Option<(f64, f64, f64, f64)> {
    let at = |t: f64| add(o, scale(d, t));
    let mut ta = t0;
    let mut ga = inside.then_some(-0.01 * march_step((t0, t1)));
    for k in 1..=MARCH_STEPS {
        let tb = march_sample((t0, t1), k);
        let p = at(tb);
        let cannot_cross = if inside {
            s.inner.level(p) < 1.0
        } else {
            s.outer.level(p) > 1.0
        };
        if cannot_cross {
            ta = tb;
            ga = None;
            continue;
        }
        let gb = s.g(p);
        let crossing = if inside { gb >= 0.0 } else { gb <= 0.0 };
        if crossing {
            let ga = ga.unwrap_or_else(|| s.g(at(ta)));
            return Some((ta, ga, tb, gb));
        }
        ta = tb;
        ga = Some(gb);
    }
    None
}

/// The monomial coefficients (`c⁰ … c⁷`, µm) of `r(c)` and of `r′/sin θ`.
type Monomials = ([f64; 8], [f64; 8]);

/// The polynomial `Σ p_k c^k` of degree ≤ 7 by Estrin's scheme.
#[inline]
fn estrin7(p: &[f64; 8], c: f64) -> f64 {
    let c2 = c * c;
    let c4 = c2 * c2;
    let lo = (p[0] + p[1] * c) + (p[2] + p[3] * c) * c2;
    let hi = (p[4] + p[5] * c) + (p[6] + p[7] * c) * c2;
    lo + hi * c4
}

/// The monomial coefficients (`c⁰ … c⁷`) of `r(c) = a (1 + Σ c_n T_n(c))` and of
/// `r′/sin θ = −a Σ n c_n U_{n−1}(c)` for a series of at most 8 terms, or `None`. The
/// conversion's rounding is ≈ 1e-15 of `a` for Beard–Chuang coefficients (test
/// `monomials_match_the_recurrences`).
fn monomial_coefficients(a: f64, coeffs: &[f64]) -> Option<Box<Monomials>> {
    if coeffs.len() > 8 {
        return None;
    }
    // T_n and U_{n−1} as coefficient arrays, by their recurrences.
    let next = |cur: &[f64; 8], prev: &[f64; 8]| {
        let mut out = [0.0; 8];
        for k in 0..8 {
            out[k] = -prev[k] + if k > 0 { 2.0 * cur[k - 1] } else { 0.0 };
        }
        out
    };
    let (mut t_prev, mut t_cur) = ([0.0; 8], [0.0; 8]);
    t_prev[0] = 1.0; // T_0
    t_cur[1] = 1.0; // T_1
    let (mut u_prev, mut u_cur) = ([0.0; 8], [0.0; 8]); // U_{-1}, U_0
    u_cur[0] = 1.0;
    let (mut r, mut rs) = ([0.0; 8], [0.0; 8]);
    r[0] = a * (1.0 + coeffs.first().copied().unwrap_or(0.0));
    for (n, &cn) in coeffs.iter().enumerate().skip(1) {
        for k in 0..8 {
            r[k] += a * cn * t_cur[k];
            rs[k] -= a * n as f64 * cn * u_cur[k];
        }
        (t_prev, t_cur) = (t_cur, next(&t_cur, &t_prev));
        (u_prev, u_cur) = (u_cur, next(&u_cur, &u_prev));
    }
    Some(Box::new((r, rs)))
}

/// Whether the meridian of a profile sampled as `(cos θ, r)` from pole to pole turns one way at
/// every sample (no turn against the others beyond rounding): the surface of revolution is then
/// convex. The samples are 0.044° apart, far finer than the curvature of a cosine series of
/// order ≤ 12 changes.
fn meridian_is_convex(profile: &[(f64, f64)]) -> bool {
    let points: Vec<(f64, f64)> = profile
        .iter()
        .map(|&(c, r)| (r * (1.0 - c * c).max(0.0).sqrt(), -r * c))
        .collect();
    let turns = points.windows(3).map(|w| {
        let (a, b) = (
            (w[1].0 - w[0].0, w[1].1 - w[0].1),
            (w[2].0 - w[1].0, w[2].1 - w[1].1),
        );
        a.0 * b.1 - a.1 * b.0
    });
    let (lo, hi) = turns.fold((0.0f64, 0.0f64), |(lo, hi), t| (lo.min(t), hi.max(t)));
    let scale = lo.abs().max(hi.abs());
    lo >= -1e-12 * scale || hi <= 1e-12 * scale
}

/// The spheroids about the centre that bound a profile sampled as `(cos θ, r)`: the one of the
/// profile's equatorial and mean polar half-axes, scaled to the largest ratio `r/r_E` over the
/// samples + 0.1 % (`outer`) and to the smallest − 0.1 % (`inner`). The samples are 0.044°
/// apart and the ratio is smooth, so the 0.1 % covers it between them.
fn bounding_spheroids(profile: &[(f64, f64)]) -> (Spheroid, Spheroid) {
    let equator = profile
        .iter()
        .map(|&(c, r)| r * (1.0 - c * c).max(0.0).sqrt())
        .fold(0.0, f64::max);
    let poles = 0.5 * (profile[0].1 + profile[profile.len() - 1].1);
    let shape = Spheroid::new(equator, poles);
    let ratios = profile.iter().map(|&(c, r)| r / shape.radius_at(c));
    let (lo, hi) = ratios.fold((f64::MAX, 0.0_f64), |(lo, hi), q| (lo.min(q), hi.max(q)));
    let (outer, inner) = (hi * 1.001, lo * 0.999);
    (
        Spheroid::new(outer * equator, outer * poles),
        Spheroid::new(inner * equator, inner * poles),
    )
}

/// First intersection of the ray `o + t d` with the sphere of radius `r` (µm) about the origin
/// (see [`DropShape::intersect`]), with the numerically stable root for the entry point.
fn sphere_intersect(r: f64, o: [f64; 3], d: [f64; 3], inside: bool) -> Option<Hit> {
    let b = dot(o, d);
    let c = dot(o, o) - r * r;
    let disc = b * b - c;
    let t = if inside {
        -b + disc.max(0.0).sqrt()
    } else {
        if disc <= 0.0 || c <= 0.0 {
            return None;
        }
        // Stable root: c / (−b + sqrt(disc)) = −b − sqrt(disc).
        let q = -b + disc.sqrt();
        c / q
    };
    if !t.is_finite() || (!inside && t <= 0.0) {
        return None;
    }
    let n = normalize(add(o, scale(d, t)));
    Some(Hit {
        t,
        point: scale(n, r),
        normal: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The march as it was before it skipped samples: g evaluated at every sample.
    fn march_evaluating_every_sample(
        s: &CosineSeries,
        o: [f64; 3],
        d: [f64; 3],
        inside: bool,
        (t0, t1): (f64, f64),
    ) -> Option<(f64, f64, f64, f64)> {
        let g_at = |t: f64| s.g(add(o, scale(d, t)));
        let first = if inside {
            -0.01 * march_step((t0, t1))
        } else {
            g_at(t0)
        };
        let (mut ta, mut ga) = (t0, first);
        for k in 1..=MARCH_STEPS {
            let tb = march_sample((t0, t1), k);
            let gb = g_at(tb);
            if (inside && gb >= 0.0) || (!inside && gb <= 0.0) {
                return Some((ta, ga, tb, gb));
            }
            (ta, ga) = (tb, gb);
        }
        None
    }

    /// The placeholder bounds never decide a sample: nothing is outside `everything` or inside
    /// `nothing`, the centre included.
    #[test]
    fn placeholder_spheroids_decide_nothing() {
        for p in [
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [3.0, -2.0, 5.0],
            [0.0, 0.0, 1e-300],
        ] {
            assert!(Spheroid::everything().level(p) <= 1.0, "{p:?}");
            assert!(Spheroid::nothing().level(p) >= 1.0 || Spheroid::nothing().level(p).is_nan());
        }
    }

    /// A random ray for `s`: from a surface point inwards (`inside`), or from 3 radii out
    /// aimed across the bounding sphere's disc; `None` when the drawn direction leaves the
    /// surface outwards.
    fn random_ray(
        s: &CosineSeries,
        uniform: &mut impl FnMut() -> f64,
        inside: bool,
    ) -> Option<([f64; 3], [f64; 3])> {
        let mut dir = || {
            let (z, phi) = (2.0 * uniform() - 1.0, 2.0 * PI * uniform());
            let rho = (1.0 - z * z).sqrt();
            [rho * phi.cos(), rho * phi.sin(), z]
        };
        let d = dir();
        if inside {
            let (th, phi) = (PI * uniform(), 2.0 * PI * uniform());
            let r = s.r_at(th);
            let p = [
                r * th.sin() * phi.cos(),
                r * th.sin() * phi.sin(),
                -r * th.cos(),
            ];
            (dot(d, s.normal(p)) < 0.0).then_some((p, d))
        } else {
            let w = dir();
            let o = sub(
                scale(d, -3.0 * s.r_max_um),
                scale(w, s.r_max_um * uniform().sqrt()),
            );
            Some((o, d))
        }
    }

    /// Rays intersected together give each ray's hit of [`DropShape::intersect`] bit for bit:
    /// Beard–Chuang drops (spheroid brackets, with the march for the chords they do not
    /// bracket), a waisted drop (marched throughout) and a sphere, with lanes left empty and
    /// rays that miss.
    #[test]
    fn intersections_in_lanes_are_those_of_single_rays() {
        let mut rng = crate::math::rng::SplitMix64::new(0x51ed_270b_27a1_bd4d);
        let mut uniform = move || rng.next_f64();
        let waisted = CosineSeries::new(1000.0, vec![0.0, 0.0, 0.3]).unwrap();
        let mut shapes: Vec<(DropShape, CosineSeries)> = [1.0, 2.0, 3.0]
            .map(|a| {
                let s = CosineSeries::beard_chuang(a);
                (DropShape::Series(s.clone()), s)
            })
            .into();
        shapes.push((DropShape::Series(waisted.clone()), waisted));
        let sphere = CosineSeries::new(1000.0, vec![0.0]).unwrap();
        shapes.push((DropShape::Sphere { radius_um: 1000.0 }, sphere));
        let (mut hits, mut misses) = (0, 0);
        for (shape, s) in &shapes {
            for round in 0..300 {
                let inside = round % 2 == 1;
                let mut rays = [None; LANES];
                for lane in rays.iter_mut() {
                    // about one lane in eight empty, and some rays far off the drop
                    if uniform() < 0.125 {
                        continue;
                    }
                    *lane = random_ray(s, &mut uniform, inside).map(|(o, d)| {
                        if !inside && uniform() < 0.2 {
                            (add(o, scale([d[1], -d[0], 0.0], 2.0 * s.r_max_um)), d)
                        } else {
                            (o, d)
                        }
                    });
                }
                let together = shape.intersect_lanes(rays, inside);
                for (ray, got) in rays.iter().zip(together) {
                    let alone = ray.and_then(|(o, d)| shape.intersect(o, d, inside));
                    match (got, alone) {
                        (Some(g), Some(a)) => {
                            assert_eq!(
                                (
                                    g.t.to_bits(),
                                    g.point.map(f64::to_bits),
                                    g.normal.map(f64::to_bits)
                                ),
                                (
                                    a.t.to_bits(),
                                    a.point.map(f64::to_bits),
                                    a.normal.map(f64::to_bits)
                                )
                            );
                            hits += 1;
                        }
                        (None, None) => misses += usize::from(ray.is_some()),
                        (g, a) => panic!("{ray:?}: {g:?} against {a:?}"),
                    }
                }
            }
        }
        assert!(hits > 5000 && misses > 300, "{hits} hits, {misses} misses");
    }

    /// The Estrin-evaluated monomials of a Beard–Chuang series give the recurrences' `r` and
    /// `r′/sin θ` within 1e-14 of the radius, at 10⁴ + 1 points of `c` from −1 to 1; a series of
    /// 13 terms keeps the recurrences.
    #[test]
    fn monomials_match_the_recurrences() {
        for a in [0.5, 1.0, 2.0, 3.0] {
            let s = CosineSeries::beard_chuang(a);
            assert!(s.monomials.is_some());
            for k in 0..=10_000 {
                let c = -1.0 + 2.0 * k as f64 / 10_000.0;
                let (r, rs) = s.r_and_rs(c);
                let (r0, rs0) = s.r_and_rs_by_recurrence(c);
                let scale = 1e-14 * s.radius_um;
                assert!(
                    (r - r0).abs() < scale && (rs - rs0).abs() < scale,
                    "{a} mm, c {c}"
                );
            }
        }
        let long = CosineSeries::new(1000.0, vec![0.01; 13]).unwrap();
        assert!(long.monomials.is_none());
    }

    /// The spheroids' chords cross their level 1 at both ends; on convex drops (Beard–Chuang
    /// 1–3 mm, not a waisted profile) the intersection bracketed between the spheroids is the
    /// one the march finds (the same drop with the fast path turned off), within the Newton
    /// tolerance, for rays from outside and from surface points inwards, with the hit point's
    /// normal; most rays take the fast path.
    #[test]
    fn spheroid_brackets_find_the_marched_crossing() {
        let waisted = CosineSeries::new(1000.0, vec![0.0, 0.0, 0.3]).unwrap();
        assert!(!waisted.convex);
        let mut rng = crate::math::rng::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
        let mut uniform = move || rng.next_f64();
        for a in [1.0, 2.0, 3.0] {
            let s = CosineSeries::beard_chuang(a);
            assert!(s.convex, "{a} mm");
            let marched = DropShape::Series(CosineSeries {
                convex: false,
                ..s.clone()
            });
            let (mut fast, mut rays) = (0, 0);
            while rays < 4000 {
                let inside = rays % 2 == 1;
                let Some((o, d)) = random_ray(&s, &mut uniform, inside) else {
                    continue;
                };
                rays += 1;
                if let Some((t_in, t_out)) = s.outer.chord(o, d) {
                    for t in [t_in, t_out] {
                        let level = s.outer.level(add(o, scale(d, t)));
                        assert!((level - 1.0).abs() < 1e-12, "{level}");
                    }
                    fast += usize::from(s.inner.chord(o, d).is_some());
                }
                let got = DropShape::Series(s.clone()).intersect(o, d, inside);
                let want = marched.intersect(o, d, inside);
                match (got, want) {
                    (Some(g), Some(w)) => {
                        assert!(
                            (g.t - w.t).abs() <= 1e-11 * s.r_max_um,
                            "{a} mm, inside {inside}: {} vs {}",
                            g.t,
                            w.t
                        );
                        // The normal from Newton's last evaluation is the hit point's.
                        let n = s.normal(g.point);
                        assert!(norm(sub(g.normal, n)) < 1e-12, "{:?} vs {n:?}", g.normal);
                    }
                    (None, None) => {}
                    (g, w) => panic!("{a} mm, inside {inside}: {g:?} vs {w:?}"),
                }
            }
            assert!(fast > rays / 2, "{a} mm: {fast} of {rays} on the fast path");
        }
    }

    /// The spheroids bound the drop (checked on 10⁵ profile points, finer than their fit), and
    /// the march that skips the samples they decide gives the bracket, hence the hit, of the
    /// march that evaluates every sample, bit for bit: rays from outside through the bounding
    /// sphere and rays from surface points inwards, on drops of 1, 2 and 3 mm.
    #[test]
    fn the_march_skips_only_samples_that_cannot_cross() {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for a in [1.0, 2.0, 3.0] {
            let s = CosineSeries::beard_chuang(a);
            for k in 0..=100_000 {
                let th = PI * k as f64 / 100_000.0;
                let r = s.r_at(th);
                let p = [r * th.sin(), 0.0, -r * th.cos()];
                assert!(
                    s.outer.level(p) < 1.0 && s.inner.level(p) > 1.0,
                    "{a} mm, θ {th}"
                );
            }
            let (mut crossed, mut rays) = (0, 0);
            while rays < 4000 {
                let inside = rays % 2 == 1;
                let Some((o, d)) = random_ray(&s, &mut uniform, inside) else {
                    continue;
                };
                let rb = s.r_max_um;
                let b = dot(o, d);
                let disc = b * b - (dot(o, o) - rb * rb);
                if disc <= 0.0 {
                    continue;
                }
                let chord = if inside {
                    (0.0, -b + disc.sqrt())
                } else {
                    (-b - disc.sqrt(), -b + disc.sqrt())
                };
                let bracket = march(&s, o, d, inside, chord);
                assert_eq!(
                    bracket,
                    march_evaluating_every_sample(&s, o, d, inside, chord),
                    "{a} mm, o {o:?}, d {d:?}, inside {inside}"
                );
                crossed += usize::from(bracket.is_some());
                rays += 1;
            }
            assert!(
                crossed > rays / 2,
                "{a} mm: {crossed} of {rays} rays crossed"
            );
        }
    }

    #[test]
    fn beard_chuang_volume_and_axis_ratios_match_references() {
        // Beard & Chuang 1987 (Table 3.1 of Sadeghi 2012), evaluated independently: volume
        // conserved to 1e-4; axis ratios 0.9273 / 0.8529 / 0.7766 / 0.7059 / 0.6404 at
        // 1.0 / 1.5 / 2.0 / 2.5 / 3.0 mm; r(0)/a and r(π)/a.
        let rows = [
            (1.0, 0.9273, 0.9293, 0.9695),
            (1.5, 0.8529, 0.8606, 0.9336),
            (2.0, 0.7766, 0.7932, 0.8920),
            (2.5, 0.7059, 0.7330, 0.8480),
            (3.0, 0.6404, 0.6779, 0.8025),
        ];
        for (a, ratio, r0, rpi) in rows {
            let s = CosineSeries::beard_chuang(a);
            let v = s.volume_um3();
            let v_sphere = 4.0 / 3.0 * PI * (a * 1e3f64).powi(3);
            assert!(
                (v / v_sphere - 1.0).abs() < 5e-4,
                "a={a}: volume {}",
                v / v_sphere
            );
            assert!(
                (s.axis_ratio() - ratio).abs() < 6e-4,
                "a={a}: {}",
                s.axis_ratio()
            );
            assert!((s.r_at(0.0) / (a * 1e3) - r0).abs() < 1e-4);
            assert!((s.r_at(PI) / (a * 1e3) - rpi).abs() < 1e-4);
        }
        // Interpolation linear in a between the sphere at 0.4 mm and the 1 mm row:
        // c(0.5) = c(1.0)/6.
        let c = beard_chuang_coefficients(0.5);
        assert!((c[2] - (-0.0376 / 6.0)).abs() < 1e-12);
        assert_eq!(beard_chuang_coefficients(0.3), [0.0; 8]);
        assert_eq!(beard_chuang_coefficients(4.0), BEARD_CHUANG_TABLE_3_1[5].1);
    }

    #[test]
    fn series_normal_is_gradient_of_implicit_function() {
        let s = CosineSeries::beard_chuang(2.5);
        for k in 0..=20 {
            let th = PI * k as f64 / 20.0;
            let phi = 0.3 * k as f64;
            let r = s.r_at(th);
            let p = [
                r * th.sin() * phi.cos(),
                r * th.sin() * phi.sin(),
                -r * th.cos(),
            ];
            let n = s.normal(p);
            let h = 1e-4;
            let grad = [
                s.g(add(p, [h, 0.0, 0.0])) - s.g(sub(p, [h, 0.0, 0.0])),
                s.g(add(p, [0.0, h, 0.0])) - s.g(sub(p, [0.0, h, 0.0])),
                s.g(add(p, [0.0, 0.0, h])) - s.g(sub(p, [0.0, 0.0, h])),
            ];
            let gn = normalize(grad);
            assert!(dot(gn, n) > 1.0 - 1e-7, "θ={th}: {n:?} vs {gn:?}");
        }
    }

    /// The slope of `g` along a ray is its derivative (central differences), and the bracketed
    /// Newton iteration lands on the surface to 1e-9 µm where a bisection of the same bracket
    /// does.
    #[test]
    fn slope_along_the_ray_and_newton_roots() {
        let s = CosineSeries::beard_chuang(2.5);
        for k in 0..40 {
            let p = [
                300.0 * (k as f64).sin(),
                250.0 * (0.7 * k as f64).cos(),
                900.0 - 45.0 * k as f64,
            ];
            let d = normalize([0.3 - 0.02 * k as f64, -0.5, 0.8]);
            let (_, slope) = s.g_and_slope(p, d);
            let h = 1e-3;
            let fd = (s.g(add(p, scale(d, h))) - s.g(sub(p, scale(d, h)))) / (2.0 * h);
            assert!((slope - fd).abs() < 1e-6, "{slope} vs {fd}");
        }
        let o = [0.0, 0.0, 0.0];
        for k in 0..50 {
            let th = PI * (k as f64 + 0.5) / 50.0;
            let d = [th.sin(), 0.0, -th.cos()];
            let g_at = |t: f64| s.g(add(o, scale(d, t)));
            let (mut a, mut b) = (0.0, s.r_max_um * 1.01);
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if g_at(m) > 0.0 { b = m } else { a = m }
            }
            let t = newton_bracketed(
                |t| s.g_and_slope(add(o, scale(d, t)), d),
                0.0,
                g_at(0.0),
                s.r_max_um * 1.01,
                g_at(s.r_max_um * 1.01),
            );
            assert!(
                (t - 0.5 * (a + b)).abs() < 1e-9,
                "θ = {th}: {t} vs {}",
                0.5 * (a + b)
            );
        }
    }

    #[test]
    fn profile_table_fit_recovers_beard_chuang() {
        let bc = CosineSeries::beard_chuang(2.0);
        let th: Vec<f64> = (0..=90).map(|k| 2.0 * k as f64).collect();
        let r: Vec<f64> = th.iter().map(|t| bc.r_at(t.to_radians()) / 7.0).collect();
        let (fit, res) = CosineSeries::fit_table(2000.0, &th, &r).unwrap();
        assert!(res < 1e-9, "{res}");
        for k in 0..8 {
            assert!((fit.coeffs[k] - bc.coeffs[k]).abs() < 2e-4, "c{k}");
        }
    }

    #[test]
    fn every_entering_ray_exits_sphere_and_series() {
        // Rays on a fine grid including grazing ones and rays through the poles: each entering
        // ray finds an exit on the surface, on the far side.
        for shape in [
            DropShape::Sphere { radius_um: 1000.0 },
            DropShape::Series(CosineSeries::beard_chuang(3.0)),
        ] {
            for elev in [0.0f64, 0.4, std::f64::consts::FRAC_PI_2] {
                let (se, ce) = elev.sin_cos();
                let d = [-ce, 0.0, -se];
                let e1 = [-se, 0.0, ce];
                let e2 = [0.0, 1.0, 0.0];
                let (w1, w2) = shape.silhouette_half_extents(elev);
                let n = 201;
                let mut entered = 0;
                for i in 0..n {
                    for j in 0..n {
                        let u = -w1 + 2.0 * w1 * i as f64 / (n - 1) as f64;
                        let v = -w2 + 2.0 * w2 * j as f64 / (n - 1) as f64;
                        let o = add(add(scale(e1, u), scale(e2, v)), scale(d, -5000.0));
                        let Some(h) = shape.intersect(o, d, false) else {
                            continue;
                        };
                        entered += 1;
                        let cos_i = -dot(d, h.normal);
                        assert!(cos_i >= -1e-9, "entry on the back face");
                        // Refract and find the exit.
                        let eta = 1.0 / 1.333;
                        let ci = cos_i.max(0.0);
                        let ct = (1.0 - eta * eta * (1.0 - ci * ci)).sqrt();
                        let dt = normalize(add(scale(d, eta), scale(h.normal, eta * ci - ct)));
                        let ex = shape.intersect(h.point, dt, true).expect("leak");
                        let g = match &shape {
                            DropShape::Sphere { radius_um } => norm(ex.point) - radius_um,
                            DropShape::Series(s) => s.g(ex.point),
                        };
                        assert!(g.abs() < 1e-6, "exit off the surface by {g}");
                    }
                }
                assert!(entered > n * n / 2);
            }
        }
    }
}
