#!/usr/bin/env python3
"""Writes tests/data/two-shapes.serialized (Mitsuba's serialized mesh format, v4: a triangle with
vertex normals in single precision, then a uv-mapped quad in double precision) and checks that
Mitsuba 3 reads both shapes as written: src/scene/serialized.rs tests read the same file."""
import struct, zlib, os, sys
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "..", "tests", "data", "two-shapes.serialized")

def shape(name, flags, pos, nrm, uv, tri, double):
    fmt = "d" if double else "f"
    raw = struct.pack("<I", flags) + name.encode() + b"\0" + struct.pack("<QQ", len(pos), len(tri))
    for arr in (pos, nrm, uv):
        for v in arr:
            raw += struct.pack("<%d%s" % (len(v), fmt), *v)
    for t in tri:
        raw += struct.pack("<3I", *t)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(raw)

tri = shape("tri", 0x1000 | 0x0001, [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
            [(0, 0, 1), (0, 0.6, 0.8), (0.6, 0, 0.8)], [], [(0, 1, 2)], False)
quad = shape("quad", 0x2000 | 0x0002, [(0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1)], [],
             [(0, 0), (1, 0), (1, 1), (0, 1)], [(0, 1, 2), (0, 2, 3)], True)
data = tri + quad + struct.pack("<QQI", 0, len(tri), 2)
with open(out, "wb") as f:
    f.write(data)

for idx in (0, 1):
    m = mi.load_dict({"type": "serialized", "filename": out, "shape_index": idx})
    import drjit as dr
    print(idx, m.vertex_count(), m.face_count(), list(m.vertex_positions_buffer()),
          list(m.vertex_normals_buffer()), list(m.vertex_texcoords_buffer()), list(m.faces_buffer()))
