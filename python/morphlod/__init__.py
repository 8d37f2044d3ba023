"""morphlod: levels of detail of meshes with morph targets (shape keys) that keep every target.

morphlod simplifies by half-edge collapses, which make no new vertices: every level's vertices
are a subset of the original's, so each morph target (shape key) carries over exactly, by
indexing. One collapse sequence is simplified over a set of poses (weight sets of the
targets) at once, so every level's triangles serve every pose.

The functions run morphlod's Rust core, the same code as the ``morphlod`` command line with
its defaults (``simplify`` is what ``morphlod export`` computes, without writing a file):

* :func:`simplify` -- levels of a mesh given as numpy arrays;
* :func:`load` -- a mesh file as those arrays (glTF with its targets and animation; OBJ,
  OFF, PLY);
* :func:`export` -- ``morphlod export``: the original and its levels as one glTF binary
  (``MSFT_lod``, every level keeping all targets, attributes, material and animation);
* :func:`build` -- ``morphlod build``: a continuous-LOD ``.mlod`` asset;
* :func:`info` -- the summary of an ``.mlod`` file (``morphlod info``);
* :func:`supermesh` -- the correspondence of two closed genus-0 meshes of different
  connectivity: one triangulation with a pose on each.

Arrays are converted to the dtypes named (float32 positions, uint32 indices) and checked;
bad input raises ``ValueError`` or ``TypeError`` (wrong shape or dtype, negative or too
large indices) or :class:`MorphlodError` (a ``ValueError`` with the Rust error's text: NaN
coordinates, indices out of range, options out of range), never a crash. The GIL is
released while Rust works. Long calls take ``progress``, a callable ``progress(stage,
fraction)`` called with a stage name and its progress in [0, 1] (possibly from another
thread); an exception it raises is raised by the call once the work is done.
"""

from __future__ import annotations

import os
from typing import Callable, List, Optional, Sequence, Union

import numpy as np

from . import _morphlod
from ._morphlod import (
    DEFAULT_FRAMES,
    DEFAULT_POSES,
    DISTANCE_WEIGHT,
    MAX_POSES,
    NORMAL_WEIGHT,
    UV_WEIGHT,
    Level,
    Mesh,
    MorphlodError,
    SupermeshResult,
)

__all__ = [
    "DEFAULT_FRAMES",
    "DEFAULT_POSES",
    "DISTANCE_WEIGHT",
    "MAX_POSES",
    "NORMAL_WEIGHT",
    "UV_WEIGHT",
    "Level",
    "Mesh",
    "MorphlodError",
    "SupermeshResult",
    "build",
    "export",
    "info",
    "load",
    "simplify",
    "supermesh",
]

__version__ = "0.1.0"

Progress = Callable[[str, float], object]
PathLike = Union[str, "os.PathLike[str]"]
ArrayLike = object

_U32_MAX = np.iinfo(np.uint32).max


def _floats(name: str, array: ArrayLike, shape: Sequence[Optional[int]]) -> np.ndarray:
    """``array`` as a C-contiguous float32 array of ``shape`` (None: any length)."""
    try:
        out = np.ascontiguousarray(array, dtype=np.float32)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name}: cannot be read as float32 numbers ({e})") from None
    _check_shape(name, out, shape)
    return out


def _indices(name: str, array: ArrayLike, shape: Sequence[Optional[int]]) -> np.ndarray:
    """``array`` as a C-contiguous uint32 array of ``shape``: integers in [0, 2^32)."""
    raw = np.asarray(array)
    if raw.size == 0:
        raw = raw.astype(np.uint32)
    if raw.dtype.kind not in "ui":
        raise TypeError(f"{name}: expected integer indices, got dtype {raw.dtype}")
    _check_shape(name, raw, shape)
    if raw.size and (raw.min() < 0 or raw.max() > _U32_MAX):
        bad = raw.min() if raw.min() < 0 else raw.max()
        raise ValueError(f"{name}: index {bad} is outside [0, {_U32_MAX}]")
    return np.ascontiguousarray(raw, dtype=np.uint32)


