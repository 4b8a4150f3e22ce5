//! The 2-D tables of non-spherical drops: one (wavelength, sun elevation) entry traced by the
//! patch tracer ([`super::tracer`]) and turned into table values `[polar][azimuth][channel]`:
//! the caustic windows of every azimuth column filtered ([`super::caustic`]: the Gaussian
//! diffraction filter, or the equal-volume sphere's Airy correction moved onto each column's
//! caustic, decisions RT-28, RT-33), the forward Fraunhofer lobe and the equal-volume sphere's
//! orders above the traced ones added (decision RT-37), everything divided by the scattering
//! cross-section, and the table mirror-symmetrised in azimuth (decisions RT-24, RT-34).
//! Channels as [`super::channel_names`].

use super::caustic::{
    AiryTransfer, CausticWindow, ColumnFilter, domain_weights, smooth_over_azimuth,
};
use super::post::{bin_edges, filter_sigma_deg, fraunhofer_bin_average};
use super::shape::DropShape;
use super::sphere1d::{
    DiffractionModel, Phase1dOptions, SPHERE_MAX_ORDER, SphereGo, SphereTableOptions,
    sphere_order_intensities_1d, sphere_phase_1d, sphere_table_channels_and_cross_section,
};
use super::tracer::{
    DirectionGrid, FieldGrid, RayGridLayout, TraceConfig, pixel_intensities, trace_fields,
    trace_fields_mirror_half,
};
use num_complex::Complex32;
use rayon::prelude::*;
use std::collections::VecDeque;
use std::f64::consts::PI;
use std::sync::{Arc, LazyLock, Mutex, OnceLock};

/// How the entries of a 2-D table are traced and turned into table values.
#[derive(Debug, Clone, Copy)]
pub struct Table2dOptions {
    /// Rays per side of the ray grid.
    pub rays: usize,
    /// Layout of the ray grid (decision RT-31).
    pub ray_grid: RayGridLayout,
    /// Highest order traced.
    pub max_order: usize,
    /// The outgoing directions of the table.
    pub grid: DirectionGrid,
    /// Filter the caustic windows (otherwise the filtered channels are the unfiltered ones).
    pub diffraction_filter: bool,
    /// `AiryLocal` (the sphere's transfer within its domain, the Gaussian filter outside) or
    /// `Gaussian`.
    pub model: DiffractionModel,
    /// Add the equal-volume sphere's orders above `max_order` up to [`SPHERE_MAX_ORDER`].
    pub sphere_higher_orders: bool,
    /// Write the per-order and unfiltered channels after the contract's four.
    pub diagnostic_channels: bool,
    /// Replace the values at φ and 360° − φ by their mean.
    pub mirror_symmetrise: bool,
    /// Trace the azimuths 0°–180° only and copy them to 360° − φ.
    pub mirror_half: bool,
}

impl Table2dOptions {
    /// Channels per direction ([`n_channels_2d`]).
    pub fn channels(&self) -> usize {
        n_channels_2d(self.max_order + 1, self.diagnostic_channels)
    }

    /// Whether the caustic filter uses the airy-local transfer (and a trace reports the
    /// transfer weights of its columns).
    pub fn airy_local(&self) -> bool {
        self.diffraction_filter && self.model == DiffractionModel::AiryLocal
    }
}

/// The parts of a 2-D table that depend on the wavelength but not on the sun elevation: the
/// column filter (with its airy-local transfer) and the equal-volume sphere's higher orders.
pub struct WavelengthFields {
    filter: ColumnFilter,
    higher: Option<SphereHigherOrders>,
}

impl WavelengthFields {
    /// The fields of a drop of equal-volume radius `a_um` at `wavelength_nm` and index `n`.
    pub fn new(a_um: f64, wavelength_nm: f64, n: f64, opts: &Table2dOptions) -> Self {
        WavelengthFields {
            filter: column_filter(a_um, wavelength_nm, n, opts),
            higher: sphere_higher_orders(a_um, wavelength_nm, n, opts),
        }
    }
}

/// What [`WavelengthFields`] depend on: the equal-volume radius, the wavelength, the index and
/// the options that shape them (the polar grid, the filter, its model, the traced and added
/// orders), compared bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldsKey {
    a_um: u64,
    wavelength_nm: u64,
    n: u64,
    n_polar: usize,
    diffraction_filter: bool,
    model: DiffractionModel,
    max_order: usize,
    sphere_higher_orders: bool,
}

impl FieldsKey {
    /// The key of [`WavelengthFields::new`]`(a_um, wavelength_nm, n, opts)`.
    pub fn new(a_um: f64, wavelength_nm: f64, n: f64, opts: &Table2dOptions) -> Self {
        FieldsKey {
            a_um: a_um.to_bits(),
            wavelength_nm: wavelength_nm.to_bits(),
            n: n.to_bits(),
            n_polar: opts.grid.n_polar,
            diffraction_filter: opts.diffraction_filter,
            model: opts.model,
            max_order: opts.max_order,
            sphere_higher_orders: opts.sphere_higher_orders,
        }
    }
}

