"""Type stubs of the extension module ``scatterbake._scatterbake`` (PyO3 bindings of the
scatterbake library).

Conventions everywhere (Bohren & Huffman 1983):

- time dependence exp(-iωt); refractive index ``m = n + ik`` with ``k >= 0`` absorbing (miepython
  and MiePlot's documentation write ``n - ik``: the same sphere, conjugate amplitudes);
- ``S1`` is the amplitude for the field perpendicular to the scattering plane, ``S2`` parallel;
  both dimensionless, ``|S1|²``, ``|S2|²`` as in Bohren & Huffman;
- ``i_perp = |S1|²/(π x² Q_sca)``, ``i_par = |S2|²/(π x² Q_sca)``, ``phase = (i_perp + i_par)/2``
  in 1/sr with ∫4π phase dΩ = 1, ``dolp = (i_perp − i_par)/(i_perp + i_par)``;
- efficiencies are cross-sections over π r² (dimensionless); ``qback`` is the radar convention
  ``4π (dC_sca/dΩ)(180°)/(π r²) = 4|S1(180°)|²/x²``; ``qback_per_sr = qback/(4π)`` is
  MiePlot's per-steradian value;
- radii in µm, wavelengths in nm (vacuum), angles in degrees;
- medium: ``m`` is the sphere's own (absolute) index and ``n_medium`` (default 1, real) the
  index of the non-absorbing medium around it, exactly as ``scatterbake mie --n-medium`` and the
  manifest key ``n_medium``: the relative index is ``m/n_medium``; from ``radius_um`` and
  ``wavelength_nm`` the size parameter is ``x = 2π r n_medium/λ`` (the wavelength in the medium);
  a given ``x`` is taken as the size parameter in the medium. With ``n_medium = 1``, ``m`` is the
  relative index.

Errors: ``ValueError`` with the library's message for input outside the validated domain or
inconsistent arguments; ``TableError`` (a ``ValueError``) for a file that is not a valid table;
``OSError`` for files that cannot be read or written.
"""

from os import PathLike
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str
Q_BACK_CONVENTIONS: str
"""Both backscattering conventions in words."""
MIE_VALIDATED_DOMAIN: str
"""The validated domain of the homogeneous-sphere solution and its measured accuracy."""
CLOTH_FABRICS: tuple[str, ...]
"""Names of the cloth fabric presets (thesis Tables 5.2 and E.1, docs/cloth.md), in the order of
Table 5.2: the ``fabric`` of :func:`cloth_brdf` and of the ``cloth`` stage."""

_Angles = Union[float, Sequence[float], npt.NDArray[np.floating]]
_Path = Union[str, "PathLike[str]"]

class TableError(ValueError):
    """The file is not a valid scatterbake table (corrupt, truncated, newer major version, ...)."""

class MieResult:
    """One sphere. Arrays are numpy arrays over ``angles_deg``."""

    x: float
    """Size parameter in the medium (outer one for a coated sphere)."""
    m: complex
    """Index relative to the medium, ``m/n_medium`` (the shell's for a coated sphere)."""
    n_medium: float
    """Real index of the medium."""
    core_x: Optional[float]
    """Core size parameter of a coated sphere, else None."""
    core_m: Optional[complex]
    """Core index relative to the medium of a coated sphere, else None."""
    n_terms: int
    """Number of partial waves summed."""
    angles_deg: npt.NDArray[np.float64]
    """Scattering angles (deg)."""
    s1: npt.NDArray[np.complex128]
    """S1(θ), perpendicular amplitude (dimensionless, Bohren & Huffman)."""
    s2: npt.NDArray[np.complex128]
    """S2(θ), parallel amplitude (dimensionless, Bohren & Huffman)."""
    i_perp: npt.NDArray[np.float64]
    """|S1|²/(π x² Q_sca) (1/sr)."""
    i_par: npt.NDArray[np.float64]
    """|S2|²/(π x² Q_sca) (1/sr)."""
    phase: npt.NDArray[np.float64]
    """(i_perp + i_par)/2 (1/sr); integrates to 1 over 4π sr."""
    dolp: npt.NDArray[np.float64]
    """Degree of linear polarisation (i_perp − i_par)/(i_perp + i_par)."""
    qext: float
    """Extinction efficiency C_ext/(π r²)."""
    qsca: float
    """Scattering efficiency C_sca/(π r²)."""
    qabs: float
    """Absorption efficiency C_abs/(π r²) (exactly 0 for real m)."""
    qback: float
    """Backscattering efficiency, radar convention 4|S1(180°)|²/x²."""
    qback_per_sr: float
    """Backscattering per steradian (MiePlot), qback/(4π) = |S1(180°)|²/(π x²)."""
    g: float
    """Asymmetry parameter ⟨cos θ⟩."""

