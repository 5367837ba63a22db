#!/usr/bin/env python3
"""False-alarm rate and power of `btfpt compare`'s calibrated verdict against the committed
Mitsuba references (reference-images/), as docs/model.md reports them.

For each scene, SEEDS renders at SPP of the unchanged scene (a correct render: every failure is a
false alarm) and of each fault (every pass is a miss) are compared with the reference in two ways:
  with    the reference's per-sample variance predicts the test's noise (`--spp N`, which also
          adds the reference's variance of its mean): the Mitsuba pipeline writes both;
  without no reference variance, the test's own variance (`render --variance`) only, as for a
          reference written without one.
A fault whose power is below 95 % at SPP is run again at 4x the spp, up to MAX_SPP.

usage: scripts/compare_calibration.py [--seeds 20] [--spp 64] [--max-spp 1024] [--json out.json]
       [--scenes a,b] [--no-faults | --faults WORD,...] [--renders DIR]
With --renders DIR every render is kept there (named by scene, fault, spp and seed) and reused
by a later run, so a change to `compare` can be measured again without rendering.
Needs target/release/btfpt (cargo build --release), or the binary named by $BTFPT. Only the
standard library.
"""

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("BTFPT", os.path.join(ROOT, "target", "release", "btfpt"))


def scale_values(text, names, factor):
    """Multiplies every `<rgb|float name="NAME" value="a, b, c"/>` of the given names."""
    def repl(m):
        vals = [float(v) * factor for v in m.group(3).split(",")]
        return f'{m.group(1)}name="{m.group(2)}" value="{", ".join(f"{v:.9g}" for v in vals)}"'
    pat = r'(<(?:rgb|float|spectrum)\s+)name="(' + "|".join(names) + r')"\s+value="([^"]+)"'
    out, n = re.subn(pat, repl, text)
    assert n > 0, f"no {names} found"
    return out


def brighter(text):
    """1 % more light: every emitter's radiance/intensity/irradiance and the envmap's scale."""
    text = scale_values(text, ["radiance", "intensity", "irradiance"], 1.01) \
        if re.search(r'name="(radiance|intensity|irradiance)"', text) else text
    if 'type="envmap"' in text:
        text = re.sub(r'(<emitter type="envmap">.*?<float name="scale" value=")([^"]+)"',
                      lambda m: f'{m.group(1)}{float(m.group(2)) * 1.01:.9g}"', text, flags=re.S)
    return text


def red_wall(text):
    """The red wall's albedo 2 % higher."""
    return re.sub(r'(<bsdf type="diffuse" id="red">\s*<rgb name="reflectance" value=")([^"]+)"',
                  lambda m: m.group(1) + ", ".join(f"{float(v) * 1.02:.9g}" for v in m.group(2).split(",")) + '"',
                  text, count=1)


def light_moved(text):
    """The Cornell box's light moved by 1 % of the box (0.02 of its 2-unit side) along x."""
    out = text.replace('<translate x="0" y="0.99" z="0"/>', '<translate x="0.02" y="0.99" z="0"/>')
    assert out != text
    return out


def rougher(text):
    """The gold roughconductor's alpha 10 % higher (0.15 -> 0.165)."""
    out = re.sub(r'(<bsdf type="roughconductor" id="gold">.*?<float name="alpha" value=")0.15"',
                 r'\g<1>0.165"', text, count=1, flags=re.S)
    assert out != text
    return out


def btf_rotated(tmp):
    """The BTF turned 90 degrees in uv: the torus's texture coordinates (u, v) -> (1 - v, u)."""
    src = os.path.join(ROOT, "scenes", "cornell-box-all", "torus.obj")
    dst = os.path.join(tmp, "torus-uv90.obj")
    with open(src) as f, open(dst, "w") as g:
        for line in f:
            if line.startswith("vt "):
                u, v = map(float, line.split()[1:3])
                line = f"vt {1.0 - v:.6f} {u:.6f}\n"
            g.write(line)

    def edit(text):
        out = text.replace('value="../cornell-box-all/torus.obj"', f'value="{dst}"')
        assert out != text
        return out
    return edit


def run(cmd, log):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    with open(log, "a") as f:
        f.write(" ".join(cmd) + "\n" + r.stdout + "\n")
    return r.returncode


