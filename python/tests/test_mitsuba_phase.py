"""The Mitsuba 3 phase function for 2-D ray-traced tables (python/scatterbake/mitsuba_phase.py),
used as a standalone file with the pure-Python reader, against the table's own lookup; and a
render by examples/mitsuba/rainbow_2d.py (through the installed package and its reader when
there is one) against `scatterbake render rainbow` of the same table.

Needs the `mitsuba` wheel (3.9; .ci/run installs it) and, for its LLVM variant, an LLVM newer
than Debian 12's default 15 (Dr.Jit 1.5's kernels do not compile with it; .ci/run installs
libllvm19). The table is built by the command line of this checkout from
python/tests/data/rainbow-2d-small.toml (a 0.5 mm Beard–Chuang drop, sun at 0° and 10°).
"""

import math
import re
import subprocess
import sys

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from conftest import ROOT, cli_path

# Appended, so that `import scatterbake` keeps finding the installed package.
sys.path.append(str(ROOT / "python"))
sys.path.append(str(ROOT / "python" / "scatterbake"))
sys.path.append(str(ROOT / "examples" / "mitsuba"))
import mitsuba_phase  # noqa: E402
import rainbow_2d  # noqa: E402
import scatterbake_table  # noqa: E402

MANIFEST = ROOT / "python" / "tests" / "data" / "rainbow-2d-small.toml"
#: Largest difference of a bow radius (luminance maximum) between Mitsuba and render rainbow:
#: 1.6 pixels of render rainbow's 0.1875° and 1.5 of Mitsuba's 0.2° (test images below).
BOW_TOL_DEG = 0.3
#: Same for the maxima of the single sRGB channels, which are broader and noisier.
CHANNEL_TOL_DEG = 0.4


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    out = tmp_path_factory.mktemp("mitsuba-table")
    subprocess.run(
        [str(cli_path()), "build", str(MANIFEST), "--out", str(out), "--no-previews", "-q"],
        check=True,
    )
    path = out / "bc-0.5mm-small.sbt"
    assert path.is_file()
    return path


def directions(n, rng):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


def table_angles(d, w):
    """(outgoing_polar, outgoing_azimuth) in deg, docs/consumers.md (drop axis z)."""
    z = np.array([0.0, 0.0, 1.0])
    e1 = z - (d @ z)[:, None] * d
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(d, e1)
    polar = np.degrees(np.arctan2(np.linalg.norm(np.cross(d, w), axis=1), np.sum(d * w, axis=1)))
    az = np.degrees(np.arctan2(np.sum(w * e2, axis=1), np.sum(w * e1, axis=1))) % 360.0
    return polar, az


def vec(a):
    return mi.Vector3f(a[:, 0], a[:, 1], a[:, 2])


def interaction(wi):
    m = dr.zeros(mi.MediumInteraction3f, len(wi))
    m.wi = vec(wi)
    return m


def load(table, **params):
    mitsuba_phase.register()
    return mi.load_dict({"type": "scatterbake_2d", "filename": str(table), **params})


