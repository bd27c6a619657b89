"""Tests of the Python module meshreduce (pytest; run by CTest as python_tests).

Environment (CTest sets them): PYTHONPATH holding the built package,
MR_CLI the meshreduce executable (results must equal the CLI's),
MR_SHARED_DATA the shared test meshes (tests that need them skip when absent).
"""

import gc
import json
import multiprocessing
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

import meshreduce

CLI = os.environ.get("MR_CLI", "")
DATA = os.environ.get("MR_SHARED_DATA", "/work/shared/data")
BUNNY = os.path.join(DATA, "stanford-bunny.obj")
# tests/make_seamed.py: a seamed copy of a generated PLY (standard library only)
MAKE_SEAMED = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests",
                           "make_seamed.py")

needs_cli = pytest.mark.skipif(not (CLI and os.access(CLI, os.X_OK)),
                               reason="MR_CLI (the meshreduce executable) not given")
needs_bunny = pytest.mark.skipif(not os.path.exists(BUNNY), reason=BUNNY + " absent")


def cli(*args):
    """Run the CLI; returns its stdout (fails the test on a nonzero exit)."""
    p = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return p.stdout


@pytest.fixture(scope="module")
def sphere():
    return meshreduce.generate("sphere", 2000)


@pytest.fixture(scope="module")
def torus():
    return meshreduce.generate("torus", 3000, seed=3)


# ---- basics ---------------------------------------------------------------


def test_simplify_basic(sphere):
    r = meshreduce.simplify(sphere.vertices, sphere.triangles, ratio=0.25)
    assert isinstance(r, meshreduce.Result)
    assert r.vertices.dtype == np.float32 and r.vertices.shape[1] == 3
    assert r.triangles.dtype == np.uint32 and r.triangles.shape[1] == 3
    assert r.target_reached is True and r.stop_reason == "target"
    assert r.output_points == round(0.25 * r.input_vertices) or \
        abs(r.output_points - 0.25 * r.input_vertices) <= 1
    assert r.output_triangles == len(r.triangles) < len(sphere.triangles)
    assert r.triangles.max() < len(r.vertices)
    assert r.origin.shape == (len(r.vertices),) and r.origin.max() < len(sphere.vertices)
    # origin: each output vertex descends from an input vertex
    assert r.error == r.max_error == r.stats["max_error"] >= 0
    assert set(r.stats["seconds"]) == {"setup", "collapse", "output"}
    assert r.normals is None and r.texcoords is None and r.colors is None
    # the arrays own their memory and outlive everything else
    v = r.vertices
    del r
    gc.collect()
    assert np.isfinite(v).all()


def test_targets(sphere):
    v, t = sphere.vertices, sphere.triangles
    assert meshreduce.simplify(v, t, vertex_count=300).output_points == 300
    r = meshreduce.simplify(v, t, triangle_count=500)
    assert r.output_triangles <= 500 and r.target_reached
    r = meshreduce.simplify(v, t, triangle_count=0, max_error=1e-3)
    assert r.stop_reason == "max_error"
    r = meshreduce.simplify(v, t, max_error=0.5, absolute=True, collapse="half",
                            strategy="greedy")
    assert r.error <= 0.5


def test_missed_target_is_a_result(sphere):
    n = len(sphere.vertices)
    locked = np.ones(n, dtype=bool)
    r = meshreduce.simplify(sphere.vertices, sphere.triangles, ratio=0.1, locked=locked)
    assert r.target_reached is False and r.stop_reason == "locked"
    assert len(r.triangles) == len(sphere.triangles)


def test_locked_vertices_stay(torus):
    v, t = torus.vertices, torus.triangles
    idx = np.arange(0, len(v), 7)
    for locked in (idx, np.isin(np.arange(len(v)), idx)):
        r = meshreduce.simplify(v, t, ratio=0.2, locked=locked)
        kept = set(r.origin.tolist())
        assert set(idx.tolist()) <= kept
        for i, o in enumerate(r.origin):
            if o in set(idx.tolist()):
                assert (r.vertices[i] == v[o]).all()
    with pytest.raises(ValueError, match="locked"):
        meshreduce.simplify(v, t, ratio=0.2, locked=[len(v)])
    with pytest.raises(ValueError, match="one entry per vertex"):
        meshreduce.simplify(v, t, ratio=0.2, locked=np.zeros(3, dtype=bool))


def test_attributes_carried(sphere):
    v, t = sphere.vertices, sphere.triangles
    n = v / np.linalg.norm(v, axis=1, keepdims=True)
    uv = v[:, :2].copy()
    c = np.concatenate([np.abs(n), np.ones((len(v), 1), np.float32)], axis=1)
    r = meshreduce.simplify(v, t, ratio=0.3, normals=n, texcoords=uv, colors=c)
    assert r.normals.shape == (len(r.vertices), 3)
    assert r.texcoords.shape == (len(r.vertices), 2)
    assert r.colors.shape == (len(r.vertices), 4)
    with pytest.raises(ValueError, match=r"normals must have shape \(%d, 3\)" % len(v)):
        meshreduce.simplify(v, t, ratio=0.3, normals=n[:-1])


def test_data_model_carried(sphere):
    # texture set 1, joints and weights are the surviving vertex's; each
    # triangle keeps its material (grouped, -1 = none first); tangents go
    v, t = sphere.vertices, sphere.triangles
    uv1 = (v[:, :2] * 0.5 + 0.5).astype(np.float32)
    joints = np.zeros((len(v), 4), np.uint16)
    joints[:, 0] = v[:, 0] > 0
    weights = np.zeros((len(v), 4), np.float32)
    weights[:, 0] = 1
    centre = v[t].mean(axis=1)
    mats = np.where(centre[:, 2] > 0.3, 1, np.where(centre[:, 2] < -0.3, -1, 0))
    tangents = np.tile(np.array([1, 0, 0, 1], np.float32), (len(v), 1))
    r = meshreduce.simplify(v, t, ratio=0.3, texcoords1=uv1, joints=joints, weights=weights,
                            materials=mats, tangents=tangents)
    assert r.tangents is None
    assert r.materials.dtype == np.int64 and len(r.materials) == len(r.triangles)
    assert set(np.unique(r.materials)) == {-1, 0, 1}
    assert np.all(np.diff(r.materials) >= 0)  # grouped
    np.testing.assert_array_equal(r.texcoords1, uv1[r.origin])
    np.testing.assert_array_equal(r.joints, joints[r.origin])
    np.testing.assert_array_equal(r.weights, weights[r.origin])
    # a Result is a mesh: info sees its arrays
    info = meshreduce.info(r)
    assert info["materials"] == 2 and info["skin"] and info["texcoord_sets"] == 1
    with pytest.raises(ValueError, match="joints and weights go together"):
        meshreduce.simplify(v, t, ratio=0.3, joints=joints)
    with pytest.raises(ValueError, match=r"materials: value -2"):
        meshreduce.simplify(v, t, ratio=0.3, materials=mats - 1)
    with pytest.raises(ValueError, match=r"joints: value 70000"):
        meshreduce.simplify(v, t, ratio=0.3, joints=joints.astype(np.int64) + 70000,
                            weights=weights)
    # levels of detail carry them level to level
    levels = meshreduce.simplify_lods(v, t, [0.5, 0.2], materials=mats, texcoords1=uv1)
    for lv in levels:
        assert len(lv.materials) == len(lv.triangles) and set(lv.materials) == {-1, 0, 1}
        np.testing.assert_array_equal(lv.texcoords1, uv1[lv.origin])


