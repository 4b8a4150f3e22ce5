"""Mitsuba 3 phase function for scatterbake's 2-D ray-traced phase tables (``raytrace-phase-2d``).

Non-spherical raindrops (Beard & Chuang 1987 shapes) scatter differently for every sun
elevation and around the bow: their tables have the axes ``[radius ×] wavelength ×
sun_elevation × outgoing_polar × outgoing_azimuth`` (docs/raytrace.md). This module registers
the Mitsuba 3 phase function ``scatterbake_2d`` that evaluates and importance-samples such a
table, so that a homogeneous medium of falling drops lit by a ``directional`` sun renders the
twinned rainbow::

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    from scatterbake import mitsuba_phase      # or: import mitsuba_phase (standalone file)
    mitsuba_phase.register()                    # after mi.set_variant
    phase = {"type": "scatterbake_2d", "filename": "tables/raytrace-beard-chuang-1mm.sbt"}

Standalone use: copy this file and ``python/scatterbake_table.py`` (the pure-Python reader,
numpy + zstandard) side by side; inside the installed ``scatterbake`` package the library's own
reader is used. Both read the same files and verify every checksum.

Conventions (docs/consumers.md, "Mitsuba 3: 2-D tables as a phase function"):

- The drops' symmetry axis is the world vector ``up`` (default (0, 0, 1)); the table's frame is
  rebuilt around it for every query, so no sun azimuth is needed.
- Light side and view side: Mitsuba passes two directions pointing away from the scattering
  point, ``mi.wi`` and ``wo``. The light arrives from ``wo`` in radiance mode (camera paths,
  every standard integrator) and from ``mi.wi`` in importance mode (light paths); that
  direction is the sun's: its elevation above the plane normal to ``up`` selects the table's
  ``sun_elevation`` and the incident (propagation) direction is d = −(light side). The other
  direction w is the outgoing one: ``outgoing_polar`` = angle(d, w) (0 = forward),
  ``outgoing_azimuth`` = atan2(w·e2, w·e1) in [0, 360) with e1 = normalize(up − (up·d) d) and
  e2 = d × e1 — the frame of ``scatterbake render rainbow``.
- Lookup: bilinear in (polar, azimuth), the azimuth periodic; linear in sun elevation between
  the table's elevations. A light-side elevation outside the table's ``sun_elevation`` range
  widened by ``elevation_tolerance_deg`` (default 0.25°, the sun's radius; within it the
  nearest end is used) scatters **nothing** (the value is 0): a table traced for a sun at 0°
  says nothing about light from 30°. Multiple scattering therefore keeps only the light that
  arrives within the range. Nothing else is clamped: a table whose polar axis does not cover
  [0, 180]°, whose azimuth axis does not start at 0°, with negative or non-finite phase values,
  an unknown schema version, a wavelength outside the table or an entry value that is not a
  stored sample is refused when the plugin is created (``ValueError``).
- Normalisation (parameter ``normalise``, default true): the tables integrate to 1 as bin
  sums; under the bilinear lookup the forward lobe's first node (a bin average over
  [0, Δθ/2]) spreads over [0, Δθ] and ∫ p dΩ exceeds 1 (1.16 on a 0.25° grid). Every
  (wavelength, sun elevation) is divided by its integral under the lookup
  (``TableData.integral``), so an albedo-1 medium conserves energy; ``normalise = false``
  keeps the stored values (as ``render rainbow``).
- Colour (parameter ``mode``): ``"rgb"`` (RGB variants, default there): each linear-sRGB
  channel is Σ_k W_ck p_k over the table's wavelengths, W from the CIE 1931 2° colour-matching
  functions and a D65 sun integrated over each wavelength's cell (the weights of
  ``render rainbow``), then XYZ → linear sRGB and every channel normalised to Σ_k W_ck = 1, so a
  wavelength-independent table renders white; channels can be slightly negative where the
  scattered light is more saturated than sRGB, exactly as ``render rainbow`` before clipping.
  ``"mono"`` (any variant; the default when ``wavelength_nm`` is given): the table at one
  wavelength (linear between the table's wavelengths), the same in every channel.
  ``"spectral"`` (spectral variants, default there): the table at each of Mitsuba's sampled
  wavelengths, linear between the table's; light outside the table's wavelength range is not
  scattered.
- Sampling: per sun elevation of the table, a piecewise-constant density over the table's
  cells (polar × azimuth between grid nodes, weight = mean of the four corners × the cell's
  solid angle) is sampled by its marginal over azimuth, then the conditional over polar angle,
  then uniformly in solid angle inside the cell; 2 % of the samples are uniform on the sphere
  so that no direction with a non-zero value has zero density. The channel sampled is the
  luminance Y (``rgb``, ``spectral``) or the wavelength (``mono``). The proposal uses ``mi.wi``
  as the light side (for radiance mode this is the reciprocal configuration, exact for a
  reciprocal table), at the nearest elevation of the table when ``mi.wi``'s lies outside it,
  mixing the two neighbouring elevations linearly otherwise. ``eval_pdf`` returns the value
  above and the density of exactly this proposal, and ``sample`` returns weight = value / pdf.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

#: Name under which :func:`register` registers the plugin.
PLUGIN_NAME = "scatterbake_2d"
#: Schema of the tables read, and its versions.
SCHEMA = "raytrace-phase-2d"
SCHEMA_VERSIONS = (1, 2)
#: Share of the samples drawn uniformly on the sphere.
DEFENSIVE_FRACTION = 0.02

# IEC 61966-2-1: XYZ (D65 white) → linear sRGB.
_XYZ_TO_SRGB = np.array(
    [
        [3.2404542, -1.5371385, -0.4985314],
        [-0.9692660, 1.8760108, 0.0415560],
        [0.0556434, -0.2040259, 1.0572252],
    ]
)


def _open_table(path):
    """Read a table with the package's reader inside ``scatterbake``, else the pure-Python one."""
    if __package__:
        from . import open_table

        return open_table(str(path))
    import scatterbake_table

    return scatterbake_table.open_table(path)


