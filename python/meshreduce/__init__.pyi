# Type stub of the meshreduce module (the C extension meshreduce._core,
# re-exported by meshreduce/__init__.py).
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Union
import os

import numpy as np
import numpy.typing as npt

__version__: str
library_version: str
features: dict[str, bool]  # "openmp": parallel build; "png": write_png available

_Floats = npt.ArrayLike  # (N, k) float32 or float64
_Indices = npt.ArrayLike  # (M, 3) int32, int64 or uint32
_Path = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]

class Error(Exception):
    status: str
    line: Optional[int]
    offset: Optional[int]

class InvalidArgumentError(Error, ValueError): ...
class MeshIOError(Error, OSError): ...
class ParseError(Error, ValueError): ...
class UnsupportedError(Error): ...
class EmptyMeshError(Error, ValueError): ...
class TooLargeError(Error, ValueError): ...
class NoMemoryError(Error, MemoryError): ...
class CancelledError(Error): ...

class Mesh:
    vertices: Any
    triangles: Any
    normals: Any
    texcoords: Any
    colors: Any
    texcoords1: Any
    texcoords2: Any
    texcoords3: Any
    tangents: Any
    joints: Any
    weights: Any
    materials: Any
    def __init__(
        self,
        vertices: _Floats,
        triangles: Optional[_Indices] = ...,
        normals: Optional[_Floats] = ...,
        texcoords: Optional[_Floats] = ...,
        colors: Optional[_Floats] = ...,
        texcoords1: Optional[_Floats] = ...,
        texcoords2: Optional[_Floats] = ...,
        texcoords3: Optional[_Floats] = ...,
        tangents: Optional[_Floats] = ...,
        joints: Optional[npt.ArrayLike] = ...,
        weights: Optional[_Floats] = ...,
        materials: Optional[npt.ArrayLike] = ...,
    ) -> None: ...

class Result:
    vertices: npt.NDArray[np.float32]
    triangles: npt.NDArray[np.uint32]
    normals: Optional[npt.NDArray[np.float32]]
    texcoords: Optional[npt.NDArray[np.float32]]
    colors: Optional[npt.NDArray[np.float32]]
    texcoords1: Optional[npt.NDArray[np.float32]]
    texcoords2: Optional[npt.NDArray[np.float32]]
    texcoords3: Optional[npt.NDArray[np.float32]]
    tangents: Optional[npt.NDArray[np.float32]]
    joints: Optional[npt.NDArray[np.uint16]]
    weights: Optional[npt.NDArray[np.float32]]
    materials: Optional[npt.NDArray[np.int64]]
    origin: npt.NDArray[np.uint32]
    error: float
    target_reached: bool
    stop_reason: Literal["target", "max_error", "locked", "refused"]
    stop: str
    input_vertices: int
    output_points: int
    input_triangles: int
    output_vertices: int
    output_triangles: int
    collapses: int
    max_error: float
    locked_vertices: int
    pruned_parts: int
    seconds: dict[str, float]
    stats: dict[str, Any]
    def __init__(self, **fields: Any) -> None: ...
    def __getattr__(self, name: str) -> Any: ...

