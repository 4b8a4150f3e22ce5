"""The Mitsuba 3 BSDF for cloth tables (python/scatterbake/mitsuba_cloth.py): its lookup
against the table reader's, its sampling against its pdf and the table's directional albedo,
and a render of cloth-covered cylinders (examples/mitsuba/cloth_cylinders.py) whose highlights
sit where `scatterbake.cloth_brdf` (the model) and the table put them.

Needs the `mitsuba` wheel (3.9) and, for its LLVM variant, libllvm19 (.ci/run installs both).
The tables (linen and satin front, the stage's default half-vector grid, `cloth-brdf/2`) are
built by the installed package from python/tests/data/cloth-small.toml.
"""

import math
import sys

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
import scatterbake as sb

from conftest import ROOT

# Appended, so that `import scatterbake` keeps finding the installed package.
sys.path.append(str(ROOT / "python"))
sys.path.append(str(ROOT / "python" / "scatterbake"))
sys.path.append(str(ROOT / "examples" / "mitsuba"))
import cloth_cylinders  # noqa: E402
import mitsuba_cloth  # noqa: E402  (the standalone file, with the pure-Python reader)
import scatterbake_table  # noqa: E402

MANIFEST = ROOT / "python" / "tests" / "data" / "cloth-small.toml"
FABRICS = ("linen_plain", "polyester_satin_front")


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    out = tmp_path_factory.mktemp("cloth-tables")
    report = sb.build(MANIFEST, out)
    assert len(report["tables_written"]) == 2
    paths = {f: out / f"cloth-{f.replace('_', '-')}.sbt" for f in FABRICS}
    for p in paths.values():
        assert p.is_file()
    return paths


def hemisphere(n, rng, min_cos=0.02):
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v[v[:, 2] > min_cos]


def vec(a):
    return mi.Vector3f(a[:, 0], a[:, 1], a[:, 2])


def interaction(wi):
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = vec(wi)
    return si


def load(table, **params):
    mitsuba_cloth.register()
    return mi.load_dict({"type": "scatterbake_cloth", "filename": str(table), **params})


def table_lookup(table, light, view, warp_deg=0.0):
    """f(light → view) (RGB, 1/sr) by the reader's multilinear `sample` of K after the header's
    reduction, at the projected half angles of the reduced pair, divided by cos θ_i; directions
    in the local frame (warp at warp_deg from +x)."""
    data = mitsuba_cloth.ClothTable(table)
    ti, pi = cloth_cylinders.angles_deg(light, warp_deg)
    tr, pr = cloth_cylinders.angles_deg(view, warp_deg)
    pi, pr, _, _ = mitsuba_cloth.reduce_deg(data.symmetry, pi, pr)

    def d(t, p):
        t, p = np.radians(t), np.radians(p)
        return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)

    h = d(ti, pi) + d(tr, pr)
    h /= np.linalg.norm(h, axis=-1)[..., None]
    bx = np.degrees(np.arctan2(h[..., 0], h[..., 2]))
    by = np.degrees(np.arctan2(h[..., 1], h[..., 2]))
    return np.array([np.array(table.sample([a, b, c, e])[:3]) / math.cos(math.radians(a))
                     for a, b, c, e in zip(ti, pi, bx, by)])


def test_reduction_maps_are_symmetries_of_the_model():
    rng = np.random.default_rng(1)
    for fabric in ("linen_plain", "velvet", "silk_shot"):
        # The stage's symmetry flags of each fabric (docs/cloth.md §3).
        flags = {"linen_plain": (True, True, True), "velvet": (False, True, False),
                 "silk_shot": (True, True, False)}[fabric]
        lo, hi = mitsuba_cloth.phi_i_domain_deg(*flags)
        for _ in range(6):
            ti, tr = rng.uniform(5, 80, 2)
            pi, pr = rng.uniform(-400, 400, 2)
            a, b, s, c = mitsuba_cloth.reduce_deg(flags, pi, pr)
            assert lo - 1e-9 <= a <= hi + 1e-9
            # The composed map φ' = s φ + c (mod 360°) sends both azimuths.
            for x, y in ((pi, a), (pr, b)):
                assert abs(mitsuba_cloth._wrap_deg(s * x + c - y)) < 1e-9
            f = sb.cloth_brdf(fabric, ti, pi, tr, pr)["brdf"]
            g = sb.cloth_brdf(fabric, ti, float(a), tr, float(b))["brdf"]
            np.testing.assert_allclose(g, f, rtol=1e-10)


