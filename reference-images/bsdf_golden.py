"""Regenerates bsdf_golden.txt: eval/pdf/sample of Mitsuba 3's own BSDF plugins (scalar_rgb)
at fixed directions and random numbers, the reference that src/bsdf/golden.rs tests against.

    python -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba
    /tmp/mts/bin/python reference-images/bsdf_golden.py > reference-images/bsdf_golden.txt

Line formats (whitespace separated, one case per line):
    bsdf <id> <name>                                      (configuration, see CONFIGS / golden.rs)
    eval <id> wix wiy wiz wox woy woz  r g b  pdf
    sample <id> wix wiy wiz s1 u1 u2  ok wox woy woz pdf eta type  r g b
(type = Mitsuba 3 BSDFFlags: 1 null, 2 diffuse refl., 8 glossy refl., 32 delta refl.,
 16 glossy transm., 64 delta transm.; ok = 1 if the sample has pdf > 0 and a non-zero weight)
"""
import math
import random

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

GOLD_ETA = [0.143, 0.374, 1.442]
GOLD_K = [3.983, 2.385, 1.603]


def rgb(v):
    return {"type": "rgb", "value": v}


def rough(au, av, vis, distribution="ggx"):
    d = {"type": "roughconductor", "alpha_u": au, "alpha_v": av,
         "eta": rgb(GOLD_ETA), "k": rgb(GOLD_K), "sample_visible": vis,
         "specular_reflectance": rgb([0.9, 0.8, 0.7])}
    if distribution is not None:
        d["distribution"] = distribution
    return d


# A 4×3 raw RGB height image (rows top to bottom), the same texels as golden.rs's BUMP_TEXELS:
# value (i, j) = 0.1 + 0.2·((3·i + 5·j) mod 7) / 7 scaled per channel by (1, 0.8, 1.3).
BUMP = np.array([[[v, 0.8 * v, 1.3 * v] for v in
                  (0.1 + 0.2 * ((3 * i + 5 * j) % 7) / 7 for i in range(4))] for j in range(3)],
                dtype=np.float32)


# Textured parameters (raw bitmaps read with bilinear filtering and repeat wrap at uv (0.3, 0.6);
# golden.rs builds the same texels): a roughness image whose channels differ (eval_1 takes the
# luminance) and complex-IOR images.
def texels(f, scales):
    return np.array([[[s * f(i, j) for s in scales] for i in range(4)] for j in range(3)],
                    dtype=np.float32)


ALPHA = texels(lambda i, j: 0.05 + 0.5 * ((2 * i + 3 * j) % 5) / 5, (1.0, 0.7, 1.4))
ETA = texels(lambda i, j: 0.2 + 0.3 * ((i + 2 * j) % 4), (1.0, 1.5, 0.6))
K = texels(lambda i, j: 2.0 + 0.4 * ((3 * i + j) % 5), (1.0, 0.8, 0.6))


def bitmap(a):
    return {"type": "bitmap", "bitmap": mi.Bitmap(a), "raw": True}


def checker(c0, c1):
    return {"type": "checkerboard", "color0": c0, "color1": c1}


def bump(nested, scale):
    return {"type": "bumpmap", "scale": scale, "nested": nested,
            "height": {"type": "bitmap", "bitmap": mi.Bitmap(BUMP), "raw": True}}


