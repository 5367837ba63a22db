"""btfpt from Python: measured BTFs and fitted PLM-C models on numpy arrays, rendering, fitting,
evaluation and comparison, with the same numbers as the `btfpt` command line.

Conventions (docs/conventions.md): directions are unit vectors in the local shading frame (z the
normal), ``wi`` towards the camera (view), ``wo`` towards the light; a BTF value is
B = π · f · cos θ_l, linear RGB."""

from . import errors
from ._btfpt import Btf, __version__
from .errors import Error

__all__ = ["Btf", "Error", "errors", "__version__"]
