"""Regenerates pplastic_golden.txt: eval/pdf/sample of Mitsuba 3's own `pplastic` BSDF
(scalar_rgb: the unpolarized response) at the fixed directions and random numbers of
bsdf_golden.py, in its line format; src/bsdf/tests/pplastic.rs builds the same configurations and
must reproduce every line.

    reference-images/.venv/bin/python reference-images/pplastic_golden.py \
        > reference-images/pplastic_golden.txt
"""
import bsdf_golden as g
from bsdf_golden import bitmap, checker, rgb, texels

# Textured parameters (4×3 raw bitmaps, bilinear, repeat, read at uv (0.3, 0.6)).
DIFF = texels(lambda i, j: 0.2 + 0.6 * ((i + 2 * j) % 4) / 4, (1.0, 0.7, 0.4))
ROUGH = texels(lambda i, j: 0.15 + 0.6 * ((2 * i + j) % 5) / 5, (1.0, 0.9, 1.1))

# Names must match src/bsdf/tests/pplastic.rs.
CONFIGS = {
    "pplastic_default": {"type": "pplastic"},
    "pplastic_ggx_specular": {"type": "pplastic", "distribution": "ggx", "alpha": 0.3,
                              "diffuse_reflectance": rgb([0.1, 0.5, 0.8]),
                              "specular_reflectance": rgb([0.9, 0.7, 0.5]),
                              "int_ior": 1.7, "ext_ior": 1.1},
    "pplastic_aniso_eta": {"type": "pplastic", "alpha_u": 0.05, "alpha_v": 0.4, "eta": 1.33,
                           "diffuse_reflectance": rgb([0.6, 0.3, 0.2])},
    "pplastic_beckmann_all_normals": {"type": "pplastic", "alpha": 0.2,
                                      "sample_visible": False, "int_ior": "bk7"},
    "pplastic_textured": {"type": "pplastic", "diffuse_reflectance": bitmap(DIFF),
                          "alpha": bitmap(ROUGH), "eta": checker(1.3, 1.8),
                          "specular_reflectance": checker(0.4, 0.9)},
}

if __name__ == "__main__":
    g.main(CONFIGS)