# Names must match golden.rs.
CONFIGS = {
    "diffuse": {"type": "diffuse", "reflectance": rgb([0.2, 0.5, 0.8])},
    "rough_iso_vis": rough(0.3, 0.3, True),
    "rough_aniso_vis": rough(0.5, 0.1, True),
    "rough_aniso_novis": rough(0.12, 0.45, False),
    "rough_iso_novis": rough(0.2, 0.2, False),
    "conductor_gold": {"type": "conductor", "eta": rgb(GOLD_ETA), "k": rgb(GOLD_K),
                       "specular_reflectance": rgb([1.0, 0.9, 0.8])},
    "conductor_none": {"type": "conductor", "material": "none"},
    "dielectric": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0},
    "dielectric_tinted": {"type": "dielectric", "int_ior": 1.33, "ext_ior": 1.0,
                          "specular_reflectance": rgb([0.5, 0.6, 0.7]),
                          "specular_transmittance": rgb([0.9, 0.3, 0.4])},
    "thindielectric": {"type": "thindielectric", "int_ior": 1.5, "ext_ior": 1.0,
                       "specular_transmittance": rgb([0.9, 0.8, 0.7])},
    "twosided_rough": {"type": "twosided", "a": rough(0.3, 0.1, True),
                       "b": {"type": "diffuse", "reflectance": rgb([0.3, 0.2, 0.1])}},
    "plastic": {"type": "plastic", "diffuse_reflectance": rgb([0.2, 0.5, 0.8])},
    "plastic_nonlinear": {"type": "plastic", "int_ior": 1.7, "ext_ior": 1.0, "nonlinear": True,
                          "diffuse_reflectance": rgb([0.6, 0.3, 0.1]),
                          "specular_reflectance": rgb([0.8, 0.9, 1.0])},
    "roughplastic": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2,
                     "diffuse_reflectance": rgb([0.2, 0.5, 0.8])},
    "roughplastic_nonlinear_novis": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.45,
                                     "int_ior": 1.7, "ext_ior": 1.0, "nonlinear": True,
                                     "sample_visible": False,
                                     "diffuse_reflectance": rgb([0.6, 0.3, 0.1]),
                                     "specular_reflectance": rgb([0.8, 0.9, 1.0])},
    "roughdielectric": {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.25,
                        "int_ior": 1.5, "ext_ior": 1.0},
    "roughdielectric_aniso_novis": {"type": "roughdielectric", "distribution": "ggx",
                                    "alpha_u": 0.4, "alpha_v": 0.1, "int_ior": 1.33,
                                    "ext_ior": 1.0, "sample_visible": False,
                                    "specular_reflectance": rgb([0.5, 0.6, 0.7]),
                                    "specular_transmittance": rgb([0.9, 0.3, 0.4])},
    "blend": {"type": "blendbsdf", "weight": 0.3, "a": rough(0.3, 0.3, True),
              "b": {"type": "diffuse", "reflectance": rgb([0.3, 0.2, 0.1])}},
    "mask": {"type": "mask", "opacity": 0.35,
             "a": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.1,
                   "diffuse_reflectance": rgb([0.1, 0.6, 0.3])}},
    "normalmap": {"type": "normalmap", "normalmap": rgb([0.7, 0.35, 0.9]),
                  "a": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2,
                        "diffuse_reflectance": rgb([0.5, 0.3, 0.2])}},
    "normalmap_rough": {"type": "normalmap", "normalmap": rgb([0.2, 0.6, 0.8]),
                        "a": rough(0.3, 0.1, True)},
    # Beckmann, Mitsuba's default distribution: left unnamed except where it is spelt out.
    "beckmann_rough_iso_vis": rough(0.3, 0.3, True, None),
    "beckmann_rough_aniso_vis": rough(0.5, 0.1, True, "beckmann"),
    "beckmann_rough_aniso_novis": rough(0.12, 0.45, False, None),
    "beckmann_rough_iso_novis": rough(0.2, 0.2, False, None),
    "beckmann_rough_smooth_vis": rough(0.03, 0.03, True, None),
    "beckmann_roughplastic": {"type": "roughplastic", "alpha": 0.2,
                              "diffuse_reflectance": rgb([0.2, 0.5, 0.8])},
    "beckmann_roughplastic_nonlinear_novis": {"type": "roughplastic", "alpha": 0.45,
                                              "int_ior": 1.7, "ext_ior": 1.0, "nonlinear": True,
                                              "sample_visible": False,
                                              "diffuse_reflectance": rgb([0.6, 0.3, 0.1]),
                                              "specular_reflectance": rgb([0.8, 0.9, 1.0])},
    "beckmann_roughdielectric": {"type": "roughdielectric", "alpha": 0.25, "int_ior": 1.5,
                                 "ext_ior": 1.0},
    "beckmann_roughdielectric_aniso_novis": {"type": "roughdielectric", "alpha_u": 0.4,
                                             "alpha_v": 0.1, "int_ior": 1.33, "ext_ior": 1.0,
                                             "sample_visible": False,
                                             "specular_reflectance": rgb([0.5, 0.6, 0.7]),
                                             "specular_transmittance": rgb([0.9, 0.3, 0.4])},
    # Bump maps on the test plane (dp/du = x, dp/dv = y, n = z) at uv (0.3, 0.6).
    "bumpmap_roughplastic": bump({"type": "roughplastic", "alpha": 0.2,
                                  "diffuse_reflectance": rgb([0.5, 0.3, 0.2])}, 0.3),
    "bumpmap_rough_aniso": bump(rough(0.3, 0.1, True), 0.5),
    # Textured roughness and IOR (Mitsuba's unbounded textures, alpha read with eval_1; the
    # checkerboard's eval_1 picks color0 at uv (0.3, 0.6) where its eval would pick color1).
    "rough_textured_alpha": {"type": "roughconductor", "distribution": "ggx",
                             "alpha_u": bitmap(ALPHA), "alpha_v": checker(0.1, 0.45),
                             "eta": rgb(GOLD_ETA), "k": rgb(GOLD_K),
                             "specular_reflectance": rgb([0.9, 0.8, 0.7])},
    "beckmann_rough_textured_novis": {"type": "roughconductor", "alpha": bitmap(ALPHA),
                                      "sample_visible": False, "eta": bitmap(ETA),
                                      "k": bitmap(K)},
    "conductor_textured_ior": {"type": "conductor", "eta": bitmap(ETA), "k": bitmap(K)},
    "roughdielectric_checker_alpha": {"type": "roughdielectric", "distribution": "ggx",
                                      "alpha": checker(0.1, 0.45), "int_ior": 1.5,
                                      "ext_ior": 1.0},
}