def mie(
    m: complex,
    x: Optional[float] = None,
    *,
    radius_um: Optional[float] = None,
    wavelength_nm: Optional[float] = None,
    n_medium: float = 1.0,
    angles_deg: Optional[_Angles] = None,
    core_m: Optional[complex] = None,
    core_x: Optional[float] = None,
    core_radius_um: Optional[float] = None,
) -> MieResult:
    """Lorenz–Mie solution of one sphere, homogeneous or coated.

    Args:
        m: the sphere's complex refractive index n + ik (k >= 0); relative to the medium it is
            ``m/n_medium``. For a coated sphere, the shell's index.
        x: size parameter 2π r/λ in the medium; or give ``radius_um`` and ``wavelength_nm``.
        radius_um: sphere (outer) radius in µm, with ``wavelength_nm``.
        wavelength_nm: vacuum wavelength in nm; x = 2π r n_medium/λ.
        n_medium: real index of the non-absorbing medium (default 1), as
            ``scatterbake mie --n-medium``.
        angles_deg: scattering angles in degrees in [0, 180] (scalar or 1-D array-like);
            default 0, 0.1, ..., 180.
        core_m: absolute complex index of the core of a coated sphere (divided by n_medium).
        core_x: core size parameter in the medium (with ``x``), ``0 <= core_x <= x``.
        core_radius_um: core radius in µm (with ``radius_um`` and ``wavelength_nm``).

    Validated domain: 1e-3 <= x <= 1e5, 0.05 <= Re m <= 10, 0 <= Im m <= 10,
    |m − 1| >= 1e-5, |m| x <= 1.5e5 (relative m); coated spheres x <= 1e4. Outside: ValueError.
    The GIL is released while computing.
    """

class DebyeResult:
    """Debye-series orders of one sphere. Per-order arrays have shape (len(orders), angles)."""

    x: float
    """Size parameter in the medium."""
    m: complex
    """Index relative to the medium."""
    n_medium: float
    orders: list[int]
    """The orders p of the rows (0: diffraction + external reflection, 1: transmission,
    2: primary rainbow, 3: secondary rainbow, ...)."""
    angles_deg: npt.NDArray[np.float64]
    s1: npt.NDArray[np.complex128]
    """S1 of each order alone (dimensionless), shape (orders, angles)."""
    s2: npt.NDArray[np.complex128]
    """S2 of each order alone (dimensionless), shape (orders, angles)."""
    i_perp: npt.NDArray[np.float64]
    """|S1_p|²/(π x² Q_sca) with the full sphere's Q_sca (1/sr)."""
    i_par: npt.NDArray[np.float64]
    """|S2_p|²/(π x² Q_sca) with the full sphere's Q_sca (1/sr)."""
    phase: npt.NDArray[np.float64]
    """(i_perp + i_par)/2 of each order (1/sr), on the full Mie scale."""
    mie_phase: npt.NDArray[np.float64]
    """Full Mie phase function (1/sr)."""
    qsca_orders: npt.NDArray[np.float64]
    """Scattering efficiency of each order alone, (2/x²) Σ (2n+1)(|a_n^p|² + |b_n^p|²)."""
    qext: float
    """Full sphere's extinction efficiency."""
    qsca: float
    """Full sphere's scattering efficiency."""
    qback: float
    """Full sphere's backscattering efficiency (radar convention)."""
    qback_per_sr: float
    """Full sphere's backscattering per steradian (MiePlot), qback/(4π)."""
    g: float
    """Full sphere's asymmetry parameter."""

def debye(
    m: complex,
    orders: Sequence[int],
    x: Optional[float] = None,
    *,
    radius_um: Optional[float] = None,
    wavelength_nm: Optional[float] = None,
    n_medium: float = 1.0,
    angles_deg: Optional[_Angles] = None,
) -> DebyeResult:
    """Debye-series orders p of a homogeneous sphere (the Lorenz–Mie coefficients split by the
    number of chords p; ``scatterbake mie --debye-orders``). Arguments and medium convention as
    :func:`mie`. Validated domain: 1e-3 <= x <= 1e5, 1.05 <= Re m <= 2.5, 0 <= Im m <= 1
    (relative m); outside: ValueError. The sum over all p of the coefficients is the Mie
    solution; intensities of single orders do not add up (interference)."""

