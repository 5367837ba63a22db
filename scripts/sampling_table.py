#!/usr/bin/env python3
"""Noise of two btfpt builds at equal render time: relMSE against a converged reference and the
fireflies (pixels whose luminance is above 5x the reference's), for BTF sampling changes.

usage: scripts/sampling_table.py --before OLD_BTFPT --after NEW_BTFPT [--out DIR] [--spp 64]
                                 [--ref-spp 2048] [--seeds 3] [--threads 2]
                                 [--cases showcase plane sphere] [--fitted foil wood ...]
                                 [--extra NAME=PATH ...]

Per case (scene + defines): a reference at --ref-spp rendered once by OLD (kept in --out and
reused), then per seed OLD and NEW at --spp; NEW is rendered again at the spp that takes OLD's
render-only CPU time (median over the seeds of the --spp runs: "equal time"). relMSE is
`btfpt compare`'s (per channel, (t - r)^2 / (r^2 + eps)), averaged over the seeds; fireflies
are counted per image and averaged. Cases: the README's showcase (480x320), and btf-plane and
btf-sphere (128x96) with the showcase's fitted materials (--fitted, default foil, wood, leather,
corduroy; none with a bare --fitted) and any --extra NAME=PATH: a fitted model (e.g. a wool model
fitted by `btfpt synth wool` + `btfpt fit`) or raw data (e.g. `btfpt synth foil --size 64 -o
foil64.btfc`).
Needs reference-images/.venv (mitsuba reads the EXRs). Prints a markdown table and one JSON line.
"""
from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MATERIALS = ROOT / "scenes" / "showcase" / "materials"


def render(btfpt: str, scene: str, defines: list[str], spp: int, seed: int, out: Path,
           threads: int) -> float:
    """Renders; returns the render-only CPU seconds btfpt reports."""
    cmd = ["nice", btfpt, "render", str(ROOT / scene), "--spp", str(spp), "--seed", str(seed),
           "--threads", str(threads), "-o", str(out)]
    for d in defines:
        cmd += ["-D", d]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"render failed: {' '.join(cmd)}\n{p.stderr}")
    m = re.search(r"rendering [0-9.]+ s \(cpu ([0-9.]+) s\)", p.stdout + p.stderr)
    if not m:
        sys.exit(f"no render time in the output of {' '.join(cmd)}")
    return float(m.group(1))


def load(path: Path):
    import mitsuba as mi
    import numpy as np
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[..., :3]


def measures(test: Path, ref: Path) -> tuple[float, int]:
    """(relMSE as `btfpt compare` computes it, pixels with luminance > 5x the reference's)."""
    import numpy as np
    t, r = load(test), load(ref)
    relmse = float(np.mean((t - r) ** 2 / (r * r + 1e-2)))
    lum = np.array([0.212671, 0.715160, 0.072169])
    lt, lr = t @ lum, r @ lum
    fireflies = int(np.sum((lr > 0) & (lt > 5 * lr)))
    return relmse, fireflies


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--before", required=True)
    ap.add_argument("--after", required=True)
    ap.add_argument("--out", default="/tmp/sampling_table")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--cases", nargs="+", default=["showcase", "plane", "sphere"])
    ap.add_argument("--fitted", nargs="*", default=["foil", "wood", "leather", "corduroy"],
                    help="showcase materials (scenes/showcase/materials/NAME.plmc)")
    ap.add_argument("--extra", nargs="*", default=[], help="NAME=PATH (.plmc or raw data)")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    mats = [(n, str(MATERIALS / f"{n}.plmc")) for n in a.fitted]
    mats += [tuple(e.split("=", 1)) for e in a.extra]
    cases = []
    if "showcase" in a.cases:
        cases.append(("showcase", "scenes/showcase/scene.xml", []))
    for key, scene in [("plane", "scenes/btf-plane/scene.xml"),
                       ("sphere", "scenes/btf-sphere/scene.xml")]:
        if key in a.cases:
            for name, path in mats:
                cases.append((f"btf-{key} {name}", scene, [f"btf={path}"]))
    rows = []
    for label, scene, defines in cases:
        tag = re.sub(r"[^A-Za-z0-9]+", "_", label)
        ref = out / f"{tag}_ref{a.ref_spp}.exr"
        if not ref.exists():
            render(a.before, scene, defines, a.ref_spp, 1_000_003, ref, a.threads)
        t_b, t_a, err_b, err_a, ff_b, ff_a = [], [], [], [], [], []
        for s in range(a.seeds):
            for btfpt, times, errs, ffs, side in [(a.before, t_b, err_b, ff_b, "before"),
                                                  (a.after, t_a, err_a, ff_a, "after")]:
                img = out / f"{tag}_{side}_{a.spp}_{s}.exr"
                times.append(render(btfpt, scene, defines, a.spp, s, img, a.threads))
                e, f = measures(img, ref)
                errs.append(e)
                ffs.append(f)
        ratio = statistics.median(t_b) / statistics.median(t_a)
        spp_eq = max(1, round(a.spp * ratio))
        err_eq, ff_eq, t_eq = [], [], []
        for s in range(a.seeds):
            img = out / f"{tag}_after_{spp_eq}_{s}.exr"
            t_eq.append(render(a.after, scene, defines, spp_eq, s, img, a.threads))
            e, f = measures(img, ref)
            err_eq.append(e)
            ff_eq.append(f)
        mean = statistics.fmean
        rows.append({
            "case": label, "spp": a.spp, "spp_equal_time": spp_eq,
            "cpu_before": statistics.median(t_b), "cpu_after": statistics.median(t_a),
            "cpu_after_equal_time": statistics.median(t_eq),
            "relmse_before": mean(err_b), "relmse_after": mean(err_a),
            "relmse_after_equal_time": mean(err_eq),
            "relmse_ratio_equal_time": mean(err_b) / max(mean(err_eq), 1e-30),
            "fireflies_before": mean(ff_b), "fireflies_after_equal_time": mean(ff_eq),
        })
        print(f"done: {label}", file=sys.stderr, flush=True)
    print(f"{a.seeds} seeds, references at {a.ref_spp} spp (the before build), "
          f"{a.threads} threads; CPU = render-only CPU seconds, medians\n")
    print("| case | CPU before / after at "
          f"{a.spp} spp (s) | after spp at equal time | relMSE before | relMSE after, "
          f"{a.spp} spp | relMSE after, equal time | ratio | pixels > 5x ref before / after "
          "(equal time) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['cpu_before']:.2f} / {r['cpu_after']:.2f} | "
              f"{r['spp_equal_time']} ({r['cpu_after_equal_time']:.2f} s) | "
              f"{r['relmse_before']:.3e} | {r['relmse_after']:.3e} | "
              f"{r['relmse_after_equal_time']:.3e} | {r['relmse_ratio_equal_time']:.2f}x | "
              f"{r['fireflies_before']:.1f} / {r['fireflies_after_equal_time']:.1f} |")
    print(json.dumps({"seeds": a.seeds, "ref_spp": a.ref_spp, "rows": rows}))


if __name__ == "__main__":
    main()
