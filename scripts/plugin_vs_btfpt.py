#!/usr/bin/env python3
"""Same image, two renderers, same material: Mitsuba 3 renders a scene with a fitted .plmc through
btfpt's plugin (btfpt.mitsuba), btfpt renders it itself, and `btfpt compare` tests the two within
both renders' noise (Mitsuba's variance of the mean from independent passes, btfpt's from
`render --variance`). Prints compare's report; writes mitsuba.exr, mitsuba_var.exr, btfpt.exr,
btfpt_var.exr and compare.json into --out. Exit status: compare's.

usage: scripts/plugin_vs_btfpt.py SCENE.xml --plmc MODEL.plmc [-D name=value ...]
           [--passes 8] [--spp 16] [--btfpt-spp 256] [--out DIR] [--btfpt target/release/btfpt]

Run it with a Python that has mitsuba==3.9.1 and the btfpt module (see bench_mitsuba_plugin.py).
The scene takes the material's file through the define `btf` (as scenes/btf-plane/scene.xml).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--plmc", required=True, type=Path)
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--passes", type=int, default=8, help="independent Mitsuba renders averaged")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel of each Mitsuba pass")
    ap.add_argument("--btfpt-spp", type=int, default=256)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", type=Path, default=Path("plugin_vs_btfpt"))
    ap.add_argument("--btfpt", type=Path, default=REPO / "target" / "release" / "btfpt")
    args = ap.parse_args()
    if args.passes < 2:
        ap.error("--passes must be at least 2 (the variance of the mean needs two)")
    for p, what in [(args.scene, "scene"), (args.plmc, "model"), (args.btfpt, "btfpt binary")]:
        if not p.exists():
            sys.exit(f"{p}: {what} not found")
    import mitsuba as mi

    mi.set_variant(args.variant)
    import btfpt.mitsuba

    btfpt.mitsuba.register()
    defines = dict(d.split("=", 1) for d in args.defines)
    defines["btf"] = str(args.plmc.resolve())
    scene = mi.load_file(str(args.scene), **defines)
    imgs = np.stack([np.array(mi.render(scene, seed=1000 + p, spp=args.spp)) for p in range(args.passes)])
    args.out.mkdir(parents=True, exist_ok=True)

    def write(name, a):
        mi.Bitmap(np.ascontiguousarray(a, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(
            str(args.out / name))

    write("mitsuba.exr", imgs.mean(0))
    write("mitsuba_var.exr", imgs.var(0, ddof=1) / args.passes)
    d = [a for k, v in defines.items() for a in ("-D", f"{k}={v}")]
    subprocess.run([str(args.btfpt), "render", str(args.scene), *d, "--spp", str(args.btfpt_spp),
                    "-o", str(args.out / "btfpt.exr"), "--variance", str(args.out / "btfpt_var.exr")],
                   check=True, capture_output=True)
    r = subprocess.run([str(args.btfpt), "compare", str(args.out / "mitsuba.exr"), str(args.out / "btfpt.exr"),
                        "--test-variance", str(args.out / "mitsuba_var.exr"),
                        "--variance", str(args.out / "btfpt_var.exr"), "--json", str(args.out / "compare.json")],
                       capture_output=True, text=True)
    print(f"Mitsuba {args.variant} through btfpt.mitsuba ({args.passes} × {args.spp} spp) vs btfpt "
          f"({args.btfpt_spp} spp), {args.scene}, {args.plmc}:")
    print(r.stdout, r.stderr, sep="")
    return r.returncode


if __name__ == "__main__":
    sys.exit(main())
