"""Writes scenes/mitsuba-emitters/pattern.png: an 8×6 sRGB image of coloured stripes and a
bright square, what the scene's projector and textured spot project (its aspect 4:3 sets the
projector's frustum).

    reference-images/.venv/bin/python reference-images/make_emitter_assets.py
"""
from pathlib import Path

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

W, H = 8, 6
img = np.zeros((H, W, 3), dtype=np.uint8)
for j in range(H):
    for i in range(W):
        img[j, i] = [40 + 200 * (i % 2), 60 + 30 * j, 220 - 25 * i]
img[1:3, 5:7] = 255
out = Path(__file__).resolve().parent.parent / "scenes" / "mitsuba-emitters" / "pattern.png"
mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(out))
print("wrote", out)
