"""btfpt.render, Scene, synth, fit and eval_model against the CLI: the same image bits and the same
figures as its JSON, and errors with its messages."""

import json
import subprocess

import numpy as np
import pytest

import btfpt
from conftest import REPO, run_cli

CORNELL = REPO / "scenes" / "cornell-box" / "scene.xml"


@pytest.mark.parametrize("integrator", ["packet", "scalar"])
def test_render_equals_cli_bits(cli, tmp_path, integrator):
    out = tmp_path / "cli.exr"
    var = tmp_path / "cli_var.exr"
    run_cli(cli, "render", CORNELL, "--spp", "4", "--seed", "3", "--integrator", integrator,
            "-o", out, "--variance", var)
    img, v = btfpt.render(CORNELL, spp=4, seed=3, integrator=integrator, variance=True, progress=False)
    assert img.dtype == np.float32 and img.shape == (128, 128, 3)
    np.testing.assert_array_equal(img, btfpt.read_image(out))
    np.testing.assert_array_equal(v, btfpt.read_image(var))


def test_scene_reused_and_threads_do_not_change_bits():
    scene = btfpt.Scene.load(CORNELL)
    assert scene.size == (128, 128) and scene.spp == 64 and scene.btf_uses == []
    a = btfpt.render(scene, spp=2, threads=1, progress=False)
    b = btfpt.render(scene, spp=2, threads=2, progress=False)
    np.testing.assert_array_equal(a, b)
    assert a.mean() > 0


def test_btf_scene_summary(material, tmp_path):
    xml = tmp_path / "plane.xml"
    xml.write_text(f"""<scene version="3.0.0">
  <integrator type="path"/>
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,3" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
  </sensor>
  <shape type="rectangle"><bsdf type="btf"><string name="filename" value="{material['plmc']}"/></bsdf></shape>
  <emitter type="constant"/>
</scene>""")
    s = btfpt.Scene.load(xml)
    assert [(u["model"], u["texels"]) for u in s.btf_uses] == [("plmc", (8, 8))]
    assert btfpt.render(s, spp=2, progress=False).mean() > 0


def test_render_errors(tmp_path):
    with pytest.raises(btfpt.errors.MissingFileError, match="nope.xml: scene file not found"):
        btfpt.render(tmp_path / "nope.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0"><shape type="teapot"/></scene>')
    with pytest.raises(btfpt.errors.SceneError, match="bad.xml:1"):
        btfpt.Scene.load(bad)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match='integrator "fast"'):
        btfpt.render(CORNELL, integrator="fast")


def test_fit_and_eval_match_cli(cli, material, tmp_path):
    data = material["data"]
    r = btfpt.fit(data, tmp_path / "py.plmc", clusters=16, progress=False)
    run_cli(cli, "fit", data, "-o", tmp_path / "cli.plmc", "--clusters", "16")
    # The same model, byte for byte, and the figures fit prints.
    assert (tmp_path / "py.plmc").read_bytes() == (tmp_path / "cli.plmc").read_bytes()
    assert r["bytes"] == (tmp_path / "cli.plmc").stat().st_size
    assert r["model"] == "plmc" and r["clusters"] == (16, 16) and r["size"] == (8, 8)
    assert r["ratio"] == pytest.approx(r["raw_bytes"] / r["bytes"])
    assert not (tmp_path / "py.plmc.parts").exists()
    doc = btfpt.eval_model(tmp_path / "py.plmc", data, clusters=16, progress=False)
    run_cli(cli, "eval", tmp_path / "cli.plmc", "--against", data, "--clusters", "16",
            "--json", tmp_path / "cli.json")
    assert doc == json.loads((tmp_path / "cli.json").read_text())
    assert doc["models"]["plmc"]["mae"] > 0