@pytest.mark.parametrize("fabric", FABRICS)
def test_eval_is_the_table_lookup(tables, fabric):
    """Radiance mode: light = wo, view = si.wi; value = f·cos θ_o with f the table's
    multilinear lookup (pure-Python reader, header reduction); importance mode swaps the sides;
    warp_angle_deg turns the cloth frame."""
    mi.set_variant("llvm_ad_rgb")
    t = scatterbake_table.open_table(tables[fabric])
    rng = np.random.default_rng(7)
    light = hemisphere(600, rng)
    view = hemisphere(600, rng)
    n = min(len(light), len(view))
    light, view = light[:n], view[:n]
    ref = table_lookup(t, light, view)
    ctx = mi.BSDFContext()
    bsdf = load(tables[fabric])
    got = np.array(bsdf.eval(ctx, interaction(view), vec(light)), dtype=float).T
    np.testing.assert_allclose(got, ref * light[:, 2:3], rtol=2e-4, atol=1e-7 * ref.max())
    ctx_imp = mi.BSDFContext(mi.TransportMode.Importance)
    got = np.array(bsdf.eval(ctx_imp, interaction(light), vec(view)), dtype=float).T
    np.testing.assert_allclose(got, ref * view[:, 2:3], rtol=2e-4, atol=1e-7 * ref.max())
    turned = load(tables[fabric], warp_angle_deg=30.0)
    got = np.array(turned.eval(ctx, interaction(view), vec(light)), dtype=float).T
    ref30 = table_lookup(t, light, view, 30.0)
    np.testing.assert_allclose(got, ref30 * light[:, 2:3], rtol=2e-4, atol=1e-7 * ref.max())
    assert np.max(np.abs(ref30 - ref)) > 0.05 * ref.max()  # the turn matters
    # Below the horizon on either side: nothing.
    below = view * np.array([1.0, 1.0, -1.0])
    assert np.all(np.array(bsdf.eval(ctx, interaction(below), vec(light))) == 0.0)
    assert np.all(np.array(bsdf.eval(ctx, interaction(view), vec(-light))) == 0.0)