/// [`WavelengthFields`] shared by the 2-D entries that need the same ones: the sun elevations
/// of one table, and tables that differ only in the sun elevation (the rainbow database has one
/// table per radius, sun elevation and wavelength, and computes each radius and wavelength's
/// fields once instead of once per elevation). A slot is computed by the first task that asks
/// for it (the others wait for it); the cache keeps the `capacity` most recently requested
/// slots (the sphere's transfer on the rows about the bows and its higher orders on every row:
/// seven 2 mm tables of one wavelength at the thesis grid peaked at 2.70–2.83 GB with the cache,
/// 2.67–2.91 GB without). A value is the same whether it comes from the cache or not: the cache
/// saves time, never changes a table.
pub struct WavelengthCache {
    /// Most recently requested last.
    slots: Mutex<VecDeque<(FieldsKey, WavelengthSlot)>>,
    capacity: usize,
}

/// A wavelength's fields, computed once by whichever task gets there first.
type WavelengthSlot = Arc<OnceLock<Arc<WavelengthFields>>>;

/// Slots of the process's [`shared_wavelength_fields`]: more than the 33 wavelengths of a
/// colour table, so that a build that walks the sun elevations in its outer loop still finds
/// them.
const WAVELENGTH_CACHE_SLOTS: usize = 48;

impl WavelengthCache {
    /// An empty cache of `capacity` slots (at least one).
    pub fn new(capacity: usize) -> Self {
        WavelengthCache {
            slots: Mutex::new(VecDeque::new()),
            capacity: capacity.max(1),
        }
    }

    /// The fields of `key`, computed by `compute` unless a task already did (or is doing) so
    /// and the slot is still held.
    pub fn get(
        &self,
        key: FieldsKey,
        compute: impl FnOnce() -> WavelengthFields,
    ) -> Arc<WavelengthFields> {
        let slot = {
            let mut slots = self.slots.lock().unwrap_or_else(|e| e.into_inner());
            let held = slots.iter().position(|(k, _)| *k == key);
            let entry = match held.and_then(|i| slots.remove(i)) {
                Some(entry) => entry,
                None => (key, Arc::new(OnceLock::new())),
            };
            let slot = Arc::clone(&entry.1);
            slots.push_back(entry);
            if slots.len() > self.capacity {
                slots.pop_front();
            }
            slot
        };
        Arc::clone(slot.get_or_init(|| Arc::new(compute())))
    }
}

/// [`WavelengthFields::new`] through the process's [`WavelengthCache`].
pub fn shared_wavelength_fields(
    a_um: f64,
    wavelength_nm: f64,
    n: f64,
    opts: &Table2dOptions,
) -> Arc<WavelengthFields> {
    static SHARED: LazyLock<WavelengthCache> =
        LazyLock::new(|| WavelengthCache::new(WAVELENGTH_CACHE_SLOTS));
    SHARED.get(FieldsKey::new(a_um, wavelength_nm, n, opts), || {
        WavelengthFields::new(a_um, wavelength_nm, n, opts)
    })
}

/// One traced entry of a 2-D table.
pub struct Trace2d {
    /// Table values `[polar][azimuth][channel]`, divided by `cross_section_um2` (before any
    /// renormalisation of the table).
    pub values: Vec<f32>,
    /// The scattering cross-section σ = σ_GO + A (+ the added orders' σ), µm².
    pub cross_section_um2: f64,
    /// With the airy-local transfer: the weight of the transfer in each azimuth column
    /// `[primary, secondary]` (1: the sphere-validated transfer, 0: the Gaussian filter,
    /// between: blended; decision RT-33).
    pub domain_weights: Option<Vec<[f64; 2]>>,
}

/// Trace one (wavelength, sun elevation) entry of a 2-D table of `shape` with real index `n`:
/// trace (rayon over ray rows, then table rows), filter the caustic windows (rayon over azimuth
/// columns), normalise and write the channels (rayon over polar rows), mirror-symmetrise.
/// `fields` are [`WavelengthFields::new`] of the same drop, wavelength, index and options.
pub fn trace_table_2d(
    shape: &DropShape,
    wavelength_nm: f64,
    n: f64,
    elevation_deg: f64,
    opts: &Table2dOptions,
    fields: &WavelengthFields,
) -> Trace2d {
    let cfg = TraceConfig {
        rays: opts.rays,
        max_order: opts.max_order,
        sun_elevation_rad: elevation_deg.to_radians(),
        wavelength_nm,
        n,
        ray_grid: opts.ray_grid,
    };
    let (filter, higher) = (&fields.filter, fields.higher.as_ref());
    let f = if opts.mirror_half {
        trace_fields_mirror_half(shape, &cfg, opts.grid)
    } else {
        trace_fields(shape, &cfg, opts.grid)
    };
    let (windows, weights) = caustic_windows(&f, filter);
    let sigma_total = f.order_cross_section_um2.iter().sum::<f64>()
        + f.projected_area_um2
        + higher.map_or(0.0, |h| h.cross_section_um2);
    let nch = opts.channels();
    let mut out = write_channels(f, &windows, wavelength_nm, nch, higher);
    if opts.mirror_symmetrise && !opts.mirror_half {
        mirror_symmetrise(&mut out, opts.grid.n_azimuth, nch);
    }
    Trace2d {
        values: out,
        cross_section_um2: sigma_total,
        domain_weights: weights,
    }
}

