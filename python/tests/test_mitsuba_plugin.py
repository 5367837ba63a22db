"""btfpt.mitsuba: Mitsuba 3 renders a fitted .plmc through the plugin and agrees with btfpt's own
render within the two renders' noise (btfpt compare's z-tests with both variances). Skipped, with
the reason printed, where the mitsuba package is not installed."""

import subprocess

import numpy as np
import pytest

from conftest import REPO

mi = pytest.importorskip("mitsuba", reason="mitsuba is not installed: the plugin test needs mitsuba==3.9.1")

PLANE = REPO / "scenes" / "btf-plane" / "scene.xml"


def variant():
    """llvm_ad_rgb where Dr.Jit finds LLVM, else scalar_rgb."""
    for v in ("llvm_ad_rgb", "scalar_rgb"):
        try:
            mi.set_variant(v)
            return v
        except Exception:  # noqa: BLE001 - a variant without its backend raises ImportError/RuntimeError
            continue
    pytest.skip("no usable Mitsuba variant")


def mitsuba_mean_and_variance(scene_path, defines, passes, spp):
    """Mean of `passes` independent renders and the variance of that mean."""
    import btfpt.mitsuba

    btfpt.mitsuba.register()
    scene = mi.load_file(str(scene_path), **defines)
    imgs = np.stack([np.array(mi.render(scene, seed=17 + p, spp=spp)) for p in range(passes)])
    return imgs.mean(0), imgs.var(0, ddof=1) / passes


def write_exr(path, a):
    mi.Bitmap(np.ascontiguousarray(a, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))


def test_plugin_render_agrees_with_btfpt(cli, material, tmp_path):
    v = variant()
    defines = {"btf": str(material["plmc"]), "width": "32", "height": "24", "uv_scale": "2"}
    passes, spp = (8, 16) if v.startswith("llvm") else (4, 4)
    mean, var = mitsuba_mean_and_variance(PLANE, defines, passes, spp)
    assert mean.shape == (24, 32, 3) and mean.mean() > 0
    write_exr(tmp_path / "mi.exr", mean)
    write_exr(tmp_path / "mi_var.exr", var)
    d = [a for k, val in defines.items() for a in ("-D", f"{k}={val}")]
    subprocess.run([str(cli), "render", str(PLANE), *d, "--spp", "256", "-o", str(tmp_path / "bt.exr"),
                    "--variance", str(tmp_path / "bt_var.exr")], check=True, capture_output=True)
    r = subprocess.run([str(cli), "compare", str(tmp_path / "mi.exr"), str(tmp_path / "bt.exr"),
                        "--test-variance", str(tmp_path / "mi_var.exr"), "--variance", str(tmp_path / "bt_var.exr")],
                       capture_output=True, text=True)
    print(r.stdout)
    assert r.returncode == 0, f"Mitsuba ({v}) through the plugin vs btfpt:\n{r.stdout}\n{r.stderr}"
    assert "PASS" in r.stdout
