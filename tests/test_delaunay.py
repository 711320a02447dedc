"""Both triangulation backends give valid Delaunay triangulations of the same vertices."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial import Delaunay

from geometry import assert_valid_delaunay
from replication.errors import DegenerateInputError, InputError
from replication.surfaces import _sweephull, delaunay
from replication.surfaces.delaunay import delaunay_2d


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


lattice_points = arrays(np.int64, st.tuples(st.integers(3, 80), st.just(2)), elements=st.integers(0, 9))


@given(lattice_points, st.sampled_from([1.0, 0.1, 1e-3, 37.5]))
def test_property_lattice_clouds(points, scale):
    uv = _unique(points.astype(float) * scale)
    if uv.shape[0] < 3 or np.linalg.matrix_rank(uv - uv[0]) < 2:
        with pytest.raises(DegenerateInputError):
            delaunay_2d(uv)
        return
    triangles, used = delaunay_2d(uv)
    assert used == "sweephull"
    assert_valid_delaunay(uv, triangles)
    # the same vertices and the same covered area as Qhull
    ref, _ = delaunay_2d(uv, backend="scipy")
    assert len(ref) == len(triangles)


# six decimals: clouds whose points are at least 1e-9 of their extent apart; closer points are
# numerical duplicates (products underflow), which the library reports as an error
sane_floats = st.floats(-1e3, 1e3).map(lambda v: round(v, 6))


@given(arrays(np.float64, st.tuples(st.integers(3, 60), st.just(2)), elements=sane_floats))
def test_property_float_clouds(points):
    uv = _unique(points)
    if uv.shape[0] < 3 or np.linalg.matrix_rank(uv - uv[0], tol=1e-9 * np.abs(uv).max()) < 2:
        return  # (nearly) collinear clouds are covered by dedicated tests
    triangles, _ = delaunay_2d(uv)
    assert_valid_delaunay(uv, triangles)


@pytest.mark.parametrize("backend", ["sweephull", "scipy"])
def test_collinear_points_raise(backend):
    uv = np.column_stack([np.arange(5.0), 2 * np.arange(5.0) + 1])
    with pytest.raises(DegenerateInputError, match="collinear"):
        delaunay_2d(uv, backend=backend)


def test_too_few_points_raise():
    with pytest.raises(DegenerateInputError, match="at least 3 distinct"):
        delaunay_2d(np.array([[0.0, 0.0], [1.0, 1.0]]))


def test_unknown_backend():
    with pytest.raises(InputError, match="'qhull'"):
        delaunay_2d(np.eye(3)[:, :2], backend="qhull")


def test_sweep_failure_falls_back_to_qhull(monkeypatch):
    """If rounding ever defeats the sweep, Qhull triangulates and the result says so."""

    def failing(x, y):
        return np.empty((0, 3), dtype=np.int64), _sweephull.STATUS_SKIPPED, 1

    monkeypatch.setattr(delaunay._sweephull, "sweep_hull", failing)
    uv = np.random.default_rng(0).random((30, 2))
    triangles, used = delaunay_2d(uv)
    assert used == "scipy"
    assert_valid_delaunay(uv, triangles)


def test_unused_point_is_an_error_not_silent(monkeypatch):
    def drops_last_point(uv):
        return Delaunay(uv[:-1]).simplices.astype(np.int64)

    monkeypatch.setattr(delaunay, "_scipy", drops_last_point)
    uv = np.random.default_rng(1).random((10, 2))
    with pytest.raises(DegenerateInputError, match=r"points 9\)"):
        delaunay_2d(uv, backend="scipy")


def test_extreme_dynamic_range_is_exact_not_a_crash():
    """Found by hypothesis: products underflow; the exact predicate still triangulates it."""
    uv = np.array([[2.0, 1.0], [1.2e-238, 0.0], [1.0, 0.0], [0.0, 0.0]])
    triangles, used = delaunay_2d(uv)
    assert used == "sweephull"
    assert_valid_delaunay(uv, triangles)


def test_exact_orientation_predicate():
    # collinear to the last bit: the float formula may round either way, the exact one must not
    a, b = (0.1, 0.1), (0.3, 0.3)
    c = (0.7, 0.7)
    assert _sweephull.orient(*a, *b, *c) == 0.0
    assert _sweephull.orient(0.0, 0.0, 1.0, 0.0, 0.5, 1e-300) == 1.0
    assert _sweephull.orient(0.0, 0.0, 1.0, 0.0, 0.5, -1e-300) == -1.0
    eps = np.nextafter(0.5, 1.0)
    assert _sweephull.orient(0.5, 0.5, 12.0, 12.0, eps, 0.5) == -1.0
    assert _sweephull.orient(0.5, 0.5, 12.0, 12.0, 24.0, 24.0) == 0.0
