#!/usr/bin/env python3
"""Why the bias test weighs a pixel by its neighbours' variance (docs/model.md, "The bias test and a
skewed reference"): correct 64-spp renders, by Mitsuba and by btfpt, against a committed reference,
scored by the bias test's statistic with two weightings.

usage: bias_weights.py [SCENE.xml] [--seeds 8] [--spp 64] [--ref2-spp 4096] [--btfpt target/release/btfpt]

  own        w = 1/sigma of the pixel's own predicted variance (the reference's sample variance):
             correlated with the reference's own error where the samples are skewed
  neighbours w = 1/sigma of the mean predicted variance of the 8 neighbours (btfpt's test)
  ref2       w = 1/sigma of an independent Mitsuba reference's predicted variance (a check)

Prints the bias z of every render under each weighting, and the mean of w_own * (ref2 - ref): the
shift the committed reference's own error makes. Renders in a temporary folder; writes nothing else.
Run with the venv's Python (reference-images/setup.sh).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import compare
import mitsuba_common as mc
import render


def neighbour_mean(v: np.ndarray) -> np.ndarray:
    """Mean of the 8 neighbours inside the image, per channel (the pixel itself left out)."""
    h, w, _ = v.shape
    p = np.pad(v, ((1, 1), (1, 1), (0, 0)))
    c = np.pad(np.ones_like(v), ((1, 1), (1, 1), (0, 0)))
    s = sum(p[1 + i:1 + i + h, 1 + j:1 + j + w] for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0))
    n = sum(c[1 + i:1 + i + h, 1 + j:1 + j + w] for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0))
    return s / n


def inv_sigma(v: np.ndarray) -> np.ndarray:
    return np.where(v > 0, 1 / np.sqrt(np.where(v > 0, v, 1)), 0.0)


def bias_z(t: np.ndarray, r: np.ndarray, w: np.ndarray) -> float:
    u = (w * (t - r)).mean(-1).ravel()
    return float(u.mean() / (u.std(ddof=1) / np.sqrt(u.size)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path, nargs="?", default=mc.HERE.parent / "scenes/mitsuba-bsdfs/scene.xml")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref2-spp", type=int, default=4096)
    ap.add_argument("--btfpt", type=Path, default=mc.HERE.parent / "target/release/btfpt")
    a = ap.parse_args(argv)
    name = mc.scene_name(a.scene)
    ref = mc.HERE / name / name
    r = compare.read(Path(f"{ref}.exr")).astype(np.float64)
    sv = compare.read(Path(f"{ref}_sample_var.exr")).astype(np.float64)
    vr = compare.read(Path(f"{ref}_var.exr")).astype(np.float64)
    var = np.where(sv > 0, np.maximum(sv, 1e-4) / a.spp, 0) + vr
    weights = {"own": inv_sigma(var), "neighbours": inv_sigma(neighbour_mean(var))}
    with tempfile.TemporaryDirectory() as tmp:
        render.main([str(a.scene), "--spp", str(a.ref2_spp), "--seed", "5000000", "--out-dir", f"{tmp}/ref2"])
        r2 = compare.read(Path(f"{tmp}/ref2/{name}.exr")).astype(np.float64)
        sv2 = compare.read(Path(f"{tmp}/ref2/{name}_sample_var.exr")).astype(np.float64)
        weights["ref2"] = inv_sigma(np.where(sv2 > 0, np.maximum(sv2, 1e-4) / a.spp, 0) + sv2 / a.ref2_spp)
        u = (weights["own"] * (r2 - r)).mean(-1)
        print(f"mean w_own*(ref2 - ref) = {u.mean():+.4f} (the committed reference's own shift)")
        renders = {"mitsuba": [], "btfpt": []}
        for k in range(1, a.seeds + 1):
            d = f"{tmp}/m{k}"
            render.main([str(a.scene), "--spp", str(a.spp), "--seed", str(2_000_000 + 1000 * k), "--out-dir", d])
            renders["mitsuba"].append(compare.read(Path(f"{d}/{name}.exr")).astype(np.float64))
            out = f"{tmp}/b{k}.exr"
            subprocess.run([str(a.btfpt), "render", str(a.scene), "--spp", str(a.spp), "--seed", str(k), "-o", out],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            renders["btfpt"].append(compare.read(Path(out)).astype(np.float64))
    for who, ts in renders.items():
        for wname, w in weights.items():
            zs = [bias_z(t, r, w) for t in ts]
            print(f"{who:8s} {wname:10s} bias z: " + " ".join(f"{z:+.2f}" for z in zs)
                  + f"   (|z| > 3.09: {sum(abs(z) > 3.09 for z in zs)} of {len(zs)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
