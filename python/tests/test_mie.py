"""scatterbake.mie / debye / mie_distribution against independent references: Rayleigh-limit
formulas, miepython (another implementation, test-only dependency) and identities."""

import math
import threading
import time

import miepython
import numpy as np
import pytest

import scatterbake as sb

ANGLES = np.linspace(0.0, 180.0, 181)
MU = np.cos(np.radians(ANGLES))


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b)) / np.maximum(np.abs(b), 1e-300))


@pytest.mark.parametrize("m", [1.5 + 0.1j, 1.33 + 0.0j, 0.75 + 0.0j, 2.0 + 1.0j])
def test_rayleigh_limit(m):
    """x = 1e-3 (the smallest validated x): K = (m²−1)/(m²+2), Bohren & Huffman §5.2:
    S1 = −i x³ K, S2 = S1 cos θ, Q_sca = 8/3 x⁴ |K|², Q_abs = 4x Im K, Q_back = 4x⁴|K|²
    (radar), g → 0; corrections are O(x²) = 1e-6."""
    x = 1e-3
    k = (m * m - 1) / (m * m + 2)
    r = sb.mie(m, x, angles_deg=ANGLES)
    s1 = -1j * x**3 * k
    assert rel(r.s1, np.full_like(r.s1, s1)) < 1e-5
    assert np.max(np.abs(r.s2 - s1 * MU)) < 1e-5 * abs(s1)
    assert abs(r.qsca / (8 / 3 * x**4 * abs(k) ** 2) - 1) < 1e-5
    if m.imag > 0:
        assert abs(r.qabs / (4 * x * k.imag) - 1) < 1e-5
        assert abs(r.qext / (r.qsca + 4 * x * k.imag) - 1) < 1e-5
    else:
        assert r.qabs == 0.0
    assert abs(r.qback / (4 * x**4 * abs(k) ** 2) - 1) < 1e-5
    assert abs(r.qback_per_sr - r.qback / (4 * math.pi)) < 1e-15 * r.qback
    assert abs(r.g) < 1e-5
    # phase function of a dipole: 3/(16π) (1 + cos²θ)
    assert rel(r.phase, 3 / (16 * math.pi) * (1 + MU**2)) < 1e-5


CASES = [
    (1.5 + 0.0j, 1.0),
    (1.33 + 0.05j, 30.0),  # absorbing
    (0.75 + 0.0j, 10.0),  # m < 1 (bubble-like)
    (1.333 + 0.0j, 100.0),
    (1.5 + 0.01j, 1000.0),
]


@pytest.mark.parametrize("m,x", CASES)
def test_against_miepython(m, x):
    """miepython 3.x writes m = n − ik and e^{+iωt}: its S1, S2 with norm='wiscombe' are the
    complex conjugates of Bohren & Huffman's; its qback is the radar convention."""
    r = sb.mie(m, x, angles_deg=ANGLES)
    qext, qsca, qback, g = miepython.efficiencies_mx(m, x)
    assert abs(r.qext / qext - 1) < 1e-9
    assert abs(r.qsca / qsca - 1) < 1e-9
    # miepython's backscatter sum loses ~1e-7 at x = 1000 (the library's is within 6e-9 of
    # 40-digit references, docs/mie.md)
    assert abs(r.qback / qback - 1) < 1e-6
    assert abs(r.qback_per_sr / (qback / (4 * np.pi)) - 1) < 1e-6
    assert abs(r.g - g) < 1e-9
    s1, s2 = miepython.S1_S2(m, x, MU, norm="wiscombe")
    scale = np.max(np.abs(s1))
    assert np.max(np.abs(r.s1 - np.conj(s1))) < 1e-8 * scale
    assert np.max(np.abs(r.s2 - np.conj(s2))) < 1e-8 * scale
    # the normalised phase function, miepython's 'one' normalisation integrates to 1 over 4π too
    p = miepython.i_unpolarized(m, x, MU, norm="one")
    assert np.max(np.abs(r.phase - p)) < 1e-8 * np.max(p)


