#!/usr/bin/env python3
"""Writes the assets of scenes/mitsuba-features/ (small, deterministic) and checks that Mitsuba 3
reads them as intended:
  assets/stage.serialized  shape 0: a 4x4 floor quad at y = 0 with uvs and +y normals (f32);
                           shape 1: a unit tetrahedron (f64, face normals flag) - shape_index test
  assets/tiles.png         8x8 sRGB tiles (nearest/mirror lookups show every texel)
  assets/ramp.png          16x4 grey-green ramp, read with raw=true (no sRGB decoding)
  assets/wall.pfm          4x4 colour PFM (float, bottom-up rows as the format stores them)
"""
import os, struct, zlib
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")

here = os.path.dirname(os.path.abspath(__file__))
assets = os.path.join(here, "..", "scenes", "mitsuba-features", "assets")
os.makedirs(assets, exist_ok=True)


def shape(name, flags, pos, nrm, uv, tri, double):
    fmt = "d" if double else "f"
    raw = struct.pack("<I", flags) + name.encode() + b"\0" + struct.pack("<QQ", len(pos), len(tri))
    for arr in (pos, nrm, uv):
        for v in arr:
            raw += struct.pack("<%d%s" % (len(v), fmt), *v)
    for t in tri:
        raw += struct.pack("<3I", *t)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(raw)


floor = shape("floor", 0x1000 | 0x0001 | 0x0002,
              [(-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)],
              [(0, 1, 0)] * 4, [(0, 0), (1, 0), (1, 1), (0, 1)],
              [(0, 1, 2), (0, 2, 3)], False)
tet = shape("tetra", 0x2000 | 0x0010,
            [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [], [],
            [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)], True)
with open(os.path.join(assets, "stage.serialized"), "wb") as f:
    f.write(floor + tet + struct.pack("<QQI", 0, len(floor), 2))

rng = np.random.default_rng(7)
tiles = rng.integers(30, 250, size=(8, 8, 3), dtype=np.uint8)
mi.Bitmap(tiles, pixel_format=mi.Bitmap.PixelFormat.RGB).write(os.path.join(assets, "tiles.png"))
ramp = np.zeros((4, 16, 3), dtype=np.uint8)
for x in range(16):
    ramp[:, x] = (16 * x + 8, 200 - 10 * x, 60)
ramp[1::2, :, 2] = 180
mi.Bitmap(ramp, pixel_format=mi.Bitmap.PixelFormat.RGB).write(os.path.join(assets, "ramp.png"))

wall = rng.uniform(0.1, 0.8, size=(4, 4, 3)).astype("<f4")
with open(os.path.join(assets, "wall.pfm"), "wb") as f:
    f.write(b"PF\n4 4\n-1.0\n")
    f.write(wall[::-1].tobytes())  # PFM rows go bottom to top

# Mitsuba reads them as intended
b = np.array(mi.Bitmap(os.path.join(assets, "wall.pfm")))
assert np.allclose(b, wall), "PFM row order"
for idx, (nv, nf) in enumerate([(4, 2), (4, 4)]):
    m = mi.load_dict({"type": "serialized", "filename": os.path.join(assets, "stage.serialized"),
                      "shape_index": idx})
    assert (m.vertex_count(), m.face_count()) == (nv, nf), (idx, m.vertex_count(), m.face_count())
print("wrote", sorted(os.listdir(assets)))