def test_eval_is_the_table_lookup_with_the_sun_on_the_light_side(table):
    """Radiance mode: the light arrives from wo; the value is the table's multilinear lookup at
    the sun elevation of wo, the polar angle and azimuth of wi about −wo, combined with the
    sRGB weights (rgb) or at one wavelength (mono). Importance mode swaps the two."""
    mi.set_variant("llvm_ad_rgb")
    t = scatterbake_table.open_table(table)
    wl = t.axis("wavelength").coords
    ic = t.channel_index("phase")
    rng = np.random.default_rng(3)
    n = 400
    az_sun = rng.uniform(0, 2 * np.pi, n)
    light = np.stack([np.cos(az_sun), np.sin(az_sun), np.zeros(n)], -1)  # sun on the horizon
    view = directions(n, rng)
    polar, az = table_angles(-light, view)
    keep = az < 345.0  # the reader's lookup clamps there; the plugin wraps to 0° (tested below)
    raw = np.array([[t.sample([500.0, w, 0.0, p, a])[ic] for w in wl]
                    for p, a in zip(polar, az)])
    # By default every wavelength is divided by its integral under the bilinear lookup.
    integral = mitsuba_phase.TableData(t, "rgb").integral[:, 0]
    assert np.all(np.abs(integral - 1.0) < 0.2)
    spectra = raw / integral
    weights, _ = mitsuba_phase.srgb_weights(wl)
    ref = spectra @ weights.T
    ctx = mi.PhaseFunctionContext()
    rgb = load(table)
    got = np.array(rgb.eval_pdf(ctx, interaction(view), vec(light))[0]).T
    np.testing.assert_allclose(got[keep], ref[keep], rtol=2e-3, atol=1e-6 * ref.max())
    as_stored = load(table, normalise=False)
    got_raw = np.array(as_stored.eval_pdf(ctx, interaction(view), vec(light))[0]).T
    ref_raw = raw @ weights.T
    np.testing.assert_allclose(got_raw[keep], ref_raw[keep], rtol=2e-3, atol=1e-6 * ref_raw.max())
    ctx_imp = mi.PhaseFunctionContext(None, mi.TransportMode.Importance)
    swapped = np.array(rgb.eval_pdf(ctx_imp, interaction(light), vec(view))[0]).T
    np.testing.assert_allclose(swapped, got, rtol=1e-5, atol=1e-9)
    mono = load(table, wavelength_nm=510.0)  # halfway between 480 and 540 nm
    got = np.array(mono.eval_pdf(ctx, interaction(view), vec(light))[0]).T
    ref = 0.5 * (spectra[:, 1] + spectra[:, 2])
    np.testing.assert_allclose(got[keep, 0], ref[keep], rtol=2e-3, atol=1e-6 * ref.max())
    np.testing.assert_allclose(got[:, 1], got[:, 0])
    # Azimuth 352.5° lies halfway between the last sample (345°) and 360° ≡ 0° (periodic).
    # Sun at +x: d = (−1, 0, 0), e1 = z, e2 = d × e1 = +y.
    th, phi = math.radians(140.0), math.radians(352.5)
    w = np.array([[-math.cos(th), math.sin(th) * math.sin(phi), math.sin(th) * math.cos(phi)]])
    v = np.array(mono.eval_pdf(ctx, interaction(w), vec(np.array([[1.0, 0.0, 0.0]])))[0])[0, 0]
    ends = [0.5 * sum(t.sample([500.0, x, 0.0, 140.0, a])[ic] / integral[k]
                      for k, x in ((1, 480.0), (2, 540.0)))
            for a in (345.0, 0.0)]
    assert v == pytest.approx(0.5 * (ends[0] + ends[1]), rel=2e-3)
    # Light 4° above the horizon: linear between the (normalised) 0° and 10° slices.
    integral_all = mitsuba_phase.TableData(t, "rgb").integral  # wavelength × elevation
    e = math.radians(4.0)
    light4 = np.stack([np.cos(az_sun) * math.cos(e), np.sin(az_sun) * math.cos(e),
                       np.full(n, math.sin(e))], -1)
    polar, az = table_angles(-light4, view)
    keep = az < 345.0
    slices = [np.array([[t.sample([500.0, w, el, p, a])[ic] / integral_all[k, ie]
                         for k, w in enumerate(wl)] for p, a in zip(polar, az)]) @ weights.T
              for ie, el in enumerate((0.0, 10.0))]
    ref = 0.6 * slices[0] + 0.4 * slices[1]
    got = np.array(rgb.eval_pdf(ctx, interaction(view), vec(light4))[0]).T
    np.testing.assert_allclose(got[keep], ref[keep], rtol=2e-3, atol=1e-6 * ref.max())


