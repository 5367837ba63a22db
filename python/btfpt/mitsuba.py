"""A Mitsuba 3 BSDF plugin ``btf`` that renders btfpt materials (fitted ``.plmc`` models or raw
data) through btfpt's batched kernels and btfpt's light sampler::

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")          # or scalar_rgb, llvm_rgb, ...
    import btfpt.mitsuba
    btfpt.mitsuba.register()
    scene = mi.load_file("scene.xml")      # <bsdf type="btf"> with filename, uv_scale, model

Parameters: ``filename`` (a ``.plmc`` file, raw BTF data or a ``synth:`` source; relative to the
scene), ``uv_scale`` (texture repeats per unit uv, 1), ``model`` ("raw", "lm", "plm", "plmc"; the
file's own by default). The conventions are btfpt's (docs/conventions.md): local shading frame,
``si.wi`` the view, ``wo`` the light, B = π · f · cos θ_l, so ``eval`` returns B / π.

In the JIT (``llvm_*``) variants each call receives a whole wavefront: its Dr.Jit arrays become
numpy arrays (one evaluation of the wavefront, no per-element Python), btfpt evaluates or samples
all of it with the GIL released, and the results go back as Dr.Jit arrays. That needs evaluated,
not recorded, loops and virtual calls, which :func:`register` switches on (``dr.JitFlag.
SymbolicLoops`` and ``SymbolicCalls`` off). Scalar variants call the plugin once per ray.
"""
from __future__ import annotations

import math

import numpy as np

from ._btfpt import Btf

__all__ = ["register", "bsdf_class"]

_CLASSES: dict = {}


def _np(x, n=None):
    """A Dr.Jit array (or a Python float in scalar variants) as a float32 numpy array."""
    a = np.asarray(x, dtype=np.float32).reshape(-1)
    if n is not None and a.size == 1 and n > 1:
        a = np.full(n, a[0], dtype=np.float32)
    return a


def _vec(v):
    """A Dr.Jit 3-vector as (N, 3) float32."""
    xs = [_np(v.x), _np(v.y), _np(v.z)]
    n = max(a.size for a in xs)
    return np.stack([_np(c, n) for c in [v.x, v.y, v.z]], axis=1)


def _sanitise(d):
    """Directions btfpt accepts: non-finite or non-unit rows become (0, 0, -1), which every
    kernel answers with 0 (below the horizon)."""
    ok = np.isfinite(d).all(axis=1)
    d = np.where(ok[:, None], d, 0.0)
    length = np.linalg.norm(d, axis=1)
    ok &= np.abs(length - 1) <= 1e-3
    d = np.where(ok[:, None], d / np.where(ok, length, 1.0)[:, None], np.array([0.0, 0.0, -1.0]))
    return np.ascontiguousarray(d, dtype=np.float32), ok


def _make_class(variant: str):
    import drjit as dr
    import mitsuba as mi

    scalar = variant.startswith("scalar")

    def color(b):
        if scalar:
            return mi.Color3f(float(b[0, 0]), float(b[0, 1]), float(b[0, 2]))
        return mi.Color3f(mi.Float(b[:, 0]), mi.Float(b[:, 1]), mi.Float(b[:, 2]))

    def floats(a):
        return float(a[0]) if scalar else mi.Float(a)

    def vector(w):
        if scalar:
            return mi.Vector3f(float(w[0, 0]), float(w[0, 1]), float(w[0, 2]))
        return mi.Vector3f(mi.Float(w[:, 0]), mi.Float(w[:, 1]), mi.Float(w[:, 2]))

    class BtfptBsdf(mi.BSDF):
        """btfpt's measured material (see the module docstring)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if "filename" not in props:
                raise ValueError("btf: the 'filename' string parameter is required")
            name = str(props["filename"])
            if not name.startswith("synth:"):
                name = str(mi.file_resolver().resolve(name))
            self.uv_scale = float(props["uv_scale"]) if "uv_scale" in props else 1.0
            model = str(props["model"]) if "model" in props else None
            self.btf = Btf.open(name, model=model, uv_scale=self.uv_scale)
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.SpatiallyVarying
            self.m_components = [flags]
            self.m_flags = flags

        def _queries(self, si, active):
            wi, ok_i = _sanitise(_vec(si.wi))
            n = wi.shape[0]
            uv = np.stack([_np(si.uv.x, n), _np(si.uv.y, n)], axis=1)
            ok_uv = np.isfinite(uv).all(axis=1)
            uv = np.where(ok_uv[:, None], uv, 0.0).astype(np.float32)
            act = _np(active, n) != 0 if not isinstance(active, bool) else np.full(n, active)
            ok = ok_i & ok_uv & act
            wi[~ok] = (0.0, 0.0, -1.0)
            return uv, wi, n

        def _eval_pdf(self, si, wo, active):
            uv, wi, n = self._queries(si, active)
            w, ok = _sanitise(_vec(wo))
            b, pdf = self.btf.eval_pdf(uv, wi, w)
            return b * np.float32(1 / math.pi), pdf

        def eval(self, ctx, si, wo, active=True):
            f, _ = self._eval_pdf(si, wo, active)
            return color(f)

        def pdf(self, ctx, si, wo, active=True):
            _, pdf = self._eval_pdf(si, wo, active)
            return floats(pdf)

        def eval_pdf(self, ctx, si, wo, active=True):
            f, pdf = self._eval_pdf(si, wo, active)
            return color(f), floats(pdf)

        def sample(self, ctx, si, sample1, sample2, active=True):
            uv, wi, n = self._queries(si, active)
            u1 = np.clip(_np(sample1, n), 0.0, 1.0)
            u2 = np.clip(np.stack([_np(sample2.x, n), _np(sample2.y, n)], axis=1), 0.0, 1.0)
            wo, weight, pdf = self.btf.sample(uv, wi, u1, u2)
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection):
                pdf[:] = 0.0
                weight[:] = 0.0
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = vector(wo)
            bs.pdf = floats(pdf)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            return bs, color(weight)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"BtfptBsdf[{self.btf!r}]"

    return BtfptBsdf


def bsdf_class():
    """The plugin class for the current Mitsuba variant (made on first use)."""
    import mitsuba as mi

    v = mi.variant()
    if v is None:
        raise RuntimeError("btfpt.mitsuba: call mi.set_variant(...) first")
    if v not in _CLASSES:
        _CLASSES[v] = _make_class(v)
    return _CLASSES[v]


def register() -> None:
    """Registers the plugin as ``btf`` for the current variant (``llvm_*`` or ``scalar_*``) and,
    in JIT variants, switches Dr.Jit to evaluated loops and calls so that each plugin call sees a
    whole evaluated wavefront."""
    import drjit as dr
    import mitsuba as mi

    v = mi.variant() or ""
    if not (v.startswith("llvm_") or v.startswith("scalar_")):
        raise RuntimeError(f"btfpt.mitsuba: variant {v!r} is not supported (llvm_* or scalar_*)")
    if v.startswith("llvm_"):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    cls = bsdf_class()
    mi.register_bsdf("btf", lambda props: cls(props))
