//! Python bindings of the `scatterbake` library (module `scatterbake._scatterbake`, re-exported
//! by the pure-Python package `scatterbake`; signatures, units and conventions in
//! `python/scatterbake/_scatterbake.pyi` and `docs/python.md`).
//!
//! The bindings only convert: every number is computed by the library (`mie`, `mie::coated`,
//! `debye`, `mie::distributions`, `cloth`, `table`, `pipeline`). Heavy work runs with the GIL
//! released; library errors become `ValueError` (bad input), `scatterbake.TableError` (a
//! `ValueError`: a file that is not a valid table) or `OSError` (files), with the library's
//! message.

use num_complex::Complex64;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::{PyKeyError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use scatterbake::debye::{DebyeCoefficients, OrderSet};
use scatterbake::error::error_chain;
use scatterbake::mie::coated::{CoatedSphere, coated_coefficients};
use scatterbake::mie::distributions::{SizeDistribution, ensemble_at_angles};
use scatterbake::mie::size_average::{AverageLimits, average_at_angles};
use scatterbake::mie::{Efficiencies, Sphere, size_parameter};
use std::path::PathBuf;

pyo3::create_exception!(
    _scatterbake,
    TableError,
    PyValueError,
    "The file is not a valid scatterbake table (corrupt, truncated, newer major version, ...)."
);

/// Largest number of angles one call may ask for (as the command line).
const MAX_ANGLES: usize = 10_000_000;
/// Largest Debye order `p` accepted.
const MAX_ORDER: usize = 100_000;
/// Largest number of radius quadrature nodes (fixed rule) and the largest node limit.
const MAX_RADIUS_POINTS: usize = 10_000;
const MAX_RADIUS_NODES: usize = 10_000_000;

fn value_error(e: &(dyn std::error::Error + 'static)) -> PyErr {
    PyValueError::new_err(error_chain(e))
}

/// The angle grid: `None` → 0, 0.1, …, 180°; otherwise any 1-D array-like of degrees in
/// [0, 180].
fn angles(py: Python<'_>, angles_deg: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<f64>> {
    let Some(obj) = angles_deg else {
        return Ok((0..=1800).map(|j| j as f64 * 0.1).collect());
    };
    let np = py.import("numpy")?;
    let arr = np.call_method1(
        "atleast_1d",
        (np.call_method1("asarray", (obj, "float64"))?,),
    )?;
    let arr: PyReadonlyArray1<'_, f64> = arr
        .extract()
        .map_err(|_| PyValueError::new_err("angles_deg must be a scalar or a 1-D array"))?;
    let v = arr.as_array().to_vec();
    if v.len() > MAX_ANGLES {
        return Err(PyValueError::new_err(format!(
            "at most {MAX_ANGLES} angles, got {}",
            v.len()
        )));
    }
    if let Some(a) = v.iter().find(|a| !(0.0..=180.0).contains(*a)) {
        return Err(PyValueError::new_err(format!(
            "angles_deg must lie in [0, 180] degrees, got {a}"
        )));
    }
    Ok(v)
}

/// Size parameter in the medium and index relative to it, with the command line's convention
/// (`scatterbake mie`): `index` is the sphere's own index; `x` as given is the size parameter in
/// the medium; from a radius and a vacuum wavelength `x = 2π r n_medium/λ`.
fn sphere_in_medium(
    index: Complex64,
    x: Option<f64>,
    radius_um: Option<f64>,
    wavelength_nm: Option<f64>,
    n_medium: f64,
) -> PyResult<(f64, Complex64)> {
    if !(n_medium > 0.0 && n_medium.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "n_medium {n_medium} must be a positive real index"
        )));
    }
    let x = match (x, radius_um, wavelength_nm) {
        (Some(x), None, None) => x,
        (None, Some(r), Some(l)) => {
            if !(r > 0.0 && r.is_finite() && l > 0.0 && l.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "radius_um {r} and wavelength_nm {l} must be positive and finite"
                )));
            }
            size_parameter(r, l / n_medium)
        }
        _ => {
            return Err(PyValueError::new_err(
                "give either x, or radius_um with wavelength_nm",
            ));
        }
    };
    Ok((x, index / n_medium))
}

fn c1(py: Python<'_>, v: Vec<Complex64>) -> Py<PyArray1<Complex64>> {
    v.into_pyarray(py).unbind()
}

fn f1(py: Python<'_>, v: Vec<f64>) -> Py<PyArray1<f64>> {
    v.into_pyarray(py).unbind()
}

