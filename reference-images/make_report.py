#!/usr/bin/env python3
"""Regenerates reference-images/REPORT.md and reference-images/report/ (the validation report).

usage: reference-images/make_report.sh        (builds btfpt, then runs this with the .venv python)
       make_report.py --btfpt target/release/btfpt [--spp 64] [--hi-spp 1024] [--threads 2]

For every committed reference scene (reference-images/<name>/<name>.exr, Mitsuba 3 at 16384 spp):
  * Mitsuba renders the scene once more at --spp (independent seed): the noise floor, and its
    render time (scene loaded once, one untimed warm-up render for the JIT, then the timed
    mi.render + dr.eval, Dr.Jit limited to --threads);
  * btfpt renders it at the same spp (release binary, --threads, one process per render): the raw
    BTF, and for BTF scenes the fitted LM, PLM and PLM-C models of the same material
    (`--btf-model`), timed as process wall time, CPU time (rusage of the child) and the render alone
    ("rendering X s" in the "done in" line, no scene/material load);
  * every image is scored against the reference with `btfpt compare --spp N --diff --json`
    (relMSE, MAE, luminance ratio, failing 4x4 blocks of the block z-test);
  * BTF scenes: the models' own error, btfpt at --hi-spp with the same seed for every model
    (common random numbers: the noise mostly cancels) scored against btfpt's raw render, and
    relMSE(model, ref) - relMSE(raw, ref), the model's share of the error against Mitsuba. These
    are the figures tests/regression_plmc.rs takes its bounds from.
The BTF material is synth:corduroy?size=32&seed=1 written by `btfpt synth` as a UBO2003 EXR
folder (what the references were rendered from), fitted with `btfpt fit` defaults; both renderers
read that folder (-D btf=...). Everything runs in one process, scene after scene, so the timings
of the two renderers are side by side under the same machine load (the load average is recorded
before and after each scene; on a shared machine compare CPU times).
Robust: a failing step is recorded in the report and the rest still runs; exit status 1 then.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCENES = [  # (scene file, reference name, has a BTF)
    ("scenes/cornell-box/scene.xml", "cornell-box", False),
    ("scenes/cornell-box-all/scene.xml", "cornell-box-all", False),
    ("scenes/cornell-box-all/scene-constant.xml", "cornell-box-all-constant", False),
    ("scenes/btf-plane/scene.xml", "btf-plane", True),
    ("scenes/btf-sphere/scene.xml", "btf-sphere", True),
]
MODELS = ["lm", "plm", "plmc"]
MODEL_LABEL = {"raw": "raw", "lm": "LM", "plm": "PLM", "plmc": "PLM-C"}
SYNTH = ["corduroy", "--size", "32", "--seed", "1"]

ERRORS: list[str] = []


def run(cmd: list[str], check: bool = True) -> tuple[subprocess.CompletedProcess, float, float]:
    """Runs cmd; returns (process, wall s, child CPU s)."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    wall = time.perf_counter() - t
    ru2 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = ru2.ru_utime + ru2.ru_stime - ru.ru_utime - ru.ru_stime
    if check and p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({p.returncode}): {p.stderr.strip()[-600:]}")
    return p, wall, cpu


def step(what: str, f, *args, **kw):
    """Runs one step; a failure is recorded (and printed) instead of ending the report."""
    try:
        return f(*args, **kw)
    except Exception as e:  # noqa: BLE001 - the report lists every failure
        msg = f"{what}: {e}"
        print("FAILED " + msg, file=sys.stderr)
        traceback.print_exc()
        ERRORS.append(msg)
        return None


def sh(cmd: list[str]) -> str:
    try:
        return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT).stdout.strip()
    except OSError as e:
        return f"unavailable ({e})"


def machine_info() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f"{kb / 1048576:.1f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    commit = sh(["git", "rev-parse", "HEAD"])
    dirty = sh(["git", "status", "--porcelain", "--untracked-files=no"])
    return {
        "date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory": mem,
        "os": platform.platform(),
        "commit": commit + (" (+ uncommitted changes)" if dirty else ""),
        "branch": sh(["git", "rev-parse", "--abbrev-ref", "HEAD"]),
        "rustc": sh(["rustc", "--version"]),
        "python": platform.python_version(),
    }