def test_materials_through_files(tmp_path):
    # an OBJ's usemtl groups read as materials, written back as usemtl
    # groups and as a glTF's primitives with the names given
    (tmp_path / "q.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
        "f 1 2 3\nusemtl red\nf 1 3 4\nusemtl blue\nf 2 5 6 3\n")
    m = meshreduce.read(tmp_path / "q.obj")
    np.testing.assert_array_equal(m.materials, [-1, 0, 1, 1])
    assert "materials=(4,)" in repr(m)
    meshreduce.write(tmp_path / "o.obj", m, material_names=["red", "blue"])
    text = (tmp_path / "o.obj").read_text()
    assert text.count("usemtl red") == 1 and text.count("usemtl blue") == 1
    np.testing.assert_array_equal(meshreduce.read(tmp_path / "o.obj").materials, [-1, 0, 1, 1])
    try:
        meshreduce.write(tmp_path / "o.glb", m, material_names=["red", "blue"])
    except meshreduce.Error as e:  # glTF support not built
        assert "not built" in str(e)
    else:
        g = meshreduce.read(tmp_path / "o.glb")
        np.testing.assert_array_equal(np.sort(g.materials), [-1, 0, 1, 1])
    # OBJ has no way back to no material: faces after a group take "None"
    m2 = meshreduce.Mesh(m.vertices, m.triangles, materials=np.array([0, 1, -1, -1]))
    meshreduce.write(tmp_path / "n.obj", m2, material_names=["red", "blue"])
    assert (tmp_path / "n.obj").read_text().count("usemtl None\n") == 1
    back = meshreduce.read(tmp_path / "n.obj").materials
    assert back[0] != back[1] and back[2] == back[3] not in (back[0], back[1], -1)
    try:  # a second texture set alone is written as glTF's set 0
        meshreduce.write(tmp_path / "t1.glb", meshreduce.Mesh(
            m.vertices, m.triangles, texcoords1=m.vertices[:, :2].copy()))
    except meshreduce.Error as e:
        assert "not built" in str(e)
    else:
        t1 = meshreduce.read(tmp_path / "t1.glb")
        assert t1.texcoords is not None and t1.texcoords1 is None
    # a glTF's materials into an OBJ's library, as convert writes it
    duck = os.path.join(DATA, "gltf", "Duck", "glTF-Binary", "Duck.glb")
    if os.path.exists(duck) and meshreduce.features["png"]:
        d = meshreduce.read(duck)
        try:
            meshreduce.write(tmp_path / "duck.obj", d, materials_from=duck)
        except meshreduce.Error as e:  # glTF support not built
            assert "not built" in str(e)
        else:
            assert "map_Kd duck_0.png" in (tmp_path / "duck.mtl").read_text()
            assert (tmp_path / "duck_0.png").exists()
            assert "mtllib duck.mtl" in (tmp_path / "duck.obj").read_text()
    with pytest.raises(TypeError, match=r"material_names\[1\] is not a str"):
        meshreduce.write(tmp_path / "o.obj", m, material_names=["red", 2])


# ---- input types and zero copy --------------------------------------------


def test_index_and_float_types_agree(sphere):
    v, t = sphere.vertices, sphere.triangles
    ref = meshreduce.simplify(v, t, ratio=0.3)
    for tt in (t.astype(np.int32), t.astype(np.int64), t.astype(np.uint64),
               t.astype(np.int16), t.tolist(), t.astype(">i4"), t.astype(">u4"),
               t.astype(">i8")):
        r = meshreduce.simplify(v, tt, ratio=0.3)
        assert np.array_equal(r.triangles, ref.triangles)
        assert np.array_equal(r.vertices, ref.vertices)
    for vv in (v.astype(np.float64), v.astype(">f4"), v.astype(">f8")):
        r = meshreduce.simplify(vv, t, ratio=0.3)
        assert np.array_equal(r.vertices, ref.vertices)
    # non-contiguous input is copied, with the same result
    big = np.zeros((len(v), 6), np.float32)
    big[:, ::2] = v
    assert not big[:, ::2].flags.c_contiguous
    r = meshreduce.simplify(big[:, ::2], np.asfortranarray(t), ratio=0.3)
    assert np.array_equal(r.triangles, ref.triangles)
    # Fortran-ordered uint32 and int32 too
    r = meshreduce.simplify(np.asfortranarray(v), np.asfortranarray(t.astype(np.int32)),
                            ratio=0.3)
    assert np.array_equal(r.triangles, ref.triangles)


def test_input_not_modified(sphere):
    v = sphere.vertices.copy()
    t = sphere.triangles.astype(np.int32)
    v0, t0 = v.copy(), t.copy()
    meshreduce.simplify(v, t, ratio=0.2)
    assert np.array_equal(v, v0) and np.array_equal(t, t0) and t.dtype == np.int32


def test_zero_copy():
    # NumPy's allocations are traced by tracemalloc (the library's own, for
    # the output, are not): float32 positions and uint32 or non-negative
    # int32 indices, C-contiguous, are used in place (no traced growth near
    # their size); float64 positions and int64 indices are converted (a copy
    # of at least their float32/uint32 size).
    import tracemalloc
    m = meshreduce.generate("scan", 200000)
    v32, t32 = m.vertices, m.triangles
    cases = [(v32, t32, 0), (v32, t32.astype(np.int32), 0),
             (v32.astype(np.float64), t32, v32.nbytes),
             (v32, t32.astype(np.int64), t32.nbytes)]
    for v, t, copied in cases:
        tracemalloc.start()
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        meshreduce.simplify(v, t, ratio=0.5, threads=1)
        peak = tracemalloc.get_traced_memory()[1] - base
        tracemalloc.stop()
        if copied:
            assert peak >= copied, (v.dtype, t.dtype, peak)
        else:
            assert peak < v32.nbytes // 10, (v.dtype, t.dtype, peak)


