#!/usr/bin/env python3
"""Mitsuba 3 rendering one BTF scene two ways, each in a process of its own: through btfpt's
plugin on a fitted .plmc model (btfpt.mitsuba) and through the raw-BTF plugin of
reference-images/ (btf_plugin.py) on the measured data. Prints, per way and run, the process's
CPU seconds (user + sys, from the kernel's accounting of the finished child), its peak resident
memory (its own VmHWM), the resident memory the material adds (resident set after
`mi.load_file` minus before it: the material's own memory, apart from the fixed cost of Python,
Mitsuba and LLVM), the wall time of loading and of rendering, and the medians and the raw/plmc
ratios.

usage: scripts/bench_mitsuba_plugin.py SCENE.xml (--size N | --raw DATA --plmc MODEL.plmc) --spp N
           [--material corduroy] [--seed 1] [--work DIR] [-D name=value ...] [--runs 3]
           [--pass-spp K] [--variant llvm_ad_rgb] [--out DIR]

--size N makes the material itself: `btfpt synth MATERIAL --size N --seed S -o WORK/MATERIALN.btfc`
(81 × 81 UBO2003 directions, as UBO2003's own samples) and `btfpt fit` of it (PLM-C, defaults) into
WORK/MATERIALN.plmc, kept in --work (default target/bench-plugin) and reused by the next run.
--pass-spp renders in passes of K spp (as Mitsuba's samples_per_pass): the wavefront, and with it
the memory every JIT renderer spends per sample, is then bounded by the pass instead of growing
with the whole spp × pixels, so the peak measures the material rather than the wavefront.

Run it with a Python that has mitsuba==3.9.1 and the btfpt module (python/ci.sh makes one in
target/ci-pyvenv; or reference-images/.venv after reference-images/make_report.sh). The scene
takes the material's file through the define `btf` (as scenes/btf-plane/scene.xml). --out writes
each way's last image as EXR. For example (a 128² material: 1.3 GB of float32 in the raw plugin):

    target/ci-pyvenv/bin/python scripts/bench_mitsuba_plugin.py scenes/btf-plane/scene.xml \\
        --size 128 --spp 64 --pass-spp 4
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
KEYS = ("cpu", "peak_mib", "material_mib", "load", "render")


def rss_mib() -> tuple[float, float]:
    """This process's resident set and its peak so far (VmRSS, VmHWM), MiB."""
    f = {k: float(v.split()[0]) / 1024 for k, v in
         (line.split(":", 1) for line in Path("/proc/self/status").read_text().splitlines() if ":" in line)
         if k in ("VmRSS", "VmHWM")}
    return f["VmRSS"], f["VmHWM"]


def child(args) -> None:
    """One render in this process: prints a JSON line with the load and render wall times and the
    resident memory before and after loading the scene."""
    t0 = time.perf_counter()
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    sys.path.insert(0, str(REPO / "scripts"))
    from plugin_vs_btfpt import register

    register(args.child)
    material = args.plmc if args.child == "plmc" else args.raw
    defines = dict(d.split("=", 1) for d in args.defines)
    defines["btf"] = str(Path(material).resolve())
    t1 = time.perf_counter()
    rss0, _ = rss_mib()
    scene = mi.load_file(str(args.scene), **defines)
    rss1, hwm1 = rss_mib()
    t2 = time.perf_counter()
    # In passes of --pass-spp (the estimator of one render at --spp, as Mitsuba's
    # samples_per_pass): the wavefront, and so the memory per sample, scales with the pass.
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
    # The peak from the process's own memory map, not wait4's ru_maxrss: that one also counts
    # the parent's resident set at the fork, before the exec (a Mitsuba parent, as in
    # make_report.py, would show as this child's peak).
    _, hwm = rss_mib()
    print(json.dumps({"import": t1 - t0, "load": t2 - t1, "render": t3 - t2, "rss_before_load_mib": rss0,
                      "rss_after_load_mib": rss1, "peak_after_load_mib": hwm1, "material_mib": rss1 - rss0,
                      "peak_mib": hwm}))


