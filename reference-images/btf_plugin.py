"""A Mitsuba 3 BSDF `btf` that evaluates a *raw* measured BTF with the btfpt conventions (DESIGN §2).

    <bsdf type="btf">
        <string name="filename" value="path/to/ubo2003-folder"/>   (relative to the scene)
        <float name="uv_scale" value="1"/>
    </bsdf>

Conventions (the same as btfpt's raw BTF material, so the two renderers agree):
- B(x, ω_l, ω_v) is cosine-baked apparent reflectance, B = π f cos θ_l; eval returns B/π
  (Mitsuba's eval includes the cosine foreshortening of wo).
- Directions are local to si.sh_frame (view = si.wi, light = wo). One-sided: 0 unless both have
  z > 0.
- Direction interpolation, for view and light separately: project to the unit disk,
  (x, y) = sin θ (cos φ, sin φ) = (d.x, d.y); Delaunay-triangulate the measured set there; take the
  triangle whose smallest barycentric weight is largest (inside the hull: the containing
  triangle), clamp negative weights to 0 and renormalise. 3 views × 3 lights = 9 lookups.
  Point location: a host-precomputed uniform grid over [-1, 1]² lists, per cell, every triangle
  that can win the "largest smallest weight" rule somewhere in that cell; the kernel evaluates
  those candidates with dr.gather and keeps the best (exact, no approximation).
- Texel (nearest): column = ⌊frac(u·uv_scale)·W⌋, row = ⌊frac(v·uv_scale)·H⌋, row 0 = first row
  of the image file.
- Sampling: uniform hemisphere (pdf 1/2π) on the front side.

Input: a UBO2003 folder (81×81 images `NNNNN tlTTT plPPP tvTTT pvPPP.{png,jpg,jpeg,exr}`,
NNNNN = 81·light + view, flat or in per-view sub-folders `tvTTT_pvPPP/`); 8-bit/16-bit images are
decoded with the exact sRGB EOTF, EXR is linear; or btfpt's `.btfc` cache (`load_btfc`). btfpt's
in-memory `synth:MATERIAL?...` sources are refused with the `btfpt synth` command that writes them.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# ----------------------------------------------------------------------------------------------
# Direction sets and their triangulation (host side, numpy/scipy)
# ----------------------------------------------------------------------------------------------

UBO2003_RINGS = [(0.0, 1), (15.0, 6), (30.0, 12), (45.0, 18), (60.0, 20), (75.0, 24)]


def ubo2003_angles() -> np.ndarray:
    """The 81 UBO2003 directions in index order as (θ°, φ°) (DESIGN §3)."""
    out = []
    for theta, n in UBO2003_RINGS:
        for k in range(n):
            out.append((theta, 360.0 * k / n))
    return np.array(out, dtype=np.float64)


UBO2014_RINGS = [(0.0, 1, 0.0), (11.0, 6, 15.0), (23.5, 12, 0.0), (30.0, 12, 15.0), (37.5, 12, 0.0),
                 (45.0, 18, 0.0), (52.5, 18, 7.5), (60.0, 24, 0.0), (67.5, 24, 7.5), (75.0, 24, 0.0)]


def ubo2014_angles() -> np.ndarray:
    """The 151 UBO2014 directions in btfpt's index order as (θ°, φ°) (btfpt DirectionSet::ubo2014)."""
    return np.array([(t, off + 360.0 * k / n) for t, n, off in UBO2014_RINGS for k in range(n)],
                    dtype=np.float64)


def angles_to_dirs(angles_deg: np.ndarray) -> np.ndarray:
    """(θ°, φ°) → unit vectors (z = normal, φ from s toward t)."""
    t = np.radians(angles_deg[:, 0])
    p = np.radians(angles_deg[:, 1])
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)


@dataclass
class Triangulation:
    """Delaunay triangulation of directions projected to the unit disk, plus a point-location grid."""

    points: np.ndarray  # (n, 2) disk coordinates, float64
    tris: np.ndarray  # (m, 3) vertex indices (counter-clockwise)
    bary: np.ndarray  # (m, 3, 3): weights = bary[t] @ (x, y, 1)
    grid_res: int
    cand: np.ndarray  # (grid_res², K) candidate triangle ids per cell (padded by repetition)

    @property
    def k(self) -> int:
        return self.cand.shape[1]


