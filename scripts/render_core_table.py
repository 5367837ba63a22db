#!/usr/bin/env python3
"""The render core's speed table: btfpt against Mitsuba 3 (llvm_ad_rgb) and PLM-C against diffuse.

usage: scripts/render_core_table.py [--threads 1 2] [--runs 3] [--matpreview PATH/matpreview.xml]
                                    [--rows cornell matpreview plmc]
                                    [--btfpt target/release/btfpt] [--skip-mitsuba]

Rows (medians of alternated runs; the machine may be shared, so compare ratios):
  cornell-box, cornell-box-all  Mitsuba/btfpt render-only CPU at 256 spp, and the efficiency ratio
                                (time x relMSE against the committed reference), from
                                reference-images/bench_vs_mitsuba.py.
  matpreview                    Mitsuba's own material-preview scene (mitsuba-data
                                scenes/matpreview/matpreview.xml, unchanged: gaussian filter,
                                serialized meshes, plastic, checkerboard, envmap) at 342x256, 64 spp:
                                Mitsuba/btfpt whole-process CPU (both command-line renderers, scene
                                load and image write included). Give its path with --matpreview
                                (the script downloads nothing).
  matpreview-btf, btf-sphere,   btfpt render-only CPU of the scene with a fitted PLM-C material
  btf-plane                     (scenes/showcase/materials/corduroy.plmc) over the same scene with
                                a diffuse material in its place (64 / 512 / 512 spp).
Mitsuba runs Python-hosted (import, load, render, write in one child process): its `mitsuba`
executable once never finished on matpreview with -t 2 (0 s of CPU after 13 minutes).
Mitsuba rows need reference-images/.venv (reference-images/setup.sh); --skip-mitsuba leaves them out.
Prints a markdown table and one JSON line.
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

ROOT = Path(__file__).resolve().parent.parent
VENV_PY = ROOT / "reference-images" / ".venv" / "bin" / "python"
PLMC = ROOT / "scenes" / "showcase" / "materials" / "corduroy.plmc"
RENDER_LINE = re.compile(r"rendering ([0-9.]+) s \(cpu ([0-9.]+) s\)")


def child_cpu(cmd: list[str]) -> tuple[float, float, str]:
    """Runs cmd; returns (whole-process CPU seconds, wall seconds, stderr)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, p.stderr


def render_cpu(stderr: str) -> float:
    m = RENDER_LINE.search(stderr)
    if not m:
        sys.exit(f"no 'rendering X s (cpu Y s)' line in btfpt's output:\n{stderr[-2000:]}")
    return float(m.group(2))


def cornell_rows(a, threads: int) -> list[dict]:
    rows = []
    for scene in ["cornell-box", "cornell-box-all"]:
        cmd = [str(VENV_PY), str(ROOT / "reference-images" / "bench_vs_mitsuba.py"),
               str(ROOT / "scenes" / scene / "scene.xml"), "256", "--threads", str(threads),
               "--runs", str(a.runs), "--btfpt", str(a.btfpt)]
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
        if p.returncode != 0:
            sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr[-2000:]}")
        data = json.loads([line for line in p.stdout.splitlines() if line.startswith("{")][-1])
        rows.append({"scene": scene, "threads": threads, "measure": "Mitsuba/btfpt render-only CPU",
                     "value": data.get("render_cpu_ratio_mitsuba_over_btfpt"), "efficiency": data.get("efficiency_ratio"),
                     "must": 0.85})
    return rows


# Mitsuba's whole render as one process: import, load, JIT, render, write (what its `mitsuba`
# command does). Python-hosted because the `mitsuba` executable hung on this scene (see above).
MITSUBA_RENDER = """
import sys
sys.path.insert(0, %r)
import drjit as dr, mitsuba as mi
from mitsuba_common import io_threads
mi.set_variant("llvm_ad_rgb")
xml, threads, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
with io_threads():
    scene = mi.load_file(xml, spp=64, width=342, height=256)
dr.set_thread_count(threads)
img = mi.render(scene)
with io_threads():
    mi.Bitmap(img).write(out)
""" % str(ROOT / "reference-images")


