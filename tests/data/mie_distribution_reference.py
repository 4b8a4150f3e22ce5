"""Brute-force references for size-distribution averages (tests/mie_distribution.rs).

Independent of scatterbake: miepython (Prahl) for the spheres' coefficients and efficiencies, the size distributions written
out here from their definitions (docs/mie.md, the manifest's `distributions` entries), and a
dense midpoint rule in the size parameter x over the distribution's support. Every case is
computed at two resolutions (step h and 2h in x); the JSON keeps the fine one and the RMS and
largest relative difference between the two (over angles and both polarisations, relative to
the phase function), which bounds the reference's own error.

Quantities per case (mixing weights n(r) dr C_sca(r), curves normalised so that the integral
of (i_perp + i_par)/2 over 4 pi sr is 1):
- `points`: i_perp, i_par at 0, 0.5, ..., 180 deg (point values);
- `bins`: solid-angle averages over 1-degree bins centred on 0, 1, ..., 180 deg (half bins at
  the poles), by a Gauss-Legendre rule in theta per bin (weight sin theta);
- q_ext, q_sca (<C>/<pi r^2>) and g (<C_sca g>/<C_sca>).

Run: python3 -m venv /tmp/mievenv && /tmp/mievenv/bin/pip install miepython
     MIEPYTHON_USE_JIT=1 /tmp/mievenv/bin/python tests/data/mie_distribution_reference.py [case ...]
Writes tests/data/mie_distribution_reference.json (all cases) or prints the named cases.
"""

import json
import math
import sys
import time
from pathlib import Path

import miepython
import numpy as np

WAVELENGTH_NM = 550.0
# Index n + ik (Bohren & Huffman sign; miepython takes n - ik). Clear water (k = 0) has
# resonances in x far narrower than any affordable step: midpoint rules of step 0.1/0.05 and
# 0.04/0.02 in x differ by 4.6e-3 and 2.1e-3 RMS (fog, point values), so the references damp
# them with a small absorption (width of a resonance ~ 2 k x / n in x).
N_REAL = 1.333


def lognormal(median_um, sigma_g):
    s = math.log(sigma_g)
    support = (median_um / sigma_g**6, median_um * sigma_g**6)
    return support, lambda r: np.exp(-np.log(r / median_um) ** 2 / (2 * s * s)) / r


def gamma(r_eff_um, v_eff):
    mean = r_eff_um * (1 - 2 * v_eff)
    sd = r_eff_um * math.sqrt(v_eff * (1 - 2 * v_eff))
    support = (max(mean - 5 * sd, 1e-3 * mean), mean + 10 * sd)
    e = (1 - 3 * v_eff) / v_eff
    return support, lambda r: np.exp(e * np.log(r / r_eff_um) - r / (r_eff_um * v_eff))


def marshall_palmer(rain_mm_h, lo_um, hi_um):
    lam_per_um = 4.1 * rain_mm_h**-0.21 * 2e-3  # Lambda D with D = 2r, D in mm
    return (lo_um, hi_um), lambda r: np.exp(-lam_per_um * r)


CASES = {
    # name: (manifest form, (support, density), step in x of the fine rule, Gauss points per
    # bin, k)
    "fog": (
        {"kind": "lognormal", "median_radius_um": 6.0, "geometric_sigma": 1.35},
        lognormal(6.0, 1.35),
        0.02,
        32,
        1e-3,
    ),
    "cloud": (
        {"kind": "gamma", "effective_radius_um": 10.0, "effective_variance": 0.1},
        gamma(10.0, 0.1),
        0.02,
        32,
        1e-3,
    ),
    "rain": (
        {
            "kind": "marshall-palmer",
            "rain_rate_mm_h": 5.0,
            "min_radius_um": 50.0,
            "max_radius_um": 100.0,
        },
        marshall_palmer(5.0, 50.0, 100.0),
        0.04,
        48,
        1e-4,
    ),
}

POINT_DEG = np.arange(0, 361) * 0.5
BIN_CENTRES_DEG = np.arange(0, 181) * 1.0


def bin_rule(points):
    """Cosines and weights (sin theta dtheta / cell solid angle / 2 pi) of every bin."""
    gx, gw = np.polynomial.legendre.leggauss(points)
    mus, ws, owner = [], [], []
    for j, c in enumerate(BIN_CENTRES_DEG):
        lo = math.radians(max(c - 0.5, 0.0))
        hi = math.radians(min(c + 0.5, 180.0))
        h, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
        t = mid + h * gx
        cell = math.cos(lo) - math.cos(hi)
        mus.append(np.cos(t))
        ws.append(gw * h * np.sin(t) / cell)
        owner.append(np.full(points, j))
    return np.concatenate(mus), np.concatenate(ws), np.concatenate(owner)


def pi_tau(mu, n_max):
    """Angular functions pi_n, tau_n (n = 1..n_max) at the cosines mu (Bohren & Huffman 4.47)."""
    pi = np.zeros((n_max, len(mu)))
    tau = np.zeros((n_max, len(mu)))
    p_prev, p = np.zeros_like(mu), np.ones_like(mu)
    for n in range(1, n_max + 1):
        pi[n - 1] = p
        tau[n - 1] = n * mu * p - (n + 1) * p_prev
        p_prev, p = p, ((2 * n + 1) * mu * p - (n + 1) * p_prev) / n
    return pi, tau


