"""scatterbake from Python: Lorenz–Mie spheres (homogeneous and coated), Debye-series orders,
size-distribution phase functions, the microcylinder cloth BRDF (``cloth_brdf``), scatterbake
tables (``.sbt``) and table builds, computed by the scatterbake library (Rust) through PyO3.

Conventions (Bohren & Huffman 1983): time dependence exp(-iωt), refractive index m = n + ik with
k ≥ 0 absorbing; radii in µm (``radius_um``), vacuum wavelengths in nm (``wavelength_nm``),
angles in degrees (``angles_deg``); ``S1`` is the amplitude perpendicular to the scattering
plane, ``S2`` parallel; efficiencies are cross-sections over πr²; ``qback`` is the radar
convention 4|S1(180°)|²/x² and ``qback_per_sr = qback/(4π)`` MiePlot's per steradian.
A medium of real index ``n_medium`` (default 1) follows ``scatterbake mie --n-medium``: ``m`` is
the sphere's own index, the relative index is ``m/n_medium`` and, from a radius and a vacuum
wavelength, x = 2π r n_medium/λ; a given ``x`` is the size parameter in the medium.

See docs/python.md.
"""

from ._scatterbake import (
    CLOTH_FABRICS,
    MIE_VALIDATED_DOMAIN,
    Q_BACK_CONVENTIONS,
    Axis,
    Channel,
    DebyeResult,
    DistributionResult,
    MieResult,
    Table,
    TableError,
    __version__,
    build,
    cloth_brdf,
    debye,
    mie,
    mie_distribution,
    open_table,
)

__all__ = [
    "CLOTH_FABRICS",
    "MIE_VALIDATED_DOMAIN",
    "Q_BACK_CONVENTIONS",
    "Axis",
    "Channel",
    "DebyeResult",
    "DistributionResult",
    "MieResult",
    "Table",
    "TableError",
    "__version__",
    "build",
    "cloth_brdf",
    "debye",
    "gamma",
    "lognormal",
    "marshall_palmer",
    "mie",
    "mie_distribution",
    "monodisperse",
    "open_table",
]


def lognormal(median_radius_um: float, geometric_sigma: float) -> dict:
    """Lognormal number density n(r) ∝ (1/r) exp(−ln²(r/r_g)/(2 ln² σ_g)), support r_g σ_g^±6;
    1 < σ_g < 5. The manifest form of the ``mie`` stage's ``distributions`` entries."""
    return {"kind": "lognormal", "median_radius_um": float(median_radius_um),
            "geometric_sigma": float(geometric_sigma)}


def gamma(effective_radius_um: float, effective_variance: float) -> dict:
    """Hansen & Travis (1974) gamma distribution n(r) ∝ r^((1−3v)/v) exp(−r/(a v)), effective
    radius a (µm) and effective variance 0 < v < 0.5."""
    return {"kind": "gamma", "effective_radius_um": float(effective_radius_um),
            "effective_variance": float(effective_variance)}


def marshall_palmer(rain_rate_mm_h: float, min_radius_um: float = 50.0,
                    max_radius_um: float = 3000.0) -> dict:
    """Marshall & Palmer (1948) rain, n(D) = N0 exp(−ΛD), Λ = 4.1 R^−0.21 mm⁻¹ for the rain rate
    R in mm/h, truncated to [min_radius_um, max_radius_um]."""
    return {"kind": "marshall-palmer", "rain_rate_mm_h": float(rain_rate_mm_h),
            "min_radius_um": float(min_radius_um), "max_radius_um": float(max_radius_um)}


def monodisperse(radius_um: float) -> dict:
    """All drops of one radius (µm)."""
    return {"kind": "monodisperse", "radius_um": float(radius_um)}
