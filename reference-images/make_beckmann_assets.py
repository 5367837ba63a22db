"""Writes scenes/mitsuba-beckmann/height.png: the 32×32 bump map of that scene (a 4×4 grid of
smooth bumps, h = ½ + ½ sin(2π·4x/32) sin(2π·4y/32) at texel centres), 8-bit RGB (r = g = b),
used with raw=true so both renderers read the stored value / 255. Python standard library only.

    python3 reference-images/make_beckmann_assets.py
"""
import math
import os
import struct
import zlib

N = 32


def chunk(tag, data):
    c = struct.pack(">I", len(data)) + tag + data
    return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def main():
    rows = []
    for y in range(N):
        row = bytearray([0])  # filter: none
        for x in range(N):
            h = 0.5 + 0.5 * math.sin(2 * math.pi * 4 * (x + 0.5) / N) * math.sin(
                2 * math.pi * 4 * (y + 0.5) / N)
            v = max(0, min(255, round(255 * h)))
            row += bytes([v, v, v])
        rows.append(bytes(row))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", N, N, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b"")
    out = os.path.join(os.path.dirname(__file__), "..", "scenes", "mitsuba-beckmann", "height.png")
    with open(out, "wb") as f:
        f.write(png)


if __name__ == "__main__":
    main()
