"""Tests of the Mitsuba `btf` plugin (run by test_plugin.sh; plain script, no pytest needed).

(a) A table B = 0.5·cos θ_l at the 81 directions against Mitsuba's `diffuse` (reflectance 0.5): the
    ratio image must equal what the *table* predicts (cos θ interpolated linearly on the disk and
    held beyond 75°), computed here with numpy, under an overhead point light and under a constant
    environment.
(b) The plugin equals a plain float64 numpy evaluation of the same conventions to float precision
    at random (uv, wi, wo), for a random table read back from a UBO2003 folder of EXR images
    (exercises the loader) and with uv_scale ≠ 1.
(c) The triangulation: sampling, Delaunay robustness report, candidate grid exactness, btfpt's
    canonical tie rule for cocircular quads.
(d) `.btfc` caches written by btfpt (`btfpt convert`; needs the built binary) read back exactly;
    `synth:` sources are refused with the btfpt command that writes them.
"""
from __future__ import annotations

import math
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
import drjit as dr  # noqa: E402

import btf_plugin as bp  # noqa: E402

bp.register()
ANG = bp.ubo2003_angles()
DIRS = bp.angles_to_dirs(ANG)
TRI = bp.build_triangulation(DIRS)


def write_ubo2003_png(folder: Path, codes: np.ndarray) -> None:
    """codes[view, light, row, col, rgb] (uint8, sRGB) → 6561 PNG files with UBO2003 names."""
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    for light in range(81):
        for view in range(81):
            tl, pl = ANG[light].astype(int)
            tv, pv = ANG[view].astype(int)
            name = f"{81 * light + view:05d} tl{tl:03d} pl{pl:03d} tv{tv:03d} pv{pv:03d}.png"
            Image.fromarray(np.ascontiguousarray(codes[view, light])).save(folder / name)


def _np3(x) -> np.ndarray:
    """A Dr.Jit 3-vector array of size n → numpy (n, 3)."""
    a = np.array(x, dtype=np.float64)
    return a.T if a.ndim == 2 and a.shape[0] == 3 else a


def cos_table(h: int = 2, w: int = 2) -> bp.BtfTable:
    b = 0.5 * np.cos(np.radians(ANG[:, 0]))  # per light
    data = np.broadcast_to(b[None, :, None, None, None], (81, 81, h, w, 3)).astype(np.float32)
    return bp.BtfTable(ANG, ANG, np.ascontiguousarray(data))


def plugin_from_table(table: bp.BtfTable, uv_scale: float = 1.0):
    props = mi.Properties("btf")
    props["uv_scale"] = uv_scale
    return bp.bsdf_class()(props, table=table)


def interp_cos_np(local_dirs: np.ndarray) -> np.ndarray:
    """The table's interpolated cos θ at local directions (q, 3) (z ≤ 0 → 0)."""
    idx, w, _ = bp.interpolate_np(TRI, local_dirs[:, :2])
    c = np.cos(np.radians(ANG[:, 0]))
    return np.where(local_dirs[:, 2] > 0, (c[idx] * w).sum(1), 0.0)


# ----------------------------------------------------------------------------------------------


def test_triangulation_is_complete_and_exact_at_vertices():
    assert len(TRI.tris) == 136, len(TRI.tris)  # 2n - 2 - h = 162 - 2 - 24
    idx, w, _ = bp.interpolate_np(TRI, TRI.points)  # float32-rounded, as btfpt
    for k in range(81):
        j = np.argmax(w[k])
        assert idx[k, j] == k and abs(w[k, j] - 1) < 1e-9, (k, idx[k], w[k])
    # near-cocircular quads exist (see NOTES.md); report the margin, require a decision was made
    print(f"    Delaunay in-circle margin: {bp.delaunay_margin(TRI):.3g}")


def test_candidate_grid_matches_brute_force():
    """The device-side rule (grid candidates) equals the brute-force rule at many points."""
    rng = np.random.default_rng(5)
    xy = rng.uniform(-1, 1, (150000, 2))
    xy = xy[np.hypot(xy[:, 0], xy[:, 1]) <= 1.0]  # directions project into the unit disk
    w_all = bp.weights_all(TRI.bary, xy)
    mins = bp._min3(w_all)
    best = mins.max(1)
    i = np.clip(np.floor((xy[:, 0] + 1) * 0.5 * TRI.grid_res).astype(int), 0, TRI.grid_res - 1)
    j = np.clip(np.floor((xy[:, 1] + 1) * 0.5 * TRI.grid_res).astype(int), 0, TRI.grid_res - 1)
    cand = TRI.cand[j * TRI.grid_res + i]
    grid_best = np.take_along_axis(mins, cand, 1).max(1)
    worst = np.max(best - grid_best)
    assert worst < 1e-12, f"grid misses the winning triangle somewhere (gap {worst})"


