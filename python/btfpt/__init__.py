"""btfpt from Python: measured BTFs and fitted PLM-C models on numpy arrays, rendering, fitting,
evaluation and comparison, with the same numbers as the `btfpt` command line."""

from ._btfpt import __version__

__all__ = ["__version__"]