/// A sphere's 2-D entry from the 1-D path (decision RT-43): a sphere scatters the same at every
/// azimuth about the incident direction and at every sun elevation, so the entry is the 1-D
/// sphere table's channels on the polar rows (bin averages of the orders up to
/// [`SPHERE_MAX_ORDER`] with the uniform caustic approximation, the axial focal-line phases,
/// the grazing waves and the forward lobe; at 0.4 mm within 0.53 % L2 of Lorenz–Mie over
/// 125–145° after the sun's disc, against 2.34 % for the traced sphere at 3000² rays)
/// repeated over the azimuths, with the 2-D layout of [`n_channels_2d`]: the per-order channels
/// `p0 … p_max` of `opts.max_order`, the higher orders in the totals as [`SphereHigherOrders`]
/// adds them to a trace. Every azimuth column is in the airy-local domain (weight 1). A 0.25 mm rainbow
/// database table took 14.6 s wall on one core traced at 3000² rays, 3.2 s so. Used for
/// `airy-local` tables (the default); the thesis's Gaussian filter keeps the tracer.
pub fn sphere_table_2d(
    radius_um: f64,
    wavelength_nm: f64,
    n: f64,
    opts: &Table2dOptions,
) -> Trace2d {
    let max_order = if opts.sphere_higher_orders {
        opts.max_order.max(SPHERE_MAX_ORDER)
    } else {
        opts.max_order
    };
    let grid = opts.grid;
    let (ch, sigma_total) = sphere_table_channels_and_cross_section(
        radius_um,
        wavelength_nm,
        n,
        &SphereTableOptions {
            max_order,
            step_deg: grid.polar_step().to_degrees(),
            angles: grid.n_polar,
            diffraction_filter: opts.diffraction_filter,
            model: DiffractionModel::AiryUniform,
        },
    );
    // 1-D layout: phase, i_perp, i_par, dolp, p0 … p_max, then the three unfiltered channels.
    let mut columns: Vec<&[f64]> = ch[..4].iter().map(Vec::as_slice).collect();
    if opts.diagnostic_channels {
        columns.extend(ch[4..=4 + opts.max_order].iter().map(Vec::as_slice));
        columns.extend(ch[ch.len() - 3..].iter().map(Vec::as_slice));
    }
    let (na, nch) = (grid.n_azimuth, opts.channels());
    assert_eq!(columns.len(), nch, "2-D channel layout");
    let mut values = vec![0f32; grid.n_polar * na * nch];
    values
        .par_chunks_mut(na * nch)
        .enumerate()
        .for_each(|(j, row)| {
            let pixel: Vec<f32> = columns.iter().map(|c| c[j] as f32).collect();
            for px in row.chunks_mut(nch) {
                px.copy_from_slice(&pixel);
            }
        });
    Trace2d {
        values,
        cross_section_um2: sigma_total,
        domain_weights: opts.airy_local().then(|| vec![[1.0, 1.0]; na]),
    }
}

/// The caustic filter of a 2-D entry's columns at one wavelength: the Gaussian diffraction
/// filter, split between the bows at the equal-volume sphere's mid-angle, with the sphere's
/// airy-local transfer when that model is on.
fn column_filter(a_um: f64, lambda: f64, n: f64, opts: &Table2dOptions) -> ColumnFilter {
    let grid = opts.grid;
    let go = SphereGo::new(a_um, lambda, n, 3);
    let split = 0.5
        * (go.rainbow_angle_rad(2).unwrap_or(PRIMARY_FALLBACK_RAD)
            + go.rainbow_angle_rad(3).unwrap_or(SECONDARY_FALLBACK_RAD));
    let filter = ColumnFilter::new(
        grid.n_polar,
        grid.polar_step(),
        filter_sigma_deg(a_um * 1e-3).to_radians(),
        split,
        opts.diffraction_filter,
    );
    if opts.airy_local() {
        // The traced orders p = 0 … max_order are the columns' channels.
        let transfer = sphere_airy_transfer(&go, &filter, grid.polar_step(), opts.max_order + 1);
        filter.with_airy_transfer(transfer)
    } else {
        filter
    }
}

/// The orders of the equal-volume sphere that a 2-D table adds to its traced ones (decision
/// RT-37): bin averages on the table's polar rows, the same at every azimuth.
pub struct SphereHigherOrders {
    /// dσ/dΩ (µm²/sr) per polar row, ⊥ and ∥.
    pub i_perp: Vec<f64>,
    pub i_par: Vec<f64>,
    /// Their scattering cross-section (µm²): the geometric-optics energy shares × πa², as the
    /// traced orders' σ_GO.
    pub cross_section_um2: f64,
}

/// [`SphereHigherOrders`] of a 2-D entry, or `None` when `sphere_higher_orders` is off or
/// `max_order` already reaches [`SPHERE_MAX_ORDER`].
fn sphere_higher_orders(
    a_um: f64,
    lambda: f64,
    n: f64,
    opts: &Table2dOptions,
) -> Option<SphereHigherOrders> {
    if !opts.sphere_higher_orders || opts.max_order >= SPHERE_MAX_ORDER {
        return None;
    }
    let grid = opts.grid;
    let orders = opts.max_order + 1..=SPHERE_MAX_ORDER;
    let go = SphereGo::new(a_um, lambda, n, SPHERE_MAX_ORDER);
    let step_deg = grid.polar_step().to_degrees();
    let angles: Vec<f64> = (0..grid.n_polar).map(|j| step_deg * j as f64).collect();
    let (i_perp, i_par) = sphere_order_intensities_1d(&go, orders.clone(), &angles, step_deg);
    let cross_section_um2 = orders.map(|p| go.energy_fraction(p)).sum::<f64>() * PI * a_um * a_um;
    Some(SphereHigherOrders {
        i_perp,
        i_par,
        cross_section_um2,
    })
}

