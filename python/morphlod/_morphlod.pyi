"""Type stubs of morphlod's Rust extension (python/src/lib.rs). The public API is
morphlod/__init__.py, which converts and checks arrays and documents each function; call
these directly only with C-contiguous arrays of the dtypes named."""

from typing import Callable, Optional, Sequence

import numpy as np
import numpy.typing as npt

Progress = Callable[[str, float], object]

UV_WEIGHT: float
NORMAL_WEIGHT: float
DISTANCE_WEIGHT: float
DEFAULT_POSES: int
DEFAULT_FRAMES: int
MAX_POSES: int

class MorphlodError(ValueError):
    """An error of morphlod's Rust core, with its text."""

class Level:
    """One level of detail: source vertices kept and triangles over them."""

    @property
    def fraction(self) -> float: ...
    @property
    def error(self) -> float: ...
    @property
    def step(self) -> int: ...
    @property
    def bytes(self) -> int: ...
    @property
    def quantization_error(self) -> float: ...
    @property
    def vertices(self) -> npt.NDArray[np.uint32]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...

class Mesh:
    """A mesh as morphlod reads it from a file."""

    @property
    def positions(self) -> npt.NDArray[np.float32]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    @property
    def targets(self) -> npt.NDArray[np.float32]: ...
    @property
    def target_names(self) -> list[str]: ...
    @property
    def uvs(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def normals(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def seams(self) -> npt.NDArray[np.uint32]: ...
    @property
    def default_weights(self) -> list[float]: ...
    def pose_weights(self, count: int) -> npt.NDArray[np.float32]: ...

class SupermeshResult:
    """The supermesh of two meshes: one triangulation with a pose on each."""

    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    @property
    def v0(self) -> npt.NDArray[np.float32]: ...
    @property
    def v1(self) -> npt.NDArray[np.float32]: ...
    @property
    def a_vertex(self) -> npt.NDArray[np.int64]: ...
    @property
    def b_vertex(self) -> npt.NDArray[np.int64]: ...
    @property
    def report(self) -> str: ...
    @property
    def fold_overs(self) -> int: ...

def simplify(
    positions: npt.NDArray[np.float32],
    triangles: npt.NDArray[np.uint32],
    targets: Optional[npt.NDArray[np.float32]] = None,
    target_names: Optional[Sequence[str]] = None,
    poses: Optional[npt.NDArray[np.float32]] = None,
    uvs: Optional[npt.NDArray[np.float32]] = None,
    normals: Optional[npt.NDArray[np.float32]] = None,
    seams: Optional[npt.NDArray[np.uint32]] = None,
    fractions: Optional[Sequence[float]] = None,
    errors: Optional[Sequence[float]] = None,
    uv_weight: float = ...,
    normal_weight: float = ...,
    distance_weight: float = ...,
    progress: Optional[Progress] = None,
) -> list[Level]: ...
def load(path: str, mesh: Optional[str] = None, animation: Optional[str] = None) -> Mesh: ...
def export(
    inputs: Sequence[str],
    output: str,
    fractions: Optional[Sequence[float]] = None,
    errors: Optional[Sequence[float]] = None,
    poses: int = ...,
    uv_weight: float = ...,
    normal_weight: float = ...,
    distance_weight: float = ...,
    animation: Optional[str] = None,
    mesh: Optional[str] = None,
    landmarks: Optional[str] = None,
    quantize: bool = False,
    compress: bool = False,
    position_bits: Optional[int] = None,
    normal_bits: Optional[int] = None,
    uv_bits: Optional[int] = None,
    pose_weights: Optional[npt.NDArray[np.float32]] = None,
    progress: Optional[Progress] = None,
) -> list[Level]: ...
def build(
    inputs: Sequence[str],
    output: str,
    target: Optional[str] = None,
    animation: Optional[str] = None,
    mesh: Optional[str] = None,
    frames: int = ...,
    sequence: str = "per-frame",
    pose_error: str = "max",
    uv_weight: float = ...,
    normal_weight: float = ...,
    distance_weight: Optional[float] = None,
    landmarks: Optional[str] = None,
    weld: bool = False,
    no_weld: bool = False,
    progress: Optional[Progress] = None,
) -> dict: ...
def info(path: str, memory_budget_mb: int = ...) -> dict: ...
def supermesh(
    a_positions: npt.NDArray[np.float32],
    a_triangles: npt.NDArray[np.uint32],
    b_positions: npt.NDArray[np.float32],
    b_triangles: npt.NDArray[np.uint32],
    landmarks: Optional[npt.NDArray[np.uint32]] = None,
    tips: bool = True,
    progress: Optional[Progress] = None,
) -> SupermeshResult: ...