def test_compact_tables_are_read_on_the_full_circle(table):
    """A compact table stores 0°–180° of azimuth on an even-periodic axis (format 3.0): the
    plugin unfolds it onto the full circle, and its value at every direction, beyond 180° and
    between the last mirrored node and 360° included, is the reader's folded lookup."""
    mi.set_variant("llvm_ad_rgb")
    path = table.parent / "bc-0.5mm-small-compact.sbt"
    t = scatterbake_table.open_table(path)
    az_axis = t.axis("outgoing_azimuth")
    assert az_axis.symmetry == {"kind": "even-periodic", "period": 360.0}
    stored = az_axis.coords
    assert stored[-1] == 180.0
    data = mitsuba_phase.TableData(t, "mono", wavelength_nm=540.0, normalise=False)
    np.testing.assert_array_equal(data.azimuth_deg, np.concatenate([stored, 360.0 - stored[-2:0:-1]]))
    rng = np.random.default_rng(5)
    n = 300
    az_sun = rng.uniform(0, 2 * np.pi, n)
    light = np.stack([np.cos(az_sun), np.sin(az_sun), np.zeros(n)], -1)
    view = directions(n, rng)
    polar, az = table_angles(-light, view)
    assert np.any(az > 180.0) and np.any(az > 360.0 - stored[1])
    ic = t.channel_index("phase")
    ref = np.array([t.sample([500.0, 540.0, 0.0, p, a])[ic] for p, a in zip(polar, az)])
    mono = load(path, wavelength_nm=540.0, normalise=False)
    got = np.array(mono.eval_pdf(mi.PhaseFunctionContext(), interaction(view), vec(light))[0]).T
    np.testing.assert_allclose(got[:, 0], ref, rtol=2e-3, atol=1e-6 * ref.max())
    # The whole table, as the dense one would be read: every stored node and its mirror image.
    k = int(np.argmin(np.abs(t.axis("wavelength").coords - 540.0)))
    full = data.values[..., 0]
    half = np.asarray(t.channel("phase"))[0, k]
    np.testing.assert_array_equal(full[..., : len(stored)], half)
    np.testing.assert_array_equal(full[..., len(stored):], half[..., -2:0:-1])


def test_scalar_variant_agrees_with_llvm(table):
    rng = np.random.default_rng(5)
    light = np.array([[1.0, 0.0, 0.0]] * 8)
    view = directions(8, rng)
    out = {}
    for variant in ("llvm_ad_rgb", "scalar_rgb"):
        mi.set_variant(variant)
        ph = load(table)
        ctx = mi.PhaseFunctionContext()
        vals = []
        for k in range(8):
            m = dr.zeros(mi.MediumInteraction3f)
            m.wi = mi.Vector3f(*map(float, view[k]))
            value, pdf = ph.eval_pdf(ctx, m, mi.Vector3f(*map(float, light[k])))
            vals.append([value[0], value[1], value[2], pdf])
        out[variant] = np.array(vals, dtype=float).reshape(8, 4)
    # float32 arithmetic differs (libm vs Dr.Jit's atan2); R and B cancel partly (sRGB weights
    # of both signs), hence 1e-3.
    np.testing.assert_allclose(out["scalar_rgb"], out["llvm_ad_rgb"], rtol=1e-3)


def test_spectral_mode_is_the_table_at_each_sampled_wavelength(table):
    """Spectral variant: each of Mitsuba's wavelengths reads the table there (linear between
    the table's wavelengths, as mode mono); outside the table's 420–660 nm nothing scatters."""
    rng = np.random.default_rng(11)
    view = directions(16, rng)
    light = np.tile([1.0, 0.0, 0.0], (16, 1))
    mi.set_variant("llvm_ad_spectral")
    ph = load(table)
    m = interaction(view)
    m.wavelengths = mi.Spectrum(480.0, 510.0, 600.0, 700.0)
    ctx = mi.PhaseFunctionContext()
    spectral = np.array(ph.eval_pdf(ctx, m, vec(light))[0]).T
    for lane, wl in enumerate((480.0, 510.0, 600.0)):
        mono = np.array(load(table, wavelength_nm=wl).eval_pdf(ctx, m, vec(light))[0]).T
        np.testing.assert_allclose(spectral[:, lane], mono[:, lane], rtol=1e-5, atol=1e-9)
    assert np.all(spectral[:, 3] == 0.0)
    assert np.all(spectral[:, :3] > 0.0)