fn dolp(i_perp: &[f64], i_par: &[f64]) -> Vec<f64> {
    i_perp
        .iter()
        .zip(i_par)
        .map(|(a, b)| if a + b > 0.0 { (a - b) / (a + b) } else { 0.0 })
        .collect()
}

/// One sphere (homogeneous or coated): amplitudes, normalised intensities and efficiencies.
///
/// Conventions (Bohren & Huffman 1983): `e^{-iωt}`, `m = n + ik` with `k ≥ 0` absorbing;
/// `S1` ⟂, `S2` ∥ to the scattering plane, dimensionless; `i_perp = |S1|²/(π x² Q_sca)`,
/// `i_par = |S2|²/(π x² Q_sca)` and `phase = (i_perp + i_par)/2` in 1/sr (∫4π phase dΩ = 1);
/// efficiencies are cross-sections over π r²; `qback` is the radar convention
/// `4|S1(180°)|²/x²`, `qback_per_sr = qback/(4π)` MiePlot's per-steradian one.
#[pyclass(frozen, get_all, module = "scatterbake._scatterbake")]
pub struct MieResult {
    /// Size parameter in the medium, `2π r n_medium/λ` (outer one for a coated sphere).
    x: f64,
    /// Index relative to the medium, `index/n_medium` (of the shell for a coated sphere).
    m: Complex64,
    /// Real index of the medium.
    n_medium: f64,
    /// Core size parameter of a coated sphere (None for a homogeneous one).
    core_x: Option<f64>,
    /// Core index relative to the medium (None for a homogeneous sphere).
    core_m: Option<Complex64>,
    /// Number of partial waves summed.
    n_terms: usize,
    /// Scattering angles (deg).
    angles_deg: Py<PyArray1<f64>>,
    /// `S1(θ)` (complex, dimensionless).
    s1: Py<PyArray1<Complex64>>,
    /// `S2(θ)` (complex, dimensionless).
    s2: Py<PyArray1<Complex64>>,
    /// `|S1|²/(π x² Q_sca)` (1/sr).
    i_perp: Py<PyArray1<f64>>,
    /// `|S2|²/(π x² Q_sca)` (1/sr).
    i_par: Py<PyArray1<f64>>,
    /// `(i_perp + i_par)/2` (1/sr), integrates to 1 over 4π.
    phase: Py<PyArray1<f64>>,
    /// `(i_perp − i_par)/(i_perp + i_par)`.
    dolp: Py<PyArray1<f64>>,
    /// Extinction efficiency.
    qext: f64,
    /// Scattering efficiency.
    qsca: f64,
    /// Absorption efficiency.
    qabs: f64,
    /// Backscattering efficiency, radar convention `4|S1(180°)|²/x²`.
    qback: f64,
    /// Backscattering per steradian (MiePlot), `qback/(4π)`.
    qback_per_sr: f64,
    /// Asymmetry parameter ⟨cos θ⟩.
    g: f64,
}

#[pymethods]
impl MieResult {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "MieResult(x={}, m={}, n_medium={}, qext={}, qsca={}, qback={}, g={}, angles={})",
            self.x,
            self.m,
            self.n_medium,
            self.qext,
            self.qsca,
            self.qback,
            self.g,
            self.angles_deg.bind(py).len().unwrap_or(0)
        )
    }
}

/// Lorenz–Mie solution of one sphere; see `_scatterbake.pyi` for the full contract.
#[pyfunction]
#[pyo3(signature = (m, x=None, *, radius_um=None, wavelength_nm=None, n_medium=1.0,
    angles_deg=None, core_m=None, core_x=None, core_radius_um=None))]
