#!/usr/bin/env python3
"""Render the rainbow of non-spherical raindrops with Mitsuba 3 from a scatterbake 2-D table.

    python3 -m venv venv && venv/bin/pip install mitsuba numpy zstandard
    cargo run --release -p scatterbake-cli -- build manifests/rainbow-raytraced.toml --out out
    venv/bin/python examples/mitsuba/rainbow_2d.py out/tables/raytrace-beard-chuang-1mm.sbt \\
        --out rainbow.png

Scene: the camera stands inside a homogeneous rain volume (a large box, σ_t = ``--sigma-t``
per unit length, albedo 1, phase function ``scatterbake_2d`` of
python/scatterbake/mitsuba_phase.py) and looks at the antisolar side; a ``directional`` sun at
the table's lowest sun elevation (``--sun-elevation-deg`` to choose another) in the +x half
lights it, the drops' axis is the world's z. Integrator ``volpath`` with ``max_depth`` 2
(single scattering, as ``scatterbake render rainbow``; ``--max-depth`` for more). The image is
written as an EXR (linear sRGB) and a PNG (exposure: 99.5th luminance percentile → 0.9, as
``render rainbow``), and the bows are measured along the top of the arch: the radius (deg from
the antisolar point) of the brightest luminance and of each sRGB channel in 36–46° (primary)
and 48–56° (secondary), from the pixels within ``--measure-half-width-deg`` of the image's
vertical centre line.
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
#: Windows (deg from the antisolar point) in which the bows are looked for (as render rainbow).
BOW_WINDOWS = (("primary", 36.0, 46.0), ("secondary", 48.0, 56.0))


def load_plugin():
    """The phase-function module: from the installed ``scatterbake`` package, else this
    checkout's file with the pure-Python reader (python/scatterbake_table.py)."""
    try:
        from scatterbake import mitsuba_phase
    except ImportError:
        for p in (ROOT / "python", ROOT / "python" / "scatterbake"):
            if str(p) not in sys.path:
                sys.path.append(str(p))
        import mitsuba_phase
    return mitsuba_phase


def sun_direction(elevation_deg):
    e = math.radians(elevation_deg)
    return np.array([math.cos(e), 0.0, math.sin(e)])


def view_direction(view_elevation_deg):
    v = math.radians(view_elevation_deg)
    return np.array([-math.cos(v), 0.0, math.sin(v)])


def scene_dict(table, sun_elevation_deg, width, height, fov_deg, view_elevation_deg, spp,
               sigma_t=0.005, box=100.0, max_depth=2, phase_params=None):
    """The Mitsuba scene (a dict for ``mi.load_dict``): camera at the origin inside the rain."""
    import mitsuba as mi

    phase = {"type": "scatterbake_2d", "filename": str(table)}
    phase.update(phase_params or {})
    medium = {
        "type": "homogeneous",
        "albedo": 1.0,
        "sigma_t": sigma_t,
        "phase": phase,
    }
    target = view_direction(view_elevation_deg)
    return {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth},
        "rain": medium,
        "sensor": {
            "type": "perspective",
            "fov": fov_deg,
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[0, 0, 0], target=target.tolist(), up=[0, 0, 1]),
            "medium": {"type": "ref", "id": "rain"},
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "volume": {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().scale(box),
            "bsdf": {"type": "null"},
            "interior": {"type": "ref", "id": "rain"},
        },
        "sun": {
            "type": "directional",
            "direction": (-sun_direction(sun_elevation_deg)).tolist(),
            "irradiance": 1.0,
        },
    }


def pixel_directions(scene):
    """World direction of every pixel centre (height × width × 3), from the sensor itself."""
    import drjit as dr
    import mitsuba as mi

    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    idx = dr.arange(mi.UInt32, w * h)
    pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    d = np.stack([np.array(ray.d.x), np.array(ray.d.y), np.array(ray.d.z)], axis=-1)
    return d.reshape(h, w, 3)


def luminance(rgb):
    """Relative luminance of linear sRGB (IEC 61966-2-1)."""
    return rgb[..., 0] * 0.2126729 + rgb[..., 1] * 0.7151522 + rgb[..., 2] * 0.0721750


def radial_profile(image, directions, sun_elevation_deg, half_width_deg, bin_deg=0.1):
    """Mean linear sRGB per radius bin (deg from the antisolar point) over the pixels within
    ``half_width_deg`` of the vertical plane through the sun (the top of the bows)."""
    anti = -sun_direction(sun_elevation_deg)
    radius = np.degrees(np.arccos(np.clip(directions @ anti, -1.0, 1.0)))
    side = np.degrees(np.abs(np.arcsin(np.clip(directions[..., 1], -1.0, 1.0))))
    keep = side <= half_width_deg
    r = radius[keep]
    rgb = image[keep]
    bins = np.floor(r / bin_deg).astype(int)
    lo, hi = bins.min(), bins.max()
    counts = np.bincount(bins - lo, minlength=hi - lo + 1)
    sums = np.stack([np.bincount(bins - lo, weights=rgb[:, c], minlength=hi - lo + 1)
                     for c in range(3)], axis=-1)
    ok = counts > 0
    centres = (np.arange(lo, hi + 1) + 0.5) * bin_deg
    return centres[ok], sums[ok] / counts[ok, None]