class DistributionResult:
    """Phase function of a size distribution at point angles (not bin averages)."""

    wavelength_nm: float
    """Vacuum wavelength (nm)."""
    m: complex
    """Index relative to the medium."""
    n_medium: float
    angles_deg: npt.NDArray[np.float64]
    i_perp: npt.NDArray[np.float64]
    """⟨|S1|²⟩/⟨π x² Q_sca⟩ (1/sr)."""
    i_par: npt.NDArray[np.float64]
    """⟨|S2|²⟩/⟨π x² Q_sca⟩ (1/sr)."""
    phase: npt.NDArray[np.float64]
    """(i_perp + i_par)/2 (1/sr); integrates to 1 over 4π sr."""
    dolp: npt.NDArray[np.float64]
    qext: float
    """⟨C_ext⟩/⟨π r²⟩."""
    qsca: float
    """⟨C_sca⟩/⟨π r²⟩."""
    qback: float
    """⟨C_back⟩/⟨π r²⟩, radar convention."""
    qback_per_sr: float
    """qback/(4π), per steradian (MiePlot)."""
    g: float
    """⟨C_sca g⟩/⟨C_sca⟩."""
    radii_um: npt.NDArray[np.float64]
    """Quadrature radii (µm)."""
    weights: npt.NDArray[np.float64]
    """Quadrature weights ≈ n(r) dr (arbitrary scale)."""
    error_estimate: Optional[float]
    """Estimated RMS relative error of i_perp and i_par over the angles (relative to phase) of
    the adaptive rule; None for a fixed ``radius_points`` rule."""
    max_error_estimate: Optional[float]
    """Estimated largest relative error over the angles and both channels (the same per-angle
    estimate); None for a fixed ``radius_points`` rule."""
    radius_nodes: int
    """Spheres evaluated."""

def mie_distribution(
    distribution: dict[str, Any],
    wavelength_nm: float,
    m: complex,
    *,
    n_medium: float = 1.0,
    angles_deg: Optional[_Angles] = None,
    tolerance: float = 1e-3,
    max_radius_nodes: int = 100000,
    radius_points: Optional[int] = None,
    max_tolerance: Optional[float] = None,
) -> DistributionResult:
    """Size-distribution-averaged phase function of spheres of index ``m`` at the vacuum
    wavelength ``wavelength_nm``.

    ``distribution`` is the manifest form of the ``mie`` stage's ``distributions`` entries
    (constructors :func:`scatterbake.lognormal`, :func:`scatterbake.gamma`,
    :func:`scatterbake.marshall_palmer`, :func:`scatterbake.monodisperse`), e.g.
    ``{"kind": "lognormal", "median_radius_um": 10, "geometric_sigma": 1.5}``.
    The single-sphere phase functions are mixed with weights n(r) dr · C_sca(r) (the ``mie``
    stage's rule) by an adaptive radius rule (uniform in r on panels, steps halved) until the
    estimated RMS error of ``i_perp`` and ``i_par`` over the angles, relative to ``phase``, is at
    most ``tolerance`` (and, with ``max_tolerance``, its estimated largest value over the angles
    at most ``max_tolerance``); ``error_estimate``, ``max_error_estimate`` and ``radius_nodes``
    report it. A tolerance that needs
    more than ``max_radius_nodes`` spheres raises ValueError (never an unconverged result).
    ``radius_points=N`` instead uses a fixed N-point Gauss–Legendre rule in ln r, with no error
    estimate (``error_estimate`` is None). Medium as :func:`mie` (wavelength and index divided by
    ``n_medium``). Every node must lie in the validated Mie domain (ValueError otherwise). GIL
    released while computing."""

class Axis:
    name: str
    unit: str
    coords: npt.NDArray[np.float64]
    @property
    def symmetry(self) -> Optional[dict[str, Any]]:
        """``None``, or the axis's symmetry as the header states it (format 3.0), e.g.
        ``{"kind": "even-periodic", "period": 360.0}``: the axis stores 0 … period/2 and
        ``Table.sample`` folds its coordinate (``fold``)."""
    def fold(self, x: float) -> float:
        """The coordinate a lookup uses for ``x``: on an even-periodic axis of period P,
        ``r = fmod(|x|, P)``, then ``P − r`` when ``r > P/2`` (the same bits in every reader;
        NaN for an infinite ``x``); ``x`` itself on any other axis."""

class Channel:
    name: str
    unit: str
    meaning: str