#[allow(clippy::too_many_arguments)]
fn mie(
    py: Python<'_>,
    m: Complex64,
    x: Option<f64>,
    radius_um: Option<f64>,
    wavelength_nm: Option<f64>,
    n_medium: f64,
    angles_deg: Option<&Bound<'_, PyAny>>,
    core_m: Option<Complex64>,
    core_x: Option<f64>,
    core_radius_um: Option<f64>,
) -> PyResult<MieResult> {
    let (x, rel) = sphere_in_medium(m, x, radius_um, wavelength_nm, n_medium)?;
    let core = match (core_m, core_x, core_radius_um) {
        (None, None, None) => None,
        (Some(_), None, None) => {
            return Err(PyValueError::new_err(
                "core_m needs core_x or core_radius_um",
            ));
        }
        (None, _, _) => {
            return Err(PyValueError::new_err(
                "core_x and core_radius_um need core_m",
            ));
        }
        (Some(_), Some(_), Some(_)) => {
            return Err(PyValueError::new_err(
                "give core_x or core_radius_um, not both",
            ));
        }
        (Some(cm), Some(xc), None) => Some((xc, cm / n_medium)),
        (Some(cm), None, Some(rc)) => {
            let (Some(_), Some(l)) = (radius_um, wavelength_nm) else {
                return Err(PyValueError::new_err(
                    "core_radius_um needs radius_um and wavelength_nm (with x use core_x)",
                ));
            };
            Some((size_parameter(rc, l / n_medium), cm / n_medium))
        }
    };
    let angles = angles(py, angles_deg)?;
    let solved = py.detach(move || -> Result<_, PyErr> {
        let sphere = match core {
            None => Sphere::new(x, rel).map_err(|e| value_error(&e))?,
            Some((xc, mc)) => Sphere::from_coefficients(
                coated_coefficients(&CoatedSphere {
                    core_size_parameter: xc,
                    size_parameter: x,
                    core_index: mc,
                    shell_index: rel,
                })
                .map_err(|e| value_error(&e))?,
            ),
        };
        let (s1, s2) = sphere.amplitudes_deg_parallel(&angles);
        let norm = sphere.phase_normalisation();
        let i_perp: Vec<f64> = s1.iter().map(|s| s.norm_sqr() / norm).collect();
        let i_par: Vec<f64> = s2.iter().map(|s| s.norm_sqr() / norm).collect();
        Ok((sphere, angles, s1, s2, i_perp, i_par))
    })?;
    let (sphere, angles, s1, s2, i_perp, i_par) = solved;
    let e: Efficiencies = sphere.efficiencies;
    let phase = i_perp
        .iter()
        .zip(&i_par)
        .map(|(a, b)| 0.5 * (a + b))
        .collect();
    Ok(MieResult {
        x,
        m: rel,
        n_medium,
        core_x: core.map(|c| c.0),
        core_m: core.map(|c| c.1),
        n_terms: sphere.coefficients.n_stop(),
        angles_deg: f1(py, angles),
        s1: c1(py, s1),
        s2: c1(py, s2),
        dolp: f1(py, dolp(&i_perp, &i_par)),
        i_perp: f1(py, i_perp),
        i_par: f1(py, i_par),
        phase: f1(py, phase),
        qext: e.q_ext,
        qsca: e.q_sca,
        qabs: e.q_abs,
        qback: e.q_back,
        qback_per_sr: e.q_back_per_sr(),
        g: e.g,
    })
}

/// Debye-series orders of one sphere: per order `p`, `S1`, `S2` and the phase function on the
/// full Mie scale (divided by the full sphere's `π x² Q_sca`, as the `debye` stage).
#[pyclass(frozen, get_all, module = "scatterbake._scatterbake")]
pub struct DebyeResult {
    /// Size parameter in the medium.
    x: f64,
    /// Index relative to the medium.
    m: Complex64,
    /// Real index of the medium.
    n_medium: f64,
    /// The orders `p`, in the order of the rows below.
    orders: Vec<usize>,
    /// Scattering angles (deg).
    angles_deg: Py<PyArray1<f64>>,
    /// `S1` of each order alone, shape (orders, angles).
    s1: Py<PyArray2<Complex64>>,
    /// `S2` of each order alone, shape (orders, angles).
    s2: Py<PyArray2<Complex64>>,
    /// `|S1_p|²/(π x² Q_sca)` (1/sr, full-sphere `Q_sca`), shape (orders, angles).
    i_perp: Py<PyArray2<f64>>,
    /// `|S2_p|²/(π x² Q_sca)` (1/sr), shape (orders, angles).
    i_par: Py<PyArray2<f64>>,
    /// `(i_perp + i_par)/2` of each order (1/sr), shape (orders, angles).
    phase: Py<PyArray2<f64>>,
    /// Full Mie phase function (1/sr) on the same scale.
    mie_phase: Py<PyArray1<f64>>,
    /// Scattering efficiency of each order alone, `(2/x²) Σ (2n+1)(|a_n^p|² + |b_n^p|²)`.
    qsca_orders: Py<PyArray1<f64>>,
    /// Full sphere: extinction efficiency.
    qext: f64,
    /// Full sphere: scattering efficiency.
    qsca: f64,
    /// Full sphere: backscattering efficiency, radar convention.
    qback: f64,
    /// Full sphere: backscattering per steradian (MiePlot), `qback/(4π)`.
    qback_per_sr: f64,
    /// Full sphere: asymmetry parameter.
    g: f64,
}