def test_gil_released():
    # While one thread simplifies (no progress callable: the GIL is not
    # taken back), the main thread keeps running Python code.
    import threading
    import time
    m = meshreduce.generate("scan", 300000)
    done = threading.Event()
    spins = []

    def work():
        meshreduce.simplify(m.vertices, m.triangles, ratio=0.05, strategy="greedy", threads=1)
        done.set()

    th = threading.Thread(target=work)
    t0 = time.perf_counter()
    th.start()
    n = 0
    while not done.is_set():
        n += 1
        if n % 1000 == 0:
            spins.append(time.perf_counter() - t0)
    th.join()
    elapsed = time.perf_counter() - t0
    # with the GIL held, the loop would stall for the whole call (a few
    # switch intervals at most); released, it runs throughout
    assert elapsed > 0.05
    assert len(spins) > 100 and spins[-1] > 0.5 * elapsed


def test_input_refcounts_and_no_copy_path(sphere):
    v = np.ascontiguousarray(sphere.vertices, dtype=np.float32)
    t = np.ascontiguousarray(sphere.triangles, dtype=np.uint32)
    t32 = t.astype(np.int32)
    before = (sys.getrefcount(v), sys.getrefcount(t), sys.getrefcount(t32))
    for _ in range(50):
        meshreduce.simplify(v, t, ratio=0.5)
        meshreduce.simplify(v, t32, ratio=0.5)
    assert (sys.getrefcount(v), sys.getrefcount(t), sys.getrefcount(t32)) == before


# ---- bad input -------------------------------------------------------------


@pytest.mark.parametrize("vertices, triangles, exc, match", [
    (np.zeros((4, 2)), [[0, 1, 2]], ValueError, r"vertices must have shape \(N, 3\), got \(4, 2\)"),
    (np.zeros(12), [[0, 1, 2]], ValueError, r"vertices must have shape \(N, 3\), got \(12,\)"),
    (np.zeros((0, 3)), np.zeros((0, 3), int), ValueError, "vertices is empty"),
    (np.eye(3), np.zeros((0, 3), int), ValueError, "triangles is empty"),
    (np.eye(3), [0, 1, 2], ValueError, r"triangles must have shape \(M, 3\)"),
    (np.eye(3), [[0, 1, 3]], ValueError, r"triangles\[0, 2\] = 3 is out of range \(3 vertices"),
    (np.eye(3), np.array([[0, 1, -1]], np.int64), ValueError, r"triangles\[0, 2\] = -1 is negative"),
    (np.eye(3), np.array([[0, -2, 1]], np.int32), ValueError, r"triangles\[0, 1\] = -2 is negative"),
    (np.eye(3), np.array([[0, 1, 2.0]]), TypeError, "triangles must hold integers"),
    (np.array([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]]), [[0, 1, 2]], ValueError,
     r"vertices\[1, 2\] is NaN"),
    (np.array([[0, 0, 0], [1, 0, np.inf], [0, 1, 0]]), [[0, 1, 2]], ValueError,
     r"vertices\[1, 2\] is infinite"),
    pytest.param(np.array([[0, 0, 0], [1e39, 0, 0], [0, 1, 0]]), [[0, 1, 2]], ValueError,
                 "beyond float32",
                 marks=pytest.mark.filterwarnings("ignore:overflow encountered in cast")),
    (np.array([["a", "b", "c"]] * 3), [[0, 1, 2]], TypeError, "vertices must hold real numbers"),
    (object(), [[0, 1, 2]], ValueError, "vertices must have shape"),
    (np.eye(3), None, ValueError, "a triangle mesh is needed"),
])
def test_bad_arrays(vertices, triangles, exc, match):
    with pytest.raises(exc, match=match):
        meshreduce.simplify(vertices, triangles, ratio=0.5)


