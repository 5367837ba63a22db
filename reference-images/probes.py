"""Probes of Mitsuba 3 behaviour that btfpt must reproduce (results are written up in NOTES.md).

Run: reference-images/.venv/bin/python reference-images/probes.py
"""
import math

import numpy as np
import mitsuba as mi

mi.set_variant("llvm_ad_rgb")
import drjit as dr  # noqa: E402

T = mi.ScalarTransform4f


def np3(x):
    a = np.array(x, dtype=np.float64)
    return a.T if a.ndim == 2 and a.shape[0] == 3 else a


def camera():
    print("== perspective camera (fov 60 along x, 40x20 film, lookat origin (0,0,5) -> 0, up +y)")
    s = mi.load_dict({"type": "perspective", "fov": 60, "fov_axis": "x",
                      "to_world": T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]),
                      "film": {"type": "hdrfilm", "width": 40, "height": 20, "rfilter": {"type": "box"}}})
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.5], [1.0, 1.0]])
    ray, _ = s.sample_ray(0.0, 0.5, mi.Point2f(pts[:, 0], pts[:, 1]), mi.Point2f(0.5, 0.5))
    d = np3(ray.d)
    for p, dd in zip(pts, d):
        print(f"  film ({p[0]:.1f}, {p[1]:.1f}) -> world dir {np.round(dd, 4)}")
    t = math.tan(math.radians(30))
    print(f"  tan(fov_x/2) = {t:.4f}; aspect = 2 -> expected |x| = t, |y| = t/2 at the corners")
    m = np.array(T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]).matrix)
    print("  lookat to_world columns (camera x, y, z, origin):\n", np.round(m, 4))


def surface(shape: dict, label: str, dirs_from: list):
    scene = mi.load_dict({"type": "scene", "s": shape})
    o = np.array([p for p, _ in dirs_from], dtype=np.float64)
    d = np.array([q for _, q in dirs_from], dtype=np.float64)
    ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(d[:, 0], d[:, 1], d[:, 2]))
    si = scene.ray_intersect(ray)
    p, uv, n, s_ = np3(si.p), np.array(si.uv).T, np3(si.sh_frame.n), np3(si.sh_frame.s)
    dpdu = np3(si.dp_du)
    print(f"== {label}")
    for k in range(len(o)):
        print(f"  p {np.round(p[k], 4)}  uv {np.round(uv[k], 4)}  n {np.round(n[k], 4)}  "
              f"s {np.round(s_[k], 4)}  dp/du {np.round(dpdu[k], 4)}")


def shapes():
    surface({"type": "rectangle"}, "rectangle (local [-1,1]^2, z = 0)",
            [((x, y, 1), (0, 0, -1)) for x, y in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5)]])
    surface({"type": "disk"}, "disk (unit, z = 0)",
            [((x, y, 1), (0, 0, -1)) for x, y in [(0.5, 0), (0, 0.5), (-0.5, 0), (0, -0.5)]])
    surface({"type": "sphere"}, "sphere (unit, analytic)",
            [((0, 0, 3), (0, 0, -1)), ((3, 0, 0), (-1, 0, 0)), ((0, 3, 0.01), (0, -1, 0)),
             ((0, -3, 0.01), (0, 1, 0)), ((-3, 0, 0), (1, 0, 0)), ((0, 0, -3), (0, 0, 1)),
             ((0, 3, 0), (0, -1, 0))])
    # asymmetric probe points (a, b) = (0.5, -0.25) in the two tangential axes of each face
    surface({"type": "cube"}, "cube ([-1,1]^3); probe points use coordinates 0.5 and -0.25",
            [((0.5, -0.25, 3), (0, 0, -1)), ((0.5, -0.25, -3), (0, 0, 1)),
             ((3, 0.5, -0.25), (-1, 0, 0)), ((-3, 0.5, -0.25), (1, 0, 0)),
             ((0.5, 3, -0.25), (0, -1, 0)), ((0.5, -3, -0.25), (0, 1, 0))])


CUBE_UV = {  # face: (axis, sign, uv formula) -- the table in NOTES.md
    "+z": (2, 1, lambda p: ((p[:, 1] + 1) / 2, (p[:, 0] + 1) / 2)),
    "-z": (2, -1, lambda p: ((1 - p[:, 1]) / 2, (p[:, 0] + 1) / 2)),
    "+x": (0, 1, lambda p: ((p[:, 1] + 1) / 2, (1 - p[:, 2]) / 2)),
    "-x": (0, -1, lambda p: ((p[:, 1] + 1) / 2, (p[:, 2] + 1) / 2)),
    "+y": (1, 1, lambda p: ((1 - p[:, 0]) / 2, (1 - p[:, 2]) / 2)),
    "-y": (1, -1, lambda p: ((p[:, 2] + 1) / 2, (p[:, 0] + 1) / 2)),
}