def test_scalar_variant_agrees_with_llvm(tables):
    rng = np.random.default_rng(5)
    views, lights = hemisphere(8, rng, 0.1), hemisphere(8, rng, 0.1)
    u = rng.uniform(size=(8, 3))
    out = {}
    for variant in ("llvm_ad_rgb", "scalar_rgb"):
        mi.set_variant(variant)
        bsdf = load(tables["polyester_satin_front"])
        ctx = mi.BSDFContext()
        rows = []
        for k in range(min(len(views), len(lights))):
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = mi.Vector3f(*map(float, views[k]))
            value = bsdf.eval(ctx, si, mi.Vector3f(*map(float, lights[k])))
            bs, weight = bsdf.sample(ctx, si, float(u[k, 0]), mi.Point2f(float(u[k, 1]),
                                                                        float(u[k, 2])))
            rows.append([value[0], value[1], value[2], bs.wo[0], bs.wo[1], bs.wo[2], bs.pdf,
                         weight[0]])
        out[variant] = np.array(rows, dtype=float).reshape(len(rows), 8)
    np.testing.assert_allclose(out["scalar_rgb"], out["llvm_ad_rgb"], rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("fabric,theta_i,phi_i", [("linen_plain", 35.0, 20.0),
                                                  ("polyester_satin_front", 55.0, 30.0)])
def test_sample_pdf_eval_agree_and_the_mean_weight_is_the_albedo(tables, fabric, theta_i, phi_i):
    """Importance mode (si.wi is the light, the table's own conditional): the sampled pdf is
    pdf(), weight·pdf is eval(), and E[eval/pdf] over 2^20 samples is the directional albedo
    of the header at that (θ_i, φ_i) node within 4 standard errors plus 0.5 % (the header's
    albedo integrates each half-vector cell on 4 × 4 sub-cells, the plugin the multilinear
    interpolant exactly in expectation); in radiance mode the mean weight is the integral of eval over
    the light directions."""
    mi.set_variant("llvm_ad_rgb")
    table = tables[fabric]
    bsdf = load(table)
    th, ph = math.radians(theta_i), math.radians(phi_i)
    wi = np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
    n = 1 << 20
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    si = interaction(np.tile(wi, (n, 1)))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(11, n)
    bs, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    np.testing.assert_allclose(np.array(bs.pdf), np.array(pdf), rtol=1e-5)
    np.testing.assert_allclose(np.array(bsdf.pdf(ctx, si, bs.wo)), np.array(pdf), rtol=1e-5)
    w = np.array(weight, dtype=float).T
    v = np.array(value, dtype=float).T
    np.testing.assert_allclose(w * np.array(pdf)[:, None], v, rtol=1e-4, atol=1e-9)
    # A reflection below the horizon is a lost sample: density and weight 0.
    assert np.all((np.array(bs.wo.z) > 0.0) | (np.array(pdf) == 0.0))
    data = mitsuba_cloth.ClothTable(scatterbake_table.open_table(table))
    k = int(np.argmin(np.abs(data.theta_i - theta_i)))
    m = int(round((phi_i - data.phi_i_lo) / data.phi_step))
    albedo = data.albedo[k, m]
    mean = w.mean(axis=0)
    err = w.std(axis=0) / math.sqrt(n)
    print(f"{fabric} θ_i={theta_i} φ_i={phi_i}: E[w] = {mean}, ± {err}, header albedo {albedo}")
    assert np.all(np.abs(mean - albedo) <= 4 * err + 0.005 * albedo), (mean, err, albedo)
    # Radiance mode: si.wi is the viewer, the sampled wo the light, and the proposal the
    # reciprocal configuration. E[weight] = ∫ f(wo → wi) cos θ_o dω_o, here against the
    # midpoint rule of eval on a 0.25° × 0.5° grid of the hemisphere.
    ctx_rad = mi.BSDFContext(mi.TransportMode.Radiance)
    bs, weight = bsdf.sample(ctx_rad, si, sampler.next_1d(), sampler.next_2d())
    np.testing.assert_allclose(np.array(bs.pdf), np.array(bsdf.pdf(ctx_rad, si, bs.wo)), rtol=1e-5)
    w = np.array(weight, dtype=float).T
    th_q = np.radians((np.arange(360) + 0.5) * 0.25)
    ph_q = np.radians((np.arange(720) + 0.5) * 0.5)
    tq, pq = [a.ravel() for a in np.meshgrid(th_q, ph_q, indexing="ij")]
    wo = np.stack([np.sin(tq) * np.cos(pq), np.sin(tq) * np.sin(pq), np.cos(tq)], -1)
    values = np.array(bsdf.eval(ctx_rad, interaction(np.tile(wi, (len(wo), 1))), vec(wo)),
                      dtype=float).T
    reverse = (values * np.sin(tq)[:, None]).sum(axis=0) * np.radians(0.25) * np.radians(0.5)
    mean, err = w.mean(axis=0), w.std(axis=0) / math.sqrt(n)
    print(f"  radiance mode: E[w] = {mean} ± {err}, quadrature {reverse}")
    assert np.all(np.abs(mean - reverse) <= 4 * err + 0.005 * reverse), (mean, err, reverse)


@pytest.mark.parametrize("fabric,theta_deg,phi_deg", [("polyester_satin_front", 40.0, 25.0),
                                                      ("linen_plain", 3.0, 80.0)])
def test_chi2_of_sample_against_pdf(tables, fabric, theta_deg, phi_deg):
    """Mitsuba's own χ² test (mitsuba.chi2): the histogram of sample() against pdf()
    integrated over its bins (64 × 128 in (cos θ, φ), 32 × 32 Simpson points per bin), for satin
    front (the narrowest lobes) and for linen lit near the normal (the θ cell at the pole).
    The proposal takes si.wi as the table's ω_i in both transport modes, so one mode is
    tested."""
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    mi.set_variant("llvm_ad_rgb")
    mitsuba_cloth.register()
    th, ph = math.radians(theta_deg), math.radians(phi_deg)
    wi = [math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)]
    sample_func, pdf_func = BSDFAdapter(
        "scatterbake_cloth", {"type": "scatterbake_cloth", "filename": str(tables[fabric])},
        wi=wi, ctx=mi.BSDFContext(mi.TransportMode.Importance))
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func,
                         sample_dim=3, sample_count=1_000_000, res=64, ires=32, seed=3)
    ok = chi2.run(test_count=1)
    print(chi2.messages)
    assert ok, chi2.messages


#: Largest distance (pixels) between a rendered highlight and the one predicted from the table
#: (the render's pixel averages against lookups at pixel centres) and from the model
#: (`cloth_brdf`: adds the table's interpolation error).
TABLE_TOL_PX = 0.25
MODEL_TOL_PX = 0.5
#: Sub-pixel points per pixel of the table's predicted profile (averaged as the box filter).
SUB = 8


def light_local(hits, light):
    return cloth_cylinders.to_local(hits, light)


