#!/usr/bin/env python3
"""Render the exported scene with Mitsuba 3 and compare it with our frame (written by `demo --export DIR`).

    pip install mitsuba                       # Mitsuba 3 (tested with 3.9.1, drjit 1.5.0)
    python3 render.py --spp 4096              # in DIR: writes mitsuba.exr, prints the comparison with engine.exr

Materials are our exact BRDFs (ours_bsdf.py, plugin `ours`) unless the scene was exported with
`--export-bsdf builtin`. By default every pixel is estimated at its centre, as our G-buffer shades it (no
antialiasing; `--film` renders with Mitsuba's film instead: box-filtered pixels, which differ from ours along
every silhouette). Needs a JIT variant (llvm_ad_rgb, the default where LLVM is installed, or cuda_ad_rgb) for
the pixel-centre mode; scalar_rgb renders with the film (slow: the plugin is called from Python per ray).
Mitsuba >= 3.6 (drjit 1.x) needs LLVM >= 16 for llvm_ad_rgb (with LLVM 15 it aborts in code generation); with an
older LLVM use `--variant scalar_rgb`, `cuda_ad_rgb`, or `pip install mitsuba==3.5.2` (drjit 0.4.6 works with 15).

The comparison is the relative RMSE sqrt(sum (m - e)^2 / sum e^2) over RGB of the covered pixels (a Mitsuba
camera ray through the pixel centre hits a mesh; the background shows the environment, interpolated
differently), over all of them, those where the shading and the geometric normal agree on the viewer's side, the interior ones (also all 8
neighbours see the same shape) and per shape, raw and with Mitsuba's own noise removed (its per-pixel sample
variance / spp; pass `--engine-rel-stderr` with the relative standard error `demo --spp` printed to remove
ours as well).
"""

import argparse
import os
import sys
import time

import numpy as np


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=os.path.join(here, "scene.xml"))
    ap.add_argument("--spp", type=int, default=1024, help="samples per pixel (default 1024)")
    ap.add_argument("--variant", default=None, help="Mitsuba variant (default: llvm_ad_rgb if available, else "
                    "scalar_rgb)")
    ap.add_argument("--film", action="store_true", help="render through Mitsuba's film (box-filtered pixels)")
    ap.add_argument("--batch", type=int, default=1 << 22, help="most samples per JIT launch (default 2^22)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=os.path.join(here, "mitsuba.exr"))
    ap.add_argument("--engine", default=os.path.join(here, "engine.exr"), help="our frame to compare with")
    ap.add_argument("--engine-rel-stderr", type=float, default=0.0,
                    help="relative standard error of our frame (printed by demo --spp), removed as noise")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    variant = a.variant
    if variant is None:
        variant = "llvm_ad_rgb" if "llvm_ad_rgb" in mi.variants() and llvm_works() else "scalar_rgb"
        if variant == "scalar_rgb":
            print("llvm_ad_rgb does not work here (no LLVM, or one too old for this drjit); using scalar_rgb",
                  file=sys.stderr)
    mi.set_variant(variant)
    jit = not variant.startswith("scalar")
    sys.path.insert(0, here)
    import ours_bsdf  # noqa: F401  (registers the plugin `ours`)

    scene = mi.load_file(a.scene)
    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    t0 = time.time()
    if a.film or not jit:
        if not jit and not a.film:
            print("scalar variant: rendering through the film (the pixel-centre mode needs a JIT variant)",
                  file=sys.stderr)
        img = np.array(mi.render(scene, spp=a.spp, seed=a.seed), dtype=np.float64)[:, :, :3]
        var = None
    else:
        img, var = render_pixel_centres(mi, dr, scene, sensor, w, h, a.spp, a.batch, a.seed)
    print(f"rendered {w}x{h} at {a.spp} spp with {variant} in {time.time() - t0:.1f} s")
    mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(a.out)
    print(f"wrote {a.out}")

    if not os.path.exists(a.engine):
        print(f"{a.engine} not found: nothing to compare")
        return
    eng = np.array(mi.Bitmap(a.engine), dtype=np.float64)
    if eng.shape[:2] != (h, w):
        sys.exit(f"{a.engine} is {eng.shape[1]}x{eng.shape[0]}, the scene {w}x{h}")
    eng = eng[:, :, :3]
    shape_index, names, flipped = covered_shapes(mi, dr, scene, sensor, w, h, jit)
    covered = shape_index >= 0
    print(f"covered pixels: {covered.sum()} of {w * h}; {flipped.sum()} of them with the interpolated normal facing "
          "away from the camera while the triangle faces it (ours bends that normal toward the viewer, Mitsuba "
          "does not: such a pixel is about 0 in Mitsuba)")
    # Interior: the pixel and its 8 neighbours see the same shape (silhouettes are where the two renderers'
    # geometry handling differs most: shading-normal treatment, ray offsets).
    pad = np.pad(shape_index, 1, constant_values=-2)
    same = np.ones_like(covered)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            same &= pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] == shape_index
    interior = covered & same & ~flipped
    regions = [("all covered", covered), ("normals agree", covered & ~flipped), ("interior", interior)]
    for i, n in enumerate(names):
        if (shape_index == i).any():
            regions += [(n, (shape_index == i) & ~flipped), (n + " interior", interior & (shape_index == i))]
    for name, mask in regions:
        d2 = ((img - eng) ** 2)[mask].sum()
        e2 = (eng ** 2)[mask].sum()
        if not mask.any() or e2 <= 0.0:
            continue
        line = f"{name:>24}: {mask.sum():6d} px, relative RMSE {100 * np.sqrt(d2 / e2):7.3f} %"
        if var is not None:
            noise = var[mask].sum() + (a.engine_rel_stderr ** 2) * e2
            line += (f", Mitsuba noise {100 * np.sqrt(var[mask].sum() / e2):6.3f} %, noise removed "
                     f"{100 * np.sqrt(max(d2 - noise, 0.0) / e2):7.3f} %")
        print(line)