fn rows<T: numpy::Element + Copy>(
    py: Python<'_>,
    rows: &[Vec<T>],
    cols: usize,
) -> PyResult<Py<PyArray2<T>>> {
    let flat: Vec<T> = rows.iter().flatten().copied().collect();
    Ok(flat.into_pyarray(py).reshape([rows.len(), cols])?.unbind())
}

/// Debye-series orders of one sphere; see `_scatterbake.pyi`.
#[pyfunction]
#[pyo3(signature = (m, orders, x=None, *, radius_um=None, wavelength_nm=None, n_medium=1.0,
    angles_deg=None))]
#[allow(clippy::too_many_arguments)]
fn debye(
    py: Python<'_>,
    m: Complex64,
    orders: Vec<usize>,
    x: Option<f64>,
    radius_um: Option<f64>,
    wavelength_nm: Option<f64>,
    n_medium: f64,
    angles_deg: Option<&Bound<'_, PyAny>>,
) -> PyResult<DebyeResult> {
    let (x, rel) = sphere_in_medium(m, x, radius_um, wavelength_nm, n_medium)?;
    if orders.is_empty() {
        return Err(PyValueError::new_err("orders must name at least one p"));
    }
    if let Some(p) = orders.iter().find(|&&p| p > MAX_ORDER) {
        return Err(PyValueError::new_err(format!(
            "order p = {p} exceeds {MAX_ORDER}"
        )));
    }
    let angles = angles(py, angles_deg)?;
    let n = angles.len();
    let ords = orders.clone();
    type Rows = Vec<Vec<Complex64>>;
    let solved = py.detach(move || -> Result<_, PyErr> {
        let d = DebyeCoefficients::new(x, rel).map_err(|e| value_error(&e))?;
        let norm = d.mie_normalisation();
        let full = Sphere::from_coefficients(d.mie.clone());
        let (ms1, ms2) = full.amplitudes_deg(&angles);
        let mie_phase: Vec<f64> = ms1
            .iter()
            .zip(&ms2)
            .map(|(a, b)| 0.5 * (a.norm_sqr() + b.norm_sqr()) / norm)
            .collect();
        let (mut s1s, mut s2s, mut q): (Rows, Rows, Vec<f64>) = (vec![], vec![], vec![]);
        for &p in &ords {
            let (a, b) = d.coefficients(&OrderSet::Orders(vec![p]));
            q.push(d.efficiency_of(&a, &b));
            let (s1, s2) = d.term_sphere(a, b).amplitudes_deg(&angles);
            s1s.push(s1);
            s2s.push(s2);
        }
        Ok((full.efficiencies, angles, s1s, s2s, q, mie_phase, norm))
    })?;
    let (e, angles, s1s, s2s, q, mie_phase, norm) = solved;
    let sq = |r: &Rows| -> Vec<Vec<f64>> {
        r.iter()
            .map(|v| v.iter().map(|s| s.norm_sqr() / norm).collect())
            .collect()
    };
    let (ip, ia) = (sq(&s1s), sq(&s2s));
    let ph: Vec<Vec<f64>> = ip
        .iter()
        .zip(&ia)
        .map(|(a, b)| a.iter().zip(b).map(|(a, b)| 0.5 * (a + b)).collect())
        .collect();
    Ok(DebyeResult {
        x,
        m: rel,
        n_medium,
        orders,
        angles_deg: f1(py, angles),
        s1: rows(py, &s1s, n)?,
        s2: rows(py, &s2s, n)?,
        i_perp: rows(py, &ip, n)?,
        i_par: rows(py, &ia, n)?,
        phase: rows(py, &ph, n)?,
        mie_phase: f1(py, mie_phase),
        qsca_orders: f1(py, q),
        qext: e.q_ext,
        qsca: e.q_sca,
        qback: e.q_back,
        qback_per_sr: e.q_back_per_sr(),
        g: e.g,
    })
}