def simplify(
    vertices: _Floats,
    triangles: _Indices,
    *,
    ratio: Optional[float] = ...,
    vertex_count: Optional[int] = ...,
    triangle_count: Optional[int] = ...,
    max_error: Optional[float] = ...,
    absolute: bool = ...,
    collapse: Literal["full", "half"] = ...,
    strategy: Optional[
        Literal[
            "greedy",
            "batched",
            "ppq",
            "rppq",
            "fppq",
            "multiqueue",
            "partitioned",
            "partitioned-boundary",
        ]
    ] = ...,
    lock_border: bool = ...,
    boundary_weight: float = ...,
    max_normal_turn: float = ...,
    locked: Optional[npt.ArrayLike] = ...,
    prune: bool = ...,
    normals: Optional[_Floats] = ...,
    texcoords: Optional[_Floats] = ...,
    colors: Optional[_Floats] = ...,
    threads: int = ...,
    progress: Optional[Callable[[float], Any]] = ...,
    filter_levels: int = ...,
    multiqueue_factor: int = ...,
    quality: Literal["default", "best"] = ...,
    partitions: int = ...,
    attribute_weights: Optional[Dict[Literal["normal", "uv", "color"], float]] = ...,
    seams: Literal["auto", "free", "keep"] = ...,
    texcoords1: Optional[_Floats] = ...,
    texcoords2: Optional[_Floats] = ...,
    texcoords3: Optional[_Floats] = ...,
    tangents: Optional[_Floats] = ...,
    joints: Optional[npt.ArrayLike] = ...,
    weights: Optional[_Floats] = ...,
    materials: Optional[npt.ArrayLike] = ...,
) -> Result: ...
def simplify_lods(
    vertices: _Floats,
    triangles: npt.ArrayLike,
    levels: Sequence[float],
    *,
    normals: Optional[_Floats] = ...,
    texcoords: Optional[_Floats] = ...,
    colors: Optional[_Floats] = ...,
    samples: int = ...,
    **options: Any,
) -> List[Result]: ...
def simplify_file(
    input: _Path,
    output: _Path,
    *,
    ratio: Optional[float] = ...,
    vertex_count: Optional[int] = ...,
    triangle_count: Optional[int] = ...,
    max_error: Optional[float] = ...,
    absolute: bool = ...,
    collapse: Literal["full", "half"] = ...,
    strategy: Optional[
        Literal[
            "greedy",
            "batched",
            "ppq",
            "rppq",
            "fppq",
            "multiqueue",
            "partitioned",
            "partitioned-boundary",
        ]
    ] = ...,
    lock_border: bool = ...,
    boundary_weight: float = ...,
    max_normal_turn: float = ...,
    locked: Optional[npt.ArrayLike] = ...,
    prune: bool = ...,
    threads: int = ...,
    progress: Optional[Callable[[float], Any]] = ...,
    quality: Literal["default", "best"] = ...,
    partitions: int = ...,
    memory: Optional[int] = ...,
    temp_dir: Optional[_Path] = ...,
    temp_budget: Optional[int] = ...,
    attribute_weights: Optional[Dict[Literal["normal", "uv", "color"], float]] = ...,
    seams: Literal["auto", "free", "keep"] = ...,
) -> dict[str, Any]: ...
def read(path: _Path, *, format: Optional[str] = ..., threads: int = ...) -> Mesh: ...
def write(
    path: _Path,
    mesh: Any,
    *,
    format: Optional[str] = ...,
    encoding: Optional[Literal["default", "ascii", "binary", "big-endian"]] = ...,
    normals: bool = ...,
    texcoords: bool = ...,
    colors: bool = ...,
    material_names: Optional[Sequence[str]] = ...,
    materials_from: Optional[_Path] = ...,
) -> None: ...
def generate(
    kind: Literal["sphere", "torus", "scan"] = ..., triangles: int = ..., *, seed: int = ...
) -> Mesh: ...
def info(vertices: Any, triangles: Optional[_Indices] = ...) -> dict[str, Any]:
    """A file path, a Mesh-like object, or the arrays."""
def compare(
    a_vertices: _Floats,
    a_triangles: _Indices,
    b_vertices: _Floats,
    b_triangles: _Indices,
    *,
    samples: int = ...,
    seed: int = ...,
    threads: int = ...,
) -> dict[str, Any]: ...
def weld(
    points: _Floats,
    triangles: Optional[_Indices] = ...,
    *,
    eps: Optional[float] = ...,
    eps_rel: Optional[float] = ...,
    reduce: Optional[float] = ...,
    strict: bool = ...,
    algorithm: Literal["auto", "serial", "pweld", "pweld-async"] = ...,
    order: Literal["index", "grade"] = ...,
    drop_degenerate: bool = ...,
    normals: Optional[_Floats] = ...,
    texcoords: Optional[_Floats] = ...,
    colors: Optional[_Floats] = ...,
    threads: int = ...,
) -> Result: ...
def cluster(
    vertices: _Floats,
    triangles: Optional[_Indices] = ...,
    *,
    cell: Optional[float] = ...,
    cell_rel: Optional[float] = ...,
    vertex_count: Optional[int] = ...,
    normals: Optional[_Floats] = ...,
    texcoords: Optional[_Floats] = ...,
    colors: Optional[_Floats] = ...,
    threads: int = ...,
) -> Result: ...
def cluster_file(
    input: Union[str, "os.PathLike[str]"],
    output: Union[str, "os.PathLike[str]"],
    *,
    cell: Optional[float] = ...,
    cell_rel: Optional[float] = ...,
    vertex_count: Optional[int] = ...,
    threads: int = ...,
) -> dict[str, Any]: ...
_Color = Union[int, tuple[int, int, int]]
def render(
    vertices: Union[_Floats, _Path],
    triangles: Optional[_Indices] = ...,
    *,
    width: int = ...,
    height: int = ...,
    view: Literal["iso", "front", "side", "top"] = ...,
    yaw: Optional[float] = ...,
    pitch: Optional[float] = ...,
    supersample: int = ...,
    wire: bool = ...,
    background: Optional[_Color] = ...,
    color: Optional[_Color] = ...,
    wire_color: Optional[_Color] = ...,
    point_radius: float = ...,
    margin: float = ...,
    face_scalar: Optional[npt.ArrayLike] = ...,
    vertex_scalar: Optional[npt.ArrayLike] = ...,
    scalar_min: Optional[float] = ...,
    scalar_max: Optional[float] = ...,
    threads: int = ...,
    texcoords: Optional[_Floats] = ...,
    colors: Optional[_Floats] = ...,
    face_materials: Optional[npt.ArrayLike] = ...,
    looks: Optional[Sequence[Dict[str, Any]]] = ...,
    plain: bool = ...,
) -> npt.NDArray[np.uint8]: ...
def write_png(path: _Path, image: npt.ArrayLike) -> None: ...