def cie_d65_weights(wavelengths_nm) -> np.ndarray:
    """XYZ weights (k × 3) of samples at ``wavelengths_nm`` lit by D65: each sample stands for
    the cell between the midpoints to its neighbours, integrated at 0.25 nm with Mitsuba's CIE
    1931 2° tables; normalised so that a flat spectrum gives Y = 1 (the weights of
    ``render rainbow``)."""
    s = mi.scalar_rgb
    wl = np.asarray(wavelengths_nm, dtype=float)
    n = len(wl)
    out = np.zeros((n, 3))
    for k in range(n):
        lo = wl[0] if k == 0 else 0.5 * (wl[k - 1] + wl[k])
        hi = wl[-1] if k == n - 1 else 0.5 * (wl[k] + wl[k + 1])
        if n == 1:
            lo, hi = wl[0] - 0.5, wl[0] + 0.5
        steps = max(1, math.ceil((hi - lo) / 0.25))
        dl = (hi - lo) / steps
        for i in range(steps):
            lam = lo + (i + 0.5) * dl
            xyz = s.cie1931_xyz(lam)
            out[k] += np.array([xyz[0], xyz[1], xyz[2]]) * float(s.cie_d65(lam)) * dl
    return out / out[:, 1].sum()


def srgb_weights(wavelengths_nm):
    """(W, y): W (3 × k) turns the table's wavelengths into linear sRGB, every row normalised
    to sum 1; y (k) the luminance weights, summing to 1."""
    xyz = cie_d65_weights(wavelengths_nm)
    w = _XYZ_TO_SRGB @ xyz.T
    sums = w.sum(axis=1, keepdims=True)
    if np.any(sums <= 0):
        raise ValueError("the table's wavelengths do not cover the three sRGB channels")
    return w / sums, xyz[:, 1] / xyz[:, 1].sum()


def check_schema(header, name, versions):
    """Refuse (ValueError) a table whose header's schema is not ``name`` at one of ``versions``."""
    schema = header["schema"]
    if schema["name"] != name:
        raise ValueError(f"schema `{schema['name']}` is not `{name}`")
    if schema["version"] not in versions:
        raise ValueError(f"`{name}/{schema['version']}` is not a version this plugin reads")


def _axis_index(names, name):
    return names.index(name) if name in names else None