/// Size-distribution average at point angles (weights `n(r) dr · C_sca(r)`, decision MIE-2).
#[pyclass(frozen, get_all, module = "scatterbake._scatterbake")]
pub struct DistributionResult {
    /// Vacuum wavelength (nm).
    wavelength_nm: f64,
    /// Index relative to the medium.
    m: Complex64,
    /// Real index of the medium.
    n_medium: f64,
    /// Scattering angles (deg).
    angles_deg: Py<PyArray1<f64>>,
    /// `⟨|S1|²⟩/⟨π x² Q_sca⟩` (1/sr).
    i_perp: Py<PyArray1<f64>>,
    /// `⟨|S2|²⟩/⟨π x² Q_sca⟩` (1/sr).
    i_par: Py<PyArray1<f64>>,
    /// `(i_perp + i_par)/2` (1/sr), integrates to 1 over 4π.
    phase: Py<PyArray1<f64>>,
    /// `(i_perp − i_par)/(i_perp + i_par)`.
    dolp: Py<PyArray1<f64>>,
    /// `⟨C_ext⟩/⟨π r²⟩`.
    qext: f64,
    /// `⟨C_sca⟩/⟨π r²⟩`.
    qsca: f64,
    /// `⟨C_back⟩/⟨π r²⟩`, radar convention.
    qback: f64,
    /// `qback/(4π)`, per steradian (MiePlot).
    qback_per_sr: f64,
    /// `⟨C_sca g⟩/⟨C_sca⟩`.
    g: f64,
    /// Quadrature radii (µm).
    radii_um: Py<PyArray1<f64>>,
    /// Quadrature weights `≈ n(r) dr` (arbitrary scale).
    weights: Py<PyArray1<f64>>,
    /// Estimated RMS relative error of `i_perp`, `i_par` (relative to `phase`) of the adaptive
    /// rule; `None` for a fixed `radius_points` rule.
    error_estimate: Option<f64>,
    /// Estimated largest relative error over the angles and channels (same estimate);
    /// `None` for a fixed `radius_points` rule.
    max_error_estimate: Option<f64>,
    /// Spheres evaluated.
    radius_nodes: usize,
}

/// Phase function of a size distribution; see `_scatterbake.pyi`.
#[pyfunction]
#[pyo3(signature = (distribution, wavelength_nm, m, *, n_medium=1.0, angles_deg=None,
    tolerance=scatterbake::mie::size_average::DEFAULT_TOLERANCE,
    max_radius_nodes=scatterbake::mie::size_average::DEFAULT_MAX_NODES, radius_points=None,
    max_tolerance=None))]
#[allow(clippy::too_many_arguments)]
fn mie_distribution(
    py: Python<'_>,
    distribution: &Bound<'_, PyAny>,
    wavelength_nm: f64,
    m: Complex64,
    n_medium: f64,
    angles_deg: Option<&Bound<'_, PyAny>>,
    tolerance: f64,
    max_radius_nodes: usize,
    radius_points: Option<usize>,
    max_tolerance: Option<f64>,
) -> PyResult<DistributionResult> {
    let json: String = py
        .import("json")?
        .call_method1("dumps", (distribution,))
        .map_err(|e| PyValueError::new_err(format!("distribution must be a dict of numbers: {e}")))?
        .extract()?;
    let dist: SizeDistribution = serde_json::from_str(&json)
        .map_err(|e| PyValueError::new_err(format!("distribution {json}: {e}")))?;
    if !(wavelength_nm > 0.0 && wavelength_nm.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "wavelength_nm {wavelength_nm} must be positive and finite"
        )));
    }
    if let Some(points) = radius_points
        && !(1..=MAX_RADIUS_POINTS).contains(&points)
    {
        return Err(PyValueError::new_err(format!(
            "radius_points must be in 1..={MAX_RADIUS_POINTS}, got {points}"
        )));
    }
    if max_radius_nodes > MAX_RADIUS_NODES {
        return Err(PyValueError::new_err(format!(
            "max_radius_nodes must be at most {MAX_RADIUS_NODES}, got {max_radius_nodes}"
        )));
    }
    // the `mie` stage's convention: wavelength and index in the medium
    let (_, rel) = sphere_in_medium(m, Some(1.0), None, None, n_medium)?;
    let in_medium = wavelength_nm / n_medium;
    let angles = angles(py, angles_deg)?;
    let Some(points) = radius_points else {
        let limits = AverageLimits {
            tolerance,
            max_tolerance,
            max_nodes: max_radius_nodes,
        };
        let a = py
            .detach(move || {
                average_at_angles(&dist, in_medium, rel, &angles, &limits).map(|a| (a, angles))
            })
            .map_err(|e| value_error(&e))?;
        let (a, angles) = a;
        return Ok(DistributionResult {
            wavelength_nm,
            m: rel,
            n_medium,
            dolp: f1(py, dolp(&a.i_perp, &a.i_par)),
            phase: f1(
                py,
                a.i_perp
                    .iter()
                    .zip(&a.i_par)
                    .map(|(p, q)| 0.5 * (p + q))
                    .collect(),
            ),
            angles_deg: f1(py, angles),
            i_perp: f1(py, a.i_perp),
            i_par: f1(py, a.i_par),
            qext: a.q_ext,
            qsca: a.q_sca,
            qback: a.q_back,
            qback_per_sr: a.q_back / (4.0 * std::f64::consts::PI),
            g: a.g,
            radii_um: f1(py, a.radii_um),
            weights: f1(py, a.weights),
            error_estimate: Some(a.error_estimate),
            max_error_estimate: Some(a.max_error_estimate),
            radius_nodes: a.radius_nodes,
        });
    };
    let e = py
        .detach(move || ensemble_at_angles(&dist, in_medium, rel, points, &angles))
        .map_err(|e| value_error(&e))?;
    let radius_nodes = e.radii_um.len();
    Ok(DistributionResult {
        wavelength_nm,
        m: rel,
        n_medium,
        dolp: f1(py, dolp(&e.i_perp, &e.i_par)),
        angles_deg: f1(py, e.angles_deg),
        i_perp: f1(py, e.i_perp),
        i_par: f1(py, e.i_par),
        phase: f1(py, e.phase),
        qext: e.q_ext,
        qsca: e.q_sca,
        qback: e.q_back,
        qback_per_sr: e.q_back / (4.0 * std::f64::consts::PI),
        g: e.g,
        radii_um: f1(py, e.radii_um),
        weights: f1(py, e.weights),
        error_estimate: None,
        max_error_estimate: None,
        radius_nodes,
    })
}