def compare(btfpt: Path, test: Path, ref: Path, spp: int | None, diff: Path | None) -> dict:
    """`btfpt compare` figures (its exit status only says pass/fail of its default criteria)."""
    out = test.with_suffix(".cmp.json")
    cmd = [btfpt, "compare", test, ref, "--json", out]
    if spp:
        cmd += ["--spp", str(spp)]
    if diff:
        cmd += ["--diff", diff]
    p, _, _ = run(cmd, check=False)
    if not out.is_file():
        raise RuntimeError(f"btfpt compare {test} wrote no JSON: {p.stderr.strip()[-400:]}")
    c = json.loads(out.read_text())["comparison"]
    r = {k: c[k] for k in ("relmse", "mae", "rmse", "mean_luminance_ratio")}
    b = c.get("block_test")
    if b:
        r["failing_blocks"], r["blocks"] = b["failing"], b["cells"]
        r["mean_z"] = (c.get("pixel_test") or {}).get("mean_z")
    return r


def btfpt_render(btfpt, xml, out: Path, spp, seed, threads, defines, model=None) -> dict:
    cmd = [btfpt, "render", xml, "--spp", str(spp), "--seed", str(seed), "--threads", str(threads), "-o", out]
    for d in defines:
        cmd += ["-D", d]
    if model:
        cmd += ["--btf-model", model]
    p, wall, cpu = run(cmd)
    m = re.search(r"rendering ([0-9.]+) s", p.stderr)
    return {"wall_s": wall, "cpu_s": cpu, "render_s": float(m.group(1)) if m else None}