def test_plugin_matches_numpy():
    rng = np.random.default_rng(1)
    h, w = 3, 5  # non-square: catches swapped rows/columns
    codes = rng.integers(0, 256, (81, 81, h, w, 3), dtype=np.uint8)
    data = bp.srgb_to_linear(codes / 255.0).astype(np.float32)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "rand"
        t0 = time.time()
        write_ubo2003_png(folder, codes)
        loaded = bp.load_table(folder)
        assert np.array_equal(loaded.data, data), "loader: 8-bit sRGB decode or layout differs"
        # through the scene-description path: filename + uv_scale properties
        bsdf = mi.load_dict({"type": "btf", "filename": str(folder), "uv_scale": 2.5})
        print(f"    wrote+loaded a 6561-image folder twice in {time.time() - t0:.1f} s")
    table = bp.BtfTable(ANG, ANG, data)
    n = 50000
    uv = rng.uniform(-1.5, 1.5, (n, 2))

    def rand_dirs(k):
        v = rng.normal(size=(k, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        v[: int(0.8 * k), 2] = np.abs(v[: int(0.8 * k), 2])  # 80 % upper hemisphere
        return v

    wi, wo = rand_dirs(n), rand_dirs(n)
    # include exactly-measured directions and grazing ones
    wi[:81], wo[81:162] = DIRS, DIRS
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.uv = mi.Point2f(uv[:, 0], uv[:, 1])
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.wi = mi.Vector3f(wi[:, 0], wi[:, 1], wi[:, 2])
    ctx = mi.BSDFContext()
    got = _np3(bsdf.eval(ctx, si, mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])))
    want, gap = bp.eval_np(table, TRI, TRI, uv, wi, wo, uv_scale=2.5)
    # uv·scale near a texel edge may round differently in float32 vs the numpy float32 path
    su = (uv * 2.5).astype(np.float32)
    edge = np.minimum(np.abs(su[:, 0] * w - np.round(su[:, 0] * w)),
                      np.abs(su[:, 1] * h - np.round(su[:, 1] * h))) < 1e-4
    ok = (gap > 1e-5) & ~edge
    err = np.abs(got - want)[ok]
    print(f"    {ok.sum()} of {n} queries compared, max |err| = {err.max():.2e}, "
          f"zero below horizon: {np.all(got[(wi[:, 2] <= 0) | (wo[:, 2] <= 0)] == 0)}")
    assert ok.sum() > 0.99 * n
    assert err.max() < 2e-6, err.max()
    assert np.all(got[(wi[:, 2] <= 0) | (wo[:, 2] <= 0)] == 0)
    # sample(): weight = eval / pdf with the uniform-hemisphere pdf
    s2 = rng.uniform(0, 1, (n, 2))
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.uniform(0, 1, n)), mi.Point2f(s2[:, 0], s2[:, 1]))
    wo_s = _np3(bs.wo)
    pdf = np.array(bs.pdf)
    wts = _np3(weight)
    ev, _ = bp.eval_np(table, TRI, TRI, uv, wi, wo_s, uv_scale=2.5)
    up = wi[:, 2] > 0
    assert np.allclose(pdf[up], 1 / (2 * math.pi), rtol=1e-6) and np.all(pdf[~up] == 0)
    assert np.all(wo_s[:, 2] >= 0)
    _, gap_s = bp.eval_np(table, TRI, TRI, uv, wi, wo_s, uv_scale=2.5)
    sel = up & (gap_s > 1e-5) & ~edge
    assert np.allclose(wts[sel], ev[sel] * 2 * math.pi, rtol=1e-5, atol=1e-5)


def _as_rgb(a) -> np.ndarray:
    return np.array(a, dtype=np.float64)