/// The equal-volume sphere's Airy and GO channels on the rows the column filter needs, as
/// dσ/dΩ (µm²/sr) in the columns' layout `[i_perp, i_par, p0, …, p_{orders−1}]`.
fn sphere_airy_transfer(
    go: &SphereGo,
    filter: &ColumnFilter,
    step_rad: f64,
    orders: usize,
) -> AiryTransfer {
    let rows = filter.needed_rows();
    AiryTransfer::new(
        filter,
        rows,
        &sphere_columns(go, filter, step_rad, orders, true),
        &sphere_columns(go, filter, step_rad, orders, false),
    )
}

/// The sphere's channels on the rows [`ColumnFilter::needed_rows`] of `filter`, in the columns'
/// layout `[i_perp, i_par, p0, …, p_{orders−1}]` (dσ/dΩ, µm²/sr): Airy-uniform with
/// `diffraction_filter`, geometric optics without; orders the sphere does not have are zero.
fn sphere_columns(
    go: &SphereGo,
    filter: &ColumnFilter,
    step_rad: f64,
    orders: usize,
    diffraction_filter: bool,
) -> Vec<Vec<f64>> {
    let rows = filter.needed_rows();
    let angles: Vec<f64> = (rows.0..=rows.1)
        .map(|j| (step_rad * j as f64).to_degrees())
        .collect();
    let opts = Phase1dOptions {
        diffraction_filter,
        model: DiffractionModel::AiryUniform,
        ..Phase1dOptions::default()
    };
    let (ch, sigma_total) = sphere_phase_1d(go, &angles, opts);
    // 1-D layout: phase, i_perp, i_par, dolp, p0 … p_max, then the unfiltered channels.
    let scaled = |c: usize| ch[c].iter().map(|v| v * sigma_total).collect::<Vec<f64>>();
    let mut out = vec![scaled(1), scaled(2)];
    for p in 0..orders {
        out.push(if p <= go.max_order {
            scaled(4 + p)
        } else {
            vec![0.0; angles.len()]
        });
    }
    out
}

/// Index of the `dolp` channel (not an intensity: never renormalised).
pub const DOLP_CHANNEL: usize = 3;

/// Geometric primary and secondary bow angles used when the index admits no bow (rad).
const PRIMARY_FALLBACK_RAD: f64 = 2.4;
const SECONDARY_FALLBACK_RAD: f64 = 2.26;

/// Channels per pixel of a 2-D table with `orders` orders: phase, i_perp, i_par, dolp and, with
/// `diagnostic`, the per-order phases and the three unfiltered channels
/// ([`crate::raytrace::channel_names`]).
pub fn n_channels_2d(orders: usize, diagnostic: bool) -> usize {
    if diagnostic { 4 + orders + 3 } else { 4 }
}

/// Azimuth columns gathered together by [`map_columns`]: the rows of a block are read once,
/// with consecutive pixels of one order adjacent in memory.
const COLUMN_BLOCK: usize = 16;

/// The columns of a block as [`ColumnFilter`] takes them.
fn block_cols(block: &[Vec<Vec<f64>>]) -> Vec<&[Vec<f64>]> {
    block.iter().map(Vec::as_slice).collect()
}

/// `op(k0, block)` for every block of [`COLUMN_BLOCK`] azimuth columns `k0..k0 + block.len()`
/// for which `want(k0, k0 + block.len())` holds (the others give `R::default()` per column,
/// without reading the accumulators; rayon over blocks), concatenated, where `block[c]` holds
/// dσ/dΩ i_perp, i_par and per order of column `k0 + c` at polar rows `rows.0..=rows.1`. The accumulators are read row by row
/// within a block: reading one column at a time visits one pixel per row and order and misses
/// the caches at nearly every value.
fn map_columns<R: Send + Default + Clone>(
    f: &FieldGrid,
    rows: (usize, usize),
    want: impl Fn(usize, usize) -> bool + Sync,
    op: impl Fn(usize, &[Vec<Vec<f64>>]) -> Vec<R> + Sync,
) -> Vec<R> {
    let (orders, na) = (f.orders, f.n_columns);
    let zeros = vec![Complex32::new(0.0, 0.0); f.order_row_len()];
    (0..na.div_ceil(COLUMN_BLOCK))
        .into_par_iter()
        .flat_map_iter(|b| {
            let (k0, k1) = (b * COLUMN_BLOCK, ((b + 1) * COLUMN_BLOCK).min(na));
            if !want(k0, k1) {
                return vec![R::default(); k1 - k0];
            }
            let n = rows.1 + 1 - rows.0;
            let mut cols = vec![vec![Vec::with_capacity(n); 2 + orders]; k1 - k0];
            let mut per = vec![0.0; orders];
            let mut acc: Vec<&[Complex32]> = Vec::with_capacity(orders);
            for j in rows.0..=rows.1 {
                acc.clear();
                acc.extend((0..orders).map(|o| f.order_row(o, j).unwrap_or(&zeros)));
                for (k, c) in (k0..k1).zip(cols.iter_mut()) {
                    let px = acc.iter().map(|a| &a[k * 4..k * 4 + 4]);
                    let (ip, ipar) = pixel_intensities(px, &mut per);
                    c[0].push(ip);
                    c[1].push(ipar);
                    for (c, v) in c[2..].iter_mut().zip(&per) {
                        c.push(*v);
                    }
                }
            }
            op(k0, &cols)
        })
        .collect()
}

