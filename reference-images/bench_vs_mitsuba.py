#!/usr/bin/env python3
"""btfpt vs Mitsuba 3 (llvm_ad_rgb) on the same XML, side by side in one run.

usage: bench_vs_mitsuba.py SCENE.xml SPP [--runs 3] [--threads 2] [--btfpt target/release/btfpt]
       [--btfpt-arg=--integrator --btfpt-arg=packet]
       (or reference-images/bench_vs_mitsuba.sh SCENE.xml SPP, which builds btfpt first)

Runs are interleaved (btfpt, Mitsuba, btfpt, Mitsuba, ...) so both see the same machine load.
btfpt: the release binary, `--threads T`, one process per run (seed = run); timed are the whole
process wall time (scene load + BVH + render + EXR write), its CPU time (rusage of the child),
and the render alone ("rendering X s (cpu Y s)" in the "done in" line: its wall time and the process CPU time over the sample
loop, getrusage, i.e. without scene load, BVH build and image writing: "render-only cpu").
Mitsuba: one process, the scene loaded once, Dr.Jit limited to T threads; one untimed warm-up
render traces and compiles the kernels (reported as "jit"), then each timed run is
mi.render + dr.eval with seed = 1 + run (render only: no load, no JIT, no EXR write); CPU time
= process_time() over the render (all threads). On a loaded machine compare CPU times.
Quality: relMSE of every run against the committed reference reference-images/<name>/<name>.exr
(mean((t - r)^2 / (r^2 + 1e-2)), as compare.py). At equal spp the two renderers differ in
variance, so "time to equal quality" compares time x relMSE (relMSE ~ 1/spp when noise dominates):
efficiency ratio = (t_mitsuba * relMSE_mitsuba) / (t_btfpt * relMSE_btfpt) > 1 means btfpt wins.
Prints a table and one JSON line.
"""
from __future__ import annotations

import argparse
import json
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mitsuba_common as mc

ROOT = mc.HERE.parent


def relmse(t: np.ndarray, r: np.ndarray) -> float:
    return float(np.mean((t - r) ** 2 / (r**2 + 1e-2)))