def _check_shape(name: str, array: np.ndarray, shape: Sequence[Optional[int]]) -> None:
    ok = array.ndim == len(shape) and all(
        want is None or have == want for have, want in zip(array.shape, shape)
    )
    if not ok:
        wanted = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name}: shape {array.shape}, expected {wanted}")


def _levels(fractions: Optional[Sequence[float]], errors: Optional[Sequence[float]]):
    as_list = lambda v: None if v is None else [float(x) for x in v]  # noqa: E731
    return as_list(fractions), as_list(errors)


def simplify(
    positions: ArrayLike,
    triangles: ArrayLike,
    targets: Optional[ArrayLike] = None,
    *,
    target_names: Optional[Sequence[str]] = None,
    poses: Optional[ArrayLike] = None,
    uvs: Optional[ArrayLike] = None,
    normals: Optional[ArrayLike] = None,
    seams: Optional[ArrayLike] = None,
    fractions: Optional[Sequence[float]] = None,
    errors: Optional[Sequence[float]] = None,
    uv_weight: float = UV_WEIGHT,
    normal_weight: float = NORMAL_WEIGHT,
    distance_weight: float = DISTANCE_WEIGHT,
    progress: Optional[Progress] = None,
) -> List[Level]:
    """Levels of detail of a mesh with morph targets, one per requested level.

    The levels are those ``morphlod export`` writes for the same mesh, poses and options: one
    collapse sequence simplified over every pose at once (each collapse costs its worst pose),
    each level a step of it. Collapses make no new vertices, so a level is a subset of the
    vertices (``Level.vertices``) and its triangles over them; every target's delta, UV and
    normal of a kept vertex is the source's, indexed.

    Args:
        positions: ``(n, 3)`` base positions (float32).
        triangles: ``(m, 3)`` vertex indices (uint32; counter-clockwise).
        targets: ``(t, n, 3)`` morph-target position deltas (shape keys relative to the
            base), or None.
        target_names: ``t`` names, for error messages.
        poses: ``(p, t)`` target weights of the poses to keep good, ``p`` from 1 to
            ``MAX_POSES``. The first pose sets the error's scale (use the basis, all 0).
            Default: the basis and each target alone at 1 (``t + 1`` poses); without targets,
            the base alone.
        uvs: ``(n, 2)`` texture coordinates, or None. With uvs or normals the mesh is
            simplified on its welded surface: vertices split at a seam (equal position and
            target deltas, different attributes) are welded, the seam kept where it is and
            never torn, and the UV and normal error counts.
        normals: ``(n, 3)`` vertex normals, or None.
        seams: ``(n,)`` for each vertex the surface vertex it is a copy of (copies at a seam
            share it), as :attr:`Mesh.seams` gives. morphlod welds the copies itself; given,
            this is checked to describe the same welding (MorphlodError naming the first
            vertex where it does not).
        fractions: triangle fractions in (0, 1], strictly decreasing: per fraction, the
            finest level with at most that fraction of the triangles. Default
            ``[0.5, 0.25, 0.1]``.
        errors: instead of fractions, error bounds relative to the base pose's bounding-box
            diagonal (0.01 = 1 %), > 0 and strictly increasing: per bound, the coarsest level
            whose error is within it.
        uv_weight, normal_weight: weights of the UV and normal error (0: geometry only).
        distance_weight: weight of the distance term (lower Hausdorff error; 0 builds about
            100 times faster).
        progress: ``progress(stage, fraction)``; the simplification is one stage
            (``"simplify"``, reported at 0 and at 1).

    Returns:
        One :class:`Level` per fraction or error bound, coarser and coarser.

    Raises:
        TypeError, ValueError: arrays of the wrong dtype or shape.
        MorphlodError: bad values (NaN, indices out of range, degenerate triangles) or
            options, with the Rust core's message.
    """
    positions = _floats("positions", positions, (None, 3))
    n = positions.shape[0]
    triangles = _indices("triangles", triangles, (None, 3))
    if targets is not None:
        targets = _floats("targets", targets, (None, n, 3))
    if poses is not None:
        t = 0 if targets is None else targets.shape[0]
        poses = _floats("poses", poses, (None, t))
    if uvs is not None:
        uvs = _floats("uvs", uvs, (n, 2))
    if normals is not None:
        normals = _floats("normals", normals, (n, 3))
    if seams is not None:
        seams = _indices("seams", seams, (n,))
    fractions, errors = _levels(fractions, errors)
    return _morphlod.simplify(
        positions,
        triangles,
        targets,
        None if target_names is None else [str(s) for s in target_names],
        poses,
        uvs,
        normals,
        seams,
        fractions,
        errors,
        float(uv_weight),
        float(normal_weight),
        float(distance_weight),
        progress,
    )