/// The filtered caustic window of every held azimuth column (rayon over blocks of columns) and,
/// with airy-local, the transfer weight of every azimuth column of the table: columns
/// of dσ/dΩ i_perp, i_par and per order over the rows the filter needs. With the airy-local
/// transfer, the columns' caustic positions are found first and smoothed over azimuth
/// (decision RT-28), then each column's bows are tested against the transfer's domain and the
/// flags turned into transfer weights smoothed over azimuth (decision RT-33): the transfer
/// where the caustic is the sphere's fold, moved and scaled, the Gaussian filter elsewhere.
fn caustic_windows(
    f: &FieldGrid,
    filter: &ColumnFilter,
) -> (Vec<CausticWindow>, Option<Vec<[f64; 2]>>) {
    let orders = f.orders;
    let rows = filter.needed_rows();
    let order = |o: usize| (o < orders).then_some(2 + o);
    let step_deg = f.grid.azimuth_step().to_degrees();
    let every = |_: usize, _: usize| true;
    if !filter.uses_fold_positions() {
        let windows = map_columns(f, rows, every, |_, block| {
            filter.filter_columns_at(rows, &block_cols(block), order(2), order(3), &[], &[])
        });
        return (windows, None);
    }
    let raw = map_columns(f, rows, every, |_, block| {
        let pos = |c: &Vec<Vec<f64>>| filter.fold_positions(rows, c, order(2), order(3));
        block.iter().map(pos).collect()
    });
    let na = f.grid.n_azimuth;
    let mut positions = smooth_over_azimuth(&over_full_circle(&raw, na), step_deg);
    positions.truncate(f.n_columns);
    let (mut windows, flags): (Vec<CausticWindow>, Vec<[bool; 2]>) =
        map_columns(f, rows, every, |k0, block| {
            let pos = &positions[k0..k0 + block.len()];
            filter
                .transfer_columns(rows, &block_cols(block), order(2), order(3), pos)
                .expect("a transfer: the filter uses fold positions")
        })
        .into_iter()
        .unzip();
    // Over every azimuth (what the table records); the held columns' part drives the blend.
    let all_weights = domain_weights(&over_full_circle(&flags, na), step_deg);
    let weights = &all_weights[..f.n_columns];
    let partial = |k0: usize, k1: usize| weights[k0..k1].iter().any(|w| w[0] < 1.0 || w[1] < 1.0);
    if partial(0, weights.len()) {
        // Only blocks with a column outside the domain are read again.
        let blended = map_columns(f, rows, partial, |k0, block| {
            let range = k0..k0 + block.len();
            filter
                .blend_with_gaussian(
                    rows,
                    &block_cols(block),
                    order(2),
                    order(3),
                    windows[range.clone()].to_vec(),
                    &weights[range],
                )
                .into_iter()
                .map(Some)
                .collect()
        });
        for (w, b) in windows.iter_mut().zip(blended) {
            if let Some(b) = b {
                *w = b;
            }
        }
    }
    (windows, Some(all_weights))
}

/// Per-column values `held` of a field grid's columns ([`FieldGrid::n_columns`]) over all `na`
/// azimuths: as they are for a whole trace, completed by the mirror image (column `na − k` is
/// column `k`) for a mirror-half one, so that smoothing over azimuth sees the columns on both
/// sides of φ = 0° and 180°.
fn over_full_circle<T: Clone>(held: &[T], na: usize) -> Vec<T> {
    (0..na)
        .map(|k| held.get(k).unwrap_or_else(|| &held[na - k]).clone())
        .collect()
}

