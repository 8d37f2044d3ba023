"""The morphlod Python package: levels against their definition, the numpy API against the file
API and the command line (byte-identical output), bad input as exceptions, progress, the GIL."""

import math
import os
import pathlib
import subprocess
import threading
import time

import numpy as np
import pytest

import morphlod

REPO = pathlib.Path(__file__).resolve().parents[2]
ASSETS = REPO / "assets"
HEAD = ASSETS / "makehuman_head.glb"
FACE = ASSETS / "makehuman_face.glb"


def in_ci():
    return os.environ.get("CI", "").lower() not in ("", "0", "false")


def cli():
    """The morphlod binary (MORPHLOD_CLI, else target/{release,debug}/morphlod); a test that
    needs it skips without it, except under CI, where it fails."""
    candidates = [os.environ.get("MORPHLOD_CLI")]
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    candidates += [target / "release" / "morphlod", target / "debug" / "morphlod"]
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return str(c)
    if in_ci():
        pytest.fail("no morphlod binary under CI: cargo build it or set MORPHLOD_CLI")
    pytest.skip("no morphlod binary (cargo build, or set MORPHLOD_CLI)")


def grid(n=12, targets=2):
    """An n × n vertex grid (two triangles a cell) with `targets` bumps as morph targets."""
    y, x = np.mgrid[0:n, 0:n].astype(np.float32) / (n - 1)
    positions = np.stack([x.ravel(), y.ravel(), 0.05 * np.sin(3 * x.ravel())], axis=1).astype(np.float32)
    cells = [(r * n + c) for r in range(n - 1) for c in range(n - 1)]
    triangles = np.array(
        [[v, v + 1, v + n] for v in cells] + [[v + 1, v + n + 1, v + n] for v in cells], np.uint32
    )
    deltas = np.zeros((targets, n * n, 3), np.float32)
    for k in range(targets):
        centre = np.array([(k + 1) / (targets + 1), 0.5])
        d = np.linalg.norm(positions[:, :2] - centre, axis=1)
        deltas[k, :, 2] = 0.3 * np.exp(-((d / 0.15) ** 2))
    return positions, triangles, deltas


def test_levels_keep_a_subset_of_the_vertices_with_valid_triangles():
    positions, triangles, targets = grid()
    fractions = [0.5, 0.25, 0.1]
    levels = morphlod.simplify(positions, triangles, targets, fractions=fractions)
    assert len(levels) == 3
    previous_error = 0.0
    for level, fraction in zip(levels, fractions):
        m = len(level.triangles)
        assert 0 < m <= math.floor(fraction * len(triangles))
        assert level.vertices.dtype == np.uint32 and level.triangles.dtype == np.uint32
        assert level.triangles.shape == (m, 3)
        # Every level vertex is used, once, and is a source vertex.
        assert sorted(np.unique(level.triangles)) == list(range(len(level.vertices)))
        assert len(np.unique(level.vertices)) == len(level.vertices)
        assert level.vertices.max() < len(positions)
        # No degenerate triangle; the error grows with the level.
        t = level.triangles
        assert np.all((t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2]))
        assert level.error >= previous_error
        previous_error = level.error
        assert level.fraction == pytest.approx(fraction)
    with pytest.raises(ValueError):
        levels[0].vertices[0] = 1  # results are read-only


def test_default_poses_are_the_basis_and_every_target_at_one():
    positions, triangles, targets = grid(targets=3)
    explicit = np.vstack([np.zeros((1, 3)), np.eye(3)])
    a = morphlod.simplify(positions, triangles, targets, fractions=[0.3], distance_weight=0)
    b = morphlod.simplify(positions, triangles, targets, poses=explicit, fractions=[0.3], distance_weight=0)
    assert np.array_equal(a[0].vertices, b[0].vertices) and np.array_equal(a[0].triangles, b[0].triangles)
    # The poses matter: the basis alone gives another sequence on this mesh.
    c = morphlod.simplify(positions, triangles, targets, poses=np.zeros((1, 3)), fractions=[0.3], distance_weight=0)
    assert not np.array_equal(a[0].vertices, c[0].vertices)


