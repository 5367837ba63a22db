#!/usr/bin/env python3
"""Wall time of a Mitsuba 3 render, for the speed comparison with btfpt.

usage: bench_mitsuba.py SCENE.xml --spp N [-D name=value ...] [--repeat R] [--variant V]

Python start-up, imports and scene loading are timed separately and excluded from the render time.
The first render includes Dr.Jit's tracing + kernel compilation (or a kernel-cache load); the
following R renders (other seeds) reuse the compiled kernels, so their median is the render time.
JIT time = first render - median. Dr.Jit's kernel history gives codegen and LLVM compile time
directly (compile time is 0 for kernels found in Dr.Jit's on-disk cache, ~/.drjit; remove it for
a cold measurement). Prints one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

T_START = time.perf_counter()
import mitsuba_common as mc  # noqa: E402
import mitsuba as mi  # noqa: E402
import drjit as dr  # noqa: E402


def timed_render(scene, spp: int, seed: int) -> float:
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--variant", default=mc.VARIANT)
    args = ap.parse_args(argv)
    if args.spp < 1 or args.repeat < 1:
        ap.error("--spp and --repeat must be positive")
    mc.set_variant(args.variant)
    t_import = time.perf_counter() - T_START
    t = time.perf_counter()
    scene = mc.load_scene(args.scene, mc.parse_defines(args.defines))
    t_load = time.perf_counter() - t
    size = scene.sensors()[0].film().crop_size()

    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # clear
    first = timed_render(scene, args.spp, 0)
    hist = [k for k in dr.kernel_history() if k.get("type") == dr.KernelType.JIT]
    codegen = sum(k.get("codegen_time", 0.0) for k in hist) / 1000.0
    backend = sum(k.get("backend_time", 0.0) for k in hist) / 1000.0
    cache_hits = sum(1 for k in hist if k.get("cache_hit", False))
    dr.set_flag(dr.JitFlag.KernelHistory, False)
    runs = [timed_render(scene, args.spp, 1 + r) for r in range(args.repeat)]
    med = statistics.median(runs)
    samples = int(size[0]) * int(size[1]) * args.spp
    print(json.dumps({
        "scene": str(args.scene),
        "variant": mi.variant(),
        "mitsuba": mi.__version__,
        "width": int(size[0]), "height": int(size[1]), "spp": args.spp,
        "import_seconds": round(t_import, 3),
        "scene_load_seconds": round(t_load, 3),
        "first_render_seconds": round(first, 3),
        "render_seconds_median": round(med, 3),
        "render_seconds_all": [round(x, 3) for x in runs],
        "jit_seconds_first_minus_median": round(first - med, 3),
        "jit_codegen_seconds": round(codegen, 3),
        "jit_backend_compile_seconds": round(backend, 3),
        "jit_kernels_first_render": len(hist),
        "jit_kernel_cache_hits": cache_hits,
        "note": "compiled kernels are cached on disk by Dr.Jit (~/.drjit): with cache hits the "
                "backend compile time is 0 and the JIT cost is tracing + codegen only",
        "msamples_per_second": round(samples / med / 1e6, 3),
    }, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
