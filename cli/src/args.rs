//! Options and value parsers shared by several commands: the refractive index (`mie`, `airy`,
//! `raytrace`, `validate`), scattering-angle ranges (`mie`, `raytrace`) and library enums named
//! on the command line.

use anyhow::bail;
use scatterbake::optics::water::WaterIndexModel;

/// Largest number of angles a single query may ask for.
pub const MAX_ANGLES: usize = 10_000_000;

/// A clap value parser for a library enum that names its variants (`NAMES`) and parses them
/// (`FromStr`): `--help` lists the names and a wrong one is refused with the list.
pub fn named<T>(names: &'static [&'static str]) -> impl clap::builder::TypedValueParser<Value = T>
where
    T: std::str::FromStr + Clone + Send + Sync + 'static,
    T::Err: std::fmt::Display,
{
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(names)
        .try_map(|s| s.parse::<T>().map_err(|e| e.to_string()))
}

/// The index of the table wavelength nearest `asked_nm`, for options documented as "nearest
/// table wavelength": when that is not the wavelength asked for, a note on stderr says which one
/// is used, so the value is never changed silently.
pub fn nearest_wavelength(wavelengths_nm: &[f64], asked_nm: f64) -> usize {
    let mut best = 0;
    for (k, &w) in wavelengths_nm.iter().enumerate() {
        if (w - asked_nm).abs() < (wavelengths_nm[best] - asked_nm).abs() {
            best = k;
        }
    }
    let used = wavelengths_nm[best];
    if (used - asked_nm).abs() > 1e-9 * asked_nm.abs().max(1.0) {
        eprintln!(
            "note: --wavelength-nm {asked_nm}: the table has no such wavelength; using the nearest, {used} nm (table wavelengths {wavelengths_nm:?} nm)"
        );
    }
    best
}

/// Parse `N+Ki`, `N-Ki` (refused: k must be ≥ 0) or `N`.
pub fn parse_complex_index(s: &str) -> Result<(f64, f64), String> {
    let t = s.trim().replace(' ', "");
    let bad = || format!("`{s}` is not a refractive index of the form N+Ki (e.g. 1.55+0.002i)");
    let (n, k) = match t.strip_suffix(['i', 'j']) {
        Some(body) => {
            // Split at the last sign that is not an exponent sign.
            let bytes = body.as_bytes();
            let pos = (1..bytes.len())
                .rev()
                .find(|&i| matches!(bytes[i], b'+' | b'-') && !matches!(bytes[i - 1], b'e' | b'E'))
                .ok_or_else(bad)?;
            let n: f64 = body[..pos].parse().map_err(|_| bad())?;
            let k: f64 = body[pos..]
                .trim_start_matches('+')
                .parse()
                .map_err(|_| bad())?;
            (n, k)
        }
        None => (t.parse().map_err(|_| bad())?, 0.0),
    };
    if !(n > 0.0) || !n.is_finite() {
        return Err(format!("real part {n} of `{s}` must be positive"));
    }
    if !(k >= 0.0) || !k.is_finite() {
        return Err(format!(
            "imaginary part {k} of `{s}` must be ≥ 0 (absorbing convention m = n + ik, e^(-iωt))"
        ));
    }
    Ok((n, k))
}

/// Scattering angles `START:STOP:STEP` in degrees (`--angles`): `0 ≤ START ≤ STOP ≤ 180`,
/// `STEP > 0`, at most [`MAX_ANGLES`] angles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AngleRange {
    pub start: f64,
    pub stop: f64,
    pub step: f64,
}

