#!/usr/bin/env python3
"""Reference values for coated spheres (`tests/mie_coated.rs`).

Regenerate (from the repository root; needs mpmath and scattnlay from PyPI):

    pip install mpmath scattnlay
    python3 tests/data/mie_coated_reference.py     # writes tests/data/mie_coated_reference.json

Two independent evaluations per case (conventions of Bohren & Huffman 1983: m = n + ik,
k >= 0 absorbing, indices relative to the outside medium, x_c = 2 pi r_core / lambda,
x = 2 pi r_shell / lambda, S1 perpendicular, S2 parallel; Q_back radar convention):

* ``mpmath``: Bohren & Huffman's coated-sphere formulas (§8.1, the direct form of
  Aden & Kerker's solution) with psi_n, chi_n of the complex arguments m_c x_c, m_s x_c,
  m_s x evaluated in arbitrary precision (psi_n from the downward log-derivative recurrence
  and psi_0 = sin z, chi_n upward from chi_0 = cos z). The direct form cancels catastrophically
  in an absorbing shell (terms grow like e^{Im(m_s) x}); the working precision is raised by
  2 Im(m_s) x / ln 10 digits to pay for it, and every case is recomputed with 15 more digits
  (``mp_self_check``).
* ``scattnlay`` (Peña & Pal 2009, double precision; Yang's 2003 recursion).
"""

import json
import math
import os
import sys

import mpmath
from mpmath import mp, mpc, mpf

ANGLES_DEG = [0.0, 10.0, 30.0, 60.0, 90.0, 120.0, 150.0, 170.0, 180.0]

# (label, x_core, x_shell, m_core, m_shell)
CASES = [
    ("soot-in-water-small", 1.0, 5.0, complex(1.75, 0.43), complex(1.33, 0.0)),
    ("soot-in-water", 10.0, 50.0, complex(1.75, 0.43), complex(1.33, 0.0)),
    ("soot-in-water-large", 100.0, 300.0, complex(1.75, 0.43), complex(1.33, 1e-4)),
    ("gold-core-silica", 2.0, 3.0, complex(0.1425812, 3.6813284), complex(1.45, 0.0)),
    ("silica-core-gold-shell", 3.0, 3.5, complex(1.45, 0.0), complex(0.1425812, 3.6813284)),
    ("silica-core-gold-shell-large", 30.0, 32.0, complex(1.45, 0.0), complex(0.1425812, 3.6813284)),
    ("bubble-core", 5.0, 8.0, complex(0.75, 0.0), complex(1.0, 0.0)),
    ("high-index-core", 50.0, 100.0, complex(4.0, 0.01), complex(1.5, 0.0)),
    ("thick-metal-shell", 10.0, 20.0, complex(1.5, 0.0), complex(10.0, 10.0)),
    ("water-core-glass-shell", 1000.0, 1100.0, complex(1.333, 0.0), complex(1.5, 0.001)),
    ("thin-shell", 0.5, 0.5000001, complex(1.5, 0.0), complex(2.0, 1.0)),
    ("tiny-core", 1e-3, 10.0, complex(2.0, 1.0), complex(1.2, 0.0)),
]


def psi_chi(z, nmax):
    """psi_n(z), chi_n(z) for n = -1..nmax (index shifted by one)."""
    big = max(nmax, float(abs(z)))
    nstart = int(big + 16.0 * big ** (1.0 / 3.0) + 60.0)
    d = mpc(0)
    dn = [mpc(0)] * (nmax + 1)
    for n in range(nstart, 0, -1):
        nz = n / z
        d = nz - 1 / (d + nz)
        if n - 1 <= nmax:
            dn[n - 1] = d
    psi = [mpmath.cos(z), mpmath.sin(z)]
    chi = [-mpmath.sin(z), mpmath.cos(z)]
    for n in range(1, nmax + 1):
        psi.append(psi[n] / (dn[n] + n / z))
        chi.append((2 * n - 1) / z * chi[n] - chi[n - 1])
    return psi, chi