def matpreview_row(a, threads: int) -> dict:
    xml = Path(a.matpreview).resolve()
    common = ["-D", "spp=64", "-D", "width=342", "-D", "height=256"]
    with tempfile.TemporaryDirectory() as tmp:
        b_cmd = [str(a.btfpt), "render", str(xml), *common, "--threads", str(threads),
                 "-o", f"{tmp}/b.exr"]
        m_cmd = [str(VENV_PY), "-c", MITSUBA_RENDER, str(xml), str(threads), f"{tmp}/m.exr"]
        child_cpu(b_cmd)  # warm-up (page cache, JIT cache)
        child_cpu(m_cmd)
        b, m = [], []
        for _ in range(a.runs):
            b.append(child_cpu(b_cmd)[0])
            m.append(child_cpu(m_cmd)[0])
    ratios = [mm / bb for mm, bb in zip(m, b)]
    return {"scene": "matpreview (mitsuba-data, unchanged)", "threads": threads,
            "measure": "Mitsuba/btfpt whole-process CPU", "value": statistics.median(ratios),
            "btfpt_cpu": statistics.median(b), "mitsuba_cpu": statistics.median(m), "must": 1.0}


def diffuse_variant(scene: Path, tmp: Path) -> Path:
    """The scene with its `btf` BSDF replaced by a diffuse one (same geometry, lights, camera)."""
    text = scene.read_text()
    new, n = re.subn(r'<bsdf type="btf"(.*?)>.*?</bsdf>', r'<bsdf type="diffuse"\1/>', text,
                     flags=re.S)
    if n == 0:
        sys.exit(f"{scene}: no <bsdf type=\"btf\"> to replace")
    # Includes and relative paths resolve against the original folder.
    new = re.sub(r'<include filename="([^"/][^"]*)"', lambda m: f'<include filename="{scene.parent / m.group(1)}"', new)
    new = re.sub(r'(<scene[^>]*>)', lambda m: f'{m.group(1)}\n    <path value="{scene.parent}"/>', new, count=1)
    out = tmp / f"{scene.parent.name}-diffuse.xml"
    out.write_text(new)
    return out


def plmc_rows(a, threads: int) -> list[dict]:
    rows = []
    # Enough samples that a run takes seconds: the summary prints CPU to 0.01 s.
    cases = [("matpreview-btf", ["-D", "spp=64"]), ("btf-sphere", ["-D", "spp=512"]),
             ("btf-plane", ["-D", "spp=512"])]
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        for name, extra in cases:
            scene = ROOT / "scenes" / name / "scene.xml"
            plmc = [str(a.btfpt), "render", str(scene), "-D", f"btf={PLMC}", *extra,
                    "--threads", str(threads), "-o", str(tmp / "p.exr")]
            diff = [str(a.btfpt), "render", str(diffuse_variant(scene, tmp)), *extra,
                    "--threads", str(threads), "-o", str(tmp / "d.exr")]
            child_cpu(plmc)
            child_cpu(diff)
            p, d = [], []
            for _ in range(a.runs):
                p.append(render_cpu(child_cpu(plmc)[2]))
                d.append(render_cpu(child_cpu(diff)[2]))
            ratios = [pp / dd for pp, dd in zip(p, d)]
            rows.append({"scene": name, "threads": threads,
                         "measure": "PLM-C/diffuse render-only CPU",
                         "value": statistics.median(ratios), "must": 1.2})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--matpreview", type=Path)
    ap.add_argument("--btfpt", type=Path, default=ROOT / "target" / "release" / "btfpt")
    ap.add_argument("--skip-mitsuba", action="store_true")
    ap.add_argument("--rows", nargs="+", choices=["cornell", "matpreview", "plmc"],
                    default=["cornell", "matpreview", "plmc"], help="which row groups to measure")
    a = ap.parse_args()
    if not a.btfpt.is_file():
        sys.exit(f"{a.btfpt}: not found (cargo build --release)")
    mitsuba = not a.skip_mitsuba
    if mitsuba and not VENV_PY.is_file():
        sys.exit("reference-images/.venv missing: run reference-images/setup.sh or pass --skip-mitsuba")
    rows = []
    for t in a.threads:
        new = []
        if mitsuba and "cornell" in a.rows:
            new += cornell_rows(a, t)
        if mitsuba and a.matpreview and "matpreview" in a.rows:
            new.append(matpreview_row(a, t))
        if "plmc" in a.rows:
            new += plmc_rows(a, t)
        for r in new:
            print(json.dumps(r), file=sys.stderr, flush=True)
        rows += new
    print("| scene | threads | measure | median | must reach | met |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        v = r["value"]
        lower_better = r["measure"].startswith("PLM-C")
        met = v is not None and (v <= r["must"] if lower_better else v >= r["must"])
        extra = f" (efficiency {r['efficiency']:.2f})" if r.get("efficiency") else ""
        print(f"| {r['scene']} | {r['threads']} | {r['measure']} | {v:.2f}{extra} | "
              f"{'≤' if lower_better else '≥'} {r['must']} | {'yes' if met else 'no'} |")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
