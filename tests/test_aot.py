"""The ahead-of-time kernels (issue 15 item 2): same results as numba's, never stale, never unsafe.

The extension module is built by ``pip install`` (setup.py); tests that run its code skip where
it was not built, except in CI, whose install must build it.
"""

import contextlib
import os
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from replication import _aot
from replication.errors import DuplicatePointsWarning
from replication.surfaces import _blocks, _moments, _partition, _triangulate, adt
from replication.surfaces._threads import frozen

BUILT = _aot.compiled() is not None
needs_module = pytest.mark.skipif(not BUILT, reason="the ahead-of-time kernels were not built here")


def test_ci_installs_the_compiled_kernels():
    if not os.environ.get("CI"):
        pytest.skip("only CI promises a build machine with a C compiler")
    assert BUILT, "pip install built no ahead-of-time kernels (see setup.py's build output)"


def _same_single(points: np.ndarray, axes=(0, 1)) -> None:
    points = frozen(points, np.float64)
    ahead = _aot._checked("single")(points, *axes)
    jit = _blocks.single(points, *axes)
    assert ahead[0] == jit[0]
    for a, b in zip(ahead[1:], jit[1:]):
        assert a.dtype == b.dtype == np.int32
        np.testing.assert_array_equal(a, b)


@needs_module
@given(
    n=st.integers(3, 300),
    lattice=st.booleans(),
    repeats=st.integers(0, 20),
    seed=st.integers(0, 2**32 - 1),
)
def test_single_matches_numba_on_random_lattice_and_repeated_points(n, lattice, repeats, seed):
    rng = np.random.default_rng(seed)
    points = rng.integers(0, 6, (n, 3)).astype(float) if lattice else rng.normal(size=(n, 3))
    if repeats:
        points = np.vstack([points, points[rng.integers(0, n, repeats)]])
    _same_single(points, axes=tuple(rng.permutation(3)[:2]))


@needs_module
def test_single_matches_numba_on_collinear_and_overflowing_clouds():
    line = np.column_stack([np.arange(10.0), 2 * np.arange(10.0), np.zeros(10)])
    _same_single(line)  # STATUS_COLLINEAR
    huge = np.array([[0.0, 0.0, 0], [1e308, 0, 0], [0, 1e308, 0], [1e308, 1e308, 0]])
    _same_single(huge)