def direction(theta, phi):
    return mi.Vector3f(math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                       math.cos(theta))


def fmt(x):
    return "%.9g" % float(x)


def main(configs=CONFIGS):
    rng = random.Random(1234)
    ctx = mi.BSDFContext()
    for cid, (name, desc) in enumerate(configs.items()):
        bsdf = mi.load_dict(desc)
        print("bsdf", cid, name)
        thetas_i = [0.0, 0.4, 1.1, 1.5, 2.0, 2.9]
        for ti in thetas_i:
            wi = direction(ti, 0.7)
            si = mi.SurfaceInteraction3f()
            si.wi = wi
            si.uv = mi.Point2f(0.3, 0.6)
            # The plane of SurfaceInteraction::for_tests (what bumpmap differentiates).
            si.n = mi.Normal3f(0, 0, 1)
            si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0),
                                     mi.Vector3f(0, 0, 1))
            si.dp_du = mi.Vector3f(1, 0, 0)
            si.dp_dv = mi.Vector3f(0, 1, 0)
            for _ in range(4):
                wo = direction(rng.uniform(0, math.pi), rng.uniform(0, 2 * math.pi))
                v = bsdf.eval(ctx, si, wo)
                p = bsdf.pdf(ctx, si, wo)
                print("eval", cid, *map(fmt, [*wi, *wo, *v, p]))
            # The exact mirror direction too (peak of the glossy lobe).
            wo = mi.Vector3f(-wi.x, -wi.y, wi.z)
            v = bsdf.eval(ctx, si, wo)
            p = bsdf.pdf(ctx, si, wo)
            print("eval", cid, *map(fmt, [*wi, *wo, *v, p]))
            for _ in range(4):
                s1, u1, u2 = rng.random(), rng.random(), rng.random()
                bs, w = bsdf.sample(ctx, si, s1, mi.Point2f(u1, u2))
                ok = int(bs.pdf > 0 and max(w) > 0)
                print("sample", cid, *map(fmt, [*wi, s1, u1, u2]), ok,
                      *map(fmt, [*bs.wo, bs.pdf, bs.eta]), int(bs.sampled_type), *map(fmt, w))


if __name__ == "__main__":
    main()
