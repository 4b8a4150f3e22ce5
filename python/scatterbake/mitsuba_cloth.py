"""Mitsuba 3 BSDF for scatterbake's cloth tables (``cloth-brdf/1``, docs/cloth.md).

The table holds the microcylinder cloth BRDF of Sadeghi et al. (2013) of one fabric preset as
K = f·cos θ_i on a 4-D grid (θ_i, φ_i, β_x, β_y): the light direction and the projected half
angles of the half vector h = (ω_i + ω_r)/|ω_i + ω_r|, β_x = atan2(h_x, h_z),
β_y = atan2(h_y, h_z), with its sampling CDFs over half-vector cells. This module registers the
Mitsuba 3 BSDF ``scatterbake_cloth`` that evaluates and importance-samples such a table::

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
  ``reduce`` says (the same mirrors applied to both azimuths); h of the reduced directions gives
  (β_x, β_y); K by multilinear interpolation in (θ_i, φ_i, β_x, β_y), clamped at the axis ends;
  f = K / cos θ_i. At and below the horizon (cos θ ≤ 0 for either direction) the BSDF is 0: the
  cloth is one-sided. A table whose schema, axes, units or channels do not match this layout is
  refused when the plugin is created (``ValueError``).
- Sampling: a proposal for ``wo`` given ``si.wi``, taking ``si.wi`` as the table's ω_i: the
  table's CDFs at the (θ_i, φ_i) node nearest to the reduced direction of ``si.wi`` pick a β_x
  interval (``cdf_half_x``) and a β_y interval (``cdf_half_y``); (β_x, β_y) is uniform inside,
  ``wo`` is ``si.wi`` reflected about h and mapped back by the inverse of the reduction (lost,
  with density 0, when it falls below the horizon). Its density per solid angle is
  w_cell / (W Δβ_x Δβ_y J(β) 4(ω_i·h)), J = sec²β_x sec²β_y / (1 + tan²β_x + tan²β_y)^{3/2}.
  ``DEFENSIVE_FRACTION`` of the samples are cosine-weighted on the hemisphere, so every direction
  with a value has a density. In importance mode this follows the table's own conditional
  f(ω_i, ·) cos θ_r; in radiance mode it is the reciprocal configuration, a proposal only (the
  model is not reciprocal). ``pdf`` is the density of exactly this proposal and ``sample``
  returns weight = eval/pdf.
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
SCHEMA_VERSIONS = (2,)
AXES = ("theta_i", "phi_i", "half_x", "half_y")
CHANNELS = ("k_r", "k_g", "k_b", "cdf_half_x", "cdf_half_y")
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

    ``k`` (NT × NPI × NX × NY × 3, K = f cos θ_i, 1/sr), ``marginal`` (NT × NPI × NX),
    ``conditional`` (NT × NPI × NX × NY); the axes ``theta_i``, ``phi_i``, ``half_x``,
    ``half_y`` (degrees); ``phi_step`` and ``phi_i_lo``; ``symmetry`` the header's flags;
    ``albedo`` (NT × NPI × 3) the header's directional albedo."""

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
        self.k = np.stack([np.asarray(table.channel(c), dtype=np.float64)
                           for c in ("k_r", "k_g", "k_b")], -1)
        cdf_x = np.asarray(table.channel("cdf_half_x"), dtype=np.float64)
        self.marginal = cdf_x[..., 0]
        self.conditional = np.asarray(table.channel("cdf_half_y"), dtype=np.float64)
        if not np.all(np.isfinite(self.k)) or np.any(self.k < 0):
            raise ValueError("the K channels have negative or non-finite values")
        for name, c in (("cdf_half_x", self.marginal), ("cdf_half_y", self.conditional)):
            if np.any(np.diff(c, axis=-1) < 0) or np.any(np.abs(c[..., -1] - 1.0) > 1e-5):
                raise ValueError(f"{name} is not a CDF (non-decreasing, ending at 1)")
        if np.any(np.abs(cdf_x - cdf_x[..., :1]) > 0):
            raise ValueError("cdf_half_x differs along half_y (one value per half_x node)")
        self.albedo = np.asarray(attrs["albedo_rgb_as_printed"], dtype=float)

    def _check_grid(self, coords, domain):
        ti, pi, hx, hy = coords
        if np.any(ti <= 0.0) or np.any(ti >= 90.0) or np.any(np.diff(ti) <= 0):
            raise ValueError("theta_i must increase inside (0, 90) deg")
        lo, hi = phi_i_domain_deg(*self.symmetry)
        if domain != (lo, hi):
            raise ValueError(f"phi_i domain {domain} does not match the symmetry ({lo}, {hi})")
        step = float(pi[1] - pi[0]) if len(pi) > 1 else 0.0
        if (len(pi) < 2 or not np.allclose(pi, lo + np.arange(len(pi)) * step, atol=1e-9)
                or abs(pi[-1] - hi) > 1e-9):
            raise ValueError(f"phi_i must be uniform nodes from {lo} to {hi} deg")
        for name, h in (("half_x", hx), ("half_y", hy)):
            if len(h) < 2 or np.any(np.abs(h) >= 90.0) or np.any(np.diff(h) <= 0):
                raise ValueError(f"{name} must increase inside (-90, 90) deg")
        self.theta_i, self.phi_i, self.half_x, self.half_y = ti, pi, hx, hy
        self.phi_step = step
        self.phi_i_lo = lo
        self.shape = (len(ti), len(pi), len(hx), len(hy))


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


