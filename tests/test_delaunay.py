"""Both triangulation backends give exactly valid Delaunay triangulations of the same vertices."""

import ast
import hashlib
import inspect
import textwrap
import warnings
from fractions import Fraction

import numba
import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial import Delaunay

from geometry import assert_valid_delaunay, orient_q
from replication.errors import DegenerateInputError, DuplicatePointsWarning, InputError
from replication.surfaces import _partition, _sweephull, _triangulate, delaunay
from replication.surfaces.delaunay import delaunay_2d, planar_delaunay
from replication.surfaces.duplicates import group_positions, groups_from_pairs
from replication.surfaces.interpolate import triangle_neighbors


def _unique(uv):
    return np.unique(uv, axis=0)


def _triangle_set(triangles):
    return {tuple(sorted(t)) for t in triangles.tolist()}


@pytest.mark.parametrize("backend", ["sweephull", "scipy"])
@pytest.mark.parametrize("n", [3, 4, 10, 200, 3000])
def test_random_points_valid(backend, n):
    uv = np.random.default_rng(n).random((n, 2))
    triangles, used = delaunay_2d(uv, backend=backend)
    assert used == backend
    assert_valid_delaunay(uv, triangles)


def test_general_position_matches_scipy_exactly():
    """In general position the Delaunay triangulation is unique: same triangles as Qhull."""
    uv = np.random.default_rng(7).normal(size=(500, 2))
    ours, _ = delaunay_2d(uv, backend="sweephull")
    ref = Delaunay(uv).simplices
    assert _triangle_set(ours) == _triangle_set(ref)


@pytest.mark.parametrize("shape", [(2, 2), (3, 7), (20, 15), (1, 5)])
def test_square_lattice(shape):
    """Co-circular and collinear points everywhere: either diagonal is Delaunay."""
    g = np.stack(np.meshgrid(np.arange(shape[0] + 1.0), np.arange(shape[1] + 1.0)), -1).reshape(-1, 2)
    for backend in ("sweephull", "scipy"):
        triangles, _ = delaunay_2d(g, backend=backend)
        assert_valid_delaunay(g, triangles)
        assert len(triangles) == 2 * shape[0] * shape[1]


def test_points_on_a_circle_and_its_centre():
    t = np.linspace(0, 2 * np.pi, 17)[:-1]
    uv = np.vstack([np.column_stack([np.cos(t), np.sin(t)]), [[0.0, 0.0]]])
    triangles, _ = delaunay_2d(uv)
    assert_valid_delaunay(uv, triangles)


def test_collinear_hull_points_and_clusters():
    rng = np.random.default_rng(3)
    edge = np.column_stack([np.linspace(0, 1, 30), np.zeros(30)])
    cluster = 0.5 + 1e-6 * rng.random((40, 2))
    uv = _unique(np.vstack([edge, cluster, [[0.5, 1.0]]]))
    triangles, _ = delaunay_2d(uv)
    assert_valid_delaunay(uv, triangles)


def test_lattice_point_rounded_inside_the_hull_is_not_a_degenerate_triangle():
    """Regression (issue 12 item 9, issue 15 item 5): (7,3), (3,3), (9,5), (4,0) x 1e-3.

    Rounded to float64, (7,3) x 1e-3 lies strictly inside the triangle of the other three
    (exact rational arithmetic on the float values), so the Delaunay triangulation has three
    triangles; the third has a floating-point area of about 1e-21, not zero. Qhull, which
    rounds, reports two triangles, leaving part of the exact hull uncovered.
    """
    uv = np.array([[7, 3], [3, 3], [9, 5], [4, 0]], dtype=float) * 1e-3
    p, a, b, c = (tuple(map(Fraction, q)) for q in uv.tolist())
    assert orient_q(a, b, c) < 0  # the hull (3,3), (9,5), (4,0) is clockwise in that order
    assert orient_q(a, b, p) < 0 and orient_q(b, c, p) < 0 and orient_q(c, a, p) < 0  # strictly inside
    triangles, used = delaunay_2d(uv)
    assert used == "sweephull" and len(triangles) == 3
    assert_valid_delaunay(uv, triangles, exact="fraction")


