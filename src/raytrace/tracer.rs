//! The patch-based wave-optics ray tracer (Sadeghi 2012, §3.4). Labels RT-n refer to the
//! decisions in `docs/decisions.md`.
//!
//! **Frame.** Drop axis `z` up; sun at elevation `e` in the `+x` half-space, so the incident
//! propagation direction is `d = (−cos e, 0, −sin e)`. Outgoing directions are given by the polar
//! angle θ from `d` (0 = forward) and the azimuth φ about `d`, measured from
//! `e1 = (−sin e, 0, cos e)` (in the vertical plane containing `d`, pointing "up") towards
//! `e2 = y`: `r = cos θ d + sin θ (cos φ e1 + sin φ e2)`; `(e1, e2, d)` is right-handed.
//!
//! **Steps.** An `N×N` grid of parallel rays covers the silhouette: mapped onto it and refined
//! towards its edge ([`RayGridLayout::Silhouette`], RT-31, the default) or evenly over its
//! bounding box centred on the projected drop centre ([`RayGridLayout::Square`], RT-11, the
//! thesis's); each ray carries two 3-D complex field vectors
//! (inputs polarised along `e1` and `e2`, unit amplitude; RT-5, RT-6) and its optical path
//! from the emitting plane at distance `D` from the centre. At each surface hit the fields are
//! split into s/p components of the plane of incidence (`s = d × N`, `p = s × k` for every
//! wave) and multiplied by the shared complex Fresnel amplitudes (Born–Wolf signs), with
//! power-consistent transmission amplitudes (exact for spheres too, where the factor cancels).
//! Order `p` leaves after `p` internal hits; its path ends on the plane through the point
//! `D·ω` perpendicular to the outgoing direction `ω`.
//!
//! **Patches.** Grid-adjacent outgoing rays of one order form cells, split into two triangles
//! (RT-7: folded patches and caustics are handled by using each triangle's |solid angle|); a
//! triangle carries the flux through its own area in the emitting plane.
//! Triangles with a missing corner (silhouette miss, total internal reflection) are discarded
//! (RT-8; the discarded flux is reported). For every table direction `r` covered by a
//! triangle, the corner fields and paths are interpolated with the gnomonic (spherical
//! barycentric) weights, which equal linear interpolation over the emitting-plane triangle in the
//! limit, and the contribution `sqrt(a/s) · E(r) · exp(i(k l(r) − (π/2) f))` is summed
//! coherently. `f = [∇l · ∇b > 0]` on the triangle (b = u² + v²): the longer-path branch is π/2
//! behind (RT-1; the literal focal-line rule of the thesis is half a fringe off for the primary
//! bow). The point-in-triangle test uses exact orientation determinants, so adjacent
//! triangles partition the sphere without gaps or double counting.
//!
//! **Acceleration / parallelism.** Rays are traced in bands of grid rows (rayon over rows);
//! each band's triangles are binned by block of polar table rows (a CSR binning grid over
//! direction) and rasterised with rayon over blocks, so memory stays bounded by the band and the
//! table.

use super::ray_density::{RadialProfile, RingTable};
use super::shape::{DropShape, LANES, add, cross, dot, normalize, scale, sub};
use crate::optics::fresnel::{fresnel_amplitudes_real, fresnel_power_consistent_real};
use crate::table::interp::interp1_uniform;
use num_complex::{Complex32, Complex64};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

type CVec = [Complex64; 3];

/// Tracer configuration for one wavelength and one incidence direction.
#[derive(Debug, Clone)]
pub struct TraceConfig {
    /// Rays per side of the square ray grid.
    pub rays: usize,
    /// Highest order traced (p = 0..=max_order).
    pub max_order: usize,
    /// Sun elevation above the horizon (radians); the drop axis is vertical.
    pub sun_elevation_rad: f64,
    /// Vacuum wavelength (nm).
    pub wavelength_nm: f64,
    /// Relative refractive index of the drop.
    pub n: f64,
    /// Where the `rays × rays` grid puts its rays in the emitting plane.
    pub ray_grid: RayGridLayout,
}

/// Layout of the `N × N` ray grid in the emitting plane (decision RT-31).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RayGridLayout {
    /// Evenly spaced over the silhouette's bounding box (Sadeghi 2012): ≈ π/4 of the rays hit a
    /// round drop, and the rays' spacing is the same at the silhouette's edge as at its centre.
    #[default]
    Square,
    /// The index square mapped onto the silhouette: Shirley & Chiu's (1997) concentric
    /// equal-area map of the square onto the disc gives each index ring `s = max(|ξ1|, |ξ2|)` an
    /// angle ψ along it, and the ring lands at `ρ = R(ψ) sin(π s / 2)`, where `R(ψ)` is the
    /// silhouette's radius towards ψ (exact for spheres, bisected on hits for other shapes, in
    /// 1024 directions, linear between them). Every ray hits, the outermost ring follows the silhouette, and the
    /// radial spacing falls as `cos(π s / 2)` towards the edge: the rays near grazing incidence
    /// (where the outer branches of p ≥ 2 come from) are ≈ √N-fold denser than on the square
    /// grid, the centre (π/2)² ≈ 2.5× sparser in area. Each ray's quadrature weight is the map's
    /// Jacobian; each triangle carries the flux of its own area.
    Silhouette,
    /// The silhouette grid with its rings warped towards the impact parameters that feed the
    /// bows (decision RT-40): ring `s` lands at `ρ = R(ψ) b(s)`, where `s(b)` gives half of the
    /// rings the `silhouette` layout's `(2/π) asin b` and half Gaussian bands about the
    /// equal-volume sphere's primary and secondary rainbow rays
    /// ([`super::ray_density::RadialProfile::bows`]). The rings at the primary's rainbow ray are
    /// 2.4× denser than on the `silhouette` grid of the same ray count and the centre's about
    /// half as dense; weights and patch areas as for `silhouette`.
    SilhouetteBows,
}

impl RayGridLayout {
    /// Whether the layout maps the index square onto the silhouette (every ray hits).
    pub fn on_silhouette(self) -> bool {
        matches!(
            self,
            RayGridLayout::Silhouette | RayGridLayout::SilhouetteBows
        )
    }
}

/// Uniform direction grid: polar θ_j = j·Δθ over [0°, 180°], azimuth φ_k = k·Δφ over [0°, 360°).
#[derive(Debug, Clone, Copy)]
pub struct DirectionGrid {
    pub n_polar: usize,
    pub n_azimuth: usize,
}

impl DirectionGrid {
    pub fn polar_step(&self) -> f64 {
        PI / (self.n_polar - 1) as f64
    }
    pub fn azimuth_step(&self) -> f64 {
        2.0 * PI / self.n_azimuth as f64
    }
}

/// Coherent fields accumulated on a direction grid, per order: for each pixel and order the
/// four complex amplitudes `[a⊥, a∥, b⊥, b∥]` (inputs `a` ∥ e1, `b` ∥ e2), in sqrt(µm²/sr).
#[derive(Debug, Clone)]
pub struct FieldGrid {
    pub grid: DirectionGrid,
    pub orders: usize,
    /// Polar rows per band of [`FieldGrid::bands`].
    pub band_rows: usize,
    /// Bands of `band_rows` polar rows (the last may be shorter), each `[order][polar][azimuth][4]`
    /// (order-major, so each order's rows are contiguous: an order's rows outside its
    /// [`FieldGrid::reach`] are never written, and their pages are never touched), so a
    /// consumer can release the accumulators band by band.
    pub bands: Vec<Vec<Complex32>>,
    /// Polar rows `(first, last)` the triangles of each order may cover (`None`: no triangle);
    /// the order's accumulators are zero outside.
    pub reach: Vec<Option<(usize, usize)>>,
    /// Azimuth columns held per polar row: `grid.n_azimuth`, or `n_azimuth / 2 + 1` (columns
    /// 0..=na/2, φ from 0° to 180°) for a trace of the mirror half ([`trace_fields_mirror_half`]),
    /// whose column `na − k` is the mirror image of column `k`.
    pub n_columns: usize,
    /// Flux per order that left the drop (µm², ray-based: Σ cell area × |ε|²).
    pub order_cross_section_um2: Vec<f64>,
    /// Flux per order carried by the complete, non-degenerate triangles (patches), including those
    /// that span no pixel centre (µm²).
    pub patch_cross_section_um2: Vec<f64>,
    /// Projected area of the drop (µm², rays that hit × cell area).
    pub projected_area_um2: f64,
    /// Number of rays traced.
    pub rays_traced: usize,
}

/// Bytes of accumulators per band of [`FieldGrid::bands`] (at least one polar row): above
/// glibc's largest mmap threshold (32 MiB), so a band is mapped on demand (pages an order never
/// reaches stay unmapped) and a released band returns to the system at once.
const FIELD_BAND_BYTES: usize = 64 << 20;

/// `n` zero accumulators from the allocator's zeroed memory. `vec![Complex32::new(0.0, 0.0); n]`
/// writes every value (the zero test of `vec!` does not see through the struct), which faults
/// in and clears every page; zeroed memory of a band's size is mapped on demand instead, so the
/// pages of rows an order never reaches are never touched.
fn zeroed_accumulators(n: usize) -> Vec<Complex32> {
    if n == 0 {
        return Vec::new();
    }
    let layout = std::alloc::Layout::array::<Complex32>(n).expect("accumulator size fits isize");
    // SAFETY: the layout has a non-zero size; `Complex32` is `repr(C)` of two `f32`, for which
    // all-zero bytes are the value 0 + 0i; the pointer comes from the global allocator with
    // exactly this layout, as `Vec::from_raw_parts` requires (length = capacity = n).
    unsafe {
        let p = std::alloc::alloc_zeroed(layout).cast::<Complex32>();
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Vec::from_raw_parts(p, n, n)
    }
}

/// Map the pages of accumulators `acc`, which nothing has written yet (all zero), as written
/// memory before the rasteriser adds to them. The rasteriser's first access to a page is a
/// read-modify-write: the read maps the shared zero page and the write then copies it, which
/// flushes the other threads' TLB entries by interrupt (a third of the build's kernel time);
/// populating the rows of an order when its reach grows maps each page once, in one call per
/// row. Values are unchanged (zero).
fn fault_in(acc: &mut [Complex32]) {
    const PAGE: usize = 4096;
    if acc.is_empty() {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        let p = acc.as_mut_ptr() as usize;
        let start = p.next_multiple_of(PAGE);
        let end = (p + std::mem::size_of_val(acc)) / PAGE * PAGE;
        // SAFETY: `start..end` lies inside `acc`, which we borrow mutably; populating writable
        // pages changes no contents (the memory is zero either way).
        if end > start
            && unsafe {
                libc::madvise(
                    start as *mut libc::c_void,
                    end - start,
                    libc::MADV_POPULATE_WRITE,
                )
            } == 0
        {
            // The partial pages at both ends.
            let last = acc.len() - 1;
            acc[0] = Complex32::new(0.0, 0.0);
            acc[last] = Complex32::new(0.0, 0.0);
            return;
        }
    }
    // Elsewhere (or on a kernel without MADV_POPULATE_WRITE): write one zero per page.
    let step = PAGE / std::mem::size_of::<Complex32>();
    for i in (0..acc.len()).step_by(step).chain([acc.len() - 1]) {
        acc[i] = Complex32::new(0.0, 0.0);
    }
}