def smooth(values, n=3):
    """Running mean over n bins (reduces Monte Carlo noise before finding maxima)."""
    if n <= 1:
        return values
    k = np.ones(n) / n
    pad = n // 2
    v = np.pad(values, [(pad, pad)] + [(0, 0)] * (values.ndim - 1), mode="edge")
    if values.ndim == 1:
        return np.convolve(v, k, mode="valid")
    return np.stack([np.convolve(v[:, c], k, mode="valid") for c in range(values.shape[1])], -1)


def measure_bows(radii, rgb, smooth_bins=3):
    """Per bow window: the radius of the luminance maximum and of each channel's maximum."""
    y = smooth(luminance(rgb), smooth_bins)
    c = smooth(rgb, smooth_bins)
    out = {}
    for name, lo, hi in BOW_WINDOWS:
        m = (radii >= lo) & (radii <= hi)
        r = radii[m]
        out[name] = {
            "radius_deg": float(r[np.argmax(y[m])]),
            "rgb_deg": [float(r[np.argmax(c[m, k])]) for k in range(3)],
        }
    return out


def to_png(image, path, exposure=None):
    """sRGB 8-bit PNG; exposure by default maps the 99.5th luminance percentile to 0.9."""
    import mitsuba as mi

    if exposure is None:
        y = luminance(image)
        exposure = 0.9 / max(float(np.percentile(y, 99.5)), 1e-30)
    lin = np.clip(image * exposure, 0.0, 1.0)
    enc = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.power(lin, 1 / 2.4) - 0.055)
    bmp = mi.Bitmap(np.ascontiguousarray((enc * 255 + 0.5).astype(np.uint8)))
    bmp.write(str(path))
    return exposure


def render(table, out, sun_elevation_deg=None, width=480, height=320, fov_deg=40.0,
           view_elevation_deg=None, spp=64, variant="llvm_ad_rgb", sigma_t=0.005, max_depth=2,
           phase_params=None, half_width_deg=1.5, seed=0):
    """Render, write ``out`` (.png) and ``out`` with .exr, return (measurements, seconds,
    profile)."""
    import mitsuba as mi

    mi.set_variant(variant)
    plugin = load_plugin()
    plugin.register()
    if sun_elevation_deg is None:
        sun_elevation_deg = lowest_elevation(plugin, table)
    if view_elevation_deg is None:
        view_elevation_deg = 46.0 - sun_elevation_deg
    scene = mi.load_dict(scene_dict(table, sun_elevation_deg, width, height, fov_deg,
                                    view_elevation_deg, spp, sigma_t=sigma_t,
                                    max_depth=max_depth, phase_params=phase_params))
    t0 = time.perf_counter()
    image = np.array(mi.render(scene, seed=seed), dtype=np.float64)
    seconds = time.perf_counter() - t0
    out = pathlib.Path(out)
    mi.Bitmap(image.astype(np.float32)).write(str(out.with_suffix(".exr")))
    to_png(image, out)
    radii, rgb = radial_profile(image, pixel_directions(scene), sun_elevation_deg, half_width_deg)
    return measure_bows(radii, rgb), seconds, (radii, rgb)


def lowest_elevation(plugin, table):
    """The table's lowest sun elevation (deg), as ``render rainbow`` without an elevation."""
    t = plugin._open_table(table)
    return float(np.asarray(t.axis("sun_elevation").coords)[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("table", help="a raytrace-phase-2d table (.sbt)")
    ap.add_argument("--out", default="rainbow-2d.png")
    ap.add_argument("--sun-elevation-deg", type=float)
    ap.add_argument("--view-elevation-deg", type=float)
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--height", type=int, default=320)
    ap.add_argument("--fov-deg", type=float, default=40.0, help="vertical field of view")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--sigma-t", type=float, default=0.005)
    ap.add_argument("--max-depth", type=int, default=2)
    ap.add_argument("--measure-half-width-deg", type=float, default=1.5)
    a = ap.parse_args()
    m, seconds, _ = render(a.table, a.out, a.sun_elevation_deg, a.width, a.height, a.fov_deg,
                           a.view_elevation_deg, a.spp, a.variant, a.sigma_t, a.max_depth,
                           half_width_deg=a.measure_half_width_deg)
    print(f"rendered {a.out} ({a.width}x{a.height}, {a.spp} spp, {a.variant}) in {seconds:.1f} s")
    for name, b in m.items():
        r, g, bl = b["rgb_deg"]
        print(f"{name} bow (top of the arch): radius {b['radius_deg']:.2f} deg "
              f"(R {r:.2f}, G {g:.2f}, B {bl:.2f})")


if __name__ == "__main__":
    main()