def _exactly_collinear(uv):
    """All points on one line, in exact rational arithmetic on their float values."""
    q = [tuple(map(Fraction, p)) for p in uv.tolist()]
    return all(orient_q(q[0], q[1], r) == 0 for r in q[2:])


lattice_points = arrays(np.int64, st.tuples(st.integers(3, 80), st.just(2)), elements=st.integers(0, 9))


@given(lattice_points, st.sampled_from([1.0, 0.1, 1e-3, 37.5]))
@example(np.array([[3, 9], [5, 5], [4, 7]]), 0.1)  # collinear, but not once rounded
@example(np.array([[5, 8], [1, 6], [3, 7], [5, 5]]), 0.1)  # Qhull's hull turns back by rounding
def test_property_lattice_clouds(points, scale):
    uv = _unique(points.astype(float) * scale)
    if uv.shape[0] < 3 or _exactly_collinear(uv):
        with pytest.raises(DegenerateInputError):
            delaunay_2d(uv)
        return
    # Collinear lattice points scaled by 0.1 or 1e-3 are rounded off their line: exactly they
    # span a sliver, which sweephull triangulates; Qhull, which rounds, may call them flat.
    nearly_collinear = np.linalg.matrix_rank(uv - uv[0]) < 2
    for backend in ("sweephull",) if nearly_collinear else ("sweephull", "scipy"):
        triangles, used = delaunay_2d(uv, backend=backend)
        assert used == backend
        assert np.array_equal(np.unique(triangles), np.arange(uv.shape[0]))  # same vertices: all
        if backend == "sweephull":
            assert_valid_delaunay(uv, triangles, exact="fraction")


def test_thousands_of_random_lattice_clouds():
    """3000 random lattice clouds (fixed seed), every one an exactly valid Delaunay triangulation."""
    rng = np.random.default_rng(20240915)
    checked = 0
    for _ in range(3000):
        n = int(rng.integers(3, 81))
        side = int(rng.choice([3, 5, 10, 40]))
        scale = float(rng.choice([1.0, 0.1, 1e-3, 37.5]))
        uv = _unique(rng.integers(0, side, size=(n, 2)).astype(float) * scale)
        if uv.shape[0] < 3 or np.linalg.matrix_rank(uv - uv[0]) < 2:
            continue
        triangles, used = delaunay_2d(uv)
        assert used == "sweephull"
        assert_valid_delaunay(uv, triangles, exact="compiled")
        checked += 1
    assert checked > 2500


# six decimals: clouds whose points are at least 1e-9 of their extent apart; closer points are
# numerical duplicates (products underflow), which the library reports as an error
sane_floats = st.floats(-1e3, 1e3).map(lambda v: round(v, 6))


@given(arrays(np.float64, st.tuples(st.integers(3, 60), st.just(2)), elements=sane_floats))
def test_property_float_clouds(points):
    uv = _unique(points)
    if uv.shape[0] < 3 or np.linalg.matrix_rank(uv - uv[0], tol=1e-9 * np.abs(uv).max()) < 2:
        return  # (nearly) collinear clouds are covered by dedicated tests
    triangles, _ = delaunay_2d(uv)
    assert_valid_delaunay(uv, triangles, exact="fraction")


@given(arrays(np.int64, st.tuples(st.integers(3, 120), st.just(2)), elements=st.integers(0, 6)))
def test_duplicates_from_the_sort_match_the_hash(points):
    """The sweep's duplicate pairs give exactly the groups of the hash table (first occurrence)."""
    uv = points.astype(float) * 0.1
    if np.unique(uv, axis=0).shape[0] < 3 or np.linalg.matrix_rank(uv - uv[0]) < 2:
        return
    result, used = planar_delaunay(uv)
    assert used == "sweephull"
    group, first = groups_from_pairs(uv.shape[0], result.duplicates, result.representatives)
    ref_group, ref_first = group_positions(uv[:, 0], uv[:, 1])
    assert np.array_equal(group, ref_group) and np.array_equal(first, ref_first)
    assert set(np.unique(result.triangles).tolist()) == set(ref_first.tolist())