/// An axis of a table: name, unit, coordinates and symmetry.
#[pyclass(frozen, module = "scatterbake._scatterbake")]
pub struct Axis {
    #[pyo3(get)]
    name: String,
    #[pyo3(get)]
    unit: String,
    #[pyo3(get)]
    coords: Py<PyArray1<f64>>,
    sym: Option<scatterbake::table::Symmetry>,
}

impl Axis {
    fn of(py: Python<'_>, a: &scatterbake::table::Axis) -> Self {
        Axis {
            name: a.name.clone(),
            unit: a.unit.clone(),
            coords: f1(py, a.coords()),
            sym: a.symmetry,
        }
    }
}

#[pymethods]
impl Axis {
    /// `None`, or the axis's symmetry as the header states it, e.g. `{"kind": "even-periodic",
    /// "period": 360.0}` (format 3.0).
    #[getter]
    fn symmetry<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(s) = self.sym else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("kind", scatterbake::table::EVEN_PERIODIC)?;
        d.set_item("period", s.period())?;
        Ok(Some(d))
    }

    /// The coordinate a lookup uses for `x`: folded into 0 … period/2 on an even-periodic axis
    /// (`r = fmod(|x|, P)`, then `P − r` when `r > P/2`), `x` itself on any other.
    fn fold(&self, x: f64) -> f64 {
        self.sym.map_or(x, |s| s.fold(x))
    }

    fn __repr__(&self) -> String {
        format!("Axis(name={:?}, unit={:?})", self.name, self.unit)
    }
}

/// A channel of a table: name, unit and meaning.
#[pyclass(frozen, get_all, module = "scatterbake._scatterbake")]
pub struct Channel {
    name: String,
    unit: String,
    meaning: String,
}

#[pymethods]
impl Channel {
    fn __repr__(&self) -> String {
        format!("Channel(name={:?}, unit={:?})", self.name, self.unit)
    }
}

/// A verified `.sbt` table read by the library's reader.
#[pyclass(frozen, module = "scatterbake._scatterbake")]
pub struct Table {
    inner: scatterbake::table::Table,
}