/// Four zero accumulators: a pixel of an order outside its reach.
const ZERO_PIXEL: [Complex32; 4] = [Complex32::new(0.0, 0.0); 4];

/// `(i_perp, i_par)` dσ/dΩ of one pixel's accumulators `px` (one `[4]` per order, in order),
/// coherent over orders, with each order's unpolarised dσ/dΩ written to `per` (length `orders`);
/// allocation-free.
pub fn pixel_intensities<'a>(
    px: impl IntoIterator<Item = &'a [Complex32]>,
    per: &mut [f64],
) -> (f64, f64) {
    let mut tot = [Complex64::new(0.0, 0.0); 4];
    for (o, c) in px.into_iter().enumerate() {
        let mut s = 0.0;
        for (t, z) in tot.iter_mut().zip(c) {
            let z = Complex64::new(z.re as f64, z.im as f64);
            *t += z;
            s += z.norm_sqr();
        }
        per[o] = 0.5 * s;
    }
    (
        tot[0].norm_sqr() + tot[2].norm_sqr(),
        tot[1].norm_sqr() + tot[3].norm_sqr(),
    )
}

impl FieldGrid {
    /// Values per polar row of one order's accumulators.
    pub fn order_row_len(&self) -> usize {
        self.n_columns * 4
    }

    /// Whether order `o` may be non-zero on polar row `j`.
    pub fn reaches(&self, o: usize, j: usize) -> bool {
        self.reach[o].is_some_and(|(a, b)| (a..=b).contains(&j))
    }

    /// The accumulators of order `o` on polar row `j` (`[azimuth][4]`), or `None` outside the
    /// order's reach (all zero).
    pub fn order_row(&self, o: usize, j: usize) -> Option<&[Complex32]> {
        if !self.reaches(o, j) {
            return None;
        }
        let (b, jj) = (j / self.band_rows, j % self.band_rows);
        let band = &self.bands[b];
        let rl = self.order_row_len();
        let block = band.len() / self.orders;
        let base = o * block + jj * rl;
        Some(&band[base..base + rl])
    }

    /// The accumulators `[a⊥, a∥, b⊥, b∥]` of order `o` at pixel (j, k).
    pub fn order_pixel(&self, o: usize, j: usize, k: usize) -> &[Complex32] {
        match self.order_row(o, j) {
            Some(row) => &row[k * 4..k * 4 + 4],
            None => &ZERO_PIXEL,
        }
    }

    /// `(i_perp, i_par)` dσ/dΩ at pixel (j, k), coherent over orders, with each order's
    /// unpolarised dσ/dΩ written to `per` (length `orders`); allocation-free.
    pub fn intensities_into(&self, j: usize, k: usize, per: &mut [f64]) -> (f64, f64) {
        pixel_intensities((0..self.orders).map(|o| self.order_pixel(o, j, k)), per)
    }

    /// `(i_perp, i_par, per-order unpolarised)` dσ/dΩ at pixel (j, k), coherent over orders.
    pub fn intensities(&self, j: usize, k: usize) -> (f64, f64, Vec<f64>) {
        let mut per = vec![0.0; self.orders];
        let (a, b) = self.intensities_into(j, k, &mut per);
        (a, b, per)
    }

    /// Number of accumulator values (all bands).
    pub fn len(&self) -> usize {
        self.bands.iter().map(Vec::len).sum()
    }