@pytest.mark.parametrize("kwargs, exc, match", [
    ({}, ValueError, "no target given"),
    ({"ratio": 0}, ValueError, r"ratio must be in \(0, 1\]"),
    ({"ratio": 1.5}, ValueError, r"ratio must be in \(0, 1\]"),
    ({"ratio": float("nan")}, ValueError, "ratio must be finite"),
    ({"ratio": "x"}, TypeError, "ratio must be a number"),
    ({"vertex_count": -3}, ValueError, "vertex_count must be >= 0"),
    ({"vertex_count": 0}, ValueError, "vertex_count must be positive"),
    ({"max_error": -1.0}, ValueError, "max_error must be positive"),
    ({"ratio": 0.5, "collapse": "quarter"}, ValueError, "collapse must be one of 'full', 'half'"),
    ({"ratio": 0.5, "strategy": "fast"}, ValueError, "strategy must be one of"),
    ({"ratio": 0.5, "quality": "great"}, ValueError, "quality must be one of 'default', 'best'"),
    ({"ratio": 0.5, "partitions": 5000}, ValueError, "partitions must be in 0..4096"),
    ({"ratio": 0.5, "max_normal_turn": 0}, ValueError, "max_normal_turn"),
    ({"ratio": 0.5, "boundary_weight": -1}, ValueError, "boundary_weight"),
    ({"ratio": 0.5, "attribute_weights": {"uv": -1}}, ValueError, "uv must be a finite"),
    ({"ratio": 0.5, "attribute_weights": {"tangent": 1}}, ValueError, "unknown attribute"),
    ({"ratio": 0.5, "attribute_weights": [1, 2]}, TypeError, "attribute_weights must be a dict"),
    ({"ratio": 0.5, "threads": -1}, ValueError, "threads must be >= 0"),
    ({"ratio": 0.5, "progress": 3}, TypeError, "progress must be callable"),
])
def test_bad_options(sphere, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        meshreduce.simplify(sphere.vertices, sphere.triangles, **kwargs)


def test_library_errors_carry_its_message(sphere):
    with pytest.raises(meshreduce.InvalidArgumentError) as e:
        meshreduce.simplify(sphere.vertices, sphere.triangles, vertex_count=10 ** 6)
    assert "exceeds the input's %d referenced vertices" % len(sphere.vertices) in str(e.value)
    assert isinstance(e.value, ValueError) and isinstance(e.value, meshreduce.Error)
    assert e.value.status == "invalid argument"
    with pytest.raises(meshreduce.InvalidArgumentError, match="FULL|full|half"):
        meshreduce.simplify(sphere.vertices, sphere.triangles, ratio=0.5, strategy="ppq")


def test_read_errors(tmp_path):
    with pytest.raises(meshreduce.MeshIOError, match="cannot open for reading") as e:
        meshreduce.read(tmp_path / "missing.obj")
    assert isinstance(e.value, OSError) and e.value.line is None
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(meshreduce.ParseError) as e:
        meshreduce.read(bad)
    assert e.value.line == 4 and "bad.obj:4" in str(e.value)
    with pytest.raises(ValueError, match="format must be one of"):
        meshreduce.read(bad, format="3ds")


# ---- read, write, generate, info, compare ---------------------------------


def test_write_read_round_trip(tmp_path, torus):
    r = meshreduce.simplify(torus.vertices, torus.triangles, ratio=0.5)
    for name, enc in (("a.ply", None), ("b.ply", "ascii"), ("c.obj", None)):
        meshreduce.write(tmp_path / name, r, encoding=enc)
        back = meshreduce.read(tmp_path / name)
        assert np.array_equal(back.triangles, r.triangles)
        assert np.allclose(back.vertices, r.vertices, rtol=1e-6, atol=0)
    meshreduce.write(str(tmp_path / "m.ply"), meshreduce.Mesh(torus.vertices.astype(np.float64),
                                                             torus.triangles.astype(np.int64)))
    back = meshreduce.read(tmp_path / "m.ply")
    assert np.array_equal(back.vertices, torus.vertices)
    # a point cloud
    meshreduce.write(tmp_path / "p.xyz", meshreduce.Mesh(torus.vertices))
    assert len(meshreduce.read(tmp_path / "p.xyz").triangles) == 0
    with pytest.raises(TypeError, match="expected an object with .vertices"):
        meshreduce.write(tmp_path / "x.ply", 42)
    with pytest.raises(meshreduce.Error):
        meshreduce.write(tmp_path / "x.unknown", r)


@needs_cli
def test_generate_matches_cli(tmp_path):
    for kind, n, seed in (("scan", 20000, 1), ("torus", 5000, 7), ("sphere", 1000, 1)):
        cli("generate", kind, "--triangles", n, "--seed", seed, "-o", tmp_path / "cli.ply", "-q")
        meshreduce.write(tmp_path / "py.ply", meshreduce.generate(kind, n, seed=seed))
        assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()


@needs_cli
def test_info_matches_cli(tmp_path, torus):
    meshreduce.write(tmp_path / "t.ply", torus)
    want = json.loads(cli("info", tmp_path / "t.ply", "--json"))
    got = meshreduce.info(meshreduce.read(tmp_path / "t.ply"))
    assert meshreduce.info(tmp_path / "t.ply") == got == meshreduce.info(str(tmp_path / "t.ply"))
    for k in ("file", "format", "bytes", "read_seconds"):
        want.pop(k)
    got["bbox_min"], got["bbox_max"] = list(got["bbox_min"]), list(got["bbox_max"])
    assert set(got) == set(want)
    for k, v in want.items():
        assert got[k] == pytest.approx(v, rel=1e-8), k
    assert meshreduce.info(torus.vertices, torus.triangles) == meshreduce.info(torus)
    assert meshreduce.info(torus.vertices)["triangles"] == 0


@needs_cli
def test_compare_matches_cli(tmp_path, torus):
    r = meshreduce.simplify(torus.vertices, torus.triangles, ratio=0.3)
    meshreduce.write(tmp_path / "a.ply", torus)
    meshreduce.write(tmp_path / "b.ply", r)
    want = json.loads(cli("compare", tmp_path / "a.ply", tmp_path / "b.ply", "--samples", 5000,
                          "--seed", 9, "--json"))
    got = meshreduce.compare(torus.vertices, torus.triangles, r.vertices, r.triangles,
                             samples=5000, seed=9)
    assert got["hausdorff"] > 0
    for k, v in got.items():
        assert want[k] == v, k  # %.17g in the JSON: the same doubles


# ---- the same results as the CLI ------------------------------------------


def simplify_both(tmp_path, path, cli_args, **kwargs):
    """The CLI's output file and JSON, and the module's output written the
    same way, for the same input file and options."""
    out = json.loads(cli("simplify", path, "-o", tmp_path / "cli.ply", "--json", "-q",
                         *cli_args))
    m = meshreduce.read(path)
    r = meshreduce.simplify(m.vertices, m.triangles, normals=m.normals,
                            texcoords=m.texcoords, colors=m.colors, **kwargs)
    meshreduce.write(tmp_path / "py.ply", r)
    return out, r


def assert_same(tmp_path, out, r):
    assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
    for k in ("target_reached", "stop_reason", "stop", "input_vertices", "output_points",
              "input_triangles", "output_vertices", "output_triangles", "collapses",
              "locked_vertices", "pruned_parts"):
        assert out[k] == getattr(r, k) == r.stats[k], k
    assert out["max_error"] == pytest.approx(r.error, rel=1e-8)


@needs_cli
@needs_bunny
@pytest.mark.parametrize("cli_args, kwargs", [
    (["--ratio", "0.1"], {"ratio": 0.1}),
    (["--triangles", "5000", "--collapse", "half", "--strategy", "greedy"],
     {"triangle_count": 5000, "collapse": "half", "strategy": "greedy"}),
    (["--vertices", "2000", "--lock-border", "--max-normal-turn", "45", "--boundary-weight", "2",
      "--threads", "1"],
     {"vertex_count": 2000, "lock_border": True, "max_normal_turn": 45, "boundary_weight": 2,
      "threads": 1}),
    (["--ratio", "0.05", "--quality", "best"], {"ratio": 0.05, "quality": "best"}),
    (["--ratio", "0.1", "--strategy", "partitioned", "--partitions", "5"],
     {"ratio": 0.1, "strategy": "partitioned", "partitions": 5}),
    (["--ratio", "0.05", "--strategy", "partitioned-boundary", "--partitions", "8"],
     {"ratio": 0.05, "strategy": "partitioned-boundary", "partitions": 8}),
])
def test_bunny_matches_cli(tmp_path, cli_args, kwargs):
    out, r = simplify_both(tmp_path, BUNNY, cli_args, **kwargs)
    assert_same(tmp_path, out, r)
    if kwargs.get("strategy", "").startswith("partitioned"):
        assert out["partitioned"] == r.stats["partitioned"]
        assert r.stats["partitioned"]["interior_collapses"] > 0
    if kwargs.get("strategy") == "partitioned-boundary":
        p = r.stats["partitioned"]
        assert p["claim_conflicts"] > 0
        assert p["rebalances"] == sum(p["rebalance_triggers"].values())


SPOT = os.path.join(DATA, "spot.obj")


@needs_cli
@pytest.mark.skipif(not os.path.exists(SPOT), reason=SPOT + " absent")
def test_texcoord_seams_match_cli(tmp_path):
    # spot.obj has texture coordinates: vertices split along UV seams,
    # carried through (mr_mesh_simplify's seam handling), as the CLI does.
    out, r = simplify_both(tmp_path, SPOT, ["--ratio", "0.2"], ratio=0.2)
    assert r.texcoords is not None and r.texcoords.shape == (len(r.vertices), 2)
    assert r.output_vertices > r.output_points  # seam splits kept
    assert_same(tmp_path, out, r)


@needs_cli
@pytest.mark.skipif(not os.path.exists(SPOT), reason=SPOT + " absent")
def test_attribute_weights_match_cli(tmp_path):
    # the attributes' part in the cost, as --attribute-weights sets it; a
    # weight of 0 (interpolation only) gives other bytes than the default
    out, r = simplify_both(tmp_path, SPOT, ["--ratio", "0.2", "--attribute-weights", "uv=2"],
                           ratio=0.2, attribute_weights={"uv": 2})
    assert_same(tmp_path, out, r)
    weighted = r.vertices.copy()
    out, r = simplify_both(tmp_path, SPOT, ["--ratio", "0.2", "--attribute-weights", "none"],
                           ratio=0.2, attribute_weights={"normal": 0, "uv": 0, "color": 0})
    assert_same(tmp_path, out, r)
    assert weighted.shape != r.vertices.shape or not np.array_equal(weighted, r.vertices)


@needs_cli
@pytest.mark.skipif(not os.path.exists(SPOT), reason=SPOT + " absent")
def test_seams_match_cli(tmp_path):
    # seams='free' is --seams free: the same bytes, and other bytes than
    # the default's (spot's seams give way at 2 %)
    out, r = simplify_both(tmp_path, SPOT, ["--ratio", "0.02", "--seams", "free"],
                           ratio=0.02, seams="free")
    assert_same(tmp_path, out, r)
    free = r.vertices.copy()
    out, r = simplify_both(tmp_path, SPOT, ["--ratio", "0.02"], ratio=0.02)
    assert_same(tmp_path, out, r)
    assert free.shape != r.vertices.shape or not np.array_equal(free, r.vertices)
    with pytest.raises(ValueError, match="seams must be"):
        meshreduce.simplify(r.vertices, r.triangles, ratio=0.5, seams="loose")


@needs_cli
@pytest.mark.skipif(not os.path.exists(SPOT), reason=SPOT + " absent")
def test_lods_match_cli(tmp_path):
    # simplify_lods gives `simplify --lods`'s levels: the same bytes, the
    # same distances, errors never decreasing, origins into the input
    m = meshreduce.read(SPOT)
    levels = meshreduce.simplify_lods(m.vertices, m.triangles, [0.5, 0.2, 0.05],
                                      texcoords=m.texcoords, threads=1)
    out = json.loads(cli("--threads", 1, "simplify", SPOT, "-o", tmp_path / "cli.ply",
                         "--lods", "50%,20%,5%", "--json", "-q"))
    assert len(levels) == len(out["levels"]) == 3
    for k, (r, c) in enumerate(zip(levels, out["levels"])):
        meshreduce.write(tmp_path / ("py.lod%d.ply" % (k + 1)), r)
        assert (tmp_path / ("py.lod%d.ply" % (k + 1))).read_bytes() == \
            (tmp_path / ("cli.lod%d.ply" % (k + 1))).read_bytes()
        assert r.target_triangles == c["target_triangles"]
        assert len(r.triangles) == c["triangles"] <= c["target_triangles"]
        assert r.origin.max() < len(m.vertices)
        # compare()'s figures are mr_compare_with's, bit for bit
        assert r.hausdorff_rel == c["hausdorff_rel"] and r.rms_rel == c["rms_rel"]
        if k:
            assert r.error_rel >= levels[k - 1].error_rel
            assert c["error_rel"] >= out["levels"][k - 1]["error_rel"]
    # level 0 is the input, written as read
    assert len(meshreduce.read(tmp_path / "cli.ply").triangles) == len(m.triangles)
    with pytest.raises(ValueError, match="the levels are the targets"):
        meshreduce.simplify_lods(m.vertices, m.triangles, [0.5], ratio=0.5)
    with pytest.raises(ValueError, match="decreasing|below the level before"):
        meshreduce.simplify_lods(m.vertices, m.triangles, [0.2, 0.5])


@needs_cli
def test_generated_matches_cli(tmp_path):
    src = tmp_path / "scan.ply"
    cli("generate", "scan", "--triangles", 30000, "-o", src, "-q")
    lock = np.arange(0, 15000, 11)
    (tmp_path / "lock.txt").write_text(" ".join(map(str, lock)))
    for cli_args, kwargs in (
            (["--max-error", "0.002", "--triangles", "0"], {"max_error": 0.002, "triangle_count": 0}),
            (["--ratio", "5%", "--lock", tmp_path / "lock.txt", "--prune"],
             {"ratio": 0.05, "locked": lock, "prune": True}),
            (["--ratio", "0.2", "--strategy", "ppq", "--collapse", "half", "--threads", "1"],
             {"ratio": 0.2, "strategy": "ppq", "collapse": "half", "threads": 1})):
        out, r = simplify_both(tmp_path, src, cli_args, **kwargs)
        assert_same(tmp_path, out, r)


def test_threads_give_the_same_result(torus):
    v, t = torus.vertices, torus.triangles
    ref = meshreduce.simplify(v, t, ratio=0.2, threads=1)
    for n in (0, 2, 3):
        r = meshreduce.simplify(v, t, ratio=0.2, threads=n)
        assert np.array_equal(r.triangles, ref.triangles)
        assert np.array_equal(r.vertices, ref.vertices)


# ---- progress, leaks, fork -------------------------------------------------


def test_progress(sphere):
    seen = []
    meshreduce.simplify(sphere.vertices, sphere.triangles, ratio=0.1, progress=seen.append)
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)

    class Stop(Exception):
        pass

    def stop(fraction):
        raise Stop("from progress")

    with pytest.raises(Stop, match="from progress"):
        meshreduce.simplify(sphere.vertices, sphere.triangles, ratio=0.1, progress=stop)