def test_synth_matches_cli(cli, tmp_path):
    btfpt.synth("foil", size=4, seed=2, out=tmp_path / "py", format="exr", progress=False)
    run_cli(cli, "synth", "foil", "--size", "4", "--seed", "2", "--format", "exr", "-o", tmp_path / "cli")
    a = btfpt.Btf.open(tmp_path / "py")
    b = btfpt.Btf.open(tmp_path / "cli")
    for v, l in [(0, 0), (40, 17), (80, 80)]:
        np.testing.assert_array_equal(a.texel_image(v, l), b.texel_image(v, l))
    with pytest.raises(btfpt.errors.InvalidArgumentError, match="already exists"):
        btfpt.synth("foil", size=4, out=tmp_path / "py")
    with pytest.raises(btfpt.errors.InvalidArgumentError, match="velvet"):
        btfpt.synth("velvet", size=4, out=tmp_path / "v")


def test_fit_errors(material, tmp_path):
    with pytest.raises(btfpt.errors.MissingFileError, match="nodata: BTF data not found"):
        btfpt.fit(tmp_path / "nodata", tmp_path / "x.plmc")
    with pytest.raises(btfpt.errors.InvalidArgumentError, match='model "pca"'):
        btfpt.fit(material["data"], tmp_path / "x.plmc", model="pca")
    with pytest.raises(btfpt.errors.MissingFileError, match="none.plmc: model file not found"):
        btfpt.eval_model(tmp_path / "none.plmc", material["data"])


def test_compare_equals_cli_json(cli, tmp_path):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    for out, seed in [(a, 1), (b, 2)]:
        run_cli(cli, "render", CORNELL, "--spp", "4", "--seed", seed, "-o", out, "--variance",
                str(out).replace(".exr", "_var.exr"))
    av, bv = tmp_path / "a_var.exr", tmp_path / "b_var.exr"
    doc = btfpt.compare(a, b, test_variance=av, variance=bv)
    r = subprocess.run([str(cli), "compare", a, b, "--test-variance", av, "--variance", bv,
                        "--json", tmp_path / "cli.json"], capture_output=True, text=True)
    assert doc == json.loads((tmp_path / "cli.json").read_text())
    assert doc["statistical_test"] and doc["passed"] == (r.returncode == 0)
    # Without a variance nothing is tested.
    doc = btfpt.compare(a, b)
    assert doc["passed"] is None and doc["comparison"]["mae"] > 0
    with pytest.raises(btfpt.errors.MissingFileError, match="cannot read the reference: .*nope.exr"):
        btfpt.compare(a, tmp_path / "nope.exr")
    with pytest.raises(btfpt.errors.InvalidArgumentError, match=r"--alpha 2: must be in \(0, 1\)"):
        btfpt.compare(a, b, alpha=2)


def test_synth_sources_read_as_cli(cli, tmp_path, monkeypatch):
    # A synth: source is generated once into the cache folder, as the CLI does, and every call
    # then reads that entry: the same model bytes and the same eval figures as the CLI's.
    cache = tmp_path / "cache"
    monkeypatch.setenv("BTFPT_CACHE_DIR", str(cache))
    src = "synth:leather?size=4&seed=2&strata=1"
    r = btfpt.fit(src, tmp_path / "py.plmc", clusters=4, progress=False)
    (entry,) = cache.iterdir()
    assert entry.suffix == ".btfc" and r["size"] == (4, 4)
    run_cli(cli, "fit", src, "-o", tmp_path / "cli.plmc", "--clusters", "4")
    assert (tmp_path / "py.plmc").read_bytes() == (tmp_path / "cli.plmc").read_bytes()
    assert list(cache.iterdir()) == [entry]
    doc = btfpt.eval_model(tmp_path / "py.plmc", src, clusters=4, progress=False)
    run_cli(cli, "eval", tmp_path / "cli.plmc", "--against", src, "--clusters", "4",
            "--json", tmp_path / "cli.json")
    assert doc == json.loads((tmp_path / "cli.json").read_text())
    a, b = btfpt.Btf.open(src), btfpt.Btf.open(entry)
    assert a.kind == b.kind == "raw" and a.size == (4, 4)
    for v, l in [(0, 0), (40, 17)]:
        np.testing.assert_array_equal(a.texel_image(v, l), b.texel_image(v, l))
    with pytest.raises(btfpt.errors.InvalidArgumentError, match="velvet"):
        btfpt.fit("synth:velvet", tmp_path / "v.plmc", progress=False)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match="size=0"):
        btfpt.eval_model(tmp_path / "py.plmc", "synth:wool?size=0", progress=False)