def read_exr(path: Path) -> np.ndarray:
    import mitsuba as mi

    with mc.io_threads():
        return np.array(mi.Bitmap(str(path)), dtype=np.float64)[..., :3]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("spp", type=int)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--btfpt", type=Path, default=ROOT / "target" / "release" / "btfpt")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--btfpt-arg", dest="btfpt_args", action="append", default=[], metavar="ARG",
                    help="extra argument for btfpt render (repeatable), e.g. --btfpt-arg=--integrator --btfpt-arg=packet")
    a = ap.parse_args(argv)
    if a.spp < 1 or a.runs < 1 or a.threads < 1:
        ap.error("SPP, --runs and --threads must be positive")
    if not a.scene.is_file():
        sys.exit(f"{a.scene}: scene file not found")
    if not a.btfpt.is_file():
        sys.exit(f"{a.btfpt}: btfpt binary not found (cargo build --release)")

    mc.set_variant(mc.VARIANT)
    import drjit as dr
    import mitsuba as mi

    dr.set_thread_count(a.threads)
    name = mc.scene_name(a.scene)
    ref_path = mc.HERE / name / f"{name}.exr"
    ref = read_exr(ref_path) if ref_path.is_file() else None

    t = time.perf_counter()
    scene = mc.load_scene(a.scene, mc.parse_defines(a.defines))
    mi_load = time.perf_counter() - t
    t = time.perf_counter()
    dr.eval(mi.render(scene, spp=a.spp, seed=10_000))
    dr.sync_thread()
    mi_first = time.perf_counter() - t

    rows = {"btfpt": [], "btfpt_render": [], "btfpt_cpu": [], "btfpt_render_cpu": [], "mitsuba": [], "mitsuba_cpu": [],
            "rel_btfpt": [], "rel_mitsuba": []}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(a.runs):
            out = Path(tmp) / f"btfpt{k}.exr"
            cmd = [str(a.btfpt), "render", str(a.scene), "--spp", str(a.spp), "--seed", str(k),
                   "--threads", str(a.threads), "-o", str(out)]
            for d in a.defines:
                cmd += ["-D", d]
            cmd += a.btfpt_args
            ru = resource.getrusage(resource.RUSAGE_CHILDREN)
            t = time.perf_counter()
            p = subprocess.run(cmd, capture_output=True, text=True)
            wall = time.perf_counter() - t
            ru2 = resource.getrusage(resource.RUSAGE_CHILDREN)
            rows["btfpt_cpu"].append(ru2.ru_utime + ru2.ru_stime - ru.ru_utime - ru.ru_stime)
            if p.returncode != 0:
                sys.exit(f"btfpt failed ({' '.join(cmd)}):\n{p.stderr}")
            m = re.search(r"rendering ([0-9.]+) s", p.stderr)
            rows["btfpt"].append(wall)
            rows["btfpt_render"].append(float(m.group(1)) if m else float("nan"))
            m = re.search(r"rendering [0-9.]+ s \(cpu ([0-9.]+) s\)", p.stderr)
            rows["btfpt_render_cpu"].append(float(m.group(1)) if m else float("nan"))
            if ref is not None:
                rows["rel_btfpt"].append(relmse(read_exr(out), ref))

            c = time.process_time()
            t = time.perf_counter()
            img = mi.render(scene, spp=a.spp, seed=1 + k)
            dr.eval(img)
            dr.sync_thread()
            rows["mitsuba"].append(time.perf_counter() - t)
            rows["mitsuba_cpu"].append(time.process_time() - c)
            if ref is not None:
                rows["rel_mitsuba"].append(relmse(np.array(img, dtype=np.float64)[..., :3], ref))

    med = {k: (statistics.median(v) if v else float("nan")) for k, v in rows.items()}
    ratio = med["mitsuba"] / med["btfpt"]
    eff = (med["mitsuba"] * med["rel_mitsuba"]) / (med["btfpt"] * med["rel_btfpt"])
    print(f"{name} @ {a.spp} spp, {a.threads} threads, {a.runs} runs each (medians):")
    cpu_ratio = med["mitsuba_cpu"] / med["btfpt_cpu"]
    render_cpu_ratio = med["mitsuba_cpu"] / med["btfpt_render_cpu"]
    print(f"  btfpt    wall {med['btfpt']:7.2f} s  cpu {med['btfpt_cpu']:7.2f} s  (render {med['btfpt_render']:.2f} s, cpu {med['btfpt_render_cpu']:.2f} s)"
          f"   relMSE {med['rel_btfpt']:.3e}")
    print(f"  mitsuba  wall {med['mitsuba']:7.2f} s  cpu {med['mitsuba_cpu']:7.2f} s  (render only; load "
          f"{mi_load:.2f} s, first render incl. JIT {mi_first:.2f} s)   relMSE {med['rel_mitsuba']:.3e}")
    print(f"  mitsuba/btfpt: wall {ratio:.2f}, cpu {cpu_ratio:.2f}, render-only cpu {render_cpu_ratio:.2f}; efficiency ratio (wall x relMSE) {eff:.2f}")
    print(json.dumps({
        "scene": name, "spp": a.spp, "threads": a.threads, "runs": a.runs,
        "btfpt_wall_s": [round(x, 3) for x in rows["btfpt"]],
        "btfpt_render_s": rows["btfpt_render"],
        "btfpt_render_cpu_s": rows["btfpt_render_cpu"],
        "btfpt_cpu_s": [round(x, 3) for x in rows["btfpt_cpu"]],
        "mitsuba_render_s": [round(x, 3) for x in rows["mitsuba"]],
        "mitsuba_cpu_s": [round(x, 3) for x in rows["mitsuba_cpu"]],
        "mitsuba_load_s": round(mi_load, 3), "mitsuba_first_render_s": round(mi_first, 3),
        "relmse_btfpt": rows["rel_btfpt"], "relmse_mitsuba": rows["rel_mitsuba"],
        "speed_ratio_mitsuba_over_btfpt": round(ratio, 3),
        "cpu_ratio_mitsuba_over_btfpt": round(cpu_ratio, 3),
        "render_cpu_ratio_mitsuba_over_btfpt": round(render_cpu_ratio, 3),
        "efficiency_ratio": round(eff, 3),
        "variant": mi.variant(), "mitsuba": mi.__version__,
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
