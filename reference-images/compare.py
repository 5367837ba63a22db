#!/usr/bin/env python3
"""Per-pixel z-test of a render against a committed reference (the check btfpt's tests perform).

usage: compare.py TEST.exr REF.exr --spp N           (recommended)
       compare.py TEST.exr REF.exr --test-var TEST_VAR.exr

REF.exr is a reference written by render.py; REF_var.exr and REF_sample_var.exr are read beside it.
With --spp N (the test render's samples per pixel) the variance of the test mean is predicted from
the reference's per-sample variance, sample_var / N: robust, because the reference has seen the
rare bright paths that a low-spp render usually misses (its own variance estimate is then too
small, and the test fails spuriously on heavy-tailed pixels). With --test-var the test's own
variance of the mean is used instead.
z = (test - ref) / sqrt(var_test_mean + var_ref_mean) per pixel and channel; a pixel fails when a
channel's |z| exceeds the two-sided threshold at the Šidák-corrected level
1 - (1 - alpha)^(1 / (pixels·3)). Channels with zero total variance must agree to 1e-5 relative.
Exit code 0 when no pixel fails. Also prints relMSE = mean((test - ref)² / (ref² + 1e-2)).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.stats import norm


def read(path) -> np.ndarray:
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    try:
        a = np.array(mi.Bitmap(str(path)), dtype=np.float64)
    except Exception as e:  # noqa: BLE001
        sys.exit(f"{path}: cannot read: {e}")
    return a[..., :3]


def ztest(test, var_t, ref, var_r, alpha=0.01):
    """(failing-pixel mask, threshold, z array)."""
    n = test[..., 0].size * 3
    level = 1.0 - (1.0 - alpha) ** (1.0 / n)
    thr = norm.isf(level / 2)
    var = var_t + var_r
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(var > 0, (test - ref) / np.sqrt(var), 0.0)
    exact_bad = (var <= 0) & (np.abs(test - ref) > 1e-5 * np.maximum(np.abs(ref), 1e-3))
    bad = ((np.abs(z) > thr) | exact_bad | ~np.isfinite(test)).any(-1)
    return bad, thr, z


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("test", type=Path)
    ap.add_argument("ref", type=Path)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--spp", type=int, help="samples per pixel of the test render")
    g.add_argument("--test-var", type=Path, help="the test render's variance-of-the-mean image")
    ap.add_argument("--alpha", type=float, default=0.01)
    a = ap.parse_args(argv)
    stem = a.ref.with_suffix("")
    t, r = read(a.test), read(a.ref)
    vr = read(f"{stem}_var.exr")
    if a.spp is not None:
        if a.spp < 1:
            ap.error("--spp must be positive")
        vt = read(f"{stem}_sample_var.exr") / a.spp
    else:
        vt = read(a.test_var)
    if not (t.shape == vt.shape == r.shape == vr.shape):
        sys.exit(f"image sizes differ: test {t.shape}, reference {r.shape}")
    bad, thr, z = ztest(t, vt, r, vr, a.alpha)
    rel = float(np.mean((t - r) ** 2 / (r**2 + 1e-2)))
    print(f"pixels {bad.size}, failing {int(bad.sum())}, |z| threshold {thr:.2f}, max |z| {np.abs(z).max():.2f}, "
          f"mean z {z.mean():+.4f} (± {1 / np.sqrt(z.size):.4f} if unbiased), var(z) {z.var():.3f}, "
          f"relMSE {rel:.3e}")
    return 1 if bad.any() else 0


if __name__ == "__main__":
    sys.exit(main())