def _locate(buf, n, x, active):
    """(j, t) on an increasing axis stored in ``buf`` (n values): x between nodes j and j + 1 at
    fraction t, clamped to the end nodes."""
    idx = dr.binary_search(0, n - 1, lambda k: _gather(buf, k, active) <= x)
    j = dr.minimum(dr.maximum(idx, 1) - 1, n - 2)
    lo, hi = _gather(buf, j, active), _gather(buf, j + 1, active)
    return j, dr.clip((x - lo) / (hi - lo), 0.0, 1.0)


def _direction(theta_deg, phi_deg):
    st, ct = dr.sincos(theta_deg * (dr.pi / 180.0))
    sp, cp = dr.sincos(phi_deg * (dr.pi / 180.0))
    return mi.Vector3f(st * cp, st * sp, ct)


def _half_angles(h):
    """(β_x, β_y) in degrees of a half vector."""
    return dr.atan2(h.x, h.z) * (180.0 / dr.pi), dr.atan2(h.y, h.z) * (180.0 / dr.pi)


def _jacobian(bx, by):
    """Solid angle of h per dβ_x dβ_y (sr/rad²)."""
    a, b = dr.tan(bx * (dr.pi / 180.0)), dr.tan(by * (dr.pi / 180.0))
    q = 1.0 + a * a + b * b
    return (1.0 + a * a) * (1.0 + b * b) / (q * dr.sqrt(q))


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
            self.nt, self.npi, self.nx, self.ny = d.shape
            self.k = _buffer(d.k)
            self.marginal = _buffer(d.marginal)
            self.conditional = _buffer(d.conditional)
            self.theta_axis = _buffer(d.theta_i)
            self.hx_axis = _buffer(d.half_x)
            self.hy_axis = _buffer(d.half_y)
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

        def _node(self, theta_i, phi_i_red, active):
            """Flat (θ_i, φ_i) node index nearest to the (reduced) incident direction."""
            j, t = _locate(self.theta_axis, self.nt, theta_i, active)
            k = dr.select(t > 0.5, j + 1, j)
            p = (phi_i_red - self.data.phi_i_lo) / self.data.phi_step
            m = dr.minimum(mi.UInt32(dr.clip(dr.round(p), 0.0, self.npi - 1.0)), self.npi - 1)
            return k * self.npi + m

        def _reduced(self, a, b):
            """The reduced (light-frame) vectors of directions a (the table's ω_i) and b, their
            θ_a (degrees) and reduced φ_a, and the map φ' = s φ + c."""
            ta, pa = self._angles(a)
            tb, pb = self._angles(b)
            pa, pb, s, c = self._reduce(pa, pb)
            return _direction(ta, pa), _direction(tb, pb), ta, pa, s, c

        # Evaluation ------------------------------------------------------------------------

        def _lookup(self, light, view, active):
            """f(light → view) (1/sr, RGB) by multilinear interpolation of K; 0 off the front
            side."""
            wi, wr, ti, pi, _, _ = self._reduced(light, view)
            front = active & (light.z > 0.0) & (view.z > 0.0)
            bx, by = _half_angles(dr.normalize(wi + wr))
            axes = [_locate(self.theta_axis, self.nt, ti, front),
                    _cell((pi - self.data.phi_i_lo) / self.data.phi_step, self.npi),
                    _locate(self.hx_axis, self.nx, bx, front),
                    _locate(self.hy_axis, self.ny, by, front)]
            sizes = (self.nt, self.npi, self.nx, self.ny)
            out = [mi.Float(0.0), mi.Float(0.0), mi.Float(0.0)]
            for corner in range(16):
                flat, weight = mi.UInt32(0), mi.Float(1.0)
                for a in range(4):
                    j, t = axes[a]
                    up = (corner >> (3 - a)) & 1
                    flat = flat * sizes[a] + j + up
                    weight *= t if up else 1.0 - t
                for c in range(3):
                    out[c] += weight * _gather(self.k, flat * 3 + c, front)
            cos_i = dr.maximum(light.z, 1e-30)
            return [dr.select(front, v / cos_i, 0.0) for v in out], front

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
            a, b, ti, pi, _, _ = self._reduced(wi, wo)
            h = dr.normalize(a + b)
            bx, by = _half_angles(h)
            nx, ny = self.nx, self.ny
            x0, x1 = float(self.data.half_x[0]), float(self.data.half_x[-1])
            y0, y1 = float(self.data.half_y[0]), float(self.data.half_y[-1])
            ok = active & (h.z > 0.0) & (bx >= x0) & (bx <= x1) & (by >= y0) & (by <= y1)
            i, _ = _locate(self.hx_axis, nx, bx, ok)
            j, _ = _locate(self.hy_axis, ny, by, ok)
            col = self._node(ti, pi, ok) * nx
            m = _gather(self.marginal, col + i + 1, ok) - _gather(self.marginal, col + i, ok)
            row = (col + i) * ny
            c = _gather(self.conditional, row + j + 1, ok) - _gather(self.conditional, row + j, ok)
            area = ((_gather(self.hx_axis, i + 1, ok) - _gather(self.hx_axis, i, ok))
                    * (_gather(self.hy_axis, j + 1, ok) - _gather(self.hy_axis, j, ok))
                    * (dr.pi / 180.0) ** 2)
            dens = m * c / (area * _jacobian(bx, by) * 4.0 * dr.maximum(dr.dot(a, h), 1e-30))
            return dr.select(ok, dens, 0.0)

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
            a, _, ti, pi, s, c = self._reduced(wi, wi)
            nx, ny = self.nx, self.ny
            col = self._node(ti, pi, active) * nx
            i = dr.binary_search(0, nx - 1, lambda x: _gather(self.marginal, col + x, active) <= u.x)
            i = dr.minimum(dr.maximum(i, 1) - 1, nx - 2)
            m_lo = _gather(self.marginal, col + i, active)
            m_hi = _gather(self.marginal, col + i + 1, active)
            ux = dr.clip((u.x - m_lo) / dr.maximum(m_hi - m_lo, 1e-30), 0.0, 1.0)
            row = (col + i) * ny
            j = dr.binary_search(0, ny - 1,
                                 lambda x: _gather(self.conditional, row + x, active) <= u.y)
            j = dr.minimum(dr.maximum(j, 1) - 1, ny - 2)
            c_lo = _gather(self.conditional, row + j, active)
            c_hi = _gather(self.conditional, row + j + 1, active)
            uy = dr.clip((u.y - c_lo) / dr.maximum(c_hi - c_lo, 1e-30), 0.0, 1.0)
            x0 = _gather(self.hx_axis, i, active)
            y0 = _gather(self.hy_axis, j, active)
            bx = x0 + ux * (_gather(self.hx_axis, i + 1, active) - x0)
            by = y0 + uy * (_gather(self.hy_axis, j + 1, active) - y0)
            h = dr.normalize(mi.Vector3f(dr.tan(bx * (dr.pi / 180.0)),
                                         dr.tan(by * (dr.pi / 180.0)), 1.0))
            wr = 2.0 * dr.dot(a, h) * h - a
            theta = dr.atan2(dr.sqrt(dr.fma(wr.x, wr.x, wr.y * wr.y)), wr.z)
            phi_red = dr.atan2(wr.y, wr.x) * (180.0 / dr.pi)
            phi = s * (phi_red - c) * (dr.pi / 180.0) + self.warp_rad
            st, ct = dr.sincos(theta)
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
            return (f"ScatterbakeCloth[fabric={d.fabric}, "
                    f"grid={d.shape}, warp_angle={math.degrees(self.warp_rad)} deg]")

    return ScatterbakeCloth


def register(name: str = PLUGIN_NAME) -> None:
    """Register the BSDF under ``name`` for the current Mitsuba variant (call after
    ``mi.set_variant``)."""
    cls = bsdf_class()
    mi.register_bsdf(name, lambda props: cls(props))