def test_error_bounds_pick_the_coarsest_level_within_each():
    positions, triangles, targets = grid()
    bounds = [0.002, 0.01, 0.05]
    levels = morphlod.simplify(positions, triangles, targets, errors=bounds)
    for level, bound in zip(levels, bounds):
        assert level.error <= bound
    assert len(levels[0].triangles) >= len(levels[1].triangles) >= len(levels[2].triangles)


def test_simplify_on_arrays_is_export_of_the_file():
    """The arrays of a file simplified over the poses export samples give export's levels."""
    mesh = morphlod.load(HEAD)
    assert mesh.targets.shape == (8, len(mesh.positions), 3)
    poses = 6
    weights = mesh.pose_weights(poses)
    assert weights.shape == (poses, 8)
    levels = morphlod.simplify(
        mesh.positions,
        mesh.triangles,
        mesh.targets,
        poses=weights,
        uvs=mesh.uvs,
        normals=mesh.normals,
        seams=mesh.seams,
        fractions=[0.5, 0.2],
    )
    out = pathlib.Path(os.environ.get("PYTEST_TMP", "/tmp")) / f"head_{os.getpid()}.glb"
    try:
        exported = morphlod.export(HEAD, out, fractions=[0.5, 0.2], poses=poses)
    finally:
        out.unlink(missing_ok=True)
    assert len(exported) == 3 and exported[0].step == 0
    for a, b in zip(levels, exported[1:]):
        assert np.array_equal(a.vertices, b.vertices)
        assert np.array_equal(a.triangles, b.triangles)
        assert a.error == b.error and a.step == b.step


def test_export_and_build_write_what_the_command_line_writes(tmp_path):
    binary = cli()
    glb_cli, glb_py = tmp_path / "cli.glb", tmp_path / "py.glb"
    args = ["--lods", "0.5,0.2", "--poses", "4", "--distance-weight", "0"]
    subprocess.run([binary, "export", str(HEAD), "-o", str(glb_cli), *args], check=True, capture_output=True)
    morphlod.export(HEAD, glb_py, fractions=[0.5, 0.2], poses=4, distance_weight=0)
    assert glb_py.read_bytes() == glb_cli.read_bytes()

    mlod_cli, mlod_py = tmp_path / "cli.mlod", tmp_path / "py.mlod"
    args = ["--target", "jawOpen", "--frames", "4"]
    subprocess.run([binary, "build", str(HEAD), "-o", str(mlod_cli), *args], check=True, capture_output=True)
    summary = morphlod.build(HEAD, mlod_py, target="jawOpen", frames=4)
    assert mlod_py.read_bytes() == mlod_cli.read_bytes()
    printed = subprocess.run([binary, "info", str(mlod_cli)], check=True, capture_output=True, text=True).stdout
    assert summary["text"] in printed
    assert morphlod.info(mlod_py) == {k: v for k, v in summary.items() if k != "build_seconds"}


def test_export_levels_over_given_poses(tmp_path):
    """export with pose_weights writes the levels simplify gives over those weight sets."""
    mesh = morphlod.load(HEAD)
    weights = np.vstack([np.zeros((1, 8)), np.eye(8)]).astype(np.float32)
    levels = morphlod.simplify(
        mesh.positions, mesh.triangles, mesh.targets, poses=weights, uvs=mesh.uvs, normals=mesh.normals,
        fractions=[0.25], distance_weight=0,
    )
    exported = morphlod.export(HEAD, tmp_path / "x.glb", fractions=[0.25], pose_weights=weights, distance_weight=0)
    assert np.array_equal(levels[0].vertices, exported[1].vertices)
    assert np.array_equal(levels[0].triangles, exported[1].triangles)
    with pytest.raises(morphlod.MorphlodError, match="pose_weights"):
        morphlod.export(HEAD, tmp_path / "y.glb", pose_weights=np.zeros((2, 3)), distance_weight=0)


