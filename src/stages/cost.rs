//! The cost model behind `scatterbake build --plan`: CPU seconds per unit of work of each
//! stage, on one core of the reference machine (the 2-core development host, release build),
//! fitted to the CPU time of measured tasks (`cargo run --release --example task_cost`), and
//! the stored fraction of the uncompressed payload per table family. docs/pipeline.md
//! ("Planning a build") lists the measurements and how far the estimates are from them.
//!
//! These figures size a cluster job; they are not a promise. Each stage's
//! [`Job::estimated_cpu_seconds`](crate::stages::Job::estimated_cpu_seconds) combines them with
//! the work it plans (spheres × series terms × angles, rays and directions, photons, …).

/// Lorenz–Mie or Debye sphere: CPU seconds per series term per angle of the intermediate grid
/// (`rainbow-mie`: 11 radii 5–1000 µm × 33 wavelengths, 94.6 s).
pub const MIE_CPU_S_PER_TERM_ANGLE: f64 = 4.0e-9;
/// Debye split: CPU of a Debye sphere relative to a Lorenz–Mie one of the same size and grid,
/// with the default four orders, each summed on its own (`debye-100um`: 0.26 s).
pub const DEBYE_COST_FACTOR: f64 = 5.0;
/// Traced sphere of a mixture (1-D exact path, orders up to 6), per radius and wavelength
/// (a Marshall–Palmer 50–2000 µm mixture at 550 nm: 9.4 s).
pub const TRACED_SPHERE_CPU_S: f64 = 0.7;
/// Ray-traced sphere (1-D exact path; its internal grid has a step ≤ λ/(10a)), per task and
/// unit of radius (µm) over wavelength (nm) (`raytrace-sphere-0.4mm` 0.28, a 0.3/1 mm test
/// table 0.30).
pub const SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH: f64 = 0.29;
/// 2-D patch tracer: per table (drop shape and set-up), then per task per size unit (radius
/// in mm × 550 nm / λ: diffraction lobe and filters), per ray traced, and per direction
/// computed (rasterised). A least-squares fit of relative error to eight tables (400²–3000²
/// rays, 0.0125°–0.1° × 0.2°–10° grids, 0.4–3 mm, 1–18 tasks), which it reproduces to within
/// a factor 0.71–1.29.
pub const RAYTRACE_2D_COST: [f64; 4] = [0.50, 0.47, 1.73e-6, 5.4e-7];
/// 2-D table of a sphere from the 1-D path (airy-local; decision RT-43), per task: the 1-D
/// sphere ([`SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH`]) plus this per direction of the dense
/// grid (spreading it over the azimuths, the bin-sum and, in compact tables, the sun's disc and
/// the knot search): a one-entry rainbow-database table of a 0.25 mm drop, 3.2 s of CPU over
/// 14401 × 1800 directions.
pub const RAYTRACE_2D_SPHERE_CPU_S_PER_DIRECTION: f64 = 1.2e-7;
/// Compact 2-D tables: the trace's estimate times this for the sun's disc, the knot search and
/// the measured errors. The rainbow database's stratified sample (77 one-entry tables, 3000²
/// rays, thesis grid, `rms`, top16 with 7 mantissa bits) took 2157 s of CPU (user and system,
/// two shards of one core) against 1835 s estimated for the traces alone: 1.18. Since the
/// cheaper intersections of raytrace stage version 14, eleven of these tables (one per radius)
/// took 229.8 s against 277.7 s with the code before, one build after the other:
/// 1.18 × 229.8/277.7 = 0.98. Since the rays are traced eight at a time (raytrace stage
/// version 15, same payloads), the same eleven tables took 193.7 and 211.6 s against 220.9 and
/// 239.6 s in two pairs alternating the order (0.98 × 405.3/460.5 = 0.86), and the whole sample
/// 1252.7 s of CPU (`--jobs 2`, one process, 10 min 30 s wall) against 1461.5 s planned with
/// 0.86, of which 22.8 s for its seven sphere tables: 0.86 × (1252.7 − 22.8)/(1461.5 − 22.8)
/// = 0.74. The machine's speed drifts by up to 30 % within hours, which bounds this figure.
pub const RAYTRACE_2D_COMPACT_CPU_FACTOR: f64 = 0.74;
/// Analog medulla Monte Carlo: one photon history at σ = 0 (× (1 + σ)); azimuthal 2.7e-5 and
/// longitudinal 4.3e-5 measured.
pub const MEDULLA_PHOTON_CPU_S: f64 = 3.3e-5;
/// Adaptive next-event medulla Monte Carlo relative to the analog one at its photon cap
/// (it stops early once its error target is met).
pub const MEDULLA_ADAPTIVE_COST_FACTOR: f64 = 0.18;
/// Method of characteristics: one plane-wave solve of a (σ, g) at σ = 0 (× (1 + σ)); the
/// default azimuthal table (9 σ × 5 g) 7.1 s.
pub const MEDULLA_DISC_SOLVE_CPU_S: f64 = 0.048;
/// Adding–doubling slab: one (σ, g, θ'_i); the default longitudinal table (9 σ × 5 g × 12 θ'_i)
/// 8.6 s.
pub const MEDULLA_SLAB_SOLVE_CPU_S: f64 = 0.016;
/// Fur far field: one fibre path per √(θ_r cells × φ cells); 6.3e-7 and 6.6e-7 measured.
pub const FARFIELD_PATH_CELL_CPU_S: f64 = 6.5e-7;
/// Hair rows: per table (quadrature set-up) and per value (both quadrature resolutions).
pub const HAIR_CPU_S: [f64; 2] = [0.06, 1.5e-6];
/// Cloth BRDF: one value (1.9e-6–3.0e-6 over the six default fabrics).
pub const CLOTH_VALUE_CPU_S: f64 = 2.2e-6;
/// Water index: one value.
pub const WATER_INDEX_VALUE_CPU_S: f64 = 1e-6;