@pytest.mark.parametrize("backend", ["sweephull", "scipy"])
def test_neighbors_and_hull_are_those_of_the_triangles(backend):
    uv = np.random.default_rng(5).random((300, 2))
    result, used = planar_delaunay(uv, backend=backend)
    assert used == backend
    assert np.array_equal(result.neighbors, triangle_neighbors(result.triangles))
    hull = delaunay.hull_from_neighbors(result.triangles, result.neighbors)
    start = int(np.flatnonzero(result.hull == hull[0])[0])
    assert np.array_equal(np.roll(result.hull, -start), hull)


def _two_block_clouds():
    rng = np.random.default_rng(11)
    random = rng.random((30_000, 2)) * [36.0, 30.0]
    g = np.stack(np.meshgrid(np.arange(180.0), np.arange(150.0)), -1).reshape(-1, 2)
    lattice = np.vstack([g, g[rng.integers(0, len(g), 3000)]])  # with duplicates
    rings = np.arange(1, 60) * 0.5
    angles = np.arange(500) * (2 * np.pi / 500)
    circles = np.concatenate([np.column_stack([r * np.cos(angles), r * np.sin(angles)]) for r in rings])
    cocircular = np.vstack([circles, [[0.0, 0.0]]])
    columns = np.column_stack([np.repeat(np.arange(3.0), 8000), np.tile(np.arange(8000.0), 3)])
    return {"random": random, "lattice": lattice, "co-circular": cocircular, "three columns": columns}


@pytest.fixture(scope="module")
def two_block_clouds():
    return _two_block_clouds()


@pytest.mark.parametrize("name", ["random", "lattice", "co-circular", "three columns"])
def test_two_blocks_are_exact_and_independent_of_the_thread_count(two_block_clouds, name):
    uv = two_block_clouds[name]
    assert uv.shape[0] >= _partition.PARALLEL_MIN
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        serial = _triangulate.triangulate(uv)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        parallel = _triangulate.triangulate(uv)
    finally:
        numba.set_num_threads(threads)
    assert serial.status == _sweephull.STATUS_OK
    for field in ("triangles", "neighbors", "hull", "duplicates", "representatives", "order"):
        assert np.array_equal(getattr(serial, field), getattr(parallel, field)), field
    distinct = np.unique(serial.triangles)
    # the storage order numbers every vertex once (with duplicates too: it once held their sort)
    assert np.array_equal(np.sort(serial.order), distinct)
    assert distinct.size == np.unique(uv, axis=0).shape[0]  # the same vertex set as scipy: all
    local = np.searchsorted(distinct, serial.triangles)
    assert_valid_delaunay(uv[distinct], local, exact="compiled")
    assert np.array_equal(serial.neighbors, triangle_neighbors(serial.triangles))
    assert (serial.blocks == 1) == (name == "three columns")  # a collinear block: one block
    if name == "random":  # general position: the unique Delaunay triangulation, as Qhull's
        assert _triangle_set(serial.triangles) == _triangle_set(Delaunay(uv).simplices)


@pytest.mark.parametrize("name", ["random", "lattice", "co-circular"])
def test_any_number_of_blocks_gives_the_same_triangles(two_block_clouds, name):
    """In general position by uniqueness; on a lattice, whose squares have two Delaunay
    diagonals each, because co-circular points are decided by a symbolic perturbation of the
    points alone (the merges at the cuts meet squares the single sweep reached another way)."""
    uv = two_block_clouds[name]
    one = _triangulate.triangulate(uv, blocks=1)
    for blocks in (2, 4, 8):
        many = _triangulate.triangulate(uv, blocks=blocks)
        assert (one.blocks, many.blocks) == (1, blocks)
        assert _triangle_set(one.triangles) == _triangle_set(many.triangles)


def _cut_by_position(uv, triangles):
    """The triangles as sets of vertex positions: comparable whatever the vertex numbering."""
    return {frozenset(map(tuple, uv[t].tolist())) for t in triangles}