impl AngleRange {
    /// Parses `START:STOP:STEP` (the clap value parser of every `--angles`).
    pub fn parse(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}` is not START:STOP:STEP in degrees (e.g. 0:180:0.05)");
        let v: Vec<f64> = s
            .split(':')
            .map(|p| p.trim().parse::<f64>().map_err(|_| bad()))
            .collect::<Result<_, _>>()?;
        let [start, stop, step] = v[..] else {
            return Err(bad());
        };
        if !(0.0..=180.0).contains(&start) || !(0.0..=180.0).contains(&stop) || !(stop >= start) {
            return Err(format!("`{s}`: need 0 ≤ START ≤ STOP ≤ 180"));
        }
        if !(step > 0.0) || (stop - start) / step > MAX_ANGLES as f64 {
            return Err(format!(
                "`{s}`: STEP must be > 0 and give at most {MAX_ANGLES} angles"
            ));
        }
        // STOP is an angle of the range: a STEP that does not reach it would end the range
        // elsewhere without saying so.
        let intervals = (stop - start) / step;
        if (intervals - intervals.round()).abs() > 1e-6 {
            let last = ((start + intervals.floor() * step) * 1e9).round() / 1e9;
            return Err(format!(
                "`{s}`: STEP {step} does not divide STOP − START = {}: the last angle would be \
                 {last}, not {stop}",
                stop - start
            ));
        }
        Ok(AngleRange { start, stop, step })
    }

    /// The whole range 0–180° in steps of `step`, which must divide 180 (`--angle-step-deg`,
    /// and the grids of the tables).
    pub fn full(step: f64) -> anyhow::Result<Self> {
        let count = 180.0 / step;
        if step.is_nan() || step <= 0.0 || (count - count.round()).abs() > 1e-6 {
            bail!("the angle step {step}° must divide 180");
        }
        if count > MAX_ANGLES as f64 {
            bail!("the angle step {step}° gives more than {MAX_ANGLES} angles");
        }
        Ok(AngleRange {
            start: 0.0,
            stop: 180.0,
            step,
        })
    }

    /// The angles START, START + STEP, … up to STOP (inclusive, to 1e-9 steps).
    pub fn angles(&self) -> Vec<f64> {
        let count = ((self.stop - self.start) / self.step + 1e-6).floor() as usize + 1;
        (0..count)
            .map(|i| self.start + self.step * i as f64)
            .collect()
    }
}

/// Refractive-index options of every command that takes an index (`mie`, `airy`, `raytrace`):
/// an explicit relative index, or water at the wavelength from a named model (IAPWS R9-97 by
/// default, or Table 3.2 of Sadeghi 2012 as `sadeghi-table-3.2`), the names and defaults of the
/// manifest keys `water_index_model` and `temperature_c`.
#[derive(Debug, Clone, clap::Args)]
pub struct IndexArgs {
    /// Relative complex refractive index as `N+Ki` (e.g. `1.55+0.002i`, or `1.333`); the same
    /// as `--n N --k K`.
    #[arg(long, conflicts_with_all = ["n", "k", "water"], value_parser = parse_complex_index)]
    pub index: Option<(f64, f64)>,
    /// Use the index of water at the wavelength (the default when no index is given).
    #[arg(long)]
    pub water: bool,
    /// Real part of the relative refractive index (default: water at the wavelength).
    #[arg(long, conflicts_with = "water")]
    pub n: Option<f64>,
    /// Imaginary part (absorption), k ≥ 0 (default 0).
    #[arg(long)]
    pub k: Option<f64>,
    /// Water index model when no --index/--n is given.
    #[arg(long, default_value = "iapws1997", value_parser = ["iapws1997", "sadeghi-table-3.2"])]
    pub water_index_model: String,
    /// Water temperature (°C) for iapws1997.
    #[arg(long, default_value_t = 20.0)]
    pub temperature_c: f64,
}

impl IndexArgs {
    /// The explicit index (n, k), if one was given (`--index`, or `--n` with optional `--k`).
    pub fn explicit(&self) -> anyhow::Result<Option<(f64, f64)>> {
        let (n, k) = match self.index {
            Some((n, k)) => (Some(n), k),
            None => (self.n, self.k.unwrap_or(0.0)),
        };
        if !(k >= 0.0) || !k.is_finite() {
            bail!("--k {k} must be ≥ 0 (absorbing convention m = n + ik, e^(-iωt))");
        }
        match n {
            Some(n) if !(n > 0.0) || !n.is_finite() => bail!("--n {n} must be positive"),
            Some(n) => Ok(Some((n, k))),
            None => Ok(None),
        }
    }

    /// The water model named by `--water-index-model` and `--temperature-c`.
    pub fn water_model(&self) -> anyhow::Result<WaterIndexModel> {
        Ok(WaterIndexModel::from_name(
            &self.water_index_model,
            Some(self.temperature_c),
        )?)
    }

    /// (n, k) at `wavelength_nm`: the explicit index, or water (with `--k` if given); without
    /// a wavelength only an explicit `--n`/`--index` works.
    pub fn resolve(&self, wavelength_nm: Option<f64>) -> anyhow::Result<(f64, f64)> {
        if let Some(nk) = self.explicit()? {
            return Ok(nk);
        }
        let Some(l) = wavelength_nm else {
            bail!("--x needs --n or --index (no wavelength to evaluate the water index)");
        };
        Ok((self.water_model()?.index(l)?, self.k.unwrap_or(0.0)))
    }

    /// Real index n at `wavelength_nm` for methods without absorption (`what`, e.g. "ray
    /// tracing"): k must be 0.
    pub fn resolve_real(&self, wavelength_nm: f64, what: &str) -> anyhow::Result<f64> {
        let (n, k) = self.resolve(Some(wavelength_nm))?;
        if k != 0.0 {
            bail!("{what} treats non-absorbing drops only: k must be 0 (use `mie` for k > 0)");
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn complex_index_forms() {
        assert_eq!(parse_complex_index("1.55+0.002i").unwrap(), (1.55, 0.002));
        assert_eq!(parse_complex_index("1.333").unwrap(), (1.333, 0.0));
        assert_eq!(parse_complex_index("1.5+1e-3i").unwrap(), (1.5, 1e-3));
        assert!(parse_complex_index("1.5-0.1i").is_err());
        assert!(parse_complex_index("abc").is_err());
    }

    #[test]
    fn angle_ranges() {
        let r = AngleRange::parse("0:180:0.5").unwrap();
        assert_eq!((r.start, r.stop, r.step), (0.0, 180.0, 0.5));
        assert_eq!(r.angles().len(), 361);
        assert_eq!(
            AngleRange::parse("130:145:0.05").unwrap().angles().len(),
            301
        );
        for bad in [
            "0:190:1",
            "0:180:0",
            "0:180:-1",
            "10:5:1",
            "1:2",
            "a:b:c",
            "0:180:1e-9",
            "0:1:0.3",
        ] {
            assert!(AngleRange::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(
            AngleRange::full(45.0).unwrap().angles(),
            [0.0, 45.0, 90.0, 135.0, 180.0]
        );
        assert!(AngleRange::full(0.7).is_err());
        assert!(AngleRange::full(0.0).is_err());
    }
}