def _bary_matrices(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    m = np.empty((len(tris), 3, 3))
    for i, t in enumerate(tris):
        a = np.array([[points[t[0], 0], points[t[1], 0], points[t[2], 0]],
                      [points[t[0], 1], points[t[1], 1], points[t[2], 1]],
                      [1.0, 1.0, 1.0]])
        m[i] = np.linalg.inv(a)
    return m


def _min3(w: np.ndarray) -> np.ndarray:
    return np.minimum(np.minimum(w[..., 0], w[..., 1]), w[..., 2])


def weights_all(bary: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Barycentric weights of points `xy` (q, 2) in every triangle: (q, m, 3), float64."""
    h = np.concatenate([xy, np.ones((len(xy), 1))], 1)
    return (h @ bary.reshape(-1, 3).T).reshape(len(xy), len(bary), 3)


def interpolate_np(tri: Triangulation, xy: np.ndarray):
    """Reference rule, brute force over all triangles (float64).

    Returns (indices (q, 3), weights (q, 3), gap (q,)) where gap is the margin between the best
    and the second-best smallest weight (ties make the rule ambiguous)."""
    w = weights_all(tri.bary, xy)
    mins = _min3(w)
    order = np.argsort(-mins, 1)
    best = order[:, 0]
    gap = mins[np.arange(len(xy)), best] - mins[np.arange(len(xy)), order[:, 1]]
    wb = np.clip(w[np.arange(len(xy)), best], 0.0, None)
    wb /= wb.sum(1, keepdims=True)
    return tri.tris[best], wb, gap


def _tri_box_overlap(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Separating-axis test of a 2-D triangle p (3, 2) against the box [lo, hi]."""
    if (p[:, 0].max() < lo[0] or p[:, 0].min() > hi[0] or p[:, 1].max() < lo[1]
            or p[:, 1].min() > hi[1]):
        return False
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    for i in range(3):
        e = p[(i + 1) % 3] - p[i]
        n = np.array([-e[1], e[0]])
        tp = p @ n
        cp = corners @ n
        if tp.max() < cp.min() or tp.min() > cp.max():
            return False
    return True


COLLINEAR_SIN = 1e-6  # btfpt src/btf/delaunay.rs: sine below which three points are collinear
COCIRCULAR_RAD = 1e-6  # |alpha + beta - pi| below which a quad counts as cocircular


def _orient(a, b, c) -> float:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _orient_sign(a, b, c) -> int:
    """Sign of the orientation with btfpt's relative tolerance (0 = collinear)."""
    o = _orient(a, b, c)
    l1, l2 = sorted([math.hypot(b[0] - a[0], b[1] - a[1]), math.hypot(c[0] - a[0], c[1] - a[1]),
                     math.hypot(c[0] - b[0], c[1] - b[1])])[1:]
    if abs(o) <= COLLINEAR_SIN * l1 * l2:
        return 0
    return 1 if o > 0 else -1


def _angle_at(p, q, r) -> float:
    u, v = (q[0] - p[0], q[1] - p[1]), (r[0] - p[0], r[1] - p[1])
    return math.atan2(abs(u[0] * v[1] - u[1] * v[0]), u[0] * v[0] + u[1] * v[1])


def _should_flip(pts, a: int, b: int, c: int, d: int) -> bool:
    """btfpt's `should_flip`: edge a-b of the ccw triangles (a, b, c), (b, a, d) becomes c-d if the
    quad is strictly convex and either not locally Delaunay, or cocircular (within
    COCIRCULAR_RAD) and c or d is the lowest index of the four (the canonical tie rule)."""
    pa, pb, pc, pd = pts[a], pts[b], pts[c], pts[d]
    if _orient_sign(pc, pd, pa) * _orient_sign(pc, pd, pb) >= 0:
        return False
    excess = _angle_at(pc, pa, pb) + _angle_at(pd, pa, pb) - math.pi
    if excess > COCIRCULAR_RAD:
        return True
    if excess < -COCIRCULAR_RAD:
        return False
    return min(c, d) < min(a, b)


def canonical_delaunay(pts: np.ndarray) -> np.ndarray:
    """The Delaunay triangulation btfpt uses (src/btf/delaunay.rs): Qhull's, then Lawson flips to
    the canonical tie rule "the diagonal of a cocircular quad is the one through its lowest-index
    point" (Qhull splits cocircular quads arbitrarily; UBO2003 has dozens). Triangles are
    counter-clockwise index triples."""
    from scipy.spatial import Delaunay

    pts = np.asarray(pts, dtype=np.float64)
    tris = [list(map(int, t)) for t in Delaunay(pts).simplices]
    for t in tris:
        if _orient(pts[t[0]], pts[t[1]], pts[t[2]]) < 0:
            t[1], t[2] = t[2], t[1]
    owner = {}
    for k, t in enumerate(tris):
        for e in range(3):
            owner[(t[e], t[(e + 1) % 3])] = k
    stack = list({(min(a, b), max(a, b)) for (a, b) in owner})
    flips = 0
    while stack:
        u, v = stack.pop()
        if (u, v) not in owner or (v, u) not in owner:
            continue
        t1, t2 = owner[(u, v)], owner[(v, u)]
        a, b = u, v
        c = next(x for x in tris[t1] if x not in (a, b))
        d = next(x for x in tris[t2] if x not in (a, b))
        if not _should_flip(pts, a, b, c, d):
            continue
        flips += 1
        if flips > 100 * len(tris) + 1000:
            raise RuntimeError("canonical_delaunay: flips do not terminate")
        for t in (t1, t2):
            for e in range(3):
                owner.pop((tris[t][e], tris[t][(e + 1) % 3]), None)
        tris[t1], tris[t2] = [a, d, c], [d, b, c]
        for t in (t1, t2):
            for e in range(3):
                owner[(tris[t][e], tris[t][(e + 1) % 3])] = t
        for (x, y) in ((a, d), (d, b), (b, c), (c, a)):
            stack.append((min(x, y), max(x, y)))
    return np.array(tris, dtype=np.int64)


def build_triangulation(dirs: np.ndarray, grid_res: int = 48, sub: int = 8) -> Triangulation:
    """Delaunay on the unit disk (btfpt's canonical one) and the candidate grid (see module docstring)."""
    # btfpt computes the disk positions in float32 and triangulates them in float64
    pts = dirs[:, :2].astype(np.float32).astype(np.float64)
    tris = canonical_delaunay(pts)
    bary = _bary_matrices(pts, tris)
    tri = Triangulation(pts, tris, bary, grid_res, np.zeros((0, 1), np.int64))

    cell = 2.0 / grid_res
    # sample points in each cell, slightly dilated so winners whose region only grazes the cell
    # are not missed; triangles overlapping the cell are candidates too (exact inside the hull)
    s = (np.arange(sub + 1) / sub) * 1.2 - 0.1
    su, sv = np.meshgrid(s, s)
    offs = np.stack([su.ravel(), sv.ravel()], -1) * cell
    cands: list[set] = []
    for j in range(grid_res):
        lo = np.stack([-1.0 + np.arange(grid_res) * cell, np.full(grid_res, -1.0 + j * cell)], -1)
        xy = (lo[:, None, :] + offs[None]).reshape(-1, 2)
        win = np.argmax(_min3(weights_all(bary, xy)), 1).reshape(grid_res, -1)
        cands.extend(set(row.tolist()) for row in win)
    tlo = np.floor((pts[tris].min(1) + 1.0) / cell).astype(int)
    thi = np.floor((pts[tris].max(1) + 1.0) / cell).astype(int)
    for t in range(len(tris)):
        for j in range(max(tlo[t, 1], 0), min(thi[t, 1], grid_res - 1) + 1):
            for i in range(max(tlo[t, 0], 0), min(thi[t, 0], grid_res - 1) + 1):
                lo = np.array([-1.0 + i * cell, -1.0 + j * cell])
                if t not in cands[j * grid_res + i] and _tri_box_overlap(pts[tris[t]], lo, lo + cell):
                    cands[j * grid_res + i].add(t)
    # outside the convex hull the winning regions can be thin slivers: sample those cells densely
    # and add the winners of the 8 neighbouring cells
    from scipy.spatial import ConvexHull

    hull = ConvexHull(pts)
    eq = hull.equations  # (h, 3): n·x + c <= 0 inside
    fine = (np.arange(4 * sub + 1) / (4 * sub)) * 1.2 - 0.1
    fu, fv = np.meshgrid(fine, fine)
    foffs = np.stack([fu.ravel(), fv.ravel()], -1) * cell
    outer = np.zeros(grid_res * grid_res, bool)
    for j in range(grid_res):
        for i in range(grid_res):
            lo = np.array([-1.0 + i * cell, -1.0 + j * cell])
            corners = lo + np.array([[0, 0], [cell, 0], [0, cell], [cell, cell]])
            if np.any(corners @ eq[:, :2].T + eq[:, 2] > -1e-12):
                outer[j * grid_res + i] = True
                xy = lo + foffs
                xy = xy[np.hypot(xy[:, 0], xy[:, 1]) <= 1.0 + cell]
                if len(xy):
                    cands[j * grid_res + i] |= set(np.argmax(_min3(weights_all(bary, xy)), 1).tolist())
    base = [set(c) for c in cands]
    for j in range(grid_res):
        for i in range(grid_res):
            if outer[j * grid_res + i]:
                for dj in (-1, 0, 1):
                    for di in (-1, 0, 1):
                        jj, ii = j + dj, i + di
                        if 0 <= jj < grid_res and 0 <= ii < grid_res:
                            cands[j * grid_res + i] |= base[jj * grid_res + ii]
    cands = [sorted(c) for c in cands]
    k = max(len(c) for c in cands)
    cand = np.array([c + [c[0]] * (k - len(c)) for c in cands], dtype=np.int64)
    tri.cand = cand
    return tri


def delaunay_margin(tri: Triangulation) -> float:
    """Smallest |in-circle determinant| over interior edges, scaled: ≈ 0 means a cocircular
    quadruple, i.e. an ambiguous Delaunay triangulation that another implementation may split
    differently."""
    pts = tri.points
    edges = {}
    for ti, t in enumerate(tri.tris):
        for e in range(3):
            a, b = sorted((t[e], t[(e + 1) % 3]))
            edges.setdefault((a, b), []).append((ti, t[(e + 2) % 3]))
    worst = math.inf
    for (a, b), lst in edges.items():
        if len(lst) != 2:
            continue
        (t0, c), (_, d) = lst
        pa, pb, pc = pts[tri.tris[t0]]
        m = np.array([[p[0] - pts[d][0], p[1] - pts[d][1],
                       (p[0] - pts[d][0]) ** 2 + (p[1] - pts[d][1]) ** 2] for p in (pa, pb, pc)])
        worst = min(worst, abs(np.linalg.det(m)))
    return worst


# ----------------------------------------------------------------------------------------------
# BTF table and loaders
# ----------------------------------------------------------------------------------------------


@dataclass
class BtfTable:
    """A raw BTF in memory: `data[view, light, row, col, rgb]`, linear, cosine-baked, float32."""

    view_angles: np.ndarray  # (nv, 2) degrees
    light_angles: np.ndarray  # (nl, 2) degrees
    data: np.ndarray  # (nv, nl, H, W, 3) float32

    @property
    def height(self) -> int:
        return self.data.shape[2]

    @property
    def width(self) -> int:
        return self.data.shape[3]


_NAME = re.compile(r"^(\d{5}) tl(\d{3}) pl(\d{3}) tv(\d{3}) pv(\d{3})\.(png|jpg|jpeg|exr)$", re.I)


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    """Exact sRGB EOTF on values in [0, 1]."""
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def read_image_linear(path: Path) -> np.ndarray:
    """(H, W, 3) linear float32: EXR as stored, 8/16-bit PNG/JPEG through the sRGB EOTF."""
    ext = path.suffix.lower()
    if ext == ".exr":
        import mitsuba as mi

        try:
            bmp = mi.Bitmap(str(path))
        except Exception as e:  # noqa: BLE001
            raise ValueError(f"{path}: cannot read EXR: {e}") from e
        a = np.array(bmp, dtype=np.float32)
        if a.ndim == 2:
            a = a[..., None]
        if a.shape[2] == 1:
            a = np.repeat(a, 3, 2)
        return np.ascontiguousarray(a[..., :3])
    from PIL import Image

    try:
        with Image.open(path) as im:
            if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.array(im, dtype=np.float64) / 65535.0
                a = np.repeat(a[..., None], 3, 2)
            else:
                raw = np.array(im.convert("RGB"))
                a = raw.astype(np.float64) / 255.0
    except Exception as e:  # noqa: BLE001
        raise ValueError(f"{path}: cannot decode image: {e}") from e
    return srgb_to_linear(a).astype(np.float32)


def load_ubo2003(folder: Path) -> BtfTable:
    """Reads a UBO2003 folder strictly (names, index ↔ angles, 6561 images, equal sizes)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a directory (expected a UBO2003 folder)")
    angles = ubo2003_angles()
    files: dict[int, Path] = {}
    for p in sorted(folder.rglob("*")):
        if not p.is_file():
            continue
        m = _NAME.match(p.name)
        if not m:
            if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".exr"):
                raise ValueError(f"{p}: image name does not follow 'NNNNN tlTTT plPPP tvTTT pvPPP.ext'")
            continue
        idx, tl, pl, tv, pv = (int(g) for g in m.groups()[:5])
        if idx >= 81 * 81:
            raise ValueError(f"{p}: index {idx} out of range (81 x 81 images)")
        light, view = divmod(idx, 81)
        if (tl, pl) != tuple(angles[light].astype(int)) or (tv, pv) != tuple(angles[view].astype(int)):
            raise ValueError(
                f"{p}: angles in the name do not match index {idx} (light {light} = "
                f"{tuple(angles[light])}, view {view} = {tuple(angles[view])})")
        if idx in files:
            raise ValueError(f"{p}: duplicate image for index {idx} (also {files[idx]})")
        files[idx] = p
    if len(files) != 81 * 81:
        missing = [i for i in range(81 * 81) if i not in files][:5]
        raise ValueError(f"{folder}: {len(files)} BTF images found, expected 6561 (missing e.g. {missing})")
    first = read_image_linear(files[0])
    h, w = first.shape[:2]
    data = np.empty((81, 81, h, w, 3), dtype=np.float32)
    for idx, p in files.items():
        img = first if idx == 0 else read_image_linear(p)
        if img.shape[:2] != (h, w):
            raise ValueError(f"{p}: size {img.shape[1]}x{img.shape[0]} differs from {w}x{h}")
        light, view = divmod(idx, 81)
        data[view, light] = img
    return BtfTable(angles, angles, data)


def load_btfc(path: Path) -> BtfTable:
    """Reads btfpt's binary cache `.btfc` (layout: btfpt's src/btf/cache.rs), checking the header
    and per-view CRC32s. The f16 payload `[view][light][row][col][rgb]` is linear and cosine-baked
    whatever the recorded source encoding (that field only says how the source was stored)."""
    import struct
    import zlib

    path = Path(path)
    b = path.read_bytes()
    if len(b) < 40 or b[:4] != b"BTFC":
        raise ValueError(f"{path}: not a .btfc cache (bad signature or too short)")
    version, encoding, w, h, nv, nl, _flags = struct.unpack_from("<7I", b, 4)
    if version != 1:
        raise ValueError(f"{path}: unsupported .btfc version {version} (expected 1)")
    if encoding not in (0, 1):
        raise ValueError(f"{path}: unknown encoding code {encoding}")
    if not (0 < nv <= 1 << 16 and 0 < nl <= 1 << 16 and w > 0 and h > 0):
        raise ValueError(f"{path}: implausible dimensions: {nv} views, {nl} lights, {w}x{h} texels")
    hl = 40 + 8 * (nv + nl) + 4
    if len(b) < hl:
        raise ValueError(f"{path}: truncated header ({len(b)} of {hl} bytes)")
    if zlib.crc32(b[: hl - 4]) != struct.unpack_from("<I", b, hl - 4)[0]:
        raise ValueError(f"{path}: header checksum mismatch (corrupt file)")
    (offset,) = struct.unpack_from("<Q", b, 32)
    if offset != -(-hl // 64) * 64:
        raise ValueError(f"{path}: unexpected payload offset {offset}")
    per_view = nl * h * w * 3
    expected = offset + 2 * nv * per_view + 4 * nv + 4
    if len(b) != expected:
        raise ValueError(f"{path}: file is {len(b)} bytes, expected {expected} for {nv} views x {nl} "
                         f"lights x {w}x{h} texels (truncated or trailing data)")
    ang = np.frombuffer(b, "<f4", 2 * (nv + nl), 40).reshape(-1, 2).astype(np.float64)
    trailer = offset + 2 * nv * per_view
    crcs = np.frombuffer(b, "<u4", nv, trailer)
    if zlib.crc32(b[trailer: trailer + 4 * nv]) != struct.unpack_from("<I", b, trailer + 4 * nv)[0]:
        raise ValueError(f"{path}: checksum table corrupt")
    for v in range(nv):
        a = offset + 2 * v * per_view
        if zlib.crc32(b[a: a + 2 * per_view]) != int(crcs[v]):
            raise ValueError(f"{path}: checksum mismatch in view {v} (corrupt file)")
    data = np.frombuffer(b, "<f2", nv * per_view, offset).astype(np.float32).reshape(nv, nl, h, w, 3)
    return BtfTable(ang[:nv], ang[nv:], data)


def _synth_hint(value: str) -> str:
    """The btfpt command that writes a `synth:` source (btfpt-only) as a folder Mitsuba can read."""
    import urllib.parse

    name, _, query = value.strip()[len("synth:"):].partition("?")
    args = [f"--{k} {v}" for k, v in urllib.parse.parse_qsl(query)]
    return f"btfpt synth {name} {' '.join(args)} --format exr -o DIR".replace("  ", " ")


def load_table(path: Path) -> BtfTable:
    """Dispatch on the path: UBO2003 folder, `.btfc` cache (hook), `.npz` (tests: views, lights, data)."""
    if str(path).strip().startswith("synth:") or Path(path).name.startswith("synth:"):
        spec = str(path).strip()
        spec = spec[spec.index("synth:"):]
        raise ValueError(f"{spec}: a synthetic BTF source is generated by btfpt only; write the same "
                         f"values for Mitsuba with `{_synth_hint(spec)}` and pass -D btf=DIR")
    path = Path(path)
    if path.is_dir():
        return load_ubo2003(path)
    if not path.exists():
        raise ValueError(f"{path}: BTF not found")
    if path.suffix.lower() == ".btfc":
        return load_btfc(path)
    if path.suffix.lower() == ".npz":
        z = np.load(path)
        return BtfTable(z["view_angles"], z["light_angles"], z["data"].astype(np.float32))
    raise ValueError(f"{path}: unknown BTF format (expected a UBO2003 folder, .btfc or .npz)")


# ----------------------------------------------------------------------------------------------
# numpy reference evaluation (float64) of exactly the plugin's conventions
# ----------------------------------------------------------------------------------------------


def texel_np(uv: np.ndarray, uv_scale: float, w: int, h: int):
    """(col, row) of the nearest texel (DESIGN §2)."""
    su = uv[:, 0].astype(np.float32) * np.float32(uv_scale)
    sv = uv[:, 1].astype(np.float32) * np.float32(uv_scale)
    fu = su - np.floor(su)
    fv = sv - np.floor(sv)
    col = np.minimum((fu * np.float32(w)).astype(np.int64), w - 1)
    row = np.minimum((fv * np.float32(h)).astype(np.int64), h - 1)
    return col, row


def eval_np(table: BtfTable, vtri: Triangulation, ltri: Triangulation, uv, wi, wo, uv_scale=1.0):
    """B/π for each query (q, 3) in float64, and the smaller tie gap of the two interpolations."""
    uv, wi, wo = (np.asarray(a, dtype=np.float64) for a in (uv, wi, wo))
    vi, vw, vgap = interpolate_np(vtri, wi[:, :2])
    li, lw, lgap = interpolate_np(ltri, wo[:, :2])
    col, row = texel_np(uv, uv_scale, table.width, table.height)
    out = np.zeros((len(uv), 3))
    for a in range(3):
        for b in range(3):
            vals = table.data[vi[:, a], li[:, b], row, col].astype(np.float64)
            out += (vw[:, a] * lw[:, b])[:, None] * vals
    front = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    out = np.where(front[:, None], out / math.pi, 0.0)
    return out, np.minimum(vgap, lgap)


# ----------------------------------------------------------------------------------------------
# The Mitsuba plugin (traced: dr.gather / dr.select only)
# ----------------------------------------------------------------------------------------------


def _make_class():
    import drjit as dr
    import mitsuba as mi

    class _Interp:
        """Device-side copy of a Triangulation."""

        def __init__(self, tri: Triangulation):
            self.res = tri.grid_res
            self.k = tri.k
            self.cand = mi.UInt32(tri.cand.ravel().astype(np.uint32))
            self.bary = mi.Float(tri.bary.reshape(-1).astype(np.float32))
            self.verts = mi.UInt32(tri.tris.reshape(-1).astype(np.uint32))

        def lookup(self, d, active):
            x, y = d.x, d.y
            res = self.res
            i = dr.clip(mi.Int32(dr.floor((x + 1.0) * (0.5 * res))), 0, res - 1)
            j = dr.clip(mi.Int32(dr.floor((y + 1.0) * (0.5 * res))), 0, res - 1)
            cell = mi.UInt32(j * res + i)
            best_t = dr.gather(mi.UInt32, self.cand, cell * self.k, active)
            best_min = mi.Float(-dr.inf)
            best_w = mi.Vector3f(0.0)
            for c in range(self.k):
                t = dr.gather(mi.UInt32, self.cand, cell * self.k + c, active)
                base = t * 9
                w = []
                for r in range(3):
                    m0 = dr.gather(mi.Float, self.bary, base + 3 * r + 0, active)
                    m1 = dr.gather(mi.Float, self.bary, base + 3 * r + 1, active)
                    m2 = dr.gather(mi.Float, self.bary, base + 3 * r + 2, active)
                    w.append(dr.fma(m0, x, dr.fma(m1, y, m2)))
                wv = mi.Vector3f(w[0], w[1], w[2])
                mn = dr.minimum(dr.minimum(w[0], w[1]), w[2])
                better = mn > best_min
                best_min = dr.select(better, mn, best_min)
                best_t = dr.select(better, t, best_t)
                best_w = dr.select(better, wv, best_w)
            wc = dr.maximum(best_w, 0.0)
            wc = wc / (wc.x + wc.y + wc.z)
            idx = [dr.gather(mi.UInt32, self.verts, best_t * 3 + r, active) for r in range(3)]
            return idx, [wc.x, wc.y, wc.z]

    class BtfBsdf(mi.BSDF):
        """Raw measured BTF (see the module docstring)."""

        def __init__(self, props, table: BtfTable | None = None):
            mi.BSDF.__init__(self, props)
            self.filename = ""
            if table is None:
                if not props.has_property("filename"):
                    raise ValueError("btf: the 'filename' string parameter is required")
                fname = str(props["filename"])
                resolved = mi.Thread.thread().file_resolver().resolve(fname)
                self.filename = str(resolved)
                table = load_table(Path(self.filename))
            self.uv_scale = float(props["uv_scale"]) if props.has_property("uv_scale") else 1.0
            if not math.isfinite(self.uv_scale):
                raise ValueError(f"btf {self.filename}: uv_scale must be finite")
            self.table = table
            nv, nl, h, w, _ = table.data.shape
            self.nv, self.nl, self.h, self.w = nv, nl, h, w
            self.vtri = build_triangulation(angles_to_dirs(table.view_angles))
            same = np.array_equal(table.view_angles, table.light_angles)
            self.ltri = self.vtri if same else build_triangulation(angles_to_dirs(table.light_angles))
            self._vinterp = _Interp(self.vtri)
            self._linterp = self._vinterp if same else _Interp(self.ltri)
            self._data = mi.Float(np.ascontiguousarray(table.data, dtype=np.float32).ravel())
            flags = (mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
                     | mi.BSDFFlags.SpatiallyVarying)
            self.m_components = [flags]
            self.m_flags = flags

        # -- core ---------------------------------------------------------------------------
        def _texel(self, si):
            s = mi.Float(self.uv_scale)
            su, sv = si.uv.x * s, si.uv.y * s
            fu, fv = su - dr.floor(su), sv - dr.floor(sv)
            col = dr.minimum(mi.UInt32(fu * self.w), self.w - 1)
            row = dr.minimum(mi.UInt32(fv * self.h), self.h - 1)
            return row * self.w + col

        def _value(self, si, wo, active):
            wi = si.wi
            active = active & (mi.Frame3f.cos_theta(wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            vi, vw = self._vinterp.lookup(wi, active)
            li, lw = self._linterp.lookup(wo, active)
            texel = self._texel(si)
            hw = self.h * self.w
            b = mi.Color3f(0.0)
            for a in range(3):
                for c in range(3):
                    img = (vi[a] * self.nl + li[c]) * hw + texel
                    val = dr.gather(mi.Color3f, self._data, img, active)
                    b += (vw[a] * lw[c]) * val
            return dr.select(active, b * dr.inv_pi, 0.0), active

        # -- Mitsuba interface --------------------------------------------------------------
        def eval(self, ctx, si, wo, active=True):
            v, _ = self._value(si, wo, active)
            return v

        def pdf(self, ctx, si, wo, active=True):
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            return dr.select(ok, mi.warp.square_to_uniform_hemisphere_pdf(wo), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wo = mi.warp.square_to_uniform_hemisphere(sample2)
            pdf = mi.warp.square_to_uniform_hemisphere_pdf(wo)
            value, ok = self._value(si, wo, active)
            ok = ok & ctx.is_enabled(mi.BSDFFlags.DiffuseReflection)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = dr.select(ok, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = mi.UInt32(0)
            return bs, dr.select(ok, value / pdf, 0.0)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return (f"BtfBsdf[filename='{self.filename}', texels={self.w}x{self.h}, "
                    f"views={self.nv}, lights={self.nl}, uv_scale={self.uv_scale}]")

    return BtfBsdf


_CLASS = None


def bsdf_class():
    """The plugin class for the current Mitsuba variant (created on first use)."""
    global _CLASS
    if _CLASS is None:
        _CLASS = _make_class()
    return _CLASS


def register() -> None:
    """Registers the plugin as `btf` (call after mi.set_variant; a JIT variant, e.g. llvm_ad_rgb)."""
    import mitsuba as mi

    cls = bsdf_class()
    mi.register_bsdf("btf", lambda props: cls(props))


def write_triangulation_json(path: Path, which: str = "ubo2003") -> None:
    """Writes the triangulation this plugin uses for the UBO2003 or UBO2014 direction set as JSON;
    btfpt's test `mitsuba_plugin_triangulation_is_ours` (tests/images/raw_btf.rs) checks that it
    is btfpt's own (UBO2014 has dozens of exactly cocircular quads: it exercises the tie rule)."""
    import json

    ang = ubo2003_angles() if which == "ubo2003" else ubo2014_angles()
    pts = angles_to_dirs(ang)[:, :2].astype(np.float32).astype(np.float64)
    tris = canonical_delaunay(pts)
    from scipy.spatial import Delaunay

    qhull = {tuple(sorted(map(int, t))) for t in Delaunay(pts).simplices}
    ours = {tuple(sorted(map(int, t))) for t in tris}
    doc = {
        "what": f"Delaunay triangulation of the {len(ang)} {which.upper()} directions projected to the "
                "unit disk, (x, y) = sin(theta)(cos(phi), sin(phi)) (float32 positions), with btfpt's "
                "canonical tie rule for cocircular quads (the diagonal through the lowest-index point); "
                "triangles counter-clockwise, indices in btfpt's index order. Written by "
                "`reference-images/btf_plugin.py --write-triangulation`; the Mitsuba btf plugin "
                "builds the same one (btf_plugin.canonical_delaunay), and btfpt's "
                "tests/images/raw_btf.rs checks it equals btfpt's own (src/btf/delaunay.rs).",
        "triangles_differing_from_plain_qhull": len(ours - qhull),
        "angles_deg": ang.tolist(),
        "triangles": tris.tolist(),
    }
    Path(path).write_text(json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    import sys

    if sys.argv[1:] == ["--write-triangulation"]:
        for which in ("ubo2003", "ubo2014"):
            out = Path(__file__).parent / f"{which}_triangulation.json"
            write_triangulation_json(out, which)
            print(f"wrote {out}")
    else:
        print("usage: btf_plugin.py --write-triangulation   (writes ubo2003/ubo2014_triangulation.json)",
              file=sys.stderr)
        sys.exit(2)