def test_medium_index_follows_the_command_line_and_miepython():
    """m is the sphere's own index, n_medium the medium's: the relative index is m/n_medium and
    x = 2π r n_medium/λ (vacuum λ); miepython.efficiencies(m, d, λ0, n_env) uses the same."""
    m, n_med, r_um, lam = 1.5 + 0.002j, 1.333, 1.2, 633.0
    a = sb.mie(m, radius_um=r_um, wavelength_nm=lam, n_medium=n_med, angles_deg=ANGLES)
    x = 2 * np.pi * r_um * 1e3 * n_med / lam
    assert abs(a.x / x - 1) < 1e-14
    assert abs(a.m - m / n_med) < 1e-15
    b = sb.mie(m / n_med, x, angles_deg=ANGLES)
    # the same sphere (x computed in another order differs in the last bit)
    assert rel(a.s1, b.s1) < 1e-11 and abs(a.qext / b.qext - 1) < 1e-13
    qext, qsca, qback, g = miepython.efficiencies(m, 2 * r_um, lam * 1e-3, n_env=n_med)
    assert abs(a.qext / qext - 1) < 1e-9 and abs(a.qsca / qsca - 1) < 1e-9
    assert abs(a.qback / qback - 1) < 1e-6 and abs(a.g - g) < 1e-9
    # a given x is the size parameter in the medium: only m is divided
    c = sb.mie(m, x, n_medium=n_med, angles_deg=ANGLES)
    assert rel(c.s1, a.s1) < 1e-11


def test_coated_sphere_limits():
    """A core of the shell's index is the homogeneous sphere; a vanishing core too; a core as
    large as the sphere is the homogeneous core-material sphere."""
    m, x = 1.33 + 0.01j, 20.0
    h = sb.mie(m, x, angles_deg=ANGLES)
    same = sb.mie(m, x, core_x=8.0, core_m=m, angles_deg=ANGLES)
    assert rel(same.s1, h.s1) < 1e-9 and abs(same.qext / h.qext - 1) < 1e-10
    zero = sb.mie(m, x, core_x=0.0, core_m=1.9 + 0.5j, angles_deg=ANGLES)
    assert rel(zero.s1, h.s1) < 1e-12
    full = sb.mie(m, x, core_x=x, core_m=1.9 + 0.5j, angles_deg=ANGLES)
    core = sb.mie(1.9 + 0.5j, x, angles_deg=ANGLES)
    assert np.max(np.abs(full.s1 - core.s1)) < 1e-8 * np.max(np.abs(core.s1))
    coated = sb.mie(1.33, radius_um=1.0, wavelength_nm=550.0, core_radius_um=0.5,
                    core_m=1.95 + 0.79j, n_medium=1.0, angles_deg=ANGLES)
    assert coated.core_x == pytest.approx(coated.x / 2, rel=1e-14)
    assert coated.qabs > 0 and coated.qext == pytest.approx(coated.qsca + coated.qabs)


def test_debye_orders_sum_to_mie():
    """For an absorbing sphere the internal reflections die out: Σ_{p=0}^{P} S_p → S_Mie."""
    m, x = 1.33 + 0.05j, 30.0
    d = sb.debye(m, list(range(0, 12)), x, angles_deg=ANGLES)
    full = sb.mie(m, x, angles_deg=ANGLES)
    assert d.s1.shape == (12, len(ANGLES))
    assert np.max(np.abs(d.s1.sum(axis=0) - full.s1)) < 1e-9 * np.max(np.abs(full.s1))
    assert np.max(np.abs(d.s2.sum(axis=0) - full.s2)) < 1e-9 * np.max(np.abs(full.s1))
    assert rel(d.mie_phase, full.phase) < 1e-12
    assert d.qext == full.qext and d.qback_per_sr == full.qback_per_sr
    # p = 0 holds the diffraction peak: about half the extinction at large x
    assert 0.4 < d.qsca_orders[0] / full.qext < 1.1


def test_debye_primary_bow_of_a_100um_drop():
    """p = 2 of a 100 µm water drop at 650 nm peaks near the geometric rainbow angle (~138°)."""
    a = np.arange(120.0, 160.0, 0.01)
    d = sb.debye(1.3314, [2], radius_um=100.0, wavelength_nm=650.0, angles_deg=a)
    peak = a[np.argmax(d.phase[0])]
    assert 136.0 < peak < 140.0


def _sphere_integral(angles_deg, values):
    th = np.radians(angles_deg)
    f = values * np.sin(th)
    return 2 * np.pi * np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(th))


@pytest.mark.parametrize(
    "dist",
    [sb.lognormal(1.0, 1.5), sb.gamma(2.0, 0.1), sb.marshall_palmer(5.0, 50.0, 100.0)],
)
def test_distribution_mixture_against_miepython(dist):
    """The ensemble equals miepython's single spheres mixed with weights n(r) dr · C_sca at
    the library's quadrature nodes, and integrates to 1 over 4π."""
    lam, m = 650.0, 1.33 + 0.0j
    a = np.linspace(0.0, 180.0, 3601)
    e = sb.mie_distribution(dist, lam, m, angles_deg=a, radius_points=12)
    mu = np.cos(np.radians(a))
    num = np.zeros_like(a)
    wsum = csca = cext = 0.0
    for r, w in zip(e.radii_um, e.weights):
        x = 2 * np.pi * r * 1e3 / lam
        qext, qsca, _, _ = miepython.efficiencies_mx(m, x)
        c = w * np.pi * r * r * qsca
        num += c * miepython.i_unpolarized(m, x, mu, norm="one")
        wsum += w * np.pi * r * r
        csca += c
        cext += w * np.pi * r * r * qext
    assert np.max(np.abs(e.phase - num / csca)) < 1e-7 * np.max(e.phase)
    assert abs(e.qsca / (csca / wsum) - 1) < 1e-9
    assert abs(e.qext / (cext / wsum) - 1) < 1e-9
    if dist["kind"] != "marshall-palmer":  # 0.01° is too coarse for the 100 µm forward peak
        assert abs(_sphere_integral(a, e.phase) - 1) < 2e-3