class Table:
    """A ``.sbt`` table read and fully verified by the library's reader."""

    @property
    def header(self) -> dict[str, Any]: ...
    @property
    def schema(self) -> str:
        """``name/version``, e.g. ``mie-phase/4``."""
    @property
    def attributes(self) -> dict[str, Any]:
        """The stage's self-description (conventions, Q values, ...)."""
    @property
    def axes(self) -> list[Axis]:
        """Axes in storage order (e.g. radius [um] × wavelength [nm] × scattering_angle [deg])."""
    @property
    def channels(self) -> list[Channel]: ...
    @property
    def data(self) -> npt.NDArray[np.float32]:
        """All samples, shape (axis lengths..., channels): a read-only view of the table's own
        samples (no copy; the view keeps the table alive)."""
    def axis(self, name: str) -> Axis:
        """The axis called ``name`` (KeyError if none)."""
    def channel_index(self, name: str) -> int:
        """Position of the channel ``name`` (KeyError if none)."""
    def channel(self, name: str) -> npt.NDArray[np.float32]:
        """One channel, float32, shape (axis lengths...)."""
    def sample(self, coords: Sequence[float]) -> npt.NDArray[np.float64]:
        """Multilinear interpolation of every channel at ``coords`` (one per axis, in axis units),
        folded on an even-periodic axis (``Axis.fold``; ValueError for an infinite coordinate
        there) and clamped at the axis ends; one value per channel."""
    def sample_channel(self, name: str, coords: Sequence[float]) -> float:
        """Interpolated value of one channel at ``coords``."""

def open_table(
    path: _Path, *, reconstruct: bool = True, entry: Optional[Sequence[int]] = None
) -> Table:
    """Open and verify a ``.sbt`` table (every checksum). A tensor-train table
    (schema ``fur-medulla-tt/1``, e.g. the shipped ``assets/fur-medulla/*.sbt``) is checked
    and reconstructed into the dense table it holds (its source schema, axes and channel; values
    bit-identical to the Rust and C readers) unless ``reconstruct=False``, which returns the
    stored cores. ``entry`` (indices of the first axes, e.g. ``(i_radius, i_wavelength,
    i_elevation)`` of a ``raytrace-phase-2d`` table) keeps only that entry: the whole file is
    still verified as it streams past, memory is bounded by the entry, and every axis stays, a
    fixed one with its chosen coordinate alone (length 1), so ``sample`` takes one coordinate
    per axis as before; a tensor-train table is refused with ``entry`` unless
    ``reconstruct=False``. OSError if it cannot be read, TableError if it is not a valid table
    (or not a valid tensor train) or an index is out of range (the message names the axis)."""

def build(
    manifests: Union[_Path, Sequence[_Path]],
    out_dir: _Path = "tables",
    *,
    jobs: Optional[int] = None,
    force: bool = False,
    quiet: bool = True,
) -> dict[str, Any]:
    """Run the library's pipeline on manifest files (as ``scatterbake build MANIFEST... --out
    OUT_DIR``, without preview pictures): tables into ``out_dir`` with the catalog
    ``out_dir/index.json``; up-to-date tables are kept unless ``force``. ``jobs``: worker
    threads (default all cores). ``quiet=False`` writes one line per table step (up to date,
    computing, writing, written, …) to the process's stderr. Returns the report: ``tables_written``, ``tables_up_to_date``,
    ``tables_pending``, ``tasks_computed``, ``tasks_reused``, ``checkpoints_rejected``.
    ValueError for a manifest that does not read or plan (the message names FILE:LINE:COLUMN).
    The GIL is released while building."""

def cloth_brdf(
    fabric: str,
    theta_i_deg: float,
    phi_i_deg: float,
    theta_r_deg: float,
    phi_r_deg: float,
    *,
    ramp_step_deg: float = 1.0,
) -> dict[str, Any]:
    """The microcylinder cloth BRDF (Sadeghi et al. 2013, as printed; docs/cloth.md) of the
    fabric preset ``fabric`` (one of :data:`CLOTH_FABRICS`) at one direction pair: the record that
    ``scatterbake cloth --format json`` prints, from the same library function.

    Angles in degrees in the cloth frame: θ from the cloth normal, in [0, 90); φ from the warp
    (+x, the first thread family of the thesis's tables) toward the weft (+y), any finite value.
    ``i`` is the direction toward the light, ``r`` toward the viewer (the model is not
    reciprocal: do not swap them). ``ramp_step_deg`` (0, 10] is the largest step in tangent
    elevation of the tangent-curve quadrature.

    Returns a dict: ``brdf`` (linear Rec. 709 RGB, 1/sr), ``surface`` (the white surface lobe,
    repeated per channel) and ``volume`` (RGB) with ``brdf = surface + volume``; ``fabric``,
    ``theta_i_deg``, ``phi_i_deg``, ``theta_r_deg``, ``phi_r_deg``, ``ramp_step_deg``, ``unit``
    (``1/sr``), ``channels``, ``model`` and ``frame`` (texts). ValueError for an unknown fabric
    (the message lists the presets) or an angle or step outside its range."""