def _plane_scene(bsdf, emitter: dict, spp: int, integrator=None):
    return mi.load_dict({
        "type": "scene",
        "integrator": integrator or {"type": "path", "max_depth": 2},
        "sensor": {
            "type": "perspective", "fov": 60,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1.6], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 64, "height": 64, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "plane": {"type": "rectangle", "bsdf": bsdf},
        "light": emitter,
    })


def test_cos_table_vs_diffuse_point_light():
    light_pos = np.array([0.3, 0.2, 1.2])
    emitter = {"type": "point", "position": light_pos.tolist(), "intensity": {"type": "rgb", "value": 1.0}}
    btf = plugin_from_table(cos_table())
    # 1 spp, same seed: the three renders trace the same camera ray per pixel, so the prediction
    # at the recorded hit position is exact up to float rounding
    img_b = _as_rgb(mi.render(_plane_scene(btf, emitter, 1), seed=3))
    img_d = _as_rgb(mi.render(_plane_scene({"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
                                           emitter, 1), seed=3))
    pos = _as_rgb(mi.render(_plane_scene(btf, emitter, 1, {"type": "aov", "aovs": "p:position"}), seed=3))[..., :3]
    hit = img_d[..., 1] > 0
    ratio = img_b[hit] / img_d[hit]
    d = light_pos[None] - pos[hit]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pred = interp_cos_np(d) / d[:, 2]
    err = np.abs(ratio - pred[:, None]).max()
    mean_pred = float((img_d[hit][:, 1] * pred).sum() / img_d[hit][:, 1].sum())
    mean_ratio = float(img_b[hit][:, 1].sum() / img_d[hit][:, 1].sum())
    print(f"    point light overhead: image ratio btf/diffuse = {mean_ratio:.5f}, table predicts "
          f"{mean_pred:.5f} ({100 * (mean_pred - 1):+.2f} %), max per-pixel |ratio - prediction| = {err:.2e}")
    assert hit.mean() > 0.9
    assert err < 1e-4, err
    assert abs(mean_ratio - mean_pred) < 1e-5


def test_cos_table_vs_diffuse_constant_env():
    emitter = {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}}
    spp = 64
    btf = plugin_from_table(cos_table())
    img_b = _as_rgb(mi.render(_plane_scene(btf, emitter, spp), seed=11))[..., 1]
    img_d = _as_rgb(mi.render(_plane_scene({"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
                                           emitter, spp), seed=12))[..., 1]
    # prediction: (0.5/π) ∫ interp_cos dω over the hemisphere vs 0.5 (midpoint rule in θ, φ)
    nt, nph = 180, 360
    th = (np.arange(nt) + 0.5) / nt * (math.pi / 2)
    ph = (np.arange(nph) + 0.5) / nph * (2 * math.pi)
    T, P = np.meshgrid(th, ph, indexing="ij")
    dirs = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    vals = np.concatenate([interp_cos_np(c) for c in np.array_split(dirs, 20)]).reshape(nt, nph)
    integral = (vals * np.sin(T)).sum() * (math.pi / 2 / nt) * (2 * math.pi / nph)
    pred = integral / math.pi
    # the exact cosine through the same quadrature (checks the quadrature error)
    exact = (np.cos(T) * np.sin(T)).sum() * (math.pi / 2 / nt) * (2 * math.pi / nph) / math.pi
    ratio = img_b.mean() / img_d.mean()
    # pixels are i.i.d. here (uniform lighting, constant frame): σ of the means from their spread
    sb = img_b.std(ddof=1) / math.sqrt(img_b.size)
    sd = img_d.std(ddof=1) / math.sqrt(img_d.size)
    sigma = ratio * math.hypot(sb / img_b.mean(), sd / img_d.mean())
    print(f"    constant env: ratio btf/diffuse = {ratio:.5f} ± {sigma:.5f}, table predicts {pred:.5f} "
          f"({100 * (pred - 1):+.2f} %); quadrature of the exact cosine = {exact:.6f}")
    assert abs(exact - 1) < 1e-4
    assert abs(img_d.mean() - 0.5) < 5 * sd
    assert abs(ratio - pred) < 4 * sigma + 1e-4, (ratio, pred, sigma)


def test_errors_name_the_file():
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "missing"
        try:
            mi.load_dict({"type": "btf", "filename": str(p)})
        except Exception as e:  # noqa: BLE001
            assert "missing" in str(e), str(e)
        else:
            raise AssertionError("no error for a missing BTF")
        bad = Path(tmp) / "bad"
        bad.mkdir()
        (bad / "00000 tl000 pl000 tv000 pv000.exr").write_bytes(b"junk")
        try:
            bp.load_table(bad)
        except ValueError as e:
            assert "6561" in str(e) and "bad" in str(e), str(e)
        else:
            raise AssertionError("no error for an incomplete folder")


def test_canonical_tie_rule():
    """Cocircular quads get btfpt's diagonal (through the lowest index) whatever Qhull picked."""
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    for perm in ([0, 1, 2, 3], [1, 0, 3, 2], [3, 2, 0, 1], [2, 3, 1, 0]):
        pts = sq[perm]
        tris = bp.canonical_delaunay(pts)
        # the lowest index is 0: the diagonal must join pts[0] to the opposite corner
        opposite = [k for k in range(4) if np.all(np.abs(pts[k] - pts[0]) == 1.0)][0]
        assert all(0 in t and opposite in t for t in tris), (perm, tris)
    # UBO2014 has exactly cocircular quads in its triangulation: the result must be locally
    # canonical everywhere (no edge wants a flip)
    pts = bp.angles_to_dirs(bp.ubo2014_angles())[:, :2].astype(np.float32).astype(np.float64)
    tris = bp.canonical_delaunay(pts)
    assert len(tris) == 2 * 151 - 2 - 24, len(tris)
    own = {(int(t[e]), int(t[(e + 1) % 3])): k for k, t in enumerate(tris) for e in range(3)}
    for (a, b), k in own.items():
        if (b, a) in own:
            c = next(x for x in tris[k] if x not in (a, b))
            d = next(x for x in tris[own[(b, a)]] if x not in (a, b))
            assert not bp._should_flip(pts, a, b, int(c), int(d)), (a, b, c, d)


def _btfpt_binary() -> Path:
    import os

    for p in [os.environ.get("BTFPT", ""), HERE.parent / "target/release/btfpt", HERE.parent / "target/debug/btfpt"]:
        if p and Path(p).is_file():
            return Path(p)
    raise AssertionError("btfpt binary not found: build it (cargo build --release) or set BTFPT")


def test_btfc_cache_matches_the_folder():
    """load_btfc reads what `btfpt convert FOLDER X.btfc` writes (values f16-rounded), and refuses
    a corrupted file naming it."""
    import subprocess

    rng = np.random.default_rng(3)
    h, w = 2, 3
    codes = rng.integers(0, 256, (81, 81, h, w, 3), dtype=np.uint8)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "rand"
        write_ubo2003_png(folder, codes)
        cache = Path(tmp) / "rand.btfc"
        subprocess.run([str(_btfpt_binary()), "convert", str(folder), str(cache)], check=True,
                       capture_output=True)
        ref = bp.load_table(folder)
        got = bp.load_table(cache)
        assert np.array_equal(got.view_angles, ANG) and np.array_equal(got.light_angles, ANG)
        assert np.array_equal(got.data, ref.data.astype(np.float16).astype(np.float32))
        bsdf = mi.load_dict({"type": "btf", "filename": str(cache)})
        assert "texels=3x2" in str(bsdf), str(bsdf)
        b = bytearray(cache.read_bytes())
        b[len(b) // 2] ^= 0x40
        bad = Path(tmp) / "corrupt.btfc"
        bad.write_bytes(bytes(b))
        try:
            bp.load_table(bad)
        except ValueError as e:
            assert "corrupt.btfc" in str(e) and "checksum" in str(e), str(e)
        else:
            raise AssertionError("no error for a corrupted cache")


def test_synth_source_names_the_btfpt_command():
    try:
        mi.load_dict({"type": "btf", "filename": "synth:corduroy?size=32&seed=1"})
    except Exception as e:  # noqa: BLE001
        assert "btfpt synth corduroy --size 32 --seed 1 --format exr" in str(e), str(e)
    else:
        raise AssertionError("no error for a synth: source")


def main() -> int:
    tests = [(k, v) for k, v in globals().items() if k.startswith("test_") and callable(v)]
    passed = failed = 0
    for name, fn in tests:
        t0 = time.time()
        try:
            fn()
            passed += 1
            print(f"PASS {name} ({time.time() - t0:.1f} s)")
        except Exception:  # noqa: BLE001
            failed += 1
            print(f"FAIL {name}")
            traceback.print_exc()
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