/// Header `attributes` of a table, pretty-printed: the stage's conventions, models and
/// validated domain.
pub const ATTRIBUTE_BYTES: u64 = 2800;
/// Header bytes of one per-task or per-entry number recorded in the attributes.
pub const ATTRIBUTE_BYTES_PER_SCALAR: u64 = 30;
/// Header bytes of the Monte Carlo statistics of one medulla (σ, g, entry).
pub const MEDULLA_ATTRIBUTE_BYTES_PER_ENTRY: u64 = 80;

// Stored fractions (compressed payload / uncompressed) measured on the default build.
/// `cloth` (linear RGB BRDF and CDFs): 0.665–0.697 over the six default tables.
pub const STORED_FRACTION_CLOTH: f64 = 0.69;
/// `debye`: 0.953 (`debye-100um`).
pub const STORED_FRACTION_DEBYE: f64 = 0.95;
/// `fur-farfield`: 0.285, 0.296.
pub const STORED_FRACTION_FARFIELD: f64 = 0.29;
/// `fur-medulla-azimuthal`, method of characteristics: 0.258.
pub const STORED_FRACTION_MEDULLA_AZIMUTHAL: f64 = 0.26;
/// `fur-medulla-longitudinal`, adding–doubling: 0.508.
pub const STORED_FRACTION_MEDULLA_LONGITUDINAL: f64 = 0.51;
/// `fur-medulla-azimuthal`, Monte Carlo (noisy bins): ≈ 0.6 at 2000 photons.
pub const STORED_FRACTION_MEDULLA_AZIMUTHAL_MC: f64 = 0.6;
/// `fur-medulla-azimuthal`, adaptive Monte Carlo: ≈ 0.9.
pub const STORED_FRACTION_MEDULLA_ADAPTIVE: f64 = 0.9;
/// `fur-medulla-longitudinal`, Monte Carlo: ≈ 0.66 at 2000 photons.
pub const STORED_FRACTION_MEDULLA_LONGITUDINAL_MC: f64 = 0.66;
/// `hair-dual`, physically based: 0.363 (look-up table) to 0.451 (three colours).
pub const STORED_FRACTION_HAIR_DUAL: f64 = 0.42;
/// `hair-dual`, artist-friendly model: 0.839.
pub const STORED_FRACTION_HAIR_DUAL_ARTIST: f64 = 0.84;
/// `hair-azimuthal`: 0.573.
pub const STORED_FRACTION_HAIR_AZIMUTHAL: f64 = 0.57;
/// `mie` and `mixture` (f32 phase functions without repeats): 0.937 (`rainbow-mie`).
pub const STORED_FRACTION_MIE: f64 = 0.94;
/// `raytrace` spheres: 0.777 (`raytrace-sphere-0.4mm`).
pub const STORED_FRACTION_RAYTRACE_SPHERE: f64 = 0.78;
/// `raytrace` 2-D shapes with the diagnostic channels (per-order channels, mostly zero where
/// an order does not reach): 0.309–0.328 (the default Beard–Chuang tables).
pub const STORED_FRACTION_RAYTRACE_2D_DIAGNOSTIC: f64 = 0.32;
/// `raytrace` 2-D shapes, the four contract channels only.
pub const STORED_FRACTION_RAYTRACE_2D: f64 = 0.66;
/// `raytrace` compact 2-D tables (`compression`, tolerance 0.01, thesis grid), stored bytes
/// over the dense grid's payload (the plan's upper bound, 414.7 MB for the four f32 channels
/// of 14401 × 1800 directions), for Beard–Chuang drops, which most entries of a database are
/// (docs/raytrace.md, "Compact tables"; mirror symmetric entries store 0°–180° of azimuth):
/// `norm = "max"` 0.144–0.156 (1.25 mm, 520 nm, sun 0°; 2 mm, 420 nm, sun 20°; 3000² rays).
pub const STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX: f64 = 0.15;
/// As [`STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX`] for `norm = "rms"`: 0.0386–0.0428.
pub const STORED_FRACTION_RAYTRACE_2D_COMPACT_RMS: f64 = 0.041;
/// Compact 2-D tables of spheres (Beard–Chuang drops ≤ 0.4 mm), f32: measured on full-circle
/// entries, `norm = "max"` 0.0009–0.0020 (0.4 mm, 650 nm, sun 0°; 0.3 mm, 450 nm, sun 20°),
/// `rms` 0.0001 (0.4 mm); the larger (the half circle stores less: an upper bound).
pub const STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE: f64 = 0.002;
/// Compact 2-D tables of drops with `values = "top16"` (i_perp and i_par as 16-bit codes,
/// phase and dolp derived) and all 8 mantissa bits, `norm = "rms"`, tolerance 0.01, thesis
/// grid, 3000² rays, calibrated on the 70 drops of the rainbow database's stratified sample
/// (`manifests/full/rainbow-database-sample.toml`, 7 mantissa bits: 47.77 MB written, with the
/// plan's header estimate, which lists the knots the header will hold), divided by
/// [`STORED_RATIO_TOP16_PER_MANTISSA_BIT`]. Checked on 248 drop tables of the database itself
/// built later (docs/raytrace.md, "Compact tables"). With 8 bits the four held-out drops
/// (0.75 mm 480 nm sun 40°, 1.25 mm 520 nm sun 0°, 2 mm 420 nm sun 20°, 3 mm 700 nm sun 60°)
/// stored 0.00168–0.00293 of their dense grid (0.698, 1.216, 1.034, 0.723 MB of payload).
pub const STORED_FRACTION_RAYTRACE_2D_COMPACT_TOP16: f64 = 0.00179;
/// The payload of a `top16` table with one mantissa bit fewer, over that with all 8: 0.838
/// for 7 bits on the same four drops (0.551, 1.012, 0.884, 0.628 MB, i.e. 0.00133–0.00244 of
/// the dense grid); fewer bits are estimated with this factor per bit (not measured).
pub const STORED_RATIO_TOP16_PER_MANTISSA_BIT: f64 = 0.84;
/// As [`STORED_FRACTION_RAYTRACE_2D_COMPACT_TOP16`] for spheres (drops ≤ 0.4 mm), whose
/// compact tables keep two azimuth knots: calibrated on 152 tables of 0.25 mm spheres of the
/// rainbow database (7 mantissa bits: 3.37 KB of payload on average, 41.1 KB of header), with
/// the plan's header estimate, divided by [`STORED_RATIO_TOP16_PER_MANTISSA_BIT`]. The
/// held-out 0.25 mm, 380 nm, sun 50° entry stored 3016 bytes (8 bits; 2843 with 7).
pub const STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE_TOP16: f64 = 0.0000115;
/// `top16` with `norm = "max"` (not measured): the f32 `max` fraction scaled by the top16/f32
/// ratio measured with `rms`.
pub const STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX_TOP16: f64 =
    STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX * STORED_FRACTION_RAYTRACE_2D_COMPACT_TOP16
        / STORED_FRACTION_RAYTRACE_2D_COMPACT_RMS;
/// Polar knots of one compact ray-traced entry (tolerance 0.01, `rms`, thesis grid, 3000²
/// rays), for the plan's estimate of the header that lists them: 1228 on average over 144
/// tables of 0.25 mm spheres and 1231 over 93 tables of 1.5 mm drops of the rainbow database;
/// 937–1268 per radius (means) in its stratified sample.
pub const RAYTRACE_2D_COMPACT_POLAR_KNOTS: usize = 1230;
/// Header `attributes` of a compact ray-traced table, pretty-printed (they summarise the
/// transfer weights instead of listing one per azimuth column): 9.25–9.27 KB for those
/// spheres, 9.70–10.18 KB for those drops.
pub const RAYTRACE_2D_COMPACT_ATTRIBUTE_BYTES: u64 = 9600;
/// `water-index`: 0.756.
pub const STORED_FRACTION_WATER_INDEX: f64 = 0.76;
