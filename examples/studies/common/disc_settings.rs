//! `DiscSettings` with the overrides of the disc examples' environment variables: DISC_CPM,
//! DISC_RINGS, DISC_ARC, DISC_INTERIOR, DISC_GROWTH, DISC_MAX_CELL, DISC_DIRECTIONS, DISC_TRACK,
//! DISC_TOL, DISC_LINEAR (0 = flat source).
use scatterbake::fur::disc::DiscSettings;

/// The default settings with every override that is set applied.
pub fn disc_settings_from_env() -> DiscSettings {
    let mut s = DiscSettings::default();
    let env = |k: &str| {
        std::env::var(k).ok().map(|v| {
            v.parse::<f64>()
                .unwrap_or_else(|_| panic!("{k}={v}: not a number"))
        })
    };
    let fields: [(&str, &mut f64); 8] = [
        ("DISC_CPM", &mut s.cells_per_mean_free_path),
        ("DISC_RINGS", &mut s.boundary_rings_per_mean_free_path),
        ("DISC_ARC", &mut s.arc_ratio),
        ("DISC_INTERIOR", &mut s.interior_cell_mean_free_paths),
        ("DISC_GROWTH", &mut s.ring_growth),
        ("DISC_MAX_CELL", &mut s.max_cell),
        ("DISC_TRACK", &mut s.track_spacing),
        ("DISC_TOL", &mut s.tolerance),
    ];
    for (key, field) in fields {
        if let Some(v) = env(key) {
            *field = v;
        }
    }
    if let Some(v) = env("DISC_DIRECTIONS") {
        s.directions = v as usize;
    }
    if let Some(v) = env("DISC_LINEAR") {
        s.linear_source = v != 0.0;
    }
    s
}