def test_info_of_a_build(tmp_path):
    out = tmp_path / "head.mlod"
    frames = []
    summary = morphlod.build(HEAD, out, target="jawOpen", frames=3, progress=lambda s, f: frames.append((s, f)))
    info = morphlod.info(out)
    assert info["vertices"] == summary["vertices"] > 0
    assert info["triangles"] == len(morphlod.load(HEAD).triangles)
    assert len(info["frames"]) == 3 and info["file_bytes"] == out.stat().st_size
    done = [f for s, f in frames if s == "frames"]
    assert sorted(done) == done and done[-1] == 1.0 and len(done) == 3
    with pytest.raises(morphlod.MorphlodError):
        morphlod.info(HEAD)  # not an .mlod file
    with pytest.raises(morphlod.MorphlodError, match="one of the inputs"):
        morphlod.build([out, out], out)
    with pytest.raises(morphlod.MorphlodError, match=r"\.mlod"):
        morphlod.build(HEAD, tmp_path / "x.glb", target="jawOpen")


def test_seams_must_describe_the_welding():
    mesh = morphlod.load(FACE)
    seams = mesh.seams
    assert seams.shape == (len(mesh.positions),) and seams.max() + 1 == 4437
    args = (mesh.positions, mesh.triangles)
    kw = dict(uvs=mesh.uvs, fractions=[0.5], distance_weight=0, poses=np.zeros((1, 0)))
    morphlod.simplify(*args, seams=seams, **kw)
    # Relabelled groups are the same welding.
    morphlod.simplify(*args, seams=seams.max() - seams, **kw)
    split = seams.copy()
    copies = np.flatnonzero(np.bincount(seams)[seams] > 1)
    split[copies[0]] = seams.max() + 1
    with pytest.raises(morphlod.MorphlodError, match="coincide"):
        morphlod.simplify(*args, seams=split, **kw)
    joined = seams.copy()
    joined[1] = joined[0]
    with pytest.raises(morphlod.MorphlodError, match="differ"):
        morphlod.simplify(*args, seams=joined, **kw)


@pytest.mark.parametrize(
    "change, error, match",
    [
        (dict(positions=np.zeros((4, 2))), ValueError, r"positions: shape \(4, 2\)"),
        (dict(positions="abc"), TypeError, "positions"),
        (dict(triangles=np.array([[0.0, 1.0, 2.0]])), TypeError, "integer"),
        (dict(triangles=np.array([[0, -1, 2]])), ValueError, "outside"),
        (dict(triangles=np.array([[0, 1, 99]])), morphlod.MorphlodError, "vertex 99"),
        (dict(triangles=np.array([[0, 1, 1]])), morphlod.MorphlodError, "repeats a vertex"),
        (dict(triangles=np.zeros((0, 3), np.uint32)), morphlod.MorphlodError, "no triangles"),
        (dict(positions=np.full((4, 3), np.nan, np.float32)), morphlod.MorphlodError, "not finite"),
        (dict(targets=np.zeros((1, 3, 3))), ValueError, "targets"),
        (dict(targets=np.full((1, 4, 3), np.inf)), morphlod.MorphlodError, "not finite"),
        (dict(poses=np.zeros((2, 5))), ValueError, "poses"),
        (dict(uvs=np.zeros((4, 3))), ValueError, "uvs"),
        (dict(fractions=[0.2, 0.5]), morphlod.MorphlodError, "strictly decreasing"),
        (dict(fractions=[0.5], errors=[0.1]), morphlod.MorphlodError, "not both"),
        (dict(errors=[-1.0]), morphlod.MorphlodError, "error bounds"),
        (dict(distance_weight=-1.0), morphlod.MorphlodError, "distance_weight"),
        (dict(fractions=[0.0]), morphlod.MorphlodError, r"fractions in \(0, 1\]"),
    ],
)
def test_bad_input_raises(change, error, match):
    quad = dict(
        positions=np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32),
        triangles=np.array([[0, 1, 2], [0, 2, 3]], np.uint32),
        targets=np.zeros((1, 4, 3), np.float32),
    )
    quad.update(change)
    positions, triangles = quad.pop("positions"), quad.pop("triangles")
    with pytest.raises(error, match=match):
        morphlod.simplify(positions, triangles, **quad)


