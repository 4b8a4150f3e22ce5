"""Mitsuba 3 BSDF for scatterbake's cloth tables (``cloth-brdf/1``, docs/cloth.md).

The table holds the microcylinder cloth BRDF of Sadeghi et al. (2013) of one fabric preset on a
4-D grid (θ_i, φ_i, θ_r, φ_r) with its sampling CDFs. This module registers the Mitsuba 3 BSDF
``scatterbake_cloth`` that evaluates and importance-samples such a table::

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    from scatterbake import mitsuba_cloth        # or: import mitsuba_cloth (standalone file)
    mitsuba_cloth.register()                     # after mi.set_variant
    bsdf = {"type": "scatterbake_cloth", "filename": "tables/cloth-polyester-satin-front.sbt"}

Standalone use: copy this file, ``mitsuba_phase.py`` (shared helpers) and
``python/scatterbake_table.py`` (the pure-Python reader, numpy + zstandard) side by side;
inside the installed ``scatterbake`` package the library's own reader is used.

Conventions:

- Frame: the table's cloth frame is Mitsuba's local shading frame ``si.sh_frame``: the cloth
  normal is ``n`` (local +z) and the warp (the fabric's first thread family, the table's
  φ = 0) is the shading tangent ``s`` (local +x; for Mitsuba's shapes dp/du made orthogonal
  to n) turned by ``warp_angle_deg`` (default 0) toward ``t`` (local +y). θ from n, φ from the
  warp toward the weft, in degrees, as the table's axes.
- Light side and view side: the model is not reciprocal, and the table's ω_i is the direction
  toward the light. In radiance mode (camera paths) the light is ``wo`` and the viewer
  ``si.wi``; in importance mode (light paths) the light is ``si.wi`` and the viewer ``wo``.
  ``eval`` returns f(light, view)·cos θ_o (Mitsuba's convention: the cosine of ``wo``).
- Lookup: the header's symmetry (``attributes.symmetry``: ``mirror_x``, ``mirror_y``,
  ``swap_xy``) reduces (φ_i, φ_r) into the stored φ_i domain exactly as the header's
  ``reduce`` says (the same mirrors applied to both azimuths), then multilinear interpolation
  of ``r, g, b`` in (θ_i, φ_i, θ_r, φ_r), as the table documents; φ_r is periodic (the last
  node repeats the first).
- Axis ends: after the reduction φ_i lies inside its axis and φ_r covers the full circle, so
  only θ has ends. θ_i and θ_r are stored at cell centres (k + ½)h of cells that tile [0°, 90°]
  (the sampling CDFs are over those same cells): inside the outer half cells, θ < h/2 and
  θ > 90° − h/2, the value is that of the end node, constant across the half cell (the cell's
  value; nothing is extrapolated). At and below the horizon (cos θ ≤ 0 for either direction)
  the BSDF is 0: the cloth is one-sided. A table whose axes, units, channels or symmetry do not
  match this layout is refused when the plugin is created (``ValueError``).
- Sampling: a proposal for ``wo`` given ``si.wi``, taking ``si.wi`` as the table's ω_i: the
  table's CDFs at the (θ_i, φ_i) node nearest to the reduced direction of ``si.wi`` pick a θ_r
  cell (``cdf_theta_r``) and a φ_r interval of it (``cdf_phi_r``), and ω_r is uniform in solid
  angle inside that cell, mapped back by the inverse of the reduction: the density per solid
  angle is the cell's probability over its solid angle, h (cos θ_k − cos θ_k+1), bounded
  everywhere (the header's recipe, uniform in (θ, φ) with density w_cell/(W h² sin θ), samples
  the same cells but its density diverges at the normal). ``DEFENSIVE_FRACTION`` of the samples are
  cosine-weighted on the hemisphere, so every direction with a value has a density. In
  importance mode this follows the table's own conditional f(ω_i, ·) cos θ_r; in radiance mode
  it is the reciprocal configuration, a proposal only (the model is not reciprocal, f(i→r) and
  f(r→i) differ by up to ~90 %). ``pdf`` is the density of exactly this proposal and
  ``sample`` returns weight = eval/pdf.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

try:
    from .mitsuba_phase import _buffer, _gather, _open_table, check_schema, class_for_variant
except ImportError:  # standalone file
    from mitsuba_phase import _buffer, _gather, _open_table, check_schema, class_for_variant

#: Name under which :func:`register` registers the plugin.
PLUGIN_NAME = "scatterbake_cloth"
#: Schema of the tables read, and its versions.
SCHEMA = "cloth-brdf"
SCHEMA_VERSIONS = (1,)
AXES = ("theta_i", "phi_i", "theta_r", "phi_r")
CHANNELS = ("r", "g", "b", "cdf_theta_r", "cdf_phi_r")
#: Share of the samples drawn cosine-weighted on the hemisphere.
DEFENSIVE_FRACTION = 0.05


def phi_i_domain_deg(mirror_x, mirror_y, swap_xy):
    """The φ_i range of a fabric with these symmetries (``Symmetry::phi_i_domain_deg``)."""
    if mirror_x and mirror_y:
        return (0.0, 45.0) if swap_xy else (0.0, 90.0)
    if mirror_y:
        return (0.0, 180.0)
    if mirror_x:
        return (-90.0, 90.0)
    return (-180.0, 180.0)


def _wrap_deg(p):
    """Angle in [−180°, 180°) (numpy arrays and numbers, or Dr.Jit arrays)."""
    if isinstance(p, np.ndarray):
        return (p.astype(float) + 180.0) % 360.0 - 180.0
    if isinstance(p, (float, int)):  # scalar variants
        return float((p + 180.0) % 360.0 - 180.0)
    return p - 360.0 * dr.floor((p + 180.0) / 360.0)


class ClothTable:
    """The numbers the plugin needs, read and checked with numpy (variant independent).

    ``rgb`` (NT × NPI × NT × NPR × 3, 1/sr), ``marginal`` (NT × NPI × NT), ``conditional``
    (NT × NPI × NT × NPR); ``step_deg`` h, ``phi_i_lo`` the first φ_i node; ``symmetry`` the
    header's flags; ``albedo`` (NT × NPI × 3) the header's directional albedo."""

    def __init__(self, table):
        header = table.header
        check_schema(header, SCHEMA, SCHEMA_VERSIONS)
        names = tuple(a.name for a in table.axes)
        if names != AXES:
            raise ValueError(f"expected axes {AXES}, found {names}")
        for a in table.axes:
            if a.unit != "deg":
                raise ValueError(f"axis {a.name} is in `{a.unit}`, not deg")
        channels = tuple(c.name for c in table.channels)
        if channels != CHANNELS:
            raise ValueError(f"expected channels {CHANNELS}, found {channels}")
        attrs = header["attributes"]
        sym = attrs["symmetry"]
        self.symmetry = (bool(sym["mirror_x"]), bool(sym["mirror_y"]), bool(sym["swap_xy"]))
        self.fabric = attrs.get("fabric", "?")
        coords = [np.asarray(a.coords, dtype=float) for a in table.axes]
        self._check_grid(coords, tuple(float(x) for x in sym["phi_i_domain_deg"]))
        self.rgb = np.stack([np.asarray(table.channel(c), dtype=np.float64) for c in "rgb"], -1)
        cdf_t = np.asarray(table.channel("cdf_theta_r"), dtype=np.float64)
        self.marginal = cdf_t[..., 0]
        self.conditional = np.asarray(table.channel("cdf_phi_r"), dtype=np.float64)
        if not np.all(np.isfinite(self.rgb)) or np.any(self.rgb < 0):
            raise ValueError("the BRDF channels have negative or non-finite values")
        for name, c in (("cdf_theta_r", self.marginal), ("cdf_phi_r", self.conditional)):
            if np.any(np.diff(c, axis=-1) < 0) or np.any(np.abs(c[..., -1] - 1.0) > 1e-5):
                raise ValueError(f"{name} is not a CDF (non-decreasing, ending at 1)")
        if np.any(np.abs(cdf_t - cdf_t[..., :1]) > 0):
            raise ValueError("cdf_theta_r differs along phi_r (one value per theta_r cell)")
        self.albedo = np.asarray(attrs["albedo_rgb_as_printed"], dtype=float)

    def _check_grid(self, coords, domain):
        ti, pi, tr, pr = coords
        h = float(ti[1] - ti[0]) if len(ti) > 1 else 90.0
        n = len(ti)
        if not np.allclose(ti, (np.arange(n) + 0.5) * h, atol=1e-9) or abs(n * h - 90.0) > 1e-9:
            raise ValueError("theta_i must be at the cell centres (k + 1/2) h of [0, 90] deg")
        if not np.array_equal(ti, tr):
            raise ValueError("theta_r must equal theta_i")
        lo, hi = phi_i_domain_deg(*self.symmetry)
        if domain != (lo, hi):
            raise ValueError(f"phi_i domain {domain} does not match the symmetry ({lo}, {hi})")
        if not np.allclose(pi, lo + np.arange(len(pi)) * h, atol=1e-9) or abs(pi[-1] - hi) > 1e-9:
            raise ValueError(f"phi_i must be the nodes {lo}, {lo} + h, ..., {hi} deg")
        if not np.allclose(pr, -180.0 + np.arange(len(pr)) * h, atol=1e-9) or abs(pr[-1] - 180.0) > 1e-9:
            raise ValueError("phi_r must be the nodes -180, -180 + h, ..., 180 deg")
        self.step_deg = h
        self.phi_i_lo = lo
        self.shape = (n, len(pi), n, len(pr))


def reduce_deg(symmetry, phi_i, phi_r, select=np.where):
    """(φ_i′, φ_r′, s, c): the header's mirrors applied to both azimuths (degrees) until φ_i′
    lies in the stored domain, and the map φ′ = s φ + c (mod 360°) they compose to. ``select``
    is ``np.where`` (numpy) or ``dr.select`` (Dr.Jit)."""
    mirror_x, mirror_y, swap_xy = symmetry
    pi, pr = _wrap_deg(phi_i), _wrap_deg(phi_r)
    s, c = pi * 0.0 + 1.0, pi * 0.0
    if mirror_y:
        m = pi < 0.0
        pi, pr, s, c = select(m, -pi, pi), select(m, -pr, pr), select(m, -s, s), select(m, -c, c)
    if mirror_x:
        m = abs(pi) > 90.0
        pi = select(m, _wrap_deg(180.0 - pi), pi)
        pr = select(m, _wrap_deg(180.0 - pr), pr)
        s, c = select(m, -s, s), select(m, 180.0 - c, c)
    if swap_xy and mirror_y:
        m = pi > 45.0
        pi, pr = select(m, 90.0 - pi, pi), select(m, 90.0 - pr, pr)
        s, c = select(m, -s, s), select(m, 90.0 - c, c)
    return _wrap_deg(pi), _wrap_deg(pr), s, c


_CLASSES = {}


def bsdf_class():
    """The plugin class for the current Mitsuba variant."""
    return class_for_variant(_CLASSES, _make_class)


def _cell(x, n):
    """(j, t): x in units of the grid step from the first node, clamped to [0, n − 1] (constant
    beyond the end nodes), as a cell index j ∈ [0, n − 2] and a weight t ∈ [0, 1]."""
    x = dr.clip(x, 0.0, n - 1.0)
    j = dr.minimum(mi.UInt32(dr.floor(x)), n - 2)
    return j, x - mi.Float(j)


def _make_class():
    class ScatterbakeCloth(mi.BSDF):
        """The ``scatterbake_cloth`` BSDF (see the module documentation)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if not mi.is_rgb:
                raise ValueError("scatterbake_cloth needs an RGB variant (the table is RGB)")
            self.data = ClothTable(_open_table(props["filename"]))
            self.warp_rad = math.radians(
                float(props["warp_angle_deg"]) if "warp_angle_deg" in props else 0.0)
            d = self.data
            self.h = d.step_deg
            self.nt, self.npi, _, self.npr = d.shape
            self.rgb = _buffer(d.rgb)
            self.marginal = _buffer(d.marginal)
            self.conditional = _buffer(d.conditional)
            # 1 − cos θ = 2 sin²(θ/2) at the θ cell edges k h, exact in float32 near the normal.
            edges = np.radians(np.arange(self.nt + 1) * self.h)
            self.versin = _buffer(2.0 * np.sin(0.5 * edges) ** 2)
            flags = (mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
                     | mi.BSDFFlags.Anisotropic | mi.BSDFFlags.NonSymmetric)
            self.m_components = [flags]
            self.m_flags = flags

        # Angles ----------------------------------------------------------------------------

        def _angles(self, w):
            """(θ, φ) in degrees of a local direction in the cloth frame (φ from the warp)."""
            theta = dr.atan2(dr.sqrt(dr.fma(w.x, w.x, w.y * w.y)), w.z) * (180.0 / dr.pi)
            phi = (dr.atan2(w.y, w.x) - self.warp_rad) * (180.0 / dr.pi)
            return theta, phi

        def _reduce(self, phi_i, phi_r):
            return reduce_deg(self.data.symmetry, phi_i, phi_r, dr.select)

        def _node(self, theta_i, phi_i_red):
            """Flat (θ_i, φ_i) node index nearest to the (reduced) incident direction."""
            k = dr.minimum(mi.UInt32(dr.floor(theta_i / self.h)), self.nt - 1)
            p = (phi_i_red - self.data.phi_i_lo) / self.h
            m = dr.minimum(mi.UInt32(dr.clip(dr.round(p), 0.0, self.npi - 1.0)), self.npi - 1)
            return k * self.npi + m

        # Evaluation ------------------------------------------------------------------------

        def _lookup(self, light, view, active):
            """f(light → view) (1/sr, RGB) by multilinear interpolation; 0 off the front side."""
            ti, pi = self._angles(light)
            tr, pr = self._angles(view)
            pi, pr, _, _ = self._reduce(pi, pr)
            half = 0.5 * self.h
            axes = [_cell((ti - half) / self.h, self.nt),
                    _cell((pi - self.data.phi_i_lo) / self.h, self.npi),
                    _cell((tr - half) / self.h, self.nt),
                    _cell((pr + 180.0) / self.h, self.npr)]
            sizes = (self.nt, self.npi, self.nt, self.npr)
            front = active & (light.z > 0.0) & (view.z > 0.0)
            out = [mi.Float(0.0), mi.Float(0.0), mi.Float(0.0)]
            for corner in range(16):
                flat, weight = mi.UInt32(0), mi.Float(1.0)
                for a in range(4):
                    j, t = axes[a]
                    up = (corner >> (3 - a)) & 1
                    flat = flat * sizes[a] + j + up
                    weight *= t if up else 1.0 - t
                for c in range(3):
                    out[c] += weight * _gather(self.rgb, flat * 3 + c, front)
            return [dr.select(front, v, 0.0) for v in out], front

        def _light_view(self, ctx, wi, wo):
            if ctx.mode == mi.TransportMode.Radiance:
                return wo, wi
            return wi, wo

        def eval(self, ctx, si, wo, active=True):
            light, view = self._light_view(ctx, si.wi, wo)
            (r, g, b), front = self._lookup(light, view, active)
            cos_o = dr.maximum(wo.z, 0.0)
            return mi.Color3f(r * cos_o, g * cos_o, b * cos_o)

        def _table_pdf(self, wi, wo, active):
            """Density per solid angle of the table's CDF proposal for wo given wi."""
            ti, pi = self._angles(wi)
            tr, pr = self._angles(wo)
            pi, pr, _, _ = self._reduce(pi, pr)
            base = self._node(ti, pi)
            k = dr.minimum(mi.UInt32(dr.floor(tr / self.h)), self.nt - 1)
            col = base * self.nt
            m_hi = _gather(self.marginal, col + k, active)
            m_lo = dr.select(k > 0, _gather(self.marginal, col + k - 1, active & (k > 0)), 0.0)
            l = dr.minimum(mi.UInt32(dr.floor(dr.clip((pr + 180.0) / self.h, 0.0, self.npr))),
                           self.npr - 2)
            row = (col + k) * self.npr
            c_lo = _gather(self.conditional, row + l, active)
            c_hi = _gather(self.conditional, row + l + 1, active)
            solid = (_gather(self.versin, k + 1, active) - _gather(self.versin, k, active)) * (
                math.radians(self.h))
            p = (m_hi - m_lo) * (c_hi - c_lo) / solid
            return dr.select(active, p, 0.0)

        def _pdf(self, wi, wo, active):
            ok = active & (wi.z > 0.0) & (wo.z > 0.0)
            p = (1.0 - DEFENSIVE_FRACTION) * self._table_pdf(wi, wo, ok)
            p += DEFENSIVE_FRACTION * mi.warp.square_to_cosine_hemisphere_pdf(wo)
            return dr.select(ok, p, 0.0)

        def pdf(self, ctx, si, wo, active=True):
            return self._pdf(si.wi, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self._pdf(si.wi, wo, active)

        # Sampling --------------------------------------------------------------------------

        def _sample_table(self, wi, u, active):
            """wo from the table's CDFs at the node nearest to wi (local frame)."""
            ti, pi = self._angles(wi)
            pi, _, s, c = self._reduce(pi, pi)
            col = self._node(ti, pi) * self.nt
            nt, npr = self.nt, self.npr
            k = dr.binary_search(0, nt - 1, lambda x: _gather(self.marginal, col + x, active) <= u.x)
            m_hi = _gather(self.marginal, col + k, active)
            m_lo = dr.select(k > 0, _gather(self.marginal, col + k - 1, active & (k > 0)), 0.0)
            ux = dr.clip((u.x - m_lo) / dr.maximum(m_hi - m_lo, 1e-30), 0.0, 1.0)
            row = (col + k) * npr
            l1 = dr.binary_search(1, npr - 1,
                                  lambda x: _gather(self.conditional, row + x, active) <= u.y)
            l = l1 - 1
            c_lo = _gather(self.conditional, row + l, active)
            c_hi = _gather(self.conditional, row + l + 1, active)
            uy = dr.clip((u.y - c_lo) / dr.maximum(c_hi - c_lo, 1e-30), 0.0, 1.0)
            # Uniform in solid angle inside the cell: 1 − cos θ uniform between the cell's edges.
            v0 = _gather(self.versin, k, active)
            v = v0 + ux * (_gather(self.versin, k + 1, active) - v0)
            ct, st = 1.0 - v, dr.safe_sqrt(v * (2.0 - v))
            phi_red = -180.0 + (mi.Float(l) + uy) * self.h
            phi = s * (phi_red - c) * (dr.pi / 180.0) + self.warp_rad
            sp, cp = dr.sincos(phi)
            return mi.Vector3f(st * cp, st * sp, ct)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            ok = active & (wi.z > 0.0)
            cosine = sample1 < DEFENSIVE_FRACTION
            wo = dr.select(cosine, mi.warp.square_to_cosine_hemisphere(sample2),
                           self._sample_table(wi, sample2, ok))
            value, pdf = self.eval_pdf(ctx, si, wo, ok)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            weight = dr.select(ok & (pdf > 0.0), value / dr.maximum(pdf, 1e-30), 0.0)
            return bs, weight

        def traverse(self, callback):
            pass

        def to_string(self):
            d = self.data
            return (f"ScatterbakeCloth[fabric={d.fabric}, step={d.step_deg} deg, "
                    f"grid={d.shape}, warp_angle={math.degrees(self.warp_rad)} deg]")

    return ScatterbakeCloth


def register(name: str = PLUGIN_NAME) -> None:
    """Register the BSDF under ``name`` for the current Mitsuba variant (call after
    ``mi.set_variant``)."""
    cls = bsdf_class()
    mi.register_bsdf(name, lambda props: cls(props))