class TableData:
    """The numbers the plugin needs, prepared with numpy from a table (variant independent).

    ``values`` (E × NP × NA × C): the phase (1/sr) per table sun elevation, polar and azimuth
    node and channel; ``sampling`` (E × NP × NA) the channel the proposal follows; ``cell_pdf``
    (E × NA × NP−1, 1/sr), ``marginal_cdf`` (E × NA), ``conditional_cdf`` (E × NA × NP−1)."""

    def __init__(self, table, mode="rgb", wavelength_nm=None, entry=None, normalise=True):
        header = table.header
        check_schema(header, SCHEMA, SCHEMA_VERSIONS)
        names = [a.name for a in table.axes]
        n = len(names)
        if n < 4 or names[-3:] != ["sun_elevation", "outgoing_polar", "outgoing_azimuth"]:
            raise ValueError(f"expected [...] × sun_elevation × outgoing_polar × outgoing_azimuth, found {names}")
        iw = _axis_index(names[:-3], "wavelength")
        if iw is None:
            raise ValueError(f"no wavelength axis before sun_elevation: {names}")
        coords = [np.asarray(a.coords, dtype=float) for a in table.axes]
        phase = np.asarray(table.channel("phase"), dtype=np.float64)
        phase = self._select_entry(phase, names, coords, iw, entry or {})
        coords[-1], phase = self._unfold_azimuth(getattr(table.axes[-1], "symmetry", None), coords[-1], phase)
        self.elevations_deg = coords[-3]
        self.polar_deg = coords[-2]
        self.azimuth_deg = coords[-1]
        self.table_wavelengths_nm = coords[iw]
        self._check_axes()
        if not np.all(np.isfinite(phase)) or np.any(phase < 0):
            raise ValueError("the phase channel has negative or non-finite values")
        # ∫ p dΩ of every (wavelength, sun elevation) under this plugin's bilinear lookup.
        self.integral = np.einsum("pa,kepa->ke", self.node_solid_angles(), phase)
        if np.any(self.integral <= 0):
            raise ValueError("a (wavelength, sun elevation) of the table has no scattered light")
        if normalise:
            phase = phase / self.integral[:, :, None, None]
        self.mode = mode
        self.channel_wavelengths_nm = None
        wl = self.table_wavelengths_nm
        if mode == "mono":
            interpolable = header.get("attributes", {}).get("interpolable_axes")
            v = self._at_wavelength(phase, wl, wavelength_nm, interpolable)
            self.values = v[..., None]
            self.sampling = v
        elif mode == "rgb":
            w, y = srgb_weights(wl)
            self.values = np.einsum("ck,kepa->epac", w, phase)
            self.sampling = np.einsum("k,kepa->epa", y, phase)
        elif mode == "spectral":
            y = cie_d65_weights(wl)[:, 1]
            self.values = np.moveaxis(phase, 0, -1)
            self.sampling = np.einsum("k,kepa->epa", y / y.sum(), phase)
            self.channel_wavelengths_nm = wl
        else:
            raise ValueError(f"mode must be rgb, mono or spectral, not {mode!r}")
        self._build_sampler()

    def node_solid_angles(self) -> np.ndarray:
        """ω (NP × NA, sr) with ∫ f dΩ = Σ ω_ja f_ja for f bilinear in (polar, azimuth) between
        the nodes, azimuth periodic (8-point Gauss–Legendre in θ per cell, exact in φ)."""
        th = np.radians(self.polar_deg)
        x, wq = np.polynomial.legendre.leggauss(8)
        s = 0.5 * (x + 1.0)  # position in the cell
        h = np.diff(th)
        sin = np.sin(th[:-1, None] + s[None, :] * h[:, None])  # cells × 8
        left = 0.5 * h * np.sum(wq * (1.0 - s) * sin, axis=1)
        right = 0.5 * h * np.sum(wq * s * sin, axis=1)
        wp = np.zeros(len(th))
        wp[:-1] += left
        wp[1:] += right
        dphi = np.radians(np.diff(np.append(self.azimuth_deg, 360.0)))
        wa = 0.5 * (dphi + np.roll(dphi, 1))
        return wp[:, None] * wa[None, :]

    @staticmethod
    def _unfold_azimuth(symmetry, azimuth_deg, phase):
        """An even-periodic azimuth axis (table format 3.0: 0°–180° stored, the value at
        360° − φ that at φ) onto the full circle: the stored nodes, then the mirror images of
        those strictly between 0° and 180°; any other axis as it is."""
        if symmetry is None:
            return azimuth_deg, phase
        period = float(symmetry["period"])
        if symmetry.get("kind") != "even-periodic" or period != 360.0:
            raise ValueError(f"outgoing_azimuth has symmetry {symmetry}; a phase function's azimuth is even-periodic with period 360 deg")
        n = len(azimuth_deg)
        mirrored = np.arange(n - 2, 0, -1)
        index = np.concatenate([np.arange(n), mirrored])
        return np.concatenate([azimuth_deg, period - azimuth_deg[mirrored]]), phase[..., index]

    @staticmethod
    def _select_entry(phase, names, coords, iw, entry):
        """Reduce the entry axes (e.g. radius) to one stored sample: → wavelength × E × NP × NA."""
        n = len(names)
        extra = [i for i in range(n - 3) if i != iw]
        unknown = set(entry) - {names[i] for i in extra}
        if unknown:
            raise ValueError(f"no entry axis {sorted(unknown)} (entry axes: {[names[i] for i in extra]})")
        index = []
        for i in range(n):
            if i not in extra:
                index.append(slice(None))
                continue
            c = coords[i]
            if names[i] not in entry:
                if len(c) > 1:
                    raise ValueError(f"the table has {len(c)} {names[i]} samples {list(c)}: choose one")
                index.append(0)
                continue
            x = float(entry[names[i]])
            k = int(np.argmin(np.abs(c - x)))
            if abs(c[k] - x) > 1e-9 * max(1.0, abs(x)):
                raise ValueError(f"{names[i]} = {x} is not a sample of the table (nearest {c[k]})")
            index.append(k)
        return phase[tuple(index)]

    def _check_axes(self):
        p, a, e = self.polar_deg, self.azimuth_deg, self.elevations_deg
        for name, c in (("outgoing_polar", p), ("outgoing_azimuth", a), ("sun_elevation", e)):
            if len(c) > 1 and np.any(np.diff(c) <= 0):
                raise ValueError(f"axis {name} is not strictly increasing")
        if len(p) < 2 or abs(p[0]) > 1e-9 or abs(p[-1] - 180.0) > 1e-9:
            raise ValueError("outgoing_polar must cover [0, 180] deg")
        if abs(a[0]) > 1e-9 or a[-1] >= 360.0:
            raise ValueError("outgoing_azimuth must start at 0 and stay below 360 deg")

    @staticmethod
    def _at_wavelength(phase, wl, x, interpolable):
        if x is None:
            raise ValueError("mode mono needs wavelength_nm")
        x = float(x)
        if not wl[0] <= x <= wl[-1]:
            raise ValueError(f"wavelength {x} nm is outside the table's [{wl[0]}, {wl[-1]}] nm")
        k = int(np.argmin(np.abs(wl - x)))
        if abs(wl[k] - x) <= 1e-9 * x:
            return phase[k]
        if interpolable is not None and "wavelength" not in interpolable:
            raise ValueError(f"wavelength {x} nm is not a sample of the table (nearest {wl[k]})")
        j = min(int(np.searchsorted(wl, x, side="right")) - 1, len(wl) - 2)
        t = (x - wl[j]) / (wl[j + 1] - wl[j])
        return (1 - t) * phase[j] + t * phase[j + 1]

    def _build_sampler(self):
        s = self.sampling  # E × NP × NA
        ext = np.concatenate([s, s[:, :, :1]], axis=2)  # periodic azimuth
        corners = 0.25 * (ext[:, :-1, :-1] + ext[:, 1:, :-1] + ext[:, :-1, 1:] + ext[:, 1:, 1:])
        th = np.radians(self.polar_deg)
        dcos = np.cos(th[:-1]) - np.cos(th[1:])  # NP−1
        dphi = np.radians(np.diff(np.append(self.azimuth_deg, 360.0)))  # NA
        solid = dcos[:, None] * dphi[None, :]  # NP−1 × NA
        weight = np.transpose(corners * solid[None], (0, 2, 1))  # E × NA × NP−1
        total = weight.sum(axis=(1, 2))
        if np.any(total <= 0):
            raise ValueError("a sun elevation of the table has no scattered light")
        weight = weight / total[:, None, None]
        self.cell_pdf = weight / solid.T[None]
        column = weight.sum(axis=2)
        self.marginal_cdf = np.cumsum(column, axis=1)
        self.marginal_cdf[:, -1] = 1.0
        cond = np.cumsum(weight, axis=2)
        colsum = cond[:, :, -1:]
        with np.errstate(invalid="ignore", divide="ignore"):
            cond = np.where(colsum > 0, cond / colsum, 1.0)
        cond[:, :, -1] = 1.0
        self.conditional_cdf = cond


