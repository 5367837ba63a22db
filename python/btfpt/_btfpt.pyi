"""Type stubs of the compiled module btfpt._btfpt (see btfpt/__init__.py)."""

from os import PathLike
from typing import Any, Literal, Mapping, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike]
_F32 = npt.NDArray[np.float32]
_ArrayLike = npt.ArrayLike

class Btf:
    """A measured material (raw data or a fitted LM/PLM/PLM-C model) evaluated as the renderer does."""

    @staticmethod
    def open(path: _Path, model: Optional[Literal["raw", "lm", "plm", "plmc"]] = None, uv_scale: float = 1.0) -> "Btf":
        """Opens raw data (UBO2003 folder, .btf, .btfc, or a synth:... source read through the cache folder as scenes read it) or a .plmc model; `model` picks another representation found next to `path`."""
    def eval(self, uv: _ArrayLike, wi: _ArrayLike, wo: _ArrayLike) -> _F32:
        """B = π·f·cos θ_l of N queries: uv (N, 2), wi/wo (N, 3) unit local directions -> (N, 3) float32."""
    def pdf(self, uv: _ArrayLike, wi: _ArrayLike, wo: _ArrayLike) -> _F32:
        """Solid-angle pdf of sample() drawing wo -> (N,) float32."""
    def eval_pdf(self, uv: _ArrayLike, wi: _ArrayLike, wo: _ArrayLike) -> Tuple[_F32, _F32]:
        """(B, pdf) in one pass -> (N, 3), (N,)."""
    def sample(self, uv: _ArrayLike, wi: _ArrayLike, sample1: _ArrayLike, sample2: _ArrayLike) -> Tuple[_F32, _F32, _F32]:
        """(wo (N, 3), weight = f·cos/pdf (N, 3), pdf (N,)); zeros where no direction was drawn."""
    def _reference(self, uv: _ArrayLike, wi: _ArrayLike, wo: _ArrayLike, sample1: _ArrayLike, sample2: _ArrayLike) -> list:
        """The scalar renderer path query by query (test oracle)."""
    @property
    def views(self) -> _F32:
        """Measured view directions (V, 3)."""
    @property
    def lights(self) -> _F32:
        """Measured light directions (L, 3)."""
    @property
    def size(self) -> Tuple[int, int]:
        """Texels (width, height)."""
    @property
    def kind(self) -> Literal["raw", "lm", "plm", "plmc"]: ...
    @property
    def path(self) -> str: ...
    @property
    def uv_scale(self) -> float: ...
    def texel_image(self, view: int, light: int) -> _F32:
        """The image at measured view/light indices, (H, W, 3) float32 linear B."""

class Scene:
    """A loaded scene, reusable across renders."""

    @staticmethod
    def load(path: _Path, defines: Optional[Mapping[str, str]] = None, btf_model: Optional[str] = None) -> "Scene": ...
    @property
    def size(self) -> Tuple[int, int]: ...
    @property
    def spp(self) -> int: ...
    @property
    def btf_uses(self) -> list[dict[str, Any]]: ...
    @property
    def path(self) -> str: ...

@overload
def render(scene: Union[_Path, Scene], spp: Optional[int] = None, seed: int = 0, defines: Optional[Mapping[str, str]] = None,
           threads: Optional[int] = None, integrator: Literal["packet", "scalar"] = "packet", variance: Literal[False] = False,
           progress: bool = True) -> _F32: ...
@overload
def render(scene: Union[_Path, Scene], spp: Optional[int] = None, seed: int = 0, defines: Optional[Mapping[str, str]] = None,
           threads: Optional[int] = None, integrator: Literal["packet", "scalar"] = "packet", variance: Literal[True] = ...,
           progress: bool = True) -> Tuple[_F32, _F32]: ...
def read_image(path: _Path) -> _F32:
    """An image file as (H, W, 3) float32 linear RGB."""
def synth(material: str, size: Union[int, Tuple[int, int], None] = None, seed: int = 1, out: Optional[_Path] = None,
          directions: Literal["ubo2003", "ubo2014"] = "ubo2003", format: Literal["png8", "png16", "exr"] = "png8",
          progress: bool = True) -> str: ...
def fit(data: _Path, out: _Path, model: Literal["lm", "plm", "plmc"] = "plmc", clusters: int = 256,
        views: Optional[str] = None, tile: Optional[str] = None, progress: bool = True) -> dict[str, Any]:
    """Fits a model to `data` (a UBO2003 folder, .btf, .btfc or a synth:... source, read as `btfpt fit` reads it) into `out`."""
def eval_model(model: _Path, against: _Path, clusters: int = 256, features: int = 20, seed: int = 0,
               pca_k: Optional[int] = None, progress: bool = True) -> dict[str, Any]:
    """The document `btfpt eval MODEL --against DATA --json` writes (`against` as fit's `data`)."""
def compare(test: _Path, reference: _Path, spp: Optional[int] = None, test_variance: Optional[_Path] = None,
            variance: Optional[_Path] = None, sample_variance: Optional[_Path] = None, alpha: float = 0.01,
            scales: Sequence[int] = (4, 8, 16, 32), sample_variance_floor: float = 1e-4, block: int = 4,
            max_failing_pixels: Optional[int] = None, max_failing_blocks: Optional[int] = None,
            max_abs_mean_z: Optional[float] = None, max_relmse: Optional[float] = None) -> dict[str, Any]:
    """The document `btfpt compare --json` writes, as a dict (`passed`, `failures`, `comparison`...)."""
