#!/usr/bin/env python3
"""Writes scenes/mitsuba-mesh-attribute/grid.ply: an 8x8-quad grid over [-1, 1]^2 (z = 0), ASCII,
as triangles, with per-vertex colours (float r, g, b in [0, 1]: Mitsuba's `vertex_color`) and a per-face `weight_0` (float: `face_weight`). Deterministic; no dependencies.

usage: reference-images/make_mesh_attribute_assets.py
"""
from pathlib import Path

N = 8
out = Path(__file__).resolve().parent.parent / "scenes" / "mitsuba-mesh-attribute" / "grid.ply"
lines = [
    "ply", "format ascii 1.0",
    "comment written by reference-images/make_mesh_attribute_assets.py",
    f"element vertex {(N + 1) ** 2}",
    "property float x", "property float y", "property float z",
    "property float r", "property float g", "property float b",
    f"element face {2 * N * N}",
    "property list uchar int vertex_indices", "property float weight_0",
    "end_header",
]
for j in range(N + 1):
    for i in range(N + 1):
        x, y = 2 * i / N - 1, 2 * j / N - 1
        r, g, b = i / N, j / N, (i + j) * 97 % 256 / 255
        lines.append(f"{x:g} {y:g} 0 {r:.6f} {g:.6f} {b:.6f}")
for j in range(N):
    for i in range(N):
        v = j * (N + 1) + i
        w = ((i * 7 + j * 3) % 10) / 9
        # Two triangles per quad (Mitsuba's PLY reader takes triangles only), same weight.
        lines.append(f"3 {v} {v + 1} {v + N + 2} {w:.6f}")
        lines.append(f"3 {v} {v + N + 2} {v + N + 1} {w:.6f}")
out.write_text("\n".join(lines) + "\n")
print(f"wrote {out}")