class Mitsuba:
    def __init__(self, threads: int):
        sys.path.insert(0, str(HERE))
        import mitsuba_common as mc

        mc.set_variant(mc.VARIANT)
        import drjit as dr
        import mitsuba as mi

        dr.set_thread_count(threads)
        self.mc, self.dr, self.mi = mc, dr, mi

    def versions(self) -> dict:
        import drjit

        return {"mitsuba": self.mi.__version__, "drjit": drjit.__version__, "variant": self.mi.variant()}

    def render(self, xml: Path, defines: list[str], spp: int, out_exr: Path, out_png: Path, seed: int) -> dict:
        dr, mi = self.dr, self.mi
        t = time.perf_counter()
        scene = self.mc.load_scene(xml, self.mc.parse_defines(defines))
        load = time.perf_counter() - t
        t = time.perf_counter()
        dr.eval(mi.render(scene, spp=spp, seed=10_000))  # traces and compiles the kernels
        dr.sync_thread()
        first = time.perf_counter() - t
        c = time.process_time()
        t = time.perf_counter()
        img = mi.render(scene, spp=spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        wall = time.perf_counter() - t
        cpu = time.process_time() - c
        with self.mc.io_threads():
            mi.Bitmap(img).write(str(out_exr))
            mi.util.write_bitmap(str(out_png), img, write_async=False)
        return {"render_s": wall, "cpu_s": cpu, "load_s": load, "first_render_s": first}


def median_times(ts: list[dict]) -> dict:
    """Per-key medians of timing dicts (keys whose values are all numbers)."""
    import statistics

    out = {"runs": len(ts)}
    for k in ts[0]:
        vals = [t[k] for t in ts if isinstance(t.get(k), (int, float))]
        if len(vals) == len(ts):
            out[k] = statistics.median(vals)
    return out


def fmt(v, spec=".3e", none="n/a"):
    return none if v is None else format(v, spec)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--btfpt", type=Path, default=ROOT / "target" / "release" / "btfpt")
    ap.add_argument("--spp", type=int, default=64, help="spp of the side-by-side renders (default 64)")
    ap.add_argument("--hi-spp", type=int, default=1024, help="spp of the model-error renders (default 1024)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3, help="interleaved timed runs of Mitsuba and btfpt raw (medians)")
    ap.add_argument("--out", type=Path, default=HERE / "REPORT.md")
    ap.add_argument("--images", type=Path, default=HERE / "report")
    ap.add_argument("--only", action="append", help="only these scene names (repeatable; for trying it out)")
    a = ap.parse_args(argv)
    if a.spp < 1 or a.hi_spp < 1 or a.threads < 1 or a.runs < 1:
        ap.error("--spp, --hi-spp, --threads and --runs must be positive")
    btfpt = a.btfpt.resolve()
    if not btfpt.is_file():
        sys.exit(f"{btfpt}: btfpt binary not found (cargo build --release)")
    info = machine_info()
    info["btfpt"] = sh([str(btfpt), "--version"])
    info["load_start"] = os.getloadavg()
    mitsuba = step("Mitsuba setup", Mitsuba, a.threads)
    if mitsuba:
        info.update(mitsuba.versions())
    work = Path(tempfile.mkdtemp(prefix="btfpt-report-"))
    results: dict = {"info": info, "settings": vars(a) | {"btfpt": str(btfpt)}, "material": {}, "scenes": {}}
    try:
        # The BTF material and its models.
        mat = work / "corduroy"
        mres = results["material"]
        r = step("btfpt synth", run, [btfpt, "synth", *SYNTH, "--format", "exr", "-o", mat])
        if r:
            mres["synth_cpu_s"] = r[2]
            for m in MODELS:
                f = work / f"corduroy.{m}.plmc"
                r = step(f"btfpt fit {m}", run, [btfpt, "fit", mat, "-o", f, "--model", m])
                if r:
                    mres[m] = {"fit_wall_s": r[1], "fit_cpu_s": r[2], "bytes": f.stat().st_size,
                               "summary": r[0].stderr.strip().splitlines()[-2:]}
        shutil.rmtree(a.images, ignore_errors=True)
        for xml_rel, name, is_btf in SCENES:
            if a.only and name not in a.only:
                continue
            xml = ROOT / xml_rel
            ref = HERE / name / f"{name}.exr"
            sdir = work / name
            sdir.mkdir()
            idir = a.images / name
            idir.mkdir(parents=True, exist_ok=True)
            defines = [f"btf={mat}"] if is_btf else []
            res: dict = {"load_before": os.getloadavg(), "rows": {}, "model_error": {}}
            results["scenes"][name] = res
            print(f"== {name}", file=sys.stderr)
            if (HERE / name / f"{name}.png").is_file():
                shutil.copy(HERE / name / f"{name}.png", idir / "reference.png")
            ref_json = HERE / name / f"{name}.json"
            if ref_json.is_file():
                res["reference"] = {k: v for k, v in json.loads(ref_json.read_text()).items()
                                    if k in ("spp", "wall_seconds", "seeds", "passes")}
            # Side by side at the same spp: Mitsuba (raw) and btfpt (raw) interleaved, --runs times
            # (medians; the images of the first run are scored), then btfpt's models once each.
            times: dict = {"mitsuba": [], "raw": []}
            for k in range(a.runs):
                if mitsuba:
                    t = step(f"{name}: Mitsuba render", mitsuba.render, xml, defines, a.spp,
                             sdir / f"mitsuba{k}.exr", sdir / f"mitsuba{k}.png", 1 + k)
                    if t:
                        times["mitsuba"].append(t)
                exr = sdir / f"btfpt-raw{k}.exr"
                t = step(f"{name}: btfpt render raw", btfpt_render, btfpt, xml, exr, a.spp, 1 + k,
                         a.threads, defines, "raw" if is_btf else None)
                if t:
                    times["raw"].append(t)
            if times["mitsuba"]:
                shutil.copy(sdir / "mitsuba0.png", idir / "mitsuba.png")
                c = step(f"{name}: compare Mitsuba", compare, btfpt, sdir / "mitsuba0.exr", ref, a.spp,
                         idir / "mitsuba-diff.png")
                res["rows"]["mitsuba"] = median_times(times["mitsuba"]) | (c or {})
            if times["raw"]:
                exr = sdir / "btfpt-raw0.exr"
                shutil.copy(exr.with_suffix(".png"), idir / "btfpt-raw.png")
                c = step(f"{name}: compare btfpt raw", compare, btfpt, exr, ref, a.spp, idir / "btfpt-raw-diff.png")
                res["rows"]["btfpt-raw"] = median_times(times["raw"]) | (c or {})
            for m in MODELS if is_btf else []:
                exr = sdir / f"btfpt-{m}.exr"
                t = step(f"{name}: btfpt render {m}", btfpt_render, btfpt, xml, exr, a.spp, 1, a.threads,
                         defines, m)
                if t:
                    shutil.copy(exr.with_suffix(".png"), idir / f"btfpt-{m}.png")
                    c = step(f"{name}: compare btfpt {m}", compare, btfpt, exr, ref, a.spp,
                             idir / f"btfpt-{m}-diff.png")
                    res["rows"][f"btfpt-{m}"] = t | {"runs": 1} | (c or {})
            # The models' own error: same seed, high spp, against btfpt raw.
            if is_btf:
                hi = {}
                for m in ["raw"] + MODELS:
                    exr = sdir / f"hi-{m}.exr"
                    t = step(f"{name}: btfpt {a.hi_spp} spp {m}", btfpt_render, btfpt, xml, exr, a.hi_spp, 2,
                             a.threads, defines, m)
                    if t:
                        hi[m] = (exr, t, step(f"{name}: compare hi {m}", compare, btfpt, exr, ref, a.hi_spp, None))
                for m in MODELS:
                    if m not in hi or "raw" not in hi:
                        continue
                    c = step(f"{name}: {m} vs raw", compare, btfpt, hi[m][0], hi["raw"][0], None, None)
                    vs_ref, raw_ref = hi[m][2], hi["raw"][2]
                    excess = vs_ref["relmse"] - raw_ref["relmse"] if vs_ref and raw_ref else None
                    res["model_error"][m] = {"vs_raw": c, "vs_ref": vs_ref, "raw_vs_ref": raw_ref,
                                             "excess_relmse_vs_ref": excess, "render_s": hi[m][1]["render_s"]}
                if "raw" in hi:
                    res["model_error"]["raw_render_s"] = hi["raw"][1]["render_s"]
            res["load_after"] = os.getloadavg()
    finally:
        shutil.rmtree(work, ignore_errors=True)
    info["load_end"] = os.getloadavg()
    results["errors"] = ERRORS
    a.images.mkdir(parents=True, exist_ok=True)
    (a.images / "report.json").write_text(json.dumps(results, indent=1, default=str) + "\n")
    a.out.write_text(markdown(results, a))
    print(f"wrote {a.out} and {a.images}/", file=sys.stderr)
    return 1 if ERRORS else 0


def markdown(res: dict, a) -> str:
    i = res["info"]
    la = lambda t: " / ".join(f"{x:.2f}" for x in t)  # noqa: E731
    rel = os.path.relpath(a.images, a.out.parent)
    L = ["# Validation report: btfpt vs Mitsuba 3", "",
         "Generated by `reference-images/make_report.sh` (do not edit by hand; rerun it). Every figure",
         "below comes from that one run. What is measured and how: the docstring of",
         "`reference-images/make_report.py`; the references and their calibration: `NOTES.md`.", ""]
    if res["errors"]:
        L += ["**Steps that failed in this run:**", ""] + [f"- {e}" for e in res["errors"]] + [""]
    L += ["## Machine and versions", "",
          f"- {i['date_utc']}; commit `{i['commit']}` (branch {i['branch']}); {i['btfpt']}; {i['rustc']}",
          f"- CPU {i['cpu']}, {i['cores']} logical cores, {i['memory']}; {i['os']}",
          f"- Mitsuba {i.get('mitsuba', 'n/a')} (Dr.Jit {i.get('drjit', 'n/a')}, variant "
          f"`{i.get('variant', 'n/a')}`), Python {i['python']}",
          f"- both renderers limited to {a.threads} threads; load average (1/5/15 min) at the start "
          f"{la(i['load_start'])}, at the end {la(i['load_end'])} (the machine is shared: wall times "
          "are only comparable within a scene, CPU times more so)", ""]
    m = res["material"]
    if m:
        L += ["## BTF material", "",
              "`btfpt synth " + " ".join(SYNTH) + " --format exr` (= `synth:corduroy?size=32&seed=1`, "
              f"the BTF scenes' default; {fmt(m.get('synth_cpu_s'), '.1f')} s CPU), fitted with "
              "`btfpt fit --model lm|plm|plmc` (defaults: K = 256 clusters, 20 KL features):", "",
              "| model | file size | fit wall | fit CPU |", "| --- | --- | --- | --- |"]
        for k in MODELS:
            if k in m:
                L.append(f"| {MODEL_LABEL[k]} | {m[k]['bytes'] / 1024:.0f} KiB | {m[k]['fit_wall_s']:.1f} s | "
                         f"{m[k]['fit_cpu_s']:.1f} s |")
        L.append("")
    L += ["## Scenes", "",
          f"Each table: images at **{a.spp} spp** scored against the committed Mitsuba reference "
          "(raw BTF, 16384 spp). *Mitsuba* is an independent Mitsuba render at the same spp: the "
          "noise floor every renderer shares. relMSE = mean((t − r)² / (r² + 0.01)); MAE on linear "
          "values; failing blocks = 4×4-pixel block means outside the Šidák-corrected z-test at "
          "α = 0.01 (with the reference's per-sample variance; the raw regression tests allow 1, "
          "see NOTES.md for the calibrated ranges). Times: Mitsuba = `mi.render` after a warm-up "
          "render (no load, no JIT); btfpt *render* = the render alone (\"rendering X s\" of its \"done in\" line), *process* "
          "= the whole `btfpt render` process (scene and material load, BVH, EXR write); CPU = all "
          "threads, of the render alone for Mitsuba but of the whole process for btfpt (so the two "
          "CPU columns are not comparable: compare the render wall times, measured side by side). "
          "Mitsuba and btfpt raw are timed in interleaved runs (medians); the first run's images "
          "are the ones scored and shown.",
          "Difference images: per pixel the channel of largest |z| (white 0, full blue/red at the "
          "per-pixel failure threshold, cyan/magenta beyond it; blue = darker than the reference).", ""]
    for _, name, is_btf in SCENES:
        s = res["scenes"].get(name)
        if not s:
            continue
        ref = s.get("reference", {})
        L += [f"### {name}", "",
              f"Reference: {ref.get('spp', '?')} spp. Load average before / after: "
              f"{la(s['load_before'])} → {la(s.get('load_after', s['load_before']))}.", "",
              "| image | relMSE | MAE | luminance ratio | failing 4×4 blocks | render wall | CPU | process wall | runs |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        rows = s["rows"]
        order = [("mitsuba", "Mitsuba raw")] + [(f"btfpt-{k}", f"btfpt {MODEL_LABEL[k]}")
                                                for k in ["raw"] + (MODELS if is_btf else [])]
        for key, label in order:
            r = rows.get(key)
            if not r:
                L.append(f"| {label} | failed (see above) | | | | | | | |")
                continue
            blocks = f"{r['failing_blocks']} / {r['blocks']}" if "blocks" in r else "n/a"
            L.append(f"| {label} | {fmt(r.get('relmse'))} | {fmt(r.get('mae'))} | "
                     f"{fmt(r.get('mean_luminance_ratio'), '.4f')} | {blocks} | {fmt(r.get('render_s'), '.2f')} s | "
                     f"{fmt(r.get('cpu_s'), '.2f')} s | {fmt(r.get('wall_s'), '.2f', '—')}{' s' if r.get('wall_s') else ''} | {r.get('runs', 1)} |")
        if "mitsuba" in rows and "btfpt-raw" in rows and rows["btfpt-raw"].get("render_s"):
            mi_t, bt_t = rows["mitsuba"]["render_s"], rows["btfpt-raw"]["render_s"]
            L += ["", f"Render wall time Mitsuba / btfpt (raw, {a.spp} spp, medians): {mi_t / bt_t:.2f}× "
                  "(> 1: btfpt faster). Mitsuba scene load "
                  f"{rows['mitsuba']['load_s']:.2f} s, first render incl. JIT {rows['mitsuba']['first_render_s']:.2f} s."]
        me = s.get("model_error") or {}
        if is_btf and any(k in me for k in MODELS):
            L += ["", f"Model error (btfpt at {a.hi_spp} spp, seed 2 for every model, so the path-tracing "
                  "noise largely cancels in *vs btfpt raw*; *excess* = relMSE(model, ref) − "
                  "relMSE(raw, ref), the model's share of the error against Mitsuba):", "",
                  "| model | relMSE vs btfpt raw | MAE vs btfpt raw | luminance ratio vs btfpt raw | "
                  "excess relMSE vs Mitsuba ref | render time |",
                  "| --- | --- | --- | --- | --- | --- |"]
            for k in MODELS:
                e = me.get(k)
                if not e:
                    continue
                v = e.get("vs_raw") or {}
                L.append(f"| {MODEL_LABEL[k]} | {fmt(v.get('relmse'))} | {fmt(v.get('mae'))} | "
                         f"{fmt(v.get('mean_luminance_ratio'), '.4f')} | {fmt(e.get('excess_relmse_vs_ref'))} | "
                         f"{fmt(e.get('render_s'), '.2f')} s |")
            if me.get("raw_render_s"):
                L.append(f"| raw | — | — | — | — | {me['raw_render_s']:.2f} s |")
        cols = [("reference.png", None, "Mitsuba reference"), ("mitsuba.png", "mitsuba-diff.png", f"Mitsuba {a.spp} spp")]
        cols += [(f"btfpt-{k}.png", f"btfpt-{k}-diff.png", f"btfpt {MODEL_LABEL[k]}")
                 for k in ["raw"] + (MODELS if is_btf else [])]
        cols = [c for c in cols if (a.images / name / c[0]).is_file()]
        if cols:
            cell = lambda f, t: f"![{t}]({rel}/{name}/{f})" if f and (a.images / name / f).is_file() else ""  # noqa: E731
            L += ["", "| " + " | ".join(t for _, _, t in cols) + " |", "|" + " --- |" * len(cols),
                  "| " + " | ".join(cell(f, t) for f, _, t in cols) + " |",
                  "| " + " | ".join(cell(d, "difference") for _, d, _ in cols) + " |"]
        L.append("")
    return "\n".join(L)


if __name__ == "__main__":
    sys.exit(main())
