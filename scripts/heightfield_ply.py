#!/usr/bin/env python3
"""Writes a noisy height field as a binary little-endian PLY (float x y z, uchar/uint faces) and
a Mitsuba 3 scene that renders it: the mesh for scripts/scaling.sh, made here so the scaling
measurements need no downloads.

usage: heightfield_ply.py TRIANGLES OUT_DIR [--spp N] [--size PIXELS]

The grid has s x s quads (2 s^2 ~ TRIANGLES triangles) over [-1, 1]^2 in the z = 0 plane, the
height a sum of sines plus a deterministic hash noise (amplitude 0.02), so every triangle has
non-zero area and no two runs differ. numpy is used when importable (the Mitsuba venv has it),
otherwise the same bytes come from the standard library, row by row.
"""
import argparse
import math
import os
import struct
import sys


def heights_row(j, s):
    """Heights of vertex row j (s + 1 values) in the standard library."""
    y = -1.0 + 2.0 * j / s
    out = []
    for i in range(s + 1):
        x = -1.0 + 2.0 * i / s
        h = (i * 73856093) ^ (j * 19349663)
        h = ((h * 2654435761) & 0xFFFFFFFF) / 4294967296.0
        out.append(0.05 * math.sin(7.0 * x) * math.cos(5.0 * y) + 0.02 * (h - 0.5))
    return out


def write_stdlib(f, s):
    """Vertices then faces, a row at a time (no numpy)."""
    for j in range(s + 1):
        y = -1.0 + 2.0 * j / s
        hs = heights_row(j, s)
        row = []
        for i in range(s + 1):
            row.extend((-1.0 + 2.0 * i / s, y, hs[i]))
        f.write(struct.pack("<%df" % len(row), *row))
    quad = struct.Struct("<BIIIBIII")
    for j in range(s):
        buf = bytearray()
        for i in range(s):
            a = j * (s + 1) + i
            b, c, d = a + 1, a + s + 2, a + s + 1
            buf += quad.pack(3, a, b, c, 3, a, c, d)
        f.write(buf)


def write_numpy(f, s, np):
    """The same bytes as write_stdlib, vectorised, in bands of rows."""
    band = max(1, 4_000_000 // (s + 1))
    i = np.arange(s + 1, dtype=np.int64)
    xs = -1.0 + 2.0 * i / s
    for j0 in range(0, s + 1, band):
        j = np.arange(j0, min(s + 1, j0 + band), dtype=np.int64)[:, None]
        y = -1.0 + 2.0 * j / s
        h = (i[None, :] * 73856093) ^ (j * 19349663)
        h = ((h * 2654435761) & 0xFFFFFFFF) / 4294967296.0
        z = 0.05 * np.sin(7.0 * xs[None, :]) * np.cos(5.0 * y) + 0.02 * (h - 0.5)
        v = np.empty((len(j), s + 1, 3), dtype="<f4")
        v[:, :, 0] = xs[None, :]
        v[:, :, 1] = y
        v[:, :, 2] = z
        f.write(v.tobytes())
    rec = np.dtype([("n", "u1"), ("i", "<u4", (3,))])
    for j0 in range(0, s, band):
        j = np.arange(j0, min(s, j0 + band), dtype=np.int64)[:, None]
        a = j * (s + 1) + np.arange(s, dtype=np.int64)[None, :]
        faces = np.empty((len(j), s, 2), dtype=rec)
        faces["n"] = 3
        faces["i"][:, :, 0, 0] = a
        faces["i"][:, :, 0, 1] = a + 1
        faces["i"][:, :, 0, 2] = a + s + 2
        faces["i"][:, :, 1, 0] = a
        faces["i"][:, :, 1, 1] = a + s + 2
        faces["i"][:, :, 1, 2] = a + s + 1
        f.write(faces.tobytes())


SCENE = """<?xml version="1.0" encoding="utf-8"?>
<!-- A noisy height field of {tris} triangles under a constant sky (scripts/heightfield_ply.py). -->
<scene version="3.0.0">
    <integrator type="path">
        <integer name="max_depth" value="4"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world">
            <lookat origin="0, -2.2, 2.0" target="0, 0, 0" up="0, 0, 1"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="{spp}"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="{size}"/>
            <integer name="height" value="{size}"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <emitter type="constant">
        <rgb name="radiance" value="1, 1, 1"/>
    </emitter>
    <shape type="ply">
        <string name="filename" value="heightfield.ply"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.6, 0.5, 0.4"/>
        </bsdf>
    </shape>
</scene>
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("triangles", type=int)
    ap.add_argument("out_dir")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--size", type=int, default=128)
    a = ap.parse_args()
    s = max(1, round(math.sqrt(a.triangles / 2)))
    os.makedirs(a.out_dir, exist_ok=True)
    ply = os.path.join(a.out_dir, "heightfield.ply")
    with open(ply, "wb") as f:
        f.write(
            (
                "ply\nformat binary_little_endian 1.0\n"
                f"comment noisy height field, {s}x{s} quads\n"
                f"element vertex {(s + 1) ** 2}\n"
                "property float x\nproperty float y\nproperty float z\n"
                f"element face {2 * s * s}\n"
                "property list uchar uint vertex_indices\nend_header\n"
            ).encode()
        )
        try:
            import numpy as np
        except ImportError:
            np = None
        if np is not None:
            write_numpy(f, s, np)
        else:
            write_stdlib(f, s)
    with open(os.path.join(a.out_dir, "scene.xml"), "w") as f:
        f.write(SCENE.format(tris=2 * s * s, spp=a.spp, size=a.size))
    print(2 * s * s)


if __name__ == "__main__":
    sys.exit(main())