def _buffer(values):
    a = np.ascontiguousarray(np.asarray(values, dtype=np.float32).ravel())
    if dr.is_jit_v(mi.Float):
        return mi.Float(a)
    return a


def _gather(buf, index, active=True):
    """buf[index] (0 where inactive) for JIT and scalar variants."""
    if dr.is_jit_v(mi.Float):
        return dr.gather(mi.Float, buf, index, active)
    return float(buf[int(index)]) if active else 0.0


def _locate(buf, n, x, active=True):
    """(j, t) with c_j ≤ x ≤ c_{j+1} on the sorted buffer of n ≥ 2 coordinates (x within)."""
    j = dr.binary_search(1, n - 1, lambda i: _gather(buf, i, active) <= x) - 1
    lo = _gather(buf, j, active)
    hi = _gather(buf, j + 1, active)
    return mi.UInt32(j), dr.clip((x - lo) / (hi - lo), 0.0, 1.0)


_CLASSES = {}


def class_for_variant(cache, make):
    """The class ``make()`` builds for the current Mitsuba variant, kept in ``cache`` (Mitsuba's
    base classes differ per variant, so a plugin class is made once per variant)."""
    variant = mi.variant()
    if variant is None:
        raise RuntimeError("call mi.set_variant before using the plugin")
    if variant not in cache:
        cache[variant] = make()
    return cache[variant]