def cell_quadrature(data, wi, sub_polar, sub_az=1):
    """World directions and solid angles of a sub_polar × sub_az grid (midpoints, uniform in
    cos θ and φ) in every table cell, in the frame of the incident direction −wi, and the cell
    (polar cell · NA + azimuth cell) of each."""
    th = np.radians(data.polar_deg)
    ph = np.radians(np.append(data.azimuth_deg, 360.0))
    fp = (np.arange(sub_polar) + 0.5) / sub_polar
    fa = (np.arange(sub_az) + 0.5) / sub_az
    c0, c1 = np.cos(th[:-1]), np.cos(th[1:])
    cos_t = (c0[:, None] + fp[None, :] * (c1 - c0)[:, None]).ravel()
    phi = (ph[:-1, None] + fa[None, :] * np.diff(ph)[:, None]).ravel()
    d = -np.asarray(wi, float)
    e1 = np.array([0.0, 0.0, 1.0]) - d[2] * d
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    ct, pp = np.meshgrid(cos_t, phi, indexing="ij")
    st = np.sqrt(1 - ct**2)
    w = ct[..., None] * d + st[..., None] * (np.cos(pp)[..., None] * e1 + np.sin(pp)[..., None] * e2)
    solid = (c0 - c1)[:, None] / sub_polar * np.diff(ph)[None, :] / sub_az
    solid = np.repeat(np.repeat(solid, sub_polar, axis=0), sub_az, axis=1)
    na = len(data.azimuth_deg)
    rows, cols = np.meshgrid(np.arange(len(cos_t)) // sub_polar, np.arange(len(phi)) // sub_az,
                             indexing="ij")
    return w.reshape(-1, 3), solid.ravel(), (rows * na + cols).ravel()


@pytest.mark.parametrize("mode,wi", [
    ("importance", [1.0, 0.0, 0.0]),  # light side wi: the sun on the horizon, the table itself
    ("importance", [0.9945219, 0.0, 0.1045285]),  # sun 6° high: mixture of the 0° and 10° slices
    ("radiance", [0.6, 0.0, -0.8]),  # wi below the table's elevations: nearest elevation
])
def test_sampling_density_is_the_pdf_and_integrates_to_one(table, mode, wi):
    mi.set_variant("llvm_ad_rgb")
    ph = load(table)
    data = mitsuba_phase.TableData(scatterbake_table.open_table(table), "rgb")
    wi = np.array(wi) / np.linalg.norm(wi)
    tmode = mi.TransportMode.Importance if mode == "importance" else mi.TransportMode.Radiance
    ctx = mi.PhaseFunctionContext(None, tmode)
    # ∫ pdf dΩ = 1 (the density is constant on each cell: the quadrature is exact but for
    # the uniform share, whose integral the quadrature also gives exactly).
    w, solid, cell_of = cell_quadrature(data, wi, 2, 2)
    pdf = np.array(ph.eval_pdf(ctx, interaction(np.tile(wi, (len(w), 1))), vec(w))[1], dtype=float)
    assert np.sum(pdf * solid) == pytest.approx(1.0, abs=1e-4)
    if mode == "importance" and wi[2] == 0.0:
        # The value (each channel) integrates to 1 under the bilinear lookup (as stored:
        # 1.16). Quadrature: 16 midpoints in cos θ per cell, exact in φ; its error, all in the
        # forward lobe's first cell, is 0.24 % (1.1 % with 4 midpoints).
        wq, sq, _ = cell_quadrature(data, wi, 16)
        value = ph.eval_pdf(ctx, interaction(np.tile(wi, (len(wq), 1))), vec(wq))[0]
        rgb = np.array(value, dtype=float).T
        np.testing.assert_allclose(rgb.T @ sq, 1.0, atol=4e-3)
    # Samples: histogram over the cells against the pdf (χ², pooled to ≥ 5 expected).
    n = 1_000_000
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(7, n)
    wo, weight, spdf = ph.sample(ctx, interaction(np.tile(wi, (n, 1))), sampler.next_1d(),
                                 sampler.next_2d())
    wo_np = np.array(wo, dtype=float).T
    v2, p2 = ph.eval_pdf(ctx, interaction(np.tile(wi, (n, 1))), wo)
    np.testing.assert_allclose(np.array(spdf), np.array(p2), rtol=1e-5)
    np.testing.assert_allclose(np.array(weight) * np.array(spdf), np.array(v2), rtol=1e-4,
                               atol=1e-7)
    polar, az = table_angles(np.tile(-wi, (n, 1)), wo_np)
    j = np.clip(np.searchsorted(data.polar_deg, polar, side="right") - 1, 0, len(data.polar_deg) - 2)
    i = np.clip(np.searchsorted(data.azimuth_deg, az, side="right") - 1, 0, len(data.azimuth_deg) - 1)
    ncell = (len(data.polar_deg) - 1) * len(data.azimuth_deg)
    hist = np.bincount(j * len(data.azimuth_deg) + i, minlength=ncell).astype(float)
    expected = np.bincount(cell_of, weights=pdf * solid, minlength=ncell) * n
    order = np.argsort(expected)
    chi2, dof, _, _ = mi.math.chi2(mi.Float64(hist[order]), mi.Float64(expected[order]), 5)
    p_value = 1.0 - mi.math_py.rlgamma(dof / 2, chi2 / 2)
    assert dof > 100
    assert p_value > 1e-3, (chi2, dof)


