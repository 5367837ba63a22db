"""Mitsuba 3.9.1 references of the `aov` integrator's channels for scenes/mitsuba-aov (read by
tests/images/mitsuba_aov.rs). Writes into reference-images/mitsuba-aov/:

  mitsuba-aov_aovs.exr      box filter: every AOV channel C (and the nested image's alpha
                            `image.A`) as its mean `C` and its per-sample variance `var.C`,
                            from Mitsuba's own `moment` integrator wrapped around the scene's
                            `aov` (with the box filter a sample lands in one pixel, so
                            m2 - mean^2 is the per-sample variance of the pixel's samples)
  mitsuba-aov_gaussian.exr  the scene with the Gaussian filter, as Mitsuba's film writes it
                            (its channel names are the ones btfpt must write)
  mitsuba-aov.json          spp, seed, versions

Variant scalar_rgb: in the JIT variants Mitsuba's shape_index AOV is the shape's pointer id,
in the scalar ones 1 + the shape's index in the scene (what btfpt writes).
Usage: reference-images/.venv/bin/python reference-images/aov_reference.py [--spp 4096]
"""
import argparse, json, os, re, sys, time
import numpy as np
import mitsuba as mi
import drjit as dr

mi.set_variant("scalar_rgb")
here = os.path.dirname(os.path.abspath(__file__))
scene_dir = os.path.join(here, "..", "scenes", "mitsuba-aov")
out_dir = os.path.join(here, "mitsuba-aov")

ap = argparse.ArgumentParser()
ap.add_argument("--spp", type=int, default=4096)
ap.add_argument("--seed", type=int, default=7)
args = ap.parse_args()
os.makedirs(out_dir, exist_ok=True)

text = open(os.path.join(scene_dir, "scene.xml")).read()
# Wrap the scene's aov integrator in a moment integrator named "m".
start = text.index('<integrator type="aov">')
end = text.index("</integrator>\n    </integrator>") + len("</integrator>\n    </integrator>")
wrapped = (text[:start] + '<integrator type="moment">\n' + text[start:end].replace(
    '<integrator type="aov">', '<integrator type="aov" name="m">', 1) + "\n</integrator>" + text[end:])
tmp = os.path.join(scene_dir, "_moment_tmp.xml")
open(tmp, "w").write(wrapped)
try:
    t0 = time.time()
    scene = mi.load_file(tmp, spp=str(args.spp))
    mi.render(scene, seed=args.seed)
    film = scene.sensors()[0].film()
    bmp = film.bitmap()
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    a = np.array(bmp, dtype=np.float32)
finally:
    os.remove(tmp)
print("moment channels:", names)
idx = {n: i for i, n in enumerate(names)}
out_names, planes = [], []
for n in names:
    m = re.fullmatch(r"m\.(.*)", n)
    # Skip the moment's XYZ of the aov's colour (m.X, m.Y, m.Z) and the nested image's colour.
    if not m or "." not in m.group(1) or m.group(1) in ("image.R", "image.G", "image.B"):
        continue
    c = m.group(1)
    mean = a[:, :, idx[n]].astype(np.float64)
    m2 = a[:, :, idx["m2_" + n]].astype(np.float64)
    out_names += [c, "var." + c]
    planes += [mean, np.maximum(m2 - mean * mean, 0.0)]
arr = np.stack(planes, axis=2).astype(np.float32)
mi.Bitmap(arr, mi.Bitmap.PixelFormat.MultiChannel, channel_names=out_names).write(
    os.path.join(out_dir, "mitsuba-aov_aovs.exr"))
box_secs = time.time() - t0

t0 = time.time()
scene = mi.load_file(os.path.join(scene_dir, "scene.xml"), spp=str(args.spp), filter="gaussian")
mi.render(scene, seed=args.seed)
bmp = scene.sensors()[0].film().bitmap()
bmp.write(os.path.join(out_dir, "mitsuba-aov_gaussian.exr"))
gauss_names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
json.dump({"scene": "scenes/mitsuba-aov/scene.xml", "spp": args.spp, "seed": args.seed,
           "variant": "scalar_rgb", "mitsuba": mi.__version__, "drjit": dr.__version__,
           "aovs_channels": out_names, "gaussian_channels": gauss_names,
           "seconds": [round(box_secs, 1), round(time.time() - t0, 1)]},
          open(os.path.join(out_dir, "mitsuba-aov.json"), "w"), indent=1)
print("wrote", out_dir)
