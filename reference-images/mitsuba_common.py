"""Helpers shared by the reference scripts: variant setup, scene loading with defines, naming."""
from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

import mitsuba as mi

HERE = Path(__file__).resolve().parent
VARIANT = "llvm_ad_rgb"


def set_variant(variant: str = VARIANT) -> None:
    """Selects the Mitsuba variant (llvm_ad_rgb by default) and registers our `btf` plugin."""
    try:
        mi.set_variant(variant)
    except Exception as e:  # noqa: BLE001 - report any failure clearly
        sys.exit(f"cannot set Mitsuba variant {variant!r}: {e} (did you run reference-images/setup.sh?)")
    sys.path.insert(0, str(HERE))
    import btf_plugin

    btf_plugin.register()


@contextlib.contextmanager
def io_threads():
    """Runs the body (Bitmap reads and writes, scene loading) with at least two Dr.Jit pool
    threads, then restores the count: Mitsuba's EXR reader and writer wait on pool tasks they
    cannot run themselves, so with `dr.set_thread_count(1)` they deadlock (Mitsuba 3.9.1)."""
    import drjit as dr

    n = dr.thread_count()
    dr.set_thread_count(max(n, 2))
    try:
        yield
    finally:
        dr.set_thread_count(n)


def parse_defines(items: list[str]) -> dict[str, str]:
    """`-D name=value` pairs → dict (Mitsuba substitutes them for `$name` / overrides <default>)."""
    out: dict[str, str] = {}
    for it in items or []:
        if "=" not in it:
            raise argparse.ArgumentTypeError(f"-D expects name=value, got {it!r}")
        k, v = it.split("=", 1)
        if not k:
            raise argparse.ArgumentTypeError(f"-D expects name=value, got {it!r}")
        out[k] = v
    return out


def scene_name(scene: Path) -> str:
    """`scenes/foo/scene.xml` → `foo`; `scenes/foo/scene-bar.xml` and `scenes/foo/bar.xml` → `foo-bar`."""
    scene = scene.resolve()
    if scene.stem == "scene":
        return scene.parent.name
    stem = scene.stem[len("scene-"):] if scene.stem.startswith("scene-") else scene.stem
    return f"{scene.parent.name}-{stem}"


def load_scene(path: Path, defines: dict[str, str]):
    """Loads a Mitsuba XML scene; exits with a message naming the file on error."""
    if not path.is_file():
        sys.exit(f"{path}: scene file not found")
    try:
        with io_threads():
            return mi.load_file(str(path), **defines)
    except Exception as e:  # noqa: BLE001
        sys.exit(f"{path}: Mitsuba cannot load the scene: {e}")
