"""Regenerates principled_golden.txt: eval/pdf/sample of Mitsuba 3's own `principled` and `principledthin` BSDFs
(scalar_rgb) at the fixed directions and random numbers of bsdf_golden.py, in its line format;
src/bsdf/tests/principled.rs builds the same configurations and must reproduce every line.

    reference-images/.venv/bin/python reference-images/principled_golden.py \
        > reference-images/principled_golden.txt
"""
import bsdf_golden as g
from bsdf_golden import bitmap, checker, rgb, texels

# Textured weights (4×3 raw bitmaps, bilinear, repeat, read at uv (0.3, 0.6)).
BASE = texels(lambda i, j: 0.2 + 0.6 * ((i + 2 * j) % 4) / 4, (1.0, 0.7, 0.4))
ROUGH = texels(lambda i, j: 0.15 + 0.6 * ((2 * i + j) % 5) / 5, (1.0, 0.9, 1.1))

# Names must match src/bsdf/tests/principled.rs.
CONFIGS = {
    "principled_default": {"type": "principled"},
    "principled_sheen_coat": {"type": "principled", "base_color": rgb([0.8, 0.3, 0.2]),
                              "roughness": 0.3, "metallic": 0.2, "spec_tint": 0.5,
                              "sheen": 0.6, "sheen_tint": 0.4, "clearcoat": 0.7,
                              "clearcoat_gloss": 0.6, "specular": 0.6},
    "principled_trans_aniso": {"type": "principled", "base_color": rgb([0.9, 0.8, 0.6]),
                               "spec_trans": 0.7, "roughness": 0.25, "eta": 1.45,
                               "anisotropic": 0.5, "metallic": 0.1, "clearcoat": 0.3},
    "principled_flat_rates": {"type": "principled", "base_color": rgb([0.2, 0.5, 0.8]),
                              "flatness": 0.6, "roughness": 0.8, "anisotropic": 0.8,
                              "diffuse_reflectance_sampling_rate": 0.5,
                              "main_specular_sampling_rate": 2.0,
                              "clearcoat_sampling_rate": 3.0, "clearcoat": 0.5},
    "principled_glass": {"type": "principled", "spec_trans": 1.0, "roughness": 0.1,
                         "eta": 1.5, "base_color": rgb([1.0, 1.0, 1.0])},
    "principled_metal": {"type": "principled", "metallic": 1.0, "roughness": 0.35,
                         "base_color": rgb([0.95, 0.7, 0.3]), "anisotropic": 0.3},
    "principled_eta_below_one": {"type": "principled", "spec_trans": 0.5, "eta": 0.8,
                                 "roughness": 0.4, "spec_tint": 0.7, "sheen": 0.3},
    "principled_textured": {"type": "principled", "base_color": bitmap(BASE),
                            "roughness": bitmap(ROUGH), "metallic": checker(0.1, 0.6),
                            "spec_trans": 0.3, "eta": 1.3, "clearcoat": checker(0.2, 0.9),
                            "clearcoat_gloss": 0.3, "sheen": 0.5, "sheen_tint": 0.8,
                            "anisotropic": 0.2, "flatness": 0.4, "spec_tint": 0.3},
    "principledthin_default": {"type": "principledthin"},
    "principledthin_all": {"type": "principledthin", "base_color": rgb([0.7, 0.4, 0.2]),
                           "roughness": 0.35, "anisotropic": 0.4, "spec_trans": 0.6,
                           "eta": 1.4, "spec_tint": 0.5, "sheen": 0.5, "sheen_tint": 0.6,
                           "flatness": 0.3, "diff_trans": 0.8,
                           "specular_reflectance_sampling_rate": 1.5,
                           "specular_transmittance_sampling_rate": 0.7,
                           "diffuse_reflectance_sampling_rate": 2.0,
                           "diffuse_transmittance_sampling_rate": 0.5},
    "principledthin_textured": {"type": "principledthin", "base_color": bitmap(BASE),
                                "roughness": bitmap(ROUGH), "spec_trans": checker(0.3, 0.8),
                                "eta": checker(1.2, 1.6), "diff_trans": 1.4},
}

if __name__ == "__main__":
    g.main(CONFIGS)