@needs_module
@given(rows=st.integers(1, 500), seed=st.integers(0, 2**32 - 1), bad=st.sampled_from([None, np.nan, np.inf]))
def test_column_spreads_kernel_matches_numba(rows, seed, bad):
    points = np.random.default_rng(seed).normal(size=(rows, 3)) * 1e3
    if bad is not None:
        points[rows // 2, 1] = bad
    points = frozen(points)
    ahead, jit = np.empty(3), np.empty(3)
    assert _aot._checked("column_spreads")(points, ahead) == _moments._small(points, jit)
    np.testing.assert_array_equal(ahead, jit)


@needs_module
@pytest.mark.parametrize(
    "args",
    [
        (np.zeros((5, 3), np.float32), 0, 1),
        (np.zeros((5, 6))[:, ::2], 0, 1),
        (np.frombuffer(bytes(121), dtype=np.float64, offset=1).reshape(5, 3), 0, 1),
        (np.zeros(5), 0, 1),
        (np.zeros((5, 3)), 0.5, 1),
        (np.zeros((5, 3)), True, 1),
        (np.zeros((5, 3)), 0),
    ],
    ids=["float32", "strided", "misaligned", "1-D", "float axis", "bool axis", "two arguments"],
)
def test_arguments_of_other_types_go_to_numba_instead_of_crashing(args, monkeypatch):
    calls = []
    monkeypatch.setattr(_aot, "_jit", lambda name: lambda *a: calls.append((name, a)) or "numba")
    assert _aot._checked("single")(*args) == "numba"
    assert calls == [("single", args)]


@needs_module
def test_read_only_outputs_go_to_numba():
    out = np.empty(3)
    out.flags.writeable = False
    assert not _aot._fits(out, _aot._parse("float64[::1]"))
    assert _aot._fits(out, _aot._parse("float64[::1] ro"))
    assert _aot._fits(np.int64(3), _aot._parse("int64")) and _aot._fits(3, _aot._parse("int64"))


def test_misaligned_clouds_are_copied_to_aligned_ones():
    from replication.surfaces import adt

    cloud = np.random.default_rng(5).normal(size=(50, 3))
    raw = b"\0" + cloud.tobytes()
    odd = np.frombuffer(raw, dtype=np.float64, offset=1).reshape(50, 3)
    assert not odd.flags.aligned
    assert frozen(odd).flags.aligned
    np.testing.assert_array_equal(adt(odd).triangles, adt(cloud).triangles)


@contextlib.contextmanager
def _fresh_lookup(monkeypatch):
    """``compiled()`` asked again under the patches made inside; the real answer after."""
    _aot.compiled.cache_clear()
    try:
        yield
    finally:
        monkeypatch.undo()
        _aot.compiled.cache_clear()


def test_a_module_built_from_other_sources_is_never_used(monkeypatch):
    with _fresh_lookup(monkeypatch):
        monkeypatch.setattr(_aot, "source_digest", lambda: -1)
        assert _aot.compiled() is None
    assert (_aot.compiled() is not None) == BUILT


def test_environment_variable_disables_the_module(monkeypatch):
    with _fresh_lookup(monkeypatch):
        monkeypatch.setenv("REPLICATION_AOT", "0")
        assert _aot.compiled() is None


def test_digest_changes_with_any_kernel_source(tmp_path, monkeypatch):
    real = os.path.dirname(_aot.__file__)
    package = tmp_path / "replication"
    shutil.copytree(os.path.dirname(_aot.__file__) + "/surfaces", package / "surfaces")
    shutil.copy(_aot.__file__, package / "_aot.py")
    shutil.copy(os.path.dirname(_aot.__file__) + "/_aotbuild.py", package / "_aotbuild.py")
    monkeypatch.setattr(_aot, "__file__", str(package / "_aot.py"))
    before = _aot.source_digest()
    assert before == _aot.source_digest()  # deterministic
    predicates = package / "surfaces" / "_predicates.py"
    predicates.write_text(predicates.read_text() + "\n")
    assert _aot.source_digest() != before
    (package / "surfaces" / "_new.py").write_text("")
    assert len({before, _aot.source_digest()}) == 2
    changed = _aot.source_digest()
    (package / "_aotbuild.py").write_text("")
    assert _aot.source_digest() != changed
    (package / "casestudy").mkdir()
    shutil.copy(real + "/casestudy/_sheet.py", package / "casestudy" / "_sheet.py")
    with_sheet = _aot.source_digest()
    assert with_sheet != changed
    sheet = package / "casestudy" / "_sheet.py"
    sheet.write_text(sheet.read_text() + "\n")
    assert _aot.source_digest() != with_sheet


def test_digest_covers_every_module_the_kernels_are_compiled_from():
    """The compiled kernels' modules, and every package module they import, are hashed."""
    modules = {spec.module for spec in _aot.KERNELS.values()}
    imports = "".join(f"import {m}\n" for m in sorted(modules))
    code = f"import sys\n{imports}print(*sys.modules)"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    package = {m for m in loaded.stdout.split() if m.startswith("replication")}
    hashed = {m for m in package if m.startswith(("replication.surfaces._", "replication.casestudy._sheet"))}
    assert modules <= hashed  # private modules of replication.surfaces and the jet's kernels: all hashed
    packages = {"replication", "replication._lazy", "replication.surfaces", "replication.casestudy"}
    no_kernels = {"replication._numbacache", "replication._aot"}  # the cache check and this digest
    assert package - hashed <= packages | no_kernels  # package __init__ modules import their names lazily


def test_once_numba_has_loaded_a_kernel_it_serves_later_calls():
    points = frozen(np.random.default_rng(0).normal(size=(20, 3)))
    _blocks.single(points, 0, 1)  # loaded (the suite's warm-up did it already)
    assert _aot.kernel("single") is _blocks.single


def test_type_spelling_of_the_table():
    from numba.core import types

    def spelled(text):
        return _aot.numba_signature(_aot.Kernel("", "", (text,), ("none",))).args[0]

    assert spelled("float64[:, ::1] ro") == types.Array(types.float64, 2, "C", readonly=True)
    assert spelled("int32[::1]") == types.Array(types.int32, 1, "C")
    assert spelled("int64") == types.int64
    single = _aot.numba_signature(_aot.KERNELS["single"])
    assert single.return_type == types.Tuple([types.int64, *[types.Array(types.int32, 2, "C")] * 2,
                                              *[types.Array(types.int32, 1, "C")] * 3])  # fmt: skip
    assert _aot.numba_signature(_aot.KERNELS["raster"]).return_type == types.none
    assert _aot._parse("float64[:, ::1] ro") == (np.dtype(np.float64), 2, True)
    assert _aot._parse("float64[::1]") == (np.dtype(np.float64), 1, False)
    assert _aot._parse("int64") == (np.dtype(np.int64), 0, False)
    assert _aot._parse("boolean") == (np.dtype(bool), 0, False)


def test_small_clouds_are_one_block_so_the_one_call_path_needs_no_partition():
    assert _triangulate.SMALL < _partition.PARALLEL_MIN
    assert _partition.levels(_triangulate.SMALL) == 0


def _command(tmp_path, args: list[str], out_name: str, aot: str) -> tuple[str, bytes]:
    """Run ``replication ARGS -o OUT`` in a fresh interpreter: (numba, scipy.spatial loaded), OUT's bytes."""
    out = tmp_path / out_name
    code = (
        "import sys\nfrom replication.cli import main\n"
        f"assert main({[*args, '-o', str(out)]!r}) == 0\n"
        "print('numba' in sys.modules, 'scipy.spatial' in sys.modules)"
    )
    env = dict(os.environ, REPLICATION_AOT=aot)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    return done.stdout.splitlines()[-1], out.read_bytes()


@needs_module
@pytest.mark.parametrize(
    "args, suffix",
    [
        (["adt", "--random", "300", "--seed", "4"], ".vtk"),
        (["nurbs", "--random", "300", "--seed", "5"], ".json"),
    ],
    ids=["adt", "nurbs"],
)
def test_small_commands_run_without_numba_and_write_the_same_file(tmp_path, args, suffix):
    (loaded_aot, ahead), (loaded_jit, jit) = (
        _command(tmp_path, args, "aot" + suffix, "1"),
        _command(tmp_path, args, "jit" + suffix, "0"),
    )
    assert loaded_aot == "False False"
    assert loaded_jit.startswith("True")
    assert ahead == jit


@needs_module
def test_force_command_runs_without_numba_and_gives_the_same_force(tmp_path):
    import json

    cloud = np.random.default_rng(1).uniform([0, 0, 0], [36, 30, 13], (101, 3))
    path = tmp_path / "half.csv"
    np.savetxt(path, cloud, delimiter=",", header="x,y,z", comments="")
    code = (
        "import contextlib, io, json, sys\nfrom replication.cli import main\nout = io.StringIO()\n"
        f"with contextlib.redirect_stdout(out):\n    assert main(['force', '--json', {str(path)!r}]) == 0\n"
        "record = json.loads(out.getvalue())\nrecord.pop('evaluation_seconds')\n"
        "print(json.dumps([record, 'numba' in sys.modules]))"
    )
    runs = []
    for aot in ("1", "0"):
        env = dict(os.environ, REPLICATION_AOT=aot)
        command = [sys.executable, "-c", code]
        done = subprocess.run(command, capture_output=True, text=True, env=env, check=True)
        runs.append(json.loads(done.stdout.splitlines()[-1]))
    (ahead, numba_loaded_aot), (jit, numba_loaded_jit) = runs
    assert not numba_loaded_aot and numba_loaded_jit
    assert ahead == jit and ahead["axial_force_N"] > 0


def _gridding_inputs(n: int, seed: int, lattice: bool):
    """A small ADT surface relabelled for the gridding, its grid, and queries outside its hull."""
    from replication.surfaces import adt
    from replication.surfaces._grid import relabel

    rng = np.random.default_rng(seed)
    points = rng.integers(0, 5, (n, 3)).astype(float) if lattice else rng.normal(size=(n, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        surface = adt(points, depth="z", duplicates="mean")
    order = np.arange(surface.n_vertices, dtype=np.int32)
    xy, depth, tri, (u0, u1, v0, v1) = relabel(surface.points, np.array([0, 1, 2]), surface.triangles, order)
    u = np.linspace(u0, u1, int(rng.integers(2, 30)))
    v = np.linspace(v0, v1, int(rng.integers(2, 30)))
    angle = rng.uniform(0, 2 * np.pi, int(rng.integers(1, 20)))
    reach = np.hypot(xy[:, 0], xy[:, 1]).max() + 1 + rng.uniform(0, 5)  # beyond every vertex: outside
    far = np.column_stack([np.cos(angle), np.sin(angle)]) * reach
    return surface, xy, depth, tri, u, v, far


def _both(name: str, *args, outputs: tuple[int, ...]):
    """Kernel ``name`` run ahead-of-time and by numba on copies of the outputs ``args[k]``, k in outputs."""
    runs = []
    for code in (_aot._checked(name), _aot._jit(name)):
        given = [a.copy() if k in outputs else a for k, a in enumerate(args)]
        code(*given)
        runs.append([given[k] for k in outputs])
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


@needs_module
@given(genome_seed=st.integers(0, 2**32 - 1), full_jet=st.booleans())
def test_jet_model_kernels_match_numba(genome_seed, full_jet):
    """The jet's force on random GA surfaces, every kernel ahead of time against numba's."""
    from replication.casestudy import jet, mesh
    from replication.casestudy.ga import GAConfig, points_from_genome, random_genome

    config = GAConfig()
    points = points_from_genome(random_genome(config, rng=np.random.default_rng(genome_seed)), config)
    if full_jet:  # the full jet on the surface mirrored into y < 0
        points = np.vstack([points, points * [1.0, -1.0, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        surface = adt(points, depth="z")
    jet_config = jet.JetConfig(full_jet=True) if full_jet else jet.JetConfig()
    results = []
    for code in (_aot._checked, _aot._jit):
        with pytest.MonkeyPatch.context() as patch:
            for module in (jet, mesh):
                patch.setattr(module, "kernel", code)
            force = jet.surface_force(surface, jet_config)
            checked = jet.jet_force(surface.points, surface.triangles, jet_config)
        results.append((force.force.tolist(), force.momentum_out.tolist(), checked.force.tolist(),
                        force.mass_flow_hit, force.n_parcels))  # fmt: skip
    assert results[0] == results[1]


@needs_module
@given(n=st.integers(3, 200), seed=st.integers(0, 2**32 - 1), lattice=st.booleans())
def test_gridding_kernels_match_numba(n, seed, lattice):
    from hypothesis import assume

    from replication.errors import InputError

    try:
        surface, xy, depth, tri, u, v, far = _gridding_inputs(n, seed, lattice)
    except InputError:  # collinear: no triangulation
        assume(False)
    f = frozen
    shape = (u.size, v.size)
    _both("raster", f(xy), f(tri), f(depth), f(u), f(v), 0, tri.shape[0], np.full(shape, -1, np.int32),
          np.zeros(shape), outputs=(7, 8))  # fmt: skip
    points, m = f(surface.points), surface.n_vertices
    order = f(np.random.default_rng(seed).permutation(m).astype(np.int32))
    _both("number", order, 0, m, np.full(m, -1, np.int32), outputs=(3,))
    position = np.argsort(order).astype(np.int32)
    _both("gather", points, f(np.array([1, 0, 2])), position, 0, m, np.zeros((m, 2)), np.zeros(m),
          np.zeros(4), outputs=(5, 6, 7))  # fmt: skip
    _both("renumber", f(surface.triangles), position, 0, surface.n_triangles,
          np.zeros((surface.n_triangles, 3), np.int32), outputs=(4,))  # fmt: skip
    nbr, far = f(surface.neighbors), f(far)
    uv = f(surface.projected())
    start = f(np.zeros(len(far), np.int32))
    _both("exits", uv, f(surface.triangles), nbr, far, start, np.zeros(len(far), np.int32), outputs=(5,))
    left = np.empty(len(far), np.int32)
    _aot._jit("exits")(uv, f(surface.triangles), nbr, far, start, left)
    assert np.all(left >= 0)  # every walk left through the boundary: valid starts for the nearest walk
    queries = f(np.vstack([far, np.random.default_rng(seed).uniform(-2, 2, (20, 2)), uv[:3]]))
    k = len(queries)
    for exhaustive in (False, True):
        _both("locate", uv, f(surface.triangles), nbr, queries, exhaustive, np.zeros(k, np.int32),
              np.zeros(k, np.int32), outputs=(5, 6))  # fmt: skip
    found, spare = np.empty(k, np.int32), np.empty(k, np.int32)
    _aot._jit("locate")(uv, f(surface.triangles), nbr, queries, False, found, spare)
    depth_of = f(surface.points[:, 2].copy())
    _both("barycentric", uv, f(surface.triangles), found, queries, depth_of, np.zeros(k), outputs=(5,))
    _both("nearest", uv, f(surface.triangles), nbr, far, f(left), np.zeros(len(far), np.int32), outputs=(5,))


def test_small_clouds_call_the_compiled_kernels_with_their_own_types(monkeypatch):
    """The gridding, the interpolation and the jet model pass exactly the table's types: no
    small call falls back to numba."""
    from replication.surfaces import _grid, interpolate, random_cloud
    from replication.surfaces.nurbs import fit_nurbs

    used = []

    def checked(name):
        used.append(name)
        spec = _aot.KERNELS[name]
        checks = [_aot._parse(a) for a in spec.args]

        def call(*args):
            fits = [_aot._fits(a, c) for a, c in zip(args, checks)]
            assert len(args) == len(checks) and all(fits), f"{name}: argument types {fits}"
            return _aot._jit(name)(*args)

        return call

    from replication.casestudy import jet, mesh
    from replication.casestudy.shapes import pelton_bucket_surface

    for module in (_grid, interpolate, jet, mesh):
        monkeypatch.setattr(module, "kernel", checked)
    bucket = pelton_bucket_surface()
    jet.surface_force(bucket)
    jet.jet_force(bucket.points, bucket.triangles)  # the mesh checks too
    surface = fit_nurbs(random_cloud(300, rng=2), evaluator="fast")
    assert surface.n_filled > 0  # the nearest fill ran
    triangle, alone = np.array([[0, 1, 2]]), np.full((1, 3), -1)
    interpolate.nearest_vertices(np.eye(3)[:, :2], triangle, alone, [[5.0, 5.0]], [0])
    uv, values = np.eye(3)[:, :2], np.arange(3.0)
    interpolate.interpolate_linear(uv, triangle, values, [[0.2, 0.2], [5, 5]], nearest_outside=True)
    interpolate.interpolate_linear(uv, triangle, values, [[0.2, 0.2]], convex=False)
    assert set(used) == set(_aot.KERNELS) - {"single", "column_spreads"}


def test_a_module_built_from_other_sources_is_stale(monkeypatch):
    """stale() tells a measurer that commands run numba's kernels because the compiled module
    is refused (an edited checkout), and only then."""
    import importlib.util

    monkeypatch.delenv("REPLICATION_AOT", raising=False)
    monkeypatch.setattr(_aot, "compiled", lambda: None)
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: object() if name == _aot.MODULE else None)
    assert _aot.stale()
    monkeypatch.setenv("REPLICATION_AOT", "0")
    assert not _aot.stale()  # disabled on purpose
    monkeypatch.delenv("REPLICATION_AOT")
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    assert not _aot.stale()  # not built at all (no C compiler): nothing to rebuild
    monkeypatch.setattr(_aot, "compiled", lambda: object())
    assert not _aot.stale()


def test_every_kernel_of_the_table_releases_the_gil_in_numba():
    """The builder compiles every ahead-of-time kernel to release the GIL, as numba's nogil
    kernels do, and refuses a kernel of the table that is not nogil: this catches one early."""
    for name in _aot.KERNELS:
        assert _aot._jit(name).targetoptions.get("nogil"), name
        assert _aot.releases_gil(_aot._jit(name))


def test_releases_gil_reads_numba_s_option():
    import numba

    @numba.njit
    def holds(x):
        return x

    @numba.njit(nogil=True)
    def releases(x):
        return x

    assert not _aot.releases_gil(holds) and _aot.releases_gil(releases)
    assert not _aot.releases_gil(lambda: None)  # neither numba's nor a compiled kernel


@needs_module
def test_the_compiled_kernels_release_the_gil():
    """While the ahead-of-time tracer runs on one thread, another runs Python.

    The main thread notes the time every millisecond while a pool-free call of one piece of the
    jet (a fine jet: about 0.1 s) runs on a second thread. Were the GIL held, no note could fall
    inside the call (tried: none did with a module built holding it); released, dozens do.
    """
    import threading
    import time

    from replication.casestudy import jet, mesh
    from replication.casestudy.ga import GAConfig, points_from_genome, random_genome

    config = GAConfig()
    points = points_from_genome(random_genome(config, rng=np.random.default_rng(3)), config)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        surface = adt(points, depth="z")
    trace = _aot._checked("sheet_trace")
    assert _aot.releases_gil(trace)
    calls = []

    def recording(name):
        if name != "sheet_trace":
            return _aot._checked(name)

        def recorded(*args):
            calls.append(args)
            return trace(*args)

        return recorded

    with pytest.MonkeyPatch.context() as patch:
        for module in (jet, mesh):
            patch.setattr(module, "kernel", recording)
        jet.surface_force(surface, resolution=48)
    args = calls[0]
    span = []

    def piece():
        rows = np.zeros_like(args[-1])
        span.append(time.perf_counter())
        trace(*args[:-1], rows)
        span.append(time.perf_counter())

    notes = []
    worker = threading.Thread(target=piece)
    worker.start()
    while worker.is_alive():
        notes.append(time.perf_counter())
        time.sleep(0.001)
    worker.join()
    start, end = span
    quarter = (end - start) / 4
    inside = [t for t in notes if start + quarter < t < end - quarter]
    assert inside, f"no Python ran during a {end - start:.3f} s call of the compiled tracer"