@given(st.integers(4, 200), st.integers(0, 2**32 - 1), st.sampled_from([2.0**-30, 0.5, 8.0, 2.0**40]))
def test_lattice_surfaces_depend_on_the_point_set_only(n, seed, scale):
    """A lattice has many Delaunay triangulations; the ADT surface built depends on neither the
    row order (a cloud file's rows shuffled gave other diagonals, hence other depths and
    p-values: 35 of 40 random 200-point lattice clouds) nor a power-of-two scale (exact)."""
    from replication.surfaces import adt

    rng = np.random.default_rng(seed)
    cloud = rng.integers(0, 10, size=(n, 3)).astype(float)  # hypothesis' arrays repeat one value
    if _exactly_collinear(_unique(cloud[:, :2])) or _unique(cloud[:, :2]).shape[0] < 3:
        return
    order = rng.permutation(n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        surfaces = [adt(c, depth="z") for c in (cloud, cloud[order], cloud * scale)]
    cuts = [_cut_by_position(s.points, s.triangles) for s in surfaces]
    assert cuts[1] == cuts[0]
    assert _cut_by_position(surfaces[2].points / scale, surfaces[2].triangles) == cuts[0]


@pytest.mark.parametrize("fallback", [False, True])
def test_qhull_s_lattice_triangles_depend_on_the_point_set_only(monkeypatch, fallback):
    """Qhull decides co-circular points by the order it is given them: shuffling the rows of
    a lattice cloud changed its triangles (20 of 20 random 200-point clouds), by the scipy
    backend and by auto's fallback to it. It is now given them in lexicographic order."""
    if fallback:  # rounding defeats the sweep (as on very nearly collinear clouds): auto uses Qhull
        failed = _triangulate._failed(np.int32, _sweephull.STATUS_SKIPPED, 1)
        monkeypatch.setattr(delaunay, "triangulate", lambda points, axes: failed)
    rng = np.random.default_rng(5)
    for _ in range(5):
        uv = _unique(rng.integers(0, 12, size=(200, 2)).astype(float))
        order = rng.permutation(uv.shape[0])
        cuts = []
        for rows in (uv, uv[order]):
            triangles, used = delaunay_2d(rows, backend="auto" if fallback else "scipy")
            assert used == "scipy"
            cuts.append(_cut_by_position(rows, triangles))
        assert cuts[1] == cuts[0]


@pytest.mark.parametrize("rows", [[0, 1, 2, 3], [3, 2, 1, 0], [1, 3, 0, 2], [2, 0, 3, 1]])
def test_a_square_is_cut_along_the_same_diagonal_in_any_row_order(rows):
    """Known answer of the perturbation (tests/test_predicates.py): the diagonal (1, 0)-(0, 1)."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])[rows]
    triangles, _ = delaunay_2d(square)
    assert _cut_by_position(square, triangles) == {
        frozenset({(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)}),
        frozenset({(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)}),
    }


@pytest.mark.parametrize("backend", ["sweephull", "scipy"])
def test_collinear_points_raise(backend):
    uv = np.column_stack([np.arange(5.0), 2 * np.arange(5.0) + 1])
    with pytest.raises(DegenerateInputError, match="collinear"):
        delaunay_2d(uv, backend=backend)


def test_too_few_points_raise():
    with pytest.raises(DegenerateInputError, match="at least 3 distinct"):
        delaunay_2d(np.array([[0.0, 0.0], [1.0, 1.0]]))


def test_repeated_points_raise():
    with pytest.raises(DegenerateInputError, match=r"repeat another point \(points 3\)"):
        delaunay_2d(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]]))


def test_unknown_backend():
    with pytest.raises(InputError, match="'qhull'"):
        delaunay_2d(np.eye(3)[:, :2], backend="qhull")


def test_sweep_failure_falls_back_to_qhull(monkeypatch):
    """If rounding ever defeats the sweep, Qhull triangulates and the result says so."""

    def failing(points, axes):
        return _triangulate._failed(np.int32, _sweephull.STATUS_SKIPPED, 1)

    monkeypatch.setattr(delaunay, "triangulate", failing)
    uv = np.random.default_rng(0).random((30, 2))
    triangles, used = delaunay_2d(uv)
    assert used == "scipy"
    assert_valid_delaunay(uv, triangles)
    with pytest.raises(DegenerateInputError, match=r"sweep-hull .* the 'auto' backend falls back to Qhull"):
        delaunay_2d(uv, backend="sweephull")  # asked for by name: an error, not Qhull's result
    monkeypatch.setattr(
        delaunay, "_scipy", lambda uv: (_ for _ in ()).throw(DegenerateInputError("Qhull: no"))
    )
    with pytest.raises(
        DegenerateInputError, match=r"^rounding defeated the sweep-hull triangulator, then: Qhull: no"
    ):
        delaunay_2d(uv)


def test_a_failed_block_is_retried_as_one_block(monkeypatch):
    calls = []
    original = _triangulate._triangulate

    def first_fails(points, axes, levels):
        calls.append(levels)
        if levels:
            return _triangulate._failed(np.int32, _sweephull.STATUS_SKIPPED, 1 << levels)
        return original(points, axes, levels)

    monkeypatch.setattr(_triangulate, "_triangulate", first_fails)
    uv = np.random.default_rng(1).random((_partition.PARALLEL_MIN, 2))
    result = _triangulate.triangulate(uv)
    assert calls == [1, 0] and result.status == _sweephull.STATUS_OK and result.blocks == 1


def test_unused_point_is_an_error_not_silent(monkeypatch):
    def drops_last_point(uv):
        return Delaunay(uv[:-1]).simplices.astype(np.int64)

    monkeypatch.setattr(delaunay, "_scipy", drops_last_point)
    uv = np.random.default_rng(1).random((10, 2))
    last = np.lexsort((uv[:, 1], uv[:, 0]))[-1]  # Qhull is given the points in this order
    with pytest.raises(DegenerateInputError, match=rf"points {last}\)"):  # named by its input row
        delaunay_2d(uv, backend="scipy")


def test_extreme_dynamic_range_is_exact_not_a_crash():
    """Found by hypothesis: products underflow; the exact predicate still triangulates it."""
    uv = np.array([[2.0, 1.0], [1.2e-238, 0.0], [1.0, 0.0], [0.0, 0.0]])
    triangles, used = delaunay_2d(uv)
    assert used == "sweephull"
    assert_valid_delaunay(uv, triangles, exact="fraction")


def test_the_one_call_path_for_small_clouds_matches_the_general_one():
    rng = np.random.default_rng(4)
    for uv in (rng.random((500, 2)), np.vstack([np.indices((12, 9)).reshape(2, -1).T * 0.1] * 2)):
        small = _triangulate.triangulate(uv)
        general = _triangulate._triangulate(uv, (0, 1), 0)
        for field in ("triangles", "neighbors", "hull", "duplicates", "representatives", "status"):
            assert np.array_equal(getattr(small, field), getattr(general, field)), field


def _flip_code(function) -> str:
    """The statements between a kernel's ``# -- flip: start --`` and ``# -- flip: end --``, as an AST."""
    lines = inspect.getsource(function.py_func).splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == "# -- flip: start --")
    end = next(i for i, line in enumerate(lines) if line.strip() == "# -- flip: end --")
    body = textwrap.dedent("\n".join(lines[start + 1 : end]))
    return ast.dump(ast.parse("while True:\n" + textwrap.indent(body, "    ")))


