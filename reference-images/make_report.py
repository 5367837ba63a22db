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
    are the figures tests/images/plmc.rs takes its bounds from.
The BTF material is synth:corduroy?size=32&seed=1 written by `btfpt synth` as a UBO2003 EXR
folder (what the references were rendered from), fitted with `btfpt fit` defaults; both renderers
read that folder (-D btf=...). Everything runs in one process, scene after scene, so the timings
of the two renderers are side by side under the same machine load (the load average is recorded
before and after each scene; on a shared machine compare CPU times).
Last (btfpt.mitsuba.register() changes Dr.Jit's flags for the rest of the process), Mitsuba with
btfpt's plugin (python/, built into the .venv by make_report.sh), through the functions of
scripts/plugin_vs_btfpt.py and scripts/bench_mitsuba_plugin.py:
  * per BTF scene, the model's error (Mitsuba raw-BTF plugin vs Mitsuba PLM-C plugin, the
    renderer held fixed) and the renderer's (Mitsuba PLM-C plugin vs btfpt PLM-C, the model held
    fixed), each `btfpt compare` with both images' variances (--plugin-passes independent Mitsuba
    passes of --plugin-spp, btfpt at --hi-spp with --variance);
  * Mitsuba's CPU time and memory with either plugin on btf-plane at --spp (in passes of
    --plugin-pass-spp) on a --plugin-size² corduroy (synth + fit, kept in target/bench-plugin),
    one process per render, --runs alternated runs.
--sections plugin reruns only that part and merges it into report/report.json and REPORT.md.
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
PLUGIN_BENCH_SCENE = "scenes/btf-plane/scene.xml"

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
    return figures(json.loads(out.read_text()))


def figures(doc: dict) -> dict:
    """The figures of a `btfpt compare --json` document the report shows."""
    c = doc["comparison"]
    r = {k: c[k] for k in ("relmse", "mae", "rmse", "mean_luminance_ratio")}
    b = c.get("block_test")
    if b:
        r["failing_blocks"], r["blocks"] = b["failing"], b["cells"]
        r["mean_z"] = (c.get("pixel_test") or {}).get("mean_z")
    if doc.get("passed") is not None:
        r["passed"], r["failures"] = doc["passed"], doc.get("failures", [])
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


