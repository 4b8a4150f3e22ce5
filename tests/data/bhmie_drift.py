"""BHMIE (Bohren & Huffman 1983, Appendix A) transcribed in double precision, against the
40-digit references of mie_wide_reference.json: the drift envelope of `scatterbake validate`
(decision MIE-15 in docs/decisions.md).

    python3 tests/data/bhmie_drift.py tests/data/mie_wide_reference.json

Prints, per case with x >= 1, the max relative error of |S1|^2, |S2|^2 over the stored angles and
of Q_ext, Q_back. Needs numpy.
"""
import json, math, cmath, sys
import numpy as np

def bhmie(x, m, mus):
    y = m * x
    xstop = x + 4.0 * x ** (1.0 / 3.0) + 2.0
    nstop = int(xstop)
    ymod = abs(y)
    nmx = int(max(xstop, ymod)) + 15
    d = np.zeros(nmx + 1, dtype=complex)
    for n in range(nmx, 1, -1):
        en = n / y
        d[n - 1] = en - 1.0 / (d[n] + en)
    mus = np.asarray(mus)
    pi0 = np.zeros_like(mus); pi1 = np.ones_like(mus)
    s1 = np.zeros(len(mus), dtype=complex); s2 = np.zeros(len(mus), dtype=complex)
    psi0, psi1 = math.cos(x), math.sin(x)
    chi0, chi1 = -math.sin(x), math.cos(x)
    xi1 = complex(psi1, -chi1)
    qsca = 0.0; qext = 0.0; gsca = 0.0; back = 0j
    an1 = bn1 = 0j
    for n in range(1, nstop + 1):
        en = float(n)
        fn = (2.0 * en + 1.0) / (en * (en + 1.0))
        psi = (2.0 * en - 1.0) * psi1 / x - psi0
        chi = (2.0 * en - 1.0) * chi1 / x - chi0
        xi = complex(psi, -chi)
        an = ((d[n] / m + en / x) * psi - psi1) / ((d[n] / m + en / x) * xi - xi1)
        bn = ((m * d[n] + en / x) * psi - psi1) / ((m * d[n] + en / x) * xi - xi1)
        qsca += (2 * en + 1) * (abs(an) ** 2 + abs(bn) ** 2)
        qext += (2 * en + 1) * (an.real + bn.real)
        back += (2 * en + 1) * (-1) ** n * (an - bn)
        pi_ = pi1
        tau = en * mus * pi_ - (en + 1) * pi0
        s1 += fn * (an * pi_ + bn * tau)
        s2 += fn * (an * tau + bn * pi_)
        psi0, psi1 = psi1, psi
        chi0, chi1 = chi1, chi
        xi1 = complex(psi1, -chi1)
        p = pi1
        pi1 = ((2 * en + 1) * mus * pi1 - (en + 1) * pi0) / en
        pi0 = p
    return s1, s2, qext * 2 / x**2, qsca * 2 / x**2, abs(back) ** 2 / x**2

r = json.load(open(sys.argv[1]))
rows = []
for c in r["cases"]:
    m = complex(*c["m"])
    x = c["x"]
    if x < 1: continue
    ref = c["mpmath"]
    s1, s2, qe, qs, qb = bhmie(x, m, c["mu"])
    r1 = np.array([complex(*v) for v in ref["s1"]]); r2 = np.array([complex(*v) for v in ref["s2"]])
    i1, i2 = np.abs(r1) ** 2, np.abs(r2) ** 2
    e = max(np.max(np.abs(np.abs(s1) ** 2 - i1) / i1), np.max(np.abs(np.abs(s2) ** 2 - i2) / i2))
    rows.append((c["label"], m, x, m.imag * x, e, abs(qe / ref["qext"] - 1), abs(qb / ref["qback"] - 1)))
rows.sort(key=lambda t: t[3])
print(f"{'case':24} {'m':>18} {'x':>8} {'k x':>9} {'|S|^2 max rel':>14} {'Qext':>9} {'Qback':>9}")
for t in rows:
    print(f"{t[0]:24} {str(t[1]):>18} {t[2]:8g} {t[3]:9.3g} {t[4]:14.2e} {t[5]:9.1e} {t[6]:9.1e}")