def model_profile(hits, light, fabric, warp, mask):
    """Luminance f·cos θ_light from `cloth_brdf` (the model) at the pixel centres in mask,
    frames from Mitsuba's own hits (0 where the light is below the local horizon)."""
    ll = light_local(hits, light)
    ti, pi = cloth_cylinders.angles_deg(ll, warp)
    tr, pr = cloth_cylinders.angles_deg(hits["wi"], warp)
    out = np.zeros(len(mask))
    for i in np.flatnonzero(mask & (ll[:, 2] > 0.0)):
        f = sb.cloth_brdf(fabric, float(ti[i]), float(pi[i]), float(tr[i]), float(pr[i]))["brdf"]
        out[i] = cloth_cylinders.luminance(np.array(f)) * ll[i, 2]
    return out


def table_profile(hits, light, table, warp, mask):
    """The same from the reader's lookup of the table: per pixel (mask, length W), the mean over
    the ``SUB`` points of ``hits`` (W·SUB points) and the value at the pixel's centre."""
    ll = light_local(hits, light)
    lit = np.repeat(mask, SUB) & hits["valid"] & (ll[:, 2] > 0.0)
    values = np.zeros(len(lit))
    values[lit] = cloth_cylinders.luminance(
        table_lookup(table, ll[lit], hits["wi"][lit], warp)) * ll[lit, 2]
    return values.reshape(-1, SUB).mean(axis=1)


def test_highlights_of_cloth_cylinders(tables, tmp_path):
    """Four cylinders (linen and satin front, warp around the cylinder and along its axis) under
    a directional light: every highlight (local luminance maximum ≥ 0.3 × the cylinder's
    maximum on the middle row, view and light within 70° of the normal) where the model and the
    table predict it, and the whole row as the table's lookup averaged over each pixel."""
    cylinders = [(tables[f], w) for f in FABRICS for w in (0.0, 90.0)]
    width, height = 256, 64
    image, seconds, scene = cloth_cylinders.render(cylinders, tmp_path / "cloth.png", width,
                                                   height, spp=256)
    hits = cloth_cylinders.middle_row_hits(scene)
    fine = cloth_cylinders.middle_row_hits(scene, SUB)
    y = cloth_cylinders.luminance(image[height // 2])
    light = np.asarray(cloth_cylinders.DEFAULT_LIGHT)
    light = light / np.linalg.norm(light)
    found = {}
    masks = cloth_cylinders.regions(hits, len(cylinders), light)
    for ((table, warp), mask, fabric) in zip(cylinders, masks, [f for f in FABRICS for _ in "ab"]):
        model = model_profile(hits, light, fabric, warp, mask)
        from_table = table_profile(fine, light, scatterbake_table.open_table(table), warp, mask)
        got = cloth_cylinders.highlights(y, mask)
        want_model = cloth_cylinders.highlights(model, mask)
        want_table = cloth_cylinders.highlights(from_table, mask)
        print(f"{fabric} warp {warp}: rendered {np.round(got, 2)}, table {np.round(want_table, 2)}, "
              f"model {np.round(want_model, 2)} (px; render {seconds:.2f} s)")
        assert len(got) == len(want_table) == len(want_model), (got, want_table, want_model)
        assert np.all(np.abs(np.subtract(got, want_table)) <= TABLE_TOL_PX)
        assert np.all(np.abs(np.subtract(got, want_model)) <= MODEL_TOL_PX)
        idx = np.flatnonzero(mask)
        dev = np.max(np.abs(y[idx] - from_table[idx])) / from_table[idx].max()
        print(f"  largest |render − table| over the row: {dev:.4f} × max")
        assert dev <= 0.02
        found[(fabric, warp)] = got
    # Satin's warp floats (flat stretches at −32°, 0°, +32°) give separate highlights when the
    # warp runs around the cylinder, a single broad one when it runs along it.
    assert len(found[("polyester_satin_front", 0.0)]) >= 2
    assert len(found[("polyester_satin_front", 90.0)]) == 1
    assert len(found[("linen_plain", 0.0)]) == len(found[("linen_plain", 90.0)]) == 1
    assert (tmp_path / "cloth.png").stat().st_size > 0


def test_refusals(tables):
    mi.set_variant("llvm_ad_rgb")
    with pytest.raises(Exception, match="is not `cloth-brdf`"):
        load(ROOT / "assets" / "fur-medulla" / "fur-medulla-azimuthal.sbt")
    mi.set_variant("llvm_ad_spectral")
    with pytest.raises(Exception, match="needs an RGB variant"):
        load(tables["linen_plain"])