def test_refusals_and_the_elevation_range(table, tmp_path):
    mi.set_variant("llvm_ad_rgb")
    with pytest.raises(Exception, match="outside the table"):
        load(table, wavelength_nm=800.0)
    with pytest.raises(Exception, match="spectral variant"):
        load(table, mode="spectral")
    other = ROOT / "assets" / "fur-medulla" / "fur-medulla-azimuthal.sbt"
    with pytest.raises(Exception, match="is not `raytrace-phase-2d`"):
        load(other)
    # Light from 12° above the horizon: the table (sun 0°–10°, tolerance 0.25°) has no value
    # there, and the plugin scatters nothing rather than using the 10° slice.
    ph = load(table)
    ctx = mi.PhaseFunctionContext()
    view = np.array([[-0.6, 0.0, 0.8], [-0.6, 0.0, 0.8]])
    e = np.radians([12.0, 10.2])
    light = np.stack([np.cos(e), np.zeros(2), np.sin(e)], -1)
    value = np.array(ph.eval_pdf(ctx, interaction(view), vec(light))[0]).T
    assert np.all(value[0] == 0.0)
    assert np.all(value[1] > 0.0)


def parse_render_rainbow(text):
    out = {}
    for name in ("primary", "secondary"):
        m = re.search(name + r" bow .*?image radius ([\d.]+) deg \(R ([\d.]+), G ([\d.]+), B ([\d.]+)\)",
                      text)
        assert m, text
        out[name] = {"radius_deg": float(m.group(1)),
                     "rgb_deg": [float(m.group(k)) for k in (2, 3, 4)]}
    return out


@pytest.mark.parametrize("name, sun_diameter_deg", [("bc-0.5mm-small", "0"),
                                                    ("bc-0.5mm-small-compact", "0.5")])
def test_mitsuba_bows_match_render_rainbow(table, tmp_path, name, sun_diameter_deg):
    """A camera inside a homogeneous rain volume lit by a directional sun on the horizon:
    the bows' radii at the top of the arch and their colour order as `render rainbow` of the
    same table: the dense table with a point sun in both; the compact table (the form of the
    rainbow database: format 3.0, 0°–180° of azimuth stored, the sun's 0.5° disc already
    applied) with the directional sun in Mitsuba and its own 0.5° disc in `render rainbow`,
    which then convolves nothing more."""
    table = table.parent / f"{name}.sbt"
    ref = subprocess.run(
        [str(cli_path()), "render", "rainbow", "--table", str(table), "--sun-diameter-deg", sun_diameter_deg,
         "--fov-deg", "60", "--width", "320", "--height", "320", "--view-elevation-deg", "45",
         "--out", str(tmp_path / "reference.png")],
        check=True, capture_output=True, text=True,
    )
    expected = parse_render_rainbow(ref.stderr)
    got, seconds, _ = rainbow_2d.render(table, tmp_path / "mitsuba.png", width=60, height=200,
                                        fov_deg=40.0, spp=64)
    print("render rainbow:", expected)
    print(f"mitsuba ({seconds:.1f} s):", got)
    for name in ("primary", "secondary"):
        assert abs(got[name]["radius_deg"] - expected[name]["radius_deg"]) <= BOW_TOL_DEG, name
        for k in range(3):
            assert abs(got[name]["rgb_deg"][k] - expected[name]["rgb_deg"][k]) <= CHANNEL_TOL_DEG
    r, _, b = got["primary"]["rgb_deg"]
    assert r > b, "primary: red outside"
    r, _, b = got["secondary"]["rgb_deg"]
    assert r < b, "secondary: red inside"
    assert (tmp_path / "mitsuba.png").stat().st_size > 0