def load(path: PathLike, *, mesh: Optional[str] = None, animation: Optional[str] = None) -> Mesh:
    """A mesh file as morphlod reads it for ``morphlod export``.

    A glTF file gives its mesh (``mesh``: name or index; default the first) with every
    morph target, driven by the weight animation ``animation`` (name or index; default the
    first, or from the basis to the default weights without one); OBJ, OFF and PLY give one
    mesh without targets. The arrays (:attr:`Mesh.positions`, ``triangles``, ``targets``,
    ``uvs``, ``normals``, ``seams``) and :meth:`Mesh.pose_weights` are what
    :func:`simplify` takes: ``simplify(m.positions, m.triangles, m.targets, uvs=m.uvs,
    normals=m.normals, poses=m.pose_weights(32))`` gives the levels of ``export(path)``.
    """
    return _morphlod.load(os.fspath(path), mesh, animation)


def export(
    inputs: Union[PathLike, Sequence[PathLike]],
    output: PathLike,
    *,
    fractions: Optional[Sequence[float]] = None,
    errors: Optional[Sequence[float]] = None,
    poses: int = DEFAULT_POSES,
    uv_weight: float = UV_WEIGHT,
    normal_weight: float = NORMAL_WEIGHT,
    distance_weight: float = DISTANCE_WEIGHT,
    animation: Optional[str] = None,
    mesh: Optional[str] = None,
    landmarks: Optional[PathLike] = None,
    quantize: bool = False,
    compress: bool = False,
    position_bits: Optional[int] = None,
    normal_bits: Optional[int] = None,
    uv_bits: Optional[int] = None,
    pose_weights: Optional[ArrayLike] = None,
    progress: Optional[Progress] = None,
) -> List[Level]:
    """``morphlod export``: the original and its levels as one glTF binary file.

    ``inputs`` is a glTF file (every morph target, driven by its weight animation) or two
    meshes ``V(0)``, ``V(1)`` (of different connectivity: morphed over their supermesh, with
    the optional ``landmarks`` file). Every level keeps all morph targets, the vertex
    attributes, the material and the animation; the chain is declared with ``MSFT_lod``.
    Options as the command line's (``--lods`` is ``fractions``, ``--error`` is ``errors``).
    ``output`` must end in ``.glb`` and not be an input.

    ``pose_weights``: ``(p, t)`` weights of the file's ``t`` morph targets: the levels are
    chosen over these poses (as :func:`simplify` chooses them) instead of ``poses`` samples
    of the animation, which is still the one written. ``progress`` gets ``"load"``,
    ``"simplify"`` and ``"write"`` (and the supermesh's stages for two meshes).

    Returns:
        LOD0 (the original) and then one :class:`Level` per fraction or bound, with the
        bytes of its mesh data in the file.
    """
    paths = [os.fspath(inputs)] if isinstance(inputs, (str, os.PathLike)) else [
        os.fspath(p) for p in inputs
    ]
    fractions, errors = _levels(fractions, errors)
    return _morphlod.export(
        paths,
        os.fspath(output),
        fractions,
        errors,
        int(poses),
        float(uv_weight),
        float(normal_weight),
        float(distance_weight),
        animation,
        mesh,
        None if landmarks is None else os.fspath(landmarks),
        bool(quantize),
        bool(compress),
        position_bits,
        normal_bits,
        uv_bits,
        None if pose_weights is None else _floats("pose_weights", pose_weights, (None, None)),
        progress,
    )