@pytest.mark.parametrize("strategy, collapse", [("batched", "full"), ("greedy", "half"),
                                                ("fppq", "half")])
def test_progress_cancels(strategy, collapse):
    # An exception from progress stops the library there (MR_ERR_CANCELLED
    # inside): progress is not called again, and the exception is raised.
    m = meshreduce.generate("scan", 40000)
    seen = []

    def stop_at_third(fraction):
        seen.append(fraction)
        if len(seen) == 3:
            raise KeyError("enough")

    with pytest.raises(KeyError, match="enough"):
        meshreduce.simplify(m.vertices, m.triangles, ratio=0.05, strategy=strategy,
                            collapse=collapse, threads=2, progress=stop_at_third)
    assert len(seen) == 3 and seen[-1] < 1.0
    # Ctrl-C: SIGINT while the library works becomes KeyboardInterrupt
    seen.clear()

    def interrupt(fraction):
        seen.append(fraction)
        if len(seen) == 2:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        meshreduce.simplify(m.vertices, m.triangles, ratio=0.05, strategy=strategy,
                            collapse=collapse, threads=2, progress=interrupt)
    assert len(seen) == 2


def test_ctrl_c_without_progress():
    # No progress callable: SIGINT while the library works still stops it
    # at its next report (about 1 % of the collapses), not at the end.
    import threading
    import time
    m = meshreduce.generate("scan", 300000)

    def run():  # greedy on one thread, to 1 %: about a second of work
        meshreduce.simplify(m.vertices, m.triangles, ratio=0.01, strategy="greedy", threads=1)

    t0 = time.perf_counter()
    run()
    full = time.perf_counter() - t0
    delay = full / 20
    timer = threading.Timer(delay, os.kill, (os.getpid(), signal.SIGINT))
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        run()
    elapsed = time.perf_counter() - t0
    timer.join()
    # stopped soon after the signal, not when the work was done
    assert elapsed < delay + 0.4 * full, "stopped after %.2f s of %.2f s" % (elapsed, full)


