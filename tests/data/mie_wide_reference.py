#!/usr/bin/env python3
"""Reference values for the wide-domain Lorenz–Mie tests (`tests/mie_wide.rs`).

Regenerate (from the repository root; needs mpmath, miepython and scattnlay from PyPI):

    pip install mpmath miepython scattnlay
    python3 tests/data/mie_wide_reference.py            # writes tests/data/mie_wide_reference.json
    python3 tests/data/mie_wide_reference.py --large    # also the x = 1e5 cases (slow, ~1 h)
    python3 tests/data/mie_wide_reference.py --only-large   # only tests/data/mie_wide_reference_x1e5.json
    (``--large-labels`` selects the indices computed at x = 1e5; default bubble,water)

Three independent evaluations of every case:

* ``mpmath``: an arbitrary-precision Lorenz–Mie solution written here (``DPS`` decimal digits,
  default 40). Conventions of Bohren & Huffman (1983): m = n + ik with k >= 0 absorbing,
  x = 2 pi r / lambda, S1 perpendicular, S2 parallel. Coefficients from the textbook form
  (Bohren & Huffman Eq. 4.88)
      a_n = [(D_n(mx)/m + n/x) psi_n - psi_{n-1}] / [(D_n(mx)/m + n/x) xi_n - xi_{n-1}]
      b_n = [(m D_n(mx) + n/x) psi_n - psi_{n-1}] / [(m D_n(mx) + n/x) xi_n - xi_{n-1}]
  with D_n(z) by downward recurrence from zero (Kattawar & Plass 1967) started far above
  max(n_stop, |mx|) (margin 16 M^(1/3) + 60), psi_n(x) from the ratio psi_{n-1}/psi_n =
  D_n(x) + n/x, chi_n(x) by upward recurrence, and many more terms than the tested code
  (n_stop = x + 12 x^(1/3) + 20). At 40 digits the cancellations of the textbook form
  (relative x^2 for small x) cost nothing. Each case is also recomputed at DPS + 15 digits
  and the relative change is stored as ``mp_self_check`` (a bound on the reference's own error).
* ``miepython`` (Prahl; Wiscombe's 1980 algorithm, double precision), m passed as n - ik.
* ``scattnlay`` (Peña & Pal 2009, double precision), m = n + ik.

The inputs are the IEEE doubles the Rust tests use: x and m as given, and the cosines
``mu = cos(radians(angle))`` stored in the output so that both sides evaluate S1, S2 at the
same double. Angles 0–180 deg; Q_back is the radar convention
|sum (2n+1)(-1)^n (a_n - b_n)|^2 / x^2 (= 4 |S1(180)|^2 / x^2).

Also stored: MiePlot's intensities for gold at 658 nm, x = 10, m = 0.1425812 + 3.6813284i
(|S1|^2 and |S2|^2 at 0, 10, ..., 90 deg as printed by MiePlot, Laven's BHMIE-based program).
"""

import argparse
import json
import math
import sys

import mpmath
from mpmath import mp, mpc, mpf

ANGLES_DEG = [0.0, 10.0, 30.0, 60.0, 90.0, 120.0, 150.0, 170.0, 180.0]

# (label, m) — regimes of the wide domain
INDICES = [
    ("bubble", complex(0.75, 0.0)),  # air bubble in water
    ("ice-in-water", complex(0.982, 0.0)),  # ice (1.309) in water (1.333)
    ("near-one-below", complex(0.999, 0.0)),
    ("near-one-above", complex(1.001, 0.0)),
    ("near-one-1e-5", complex(1.00001, 0.0)),
    ("low-real", complex(0.05, 0.0)),
    ("silver-like", complex(0.05, 4.0)),
    ("gold-658nm", complex(0.1425812, 3.6813284)),
    ("absorbing", complex(1.5, 1.0)),
    ("metal-k10", complex(0.5, 10.0)),
    ("metal-10+10i", complex(10.0, 10.0)),
    ("water", complex(1.333, 0.0)),
    ("silicon-like", complex(4.0, 0.01)),
    ("high-index", complex(10.0, 0.0)),
    ("high-index-absorbing", complex(10.0, 1.0)),
]
SIZES = [1e-3, 0.1, 1.0, 10.0, 100.0, 1000.0, 1e4]
LARGE = [
    ("bubble", complex(0.75, 0.0)),
    ("gold-658nm", complex(0.1425812, 3.6813284)),
    ("metal-10+10i", complex(10.0, 10.0)),
    ("water", complex(1.333, 0.0)),
    ("silicon-like", complex(4.0, 0.01)),
    ("high-index", complex(10.0, 0.0)),
]