def cube_uv_check():
    print("== cube uv formulas of NOTES.md at 1000 random points per face")
    scene = mi.load_dict({"type": "scene", "s": {"type": "cube"}})
    rng = np.random.default_rng(0)
    for face, (ax, sg, f) in CUBE_UV.items():
        p = rng.uniform(-0.95, 0.95, (1000, 3))
        p[:, ax] = 3 * sg
        d = np.zeros_like(p)
        d[:, ax] = -sg
        si = scene.ray_intersect(mi.Ray3f(mi.Point3f(p[:, 0], p[:, 1], p[:, 2]),
                                          mi.Vector3f(d[:, 0], d[:, 1], d[:, 2])))
        hit = np3(si.p)
        uv = np.array(si.uv).T
        u, v = f(hit)
        print(f"  {face}: max |uv - formula| = {max(np.abs(uv[:, 0] - u).max(), np.abs(uv[:, 1] - v).max()):.1e}")


def bitmap_texture():
    print("== bitmap texture orientation: 2x2 image rows [[A, B], [C, D]] (A = row 0, col 0)")
    img = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 1]]], dtype=np.float32)
    tex = mi.load_dict({"type": "bitmap", "bitmap": mi.Bitmap(img), "filter_type": "nearest", "raw": True})
    uvs = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]])
    si = dr.zeros(mi.SurfaceInteraction3f, len(uvs))
    si.uv = mi.Point2f(uvs[:, 0], uvs[:, 1])
    v = np3(tex.eval(si))
    for a, b in zip(uvs, v):
        print(f"  uv {a} -> {b}")
    tex = mi.load_dict({"type": "bitmap", "bitmap": mi.Bitmap(img), "raw": True})
    si = dr.zeros(mi.SurfaceInteraction3f, 2)
    si.uv = mi.Point2f([0.5, 0.0], [0.25, 0.25])
    print("  bilinear (default): uv (0.5,0.25) ->", np3(tex.eval(si))[0], " uv (0,0.25) ->", np3(tex.eval(si))[1],
          "(wrap: repeat)")


def envmap():
    print("== envmap mapping: 16x8 map with R = u of the texel centre, G = v of the texel centre")
    w, h = 16, 8
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    img = np.zeros((h, w, 3), np.float32)
    img[..., 0] = u[None, :]
    img[..., 1] = v[:, None]
    img[..., 2] = 1.0
    for rot in (0, 30):
        em = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(img),
                           "to_world": T().rotate([0, 1, 0], rot)})
        rng = np.random.default_rng(0)
        d = rng.normal(size=(2000, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        si = dr.zeros(mi.SurfaceInteraction3f, len(d))
        # eval() looks up the radiance arriving along -si.wi (si.wi points away from the emitter)
        si.wi = mi.Vector3f(-d[:, 0], -d[:, 1], -d[:, 2])
        val = np3(em.eval(si))
        # the formula to check: local = R^-1 d ; u = atan2(x, -z)/(2π) mod 1 ; v = acos(y)/π
        a = math.radians(-rot)
        loc = np.stack([d[:, 0] * math.cos(a) + d[:, 2] * math.sin(a), d[:, 1],
                        -d[:, 0] * math.sin(a) + d[:, 2] * math.cos(a)], -1)
        uu = (np.arctan2(loc[:, 0], -loc[:, 2]) / (2 * math.pi)) % 1.0
        vv = np.arccos(np.clip(loc[:, 1], -1, 1)) / math.pi
        # texel lookup: x = u·W - 0.5 (centres at (i+0.5)/W, wraps in u), but y = v·(H-1)
        # (row 0 exactly at the zenith, row H-1 at the nadir, clamped): G = (y + 0.5)/H
        g_pred = (vv * (h - 1) + 0.5) / h
        x = uu * w - 0.5
        x0 = np.floor(x)
        fx = x - x0
        col = lambda i: ((i % w) + 0.5) / w  # noqa: E731 - R stored in column i
        r_pred = (1 - fx) * col(x0) + fx * col(x0 + 1)
        inner = (uu > 1.5 / w) & (uu < 1 - 1.5 / w) & (vv > 1.5 / h) & (vv < 1 - 1.5 / h)
        print(f"  rotate y {rot:2d}: max |R - u| = {np.abs(val[inner, 0] - uu[inner]).max():.2e}, "
              f"max |G - v| = {np.abs(val[inner, 1] - vv[inner]).max():.2e}, "
              f"max |G - (v(H-1)+0.5)/H| = {np.abs(val[:, 1] - g_pred).max():.2e} (all directions), "
              f"max |R - wrap-bilinear(u·W - 0.5)| = {np.abs(val[:, 0] - r_pred).max():.2e} (all), "
              f"B (should be 1): "
              f"{val[inner, 2].min():.4f}..{val[inner, 2].max():.4f} over {inner.sum()} directions")


def obj_uv():
    import tempfile
    from pathlib import Path

    print("== OBJ: a triangle with vt (0,0) (1,0) (0,1) -> Mitsuba uv (flip_tex_coords default true)")
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "t.obj"
        p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n")
        scene = mi.load_dict({"type": "scene", "s": {"type": "obj", "filename": str(p)}})
        ray = mi.Ray3f(mi.Point3f([0.1, 0.8, 0.1], [0.1, 0.1, 0.8], [1, 1, 1]), mi.Vector3f(0, 0, -1))
        si = scene.ray_intersect(ray)
        print("  p", np.round(np3(si.p), 3).tolist(), "-> uv", np.round(np.array(si.uv).T, 3).tolist())


if __name__ == "__main__":
    camera()
    shapes()
    cube_uv_check()
    bitmap_texture()
    envmap()
    obj_uv()
