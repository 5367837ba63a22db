#!/usr/bin/env python3
"""Mitsuba 3 rendering one BTF scene two ways, each in a process of its own: through btfpt's
plugin on a fitted .plmc model (btfpt.mitsuba) and through the raw-BTF plugin of
reference-images/ (btf_plugin.py) on the measured data. Prints, per way and run, the process's
CPU seconds (user + sys, from the kernel's accounting of the finished child), its peak resident
memory, the wall time of loading and of rendering, and the medians and the raw/plmc ratios.

usage: scripts/bench_mitsuba_plugin.py SCENE.xml --raw DATA --plmc MODEL.plmc --spp N
           [-D name=value ...] [--runs 3] [--pass-spp K] [--variant llvm_ad_rgb] [--out DIR]

Run it with a Python that has mitsuba==3.9.1 and the btfpt module (python/ci.sh makes one in
target/ci-pyvenv; or reference-images/.venv/bin/python with PYTHONPATH=python after
`maturin develop`). The scene takes the material's file through the define `btf` (as
scenes/btf-plane/scene.xml). --out writes each way's last image as EXR. For example:

    btfpt synth corduroy --size 32 --seed 1 --format exr -o /tmp/cord32
    btfpt fit /tmp/cord32 -o /tmp/cord32.plmc
    target/ci-pyvenv/bin/python scripts/bench_mitsuba_plugin.py scenes/btf-plane/scene.xml \\
        --raw /tmp/cord32 --plmc /tmp/cord32.plmc --spp 64
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def child(args) -> None:
    """One render in this process: prints a JSON line with the load and render wall times."""
    t0 = time.perf_counter()
    import mitsuba as mi
    import drjit as dr

    mi.set_variant(args.variant)
    if args.child == "plmc":
        import btfpt.mitsuba

        btfpt.mitsuba.register()
        material = args.plmc
    else:
        sys.path.insert(0, str(REPO / "reference-images"))
        import btf_plugin

        btf_plugin.register()
        material = args.raw
    defines = dict(d.split("=", 1) for d in args.defines)
    defines["btf"] = str(Path(material).resolve())
    t1 = time.perf_counter()
    scene = mi.load_file(str(args.scene), **defines)
    t2 = time.perf_counter()
    # In passes of --pass-spp (the estimator of one render at --spp, as Mitsuba's
    # samples_per_pass): the plugin's wavefront, and so its memory, scales with the pass.
    passes = max(1, args.spp // args.pass_spp) if args.pass_spp else 1
    img = None
    for p in range(passes):
        part = mi.render(scene, spp=args.spp // passes, seed=args.seed + p * 7919)
        img = part if img is None else img + part
        dr.eval(img)
    img = img / passes
    dr.eval(img)
    dr.sync_thread()
    t3 = time.perf_counter()
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        mi.Bitmap(img).write(str(Path(args.out) / f"{args.child}.exr"))
    print(json.dumps({"import": t1 - t0, "load": t2 - t1, "render": t3 - t2}))


def run_child(argv: list[str], way: str) -> dict:
    """Runs this script as a child for `way`: its report, CPU seconds and peak memory (wait4)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen([sys.executable, __file__, *argv, "--child", way], stdout=out, stderr=err)
        _, status, ru = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if p.returncode != 0:
            sys.exit(f"the {way} render failed (exit {p.returncode}):\n{err.read()}")
        r = json.loads(out.read().strip().splitlines()[-1])
    r["cpu"] = ru.ru_utime + ru.ru_stime
    r["peak_mib"] = ru.ru_maxrss / 1024
    return r


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--raw", required=True, help="the measured data (UBO2003 folder, .btf, .btfc)")
    ap.add_argument("--plmc", required=True, help="the fitted model of the same material")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--pass-spp", type=int, default=0,
                    help="render in passes of this many spp (a divisor of --spp; 0: one pass)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", help="folder for the last image of each way (raw.exr, plmc.exr)")
    ap.add_argument("--child", choices=["raw", "plmc"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return 0
    for p, what in [(args.scene, "scene"), (Path(args.raw), "raw data"), (Path(args.plmc), "model")]:
        if not p.exists():
            sys.exit(f"{p}: {what} not found")
    argv = [str(args.scene), "--raw", args.raw, "--plmc", args.plmc, "--spp", str(args.spp),
            "--seed", str(args.seed), "--variant", args.variant, "--pass-spp", str(args.pass_spp)]
    argv += [a for d in args.defines for a in ("-D", d)]
    if args.out:
        argv += ["--out", args.out]
    rows: dict[str, list[dict]] = {"raw": [], "plmc": []}
    for i in range(args.runs):
        # Alternated, so a drift of the machine's speed hits both ways alike.
        for way in ("raw", "plmc"):
            r = run_child(argv, way)
            rows[way].append(r)
            print(f"run {i} {way:4}: cpu {r['cpu']:.2f} s, peak {r['peak_mib']:.0f} MiB, "
                  f"load {r['load']:.2f} s, render {r['render']:.2f} s", flush=True)
    med = {w: {k: statistics.median(x[k] for x in rows[w]) for k in ("cpu", "peak_mib", "load", "render")} for w in rows}
    per = f", passes of {args.spp // max(1, args.spp // args.pass_spp)} spp" if args.pass_spp else ""
    print(f"{args.scene} at {args.spp} spp{per}, {args.variant}, {args.runs} runs each (medians):")
    for w in rows:
        m = med[w]
        print(f"  {w:4}: cpu {m['cpu']:.2f} s, peak {m['peak_mib']:.0f} MiB, load {m['load']:.2f} s, render {m['render']:.2f} s")
    print(f"  raw / plmc: cpu {med['raw']['cpu'] / med['plmc']['cpu']:.2f}x, "
          f"peak memory {med['raw']['peak_mib'] / med['plmc']['peak_mib']:.2f}x, "
          f"render {med['raw']['render'] / med['plmc']['render']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