def plugin_section(btfpt: Path, mat: Path, plmc: Path, work: Path, a) -> dict:
    """Mitsuba with btfpt's plugin (the module doc says what): the two renderers' comparisons per
    BTF scene and the plugins' speed and memory. Call it after every other Mitsuba render of the
    process (btfpt.mitsuba.register() changes Dr.Jit's flags)."""
    sys.path.insert(0, str(ROOT / "scripts"))
    import bench_mitsuba_plugin as bench
    import plugin_vs_btfpt as pvb

    info = machine_info()
    res: dict = {"date_utc": info["date_utc"], "commit": info["commit"], "load_before": os.getloadavg(),
                 "settings": {k: getattr(a, k) for k in ("spp", "hi_spp", "runs", "plugin_size", "plugin_spp",
                                                          "plugin_passes", "plugin_pass_spp", "threads")},
                 "bench_scene": PLUGIN_BENCH_SCENE, "scenes": {}}
    for xml_rel, name, is_btf in SCENES:
        if not is_btf or (a.only and name not in a.only):
            continue
        print(f"== plugin: {name}", file=sys.stderr)
        r = step(f"plugin: {name}: two renderers", pvb.two_renderers, ROOT / xml_rel, plmc, mat, {},
                 a.plugin_passes, a.plugin_spp, a.hi_spp, "llvm_ad_rgb", work / "plugin" / name, btfpt)
        if r:
            res["scenes"][name] = {"model": figures(r["model"][0]), "renderer": figures(r["renderer"][0])}
    print("== plugin: speed and memory", file=sys.stderr)
    m = step("plugin: material", bench.make_material, btfpt, "corduroy", a.plugin_size, 1,
             ROOT / "target" / "bench-plugin")
    if m:
        b = step("plugin: speed and memory", bench.bench, ROOT / PLUGIN_BENCH_SCENE, *m, a.spp, [], a.runs,
                 a.plugin_pass_spp, 0, "llvm_ad_rgb", None, log=lambda t: print(t, file=sys.stderr))
        if b:
            res["bench"] = b | {"material": bench.material_bytes(*m)}
    res["load_after"] = os.getloadavg()
    return res


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
    ap.add_argument("--sections", choices=["all", "plugin"], default="all",
                    help="plugin: rerun only the Mitsuba plugin section, merged into the existing report")
    ap.add_argument("--plugin-size", type=int, default=128, help="texels per side of the plugin bench's material")
    ap.add_argument("--plugin-passes", type=int, default=8, help="Mitsuba passes of the two-renderer comparisons")
    ap.add_argument("--plugin-spp", type=int, default=16, help="spp of each of those passes")
    ap.add_argument("--plugin-pass-spp", type=int, default=4, help="spp per pass of the plugin bench's renders")
    a = ap.parse_args(argv)
    if min(a.spp, a.hi_spp, a.threads, a.runs, a.plugin_size, a.plugin_spp, a.plugin_pass_spp) < 1:
        ap.error("--spp, --hi-spp, --threads, --runs and the --plugin-* sizes must be positive")
    if a.plugin_passes < 2:
        ap.error("--plugin-passes must be at least 2 (the variance of the mean needs two)")
    earlier = None
    if a.sections != "all":
        try:
            earlier = json.loads((a.images / "report.json").read_text())
        except (OSError, ValueError) as e:
            sys.exit(f"{a.images / 'report.json'}: cannot read the report to merge into ({e}); run all sections")
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
            for m in MODELS if earlier is None else ["plmc"]:
                f = work / f"corduroy.{m}.plmc"
                r = step(f"btfpt fit {m}", run, [btfpt, "fit", mat, "-o", f, "--model", m])
                if r:
                    mres[m] = {"fit_wall_s": r[1], "fit_cpu_s": r[2], "bytes": f.stat().st_size,
                               "summary": r[0].stderr.strip().splitlines()[-2:]}
        if earlier is None:
            shutil.rmtree(a.images, ignore_errors=True)
        for xml_rel, name, is_btf in SCENES:
            if (a.only and name not in a.only) or earlier is not None:
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
        plmc = work / "corduroy.plmc.plmc"
        if mitsuba and plmc.is_file():
            results["plugin"] = plugin_section(btfpt, mat, plmc, work, a)
        else:
            ERRORS.append("plugin: skipped (Mitsuba or the PLM-C fit of the material is missing)")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    info["load_end"] = os.getloadavg()
    results["errors"] = ERRORS
    if earlier is not None:
        # Only the plugin section is new: everything else, and the settings the other sections
        # were made with, come from the earlier run.
        earlier["errors"] = [e for e in earlier.get("errors", []) if not e.startswith("plugin")] + ERRORS
        earlier["plugin"] = results.get("plugin")
        results = earlier
        a = argparse.Namespace(**(vars(a) | {k: earlier["settings"][k] for k in ("spp", "hi_spp", "threads", "runs")}))
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
         "Generated by `reference-images/make_report.sh` (do not edit by hand; rerun it). Every figure "
         "below comes from that one run" + (" (the plugin section, which can be rerun alone, says when it ran)"
                                            if res.get("plugin") else "") + ". What is measured and how: the docstring of",
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
    if res.get("plugin"):
        L += plugin_markdown(res["plugin"])
    return "\n".join(L)


