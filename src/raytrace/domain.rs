//! The domain of the ray tracer, checked in one place by the `raytrace` stage and the
//! `scatterbake raytrace` command: the drop radii where geometric optics plus phase holds, the
//! ray-grid sizes the tracer accepts and the sun elevations it is defined for. Each check
//! returns the reason a value is outside, for the caller to attach to its key or option.

/// Equal-volume drop radii (µm) of the validated domain: x = 2πa/λ ≳ 90 at 700 nm (geometric
/// optics needs x ≫ 1) up to the largest raindrops.
pub const RADIUS_UM: std::ops::RangeInclusive<f64> = 10.0..=5000.0;
/// Rays per side of the ray grid.
pub const RAYS_PER_SIDE: std::ops::RangeInclusive<usize> = 8..=20_000;
/// Sun elevation above the horizon (degrees).
pub const SUN_ELEVATION_DEG: std::ops::RangeInclusive<f64> = 0.0..=90.0;

/// `Err(why)` unless `radius_um` lies in [`RADIUS_UM`].
pub fn check_radius_um(radius_um: f64) -> Result<(), String> {
    if RADIUS_UM.contains(&radius_um) {
        Ok(())
    } else {
        Err(format!(
            "{radius_um} µm is outside 10–5000 µm (geometric optics needs x ≫ 1)"
        ))
    }
}

/// `Err(why)` unless `rays` lies in [`RAYS_PER_SIDE`].
pub fn check_rays(rays: usize) -> Result<(), String> {
    if RAYS_PER_SIDE.contains(&rays) {
        Ok(())
    } else {
        Err(format!("{rays} is outside 8–20000"))
    }
}

/// `Err(why)` unless `elevation_deg` lies in [`SUN_ELEVATION_DEG`].
pub fn check_sun_elevation_deg(elevation_deg: f64) -> Result<(), String> {
    if SUN_ELEVATION_DEG.contains(&elevation_deg) {
        Ok(())
    } else {
        Err(format!("{elevation_deg}° is outside 0–90°"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_domain_edges_are_inside_and_beyond_them_is_refused() {
        assert!(check_radius_um(10.0).is_ok() && check_radius_um(5000.0).is_ok());
        assert!(
            check_radius_um(9.99)
                .unwrap_err()
                .contains("outside 10–5000 µm")
        );
        assert!(check_radius_um(f64::NAN).is_err());
        assert!(check_rays(8).is_ok() && check_rays(20_000).is_ok());
        assert!(check_rays(7).is_err() && check_rays(20_001).is_err());
        assert!(check_sun_elevation_deg(0.0).is_ok() && check_sun_elevation_deg(90.0).is_ok());
        assert!(
            check_sun_elevation_deg(-0.1).is_err() && check_sun_elevation_deg(f64::NAN).is_err()
        );
    }
}