    /// Whether the grid has no accumulators.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[derive(Debug, Clone, Copy)]
struct RayOut {
    dir: [f64; 3],
    /// Polar angle and azimuth of `dir` in the table frame.
    pa: (f64, f64),
    /// sin of the polar angle (each ray is a corner of up to six triangles of its order).
    sin_polar: f64,
    /// Outgoing fields of the incident polarisations e1 and e2, traced in f64 and stored in
    /// f32, the precision of the accumulators they feed (relative rounding ≤ 6e-8; the phase
    /// k·l stays in f64). A ray takes 120 instead of 168 bytes, and the rasteriser, which
    /// reads three corner rays per pixel test and waits on memory, ran the seed grid ≈ 7 %
    /// faster (`raytrace_perf -- seed 1`: 17.7 s against 19.0 s).
    ea: [Complex32; 3],
    eb: [Complex32; 3],
    l: f64,
    /// Mean of the two inputs' |E|² it carries ([`ray_flux`]; zero for an invalid ray).
    flux: f64,
    valid: bool,
}

const INVALID: RayOut = RayOut {
    dir: [0.0; 3],
    pa: (0.0, 0.0),
    sin_polar: 0.0,
    ea: [Complex32::new(0.0, 0.0); 3],
    eb: [Complex32::new(0.0, 0.0); 3],
    l: 0.0,
    flux: 0.0,
    valid: false,
};

impl RayOut {
    /// A valid outgoing ray along `dir` with fields `ea`, `eb` and optical path `l`.
    fn new(fr: &Frame, dir: [f64; 3], ea: CVec, eb: CVec, l: f64) -> Self {
        let (pa, sin_polar) = polar_azimuth(fr, dir);
        RayOut {
            dir,
            pa,
            sin_polar,
            flux: ray_flux(&ea, &eb),
            ea: ea.map(|z| Complex32::new(z.re as f32, z.im as f32)),
            eb: eb.map(|z| Complex32::new(z.re as f32, z.im as f32)),
            l,
            valid: true,
        }
    }
}

struct Frame {
    d: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
}

fn frame(sun_elevation_rad: f64) -> Frame {
    let (se, ce) = sun_elevation_rad.sin_cos();
    Frame {
        d: [-ce, 0.0, -se],
        e1: [-se, 0.0, ce],
        e2: [0.0, 1.0, 0.0],
    }
}

#[inline]
fn cdot(e: &CVec, v: [f64; 3]) -> Complex64 {
    e[0] * v[0] + e[1] * v[1] + e[2] * v[2]
}

#[inline]
fn cfield(a: Complex64, u: [f64; 3], b: Complex64, v: [f64; 3]) -> CVec {
    [
        a * u[0] + b * v[0],
        a * u[1] + b * v[1],
        a * u[2] + b * v[2],
    ]
}

/// Result of one interface interaction.
struct Split {
    refl_dir: [f64; 3],
    refl: (CVec, CVec),
    trans: Option<([f64; 3], CVec, CVec)>,
}

/// Interaction of a ray travelling along `d` with the interface of outward normal `normal`,
/// from index `eta1` into `eta2`.
fn interact(d: [f64; 3], normal: [f64; 3], eta1: f64, eta2: f64, ea: &CVec, eb: &CVec) -> Split {
    // Normal facing the incident side.
    let nf = if dot(d, normal) < 0.0 {
        normal
    } else {
        scale(normal, -1.0)
    };
    let cos_i = (-dot(d, nf)).clamp(0.0, 1.0);
    let mut s = cross(d, nf);
    let sl = dot(s, s).sqrt();
    if sl < 1e-12 {
        // Normal incidence: any direction perpendicular to d.
        let helper = if d[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        s = normalize(cross(d, helper));
    } else {
        s = scale(s, 1.0 / sl);
    }
    let p_in = cross(s, d);
    let refl_dir = normalize(add(d, scale(nf, 2.0 * cos_i)));
    let p_r = cross(s, refl_dir);
    let split = |e: &CVec| (cdot(e, s), cdot(e, p_in));
    let (as_, ap) = split(ea);
    let (bs, bp) = split(eb);
    let Some(f) = fresnel_power_consistent_real(eta1, eta2, cos_i) else {
        // Total internal reflection: complex reflection amplitudes, no transmitted ray.
        let f = fresnel_amplitudes_real(eta1, eta2, cos_i);
        return Split {
            refl_dir,
            refl: (
                cfield(f.r_s * as_, s, f.r_p * ap, p_r),
                cfield(f.r_s * bs, s, f.r_p * bp, p_r),
            ),
            trans: None,
        };
    };
    // Below the critical angle every amplitude is real: complex × real products.
    let (r_s, r_p) = (f.r_s, f.r_p);
    let refl = (
        cfield(as_ * r_s, s, ap * r_p, p_r),
        cfield(bs * r_s, s, bp * r_p, p_r),
    );
    let eta = eta1 / eta2;
    let cos_t = f.cos_theta_t;
    let td = normalize(add(scale(d, eta), scale(nf, eta * cos_i - cos_t)));
    let p_t = cross(s, td);
    let (ts, tp) = (f.t_s, f.t_p);
    let trans = Some((
        td,
        cfield(as_ * ts, s, ap * tp, p_t),
        cfield(bs * ts, s, bp * tp, p_t),
    ));
    Split {
        refl_dir,
        refl,
        trans,
    }
}

/// Trace one ray of the grid `g` starting at emitting-plane coordinates (u, v) through `shape`
/// of relative index `n`; returns the outgoing ray of every order (invalid where absent) in
/// `out` and whether the ray hit the drop.
fn trace_ray(
    g: &RayGrid,
    shape: &DropShape,
    n: f64,
    (u, v): (f64, f64),
    out: &mut [RayOut],
) -> bool {
    let mut lanes = [None; LANES];
    lanes[0] = Some((u, v));
    trace_rays(g, shape, n, lanes, out)[0]
}

/// A ray inside the drop between two crossings of its surface.
#[derive(Clone, Copy)]
struct InsideRay {
    pos: [f64; 3],
    dir: [f64; 3],
    fa: CVec,
    fb: CVec,
    /// Optical path so far (µm).
    l: f64,
}

/// [`trace_ray`] of the rays at the emitting-plane coordinates of `uv` (`None` lanes absent)
/// at once, each ray bit for bit as alone: `out` holds `g.orders` slots per present lane, in
/// order. Their crossings of the surface are found together ([`DropShape::intersect_lanes`]),
/// one order after the other.
fn trace_rays(
    g: &RayGrid,
    shape: &DropShape,
    n: f64,
    uv: [Option<(f64, f64)>; LANES],
    out: &mut [RayOut],
) -> [bool; LANES] {
    let (fr, dist, orders) = (&g.fr, g.dist, g.orders);
    out.fill(INVALID);
    let entering = uv.map(|p| {
        p.map(|(u, v)| {
            let origin = add(add(scale(fr.e1, u), scale(fr.e2, v)), scale(fr.d, -dist));
            (origin, fr.d)
        })
    });
    let one = Complex64::new(1.0, 0.0);
    let ea: CVec = [one * fr.e1[0], one * fr.e1[1], one * fr.e1[2]];
    let eb: CVec = [one * fr.e2[0], one * fr.e2[1], one * fr.e2[2]];
    let mut inside: [Option<InsideRay>; LANES] = [None; LANES];
    let hits = shape.intersect_lanes(entering, false);
    for ((slots, hit), ray) in out.chunks_mut(orders).zip(hits).zip(&mut inside) {
        let Some(h) = hit else { continue };
        let sp = interact(fr.d, h.normal, 1.0, n, &ea, &eb);
        let l = h.t;
        slots[0] = RayOut::new(
            fr,
            sp.refl_dir,
            sp.refl.0,
            sp.refl.1,
            l + dist - dot(h.point, sp.refl_dir),
        );
        *ray = sp.trans.map(|(dir, fa, fb)| InsideRay {
            pos: h.point,
            dir,
            fa,
            fb,
            l,
        });
    }
    for order in 1..orders {
        let hits = shape.intersect_lanes(inside.map(|r| r.map(|r| (r.pos, r.dir))), true);
        for ((slots, hit), ray) in out.chunks_mut(orders).zip(hits).zip(&mut inside) {
            let Some(r) = ray else { continue };
            let Some(hh) = hit else {
                *ray = None;
                continue;
            };
            r.l += n * hh.t;
            r.pos = hh.point;
            let sp = interact(r.dir, hh.normal, n, 1.0, &r.fa, &r.fb);
            if let Some((td, ta, tb)) = sp.trans {
                slots[order] = RayOut::new(fr, td, ta, tb, r.l + dist - dot(r.pos, td));
            }
            r.dir = sp.refl_dir;
            r.fa = sp.refl.0;
            r.fb = sp.refl.1;
        }
    }
    hits.map(|h| h.is_some())
}

/// A triangle ready for rasterisation.
#[derive(Clone, Copy)]
struct Tri {
    order: u8,
    corners: [u32; 3],
    /// Edge normals v_{i} × v_{i+1} and tie-break flags.
    edges: [[f64; 3]; 3],
    ties: [bool; 3],
    amp: f64,
    phase0: f64,
    j0: u32,
    j1: u32,
    /// Azimuth index range (may exceed n_azimuth; wrap modulo). `full` covers every column.
    k0: i64,
    k1: i64,
    full: bool,
}

#[inline]
fn lex_less(a: [f64; 3], b: [f64; 3]) -> bool {
    (a[0], a[1], a[2]) < (b[0], b[1], b[2])
}

/// Polar angle and azimuth of the unit direction `w` in the table frame, and the sine of the
/// polar angle (from its cosine, `(1 − c)(1 + c)` keeping the relative precision near the poles;
/// it only widens the triangles' row margins, which are conservative by far more than its last
/// bits).
fn polar_azimuth(fr: &Frame, w: [f64; 3]) -> ((f64, f64), f64) {
    let c = dot(w, fr.d).clamp(-1.0, 1.0);
    (
        (c.acos(), dot(w, fr.e2).atan2(dot(w, fr.e1))),
        ((1.0 - c) * (1.0 + c)).sqrt(),
    )
}

/// Inside test with exact-orientation tie-break (see module docs).
#[inline]
#[allow(clippy::needless_range_loop)]
fn inside(t: &Tri, r: [f64; 3]) -> Option<[f64; 3]> {
    let mut w = [0.0; 3];
    for e in 0..3 {
        let s = dot(t.edges[e], r);
        if s < 0.0 || (s == 0.0 && !t.ties[e]) {
            return None;
        }
        w[e] = s;
    }
    // Edge e (v_e → v_{e+1}) determinant is the weight of the opposite vertex v_{e+2}.
    let sum = w[0] + w[1] + w[2];
    if sum <= 0.0 {
        return None;
    }
    Some([w[1] / sum, w[2] / sum, w[0] / sum])
}

/// The emitting-plane ray grid and the quantities shared by every step of one trace.
struct RayGrid {
    fr: Frame,
    layout: RayGridLayout,
    /// `SilhouetteBows` layout: each ring's impact parameter and slope (empty otherwise).
    rings: Option<RingTable>,
    /// Silhouette layouts: the silhouette's radius (µm) towards ψ_m = 2π m / M, m = 0..=M
    /// (the last repeats the first); empty for `Square`.
    silhouette_um: Vec<f64>,
    /// Rays per side.
    nr: usize,
    orders: usize,
    /// Lower corner and spacing of the grid in (e1, e2) coordinates (µm).
    w1: f64,
    w2: f64,
    h1: f64,
    h2: f64,
    /// Area of one grid cell (µm²).
    cell: f64,
    /// Distance of the emitting plane from the drop centre (µm).
    dist: f64,
    k_wave: f64,
    /// Reference path removed from every phase (µm).
    l_ref: f64,
}

/// Rays traced per band, summed over orders: bounds the band's memory (RayOut ≈ 150 bytes).
const RAYS_PER_BAND: usize = 200_000;

impl RayGrid {
    fn new(shape: &DropShape, cfg: &TraceConfig) -> Self {
        let nr = cfg.rays.max(2);
        let (w1, w2) = shape.silhouette_half_extents(cfg.sun_elevation_rad);
        let h1 = 2.0 * w1 / (nr - 1) as f64;
        let h2 = 2.0 * w2 / (nr - 1) as f64;
        let dist = 2.0 * shape.bounding_radius_um() + 1.0;
        let fr = frame(cfg.sun_elevation_rad);
        let silhouette_um = if cfg.ray_grid.on_silhouette() {
            silhouette_radii(shape, &fr, dist, w1.hypot(w2))
        } else {
            Vec::new()
        };
        let rings = (cfg.ray_grid == RayGridLayout::SilhouetteBows)
            .then(|| RingTable::new(&RadialProfile::bows(cfg.n), nr));
        RayGrid {
            fr,
            rings,
            layout: cfg.ray_grid,
            silhouette_um,
            nr,
            orders: cfg.max_order + 1,
            w1,
            w2,
            h1,
            h2,
            cell: h1 * h2,
            dist,
            k_wave: 2.0 * PI / (cfg.wavelength_nm * 1e-3),
            l_ref: 2.0 * dist,
        }
    }
    fn u_at(&self, i: usize) -> f64 {
        -self.w1 + self.h1 * i as f64
    }
    fn v_at(&self, j: usize) -> f64 {
        -self.w2 + self.h2 * j as f64
    }

    /// Index-square coordinates of grid point (i, j) in [−1, 1]².
    fn unit_square(&self, i: usize, j: usize) -> (f64, f64) {
        let h = 2.0 / (self.nr - 1) as f64;
        (-1.0 + h * i as f64, -1.0 + h * j as f64)
    }

    /// The silhouette's radius (µm) towards ψ (radians), interpolated linearly in ψ.
    fn silhouette_at(&self, psi: f64) -> f64 {
        let step = 2.0 * PI / (self.silhouette_um.len() - 1) as f64;
        interp1_uniform(&self.silhouette_um, 0.0, step, psi.rem_euclid(2.0 * PI))
    }

    /// Grid point (i, j): its emitting-plane coordinates (u along e1, v along e2; µm) and its
    /// quadrature weight (µm²): the cell area for `Square`, the map's Jacobian times the index
    /// cell for `Silhouette` (zero on the outer ring).
    fn point_and_weight(&self, i: usize, j: usize) -> (f64, f64, f64) {
        match self.layout {
            RayGridLayout::Square => (self.u_at(i), self.v_at(j), self.cell),
            RayGridLayout::Silhouette => {
                let h = 2.0 / (self.nr - 1) as f64;
                let (x, y) = self.unit_square(i, j);
                let (s, psi) = concentric(x, y);
                let r = self.silhouette_at(psi);
                let q = 0.5 * PI * s;
                let (sq, cq) = q.sin_cos();
                let rho = r * sq;
                let (sp, cp) = psi.sin_cos();
                // ρ ∂ρ/∂s with ρ = R sin(πs/2), over s (the concentric map's dψ ds = π/(4s) dξ²).
                let g_dg_over_s = if s > 0.0 {
                    sq * 0.5 * PI * cq / s
                } else {
                    0.25 * PI * PI
                };
                (rho * cp, rho * sp, r * r * g_dg_over_s * 0.25 * PI * h * h)
            }
            RayGridLayout::SilhouetteBows => self.warped_point_and_weight(i, j),
        }
    }

    /// [`RayGrid::point_and_weight`] of the `SilhouetteBows` layout: ring `m` of the index
    /// square (s = m/(N − 1)) at `ρ = R(ψ) b_m`, weight `R² b b′(s)/s · (π/4) h²` (the
    /// concentric map's `ds dψ = π/(4s) dξ²`; `b′(0)²` at the centre).
    fn warped_point_and_weight(&self, i: usize, j: usize) -> (f64, f64, f64) {
        let rings = self
            .rings
            .as_ref()
            .expect("ring table of the warped layout");
        let last = self.nr - 1;
        let m = (2 * i).abs_diff(last).max((2 * j).abs_diff(last));
        let h = 2.0 / last as f64;
        let (x, y) = self.unit_square(i, j);
        let (_, psi) = concentric(x, y);
        let r = self.silhouette_at(psi);
        let (b, slope) = rings.ring(m);
        let s = m as f64 / last as f64;
        let b_db_over_s = if m > 0 { b * slope / s } else { slope * slope };
        let rho = r * b;
        let (sp, cp) = psi.sin_cos();
        (rho * cp, rho * sp, r * r * b_db_over_s * 0.25 * PI * h * h)
    }
}

/// Shirley & Chiu's (1997) concentric map of the square [−1, 1]² onto the unit disc: the ring
/// `s = max(|x|, |y|)` and the angle ψ ∈ [0, 2π) along it (linear along each side of the ring),
/// rotated by [`CONCENTRIC_OFFSET_RAD`].
fn concentric(x: f64, y: f64) -> (f64, f64) {
    if x == 0.0 && y == 0.0 {
        return (0.0, 0.0);
    }
    let (s, psi) = if x.abs() >= y.abs() {
        (
            x.abs(),
            0.25 * PI * (y / x) + if x < 0.0 { PI } else { 0.0 },
        )
    } else {
        (
            y.abs(),
            0.5 * PI - 0.25 * PI * (x / y) + if y < 0.0 { PI } else { 0.0 },
        )
    };
    (s, (psi + CONCENTRIC_OFFSET_RAD).rem_euclid(2.0 * PI))
}

/// Rotation of the concentric map (radians). The map's derivative jumps on the square's
/// diagonals, and on a sphere the rays there leave at azimuths 45° + k·90°, where table columns
/// lie for most azimuth steps: the pixel centres then sit on triangle edges, and rounding can
/// give a pixel to both triangles (raw values up to 5.7× too high in single pixels, measured at
/// 600² rays, 0.0125° × 5°). A rotation that is no rational multiple of π keeps every such
/// edge off the columns of any azimuth grid that divides 360°.
const CONCENTRIC_OFFSET_RAD: f64 = 0.1;

/// Directions ψ in which [`silhouette_radii`] bisects the silhouette's radius.
const SILHOUETTE_DIRECTIONS: usize = 1024;

/// The silhouette's radius (µm) seen along the incident direction, towards ψ_m = 2π m / M in the
/// emitting plane (m = 0..=M, the last repeating the first): the largest ρ whose ray hits,
/// bisected between the centre and `rho_max` (silhouettes star-shaped about the projected
/// centre, as every drop shape here). Exact for spheres.
fn silhouette_radii(shape: &DropShape, fr: &Frame, dist: f64, rho_max: f64) -> Vec<f64> {
    let m = SILHOUETTE_DIRECTIONS;
    let mut r: Vec<f64> = match shape {
        DropShape::Sphere { radius_um } => vec![*radius_um; m],
        _ => (0..m)
            .into_par_iter()
            .map(|k| {
                let (sp, cp) = (2.0 * PI * k as f64 / m as f64).sin_cos();
                let hits = |rho: f64| {
                    let o = add(
                        add(scale(fr.e1, rho * cp), scale(fr.e2, rho * sp)),
                        scale(fr.d, -dist),
                    );
                    shape.intersect(o, fr.d, false).is_some()
                };
                let (mut lo, mut hi) = (0.0, rho_max * 1.01);
                for _ in 0..44 {
                    let mid = 0.5 * (lo + hi);
                    if hits(mid) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                lo
            })
            .collect(),
    };
    // The outermost ring 1 ppm inside: a ray exactly tangent to the surface reflects without
    // deviation onto the forward pole, where its triangles span every azimuth column and (with
    // the polar margin of a near-pole triangle) every polar row: at 600² rays on 14401 × 72
    // directions a tangent ring made 130× the pixel tests of the rest. The annulus left out
    // carries 2e-6 of the geometric cross-section.
    for x in &mut r {
        *x *= 1.0 - SILHOUETTE_INSET;
    }
    r.push(r[0]);
    r
}

/// Relative inset of the outermost ring of the silhouette grid (see [`silhouette_radii`]).
const SILHOUETTE_INSET: f64 = 1e-6;

/// One band of traced grid rows: per row, the outgoing rays `[column][order]`, the hit count
/// and per column the ray's emitting-plane point and quadrature weight `(u, v, w)` (µm, µm²).
type Band = Vec<BandRow>;

/// One traced grid row of a [`Band`].
type BandRow = (Vec<RayOut>, usize, Vec<(f64, f64, f64)>);

/// Mean of the two inputs' |E|² carried by an outgoing ray of fields `ea`, `eb`.
fn ray_flux(ea: &CVec, eb: &CVec) -> f64 {
    0.5 * (ea.iter().map(|z| z.norm_sqr()).sum::<f64>()
        + eb.iter().map(|z| z.norm_sqr()).sum::<f64>())
}

/// Step 1: trace grid rows `row0..=row1` into `band` (rayon over rows), whose row buffers are
/// reused from band to band (fresh ones cost a page fault per 4 KiB every band); a non-empty
/// `band` holds the previous band, which ended at row `row0`.
fn trace_band(
    g: &RayGrid,
    shape: &DropShape,
    cfg: &TraceConfig,
    row0: usize,
    row1: usize,
    band: &mut Band,
) {
    // The previous band's last row is this band's first: moved, not traced again.
    let reuse_first = !band.is_empty();
    if reuse_first {
        let last = band.len() - 1;
        band.swap(0, last);
    }
    band.resize_with(row1 - row0 + 1, || {
        (
            vec![INVALID; g.nr * g.orders],
            0,
            vec![(0.0, 0.0, 0.0); g.nr],
        )
    });
    band.par_iter_mut()
        .enumerate()
        .for_each(|(ri, (row, hit, points))| {
            if ri == 0 && reuse_first {
                return;
            }
            let i = row0 + ri;
            *hit = 0;
            let lanes = row
                .chunks_mut(g.orders * LANES)
                .zip(points.chunks_mut(LANES))
                .enumerate();
            for (c, (slots, pts)) in lanes {
                let mut uv = [None; LANES];
                for (k, (pt, lane)) in pts.iter_mut().zip(&mut uv).enumerate() {
                    *pt = g.point_and_weight(i, c * LANES + k);
                    *lane = Some((pt.0, pt.1));
                }
                let traced = trace_rays(g, shape, cfg.n, uv, slots);
                *hit += traced.iter().filter(|&&t| t).count();
            }
        });
}

/// Direction-space extent of a triangle: polar rows `j0..=j1`, azimuth columns `k0..=k1`
/// (wrapping modulo the azimuth count) or every column.
struct Extent {
    j0: u32,
    j1: u32,
    k0: i64,
    k1: i64,
    full: bool,
}

/// The table rows and columns a triangle with (oriented) vertices `v` and their (polar,
/// azimuth) `pa` may cover, or `None` when it falls between grid directions.
fn triangle_extent(
    fr: &Frame,
    grid: DirectionGrid,
    n_columns: usize,
    v: &[[f64; 3]; 3],
    edges: &[[f64; 3]; 3],
    pa: &[(f64, f64); 3],
    sin_polar: &[f64; 3],
) -> Option<Extent> {
    let (dth, dph) = (grid.polar_step(), grid.azimuth_step());
    let in_tri = |r: [f64; 3]| edges.iter().all(|e| dot(*e, r) >= 0.0);
    let (forward, backward) = (in_tri(fr.d), in_tri(scale(fr.d, -1.0)));
    let mut full = forward || backward;
    // Azimuth first: most triangles fall between two azimuth columns.
    let (mut k0, mut k1) = (0i64, grid.n_azimuth as i64 - 1);
    if !full {
        let ph0 = pa[0].1;
        let (mut lo, mut hi) = (ph0, ph0);
        for x in &pa[1..] {
            let dphi = wrap_angle(x.1 - ph0);
            lo = lo.min(ph0 + dphi);
            hi = hi.max(ph0 + dphi);
        }
        // The azimuth along a minor great-circle arc that avoids the pole is monotonic, so a
        // triangle not containing a pole spans exactly its vertices' azimuth range (unwrapping
        // is unambiguous below π/2).
        lo -= 1e-9;
        hi += 1e-9;
        if hi - lo >= 0.5 * PI {
            full = true;
        } else {
            k0 = ceil_i64(lo / dph);
            k1 = floor_i64(hi / dph);
            if k1 < k0 {
                return None;
            }
            if n_columns < grid.n_azimuth {
                (k0, k1) = held_columns(k0, k1, grid.n_azimuth as i64, n_columns as i64)?;
            }
        }
    }
    // sqrt is monotonic and correctly rounded: the longest edge is the root of the largest
    // squared length.
    let lmax = (0..3)
        .map(|e| {
            let c = sub(v[e], v[(e + 1) % 3]);
            dot(c, c)
        })
        .fold(0.0, f64::max)
        .sqrt();
    let (mut imin, mut imax) = (0, 0);
    for i in 1..3 {
        if pa[i].0 < pa[imin].0 {
            imin = i;
        }
        if pa[i].0 > pa[imax].0 {
            imax = i;
        }
    }
    let (th_min, th_max) = (pa[imin].0, pa[imax].0);
    let sin_min = sin_polar[imin].min(sin_polar[imax]).max(1e-9);
    let margin = lmax * lmax * (0.5 + 0.5 / sin_min) + 1e-12;
    let tlo = if forward { 0.0 } else { th_min - margin };
    let thi = if backward { PI } else { th_max + margin };
    let j0 = ceil_i64(tlo / dth).max(0);
    let j1 = floor_i64(thi / dth).min(grid.n_polar as i64 - 1);
    if j1 < j0 {
        return None;
    }
    Some(Extent {
        j0: j0 as u32,
        j1: j1 as u32,
        k0,
        k1,
        full,
    })
}

/// The part of the (unwrapped) column range `k0..=k1` of a triangle that falls on the held
/// columns `0..nc` of a mirror-half trace (modulo `na`), or `None`. A non-full triangle spans
/// less than a quarter turn and the columns not held span nearly half a turn, so at most one
/// copy `s..s + nc` (s = −na, 0, na) of the held columns meets it.
fn held_columns(k0: i64, k1: i64, na: i64, nc: i64) -> Option<(i64, i64)> {
    [-na, 0, na].into_iter().find_map(|s| {
        let (a, b) = (k0.max(s), k1.min(s + nc - 1));
        (a <= b).then_some((a, b))
    })
}

/// `k.rem_euclid(na)` without the integer division (called per pixel test): triangle extents
/// reach at most a few half-turns beyond `0..na`, so a correction or two suffices.
#[inline]
fn wrap_column(k: i64, na: i64) -> usize {
    let mut k = k;
    while k < 0 {
        k += na;
    }
    while k >= na {
        k -= na;
    }
    k as usize
}

/// `x.ceil() as i64` (saturating, NaN → 0) without the library call `ceil` compiles to on
/// baseline x86-64 (it is called for ≈ 100 M candidate triangles at the seed resolution).
#[inline]
fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) < x {
        t.saturating_add(1)
    } else {
        t
    }
}

/// `x.floor() as i64` (saturating, NaN → 0) without the library call `floor`.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// `(x + π).rem_euclid(2π) − π` (the angle `x` wrapped into [−π, π)), bit for bit, without the
/// floating-point remainder for the arguments differences of two azimuths give: below 2π in
/// magnitude the remainder is one exact subtraction (Sterbenz) or the argument itself.
#[inline]
fn wrap_angle(x: f64) -> f64 {
    let (a, b) = (x + PI, 2.0 * PI);
    let r = if (0.0..b).contains(&a) {
        a
    } else if (b..2.0 * b).contains(&a) {
        a - b
    } else if a < 0.0 && a > -b {
        a + b
    } else {
        a.rem_euclid(b)
    };
    r - PI
}

/// Whether the longer-path branch is crossed: `∇l · ∇b > 0` over the emitting-plane triangle
/// with corners `uv`, path lengths `l` (RT-1).
fn focal_flag(uv: [(f64, f64); 3], l: [f64; 3]) -> bool {
    let b = uv.map(|(u, v)| u * u + v * v);
    let grad = |f: [f64; 3]| {
        let (x0, y0) = uv[0];
        let (x1, y1) = uv[1];
        let (x2, y2) = uv[2];
        let det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
        let gx = ((f[1] - f[0]) * (y2 - y0) - (f[2] - f[0]) * (y1 - y0)) / det;
        let gy = ((x1 - x0) * (f[2] - f[0]) - (x2 - x0) * (f[1] - f[0])) / det;
        (gx, gy)
    };
    let (gl, gb) = (grad(l), grad(b));
    gl.0 * gb.0 + gl.1 * gb.1 > 0.0
}

/// One grid triangle `tri` (band-local (row, column) corners) of order `o`: the flux the patch
/// carries (zero for an incomplete or degenerate triangle) and, when it spans at least one
/// pixel centre, the triangle ready for rasterisation. A patch between pixel centres still
/// counts: the table point-samples patches, so it conserves their flux in expectation.
fn make_triangle(
    g: &RayGrid,
    grid: DirectionGrid,
    n_columns: usize,
    band: &Band,
    tri: [(usize, usize); 3],
    o: usize,
) -> (Option<Tri>, f64) {
    let rs = tri.map(|(ii, jj)| &band[ii].0[jj * g.orders + o]);
    if !rs.iter().all(|r| r.valid) {
        return (None, 0.0);
    }
    let mut v = rs.map(|r| r.dir);
    let mut corners = tri.map(|(ii, jj)| ((ii * g.nr + jj) * g.orders + o) as u32);
    let mut pa = rs.map(|r| r.pa);
    let mut sin_polar = rs.map(|r| r.sin_polar);
    // Signed solid angle 2·atan2(num, den) (Van Oosterom–Strackee). Its sign (the orientation)
    // is that of `num` wherever |Ω| passes the floor below, so the extent test, which rejects
    // most triangles, runs before the arctangent and the focal flag (the flux counts every
    // complete, non-degenerate patch, whether or not it spans a pixel centre).
    let num = dot(v[0], cross(v[1], v[2]));
    let den = 1.0 + dot(v[0], v[1]) + dot(v[1], v[2]) + dot(v[2], v[0]);
    if num.is_nan() || den.is_nan() || (num == 0.0 && (2.0 * num.atan2(den)).abs() <= 1e-300) {
        return (None, 0.0);
    }
    let uv = tri.map(|(ii, jj)| {
        let (u, v, _) = band[ii].2[jj];
        (u, v)
    });
    let area = if g.layout.on_silhouette() {
        let (a, b, c) = (uv[0], uv[1], uv[2]);
        0.5 * ((b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1)).abs()
    } else {
        0.5 * g.cell
    };
    let flux = rs.iter().map(|r| r.flux).sum::<f64>() / 3.0 * area;
    if n_columns < grid.n_azimuth && pa.iter().all(|p| p.1 < -1e-9 && p.1 > 1e-9 - PI) {
        // A mirror-half trace holds the azimuths 0°–180°; a triangle whose corners all lie
        // strictly beyond them (azimuth in (−180°, 0°)) contains neither pole (its corners lie
        // in one open half-plane through the axis) and spans its corners' azimuth range, so it
        // covers no held pixel: rejected before its edges (about half of all triangles).
        return (None, flux);
    }
    let negative = if num != 0.0 {
        num < 0.0
    } else {
        2.0 * num.atan2(den) < 0.0
    };
    if negative {
        v.swap(1, 2);
        corners.swap(1, 2);
        pa.swap(1, 2);
        sin_polar.swap(1, 2);
    }
    let edges = [cross(v[0], v[1]), cross(v[1], v[2]), cross(v[2], v[0])];
    let Some(ext) = triangle_extent(&g.fr, grid, n_columns, &v, &edges, &pa, &sin_polar) else {
        return (None, flux);
    };
    let s = (2.0 * num.atan2(den)).abs();
    if s.is_nan() || s <= 1e-300 {
        return (None, 0.0);
    }
    let focal = focal_flag(uv, rs.map(|r| r.l));
    let ties = [
        lex_less(v[0], v[1]),
        lex_less(v[1], v[2]),
        lex_less(v[2], v[0]),
    ];
    let omega_floor = 0.5 * grid.polar_step() * grid.polar_step();
    let t = Tri {
        order: o as u8,
        corners,
        edges,
        ties,
        // Solid-angle floor (RT-7): slivers folded across a caustic (|Ω| → 0) are point-sampled
        // by the table; their weight is capped at sqrt(a / (½Δθ²)) so a single pixel cannot
        // carry more than the patch's flux (expected flux is conserved or reduced, never
        // inflated).
        amp: (area / s.max(omega_floor)).sqrt(),
        phase0: if focal { -FRAC_PI_2 } else { 0.0 },
        j0: ext.j0,
        j1: ext.j1,
        k0: ext.k0,
        k1: ext.k1,
        full: ext.full,
    };
    (Some(t), flux)
}

/// Step 2: the triangles of a band (rayon over grid rows) into `parts`, one list per grid row of
/// cells in ray-grid order (the lists are reused from band to band), and the flux per order
/// they carry.
fn build_triangles(
    g: &RayGrid,
    grid: DirectionGrid,
    n_columns: usize,
    band: &Band,
    parts: &mut Vec<Vec<Tri>>,
) -> Vec<f64> {
    parts.resize_with(band.len() - 1, Vec::new);
    let row_flux: Vec<Vec<f64>> = parts
        .par_iter_mut()
        .enumerate()
        .map(|(i, tris)| {
            tris.clear();
            let mut flux = vec![0.0; g.orders];
            for j in 0..g.nr - 1 {
                let (a, b, c, d) = ((i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1));
                for (o, flux_o) in flux.iter_mut().enumerate() {
                    for tri in [[a, b, c], [a, c, d]] {
                        let (t, f) = make_triangle(g, grid, n_columns, band, tri, o);
                        *flux_o += f;
                        tris.extend(t);
                    }
                }
            }
            flux
        })
        .collect();
    let mut flux = vec![0.0; g.orders];
    for f in row_flux {
        flux.iter_mut().zip(f).for_each(|(a, b)| *a += b);
    }
    flux
}

/// Step 3a: the triangles of `parts` (taken in order) into `out` in order of their first polar
/// row (a stable counting sort, so triangles of one row keep their ray-grid order), straight
/// from the per-row lists into the buffer `out` reuses from band to band. Rasterising goes block
/// of rows by block, and a triangle is visited from every block it spans: in this order the
/// triangles a block visits lie together in memory (in ray-grid order they are scattered over
/// the band, and fetching them dominated the rasteriser's time).
fn sort_by_first_row(parts: &[Vec<Tri>], n_polar: usize, out: &mut Vec<Tri>) {
    let n: usize = parts.iter().map(Vec::len).sum();
    let mut start = vec![0usize; n_polar + 1];
    for t in parts.iter().flatten() {
        start[t.j0 as usize + 1] += 1;
    }
    for j in 0..n_polar {
        start[j + 1] += start[j];
    }
    out.clear();
    out.reserve(n);
    let slots = &mut out.spare_capacity_mut()[..n];
    for t in parts.iter().flatten() {
        let slot = &mut start[t.j0 as usize];
        slots[*slot].write(*t);
        *slot += 1;
    }
    // Each first row's slots start[j]..start[j + 1] (before the scatter advanced them) received
    // exactly its triangles, so the scatter ended with every start at the next row's beginning.
    assert_eq!(start[n_polar - 1], n, "counting sort filled every slot");
    // SAFETY: the counting sort wrote each of the first `n` slots exactly once (checked above:
    // the slots of the rows partition 0..n and each row's were all written), and `reserve(n)`
    // made room for them.
    unsafe { out.set_len(n) };
}

/// Polar rows per block of the rasteriser: a triangle spans ≈ 7 rows on average at the seed
/// resolution (0.0125° × 0.2° pixels), so it is fetched once per block it overlaps (mostly one)
/// instead of once per row (blocks of 64 rows measured the same).
const RASTER_BLOCK_ROWS: usize = 16;

/// Step 3b: triangle indices binned by block of [`RASTER_BLOCK_ROWS`] polar table rows (CSR:
/// block `b` lists `idx[counts[b]..counts[b + 1]]`, in triangle order).
fn bin_by_row_block(tris: &[Tri], n_polar: usize) -> (Vec<u32>, Vec<u32>) {
    let n_blocks = n_polar.div_ceil(RASTER_BLOCK_ROWS);
    let blocks = |t: &Tri| t.j0 as usize / RASTER_BLOCK_ROWS..=t.j1 as usize / RASTER_BLOCK_ROWS;
    let mut counts = vec![0u32; n_blocks + 1];
    for t in tris {
        for b in blocks(t) {
            counts[b + 1] += 1;
        }
    }
    for b in 0..n_blocks {
        counts[b + 1] += counts[b];
    }
    let mut fill = counts.clone();
    let mut idx = vec![0u32; counts[n_blocks] as usize];
    for (ti, t) in tris.iter().enumerate() {
        for b in blocks(t) {
            idx[fill[b] as usize] = ti as u32;
            fill[b] += 1;
        }
    }
    (counts, idx)
}

/// Coherent contribution of triangle `t` at direction `r` (polar row sin/cos `st`, `ct`,
/// azimuth column `k`), or `None` when `r` lies outside it: `[a⊥, a∥, b⊥, b∥]`.
fn triangle_field(
    g: &RayGrid,
    t: &Tri,
    flat: &[&RayOut],
    r: [f64; 3],
    (sin_ph, cos_ph): (f64, f64),
) -> Option<[Complex64; 4]> {
    let w = inside(t, r)?;
    let c = t.corners.map(|ci| flat[ci as usize]);
    let l = w[0] * c[0].l + w[1] * c[1].l + w[2] * c[2].l - g.l_ref;
    let ph = Complex64::from_polar(t.amp, g.k_wave * l + t.phase0);
    let fr = &g.fr;
    let perp = sub(scale(fr.e2, cos_ph), scale(fr.e1, sin_ph));
    let par = cross(perp, r);
    let mut ea = [Complex64::new(0.0, 0.0); 3];
    let mut eb = [Complex64::new(0.0, 0.0); 3];
    for q in 0..3 {
        for (cw, cc) in w.iter().zip(&c) {
            let (a, b) = (cc.ea[q], cc.eb[q]);
            ea[q] += Complex64::new(a.re as f64, a.im as f64) * *cw;
            eb[q] += Complex64::new(b.re as f64, b.im as f64) * *cw;
        }
    }
    Some([
        cdot(&ea, perp) * ph,
        cdot(&ea, par) * ph,
        cdot(&eb, perp) * ph,
        cdot(&eb, par) * ph,
    ])
}

/// Mutable views of the accumulators of one polar row, one `[azimuth][4]` slice per order.
type RowViews<'a> = Vec<&'a mut [Complex32]>;

/// How many triangles ahead of the one being rasterised [`prefetch_triangle`] reaches.
const PREFETCH_AHEAD: usize = 4;

/// Hint the cache to load what rasterising triangle `t` in the block of rows starting at
/// `first` will read: its three corner rays and, in each of its rows of the block, the
/// accumulator lines at the ends of its azimuth range. Each accumulator value receives about one
/// contribution in the whole trace at the seed resolution, so nearly every access misses the
/// caches; issuing the loads a few triangles early overlaps their latency. A hint only: no
/// value or summation order changes.
#[inline]
fn prefetch_triangle(t: &Tri, flat: &[&RayOut], block: &[RowViews<'_>], first: usize, na: i64) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        for &c in &t.corners {
            let r: *const RayOut = flat[c as usize];
            // SAFETY: prefetching is a hint with no architectural effect, valid for any address;
            // `r` points into a live allocation anyway.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(r.cast());
                _mm_prefetch::<_MM_HINT_T0>(r.cast::<i8>().wrapping_add(64));
                _mm_prefetch::<_MM_HINT_T0>(r.cast::<i8>().wrapping_add(128));
            }
        }
        if t.full {
            return;
        }
        let last = first + block.len() - 1;
        let (ka, kb) = (wrap_column(t.k0, na), wrap_column(t.k1, na));
        // Two azimuth values (2 × 32 bytes) share a cache line.
        let kb_line = if kb / 2 != ka / 2 { Some(kb) } else { None };
        for j in (t.j0 as usize).max(first)..=(t.j1 as usize).min(last) {
            let row = &block[j - first][t.order as usize];
            for k in std::iter::once(ka).chain(kb_line) {
                if let Some(v) = row.get(k * 4) {
                    // SAFETY: as above; `v` is a live element.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>((v as *const Complex32).cast()) };
                }
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (t, flat, block, first, na);
}

/// Step 4: rasterise a band's triangles into the field accumulators `rows` (per polar row, one
/// view per order; rayon over blocks of [`RASTER_BLOCK_ROWS`] rows). `sc_th` holds the sine and
/// cosine of every row's polar angle. Within a block the triangles are taken in their sorted
/// order and each adds to all its rows of the block, so every pixel receives its contributions
/// in the same order as row by row (the sums are bit-identical), with one fetch of a triangle
/// per block instead of one per row.
fn rasterise(
    g: &RayGrid,
    grid: DirectionGrid,
    n_columns: usize,
    band: &Band,
    tris: &[Tri],
    sc_th: &[(f64, f64)],
    rows: &mut [RowViews<'_>],
) {
    let (counts, idx) = bin_by_row_block(tris, grid.n_polar);
    let flat: Vec<&RayOut> = band.iter().flat_map(|(r, _, _)| r.iter()).collect();
    let dph = grid.azimuth_step();
    let sc_ph: Vec<(f64, f64)> = (0..n_columns).map(|k| (dph * k as f64).sin_cos()).collect();
    let na = grid.n_azimuth as i64;
    rows.par_chunks_mut(RASTER_BLOCK_ROWS)
        .enumerate()
        .for_each(|(b, block)| {
            let list = &idx[counts[b] as usize..counts[b + 1] as usize];
            let first = b * RASTER_BLOCK_ROWS;
            let last = first + block.len() - 1;
            for (n, &ti) in list.iter().enumerate() {
                if let Some(&ahead) = list.get(n + PREFETCH_AHEAD) {
                    prefetch_triangle(&tris[ahead as usize], &flat, block, first, na);
                }
                let t = &tris[ti as usize];
                let (ka, kb) = if t.full {
                    (0, n_columns as i64 - 1)
                } else {
                    (t.k0, t.k1)
                };
                for j in (t.j0 as usize).max(first)..=(t.j1 as usize).min(last) {
                    let (st, ct) = sc_th[j];
                    let acc = &mut *block[j - first][t.order as usize];
                    for kk in ka..=kb {
                        let k = wrap_column(kk, na);
                        let (sp, cp) = sc_ph[k];
                        let radial = add(scale(g.fr.e1, cp), scale(g.fr.e2, sp));
                        let r = add(scale(g.fr.d, ct), scale(radial, st));
                        let Some(vals) = triangle_field(g, t, &flat, r, (sp, cp)) else {
                            continue;
                        };
                        for (acc, v) in acc[k * 4..k * 4 + 4].iter_mut().zip(vals) {
                            *acc += Complex32::new(v.re as f32, v.im as f32);
                        }
                    }
                }
            }
        });
}

/// The outgoing directions (polar angle, azimuth; radians, table frame) of every order of the
/// rays at normalised impact parameters `b` ∈ [0, 1) towards ψ (radians, from e1 towards e2)
/// on the silhouette seen along the incident direction of `cfg`, per `b` one entry per order,
/// `None` for an order that does not leave (total internal reflection, or `b` off the drop):
/// where on the ray grid the rays feeding each part of a table come from.
pub fn outgoing_directions(
    shape: &DropShape,
    cfg: &TraceConfig,
    psi: f64,
    b: &[f64],
) -> Vec<Vec<Option<(f64, f64)>>> {
    outgoing_rays(shape, cfg, psi, b)
        .into_iter()
        .map(|orders| {
            (orders.into_iter())
                .map(|r| r.map(|r| (r.polar_rad, r.azimuth_rad)))
                .collect()
        })
        .collect()
}

/// One outgoing ray of [`outgoing_rays`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutgoingRay {
    /// Polar angle from the incident direction (radians, table frame).
    pub polar_rad: f64,
    /// Azimuth from e1 towards e2 (radians, table frame).
    pub azimuth_rad: f64,
    /// Optical path (µm) from the emitting plane to the plane through the drop's centre normal
    /// to the outgoing direction, plus the emitting plane's distance from the centre (the same
    /// for every ray of a drop and sun): 2π/λ times its differences are the rays' phase
    /// differences.
    pub path_um: f64,
    /// Mean of the two incident polarisations' outgoing |E|² (unit incident fields).
    pub flux: f64,
}

/// [`outgoing_directions`] with each ray's optical path and flux.
pub fn outgoing_rays(
    shape: &DropShape,
    cfg: &TraceConfig,
    psi: f64,
    b: &[f64],
) -> Vec<Vec<Option<OutgoingRay>>> {
    let cfg = TraceConfig {
        rays: 2,
        ray_grid: RayGridLayout::Silhouette,
        ..cfg.clone()
    };
    let g = RayGrid::new(shape, &cfg);
    let edge = g.silhouette_at(psi) / (1.0 - SILHOUETTE_INSET);
    let (sp, cp) = psi.sin_cos();
    let mut out = vec![INVALID; g.orders];
    b.iter()
        .map(|&b| {
            let rho = b * edge;
            trace_ray(&g, shape, cfg.n, (rho * cp, rho * sp), &mut out);
            (out.iter())
                .map(|r| {
                    r.valid.then_some(OutgoingRay {
                        polar_rad: r.pa.0,
                        azimuth_rad: r.pa.1,
                        path_um: r.l,
                        flux: r.flux,
                    })
                })
                .collect()
        })
        .collect()
}

/// Trace the drop and accumulate the coherent far fields of every order on `grid`: rows of
/// the ray grid are processed in bands (trace, build triangles, rasterise), so memory stays
/// bounded by one band plus the accumulators.
pub fn trace_fields(shape: &DropShape, cfg: &TraceConfig, grid: DirectionGrid) -> FieldGrid {
    trace_fields_on_columns(shape, cfg, grid, grid.n_azimuth)
}

/// [`trace_fields`] on the azimuths φ = 0°–180° only (columns `0..=na/2`, see
/// [`FieldGrid::n_columns`]). Every drop shape and the sun are mirror-symmetric about the
/// vertical plane φ = 0, so the field at `−φ` is the mirror image of the one at `φ` (the same
/// intensities); the whole ray grid is traced (rays from both halves of the emitting plane reach
/// either half of the sky), and the triangles, their rasterisation and the accumulators are
/// those of the held half (decision RT-34). Each held pixel's value is bit-identical to the
/// whole trace's.
pub fn trace_fields_mirror_half(
    shape: &DropShape,
    cfg: &TraceConfig,
    grid: DirectionGrid,
) -> FieldGrid {
    trace_fields_on_columns(shape, cfg, grid, grid.n_azimuth / 2 + 1)
}

fn trace_fields_on_columns(
    shape: &DropShape,
    cfg: &TraceConfig,
    grid: DirectionGrid,
    n_columns: usize,
) -> FieldGrid {
    let g = RayGrid::new(shape, cfg);
    let (nr, orders) = (g.nr, g.orders);
    let order_row_len = n_columns * 4;
    let row_len = order_row_len * orders;
    let field_rows =
        (FIELD_BAND_BYTES / (row_len * std::mem::size_of::<Complex32>())).clamp(1, grid.n_polar);
    let mut data: Vec<Vec<Complex32>> = (0..grid.n_polar.div_ceil(field_rows))
        .map(|b| {
            let rows = field_rows.min(grid.n_polar - b * field_rows);
            zeroed_accumulators(rows * row_len)
        })
        .collect();
    let mut reach: Vec<Option<(usize, usize)>> = vec![None; orders];
    let mut tally = RayTally::new(orders);
    let mut patch_flux = vec![0.0; orders];
    {
        let mut rows = row_views(&mut data, orders, order_row_len);
        let sc_th: Vec<(f64, f64)> = (0..grid.n_polar)
            .map(|j| (grid.polar_step() * j as f64).sin_cos())
            .collect();
        let band_rows = (RAYS_PER_BAND / (nr * orders)).clamp(2, nr - 1);
        // Buffers reused from band to band: the traced rows, the triangles per row of cells and
        // all the band's triangles in rasterising order.
        let mut band: Band = Vec::new();
        let mut parts: Vec<Vec<Tri>> = Vec::new();
        let mut tris: Vec<Tri> = Vec::new();
        let mut row0 = 0usize;
        while row0 < nr - 1 {
            let row1 = (row0 + band_rows).min(nr - 1); // rows row0..=row1 traced, cells row0..row1
            trace_band(&g, shape, cfg, row0, row1, &mut band);
            // Count each grid row once (the band's last row is the next band's first).
            let counted = if row1 == nr - 1 {
                band.len()
            } else {
                row1 - row0
            };
            tally.add(&band[..counted], orders);
            let flux = build_triangles(&g, grid, n_columns, &band, &mut parts);
            sort_by_first_row(&parts, grid.n_polar, &mut tris);
            extend_reach(&tris, &mut reach, &mut rows);
            patch_flux.iter_mut().zip(flux).for_each(|(a, b)| *a += b);
            rasterise(&g, grid, n_columns, &band, &tris, &sc_th, &mut rows);
            row0 = row1;
        }
    }
    FieldGrid {
        grid,
        orders,
        band_rows: field_rows,
        bands: data,
        reach,
        n_columns,
        order_cross_section_um2: tally.order_flux,
        patch_cross_section_um2: patch_flux,
        projected_area_um2: if g.layout.on_silhouette() {
            tally.hit_area
        } else {
            tally.hits as f64 * g.cell
        },
        rays_traced: nr * nr,
    }
}

/// Per polar row, a view of each order's accumulators in the bands `data` (each
/// `[order][row][order_row_len]`).
fn row_views(
    data: &mut [Vec<Complex32>],
    orders: usize,
    order_row_len: usize,
) -> Vec<RowViews<'_>> {
    let mut rows: Vec<RowViews<'_>> = Vec::new();
    for acc in data.iter_mut() {
        let block = acc.len() / orders;
        let mut per_order: Vec<_> = acc
            .chunks_mut(block)
            .map(|b| b.chunks_mut(order_row_len))
            .collect();
        for _ in 0..block / order_row_len {
            rows.push(per_order.iter_mut().map(|it| it.next().unwrap()).collect());
        }
    }
    rows
}

/// What the traced rays carried: rays that hit the drop, the quadrature area of the hits and,
/// per order, the flux-weighted area of its outgoing rays.
struct RayTally {
    hits: usize,
    hit_area: f64,
    order_flux: Vec<f64>,
}

impl RayTally {
    fn new(orders: usize) -> Self {
        RayTally {
            hits: 0,
            hit_area: 0.0,
            order_flux: vec![0.0; orders],
        }
    }

