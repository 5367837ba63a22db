#!/usr/bin/env python3
"""Same image, two renderers, same material: Mitsuba 3 renders a scene with a fitted .plmc through
btfpt's plugin (btfpt.mitsuba), btfpt renders it itself, and `btfpt compare` tests the two within
both renders' noise (Mitsuba's variance of the mean from independent passes, btfpt's from
`render --variance`): the *renderer's* error. With --raw DATA (the measured data the model was
fitted to), Mitsuba also renders the raw data through the raw-BTF plugin of reference-images/
(btf_plugin.py) and compare tests raw against PLM-C, both Mitsuba: the *model's* error, with the
renderer held fixed. Prints compare's reports; writes mitsuba.exr, mitsuba_var.exr, btfpt.exr,
btfpt_var.exr, compare.json (and mitsuba_raw.exr, mitsuba_raw_var.exr, compare_model.json) into
--out. Exit status: that of the renderer comparison.

usage: scripts/plugin_vs_btfpt.py SCENE.xml --plmc MODEL.plmc [--raw DATA] [-D name=value ...]
           [--passes 8] [--spp 16] [--btfpt-spp 256] [--out DIR] [--btfpt target/release/btfpt]

Run it with a Python that has mitsuba==3.9.1 and the btfpt module (see bench_mitsuba_plugin.py).
The scene takes the material's file through the define `btf` (as scenes/btf-plane/scene.xml).
reference-images/make_report.py imports `two_renderers` for REPORT.md's plugin section.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def register(plugin: str) -> None:
    """Registers Mitsuba's `btf` BSDF as btfpt's plugin ("plmc": btfpt.mitsuba, any btfpt
    material) or as the raw-BTF plugin of reference-images/ ("raw": btf_plugin.py)."""
    if plugin == "plmc":
        import btfpt.mitsuba

        btfpt.mitsuba.register()
    else:
        sys.path.insert(0, str(REPO / "reference-images"))
        import btf_plugin

        btf_plugin.register()


def mitsuba_mean_var(scene: Path, material, plugin: str, defines: dict, passes: int, spp: int,
                     seed: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    """Mitsuba (variant already set) renders `scene` with `material` (define `btf`) through
    `plugin` in `passes` independent passes of `spp`: their mean and the variance of that mean."""
    import mitsuba as mi

    register(plugin)
    d = dict(defines) | {"btf": str(Path(material).resolve())}
    s = mi.load_file(str(scene), **d)
    imgs = np.stack([np.array(mi.render(s, seed=seed + p, spp=spp)) for p in range(passes)])
    return imgs.mean(0), imgs.var(0, ddof=1) / passes


def write_exr(path: Path, a: np.ndarray) -> None:
    """An (H, W, 3) array as an RGB float EXR."""
    import mitsuba as mi

    mi.Bitmap(np.ascontiguousarray(a, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))


def compare(btfpt: Path, test: Path, ref: Path, test_var: Path, var: Path, out_json: Path) -> tuple[dict, str]:
    """`btfpt compare` with both images' variances: its JSON document and its printed report."""
    r = subprocess.run([str(btfpt), "compare", str(test), str(ref), "--test-variance", str(test_var),
                        "--variance", str(var), "--json", str(out_json)], capture_output=True, text=True)
    if not out_json.is_file():
        raise RuntimeError(f"btfpt compare {test} {ref} failed ({r.returncode}): {r.stderr.strip()[-600:]}")
    return json.loads(out_json.read_text()), r.stdout + r.stderr


def two_renderers(scene: Path, plmc: Path, raw: Path | None = None, defines: dict | None = None,
                  passes: int = 8, spp: int = 16, btfpt_spp: int = 256, variant: str = "llvm_ad_rgb",
                  out: Path = Path("plugin_vs_btfpt"), btfpt: Path = REPO / "target" / "release" / "btfpt") -> dict:
    """The renderer's error (Mitsuba PLM-C plugin vs btfpt PLM-C) and, with `raw`, the model's
    (Mitsuba raw-BTF plugin vs Mitsuba PLM-C plugin): {"renderer": (compare doc, report),
    "model": (compare doc, report) or None}. Images and JSON go to `out`."""
    import mitsuba as mi

    if passes < 2:
        raise ValueError("passes must be at least 2 (the variance of the mean needs two)")
    mi.set_variant(variant)
    defines = dict(defines or {})
    out.mkdir(parents=True, exist_ok=True)
    # The raw plugin first: btfpt.mitsuba.register() turns off Dr.Jit's symbolic loops and calls
    # for the rest of the process (it needs evaluated wavefronts); the raw plugin works either way.
    model = None
    if raw is not None:
        mean, var = mitsuba_mean_var(scene, raw, "raw", defines, passes, spp)
        write_exr(out / "mitsuba_raw.exr", mean)
        write_exr(out / "mitsuba_raw_var.exr", var)
    mean, var = mitsuba_mean_var(scene, plmc, "plmc", defines, passes, spp)
    write_exr(out / "mitsuba.exr", mean)
    write_exr(out / "mitsuba_var.exr", var)
    if raw is not None:
        model = compare(btfpt, out / "mitsuba.exr", out / "mitsuba_raw.exr", out / "mitsuba_var.exr",
                        out / "mitsuba_raw_var.exr", out / "compare_model.json")
    d = [a for k, v in (defines | {"btf": str(Path(plmc).resolve())}).items() for a in ("-D", f"{k}={v}")]
    subprocess.run([str(btfpt), "render", str(scene), *d, "--spp", str(btfpt_spp),
                    "-o", str(out / "btfpt.exr"), "--variance", str(out / "btfpt_var.exr")],
                   check=True, capture_output=True)
    renderer = compare(btfpt, out / "mitsuba.exr", out / "btfpt.exr", out / "mitsuba_var.exr",
                       out / "btfpt_var.exr", out / "compare.json")
    return {"renderer": renderer, "model": model}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--plmc", required=True, type=Path)
    ap.add_argument("--raw", type=Path, help="the measured data of the model: also the model's error")
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
    for p, what in [(args.scene, "scene"), (args.plmc, "model"), (args.btfpt, "btfpt binary"),
                    (args.raw, "raw data")]:
        if p is not None and not p.exists():
            sys.exit(f"{p}: {what} not found")
    r = two_renderers(args.scene, args.plmc, args.raw, dict(d.split("=", 1) for d in args.defines),
                      args.passes, args.spp, args.btfpt_spp, args.variant, args.out, args.btfpt)
    if r["model"]:
        print(f"Model: Mitsuba {args.variant}, raw-BTF plugin on {args.raw} vs btfpt.mitsuba on {args.plmc} "
              f"({args.passes} × {args.spp} spp each), {args.scene}:")
        print(r["model"][1])
    print(f"Renderer: Mitsuba {args.variant} through btfpt.mitsuba ({args.passes} × {args.spp} spp) vs btfpt "
          f"({args.btfpt_spp} spp), {args.scene}, {args.plmc}:")
    print(r["renderer"][1])
    return 0 if r["renderer"][0].get("passed") else 1


if __name__ == "__main__":
    sys.exit(main())
