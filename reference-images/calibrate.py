#!/usr/bin/env python3
"""How far an *independent Mitsuba render* lands from a committed reference, to set test bounds.

usage: calibrate.py SCENE.xml [--spp 64 256] [--seeds 3] [-D name=value ...]

For each spp and each of `--seeds` seeds (1000000 + k, far from the reference's seeds), renders the
scene with Mitsuba (through render.py's code), compares it with reference-images/<name>/<name>.exr
exactly as compare.py does (z with the reference's per-sample variance), and records per run: failing
pixels (Šidák α = 0.01), max |z|, mean z, relMSE, and the same z-test on 4×4-pixel block means.
A correct btfpt render at the same spp should fall in the same ranges (heavy-tailed scenes with
caustics fail some pixels even Mitsuba-vs-Mitsuba). Writes <name>_calibration.json beside the reference.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import compare
import mitsuba_common as mc
import render


def block(a: np.ndarray, b: int = 4) -> np.ndarray:
    h, w = (a.shape[0] // b) * b, (a.shape[1] // b) * b
    return a[:h, :w].reshape(h // b, b, w // b, b, 3).mean((1, 3))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--spp", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    a = ap.parse_args(argv)
    name = mc.scene_name(a.scene)
    ref_dir = mc.HERE / name
    r = compare.read(ref_dir / f"{name}.exr")
    vr = compare.read(ref_dir / f"{name}_var.exr")
    sv = compare.read(ref_dir / f"{name}_sample_var.exr")
    runs = []
    for spp in a.spp:
        for k in range(a.seeds):
            seed = 1_000_000 + 1000 * k
            with tempfile.TemporaryDirectory() as tmp:
                args = [str(a.scene), "--spp", str(spp), "--seed", str(seed), "--out-dir", tmp]
                for d in a.defines:
                    args += ["-D", d]
                render.main(args)
                t = compare.read(Path(tmp) / f"{name}.exr")
            bad, thr, z = compare.ztest(t, sv / spp, r, vr)
            # block means: variance of a block mean = mean of the pixel variances / b²
            bb, bthr, bz = compare.ztest(block(t), block(sv / spp) / 16, block(r), block(vr) / 16)
            run = {
                "spp": spp, "seed": seed,
                "failing_pixels": int(bad.sum()), "pixels": int(bad.size), "z_threshold": round(float(thr), 3),
                "max_abs_z": round(float(np.abs(z).max()), 3), "mean_z": round(float(z.mean()), 5),
                "mean_z_stderr": round(float(1 / np.sqrt(z.size)), 5),
                "relmse": float(np.mean((t - r) ** 2 / (r**2 + 1e-2))),
                "failing_blocks4": int(bb.sum()), "blocks4": int(bb.size),
                "max_abs_z_blocks4": round(float(np.abs(bz).max()), 3),
            }
            print(json.dumps(run), file=sys.stderr)
            runs.append(run)
    out = {"scene": name, "what": __doc__.strip().splitlines()[0], "runs": runs}
    (ref_dir / f"{name}_calibration.json").write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {ref_dir / (name + '_calibration.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