def llvm_works():
    """Whether llvm_ad_rgb compiles a kernel, tried in a child process: drjit aborts the whole process when the
    installed LLVM cannot generate its code (drjit 1.x with LLVM 15: `Cannot select: fmaximum`)."""
    import subprocess
    probe = ("import mitsuba as mi, drjit as dr; mi.set_variant('llvm_ad_rgb'); "
             "x = dr.maximum(dr.arange(mi.Float, 16), 1.5); dr.eval(x); print(float(dr.sum(x)[0] "
             "if hasattr(dr.sum(x), '__getitem__') else dr.sum(x)))")
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    return r.returncode == 0


def render_pixel_centres(mi, dr, scene, sensor, w, h, spp, batch, seed):
    """Per pixel the mean of `spp` estimates of the scene's integrator along the ray through the pixel centre,
    and the variance of that mean (sample variance / spp), both (h, w, 3)."""
    integrator = scene.integrator()
    per = max(1, min(spp, batch // (w * h)))
    total = np.zeros((h * w, 3))
    total2 = np.zeros((h * w, 3))
    done, k = 0, 0
    while done < spp:
        n = min(per, spp - done)
        count = w * h * n
        idx = dr.arange(mi.UInt32, count)
        pix = idx // n
        x, y = pix % w, pix // w
        pos = mi.Point2f((mi.Float(x) + 0.5) / w, (mi.Float(y) + 0.5) / h)
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(seed * 1_000_003 + k, count)
        ray, weight = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
        L, _, _ = integrator.sample(scene, sampler, ray, None, True)
        L = L * weight
        v = np.stack([np.array(L.x), np.array(L.y), np.array(L.z)], axis=-1).astype(np.float64)
        v = np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0).reshape(w * h, n, 3)
        total += v.sum(axis=1)
        total2 += (v ** 2).sum(axis=1)
        done += n
        k += 1
    mean = total / spp
    var = np.maximum(total2 / spp - mean ** 2, 0.0) * spp / max(spp - 1, 1) / spp
    return mean.reshape(h, w, 3), var.reshape(h, w, 3)


def covered_shapes(mi, dr, scene, sensor, w, h, jit):
    """Per pixel the index of the non-emitting shape the pixel-centre ray hits (-1: none), the shape names, and
    per pixel whether the view is on different sides of the shading and the geometric normal there."""
    shapes = [s for s in scene.shapes() if not s.is_emitter()]
    names = [s.id() or f"shape{i}" for i, s in enumerate(shapes)]
    out = np.full(w * h, -1, dtype=np.int64)
    flipped = np.zeros(w * h, dtype=bool)
    if jit:
        idx = dr.arange(mi.UInt32, w * h)
        pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
        ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
        si = scene.ray_intersect(ray)
        valid = np.array(si.is_valid())
        flipped = valid & ((np.array(si.wi.z) > 0.0) != (np.array(dr.dot(si.n, -ray.d)) > 0.0))
        for i, s in enumerate(shapes):
            # drjit < 1.0 compares arrays elementwise with dr.eq (its `==` compares the objects).
            eq = dr.eq(si.shape, mi.ShapePtr(s)) if hasattr(dr, "eq") else si.shape == mi.ShapePtr(s)
            hit = np.array(eq) & valid
            out[hit] = i
    else:
        for p in range(w * h):
            pos = mi.Point2f((p % w + 0.5) / w, (p // w + 0.5) / h)
            ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
            si = scene.ray_intersect(ray)
            if si.is_valid():
                flipped[p] = (si.wi.z > 0.0) != (dr.dot(si.n, -ray.d) > 0.0)
                hit_id = si.shape.id()  # (by id: the Python wrappers of one shape need not compare equal)
                for i, s in enumerate(shapes):
                    if s.id() == hit_id:
                        out[p] = i
    return out.reshape(h, w), names, flipped.reshape(h, w)


if __name__ == "__main__":
    main()