/// The table values `[polar][azimuth][channel]` of one entry (rayon over polar rows): filtered
/// values inside each column's caustic window, unfiltered outside, plus the forward lobe of the
/// equal-area disc and, in all but the per-order channels, the sphere's higher orders
/// (`higher`), all divided by σ = σ_GO + A (+ the higher orders' σ). Consumes the accumulators
/// band by band (each band is released once its rows are written), so the accumulators and the
/// output are not held in full at the same time.
fn write_channels(
    mut f: FieldGrid,
    windows: &[CausticWindow],
    lambda: f64,
    nch: usize,
    higher: Option<&SphereHigherOrders>,
) -> Vec<f32> {
    let grid = f.grid;
    let (np, na, orders) = (grid.n_polar, grid.n_azimuth, f.orders);
    let nc = f.n_columns;
    let area = f.projected_area_um2;
    let a_eff = (area / PI).sqrt();
    let sigma_total: f64 = f.order_cross_section_um2.iter().sum::<f64>()
        + area
        + higher.map_or(0.0, |h| h.cross_section_um2);
    let dth = grid.polar_step();
    let (band_rows, order_row_len) = (f.band_rows, f.order_row_len());
    let mut out = vec![0f32; np * na * nch];
    let bands = std::mem::take(&mut f.bands);
    let reach = &f.reach;
    let zeros = vec![Complex32::new(0.0, 0.0); order_row_len];
    for (b, (band, out_band)) in bands
        .into_iter()
        .zip(out.chunks_mut(band_rows * na * nch))
        .enumerate()
    {
        let block = band.len() / orders;
        out_band
            .par_chunks_mut(na * nch)
            .enumerate()
            .for_each(|(jj, row)| {
                let j = b * band_rows + jj;
                // Each order's accumulators on this row (zeros outside the order's reach, whose
                // pages were never touched).
                let acc: Vec<&[Complex32]> = (0..orders)
                    .map(|o| match reach[o] {
                        Some((lo, hi)) if (lo..=hi).contains(&j) => {
                            let base = o * block + jj * order_row_len;
                            &band[base..base + order_row_len]
                        }
                        _ => &zeros[..],
                    })
                    .collect();
                let (lo, hi) = bin_edges(dth * j as f64, dth);
                let lobe = fraunhofer_bin_average(a_eff, lambda, lo, hi);
                let (hp, hl) = higher.map_or((0.0, 0.0), |h| (h.i_perp[j], h.i_par[j]));
                let mut per = vec![0.0; orders];
                let mut unf = vec![0.0; 2 + orders];
                for (k, px) in row.chunks_exact_mut(nch).take(nc).enumerate() {
                    let (ip_u, ipar_u) =
                        pixel_intensities(acc.iter().map(|a| &a[k * 4..k * 4 + 4]), &mut per);
                    unf[0] = ip_u;
                    unf[1] = ipar_u;
                    unf[2..].copy_from_slice(&per);
                    let filt = windows[k].get(j).unwrap_or(&unf);
                    let ip = (filt[0] + lobe + hp) / sigma_total;
                    let ipar = (filt[1] + lobe + hl) / sigma_total;
                    let ipu = (ip_u + lobe + hp) / sigma_total;
                    let iparu = (ipar_u + lobe + hl) / sigma_total;
                    let dolp = if ip + ipar > 0.0 {
                        (ip - ipar) / (ip + ipar)
                    } else {
                        0.0
                    };
                    let head = [0.5 * (ip + ipar), ip, ipar, dolp];
                    let tail = [0.5 * (ipu + iparu), ipu, iparu];
                    let per_order = filt[2..].iter().map(|v| v / sigma_total);
                    // The first `nch` of the channels (the contract's four without the
                    // diagnostic channels).
                    for (dst, v) in px
                        .iter_mut()
                        .zip(head.into_iter().chain(per_order).chain(tail))
                    {
                        *dst = v as f32;
                    }
                }
                // A mirror-half trace: column na − k is the mirror image of column k (the same
                // intensities, decision RT-34).
                for k in nc..na {
                    row.copy_within((na - k) * nch..(na - k + 1) * nch, k * nch);
                }
            });
        // `band` is dropped here: its accumulators return to the system before the next band.
    }
    out
}

/// Mirror symmetrisation φ ↔ 360° − φ of table values `[polar][azimuth][channel]` (rayon over
/// polar rows; decision RT-24): every channel but `dolp` of columns k and `na − k` is replaced
/// by the pair's mean and `dolp` is recomputed from the mean i_perp and i_par. Columns 0 and
/// na/2 (φ = 0°, 180°) are their own mirror images. The pair has equal solid angles, so
/// ∫ p dΩ is unchanged.
pub fn mirror_symmetrise(values: &mut [f32], na: usize, nch: usize) {
    values.par_chunks_mut(na * nch).for_each(|row| {
        for k in 1..na.div_ceil(2) {
            let (head, tail) = row.split_at_mut((na - k) * nch);
            let a = &mut head[k * nch..(k + 1) * nch];
            let b = &mut tail[..nch];
            for (c, (x, y)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
                if c != DOLP_CHANNEL {
                    let m = 0.5 * (*x as f64 + *y as f64);
                    (*x, *y) = (m as f32, m as f32);
                }
            }
            let (ip, ipar) = (a[1] as f64, a[2] as f64);
            let dolp = if ip + ipar > 0.0 {
                ((ip - ipar) / (ip + ipar)) as f32
            } else {
                0.0
            };
            a[DOLP_CHANNEL] = dolp;
            b[DOLP_CHANNEL] = dolp;
        }
    });
}

/// ∫ p dΩ over the table grid (bin-sum with exact bin solid angles) of channel 0 of one entry
/// `[polar][azimuth][channel]` with `nch` channels (rows summed in parallel, added in row order:
/// deterministic).
pub fn entry_integral_2d(values: &[f32], grid: DirectionGrid, nch: usize) -> f64 {
    let (np, na) = (grid.n_polar, grid.n_azimuth);
    let dth = grid.polar_step();
    let rows: Vec<f64> = (0..np)
        .into_par_iter()
        .map(|j| {
            let (lo, hi) = bin_edges(dth * j as f64, dth);
            let om = (lo.cos() - hi.cos()) * grid.azimuth_step();
            (0..na)
                .map(|k| values[(j * na + k) * nch] as f64 * om)
                .sum::<f64>()
        })
        .collect();
    rows.iter().sum()
}