def rss_kib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024


def test_no_leaks_over_10000_calls():
    m = meshreduce.generate("sphere", 200)
    v, t = m.vertices, m.triangles
    t64 = t.astype(np.int64)
    nan = v.copy()
    nan[3, 1] = np.nan

    def calls(n, others_every=1):
        for i in range(n):
            r = meshreduce.simplify(v, t64, ratio=0.5, threads=1)
            assert len(r.triangles)
            if i % others_every:
                continue
            try:
                meshreduce.simplify(nan, t, ratio=0.5)
            except ValueError:
                pass
            try:
                meshreduce.simplify(v, t, vertex_count=10 ** 6)
            except meshreduce.Error:
                pass
            meshreduce.info(v, t)

    import tracemalloc
    calls(200)  # warm up: allocator pools, caches
    tracemalloc.start()
    calls(100)
    gc.collect()
    traced = tracemalloc.get_traced_memory()[0]
    calls(1000)  # traced: a leaked Python object per call shows (> 50 kB)
    gc.collect()
    grown = tracemalloc.get_traced_memory()[0] - traced
    tracemalloc.stop()
    assert grown < 30000, "Python allocations grew by %d bytes over 1,000 calls" % grown
    gc.collect()
    refs = (sys.getrefcount(v), sys.getrefcount(t), sys.getrefcount(t64), sys.getrefcount(None),
            sys.getrefcount(True))
    objects = len(gc.get_objects())
    rss = rss_kib()
    calls(10000, others_every=4)  # 10,000 simplify calls, 2,500 of each other kind
    gc.collect()
    assert (sys.getrefcount(v), sys.getrefcount(t), sys.getrefcount(t64)) == refs[:3]
    # None and True are shared by everything; a leak of one per call shows.
    assert abs(sys.getrefcount(None) - refs[3]) < 1000
    assert abs(sys.getrefcount(True) - refs[4]) < 1000
    assert len(gc.get_objects()) - objects < 1000
    # 10,000 leaked results of ~100 vertices would be > 10 MB
    assert rss_kib() - rss < 4096, "RSS grew by %d KiB" % (rss_kib() - rss)


def _child_simplify(n):
    m = meshreduce.generate("scan", 20000, seed=n)
    r = meshreduce.simplify(m.vertices, m.triangles, ratio=0.1, threads=0)
    return len(r.triangles)


def test_fork_after_a_call():
    # The parent runs parallel regions first (OpenMP's thread pool exists),
    # then forks: the children must not hang (libgomp is not fork-safe: the
    # module runs forked children on one thread).
    m = meshreduce.generate("scan", 20000, seed=1)
    meshreduce.simplify(m.vertices, m.triangles, ratio=0.1, threads=2)
    want = [_child_simplify(n) for n in (1, 2)]
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(2) as pool:
        res = pool.map_async(_child_simplify, [1, 2])
        assert res.get(timeout=120) == want


# ---- interop -----------------------------------------------------------------


def test_open3d_arrays(sphere):
    o3d = pytest.importorskip("open3d")
    mesh = o3d.geometry.TriangleMesh()
    mesh.vertices = o3d.utility.Vector3dVector(sphere.vertices.astype(np.float64))
    mesh.triangles = o3d.utility.Vector3iVector(sphere.triangles.astype(np.int32))
    r = meshreduce.simplify(np.asarray(mesh.vertices), np.asarray(mesh.triangles), ratio=0.25)
    ref = meshreduce.simplify(sphere.vertices, sphere.triangles, ratio=0.25)
    assert np.array_equal(r.triangles, ref.triangles)
    out = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(r.vertices.astype(np.float64)),
                                    o3d.utility.Vector3iVector(r.triangles.astype(np.int32)))
    assert len(out.triangles) == len(ref.triangles)


def test_docstrings():
    import inspect
    for name in meshreduce.__all__:
        obj = getattr(meshreduce, name)
        if callable(obj):
            assert obj.__doc__ and len(obj.__doc__) >= 30, name
        if callable(obj) and not isinstance(obj, type):
            inspect.signature(obj)  # a text signature for help() and IDEs
    assert "multiqueue_factor" in inspect.signature(meshreduce.simplify).parameters
    stub = os.path.join(os.path.dirname(meshreduce.__file__), "__init__.pyi")
    assert os.path.exists(stub)


# ---- weld, cluster, render ---------------------------------------------------