def coated_mpmath(xc, x, mc, ms, mus, dps):
    with mp.workdps(dps):
        xc, x = mpf(xc), mpf(x)
        mc, ms = mpc(mc.real, mc.imag), mpc(ms.real, ms.imag)
        nstop = int(float(x) + 12.0 * float(x) ** (1.0 / 3.0) + 20.0)
        p1, c1 = psi_chi(mc * xc, nstop)  # core material at the core surface
        p2, c2 = psi_chi(ms * xc, nstop)  # shell material at the core surface
        p3, c3 = psi_chi(ms * x, nstop)  # shell material at the outer surface
        py, cy = psi_chi(x, nstop)  # outside
        zc, z2, z3 = mc * xc, ms * xc, ms * x

        def d(f, z, n):  # derivative from f_{n-1} - n f_n / z (arrays shifted by one)
            return f[n] - n * f[n + 1] / z

        a, b = [], []
        for n in range(1, nstop + 1):
            k = n + 1
            A = (ms * p2[k] * d(p1, zc, n) - mc * d(p2, z2, n) * p1[k]) / (
                ms * c2[k] * d(p1, zc, n) - mc * d(c2, z2, n) * p1[k])
            B = (ms * p1[k] * d(p2, z2, n) - mc * p2[k] * d(p1, zc, n)) / (
                ms * d(c2, z2, n) * p1[k] - mc * d(p1, zc, n) * c2[k])
            xi = py[k] - 1j * cy[k]
            dxi = d(py, x, n) - 1j * d(cy, x, n)
            dpsi = d(py, x, n)
            fa = d(p3, z3, n) - A * d(c3, z3, n)
            ga = p3[k] - A * c3[k]
            fb = d(p3, z3, n) - B * d(c3, z3, n)
            gb = p3[k] - B * c3[k]
            a.append((py[k] * fa - ms * dpsi * ga) / (xi * fa - ms * dxi * ga))
            b.append((ms * py[k] * fb - dpsi * gb) / (ms * xi * fb - dxi * gb))
        sca = ext = g = mpf(0)
        back = mpc(0)
        for i in range(nstop):
            n = i + 1
            w = 2 * n + 1
            sca += w * (abs(a[i]) ** 2 + abs(b[i]) ** 2)
            ext += w * (a[i].real + b[i].real)
            back += w * (-1) ** n * (a[i] - b[i])
            g += mpf(w) / (n * (n + 1)) * (a[i] * mpmath.conj(b[i])).real
            if i + 1 < nstop:
                g += mpf(n * (n + 2)) / (n + 1) * (
                    (a[i] * mpmath.conj(a[i + 1])).real + (b[i] * mpmath.conj(b[i + 1])).real)
        x2 = x * x
        q_sca = 2 * sca / x2
        res = {"qext": 2 * ext / x2, "qsca": q_sca, "qback": abs(back) ** 2 / x2,
               "g": 4 * g / (x2 * q_sca), "s1": [], "s2": []}
        for mu in mus:
            mu = mpf(mu)
            pi_prev, pi_n = mpf(0), mpf(1)
            s1 = s2 = mpc(0)
            for i in range(nstop):
                n = i + 1
                tau = n * mu * pi_n - (n + 1) * pi_prev
                c = mpf(2 * n + 1) / (n * (n + 1))
                s1 += c * (a[i] * pi_n + b[i] * tau)
                s2 += c * (a[i] * tau + b[i] * pi_n)
                pi_prev, pi_n = pi_n, ((2 * n + 1) * mu * pi_n - (n + 1) * pi_prev) / n
            res["s1"].append(s1)
            res["s2"].append(s2)
        return res


def floats(r):
    c = lambda v: [float(v.real), float(v.imag)]
    return {"qext": float(r["qext"]), "qsca": float(r["qsca"]), "qback": float(r["qback"]),
            "g": float(r["g"]), "s1": [c(v) for v in r["s1"]], "s2": [c(v) for v in r["s2"]]}


def self_check(r1, r2):
    worst = mpf(0)
    for k in ("qext", "qsca", "qback", "g"):
        worst = max(worst, abs(r1[k] - r2[k]) / abs(r2[k]))
    for k in ("s1", "s2"):
        for u, v in zip(r1[k], r2[k]):
            worst = max(worst, abs(u - v) / abs(v))
    return float(worst)


def scattnlay_case(xc, x, mc, ms):
    import numpy as np
    from scattnlay import scattnlay

    theta = np.array([math.radians(a) for a in ANGLES_DEG])
    _, qext, qsca, _, qbk, _, g, _, s1, s2 = scattnlay(np.array([xc, x]), np.array([mc, ms]), theta)
    return {"qext": float(qext), "qsca": float(qsca), "qback": float(qbk), "g": float(g),
            "s1": [[float(v.real), float(v.imag)] for v in s1],
            "s2": [[float(v.real), float(v.imag)] for v in s2]}


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    mus = [math.cos(math.radians(a)) for a in ANGLES_DEG]
    out = []
    for label, xc, x, mc, ms in CASES:
        dps = 40 + int(2.0 * max(ms.imag * x, mc.imag * xc) / math.log(10.0)) + 5
        r = coated_mpmath(xc, x, mc, ms, mus, dps)
        chk = self_check(r, coated_mpmath(xc, x, mc, ms, mus, dps + 15))
        case = {"label": label, "core_x": xc, "x": x, "core_m": [mc.real, mc.imag],
                "shell_m": [ms.real, ms.imag], "angles_deg": ANGLES_DEG, "mu": mus, "dps": dps,
                "mp_self_check": chk, "mpmath": floats(r)}
        try:
            case["scattnlay"] = scattnlay_case(xc, x, mc, ms)
        except Exception as err:
            case["scattnlay"] = {"error": repr(err)}
        print(f"{label:>30} dps {dps} self-check {chk:.1e}", file=sys.stderr, flush=True)
        out.append(case)
    with open(os.path.join(here, "mie_coated_reference.json"), "w") as f:
        json.dump({"generator": "tests/data/mie_coated_reference.py", "cases": out}, f, indent=1)


if __name__ == "__main__":
    main()