/// Divide every intensity channel (all but `dolp`) of one entry with `nch` channels and rows
/// of `row_len` values by `s`.
pub fn divide_intensities(values: &mut [f32], row_len: usize, nch: usize, s: f64) {
    values.par_chunks_mut(row_len).for_each(|row| {
        for v in row.chunks_mut(nch) {
            for (c, x) in v.iter_mut().enumerate() {
                if c != DOLP_CHANNEL {
                    *x = (*x as f64 / s) as f32;
                }
            }
        }
    });
}

/// The azimuth average about the incident direction, per polar row, of the phase, i_perp and
/// i_par of one traced entry of `shape` (the values of [`trace_table_2d`], divided by the
/// entry's cross-section, not renormalised on the grid).
pub fn azimuth_mean_curves(
    shape: &DropShape,
    wavelength_nm: f64,
    n: f64,
    elevation_deg: f64,
    opts: &Table2dOptions,
) -> super::PhaseCurves {
    let fields = WavelengthFields::new(shape.radius_um(), wavelength_nm, n, opts);
    let t = trace_table_2d(shape, wavelength_nm, n, elevation_deg, opts, &fields);
    let (np, na, nch) = (opts.grid.n_polar, opts.grid.n_azimuth, opts.channels());
    let step_deg = 180.0 / (np - 1) as f64;
    let mean = |j: usize, c: usize| -> f64 {
        (0..na)
            .map(|k| t.values[(j * na + k) * nch + c] as f64)
            .sum::<f64>()
            / na as f64
    };
    super::PhaseCurves {
        angle_deg: (0..np).map(|j| step_deg * j as f64).collect(),
        phase: (0..np).map(|j| mean(j, 0)).collect(),
        i_perp: (0..np).map(|j| mean(j, 1)).collect(),
        i_par: (0..np).map(|j| mean(j, 2)).collect(),
    }
}

/// A drop-size mixture of traced 2-D entries of one (wavelength, sun elevation):
/// `p = Σ n_i σ_i p_i / Σ n_i σ_i` channel by channel over the radii `i` with number weights
/// `n_i` and cross-sections `σ_i`, `dolp` recomputed from the mixed `i_perp` and `i_par`.
#[derive(Debug, Clone, Default)]
pub struct SizeMix {
    acc: Vec<f64>,
    total: f64,
}

impl SizeMix {
    /// Add the entry `values` (divided by its cross-section `sigma`, as [`Trace2d::values`])
    /// of a radius of number weight `number_weight`.
    pub fn add(&mut self, number_weight: f64, values: &[f32], sigma: f64) {
        let w = number_weight * sigma;
        if self.acc.is_empty() {
            self.acc = vec![0.0; values.len()];
        }
        for (a, v) in self.acc.iter_mut().zip(values) {
            *a += w * *v as f64;
        }
        self.total += w;
    }

