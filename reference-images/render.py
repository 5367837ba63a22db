#!/usr/bin/env python3
"""Renders a Mitsuba 3 reference image and its per-pixel variance (for the z-test in btfpt).

usage: render.py SCENE.xml [--spp N] [-D name=value ...] [--out-dir DIR] [--seed S]

Writes into reference-images/<scene-name>/ (scene-name: the scene's folder name, plus "-<stem>"
when the file is not called scene.xml):
  <name>.exr      mean radiance, float32 linear RGB (box filter, N samples per pixel)
  <name>_var.exr  per-pixel, per-channel variance of that mean, float32
                  (= unbiased sample variance of the N per-pixel samples / N)
  <name>_sample_var.exr  the per-sample variance itself (= <name>_var · N), float32: the variance
                  of a test render's mean at n spp is predicted as sample_var / n (robust z-test)
  <name>.png      sRGB preview
  <name>.json     how it was made: scene, defines, spp, passes, seeds, Mitsuba version, timing,
                  and a consistency check of the variance estimate.

The N samples are taken in passes of independent seeds (seed S + pass index) so that a pass fits
in memory. Every camera sample is recorded with its square through a thin wrapper integrator,
so the variance is the exact per-sample RGB second moment (each sample lands in exactly one pixel
with the box filter); the across-pass variance is written to the JSON as a cross-check.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import mitsuba_common as mc
import mitsuba as mi
import drjit as dr

MAX_LANES = 1 << 21  # samples per pass (memory of one LLVM wavefront)


def make_moment_integrator(nested):
    """A SamplingIntegrator returning the nested integrator's radiance plus its RGB square as AOVs."""

    class RgbMoment(mi.SamplingIntegrator):
        def __init__(self, props=mi.Properties()):
            super().__init__(props)
            self.nested = nested

        def aov_names(self):
            return ["m2.R", "m2.G", "m2.B"]

        def sample(self, scene, sampler, ray, medium=None, active=True):
            L, valid, _ = self.nested.sample(scene, sampler, ray, medium, active)
            L = mi.Color3f(L)
            return L, valid, [L.x * L.x, L.y * L.y, L.z * L.z]

        def to_string(self):
            return f"RgbMoment[{self.nested}]"

    return RgbMoment()


def write_exr(path: Path, arr: np.ndarray) -> None:
    bmp = mi.Bitmap(np.ascontiguousarray(arr, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.write(str(path))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--spp", type=int, default=4096, help="total samples per pixel (default 4096)")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--out-dir", type=Path, help="default: reference-images/<scene-name>/")
    ap.add_argument("--name", help="output base name (default: scene name)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first pass (default 0)")
    ap.add_argument("--variant", default=mc.VARIANT)
    args = ap.parse_args(argv)
    if args.spp < 2:
        ap.error("--spp must be at least 2 (the variance needs two samples)")

    defines = mc.parse_defines(args.defines)
    mc.set_variant(args.variant)
    name = args.name or mc.scene_name(args.scene)
    out_dir = args.out_dir or (mc.HERE / name)
    out_dir.mkdir(parents=True, exist_ok=True)

    scene = mc.load_scene(args.scene, defines)
    sensor = scene.sensors()[0]
    size = sensor.film().crop_size()
    pixels = int(size[0]) * int(size[1])
    spp_pass = max(1, min(args.spp, MAX_LANES // pixels))
    passes = math.ceil(args.spp / spp_pass)
    integrator = make_moment_integrator(scene.integrator())

    s1 = np.zeros((int(size[1]), int(size[0]), 3))
    s2 = np.zeros_like(s1)
    pass_means, pass_counts = [], []
    done = 0
    t0 = time.perf_counter()
    for p in range(passes):
        n = min(spp_pass, args.spp - done)
        img = mi.render(scene, sensor=sensor, integrator=integrator, spp=n, seed=args.seed + p)
        a = np.array(img, dtype=np.float64)
        if a.shape[2] != 6:
            sys.exit(f"unexpected film channel count {a.shape[2]} (expected RGB + 3 moment AOVs)")
        s1 += a[..., :3] * n
        s2 += a[..., 3:6] * n
        pass_means.append(a[..., :3])
        pass_counts.append(n)
        done += n
        el = time.perf_counter() - t0
        print(f"\r{name}: pass {p + 1}/{passes}, {done}/{args.spp} spp, {el:.0f} s", end="", file=sys.stderr)
    print(file=sys.stderr)
    wall = time.perf_counter() - t0

    N = float(done)
    mean = s1 / N
    var_sample = np.maximum(s2 / N - mean * mean, 0.0) * N / (N - 1.0)
    var_mean = var_sample / N
    bad = ~np.isfinite(mean).all(-1)
    if bad.any():
        print(f"warning: {int(bad.sum())} pixels are not finite", file=sys.stderr)

    # cross-check: variance of the mean from the spread of the pass means (equal-size passes only)
    check = None
    full = [m for m, c in zip(pass_means, pass_counts) if c == spp_pass]
    if len(full) >= 4:
        pm = np.stack(full)
        var_between = pm.var(0, ddof=1) / len(full) * (len(full) * spp_pass / N)
        ok = var_mean > 1e-12
        ratio = var_between[ok] / var_mean[ok]
        check = {
            "passes_used": len(full),
            "median_ratio_between_over_moment": float(np.median(ratio)),
            "mean_ratio_between_over_moment": float(np.mean(ratio)),
            "expected": "about 1 (the ratio's spread follows chi^2 with passes-1 dof)",
        }

    write_exr(out_dir / f"{name}.exr", mean)
    write_exr(out_dir / f"{name}_var.exr", var_mean)
    write_exr(out_dir / f"{name}_sample_var.exr", var_sample)
    mi.util.write_bitmap(str(out_dir / f"{name}.png"), mi.TensorXf(mean.astype(np.float32)))
    try:
        scene_rel = str(args.scene.resolve().relative_to(mc.HERE.parent))
    except ValueError:
        scene_rel = str(args.scene)
    meta = {
        "scene": scene_rel,
        "defines": defines,
        "spp": done,
        "passes": passes,
        "spp_per_pass": spp_pass,
        "seeds": [args.seed, args.seed + passes - 1],
        "width": int(size[0]),
        "height": int(size[1]),
        "mitsuba": mi.__version__,
        "drjit": dr.__version__,
        "variant": mi.variant(),
        "wall_seconds": round(wall, 2),
        "mean_rgb": [float(x) for x in mean.mean((0, 1))],
        "nonfinite_pixels": int(bad.sum()),
        "variance": "per-pixel variance of the mean (sample variance / spp), float32 EXR",
        "variance_check": check,
    }
    (out_dir / f"{name}.json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {out_dir}/{name}.exr, {name}_var.exr ({done} spp, {wall:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