@needs_cli
@pytest.mark.parametrize("cli_args, kwargs", [
    (["--eps-rel", "0.01"], {"eps_rel": 0.01}),
    (["--eps", "0.05", "--strict", "--order", "grade", "--algorithm", "serial",
      "--drop-degenerate"],
     {"eps": 0.05, "strict": True, "order": "grade", "algorithm": "serial",
      "drop_degenerate": True}),
    (["--reduce", "30"], {"reduce": 0.3}),
])
def test_weld_matches_cli(tmp_path, cli_args, kwargs):
    src = tmp_path / "scan.ply"
    cli("generate", "scan", "--triangles", 20000, "-o", src, "-q")
    out = json.loads(cli("weld", src, "-o", tmp_path / "cli.ply", "--json", "-q", *cli_args))
    m = meshreduce.read(src)
    r = meshreduce.weld(m.vertices, m.triangles, **kwargs)
    meshreduce.write(tmp_path / "py.ply", r)
    assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
    for k in ("algorithm", "eps", "input_vertices", "output_vertices", "output_triangles",
              "graph_edges"):
        assert out[k] == getattr(r, k), k
    assert r.remap.shape == (len(m.vertices),) and r.remap.max() == len(r.vertices) - 1


def test_weld_point_cloud_and_threads():
    rng = np.random.default_rng(5)
    pts = rng.random((3000, 3)).astype(np.float32)
    pts = np.concatenate([pts, pts + 1e-4])
    r = meshreduce.weld(pts, eps=1e-3)
    assert len(r.vertices) == 3000 and r.output_triangles == 0
    assert np.array_equal(r.remap[:3000], r.remap[3000:])
    # threads=0: all the cores OpenMP may use (OMP_NUM_THREADS, else the
    # CPUs this process may run on)
    cores = int(os.environ.get("OMP_NUM_THREADS") or len(os.sched_getaffinity(0)))
    if not meshreduce.features["openmp"]:
        cores = 1  # the serial build
    assert meshreduce.weld(pts, eps=1e-3, threads=0).threads == cores
    assert meshreduce.weld(pts, eps=1e-3, threads=1).threads == 1
    for kw in ({}, {"eps": 1, "eps_rel": 1}, {"eps": -1}, {"reduce": 1.0}):
        with pytest.raises(ValueError):
            meshreduce.weld(pts, **kw)
    with pytest.raises(ValueError, match="algorithm must be one of"):
        meshreduce.weld(pts, eps=0, algorithm="fast")


@needs_cli
def test_cluster_matches_cli(tmp_path):
    src = tmp_path / "torus.ply"
    cli("generate", "torus", "--triangles", 20000, "-o", src, "-q")
    m = meshreduce.read(src)
    for cli_args, kwargs in ((["--cell-rel", "0.02"], {"cell_rel": 0.02}),
                             (["--target-vertices", "1500"], {"vertex_count": 1500})):
        out = json.loads(cli("cluster", src, "-o", tmp_path / "cli.ply", "--json", "-q",
                             *cli_args))
        r = meshreduce.cluster(m.vertices, m.triangles, **kwargs)
        meshreduce.write(tmp_path / "py.ply", r)
        assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
        assert out["cell"] == r.cell and out["cells"] == r.cells
    with pytest.raises(ValueError, match="exactly one of"):
        meshreduce.cluster(m.vertices, m.triangles)


@needs_cli
def test_cluster_file_matches_cli(tmp_path):
    src = tmp_path / "scan.ply"
    cli("generate", "scan", "--triangles", 30000, "-o", src, "-q")
    for cli_args, kwargs in ((["--cell-rel", "0.01"], {"cell_rel": 0.01}),
                             (["--target-vertices", "2000"], {"vertex_count": 2000})):
        out = json.loads(cli("cluster", src, "-o", tmp_path / "cli.ply", "--json", "-q",
                             *cli_args))
        st = meshreduce.cluster_file(src, tmp_path / "py.ply", **kwargs)
        assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
        assert out["cell"] == st["cell"] and out["cells"] == st["cells"]
    with pytest.raises(ValueError, match="exactly one of"):
        meshreduce.cluster_file(src, tmp_path / "x.ply")
    with pytest.raises(meshreduce.MeshIOError):
        meshreduce.cluster_file(tmp_path / "missing.ply", tmp_path / "x.ply", cell=1.0)
    assert not (tmp_path / "x.ply").exists()
    # an OBJ file: streamed through temporary files under a small budget,
    # read whole under the default; the same bytes either way, as the CLI's
    obj = tmp_path / "scan.obj"
    cli("convert", src, obj, "-q")
    whole = meshreduce.cluster_file(obj, tmp_path / "whole.ply", cell_rel=0.01)
    streamed = meshreduce.cluster_file(obj, tmp_path / "streamed.ply", cell_rel=0.01,
                                       memory=1 << 20, temp_dir=tmp_path)
    out = json.loads(cli("cluster", obj, "-o", tmp_path / "cli.ply", "--cell-rel", "0.01",
                         "--memory", "1M", "--temp-dir", tmp_path, "--json", "-q"))
    assert not whole["streamed"] and streamed["streamed"] and out["streamed"]
    assert streamed["temp_bytes_peak"] > 0
    assert ((tmp_path / "whole.ply").read_bytes() == (tmp_path / "streamed.ply").read_bytes()
            == (tmp_path / "cli.ply").read_bytes())


@needs_cli
def test_simplify_file_matches_cli(tmp_path):
    src = tmp_path / "scan.ply"
    cli("generate", "scan", "--triangles", 60000, "-o", src, "-q")
    # out of core (a 2 MiB budget) and in memory (the default): the CLI's bytes
    for memory, cli_memory in ((2 << 20, "2M"), (None, "4G")):
        out = json.loads(cli("simplify", src, "-o", tmp_path / "cli.ply", "--ratio", "2%",
                             "--memory", cli_memory, "--json", "-q"))
        kwargs = {"memory": memory} if memory else {}
        st = meshreduce.simplify_file(src, tmp_path / "py.ply", ratio=0.02, temp_dir=tmp_path,
                                      **kwargs)
        assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
        assert st["out_of_core"] == out["out_of_core"] == (memory is not None)
        assert st["output_triangles"] == out["output_triangles"]
        if memory:
            assert st["chunks"] == out["chunks"] >= 2
            assert len(st["levels"]) == len(out["levels"])
    # an output larger than a chunk: the forest, top_chunks, the CLI's bytes
    out = json.loads(cli("simplify", src, "-o", tmp_path / "cli.ply", "--ratio", "60%",
                         "--memory", "2M", "--json", "-q"))
    st = meshreduce.simplify_file(src, tmp_path / "py.ply", ratio=0.6, memory=2 << 20)
    assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
    assert st["top_chunks"] == out["top_chunks"] >= 2
    # texture coordinates and colors travel through the chunks (a seamed copy
    # of the scan): the CLI's bytes, the attributes in the output
    seamed = tmp_path / "seamed.ply"
    subprocess.run([sys.executable, MAKE_SEAMED, str(src), str(seamed)], check=True)
    out = json.loads(cli("simplify", seamed, "-o", tmp_path / "cli.ply", "--ratio", "5%",
                         "--memory", "6M", "--json", "-q"))
    st = meshreduce.simplify_file(seamed, tmp_path / "py.ply", ratio=0.05, memory=6 << 20)
    assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
    assert st["out_of_core"] and st["chunks"] == out["chunks"] >= 2
    got = meshreduce.read(tmp_path / "py.ply")
    assert got.texcoords is not None and got.colors is not None
    # the locked vertices stay; a budget too small is an error, no output left
    m = meshreduce.read(src)
    st = meshreduce.simplify_file(src, tmp_path / "lk.ply", ratio=0.02, memory=2 << 20,
                                  locked=[0, 10, 20])
    got = meshreduce.read(tmp_path / "lk.ply")
    for v in (0, 10, 20):
        assert (got.vertices == m.vertices[v]).all(axis=1).any()
    with pytest.raises(meshreduce.InvalidArgumentError, match="too small"):
        meshreduce.simplify_file(src, tmp_path / "x.ply", ratio=0.02, memory=65536)
    with pytest.raises(ValueError, match="no target"):
        meshreduce.simplify_file(src, tmp_path / "x.ply")
    assert not (tmp_path / "x.ply").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".meshreduce")]