def plugin_markdown(p: dict) -> list[str]:
    """The section of Mitsuba with btfpt's plugin (see `plugin_section`)."""
    la = lambda t: " / ".join(f"{x:.2f}" for x in t)  # noqa: E731
    st = p["settings"]
    L = ["## Mitsuba with btfpt's plugin", "",
         f"Run {p['date_utc']} at commit `{p['commit']}`; load average {la(p['load_before'])} → "
         f"{la(p['load_after'])}. Mitsuba 3 renders the BTF scenes with the 32² corduroy above twice: "
         "through the raw-BTF plugin of this folder (`btf_plugin.py`) on the measured data, and through "
         "btfpt's plugin (`btfpt.mitsuba`, `python/`) on its PLM-C fit. *Model*: Mitsuba raw vs "
         "Mitsuba PLM-C, the renderer held fixed, so what differs is the model's error. *Renderer*: "
         "Mitsuba PLM-C vs btfpt PLM-C, the model held fixed, so what differs is the renderers'. "
         f"Each is `btfpt compare` with both images' variances (Mitsuba: the mean of {st['plugin_passes']} "
         f"independent passes of {st['plugin_spp']} spp and the variance of that mean; btfpt: "
         f"{st['hi_spp']} spp with `--variance`); the verdict is compare's calibrated one "
         "(`scripts/plugin_vs_btfpt.py SCENE --plmc MODEL --raw DATA` makes the same figures). The "
         "renderer comparison must pass; the model comparison fails wherever the model's error is "
         "larger than the two renders' noise, so its figures, not its verdict, say how large it is.", "",
         "| scene | comparison | relMSE | MAE | luminance ratio | failing 4×4 blocks | verdict |",
         "| --- | --- | --- | --- | --- | --- | --- |"]
    label = {"model": "model: Mitsuba raw vs Mitsuba PLM-C", "renderer": "renderer: Mitsuba PLM-C vs btfpt PLM-C"}
    for name, sc in p["scenes"].items():
        for k in ("model", "renderer"):
            r = sc.get(k) or {}
            blocks = f"{r['failing_blocks']} / {r['blocks']}" if "blocks" in r else "n/a"
            # Each failure's first clause (the full sentences, with the worst pixels, are in
            # report.json).
            verdict = "n/a" if "passed" not in r else "PASS" if r["passed"] else \
                "FAIL: " + "; ".join(f.split(";")[0].split(" (")[0] for f in r["failures"])
            L.append(f"| {name} | {label[k]} | {fmt(r.get('relmse'))} | {fmt(r.get('mae'))} | "
                     f"{fmt(r.get('mean_luminance_ratio'), '.4f')} | {blocks} | {verdict} |")
    b = p.get("bench")
    if b:
        m, med, ratio = b["material"], b["median"], b["ratio"]
        mib = lambda x: f"{x / 2**20:.1f} MiB"  # noqa: E731
        L += ["", f"Speed and memory: Mitsuba renders `{p['bench_scene']}` at {st['spp']} spp (in passes of "
              f"{b['pass_spp']} spp) with a {m['size'][0]}×{m['size'][1]}-texel corduroy ({m['views']} × "
              f"{m['lights']} directions, `btfpt synth corduroy --size {st['plugin_size']} --seed 1` and "
              "`btfpt fit` defaults), one process per render, both plugins in alternated runs "
              f"({st['runs']} each, medians; `scripts/bench_mitsuba_plugin.py {p['bench_scene']} --size "
              f"{st['plugin_size']} --spp {st['spp']} --pass-spp {st['plugin_pass_spp']}`). *Material* = "
              "resident memory after loading the scene minus before: what the material itself holds, "
              "apart from the fixed cost of Python, Mitsuba and LLVM that every process pays. The raw "
              f"plugin's table is {mib(m['raw_float32_bytes'])} of float32 ({mib(m['raw_file_bytes'])} "
              f"as a half-float `.btfc`), the `.plmc` file {mib(m['plmc_file_bytes'])}: "
              f"{m['raw_float32_bytes'] / m['plmc_file_bytes']:.0f}×.", "",
              "| plugin | CPU | peak resident | material resident | scene load | render |",
              "| --- | --- | --- | --- | --- | --- |"]
        for w, lab in (("raw", "raw-BTF (`btf_plugin.py`)"), ("plmc", "PLM-C (`btfpt.mitsuba`)")):
            x = med[w]
            L.append(f"| {lab} | {x['cpu']:.1f} s | {x['peak_mib']:.0f} MiB | {x['material_mib']:.0f} MiB | "
                     f"{x['load']:.2f} s | {x['render']:.2f} s |")
        fx = lambda v: "n/a" if v is None else f"{v:.1f}×"  # noqa: E731
        L.append(f"| raw / PLM-C | {fx(ratio['cpu'])} | {fx(ratio['peak_mib'])} | {fx(ratio['material_mib'])} | "
                 f"{fx(ratio['load'])} | {fx(ratio['render'])} |")
    L.append("")
    return L


if __name__ == "__main__":
    sys.exit(main())