def run_child(argv: list[str], way: str) -> dict:
    """Runs this script as a child for `way`: its report and CPU seconds (wait4)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen([sys.executable, __file__, *argv, "--child", way], stdout=out, stderr=err)
        _, status, ru = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if p.returncode != 0:
            raise RuntimeError(f"the {way} render failed (exit {p.returncode}):\n{err.read()[-2000:]}")
        r = json.loads(out.read().strip().splitlines()[-1])
    r["cpu"] = ru.ru_utime + ru.ru_stime
    return r


def make_material(btfpt: Path, material: str, size: int, seed: int, work: Path) -> tuple[Path, Path]:
    """The raw data (`btfpt synth`, a .btfc cache) and its PLM-C fit (`btfpt fit`, defaults) of a
    size² material in `work`, made when missing: (raw, plmc)."""
    work.mkdir(parents=True, exist_ok=True)
    raw, plmc = work / f"{material}{size}-seed{seed}.btfc", work / f"{material}{size}-seed{seed}.plmc"
    if not raw.exists():
        subprocess.run([str(btfpt), "synth", material, "--size", str(size), "--seed", str(seed), "-o", str(raw)],
                       check=True)
    if not plmc.exists():
        subprocess.run([str(btfpt), "fit", str(raw), "-o", str(plmc)], check=True)
    return raw, plmc


def material_bytes(raw: Path, plmc: Path) -> dict:
    """What each plugin holds of the material: the raw plugin the whole table as float32
    (views × lights × texels × RGB), btfpt's plugin the model file's parameters."""
    import btfpt

    b = btfpt.Btf.open(raw)
    w, h = b.size
    return {"size": [w, h], "views": len(b.views), "lights": len(b.lights),
            "raw_float32_bytes": len(b.views) * len(b.lights) * w * h * 3 * 4,
            "raw_file_bytes": sum(f.stat().st_size for f in ([raw] if raw.is_file() else raw.rglob("*"))
                                  if f.is_file()),
            "plmc_file_bytes": plmc.stat().st_size}


def bench(scene: Path, raw: Path, plmc: Path, spp: int, defines: list[str] = (), runs: int = 3,
          pass_spp: int = 0, seed: int = 0, variant: str = "llvm_ad_rgb", out: str | None = None,
          log=print) -> dict:
    """Both ways `runs` times, alternated: {"runs": {way: [report]}, "median": {way: {...}},
    "ratio": raw / plmc of the medians}."""
    argv = [str(scene), "--raw", str(raw), "--plmc", str(plmc), "--spp", str(spp), "--seed", str(seed),
            "--variant", variant, "--pass-spp", str(pass_spp)]
    argv += [a for d in defines for a in ("-D", d)]
    if out:
        argv += ["--out", str(out)]
    rows: dict[str, list[dict]] = {"raw": [], "plmc": []}
    for i in range(runs):
        # Alternated, so a drift of the machine's speed hits both ways alike.
        for way in ("raw", "plmc"):
            r = run_child(argv, way)
            rows[way].append(r)
            log(f"run {i} {way:4}: cpu {r['cpu']:.2f} s, peak {r['peak_mib']:.0f} MiB, "
                f"material {r['material_mib']:.0f} MiB, load {r['load']:.2f} s, render {r['render']:.2f} s")
    med = {w: {k: statistics.median(x[k] for x in rows[w]) for k in KEYS} for w in rows}
    ratio = {k: med["raw"][k] / med["plmc"][k] if med["plmc"][k] > 0 else None for k in KEYS}
    return {"runs": rows, "median": med, "ratio": ratio,
            "pass_spp": spp // max(1, spp // pass_spp) if pass_spp else spp}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--size", type=int, help="make a size² material (synth + fit) instead of --raw/--plmc")
    ap.add_argument("--material", default="corduroy", help="the procedural material of --size")
    ap.add_argument("--material-seed", type=int, default=1)
    ap.add_argument("--work", type=Path, default=REPO / "target" / "bench-plugin", help="where --size keeps it")
    ap.add_argument("--btfpt", type=Path, default=REPO / "target" / "release" / "btfpt")
    ap.add_argument("--raw", help="the measured data (UBO2003 folder, .btf, .btfc)")
    ap.add_argument("--plmc", help="the fitted model of the same material")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--pass-spp", type=int, default=0,
                    help="render in passes of this many spp (a divisor of --spp; 0: one pass)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", help="folder for the last image of each way (raw.exr, plmc.exr)")
    ap.add_argument("--json", type=Path, help="also write the figures as JSON")
    ap.add_argument("--child", choices=["raw", "plmc"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return 0
    if args.size is not None:
        if args.raw or args.plmc:
            ap.error("give --size or --raw/--plmc, not both")
        if not 1 <= args.size <= 1024:
            ap.error("--size must be in 1..=1024")
        raw, plmc = make_material(args.btfpt, args.material, args.size, args.material_seed, args.work)
    elif args.raw and args.plmc:
        raw, plmc = Path(args.raw), Path(args.plmc)
    else:
        ap.error("give --size N, or --raw DATA and --plmc MODEL")
    for p, what in [(args.scene, "scene"), (raw, "raw data"), (plmc, "model")]:
        if not p.exists():
            sys.exit(f"{p}: {what} not found")
    r = bench(args.scene, raw, plmc, args.spp, args.defines, args.runs, args.pass_spp, args.seed, args.variant,
              args.out, log=lambda s: print(s, flush=True))
    mb = material_bytes(raw, plmc)
    r["material"] = mb | {"raw": str(raw), "plmc": str(plmc)}
    r["load_average"] = os.getloadavg()
    med, ratio = r["median"], r["ratio"]
    print(f"{args.scene} at {args.spp} spp in passes of {r['pass_spp']} spp, {args.variant}, "
          f"{args.runs} runs each (medians), load average {' / '.join(f'{x:.1f}' for x in r['load_average'])}:")
    print(f"  material {mb['size'][0]}×{mb['size'][1]} texels, {mb['views']} × {mb['lights']} directions: raw "
          f"{mb['raw_float32_bytes'] / 2**20:.0f} MiB as float32 ({mb['raw_file_bytes'] / 2**20:.0f} MiB on disk), "
          f".plmc {mb['plmc_file_bytes'] / 2**20:.1f} MiB: {mb['raw_float32_bytes'] / mb['plmc_file_bytes']:.0f}x")
    for w in ("raw", "plmc"):
        m = med[w]
        print(f"  {w:4}: cpu {m['cpu']:.2f} s, peak {m['peak_mib']:.0f} MiB, material {m['material_mib']:.0f} MiB, "
              f"load {m['load']:.2f} s, render {m['render']:.2f} s")
    fx = lambda v: "n/a" if v is None else f"{v:.2f}x"  # noqa: E731
    print(f"  raw / plmc: cpu {fx(ratio['cpu'])}, peak memory {fx(ratio['peak_mib'])}, "
          f"material memory {fx(ratio['material_mib'])}, render {fx(ratio['render'])}")
    if args.json:
        args.json.write_text(json.dumps(r, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