def test_the_sweep_flips_exactly_as_legalize_does():
    """The sweep holds a copy of legalize's flip (a call would cost numba's reference counting
    per triangle): the two copies must stay the same statements, whatever the formatting."""
    sweep, legalize = _flip_code(_sweephull.sweep), _flip_code(_sweephull.legalize)
    assert "incircle" in legalize and "hull_tri" in legalize
    assert sweep == legalize


#: SHA-256 of the sweep-hull's exact output on the clouds of the test below, as computed by
#: every version since the reports' data were. Changed on purpose once, when co-circular
#: ties (the lattice clouds) came to be decided by a symbolic perturbation instead of by the
#: insertion order; the random clouds' triangles stayed the same (checked cloud by cloud).
_TRIANGULATION_DIGEST = "362a370a3d500fd9ca46dac52ce24f6ce2e63cab1589ebb2b9efbce9a290f29b"


def test_the_triangulator_s_output_is_the_one_the_reports_were_computed_with():
    """Triangles in their slots, neighbours, hull and duplicates, bit for bit, on random, lattice,
    grid and co-circular clouds and on two-block clouds with a merge. The kernels use only
    IEEE arithmetic and exact predicates, so the digest holds on any machine. A speed-up must
    leave it as it is; a deliberate change of the output changes the committed reports' data
    too and updates the digest with them."""
    rng = np.random.default_rng(20261122)
    grid = np.stack(np.meshgrid(np.arange(15.0), np.arange(15.0)), -1).reshape(-1, 2)
    angle = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    clouds = [
        rng.random((200, 3)),
        np.round(rng.random((500, 3)) * 10) / 10,  # a lattice with duplicates
        np.c_[grid, np.zeros(len(grid))],  # co-circular everywhere
        np.c_[np.cos(angle), np.sin(angle), angle],
        rng.random((60_000, 3)),  # two blocks and their merge
        np.round(rng.random((60_000, 3)) * 200) / 200,
    ]
    digest = hashlib.sha256()
    blocks = []
    for cloud in clouds:
        result = _triangulate.triangulate(np.ascontiguousarray(cloud), (0, 1))
        blocks.append(result.blocks)
        for a in (result.triangles, result.neighbors, result.hull, result.duplicates, result.representatives):
            digest.update(np.ascontiguousarray(a, dtype=np.int64).tobytes())
    assert blocks == [1, 1, 1, 1, 2, 2]
    assert digest.hexdigest() == _TRIANGULATION_DIGEST