# MiePlot, gold at 658 nm, x = 10, m = 0.1425812 + 3.6813284i, angles 0, 10, ..., 90 deg.
MIEPLOT_GOLD = {
    "x": 10.0,
    "m": [0.1425812, 3.6813284],
    "angles_deg": [10.0 * k for k in range(10)],
    "i_perp": [4830.51401095968, 2002.39671236719, 73.6230330613015, 118.676685975947,
               38.348829860926, 46.0044258298926, 31.3142368857685, 31.3709239005213,
               27.8720309121251, 27.1204995833711],
    "i_par": [4830.51401095968, 1225.28102200945, 216.265206462472, 17.0794942389782,
              91.4145998381414, 39.0790253214751, 24.9801217735053, 53.2319915708624,
              8.26505988320951, 47.4736966179677],
}


def mie_mpmath(x, m, mus, dps):
    """Arbitrary-precision S1, S2 at cosines ``mus`` and Q_ext, Q_sca, Q_back, g."""
    with mp.workdps(dps):
        x = mpf(x)
        m = mpc(m.real, m.imag)
        nstop = int(float(x) + 12.0 * float(x) ** (1.0 / 3.0) + 20.0)
        z = m * x
        big = max(nstop, float(abs(z)))
        nstart = int(big + 16.0 * big ** (1.0 / 3.0) + 60.0)
        dz = [mpc(0)] * (nstop + 1)
        dx = [mpf(0)] * (nstop + 1)
        d = mpc(0)
        e = mpf(0)
        big_x = max(nstop, float(x))
        nstart_x = int(big_x + 16.0 * big_x ** (1.0 / 3.0) + 60.0)
        for n in range(max(nstart, nstart_x), 0, -1):
            if n <= nstart:
                nz = n / z
                d = nz - 1 / (d + nz)
                if n - 1 <= nstop:
                    dz[n - 1] = d
            if n <= nstart_x:
                nx = n / x
                e = nx - 1 / (e + nx)
                if n - 1 <= nstop:
                    dx[n - 1] = e
        psi = [mpmath.sin(x)]
        chi = [mpmath.cos(x)]
        chi_m1 = -mpmath.sin(x)
        psi_m1 = mpmath.cos(x)
        for n in range(1, nstop + 1):
            psi.append(psi[n - 1] / (dx[n] + n / x))
            prev2 = chi_m1 if n == 1 else chi[n - 2]
            chi.append((2 * n - 1) / x * chi[n - 1] - prev2)
        a = []
        b = []
        for n in range(1, nstop + 1):
            xi = mpc(psi[n], -chi[n])
            xi_p = mpc(psi[n - 1], -chi[n - 1])
            ta = dz[n] / m + n / x
            tb = m * dz[n] + n / x
            a.append((ta * psi[n] - psi[n - 1]) / (ta * xi - xi_p))
            b.append((tb * psi[n] - psi[n - 1]) / (tb * xi - xi_p))
        del psi_m1
        sca = mpf(0)
        ext = mpf(0)
        g = mpf(0)
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
                    (a[i] * mpmath.conj(a[i + 1])).real + (b[i] * mpmath.conj(b[i + 1])).real
                )
        x2 = x * x
        q_sca = 2 * sca / x2
        q_ext = 2 * ext / x2
        q_back = abs(back) ** 2 / x2
        g = 4 * g / (x2 * q_sca) if q_sca > 0 else mpf(0)
        s1s = []
        s2s = []
        for mu in mus:
            mu = mpf(mu)
            pi_prev = mpf(0)
            pi_n = mpf(1)
            s1 = mpc(0)
            s2 = mpc(0)
            for i in range(nstop):
                n = i + 1
                tau = n * mu * pi_n - (n + 1) * pi_prev
                c = mpf(2 * n + 1) / (n * (n + 1))
                s1 += c * (a[i] * pi_n + b[i] * tau)
                s2 += c * (a[i] * tau + b[i] * pi_n)
                pi_prev, pi_n = pi_n, ((2 * n + 1) * mu * pi_n - (n + 1) * pi_prev) / n
            s1s.append(s1)
            s2s.append(s2)
        return {
            "n_terms": nstop,
            "qext": q_ext,
            "qsca": q_sca,
            "qback": q_back,
            "g": g,
            "s1": s1s,
            "s2": s2s,
        }


def to_floats(r):
    c = lambda v: [float(v.real), float(v.imag)]
    return {
        "qext": float(r["qext"]),
        "qsca": float(r["qsca"]),
        "qback": float(r["qback"]),
        "g": float(r["g"]),
        "s1": [c(v) for v in r["s1"]],
        "s2": [c(v) for v in r["s2"]],
    }