def build(
    inputs: Union[PathLike, Sequence[PathLike]],
    output: PathLike,
    *,
    target: Optional[str] = None,
    animation: Optional[str] = None,
    mesh: Optional[str] = None,
    frames: int = DEFAULT_FRAMES,
    sequence: str = "per-frame",
    pose_error: str = "max",
    uv_weight: float = UV_WEIGHT,
    normal_weight: float = NORMAL_WEIGHT,
    distance_weight: Optional[float] = None,
    landmarks: Optional[PathLike] = None,
    weld: bool = False,
    no_weld: bool = False,
    progress: Optional[Progress] = None,
) -> dict:
    """``morphlod build``: a continuous-LOD ``.mlod`` asset of a morph.

    ``inputs``: a glTF file with ``target`` (morph from the base to that target) or
    ``animation`` (follow that weight animation), or two meshes ``V(0)``, ``V(1)``.
    ``sequence``: ``"per-frame"`` (one collapse sequence per sampled frame) or ``"shared"``
    (one over all sampled poses; ``pose_error`` ``"max"`` or ``"mean"``).
    ``distance_weight`` defaults to 0 per frame and ``DISTANCE_WEIGHT`` shared, as the
    command line's. ``progress`` gets ``("frames", done / frames)`` after each frame.

    Returns:
        The written file's summary as :func:`info` gives it, plus ``build_seconds``.
    """
    paths = [os.fspath(inputs)] if isinstance(inputs, (str, os.PathLike)) else [
        os.fspath(p) for p in inputs
    ]
    return _morphlod.build(
        paths,
        os.fspath(output),
        target,
        animation,
        mesh,
        int(frames),
        str(sequence),
        str(pose_error),
        float(uv_weight),
        float(normal_weight),
        None if distance_weight is None else float(distance_weight),
        None if landmarks is None else os.fspath(landmarks),
        bool(weld),
        bool(no_weld),
        progress,
    )


def info(path: PathLike, *, memory_budget_mb: int = 4096) -> dict:
    """The summary of an ``.mlod`` file, as ``morphlod info`` prints it.

    Keys: ``version``, ``file_bytes``, ``vertices``, ``triangles`` (at full detail),
    ``strips``, ``strip_indices``, ``frames`` (LODs per sampled frame), ``targets`` (morph
    targets blended on the GPU), ``sections`` (tag: bytes) and ``text`` (the printed report).
    A file that would take more than ``memory_budget_mb`` MiB to load is refused.
    """
    return _morphlod.info(os.fspath(path), int(memory_budget_mb))


def supermesh(
    a_positions: ArrayLike,
    a_triangles: ArrayLike,
    b_positions: ArrayLike,
    b_triangles: ArrayLike,
    *,
    landmarks: Optional[ArrayLike] = None,
    tips: bool = True,
    progress: Optional[Progress] = None,
) -> SupermeshResult:
    """The supermesh of two closed genus-0 meshes A and B (``morphlod supermesh``).

    One triangulation holding both meshes' vertices and their edges' crossings, with a pose
    on A (``v0``, A's vertices bit for bit) and one on B (``v1``): morphing ``v0`` to ``v1``
    turns A into B. ``landmarks``: ``(k, 2)`` pairs (vertex of A, vertex of B) brought
    together. ``tips``: without landmarks, pair the limb tips of A and B. ``progress`` gets
    each stage (``"supermesh: check"``, ``"supermesh: embed A"``, ...). Meshes that cannot have a supermesh (open,
    genus > 0, non-manifold, several components) raise MorphlodError naming the check.
    """
    a_positions = _floats("a_positions", a_positions, (None, 3))
    b_positions = _floats("b_positions", b_positions, (None, 3))
    a_triangles = _indices("a_triangles", a_triangles, (None, 3))
    b_triangles = _indices("b_triangles", b_triangles, (None, 3))
    if landmarks is not None:
        landmarks = _indices("landmarks", landmarks, (None, 2))
    return _morphlod.supermesh(
        a_positions, a_triangles, b_positions, b_triangles, landmarks, bool(tips), progress
    )