@pytest.mark.parametrize("n", [300, 5000])
@pytest.mark.parametrize("exponent", [-1000, -530, -264, -129, 129, 260, 300, 900])
def test_clouds_beyond_the_predicates_range_are_scaled_exactly(n, exponent):
    """The exact predicates multiply four coordinates: at 2^260 they overflowed and at 2^-264
    underflowed, giving non-Delaunay triangles without an error. Scaling by a power of two is
    exact, so the triangulation must be the unit cloud's, bit for bit, on both paths (one
    compiled call, blocks), and Qhull's must be valid."""
    rng = np.random.default_rng(n)
    uv = rng.random((n, 2))
    uv[::7] *= 1e-3  # a spread of exponents, all still exact after the scaling
    reference, _ = planar_delaunay(uv)
    scaled = np.ldexp(uv, exponent)
    result, used = planar_delaunay(scaled)
    assert used == "sweephull"
    for field in ("triangles", "neighbors", "hull", "duplicates", "representatives", "order"):
        assert np.array_equal(getattr(result, field), getattr(reference, field)), field
    if n == 300:
        assert_valid_delaunay(scaled, result.triangles, exact="fraction")  # rationals: no range
        qhull, used = planar_delaunay(scaled, backend="scipy")
        assert used == "scipy"
        assert_valid_delaunay(scaled, qhull.triangles, exact="fraction")


def test_a_range_no_power_of_two_can_hold_is_an_error_not_wrong_triangles():
    uv = np.array([[1e300, 0.0], [0.0, 1e300], [1e300, 1e300], [1e-300, 5.0]])
    with pytest.raises(DegenerateInputError, match=r"too wide a range .* from 1e-300 to 1e\+300"):
        planar_delaunay(uv)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_qhull_is_delaunay_on_map_coordinates(seed):
    """Qhull is not exact and lost the digits of an offset: 100 m squares at UTM-like
    positions (1e6 m) gave 15-21 edges that are not locally Delaunay. Centred, they are all."""
    uv = np.random.default_rng(seed).random((3000, 2)) * 100 + [1e6, 7e5]
    result, used = planar_delaunay(uv, backend="scipy")
    assert used == "scipy"
    assert_valid_delaunay(uv, result.triangles, exact="compiled")
    sweep, _ = planar_delaunay(uv)
    assert _triangle_set(result.triangles) == _triangle_set(sweep.triangles)