#[pymethods]
impl Table {
    /// The JSON header as a dict.
    #[getter]
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = serde_json::to_string(&self.inner.header)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (s,))
    }

    /// `schema/version`, e.g. `mie-phase/4`.
    #[getter]
    fn schema(&self) -> String {
        let s = &self.inner.header.schema;
        format!("{}/{}", s.name, s.version)
    }

    /// The stage's attributes (conventions, Q values, ...) as a dict.
    #[getter]
    fn attributes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = serde_json::to_string(&self.inner.header.attributes)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (s,))
    }

    /// Axes in storage order.
    #[getter]
    fn axes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let v: Vec<Axis> = self
            .inner
            .header
            .axes
            .iter()
            .map(|a| Axis::of(py, a))
            .collect();
        PyList::new(py, v)
    }

    /// Channels, innermost dimension of `data`.
    #[getter]
    fn channels<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let v: Vec<Channel> = self
            .inner
            .header
            .channels
            .iter()
            .map(|c| Channel {
                name: c.name.clone(),
                unit: c.unit.clone(),
                meaning: c.meaning.clone(),
            })
            .collect();
        PyList::new(py, v)
    }

    /// All samples, float32, shape (axis lengths..., channels): a read-only view of the
    /// table's own samples (no copy, so a table costs its size once however often `data` is
    /// read; the view keeps the table alive).
    #[getter]
    fn data<'py>(this: Bound<'py, Self>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let table = &this.get().inner;
        let mut shape = table.grid_shape();
        shape.push(table.header.channels.len());
        let view = numpy::ndarray::ArrayViewD::from_shape(shape, &table.data)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        // SAFETY: the class is frozen, so the samples are never written or reallocated while
        // the table, the array's base object, is alive.
        let array = unsafe { PyArrayDyn::borrow_from_array(&view, this.clone().into_any()) };
        array.readwrite().make_nonwriteable();
        Ok(array)
    }

    /// The axis called `name` (KeyError if none).
    fn axis(&self, py: Python<'_>, name: &str) -> PyResult<Axis> {
        let i = self
            .inner
            .axis_index(name)
            .map_err(|e| PyKeyError::new_err(e.to_string()))?;
        Ok(Axis::of(py, &self.inner.header.axes[i]))
    }

    /// Position of the channel called `name` (KeyError if none).
    fn channel_index(&self, name: &str) -> PyResult<usize> {
        self.inner
            .channel_index(name)
            .map_err(|e| PyKeyError::new_err(e.to_string()))
    }

    /// One channel, float32, shape (axis lengths...).
    fn channel<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let c = self.channel_index(name)?;
        let nc = self.inner.header.channels.len();
        let v: Vec<f32> = self
            .inner
            .data
            .iter()
            .skip(c)
            .step_by(nc)
            .copied()
            .collect();
        v.into_pyarray(py).reshape(self.inner.grid_shape())
    }

    /// Multilinear interpolation of every channel at `coords` (one per axis, axis units),
    /// folded on an even-periodic axis ([`Axis::fold`]) and clamped at the axis ends (float64
    /// array, one value per channel).
    fn sample<'py>(
        &self,
        py: Python<'py>,
        coords: Vec<f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let v = self
            .inner
            .sample(&coords)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(v.into_pyarray(py))
    }

    /// Interpolated value of one channel at `coords`.
    fn sample_channel(&self, name: &str, coords: Vec<f64>) -> PyResult<f64> {
        self.inner
            .sample_channel(name, &coords)
            .map_err(|e| match e {
                scatterbake::table::SampleError::NoChannel(_) => PyKeyError::new_err(e.to_string()),
                _ => PyValueError::new_err(e.to_string()),
            })
    }

    fn __repr__(&self) -> String {
        let axes: Vec<String> = self
            .inner
            .header
            .axes
            .iter()
            .map(|a| format!("{} [{}] × {}", a.name, a.unit, a.len()))
            .collect();
        format!("Table({}: {})", self.schema(), axes.join(", "))
    }
}

/// Opens and fully verifies a `.sbt` table (every checksum) with the library's reader; a
/// tensor-train table (`fur-medulla-tt/1`) is checked and reconstructed into the dense table
/// it holds unless `reconstruct=False` (`Table::open_reconstructed`). With `entry` (indices of
/// the first axes) only that entry is kept (`Table::open_slice`); a tensor-train table is
/// reconstructed whole only, so it is refused with `entry` unless `reconstruct=False`.
#[pyfunction]
#[pyo3(signature = (path, *, reconstruct=true, entry=None))]
fn open_table(
    py: Python<'_>,
    path: PathBuf,
    reconstruct: bool,
    entry: Option<Vec<usize>>,
) -> PyResult<Table> {
    use scatterbake::table::{ReadLimits, TableError as E, tt::TT_SCHEMA};
    let limits = ReadLimits::default();
    let r = py.detach(|| match &entry {
        None if reconstruct => scatterbake::table::Table::open_reconstructed(&path, &limits),
        None => scatterbake::table::Table::open(&path),
        Some(entry) => {
            let t = scatterbake::table::Table::open_slice(&path, entry, &limits)?;
            if reconstruct && t.header.schema.name == TT_SCHEMA {
                return Err(E::Entry {
                    path: path.clone(),
                    message: "a tensor-train table is reconstructed whole (open it without an \
                              entry, or with reconstruct=False)"
                        .into(),
                });
            }
            Ok(t)
        }
    });
    match r {
        Ok(inner) => Ok(Table { inner }),
        Err(e @ E::Io { .. }) => Err(PyOSError::new_err(e.to_string())),
        Err(e) => Err(TableError::new_err(error_chain(&e))),
    }
}