def phase_class():
    """The plugin class for the current Mitsuba variant."""
    return class_for_variant(_CLASSES, _make_class)


def _make_class():
    class ScatterbakePhase2D(mi.PhaseFunction):
        """The ``scatterbake_2d`` phase function (see the module documentation)."""

        def __init__(self, props):
            mi.PhaseFunction.__init__(self, props)
            filename = props["filename"]
            wavelength = props["wavelength_nm"] if "wavelength_nm" in props else None
            mode = props["mode"] if "mode" in props else None
            if mode is None:
                mode = "mono" if wavelength is not None else ("spectral" if mi.is_spectral else "rgb")
            if mode == "rgb" and not mi.is_rgb:
                raise ValueError("mode rgb needs an RGB variant (use mono or spectral)")
            if mode == "spectral" and not mi.is_spectral:
                raise ValueError("mode spectral needs a spectral variant")
            if mi.is_monochromatic and mode != "mono":
                raise ValueError("monochromatic variants need mode mono and wavelength_nm")
            entry = {}
            for key in props.keys():
                if key.startswith("entry_"):
                    entry[key[len("entry_"):]] = float(props[key])
            up = props["up"] if "up" in props else [0.0, 0.0, 1.0]
            up = np.asarray([float(up[i]) for i in range(3)])
            if np.linalg.norm(up) == 0:
                raise ValueError("up must be a non-zero vector")
            self.tolerance_deg = (
                float(props["elevation_tolerance_deg"]) if "elevation_tolerance_deg" in props else 0.25
            )
            normalise = bool(props["normalise"]) if "normalise" in props else True
            self.data = TableData(_open_table(filename), mode, wavelength, entry, normalise)
            self._upload(up / np.linalg.norm(up))
            self.m_flags = mi.PhaseFunctionFlags.Anisotropic

        def _upload(self, up):
            d = self.data
            self.up = [float(x) for x in up]
            self.ne, self.npol, self.naz = d.sampling.shape
            self.nch = d.values.shape[-1]
            self.elev = _buffer(d.elevations_deg)
            self.elev_range = (float(d.elevations_deg[0]), float(d.elevations_deg[-1]))
            self.polar = _buffer(d.polar_deg)
            # 1 − cos θ = 2 sin²(θ/2), exact in float32 near the forward direction.
            self.versin_polar = _buffer(2.0 * np.sin(np.radians(d.polar_deg) / 2.0) ** 2)
            self.azim = _buffer(np.append(d.azimuth_deg, 360.0))
            self.values = _buffer(d.values)
            self.cell_pdf = _buffer(d.cell_pdf)
            self.marginal = _buffer(d.marginal_cdf)
            self.conditional = _buffer(d.conditional_cdf)
            if d.channel_wavelengths_nm is not None:
                self.wl = _buffer(d.channel_wavelengths_nm)
                self.wl_range = (float(d.channel_wavelengths_nm[0]), float(d.channel_wavelengths_nm[-1]))

        # Geometry ------------------------------------------------------------------------------

        def _up(self):
            return mi.Vector3f(self.up[0], self.up[1], self.up[2])

        def _frame(self, d):
            """e1 = normalize(up − (up·d) d), e2 = d × e1 about the incident direction d."""
            up = self._up()
            e1 = up - dr.dot(up, d) * d
            l2 = dr.squared_norm(e1)
            e1 = dr.select(l2 > 1e-12, e1 * dr.rsqrt(dr.maximum(l2, 1e-30)), mi.coordinate_system(d)[0])
            return e1, dr.cross(d, e1)

        def _angles(self, d, w):
            """(outgoing_polar, outgoing_azimuth) in deg of w for light propagating along d."""
            e1, e2 = self._frame(d)
            polar = dr.atan2(dr.norm(dr.cross(d, w)), dr.dot(d, w)) * (180.0 / dr.pi)
            az = dr.atan2(dr.dot(w, e2), dr.dot(w, e1)) * (180.0 / dr.pi)
            az = dr.select(az < 0.0, az + 360.0, az)
            return polar, dr.minimum(az, 360.0)

        def _elevation_deg(self, a):
            return dr.asin(dr.clip(dr.dot(a, self._up()), -1.0, 1.0)) * (180.0 / dr.pi)

        def _slices(self, e, active):
            """Table elevation slices (k0, k1, t) for the elevation e (deg), clamped into the table."""
            if self.ne == 1:
                zero = mi.UInt32(0)
                return zero, zero, mi.Float(0.0)
            ec = dr.clip(e, self.elev_range[0], self.elev_range[1])
            k, t = _locate(self.elev, self.ne, ec, active)
            return k, k + 1, t

        def _cells(self, polar, az, active):
            j, tj = _locate(self.polar, self.npol, polar, active)
            i, ti = _locate(self.azim, self.naz + 1, az, active)
            return j, tj, i, ti

        # Evaluation ----------------------------------------------------------------------------

        def _light_and_view(self, ctx, wi, wo):
            if ctx.mode == mi.TransportMode.Radiance:
                return wo, wi
            return wi, wo

        def _eval(self, ctx, wi, wo, wavelengths, active):
            light, view = self._light_and_view(ctx, wi, wo)
            e = self._elevation_deg(light)
            valid = active & (e >= self.elev_range[0] - self.tolerance_deg) & (
                e <= self.elev_range[1] + self.tolerance_deg
            )
            k0, k1, te = self._slices(e, valid)
            polar, az = self._angles(-light, view)
            j, tj, i, ti = self._cells(polar, az, valid)
            i1 = dr.select(i + 1 == self.naz, 0, i + 1)
            corners = []
            for k, wk in ((k0, 1.0 - te), (k1, te)):
                for jj, wj in ((j, 1.0 - tj), (j + 1, tj)):
                    for ii, wa in ((i, 1.0 - ti), (i1, ti)):
                        corners.append(((k * self.npol + jj) * self.naz + ii, wk * wj * wa))
            if self.data.mode == "spectral":
                return self._eval_spectral(corners, wavelengths, valid)
            channels = [self._channel(corners, c, valid) for c in range(self.nch)]
            if self.nch == 3:
                return mi.Spectrum(channels[0], channels[1], channels[2])
            return mi.Spectrum(channels[0])

        def _channel(self, corners, c, active):
            v = mi.Float(0.0)
            for idx, w in corners:
                v += w * _gather(self.values, idx * self.nch + c, active)
            return dr.select(active, v, 0.0)

        def _eval_spectral(self, corners, wavelengths, active):
            out = dr.zeros(mi.Spectrum)
            for lane in range(len(out)):
                lam = wavelengths[lane]
                ok = active & (lam >= self.wl_range[0]) & (lam <= self.wl_range[1])
                k, t = _locate(self.wl, self.nch, dr.clip(lam, self.wl_range[0], self.wl_range[1]), ok)
                v = (1.0 - t) * self._channel(corners, k, ok) + t * self._channel(corners, k + 1, ok)
                out[lane] = dr.select(ok, v, 0.0)
            return out

        def _pdf(self, wi, wo, active):
            e = self._elevation_deg(wi)
            k0, k1, te = self._slices(e, active)
            polar, az = self._angles(-wi, wo)
            j, _, i, _ = self._cells(polar, az, active)
            cells = self.naz * (self.npol - 1)
            cell = i * (self.npol - 1) + j
            p = (1.0 - te) * _gather(self.cell_pdf, k0 * cells + cell, active)
            p += te * _gather(self.cell_pdf, k1 * cells + cell, active)
            pdf = DEFENSIVE_FRACTION * dr.inv_four_pi + (1.0 - DEFENSIVE_FRACTION) * p
            return dr.select(active, pdf, 0.0)

        def eval_pdf(self, ctx, mi_, wo, active=True):
            value = self._eval(ctx, mi_.wi, wo, mi_.wavelengths, active)
            return value, self._pdf(mi_.wi, wo, active)

        def sample(self, ctx, mi_, sample1, sample2, active=True):
            wi = mi_.wi
            uniform = sample1 < DEFENSIVE_FRACTION
            s1 = (sample1 - DEFENSIVE_FRACTION) / (1.0 - DEFENSIVE_FRACTION)
            k0, k1, te = self._slices(self._elevation_deg(wi), active)
            k = dr.select(s1 < te, k1, k0)
            # Marginal over azimuth columns, then the conditional over polar cells.
            na, nc = self.naz, self.npol - 1
            i = dr.binary_search(
                0, na - 1, lambda x: _gather(self.marginal, k * na + x, active) <= sample2.x
            )
            c_hi = _gather(self.marginal, k * na + i, active)
            c_lo = dr.select(i > 0, _gather(self.marginal, k * na + i - 1, active & (i > 0)), 0.0)
            ux = dr.clip((sample2.x - c_lo) / dr.maximum(c_hi - c_lo, 1e-30), 0.0, 1.0)
            base = (k * na + i) * nc
            j = dr.binary_search(
                0, nc - 1, lambda x: _gather(self.conditional, base + x, active) <= sample2.y
            )
            d_hi = _gather(self.conditional, base + j, active)
            d_lo = dr.select(j > 0, _gather(self.conditional, base + j - 1, active & (j > 0)), 0.0)
            uy = dr.clip((sample2.y - d_lo) / dr.maximum(d_hi - d_lo, 1e-30), 0.0, 1.0)
            a0 = _gather(self.azim, i, active)
            a1 = _gather(self.azim, i + 1, active)
            phi = (a0 + ux * (a1 - a0)) * (dr.pi / 180.0)
            h0 = _gather(self.versin_polar, j, active)
            h1 = _gather(self.versin_polar, j + 1, active)
            h = dr.clip(h0 + uy * (h1 - h0), 0.0, 2.0)  # uniform in cos θ = 1 − h
            cos_t = 1.0 - h
            sin_t = dr.safe_sqrt(h * (2.0 - h))
            d = -wi
            e1, e2 = self._frame(d)
            w = cos_t * d + sin_t * (dr.cos(phi) * e1 + dr.sin(phi) * e2)
            wo = dr.select(uniform, mi.warp.square_to_uniform_sphere(sample2), w)
            value = self._eval(ctx, wi, wo, mi_.wavelengths, active)
            pdf = self._pdf(wi, wo, active)
            weight = dr.select(pdf > 0.0, value / dr.maximum(pdf, 1e-30), 0.0)
            return wo, weight, pdf

        def projected_area(self, mi_, active=True):
            return mi.Float(0.0)

        def max_projected_area(self):
            return 0.0

        def traverse(self, callback):
            pass

        def to_string(self):
            d = self.data
            elevations = [float(e) for e in d.elevations_deg]
            return (
                f"ScatterbakePhase2D[mode={d.mode}, sun_elevation={elevations} deg, "
                f"polar × azimuth = {len(d.polar_deg)} × {len(d.azimuth_deg)}, up={self.up}]"
            )

    return ScatterbakePhase2D


def register(name: str = PLUGIN_NAME) -> None:
    """Register the phase function under ``name`` for the current Mitsuba variant (call after
    ``mi.set_variant``)."""
    cls = phase_class()
    reg = getattr(mi, "register_phase", None) or getattr(mi, "register_phasefunction")
    reg(name, lambda props: cls(props))