def test_bad_files_raise_with_the_path(tmp_path):
    with pytest.raises(morphlod.MorphlodError, match="no-such.glb"):
        morphlod.load(tmp_path / "no-such.glb")
    broken = tmp_path / "broken.glb"
    broken.write_bytes(b"glTF not really")
    with pytest.raises(morphlod.MorphlodError, match="broken.glb"):
        morphlod.export(broken, tmp_path / "out.glb")
    with pytest.raises(morphlod.MorphlodError, match="animation"):
        morphlod.load(HEAD, animation="no such animation")


def test_progress_and_its_exceptions():
    positions, triangles, targets = grid()
    calls = []
    morphlod.simplify(positions, triangles, targets, progress=lambda s, f: calls.append((s, f)))
    assert calls == [("simplify", 0.0), ("simplify", 1.0)]

    def fails(stage, fraction):
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        morphlod.simplify(positions, triangles, targets, progress=fails)


def test_the_gil_is_released_while_rust_works():
    mesh = morphlod.load(HEAD)
    done = threading.Event()

    def work():
        try:
            morphlod.simplify(mesh.positions, mesh.triangles, mesh.targets, uvs=mesh.uvs, fractions=[0.2])
        finally:
            done.set()

    thread = threading.Thread(target=work)
    ticks, start = 0, time.perf_counter()
    thread.start()
    time.sleep(0.05)  # let the worker enter Rust
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    thread.join()
    elapsed = time.perf_counter() - start
    # With the GIL held for the whole call this thread would not run until it returned.
    assert elapsed > 0.2 and ticks > 20, (elapsed, ticks)


def octahedron():
    p = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float32)
    t = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    return p, np.array(t, np.uint32)


def cube():
    p = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float32) * 0.8
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    t = [[a, b, c] for a, b, c, d in quads] + [[a, c, d] for a, b, c, d in quads]
    return p, np.array(t, np.uint32)


def test_supermesh_keeps_both_meshes_vertices():
    a, b = octahedron(), cube()
    stages = []
    s = morphlod.supermesh(*a, *b, progress=lambda stage, f: stages.append(stage))
    assert s.fold_overs == 0 and "supermesh" in stages[0]
    n = len(s.v0)
    assert s.v1.shape == (n, 3) and s.triangles.max() < n
    from_a, from_b = s.a_vertex >= 0, s.b_vertex >= 0
    assert sorted(s.a_vertex[from_a]) == list(range(6)) and sorted(s.b_vertex[from_b]) == list(range(8))
    assert np.array_equal(s.v0[from_a], a[0][s.a_vertex[from_a]])
    assert np.array_equal(s.v1[from_b], b[0][s.b_vertex[from_b]])
    # A and B of one connectivity: the supermesh is the mesh itself.
    same = morphlod.supermesh(*a, a[0] * 2, a[1])
    assert np.array_equal(same.triangles, a[1]) and np.array_equal(same.v1, a[0] * 2)
    open_mesh = (a[0], a[1][:-1])
    with pytest.raises(morphlod.MorphlodError, match="open"):
        morphlod.supermesh(*open_mesh, *b)
    with pytest.raises(morphlod.MorphlodError, match="landmark pair 0"):
        morphlod.supermesh(*a, *b, landmarks=[[0, 99]])


def test_stubs_name_every_public_function():
    stubs = (pathlib.Path(morphlod.__file__).parent / "_morphlod.pyi").read_text()
    for name in ("simplify", "load", "export", "build", "info", "supermesh", "Level", "Mesh", "SupermeshResult"):
        assert name in stubs