/// Reports a build on the process's stderr, one line per table step.
struct StderrLines;

impl scatterbake::progress::Progress for StderrLines {
    fn table(&self, name: &str, step: scatterbake::progress::TableStep) {
        eprintln!("build: {name}: {step}");
    }
}

/// Runs the library's pipeline (`scatterbake build`) on manifests; see `_scatterbake.pyi`.
#[pyfunction]
#[pyo3(signature = (manifests, out_dir="tables".into(), *, jobs=None, force=false, quiet=true))]
fn build<'py>(
    py: Python<'py>,
    manifests: &Bound<'py, PyAny>,
    out_dir: PathBuf,
    jobs: Option<usize>,
    force: bool,
    quiet: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let manifests: Vec<PathBuf> = match manifests.extract::<PathBuf>() {
        Ok(p) => vec![p],
        Err(_) => manifests
            .extract()
            .map_err(|_| PyValueError::new_err("manifests must be a path or a list of paths"))?,
    };
    if manifests.is_empty() {
        return Err(PyValueError::new_err("no manifests to build"));
    }
    if jobs == Some(0) {
        return Err(PyValueError::new_err("jobs must be at least 1"));
    }
    let opts = scatterbake::pipeline::BuildOptions {
        manifests,
        out_dir,
        jobs,
        shard: None,
        force,
    };
    let progress: &dyn scatterbake::progress::Progress = if quiet {
        &scatterbake::progress::Silent
    } else {
        &StderrLines
    };
    let report = py
        .detach(|| scatterbake::pipeline::build(&opts, progress))
        .map_err(|e| match e {
            scatterbake::pipeline::PipelineError::Io(_) => PyOSError::new_err(error_chain(&e)),
            _ => value_error(&e),
        })?;
    let d = PyDict::new(py);
    d.set_item("tables_written", report.tables_written)?;
    d.set_item("tables_up_to_date", report.tables_up_to_date)?;
    d.set_item("tables_pending", report.tables_pending)?;
    d.set_item("tasks_computed", report.tasks_computed)?;
    d.set_item("tasks_reused", report.tasks_reused)?;
    d.set_item("checkpoints_rejected", report.checkpoints_rejected)?;
    Ok(d)
}

/// The cloth BRDF of a fabric preset at one direction pair (`scatterbake cloth --format json`):
/// the library's record as a dict; see `_scatterbake.pyi`.
#[pyfunction]
#[pyo3(signature = (fabric, theta_i_deg, phi_i_deg, theta_r_deg, phi_r_deg, *, ramp_step_deg=1.0))]
fn cloth_brdf<'py>(
    py: Python<'py>,
    fabric: &str,
    theta_i_deg: f64,
    phi_i_deg: f64,
    theta_r_deg: f64,
    phi_r_deg: f64,
    ramp_step_deg: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let q = scatterbake::cloth::query::DirectionPairDeg {
        theta_i_deg,
        phi_i_deg,
        theta_r_deg,
        phi_r_deg,
    };
    let fabric = fabric.to_string();
    let record = py
        .detach(move || scatterbake::cloth::query::brdf_record(&fabric, q, ramp_step_deg))
        .map_err(|e| value_error(&e))?;
    let text = serde_json::to_string(&record).map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

#[pymodule]
fn _scatterbake(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(mie, m)?)?;
    m.add_function(wrap_pyfunction!(debye, m)?)?;
    m.add_function(wrap_pyfunction!(mie_distribution, m)?)?;
    m.add_function(wrap_pyfunction!(open_table, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(cloth_brdf, m)?)?;
    m.add_class::<MieResult>()?;
    m.add_class::<DebyeResult>()?;
    m.add_class::<DistributionResult>()?;
    m.add_class::<Table>()?;
    m.add_class::<Axis>()?;
    m.add_class::<Channel>()?;
    m.add("TableError", m.py().get_type::<TableError>())?;
    m.add("Q_BACK_CONVENTIONS", scatterbake::mie::Q_BACK_CONVENTIONS)?;
    m.add(
        "MIE_VALIDATED_DOMAIN",
        scatterbake::mie::VALIDATED_DOMAIN_TEXT,
    )?;
    m.add(
        "CLOTH_FABRICS",
        PyTuple::new(m.py(), scatterbake::cloth::PRESET_NAMES)?,
    )?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