    /// The mixed values with `nch` channels per direction, or `Err(Σ n_i σ_i)` when that is not
    /// positive and finite.
    pub fn finish(self, nch: usize) -> Result<Vec<f32>, f64> {
        let total = self.total;
        if !(total > 0.0 && total.is_finite()) {
            return Err(total);
        }
        let mut out: Vec<f32> = self.acc.iter().map(|a| (a / total) as f32).collect();
        for px in out.chunks_exact_mut(nch) {
            let (ip, ipar) = (px[1] as f64, px[2] as f64);
            px[DOLP_CHANNEL] = if ip + ipar > 0.0 {
                ((ip - ipar) / (ip + ipar)) as f32
            } else {
                0.0
            };
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fields are computed once for all the requests of one key (concurrent ones wait), again
    /// for another wavelength or index, and again once the slot has left the cache.
    #[test]
    fn wavelength_fields_are_computed_once_per_key() {
        let cache = WavelengthCache::new(2);
        let computed = std::sync::atomic::AtomicUsize::new(0);
        let fields = || {
            computed.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            WavelengthFields {
                filter: ColumnFilter::new(10, 0.1, 0.01, 0.5, false),
                higher: None,
            }
        };
        let count = || computed.load(std::sync::atomic::Ordering::SeqCst);
        let opts = Table2dOptions {
            rays: 10,
            ray_grid: RayGridLayout::Silhouette,
            max_order: 3,
            grid: DirectionGrid {
                n_polar: 11,
                n_azimuth: 4,
            },
            diffraction_filter: true,
            model: DiffractionModel::AiryLocal,
            sphere_higher_orders: true,
            diagnostic_channels: false,
            mirror_symmetrise: true,
            mirror_half: false,
        };
        let key = |lambda: f64, n: f64| FieldsKey::new(1000.0, lambda, n, &opts);
        (0..4).into_par_iter().for_each(|_| {
            cache.get(key(550.0, 1.333), fields);
        });
        assert_eq!(count(), 1);
        cache.get(key(550.0, 1.333), fields);
        assert_eq!(count(), 1, "a held slot is computed again");
        cache.get(key(550.0, 1.334), fields);
        cache.get(key(650.0, 1.333), fields);
        assert_eq!(count(), 3);
        // Two slots: 550 nm at 1.333 was the least recently requested and has left.
        cache.get(key(550.0, 1.333), fields);
        assert_eq!(count(), 4);
        cache.get(key(650.0, 1.333), fields);
        assert_eq!(count(), 4);
    }

    /// The airy-local domain (decision RT-33) on columns whose caustics are known: the
    /// sphere's own GO columns are in it for both bows; a caustic three times weaker than the
    /// sphere's is not (strength); a column whose `i_perp`, `i_par` do not carry the caustic its
    /// order channel shows is not (the transfer would drive them negative).
    #[test]
    fn airy_domain_holds_on_the_sphere_and_not_on_foreign_caustics() {
        let go = SphereGo::new(400.0, 650.0, 1.331, 3);
        let step = 0.0125f64.to_radians();
        let split = 0.5 * (go.rainbow_angle_rad(2).unwrap() + go.rainbow_angle_rad(3).unwrap());
        let filter =
            ColumnFilter::new(14401, step, filter_sigma_deg(0.4).to_radians(), split, true);
        let transfer = sphere_airy_transfer(&go, &filter, step, 4);
        let filter = filter.with_airy_transfer(transfer);
        let rows = filter.needed_rows();
        let domain = |cols: &[Vec<f64>]| {
            let pos = filter.fold_positions(rows, cols, Some(4), Some(5));
            filter.airy_domain(rows, cols, Some(4), Some(5), pos)
        };
        let sphere = sphere_columns(&go, &filter, step, 4, false);
        assert_eq!(domain(&sphere), [true, true]);
        let scaled = |f: &dyn Fn(usize) -> f64| -> Vec<Vec<f64>> {
            sphere
                .iter()
                .enumerate()
                .map(|(c, v)| v.iter().map(|x| x * f(c)).collect())
                .collect()
        };
        assert_eq!(domain(&scaled(&|_| 0.3)), [false, false]);
        assert_eq!(
            domain(&scaled(&|c| if c < 2 { 0.01 } else { 1.0 })),
            [false, false]
        );
        // Without a transfer (the gaussian model) no column is in the domain.
        let plain = ColumnFilter::new(14401, step, 0.001, split, true);
        assert_eq!(
            plain.airy_domain(rows, &sphere, Some(4), Some(5), [None, None]),
            [false, false]
        );
    }

    /// A sphere's entry from the 1-D path against the 2-D tracer on the same sphere (an
    /// independent computation: rays, patches and the airy-local transfer): the same channels at
    /// every azimuth, the same cross-section, and the azimuth-mean phase within the tracer's
    /// ray noise in 1° bins, over the sphere and over the bows.
    #[test]
    fn a_sphere_entry_from_the_1d_path_matches_the_tracer() {
        let (a, lambda, n) = (250.0, 520.0, 1.3350);
        let opts = Table2dOptions {
            rays: 500,
            ray_grid: RayGridLayout::Silhouette,
            max_order: 3,
            grid: DirectionGrid {
                n_polar: 3601,
                n_azimuth: 36,
            },
            diffraction_filter: true,
            model: DiffractionModel::AiryLocal,
            sphere_higher_orders: true,
            diagnostic_channels: true,
            mirror_symmetrise: true,
            mirror_half: false,
        };
        let shape = DropShape::Sphere { radius_um: a };
        let one_d = sphere_table_2d(a, lambda, n, &opts);
        let fields = WavelengthFields::new(a, lambda, n, &opts);
        let traced = trace_table_2d(&shape, lambda, n, 23.0, &opts, &fields);
        let (np, na, nch) = (3601, 36, opts.channels());
        assert_eq!(one_d.values.len(), traced.values.len());
        for j in (0..np).step_by(97) {
            let first = &one_d.values[j * na * nch..][..nch];
            for k in 1..na {
                assert_eq!(&one_d.values[(j * na + k) * nch..][..nch], first);
            }
        }
        let sigma_ratio = one_d.cross_section_um2 / traced.cross_section_um2;
        assert!((sigma_ratio - 1.0).abs() < 2e-3, "σ ratio {sigma_ratio}");
        assert_eq!(one_d.domain_weights, Some(vec![[1.0, 1.0]; na]));
        // Azimuth-mean phase × solid angle in 1° bins (20 rows each).
        let binned = |v: &[f32]| -> Vec<f64> {
            (0..180)
                .map(|b| {
                    (20 * b..20 * b + 20)
                        .map(|j| {
                            let th = (j as f64 * 0.05).to_radians();
                            let mean = (0..na).map(|k| v[(j * na + k) * nch] as f64).sum::<f64>();
                            mean / na as f64 * th.sin()
                        })
                        .sum()
                })
                .collect()
        };
        let (p1, p2) = (binned(&one_d.values), binned(&traced.values));
        let l2 = |r: std::ops::Range<usize>| {
            let d: f64 = r.clone().map(|b| (p1[b] - p2[b]).powi(2)).sum();
            let s: f64 = r.map(|b| p2[b].powi(2)).sum();
            (d / s).sqrt()
        };
        let (all, bows) = (l2(0..180), l2(125..145));
        eprintln!("L2 all {all:.4}, bows {bows:.4}");
        assert!(all < 0.02 && bows < 0.05, "L2 all {all}, bows {bows}");
    }
}