def average(case, step_x, batch=128):
    """Midpoint rule in x: coefficients a_n, b_n and efficiencies from miepython, the
    amplitude sums S1, S2 = sum_n (2n+1)/(n(n+1)) (a_n pi_n + b_n tau_n, a_n tau_n + b_n pi_n)
    for a batch of spheres at once as matrix products with pi_n, tau_n tabulated once."""
    _, ((lo_um, hi_um), density), _, points, k_im = CASES[case]
    m = complex(N_REAL, -k_im)  # miepython's sign
    k = 2 * math.pi / (WAVELENGTH_NM * 1e-3)  # x per um
    x_lo, x_hi = k * lo_um, k * hi_um
    n = int(math.ceil((x_hi - x_lo) / step_x))
    h = (x_hi - x_lo) / n
    mu_points = np.cos(np.radians(POINT_DEG))
    mu_bins, w_bins, owner = bin_rule(points)
    mu = np.concatenate([mu_points, mu_bins])
    npt = len(mu_points)
    n_max = len(miepython.an_bn(m, x_hi)[0]) + 8
    pi, tau = pi_tau(mu, n_max)
    sums = {"perp": np.zeros(len(mu)), "par": np.zeros(len(mu))}
    area = ext = sca = gsca = 0.0
    for start in range(0, n, batch):
        idx = range(start, min(start + batch, n))
        ca = np.zeros((len(idx), n_max), complex)
        cb = np.zeros((len(idx), n_max), complex)
        weights = np.zeros(len(idx))
        for row, i in enumerate(idx):
            x = x_lo + (i + 0.5) * h
            r = x / k
            w = float(density(r)) * h / k  # n(r) dr
            a, b = miepython.an_bn(m, x)
            order = np.arange(1, len(a) + 1)
            c = (2 * order + 1) / (order * (order + 1))
            ca[row, : len(a)] = c * a
            cb[row, : len(b)] = c * b
            qext, qsca, _, g = miepython.efficiencies_mx(m, x)
            c_sca = math.pi * r * r * qsca
            weights[row] = w / (k * k)  # C_sca p = |S|^2 / k^2
            area += w * math.pi * r * r
            ext += w * math.pi * r * r * qext
            sca += w * c_sca
            gsca += w * c_sca * g
        s1 = ca @ pi + cb @ tau
        s2 = ca @ tau + cb @ pi
        sums["perp"] += weights @ (np.abs(s1) ** 2)
        sums["par"] += weights @ (np.abs(s2) ** 2)
    out = {"nodes": n, "q_ext": ext / area, "q_sca": sca / area, "g": gsca / sca}
    for ch in ("perp", "par"):
        v = sums[ch] / sca
        out[f"points_i_{ch}"] = v[:npt]
        out[f"bins_i_{ch}"] = np.bincount(owner, weights=w_bins * v[npt:], minlength=181)
    return out


def difference(a, b, part):
    phase = 0.5 * (a[f"{part}_i_perp"] + a[f"{part}_i_par"])
    rel = np.concatenate(
        [np.abs(a[f"{part}_i_{ch}"] - b[f"{part}_i_{ch}"]) / phase for ch in ("perp", "par")]
    )
    return float(np.sqrt(np.mean(rel**2))), float(rel.max())


def run(case):
    manifest, _, step, points, k_im = CASES[case]
    t0 = time.time()
    fine = average(case, step)
    coarse = average(case, 2 * step)
    seconds = time.time() - t0
    conv = {}
    for part in ("points", "bins"):
        rms, mx = difference(coarse, fine, part)
        conv[part] = {"rms": rms, "max": mx}
    sig = lambda v: [float(f"{x:.10g}") for x in v]
    return {
        "distribution": manifest,
        "wavelength_nm": WAVELENGTH_NM,
        "m": [N_REAL, k_im],
        "rule": f"midpoint in x, step {step} ({fine['nodes']} spheres); check: step {2 * step}",
        "gauss_points_per_bin": points,
        "coarse_vs_fine": conv,
        "seconds": round(seconds, 1),
        "q_ext": fine["q_ext"],
        "q_sca": fine["q_sca"],
        "g": fine["g"],
        "points_deg": sig(POINT_DEG),
        "points_i_perp": sig(fine["points_i_perp"]),
        "points_i_par": sig(fine["points_i_par"]),
        "bin_centres_deg": sig(BIN_CENTRES_DEG),
        "bins_i_perp": sig(fine["bins_i_perp"]),
        "bins_i_par": sig(fine["bins_i_par"]),
    }


def main():
    names = sys.argv[1:] or list(CASES)
    result = {"generator": "tests/data/mie_distribution_reference.py",
              "miepython": miepython.__version__, "cases": {}}
    for name in names:
        result["cases"][name] = run(name)
        c = result["cases"][name]
        print(name, c["rule"], c["coarse_vs_fine"], f"{c['seconds']} s", file=sys.stderr)
    if sys.argv[1:]:
        print(json.dumps(result)[:2000])
    else:
        out = Path(__file__).with_name("mie_distribution_reference.json")
        out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