def self_check(r1, r2):
    """Largest relative change between two precisions over all stored quantities."""
    worst = mpf(0)
    for k in ("qext", "qsca", "qback", "g"):
        if r2[k] != 0:
            worst = max(worst, abs(r1[k] - r2[k]) / abs(r2[k]))
    for k in ("s1", "s2"):
        for u, v in zip(r1[k], r2[k]):
            if v != 0:
                worst = max(worst, abs(u - v) / abs(v))
    return float(worst)


def miepython_case(x, m, mus):
    import numpy as np
    import miepython

    mm = complex(m.real, -m.imag)
    qext, qsca, qback, g = miepython.efficiencies_mx(mm, x)
    s1, s2 = miepython.S1_S2(mm, x, np.array(mus), norm="wiscombe")
    return {
        "qext": float(qext),
        "qsca": float(qsca),
        "qback": float(qback),
        "g": float(g),
        # miepython's amplitudes for k < 0 are the complex conjugates of the e^{-iwt} ones
        "s1": [[float(v.real), -float(v.imag)] for v in s1],
        "s2": [[float(v.real), -float(v.imag)] for v in s2],
    }


def scattnlay_case(x, m, angles):
    import numpy as np
    from scattnlay import scattnlay

    theta = np.array([math.radians(a) for a in angles])
    _, qext, qsca, _, qbk, _, g, _, s1, s2 = scattnlay(np.array([x]), np.array([m]), theta)
    return {
        "qext": float(qext),
        "qsca": float(qsca),
        "qback": float(qbk),
        "g": float(g),
        "s1": [[float(v.real), float(v.imag)] for v in s1],
        "s2": [[float(v.real), float(v.imag)] for v in s2],
    }


def case(label, x, m, dps, check_dps):
    mus = [math.cos(math.radians(a)) for a in ANGLES_DEG]
    r = mie_mpmath(x, m, mus, dps)
    out = {
        "label": label,
        "x": x,
        "m": [m.real, m.imag],
        "angles_deg": ANGLES_DEG,
        "mu": mus,
        "dps": dps,
        "mp_terms": r["n_terms"],
        "mpmath": to_floats(r),
    }
    if check_dps:
        out["mp_self_check"] = self_check(r, mie_mpmath(x, m, mus, check_dps))
    for name, f in (
        ("miepython", lambda: miepython_case(x, m, mus)),
        ("scattnlay", lambda: scattnlay_case(x, m, ANGLES_DEG)),
    ):
        try:
            out[name] = f()
        except Exception as err:  # recorded, never silently dropped
            out[name] = {"error": repr(err)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dps", type=int, default=40)
    ap.add_argument("--large", action="store_true", help="also x = 1e5 (slow)")
    ap.add_argument("--only-large", action="store_true", help="only the x = 1e5 file")
    ap.add_argument("--large-labels", default="bubble,water",
                    help="comma-separated labels of LARGE to compute at x = 1e5")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    import os

    here = os.path.dirname(os.path.abspath(__file__))
    cases = []
    for label, m in [] if args.only_large else INDICES:
        for x in SIZES:
            # the self-check at higher precision is done where it is affordable
            check = args.dps + 15 if x <= 1000.0 else None
            c = case(label, x, m, args.dps, check)
            print(f"{label:>22} x={x:<8g} self-check {c.get('mp_self_check', float('nan')):.1e}",
                  file=sys.stderr, flush=True)
            cases.append(c)
    result = {"generator": "tests/data/mie_wide_reference.py", "cases": cases}
    gold = dict(MIEPLOT_GOLD)
    gmus = [math.cos(math.radians(a)) for a in gold["angles_deg"]]
    gr = mie_mpmath(gold["x"], complex(*gold["m"]), gmus, args.dps)
    gold["mu"] = gmus
    gold["mpmath"] = to_floats(gr)
    result["mieplot_gold"] = gold
    out = args.out or os.path.join(here, "mie_wide_reference.json")
    if not args.only_large:
        with open(out, "w") as f:
            json.dump(result, f, separators=(",", ":"))
    if args.large or args.only_large:
        large = []
        for label, m in [c for c in LARGE if c[0] in args.large_labels.split(",")]:
            c = case(label, 1e5, m, args.dps, None)
            print(f"{label:>22} x=1e5 done", file=sys.stderr, flush=True)
            large.append(c)
        with open(os.path.join(here, "mie_wide_reference_x1e5.json"), "w") as f:
            json.dump({"generator": "tests/data/mie_wide_reference.py --large", "cases": large},
                      f, separators=(",", ":"))


if __name__ == "__main__":
    main()