def verdict(test, var, ref, spp, mode, tmp, log):
    """True when `compare` passes the render (exit 0)."""
    js = os.path.join(tmp, "cmp.json")
    if mode == "with":
        args = ["--spp", str(spp)]
    else:
        args = ["--test-variance", var]
    rc = run([BIN, "compare", test, ref, *args, "--json", js], log)
    with open(js) as f:
        doc = json.load(f)
    assert doc["passed"] is not None, "no statistical test ran"
    assert (rc == 0) == doc["passed"]
    return doc["passed"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-spp", type=int, default=1024)
    ap.add_argument("--json")
    ap.add_argument("--no-faults", action="store_true", help="only the correct renders (false alarms)")
    ap.add_argument("--scenes", default="cornell-box,cornell-box-all,btf-sphere,mitsuba-bsdfs")
    ap.add_argument("--faults", help="only the faults whose names contain one of these comma-separated words")
    ap.add_argument("--renders", help="keep the renders in this folder and reuse the ones already there")
    a = ap.parse_args()
    if not os.path.isfile(BIN):
        sys.exit(f"{BIN} not found: run cargo build --release first")
    # A kill still runs the `finally` that removes the fault scenes written beside the scenes.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit("terminated"))
    tmp = tempfile.mkdtemp(prefix="btfpt-calib-")
    if a.renders:
        os.makedirs(a.renders, exist_ok=True)
    log = os.path.join(tmp, "log.txt")
    # The BTF of btf-sphere once as a folder (a synth: URI would be regenerated per render), as
    # the Mitsuba reference was made.
    btf = os.path.join(tmp, "corduroy32")
    assert run([BIN, "synth", "corduroy", "--size", "32", "--seed", "1", "--format", "exr", "-o", btf], log) == 0
    scenes = {
        "cornell-box": ([], {"1 % brighter": brighter, "red wall albedo +2 %": red_wall,
                             "light moved 1 % of the box": light_moved}),
        "cornell-box-all": ([], {"1 % brighter": brighter, "gold roughness +10 %": rougher}),
        "btf-sphere": (["-D", f"btf={btf}"], {"1 % brighter": brighter, "BTF rotated 90° in uv": btf_rotated(tmp)}),
        "mitsuba-bsdfs": ([], {"1 % brighter": brighter}),
    }
    results = []
    written = []
    try:
        for name in a.scenes.split(","):
            defines, faults = scenes[name]
            xml = os.path.join(ROOT, "scenes", name, "scene.xml")
            ref = os.path.join(ROOT, "reference-images", name, f"{name}.exr")
            with open(xml) as f:
                base = f.read()
            if a.faults:
                faults = {k: v for k, v in faults.items() if any(w in k for w in a.faults.split(","))}
            variants = ([] if a.faults else [("none (correct render)", None)]) + \
                ([] if a.no_faults else list(faults.items()))
            for fault, edit in variants:
                spp = a.spp
                while True:
                    if edit is None:
                        scene = xml
                    else:
                        scene = os.path.join(ROOT, "scenes", name, f".fault-{os.getpid()}.xml")
                        written.append(scene)
                        with open(scene, "w") as f:
                            f.write(edit(base))
                    fails = {"with": 0, "without": 0}
                    t0 = time.time()
                    for seed in range(1, a.seeds + 1):
                        if a.renders:
                            tag = re.sub(r"[^a-z0-9]+", "-", fault.lower()).strip("-")
                            out = os.path.join(a.renders, f"{name}.{tag}.{spp}spp.seed{seed}.exr")
                        else:
                            out = os.path.join(tmp, "t.exr")
                        var = out[:-4] + "_var.exr"
                        if not (a.renders and os.path.exists(out) and os.path.exists(var)):
                            rc = run([BIN, "render", scene, "--spp", str(spp), "--seed", str(seed), "-o", out,
                                      "--variance", var, *defines], log)
                            assert rc == 0, f"render failed, see {log}"
                        for mode in fails:
                            fails[mode] += not verdict(out, var, ref, spp, mode, tmp, log)
                    row = {"scene": name, "fault": fault, "spp": spp, "seeds": a.seeds,
                           "failed_with": fails["with"], "failed_without": fails["without"],
                           "seconds": round(time.time() - t0, 1)}
                    results.append(row)
                    print(json.dumps(row), flush=True)
                    power = min(fails.values()) / a.seeds
                    if edit is None or power >= 0.95 or spp * 4 > a.max_spp:
                        break
                    spp *= 4
    finally:
        for p in written:
            if os.path.exists(p):
                os.remove(p)
    print()
    print(f"| scene | fault | spp | fails, with the reference's variance | fails, without |")
    print("|---|---|---|---|---|")
    for r in results:
        kind = "false alarms" if r["fault"].startswith("none") else "detected"
        print(f"| {r['scene']} | {r['fault']} | {r['spp']} | {r['failed_with']}/{r['seeds']} {kind} "
              f"| {r['failed_without']}/{r['seeds']} |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    print(f"log: {log}")


if __name__ == "__main__":
    main()
