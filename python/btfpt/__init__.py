"""btfpt from Python: measured BTFs and fitted PLM-C models on numpy arrays, rendering, fitting,
evaluation and comparison, with the same numbers as the `btfpt` command line.

Conventions (docs/conventions.md): directions are unit vectors in the local shading frame (z the
normal), ``wi`` towards the camera (view), ``wo`` towards the light; a BTF value is
B = π · f · cos θ_l, linear RGB. Errors raise :class:`btfpt.Error` subclasses (``btfpt.errors``)
with the message the command line prints."""

from . import errors
from ._btfpt import Btf, Scene, __version__, compare, eval_model, fit, read_image, render, synth
from .errors import Error

__all__ = ["Btf", "Scene", "Error", "errors", "compare", "eval_model", "fit", "read_image", "render", "synth",
           "__version__"]
