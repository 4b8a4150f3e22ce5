"""Speed of scatterbake.mie against miepython in the same process.

Same spheres (m = 1.333 + 1e-4i, x = 1e1, 1e2, 1e3, 1e4), 3601 scattering angles 0–180°, both
computing S1, S2 and the efficiencies (miepython: efficiencies_mx + S1_S2). Each time is the
best of several repetitions after one warm-up call (which also compiles numba's kernels).
miepython picks its backend at import: numpy by default, numba with MIEPYTHON_USE_JIT=1; this
script measures the default backend, then reruns itself with MIEPYTHON_USE_JIT=1.

    python python/bench/bench_vs_miepython.py            # both backends
    python python/bench/bench_vs_miepython.py --single   # only the backend of this process
"""

import os
import subprocess
import sys
import time

import numpy as np

import miepython
import scatterbake as sb

M = 1.333 + 1e-4j
SIZES = [1e1, 1e2, 1e3, 1e4]
ANGLES = np.linspace(0.0, 180.0, 3601)
MU = np.cos(np.radians(ANGLES))


def best_time(f, budget_s=3.0, max_reps=20):
    f()  # warm-up (numba compiles here)
    times = []
    start = time.perf_counter()
    while len(times) < max_reps and (len(times) < 3 or time.perf_counter() - start < budget_s):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def run():
    backend = "numba" if os.environ.get("MIEPYTHON_USE_JIT") == "1" else "numpy"
    print(f"miepython {miepython.__version__} ({backend} backend), scatterbake {sb.__version__}, "
          f"numpy {np.__version__}, {len(ANGLES)} angles, m = {M}")
    print(f"{'x':>8} {'scatterbake s':>14} {'miepython s':>12} {'ratio mp/sb':>12}")
    for x in SIZES:
        def ours():
            return sb.mie(M, x, angles_deg=ANGLES)

        def theirs():
            miepython.efficiencies_mx(M, x)
            return miepython.S1_S2(M, x, MU, norm="wiscombe")

        # same answer before timing
        r = ours()
        s1, _ = theirs()
        err = np.max(np.abs(r.s1 - np.conj(s1))) / np.max(np.abs(s1))
        assert err < 1e-6, f"x={x}: S1 differs by {err:.1e}"
        t_sb = best_time(ours)
        t_mp = best_time(theirs)
        print(f"{x:>8.0e} {t_sb:>14.4g} {t_mp:>12.4g} {t_mp / t_sb:>12.1f}")


if __name__ == "__main__":
    run()
    if "--single" not in sys.argv:
        print()
        env = dict(os.environ, MIEPYTHON_USE_JIT="1")
        subprocess.run([sys.executable, __file__, "--single"], env=env, check=True)
