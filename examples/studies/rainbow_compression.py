#!/usr/bin/env python3
"""How far a 2-D ray-traced phase-function table compresses, and at what error.

Reads one entry (radius, wavelength, sun elevation) of a `raytrace-phase-2d` table with the
pure-Python reader and prints, for the perpendicular and parallel components:

- the zstd size of the dense f32 values (four contract channels, and the two components
  `phase` and `dolp` follow from);
- the pixel-scale noise (median relative deviation from the mean of the two polar neighbours);
- the size after quantising ln(value) to a step that bounds the relative error, delta-coding
  along the polar axis and zstd, without smoothing and after Gaussian smoothing at scales
  below the sun's disc (0.5 degrees), with the relative L2 and maximum error of the smoothed
  table against the dense one in the bow window (scattering angles 125-145 degrees).

Usage (numpy and zstandard; the table from `scatterbake build`):

    python3 examples/studies/rainbow_compression.py TABLE.sbt

Measurements: docs/studies/rainbow-compression.md.
"""
import sys
from pathlib import Path

import numpy as np
import zstandard

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))
from scatterbake_table import open_table  # noqa: E402


def gaussian(x, sigma_px, axis, wrap):
    """Gaussian smoothing of `x` along `axis` (sigma in samples)."""
    if sigma_px <= 0:
        return x
    r = int(np.ceil(4 * sigma_px))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma_px) ** 2)
    k /= k.sum()
    pad = [(0, 0)] * x.ndim
    pad[axis] = (r, r)
    xp = np.pad(x, pad, mode="wrap" if wrap else "edge")
    out = np.zeros_like(x)
    for i, w in enumerate(k):
        sl = [slice(None)] * x.ndim
        sl[axis] = slice(i, i + x.shape[axis])
        out += w * xp[tuple(sl)]
    return out


def quantised_bytes(values, rel, zc):
    """zstd bytes of ln(values) quantised to max relative error `rel`, delta-coded along polar."""
    step = 2 * np.log1p(rel)
    q = np.round(np.log(np.maximum(values, 1e-30)) / step).astype(np.int64)
    dq = np.diff(q, axis=0, prepend=0)
    zz = (dq << 1) ^ (dq >> 63)
    arr = zz.astype(np.uint16) if zz.max() < 65536 else zz.astype(np.uint32)
    return len(zc.compress(arr.tobytes()))


def bow_window(header, n_polar, n_azimuth):
    """Mask of directions whose scattering angle lies in 125-145 degrees."""
    axes = {a["name"]: a for a in header["axes"]}
    elev = np.radians(axes["sun_elevation"]["points"]["values"][0])
    pol = np.radians(np.arange(n_polar) * axes["outgoing_polar"]["points"]["uniform"]["step"])
    az = np.radians(np.arange(n_azimuth) * axes["outgoing_azimuth"]["points"]["uniform"]["step"])
    # Incident direction: travelling from the sun, elevation `elev`, in the plane azimuth 0.
    inc = np.array([-np.cos(elev), 0.0, -np.sin(elev)])
    p, a = np.meshgrid(pol, az, indexing="ij")
    out = np.stack([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)], -1)
    scat = np.degrees(np.arccos(np.clip(out @ inc, -1, 1)))
    return (scat >= 125) & (scat <= 145)


def main():
    t = open_table(sys.argv[1])
    h = t.header
    names = [c["name"] for c in h["channels"]]
    d = np.asarray(t.data, dtype=np.float32).reshape(h["layout"]["shape"])[0, 0, 0]
    ip = d[..., names.index("i_perp")].astype(np.float64)
    ia = d[..., names.index("i_par")].astype(np.float64)
    axes = {a["name"]: a for a in h["axes"]}
    dp = axes["outgoing_polar"]["points"]["uniform"]["step"]
    da = axes["outgoing_azimuth"]["points"]["uniform"]["step"]
    zc = zstandard.ZstdCompressor(level=3)
    four = d[..., [names.index(n) for n in ("phase", "i_perp", "i_par", "dolp")]]
    dense = len(zc.compress(np.ascontiguousarray(four).tobytes()))
    two = len(zc.compress(np.stack([ip, ia], -1).astype(np.float32).tobytes()))
    print(f"entry {ip.shape[0]} x {ip.shape[1]} directions, {dp} x {da} deg")
    print(f"dense f32, 4 channels, zstd 3: {dense / 1e6:.2f} MB; i_perp, i_par only: {two / 1e6:.2f} MB")
    m = (np.roll(ip, 1, 0) + np.roll(ip, -1, 0)) / 2
    print(f"pixel-scale noise (median |x - neighbours' mean| / x): {np.median(np.abs(ip - m) / ip):.4f}")
    window = bow_window(h, *ip.shape)
    phase = (ip + ia) / 2

    def seen(x):
        """What an observer of the sun's 0.5-degree disc sees: a Gaussian of the disc's
        standard deviation, 0.125 degrees, along both axes (azimuth at the bow's polar
        scale, about 1 degree)."""
        return gaussian(gaussian(x, 0.125 / dp, 0, False), 1.0 / da, 1, True)

    seen_phase = seen(phase)

    def errors(a, b):
        dev = (a - b)[window] / b[window]
        l2 = np.sqrt(np.sum((a - b)[window] ** 2) / np.sum(b[window] ** 2))
        return l2, np.median(np.abs(dev)), np.max(np.abs(dev))

    for sp, sa in [(0.0, 0.0), (0.025, 0.2), (0.05, 0.5), (0.1, 1.0)]:
        s_ip = gaussian(gaussian(ip, sp / dp, 0, False), sa / da, 1, True)
        s_ia = gaussian(gaussian(ia, sp / dp, 0, False), sa / da, 1, True)
        s_phase = (s_ip + s_ia) / 2
        l2, med, mx = errors(s_phase, phase)
        sl2, smed, smx = errors(seen(s_phase), seen_phase)
        for rel in (1e-2, 3e-3):
            size = quantised_bytes(s_ip, rel, zc) + quantised_bytes(s_ia, rel, zc)
            print(
                f"smoothing sigma {sp:.3f} deg polar x {sa:.1f} deg azimuth, ln quantised to "
                f"{rel:.0e}: {size / 1e6:.2f} MB ({dense / size:.1f}x); in 125-145 deg against "
                f"dense: L2 {l2:.3f}, median {med:.3f}, max {mx:.2f}; both seen through the "
                f"sun's disc: L2 {sl2:.4f}, median {smed:.4f}, max {smx:.3f}"
            )


if __name__ == "__main__":
    main()
