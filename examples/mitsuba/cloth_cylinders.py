#!/usr/bin/env python3
"""Render cloth-covered cylinders with Mitsuba 3 from scatterbake cloth tables (``cloth-brdf/2``).

    python3 -m venv venv && venv/bin/pip install ./python mitsuba
    scatterbake build manifests/cloth.toml --out out
    venv/bin/python examples/mitsuba/cloth_cylinders.py \\
        out/cloth-linen-plain.sbt out/cloth-polyester-satin-front.sbt --out cloth.png

Scene: one vertical cylinder (axis along the world's y, radius 1, longer than the view) per
(table, warp angle), side by side along x, covered by the BSDF ``scatterbake_cloth`` of
python/scatterbake/mitsuba_cloth.py; an orthographic camera on the +z axis looks down −z, so
every image row crosses the cylinders at the same height and sees the same normals; a
``directional`` light from ``--light`` (the direction toward the light) with irradiance 1.
Integrator ``direct``. The shading tangent of Mitsuba's cylinder (dp/du) runs around the
circumference, so warp angle 0° lays the warp around the cylinder and 90° along its axis. The
image is written as a PNG (the 99.5th luminance percentile → 0.9) and, with ``--exr``, as an EXR
(linear, pixel = radiance f·cos θ_light for irradiance 1), and the highlights of each cylinder
are measured on the middle row: the pixel columns of the local luminance maxima (at least 0.3 ×
the cylinder's maximum and 0.05 × it above their surroundings, where the view and the light are
within 70° of the normal), refined by a parabola through the neighbours.
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
#: Direction toward the light (world): 50° from the camera axis in the x-z plane, tilted 20° up.
DEFAULT_LIGHT = (math.sin(math.radians(50)) * math.cos(math.radians(20)),
                 math.sin(math.radians(20)),
                 math.cos(math.radians(50)) * math.cos(math.radians(20)))
#: Centre distance of neighbouring cylinders (radius 1).
SPACING = 2.2


def load_plugin():
    """The BSDF module: from the installed ``scatterbake`` package, else this checkout's file
    with the pure-Python reader (python/scatterbake_table.py)."""
    try:
        from scatterbake import mitsuba_cloth
    except ImportError:
        for p in (ROOT / "python", ROOT / "python" / "scatterbake"):
            if str(p) not in sys.path:
                sys.path.append(str(p))
        import mitsuba_cloth
    return mitsuba_cloth


def centres(count):
    """x of each cylinder's axis."""
    return [(k - 0.5 * (count - 1)) * SPACING for k in range(count)]


def scene_dict(cylinders, width, height, light, spp):
    """The scene (a dict for ``mi.load_dict``); ``cylinders``: list of (table, warp_angle_deg)."""
    import mitsuba as mi

    half_width = 0.5 * SPACING * len(cylinders)
    scene = {
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0],
                                                       up=[0, 1, 0])
            @ mi.ScalarTransform4f().scale([half_width, half_width, 1.0]),
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": {"type": "directional", "direction": [-x for x in light], "irradiance": 1.0},
    }
    for k, ((table, warp), x) in enumerate(zip(cylinders, centres(len(cylinders)))):
        scene[f"cloth{k}"] = {
            "type": "cylinder", "p0": [x, -10.0, 0.0], "p1": [x, 10.0, 0.0], "radius": 1.0,
            "bsdf": {"type": "scatterbake_cloth", "filename": str(table),
                     "warp_angle_deg": float(warp)},
        }
    return scene