@pytest.mark.parametrize("n", [3000, 12000])
def test_a_nearly_collinear_cloud_is_swept_from_a_round_seed(n):
    """Points on a line to within rounding, and one apex: the empty-circle seed of nearest
    neighbours was a sliver with its circumcentre 5e8 extents away, so the sort keys differed by
    less than their rounding and the sweep failed (then Qhull, 33 s at 20,000 points, failed
    too). The seed grown from an extreme point (the apex) is round, and the sweep exact."""
    t = np.random.default_rng(3).random(n)
    uv = np.vstack([np.column_stack([t, 0.1 * t + 0.3]), [[0.5, 0.9]]])
    i0, i1, i2, cx, cy = _sweephull.seed_triangle(uv)
    assert max(abs(cx - uv[i0, 0]), abs(cy - uv[i0, 1])) < 4.0  # not the sliver's 5e8
    result, used = planar_delaunay(uv, backend="sweephull")
    assert used == "sweephull"
    assert_valid_delaunay(uv, result.triangles, exact="compiled")


# ---- the exact check of Qhull's output ---------------------------------------------------------------


def _square_with_centre():
    uv = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [1.0, 0.9]])
    triangles = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return uv, triangles


def test_the_exact_check_accepts_delaunay_and_refuses_everything_else():
    from replication.surfaces._verify import is_delaunay

    def check(uv, triangles):
        neighbors = triangle_neighbors(triangles)
        return is_delaunay(uv, triangles, neighbors, delaunay.hull_from_neighbors(triangles, neighbors))

    uv, triangles = _square_with_centre()
    assert check(uv, triangles)
    assert not check(uv, triangles[:3])  # part of the hull uncovered (Euler's count)
    assert not check(uv, triangles[:, [0, 2, 1]])  # clockwise triangles
    # a quadrilateral (0, 0), (4, 0), (4, 1), (0, 1.2): with the diagonal 1-3, vertex 2 lies inside
    # the circle through 0, 1, 3 (centre (2, 0.6), radius 2.088; vertex 2 at 2.040 from it)
    quad = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.2]])
    assert not check(quad, np.array([[0, 1, 3], [1, 2, 3]]))
    assert check(quad, np.array([[0, 1, 2], [0, 2, 3]]))
    # co-circular: either diagonal of a square is Delaunay (the exact in-circle test gives 0)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]) * 0.1
    assert check(square, np.array([[0, 1, 2], [0, 2, 3]])) and check(square, np.array([[0, 1, 3], [1, 2, 3]]))


@pytest.mark.parametrize("seed", [12, 1, 19, 76])
def test_a_cloud_too_stretched_for_qhull_is_refused_not_wrongly_triangulated(seed):
    # Qhull returned triangles covering 0.99991 of the hull, with empty-circle violations
    from replication.surfaces import adt, random_cloud

    cloud = random_cloud(52, rng=seed) * np.array([10**12.57, 1, 1])
    try:
        surface = adt(cloud)
    except DegenerateInputError as exc:
        assert "not their Delaunay triangulation (checked with exact orientations" in str(exc)
    else:
        assert_valid_delaunay(surface.points[:, list(surface.projection_axes)], surface.triangles)


def test_qhull_is_accepted_when_it_is_delaunay_up_to_rounding():
    # a lattice scaled by 0.1: exactly, Qhull's edge 0-2 is not locally Delaunay (by 6e-17 of the
    # determinant's terms); the exact check refuses it, the fallback's tolerance accepts it
    from replication.surfaces._verify import is_delaunay

    uv = np.unique(np.array([[6, 7], [3, 7], [7, 0], [7, 7], [2, 0]], float) * 0.1, axis=0)
    triangles, used = delaunay_2d(uv, backend="scipy")
    neighbors = triangle_neighbors(triangles)
    hull = delaunay.hull_from_neighbors(triangles, neighbors)
    assert used == "scipy" and not is_delaunay(uv, triangles, neighbors, hull)
    assert is_delaunay(uv, triangles, neighbors, hull, tolerance=delaunay.QHULL_TOLERANCE)