    /// Count the traced grid rows `rows`.
    fn add(&mut self, rows: &[BandRow], orders: usize) {
        for (row, hit, points) in rows {
            self.hits += hit;
            for (r, &(_, _, w)) in row.chunks(orders).zip(points) {
                if r[0].valid {
                    self.hit_area += w;
                }
                for (o, ro) in r.iter().enumerate().filter(|(_, ro)| ro.valid) {
                    self.order_flux[o] += ro.flux * w;
                }
            }
        }
    }
}

/// Widen each order's polar reach to the rows of its triangles `tris`, and map the pages of
/// the accumulator rows newly reached ([`fault_in`]).
fn extend_reach(tris: &[Tri], reach: &mut [Option<(usize, usize)>], rows: &mut [RowViews<'_>]) {
    let reached = reach.to_vec();
    for t in tris {
        let (j0, j1) = (t.j0 as usize, t.j1 as usize);
        let r = &mut reach[t.order as usize];
        *r = Some(r.map_or((j0, j1), |(a, b)| (a.min(j0), b.max(j1))));
    }
    if reach != reached.as_slice() {
        let within =
            |r: Option<(usize, usize)>, j: usize| r.is_some_and(|(a, b)| (a..=b).contains(&j));
        let reach = &*reach;
        rows.par_iter_mut().enumerate().for_each(|(j, row)| {
            for (o, acc) in row.iter_mut().enumerate() {
                if within(reach[o], j) && !within(reached[o], j) {
                    fault_in(acc);
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raytrace::sphere1d::SphereGo;

    fn silhouette_grid(shape: &DropShape, rays: usize, elevation_deg: f64) -> RayGrid {
        layout_grid(shape, rays, elevation_deg, RayGridLayout::Silhouette)
    }

    fn layout_grid(
        shape: &DropShape,
        rays: usize,
        elevation_deg: f64,
        ray_grid: RayGridLayout,
    ) -> RayGrid {
        let cfg = TraceConfig {
            rays,
            max_order: 3,
            sun_elevation_rad: elevation_deg.to_radians(),
            wavelength_nm: 650.0,
            n: 1.331,
            ray_grid,
        };
        RayGrid::new(shape, &cfg)
    }

    /// The warped silhouette grid (RT-40) is a quadrature of the silhouette like the
    /// `silhouette` grid: its weights sum to the drop's projected area and integrate ρ² (the
    /// polar moment) to 3e-4, on a sphere and on a Beard–Chuang drop under an elevated sun
    /// (whose projected area the `silhouette` grid gives), and its rings are denser than the
    /// `silhouette` grid's at the primary bow's impact parameter and sparser at the centre.
    #[test]
    fn warped_grid_weights_integrate_the_silhouette() {
        let a = 400.0;
        for (shape, elev) in [
            (DropShape::Sphere { radius_um: a }, 17.0),
            (DropShape::beard_chuang(2.0), 30.0),
        ] {
            let sums = |layout| {
                let g = layout_grid(&shape, 301, elev, layout);
                let (mut area, mut moment) = (0.0, 0.0);
                for i in 0..g.nr {
                    for j in 0..g.nr {
                        let (u, v, w) = g.point_and_weight(i, j);
                        area += w;
                        moment += w * (u * u + v * v);
                    }
                }
                (area, moment)
            };
            let (area, moment) = sums(RayGridLayout::SilhouetteBows);
            let (area0, moment0) = sums(RayGridLayout::Silhouette);
            assert!((area / area0 - 1.0).abs() < 1e-4, "area {area} vs {area0}");
            assert!(
                (moment / moment0 - 1.0).abs() < 3e-4,
                "moment {moment} vs {moment0}"
            );
            if matches!(shape, DropShape::Sphere { .. }) {
                let r = a * (1.0 - SILHOUETTE_INSET);
                assert!(
                    (area / (PI * r * r) - 1.0).abs() < 1e-4,
                    "sphere area {area}"
                );
            }
        }
        // Rays along the grid's middle row: radial spacing at b ≈ 0.86 and at the centre.
        let shape = DropShape::Sphere { radius_um: a };
        let spacing = |layout, b: f64| {
            let g = layout_grid(&shape, 601, 0.0, layout);
            let mid = g.nr / 2;
            let u: Vec<f64> = (mid..g.nr).map(|j| g.point_and_weight(mid, j).1).collect();
            let i = u.iter().position(|&x| x.abs() >= b * a).unwrap_or(1).max(1);
            (u[i] - u[i - 1]).abs()
        };
        let bow =
            spacing(RayGridLayout::Silhouette, 0.86) / spacing(RayGridLayout::SilhouetteBows, 0.86);
        let centre =
            spacing(RayGridLayout::Silhouette, 0.0) / spacing(RayGridLayout::SilhouetteBows, 0.0);
        assert!(bow > 2.0, "rays at the primary's rainbow ray {bow}× denser");
        assert!(centre < 0.7, "rays at the centre {centre}× as dense");
    }

    /// The warped grid moves rays, not flux: on a Beard–Chuang drop under an elevated sun, the
    /// patches of every order carry the rays' flux (to 1e-3), the per-order cross-sections and
    /// the projected area equal the `silhouette` grid's (to 2e-3), and the azimuth-averaged
    /// primary and secondary bows (1° bins over 115–150°, per order) agree with the `silhouette`
    /// grid's at 4× the rays within 12 % (the bows' point-sampled GO caustics: measured 8.8 %
    /// for p = 3, the `silhouette` grid of the same ray count 8.9 %) and no worse than that
    /// grid; a wrong Jacobian or patch area breaks the first two.
    #[test]
    fn warped_grid_conserves_flux_and_matches_the_silhouette_grid() {
        let shape = DropShape::beard_chuang(1.0);
        let grid = DirectionGrid {
            n_polar: 1801,
            n_azimuth: 36,
        };
        let trace = |rays, ray_grid| {
            let cfg = TraceConfig {
                rays,
                max_order: 3,
                sun_elevation_rad: 0.3,
                wavelength_nm: 600.0,
                n: 1.332,
                ray_grid,
            };
            trace_fields(&shape, &cfg, grid)
        };
        let warped = trace(200, RayGridLayout::SilhouetteBows);
        let fine = trace(400, RayGridLayout::Silhouette);
        let ratios: Vec<[f64; 2]> = (0..4)
            .map(|o| {
                let r = warped.order_cross_section_um2[o];
                [
                    warped.patch_cross_section_um2[o] / r,
                    r / fine.order_cross_section_um2[o],
                ]
            })
            .collect();
        let area = warped.projected_area_um2 / fine.projected_area_um2;
        assert!(
            ratios.iter().flatten().all(|x| (x - 1.0).abs() < 1e-2) && (area - 1.0).abs() < 2e-3,
            "patches / rays and rays / finer grid per order {ratios:?}, area ratio {area}"
        );
        // Azimuth sums over 1° of polar rows (ten rows): the bows' GO caustics are point
        // samples of a singular intensity, which neither grid resolves row by row.
        let mean = |f: &FieldGrid, o: usize, deg: usize| {
            let mut per = vec![0.0; f.orders];
            let mut sum = 0.0;
            for j in deg * 10..deg * 10 + 10 {
                for k in 0..grid.n_azimuth {
                    f.intensities_into(j, k, &mut per);
                    sum += per[o];
                }
            }
            sum
        };
        let coarse = trace(200, RayGridLayout::Silhouette);
        let l2 = |f: &FieldGrid, o: usize| {
            let (mut d2, mut n2) = (0.0, 0.0);
            for deg in 115..150 {
                let (a, b) = (mean(f, o, deg), mean(&fine, o, deg));
                d2 += (a - b).powi(2);
                n2 += b * b;
            }
            (d2 / n2).sqrt()
        };
        for o in [2, 3] {
            let (w, c) = (l2(&warped, o), l2(&coarse, o));
            assert!(
                w < 0.12 && w < 1.25 * c + 0.01,
                "order {o}: L2 {w} (warped) and {c} (silhouette, same rays) against the finer grid"
            );
        }
    }

    /// On a sphere the outgoing rays of `outgoing_rays` leave at Descartes' deviations
    /// `D_p = 2(i − r) + (p − 1)(π − 2r)` (sin i = b, sin r = b/n), in the plane of incidence
    /// (azimuth ψ or ψ + π), and the central ray's paths differ by the chords: 2na between
    /// p = 1 and p = 0, 2na again between p = 2 and p = 1.
    #[test]
    fn outgoing_rays_of_a_sphere_leave_at_descartes_deviations() {
        let (a, n) = (500.0, 1.333);
        let shape = DropShape::Sphere { radius_um: a };
        let cfg = TraceConfig {
            rays: 2,
            max_order: 3,
            sun_elevation_rad: 0.3,
            wavelength_nm: 550.0,
            n,
            ray_grid: RayGridLayout::Silhouette,
        };
        let psi = 0.7;
        let bs = [0.0, 0.3, 0.6, 0.86, 0.95];
        let rays = outgoing_rays(&shape, &cfg, psi, &bs);
        for (b, orders) in bs.iter().zip(&rays) {
            let (i, r) = (f64::asin(*b), f64::asin(b / n));
            for (p, ray) in orders.iter().enumerate() {
                let ray = ray.expect("every order leaves a sphere");
                let d = 2.0 * (i - r) + (p as f64 - 1.0) * (PI - 2.0 * r);
                let polar = d.cos().acos();
                let (got, want) = (ray.polar_rad.cos(), d.cos());
                assert!(
                    (got - want).abs() < 1e-12,
                    "b {b}, p {p}: cos {got} against {want}"
                );
                if *b > 0.0 && polar > 1e-6 && polar < PI - 1e-6 {
                    let off = (ray.azimuth_rad - psi).rem_euclid(PI);
                    assert!(
                        off < 1e-9 || PI - off < 1e-9,
                        "b {b}, p {p}: azimuth {}",
                        ray.azimuth_rad
                    );
                }
                assert!(
                    ray.flux > 0.0 && ray.flux < 1.0,
                    "b {b}, p {p}: flux {}",
                    ray.flux
                );
            }
        }
        let central = &rays[0];
        let path = |p: usize| central[p].unwrap().path_um;
        assert!((path(1) - path(0) - 2.0 * n * a).abs() < 1e-9 * a);
        assert!((path(2) - path(1) - 2.0 * n * a).abs() < 1e-9 * a);
    }

    /// The concentric map is onto the disc ring by ring: ring s lands on radius s (the outer
    /// ring on the unit circle), and its angle runs linearly along each side.
    #[test]
    fn concentric_map_rings_and_angles() {
        for (x, y) in [
            (0.5, 0.2),
            (-0.3, 0.7),
            (1.0, -1.0),
            (-0.25, -0.25),
            (0.0, -0.8),
        ] {
            let (s, psi) = concentric(x, y);
            assert_eq!(s, f64::max(f64::abs(x), f64::abs(y)));
            assert!((0.0..2.0 * PI).contains(&psi));
        }
        let psi0 =
            |x: f64, y: f64| (concentric(x, y).1 - CONCENTRIC_OFFSET_RAD).rem_euclid(2.0 * PI);
        assert!((psi0(1.0, 0.0) - 0.0).abs() < 1e-15);
        assert!((psi0(1.0, 1.0) - 0.25 * PI).abs() < 1e-15);
        assert!((psi0(0.0, 1.0) - 0.5 * PI).abs() < 1e-15);
        assert!((psi0(-1.0, 0.0) - PI).abs() < 1e-15);
        assert!((psi0(0.5, -0.5) - 1.75 * PI).abs() < 1e-15);
        // Linear along a side: equal steps in y give equal steps in ψ.
        let (a, b, c) = (psi0(0.6, 0.0), psi0(0.6, 0.2), psi0(0.6, 0.4));
        assert!(((b - a) - (c - b)).abs() < 1e-15);
    }

    /// The silhouette grid's quadrature weights sum to the silhouette's area (sphere: π a²
    /// less the 1 ppm inset) and every ray of the sphere hits; the weights integrate a smooth
    /// function (ρ², the polar moment π a⁴/2) to the grid's order of accuracy.
    #[test]
    fn silhouette_grid_weights_integrate_the_disc() {
        let a = 400.0;
        let g = silhouette_grid(&DropShape::Sphere { radius_um: a }, 301, 17.0);
        let r = a * (1.0 - SILHOUETTE_INSET);
        let (mut area, mut moment) = (0.0, 0.0);
        for i in 0..g.nr {
            for j in 0..g.nr {
                let (u, v, w) = g.point_and_weight(i, j);
                assert!(u.hypot(v) <= r * (1.0 + 1e-12));
                area += w;
                moment += w * (u * u + v * v);
            }
        }
        let disc = PI * r * r;
        assert!((area / disc - 1.0).abs() < 1e-4, "area {area} vs {disc}");
        let polar = 0.5 * PI * r.powi(4);
        assert!(
            (moment / polar - 1.0).abs() < 1e-4,
            "moment {moment} vs {polar}"
        );
    }

    /// For a Beard–Chuang drop the bisected silhouette radius lies on the silhouette: a ray at
    /// 0.999 R hits and one at 1.001 R misses, in every direction, and the silhouette they trace
    /// reaches the bounding box's half-extents (less its 0.2 % margin) along e1 and e2.
    #[test]
    fn silhouette_radii_lie_on_the_beard_chuang_silhouette() {
        for elev in [0.0, 40.0] {
            let shape = DropShape::beard_chuang(2.0);
            let g = silhouette_grid(&shape, 11, elev);
            let hits = |rho: f64, psi: f64| {
                let (sp, cp) = psi.sin_cos();
                let o = add(
                    add(scale(g.fr.e1, rho * cp), scale(g.fr.e2, rho * sp)),
                    scale(g.fr.d, -g.dist),
                );
                shape.intersect(o, g.fr.d, false).is_some()
            };
            for k in 0..64 {
                let psi = 2.0 * PI * (k as f64 + 0.37) / 64.0;
                let r = g.silhouette_at(psi);
                assert!(
                    hits(0.999 * r, psi) && !hits(1.001 * r, psi),
                    "elev {elev} ψ {psi}"
                );
            }
            let (w1, w2) = shape.silhouette_half_extents(elev.to_radians());
            let m = g.silhouette_um.len() - 1;
            let (mut r_e1, mut r_e2) = (0.0f64, 0.0f64);
            for (k, r) in g.silhouette_um[..m].iter().enumerate() {
                let (sp, cp) = (2.0 * PI * k as f64 / m as f64).sin_cos();
                r_e1 = r_e1.max(r * cp.abs());
                r_e2 = r_e2.max(r * sp.abs());
            }
            assert!((r_e1 * 1.002 / w1 - 1.0).abs() < 1e-4, "{r_e1} vs {w1}");
            assert!((r_e2 * 1.002 / w2 - 1.0).abs() < 1e-4, "{r_e2} vs {w2}");
        }
    }

    /// The remainder-free wrap equals the remainder formula bit for bit.
    #[test]
    fn wrap_angle_matches_rem_euclid() {
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        let mut args = vec![0.0, -0.0, PI, -PI, 2.0 * PI, -2.0 * PI, 3.0 * PI, -3.0 * PI];
        for _ in 0..100_000 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            args.push(((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 5.0 * PI);
        }
        for a in args {
            let want = (a + PI).rem_euclid(2.0 * PI) - PI;
            assert_eq!(wrap_angle(a).to_bits(), want.to_bits(), "{a}");
        }
    }

    /// The division-free column wrap equals `rem_euclid` over three turns either side.
    #[test]
    fn wrap_column_matches_rem_euclid() {
        for na in [1i64, 7, 1800] {
            for k in -3 * na..3 * na {
                assert_eq!(
                    wrap_column(k, na),
                    k.rem_euclid(na) as usize,
                    "k = {k}, na = {na}"
                );
            }
        }
    }

    /// The call-free integer ceiling and floor equal the library's, cast to i64.
    #[test]
    fn integer_ceil_floor_match_the_library() {
        let mut x = 0x2545_f491_4f6c_dd1d_u64;
        let mut args = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            9.223372036854776e18,
            -9.223372036854776e18,
            1e30,
            -1e30,
            4503599627370495.5,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for _ in 0..200_000 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            args.push(u * 4e4);
            args.push(u * 3.0);
            args.push((u * 2e4).round() + [0.0, 1e-12, -1e-12][(x % 3) as usize]);
        }
        for a in args {
            assert_eq!(ceil_i64(a), a.ceil() as i64, "ceil {a}");
            assert_eq!(floor_i64(a), a.floor() as i64, "floor {a}");
        }
    }

    /// A mirror-half trace (RT-34) holds columns 0..=na/2, each bit-identical to the whole
    /// trace's (the same triangles reach a held pixel in the same order), and the whole trace
    /// is mirror-symmetric there up to ray noise; for even and odd azimuth counts, a deformed drop
    /// and a sun off the horizon, on both ray-grid layouts.
    #[test]
    fn mirror_half_trace_equals_the_whole_trace_on_its_columns() {
        let shape = DropShape::beard_chuang(2.0);
        for (na, layout) in [(36, RayGridLayout::Silhouette), (35, RayGridLayout::Square)] {
            let cfg = TraceConfig {
                rays: 90,
                max_order: 3,
                sun_elevation_rad: 0.2,
                wavelength_nm: 550.0,
                n: 1.333,
                ray_grid: layout,
            };
            let grid = DirectionGrid {
                n_polar: 361,
                n_azimuth: na,
            };
            let whole = trace_fields(&shape, &cfg, grid);
            let half = trace_fields_mirror_half(&shape, &cfg, grid);
            assert_eq!(half.n_columns, na / 2 + 1);
            assert_eq!(whole.n_columns, na);
            assert_eq!(half.order_cross_section_um2, whole.order_cross_section_um2);
            assert_eq!(half.patch_cross_section_um2, whole.patch_cross_section_um2);
            assert_eq!(half.projected_area_um2, whole.projected_area_um2);
            let (mut nonzero, mut asym, mut norm) = (0usize, 0.0f64, 0.0f64);
            for o in 0..4 {
                for j in 0..grid.n_polar {
                    for k in 0..half.n_columns {
                        let (a, b) = (half.order_pixel(o, j, k), whole.order_pixel(o, j, k));
                        assert_eq!(a, b, "order {o}, row {j}, column {k}");
                        nonzero += usize::from(a.iter().any(|z| z.norm_sqr() > 0.0));
                    }
                }
            }
            // Column totals (Σ over rows of dσ/dΩ · sin θ): pixel values at 90² rays are
            // point samples with large ray noise, their column sums are not.
            let column = |k: usize| {
                (0..grid.n_polar)
                    .map(|j| whole.intensities(j, k).0 * (grid.polar_step() * j as f64).sin())
                    .sum::<f64>()
            };
            for k in 1..na.div_ceil(2) {
                let (a, b) = (column(k), column(na - k));
                asym += (a - b).powi(2);
                norm += (0.5 * (a + b)).powi(2);
            }
            assert!(nonzero > 1000, "{nonzero} non-zero held pixels");
            let rel = (asym / norm).sqrt();
            // Measured 0.030 (silhouette) and 0.060 (square): ray noise at 90² rays; a frame
            // that broke the symmetry would put O(1) differences between the bows' columns.
            assert!(rel < 0.1, "whole trace far from mirror-symmetric: {rel}");
        }
    }

    /// Sphere, 2-D tracer vs the 1-D GO+phase reference: per-order cross-sections and the
    /// primary/secondary bow region of i_perp.
    #[test]
    fn sphere_tracer_matches_1d_reference_energy_and_bows() {
        let a = 100.0;
        let lambda = 650.0;
        let n = 1.331;
        let shape = DropShape::Sphere { radius_um: a };
        let cfg = TraceConfig {
            rays: 500,
            max_order: 3,
            sun_elevation_rad: 0.3,
            wavelength_nm: lambda,
            n,
            ray_grid: RayGridLayout::Square,
        };
        let grid = DirectionGrid {
            n_polar: 3601,
            n_azimuth: 8,
        };
        let f = trace_fields(&shape, &cfg, grid);
        let go = SphereGo::new(a, lambda, n, 3);
        for p in 0..4 {
            let want = go.energy_fraction(p) * PI * a * a;
            let got = f.order_cross_section_um2[p];
            assert!((got / want - 1.0).abs() < 5e-3, "p={p}: {got} vs {want}");
        }
        assert!((f.projected_area_um2 / (PI * a * a) - 1.0).abs() < 1e-2);
    }
}