def middle_row_hits(scene, sub=1):
    """Per point of the middle row (``sub`` evenly spaced points across each pixel, pixel-major):
    hit mask, world x of the hit, the shading frame (s, t, n, world, as N × 3 arrays) and the
    local direction toward the camera, from Mitsuba's own rays and intersections."""
    import drjit as dr
    import mitsuba as mi

    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    k = np.arange(w * sub)
    pos = mi.Point2f(mi.Float((k // sub + (k % sub + 0.5) / sub) / w),
                     dr.full(mi.Float, (h // 2 + 0.5) / h, w * sub))
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(ray)
    a = lambda v: np.stack([np.array(v.x), np.array(v.y), np.array(v.z)], -1)  # noqa: E731
    f = si.sh_frame
    return {"valid": np.array(si.is_valid()), "x": np.array(si.p.x), "s": a(f.s), "t": a(f.t),
            "n": a(f.n), "wi": a(si.wi)}


def to_local(hits, world):
    v = np.asarray(world, dtype=float)
    return np.stack([hits[k] @ v for k in ("s", "t", "n")], -1)


def angles_deg(local, warp_angle_deg):
    """(θ, φ) in degrees of local directions in the cloth frame (φ from the warp)."""
    theta = np.degrees(np.arctan2(np.hypot(local[:, 0], local[:, 1]), local[:, 2]))
    phi = np.degrees(np.arctan2(local[:, 1], local[:, 0])) - warp_angle_deg
    return theta, phi


def luminance(rgb):
    """Rec. 709 luminance of linear RGB (the tables' sampling weight)."""
    rgb = np.asarray(rgb)
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]


def regions(hits, count, light, max_deg=70.0):
    """Pixel mask of each cylinder on the middle row where both the view and the light are at
    most ``max_deg`` from the normal: away from the silhouette (partly background pixels) and
    from grazing light, where the model's albedo grows like 1/cos θ_i and the 5° tables' last
    θ cell holds it only coarsely."""
    c = math.cos(math.radians(max_deg))
    inner = hits["valid"] & (hits["wi"][:, 2] >= c) & (to_local(hits, light)[:, 2] >= c)
    return [inner & (np.abs(hits["x"] - x) < 1.0) for x in centres(count)]


def highlights(y, mask, rel=0.3, prominence=0.05):
    """Sub-pixel columns of the local maxima of y inside mask that reach ``rel`` × its maximum
    and stand ``prominence`` × its maximum above the higher of the two lowest points between
    them and the next higher value on either side (so that ripples on a plateau do not count);
    each refined by a parabola through its neighbours."""
    idx = np.flatnonzero(mask)
    v = y[idx]
    top = v.max()
    out = []
    for j in range(1, len(v) - 1):
        if not (v[j] > v[j - 1] and v[j] >= v[j + 1] and v[j] >= rel * top):
            continue
        bases = []
        for side in (v[j::-1], v[j:]):
            higher = np.flatnonzero(side > v[j])
            stop = higher[0] if len(higher) else len(side)
            bases.append(side[:stop].min())
        if v[j] - max(bases) < prominence * top:
            continue
        a, b, c = v[j - 1], v[j], v[j + 1]
        den = a - 2 * b + c
        out.append(idx[j] + (0.5 * (a - c) / den if den < 0 else 0.0))
    return out


def to_png(image, path, exposure=None):
    """sRGB 8-bit PNG; exposure by default maps the 99.5th luminance percentile to 0.9."""
    import mitsuba as mi

    if exposure is None:
        exposure = 0.9 / max(float(np.percentile(luminance(image), 99.5)), 1e-30)
    lin = np.clip(image * exposure, 0.0, 1.0)
    enc = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.power(lin, 1 / 2.4) - 0.055)
    mi.Bitmap(np.ascontiguousarray((enc * 255 + 0.5).astype(np.uint8))).write(str(path))
    return exposure


def render(cylinders, out=None, width=64, height=32, light=DEFAULT_LIGHT, spp=4,
           variant="llvm_ad_rgb", seed=0, exr=False):
    """Render; write ``out`` (.png) when given, and with ``exr`` the linear image beside it.
    Returns (image, seconds, scene)."""
    import mitsuba as mi

    mi.set_variant(variant)
    load_plugin().register()
    light = np.asarray(light, dtype=float)
    light = light / np.linalg.norm(light)
    scene = mi.load_dict(scene_dict(cylinders, width, height, light.tolist(), spp))
    t0 = time.perf_counter()
    image = np.array(mi.render(scene, seed=seed, spp=spp), dtype=float)
    seconds = time.perf_counter() - t0
    if out is not None:
        out = pathlib.Path(out)
        if exr:
            mi.Bitmap(image.astype(np.float32)).write(str(out.with_suffix(".exr")))
        to_png(image, out)
    return image, seconds, scene


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tables", nargs="+", type=pathlib.Path)
    ap.add_argument("--warp-angle-deg", type=float, nargs="+", default=[0.0, 90.0])
    ap.add_argument("--light", type=float, nargs=3, default=DEFAULT_LIGHT)
    ap.add_argument("--width", type=int, default=512)
    ap.add_argument("--height", type=int, default=192)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("cloth.png"))
    ap.add_argument("--exr", action="store_true", help="also write the linear image (.exr)")
    a = ap.parse_args(argv)
    cylinders = [(t, w) for t in a.tables for w in a.warp_angle_deg]
    image, seconds, scene = render(cylinders, a.out, a.width, a.height, a.light, a.spp, a.variant,
                                   exr=a.exr)
    hits = middle_row_hits(scene)
    y = luminance(image[a.height // 2])
    light = np.asarray(a.light) / np.linalg.norm(a.light)
    for (table, warp), mask in zip(cylinders, regions(hits, len(cylinders), light)):
        cols = ", ".join(f"{c:.2f}" for c in highlights(y, mask))
        print(f"{table.name} warp {warp:g} deg: highlights at columns {cols}")
    print(f"rendered {a.width}x{a.height}, {a.spp} spp in {seconds:.2f} s -> {a.out}")


if __name__ == "__main__":
    main()