def test_distribution_meets_its_tolerance_against_the_reference():
    """The adaptive rule against the miepython brute-force reference of the Rust tests
    (tests/data/mie_distribution_reference.json): the estimate meets the tolerance and bounds
    the true RMS error, relative to the phase function over both polarisations."""
    import json
    import pathlib

    path = pathlib.Path(__file__).parents[2] / "tests/data/mie_distribution_reference.json"
    fog = json.loads(path.read_text())["cases"]["fog"]
    m = complex(fog["m"][0], fog["m"][1])
    e = sb.mie_distribution(fog["distribution"], fog["wavelength_nm"], m,
                            angles_deg=fog["points_deg"], tolerance=1e-3)
    rp, ra = np.array(fog["points_i_perp"]), np.array(fog["points_i_par"])
    phase = 0.5 * (rp + ra)
    rms = np.sqrt(np.mean(np.concatenate([(e.i_perp - rp) / phase, (e.i_par - ra) / phase]) ** 2))
    assert e.error_estimate <= 1e-3 and rms <= e.error_estimate
    assert e.radius_nodes >= len(e.radii_um) > 100
    fixed = sb.mie_distribution(fog["distribution"], 550.0, m, angles_deg=[90.0], radius_points=8)
    assert fixed.error_estimate is None and fixed.radius_nodes == 8


def test_monodisperse_distribution_is_the_sphere():
    e = sb.mie_distribution(sb.monodisperse(3.0), 550.0, 1.33 + 0.001j, angles_deg=ANGLES)
    s = sb.mie(1.33 + 0.001j, radius_um=3.0, wavelength_nm=550.0, angles_deg=ANGLES)
    assert rel(e.phase, s.phase) < 1e-12 and abs(e.g / s.g - 1) < 1e-12


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: sb.mie(1.5 - 0.1j, 10.0), "refractive index"),
        (lambda: sb.mie(1.5, 2e5), "size parameter"),
        (lambda: sb.mie(1.5, 10.0, radius_um=1.0, wavelength_nm=500.0), "either x"),
        (lambda: sb.mie(1.5), "either x"),
        (lambda: sb.mie(1.5, 10.0, angles_deg=[190.0]), r"\[0, 180\]"),
        (lambda: sb.mie(1.5, 10.0, angles_deg=[float("nan")]), r"\[0, 180\]"),
        (lambda: sb.mie(1.5, 10.0, n_medium=0.0), "n_medium"),
        (lambda: sb.mie(1.5, 10.0, core_x=11.0, core_m=2.0), "core size parameter"),
        (lambda: sb.mie(1.5, 10.0, core_m=2.0), "core_x"),
        (lambda: sb.debye(0.75, [1], 10.0), "refractive index"),
        (lambda: sb.debye(1.33, [], 10.0), "orders"),
        (lambda: sb.mie_distribution({"kind": "weibull"}, 550.0, 1.33), "unknown variant"),
        (lambda: sb.mie_distribution(sb.gamma(1.0, 0.7), 550.0, 1.33), "effective_variance"),
        (lambda: sb.mie_distribution(sb.lognormal(1.0, 1.5), 550.0, 1.33, radius_points=0),
         "radius_points"),
        (lambda: sb.mie_distribution(sb.lognormal(6.0, 1.35), 550.0, 1.333, angles_deg=[30.0],
                                     tolerance=1e-5, max_radius_nodes=500), "tolerance"),
    ],
)
def test_bad_input_is_a_value_error_with_the_library_message(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_gil_is_released_while_computing():
    """Another Python thread runs while a large sphere is computed."""
    ticks = []
    done = threading.Event()

    def work():
        sb.mie(1.333, 5e4, angles_deg=np.linspace(0, 180, 3601))
        done.set()

    t = threading.Thread(target=work)
    t0 = time.perf_counter()
    t.start()
    while not done.is_set():
        ticks.append(time.perf_counter() - t0)
        time.sleep(0.001)
    t.join()
    assert len(ticks) >= 5, f"main thread ran {len(ticks)} times during the computation"