@needs_cli
@pytest.mark.skipif(not meshreduce.features["png"], reason="built without libpng")
def test_render_matches_cli(tmp_path, torus):
    meshreduce.write(tmp_path / "t.ply", torus)
    cli("render", tmp_path / "t.ply", "-o", tmp_path / "cli.png", "--size", "96x64", "--view",
        "front", "--wire", "-q")
    img = meshreduce.render(torus.vertices, torus.triangles, width=96, height=64, view="front",
                            wire=True)
    assert img.shape == (64, 96, 4) and img.dtype == np.uint8 and (img[..., 3] == 255).all()
    assert len(np.unique(img.reshape(-1, 4), axis=0)) > 10
    meshreduce.write_png(tmp_path / "py.png", img)
    assert (tmp_path / "cli.png").read_bytes() == (tmp_path / "py.png").read_bytes()


@needs_cli
@pytest.mark.skipif(not meshreduce.features["png"], reason="built without libpng")
def test_textured_render(tmp_path, sphere):
    # a file is drawn as the CLI draws it: its materials and texture
    tex = np.zeros((16, 16, 3), np.uint8)
    tex[::4] = (255, 0, 0)
    img = meshreduce.render(sphere.vertices, sphere.triangles, width=64, height=48)
    meshreduce.write_png(tmp_path / "tex.png", np.dstack([tex, np.full((16, 16), 255, np.uint8)]))
    uv = (sphere.vertices[:, :2] * 0.5 + 0.5).astype(np.float32)
    m = meshreduce.Mesh(sphere.vertices, sphere.triangles, texcoords=uv,
                        materials=np.zeros(len(sphere.triangles), np.int64))
    meshreduce.write(tmp_path / "s.obj", m, material_names=["skin"])
    text = (tmp_path / "s.obj").read_text()
    (tmp_path / "s.obj").write_text("mtllib s.mtl\n" + text)
    (tmp_path / "s.mtl").write_text("newmtl skin\nKd 1 1 1\nmap_Kd tex.png\n")
    cli("render", tmp_path / "s.obj", "-o", tmp_path / "cli.png", "--size", "64x48", "-q")
    got = meshreduce.render(tmp_path / "s.obj", width=64, height=48)
    meshreduce.write_png(tmp_path / "py.png", got)
    assert (tmp_path / "cli.png").read_bytes() == (tmp_path / "py.png").read_bytes()
    assert not np.array_equal(got, img)
    plain = meshreduce.render(str(tmp_path / "s.obj"), width=64, height=48, plain=True)
    assert np.array_equal(plain, img)
    # the same look from arrays
    arr = meshreduce.render(sphere.vertices, sphere.triangles, width=64, height=48,
                            texcoords=uv, looks=[{"color": (1, 1, 1), "texture": tex}])
    assert np.array_equal(arr, got)
    two = meshreduce.render(sphere.vertices, sphere.triangles, width=64, height=48,
                            looks=[{"color": 0xFF8800}, {"color": (0.2, 0.4, 1.0)}],
                            face_materials=np.arange(len(sphere.triangles)) % 2)
    assert len(np.unique(two.reshape(-1, 4), axis=0)) > len(np.unique(img.reshape(-1, 4), axis=0)) / 4
    with pytest.raises(ValueError, match="face_materials: value 2"):
        meshreduce.render(sphere.vertices, sphere.triangles, width=8, height=8,
                          looks=[{}, {}], face_materials=np.full(len(sphere.triangles), 2))
    with pytest.raises(ValueError, match="give looks too"):
        meshreduce.render(sphere.vertices, sphere.triangles, width=8, height=8,
                          face_materials=np.zeros(len(sphere.triangles)))
    with pytest.raises(TypeError, match="brings its own triangles"):
        meshreduce.render(tmp_path / "s.obj", sphere.triangles)
    with pytest.raises(meshreduce.Error, match="tex2.png"):
        (tmp_path / "s.mtl").write_text("newmtl skin\nKd 1 1 1\nmap_Kd tex2.png\n")
        meshreduce.render(tmp_path / "s.obj", width=8, height=8)


@pytest.mark.skipif(meshreduce.features["png"], reason="built with libpng")
def test_write_png_without_libpng(tmp_path):
    with pytest.raises(meshreduce.UnsupportedError, match="PNG output: support was not built"):
        meshreduce.write_png(tmp_path / "x.png", np.zeros((2, 2, 4), np.uint8))
    assert not (tmp_path / "x.png").exists()


def test_render_options(torus):
    v, t = torus.vertices, torus.triangles
    a = meshreduce.render(v, t, width=40, height=30, threads=1)
    assert np.array_equal(a, meshreduce.render(v, t, width=40, height=30, threads=2))
    heat = meshreduce.render(v, t, width=40, height=30, face_scalar=np.arange(len(t)))
    assert not np.array_equal(a, heat)
    pts = meshreduce.render(v, None, width=40, height=30, background=(0, 0, 0))
    assert (pts[0, 0, :3] == 0).all()
    with pytest.raises(ValueError, match="one value per triangle"):
        meshreduce.render(v, t, face_scalar=[1.0, 2.0])
    with pytest.raises(ValueError, match="view must be one of"):
        meshreduce.render(v, t, view="below")
    with pytest.raises(ValueError, match="width and height"):
        meshreduce.render(v, t, width=0)
