"""Point location, linear interpolation and nearest vertices on ADT triangulations."""

import numpy as np
import pytest
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import Delaunay, cKDTree

from geometry import orient_q
from replication.surfaces import adt, random_cloud
from replication.surfaces.interpolate import (
    interpolate_linear,
    locate,
    locate_valid,
    nearest_vertices,
    triangle_neighbors,
)


@pytest.fixture(scope="module")
def surface():
    return adt(random_cloud(400, rng=3))


def _queries(uv, rng, k=500):
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    span = hi - lo
    return np.vstack([rng.uniform(lo - 0.2 * span, hi + 0.2 * span, size=(k, 2)), uv[:50]])


def test_locate_agrees_with_brute_force(surface):
    uv = surface.projected()
    queries = _queries(uv, np.random.default_rng(1))
    found = locate(uv, surface.triangles, queries, surface.neighbors)
    assert np.array_equal(found, locate(uv, surface.triangles, queries))  # own vs sorted adjacency
    inside = Delaunay(uv).find_simplex(queries) >= 0
    assert np.array_equal(found >= 0, inside)
    for convex in (True, False):  # the unchecked walk the jet model takes: the same triangles
        unchecked = locate_valid(uv, surface.triangles, surface.neighbors, queries, convex=convex)
        assert np.array_equal(unchecked, found)
    for q, t in zip(queries[found >= 0], found[found >= 0]):
        a, b, c = uv[surface.triangles[t]].tolist()
        assert orient_q(a, b, q) >= 0 and orient_q(b, c, q) >= 0 and orient_q(c, a, q) >= 0


def test_linear_interpolation_matches_scipy(surface):
    uv = surface.projected()
    depth = surface.points[:, surface.depth_axis]
    queries = _queries(uv, np.random.default_rng(2))
    ours = interpolate_linear(uv, surface.triangles, depth, queries, neighbors=surface.neighbors)
    ref = LinearNDInterpolator(Delaunay(uv), depth)(queries)
    np.testing.assert_allclose(ours, ref, rtol=1e-12, atol=1e-12)
    assert np.array_equal(np.isnan(ours), np.isnan(ref))
    assert np.array_equal(ours[-50:], depth[:50])  # exactly the vertex values at the vertices


def test_nearest_vertex_outside_is_the_nearest_point(surface):
    uv = surface.projected()
    depth = surface.points[:, surface.depth_axis]
    queries = _queries(uv, np.random.default_rng(3))
    found, filled = interpolate_linear(
        uv, surface.triangles, depth, queries, neighbors=surface.neighbors, nearest_outside=True, located=True
    )
    outside = found < 0
    assert outside.sum() > 100
    _, nearest = cKDTree(uv).query(queries[outside])
    np.testing.assert_array_equal(filled[outside], depth[nearest])  # continuous cloud: no ties


def test_nearest_vertex_tie_takes_the_lexicographically_first_point():
    """Lattice points at equal distance: the first of them in (u, v) order wins, from any start
    and however the points are numbered. It was the smallest index, i.e. the first row of the
    cloud file: shuffling a lattice cloud's rows changed the NURBS grid outside the hull."""
    g = np.indices((6, 5)).reshape(2, -1).T.astype(float)
    queries = np.array([[-1.0, 2.5], [2.5, -3.0], [7.0, 1.5], [2.5, 6.0]])  # equidistant from two points
    expected = [[-0.0, 2.0], [2.0, 0.0], [5.0, 1.0], [2.0, 4.0]]
    for order in (np.arange(len(g)), np.arange(len(g))[::-1], np.random.default_rng(7).permutation(len(g))):
        surface = adt(np.column_stack([g[order], np.arange(len(g), dtype=float)]), depth="z")
        uv = surface.projected()
        for start in range(surface.n_triangles):
            near = nearest_vertices(uv, surface.triangles, surface.neighbors, queries, np.full(4, start))
            assert uv[near].tolist() == expected


def test_triangle_neighbors_of_any_mesh():
    tri = np.array([[0, 1, 2], [2, 1, 3], [3, 4, 2]])
    nbr = triangle_neighbors(tri)
    assert nbr.dtype == np.int32
    assert nbr.tolist() == [[-1, 1, -1], [0, -1, 2], [-1, -1, 1]]


@pytest.mark.filterwarnings("ignore::replication.errors.DuplicatePointsWarning")
@pytest.mark.parametrize("step", [None, 1.0])
def test_grid_depths_match_linear_interpolation_and_nearest_points(step):
    """The NURBS grid: linear interpolation inside the hull, the nearest point's depth outside
    (of equally near points, the first in (u, v) order)."""
    from replication.surfaces.nurbs import grid_depths

    for seed in range(12):
        surface = adt(random_cloud(60 + 37 * seed, step=step, rng=seed))
        shape = (7 + seed % 5, 9 + seed % 3)
        grid = grid_depths(surface, shape)
        uv = surface.projected()
        depth = surface.points[:, surface.depth_axis]
        nodes = np.stack(np.meshgrid(grid.u, grid.v, indexing="ij"), axis=-1).reshape(-1, 2)
        ref = interpolate_linear(uv, surface.triangles, depth, nodes)
        outside = np.isnan(ref)
        assert np.array_equal(grid.filled.ravel(), outside)
        np.testing.assert_allclose(grid.depth.ravel()[~outside], ref[~outside], rtol=1e-14, atol=1e-14)
        d = ((uv[None, :, :] - nodes[outside][:, None, :]) ** 2).sum(-1)
        first = []
        for row in d:
            tied = np.flatnonzero(row == row.min())
            first.append(tied[np.lexsort((uv[tied, 1], uv[tied, 0]))[0]])
        assert np.array_equal(grid.depth.ravel()[outside], depth[first])


def test_the_nearest_walks_refuse_start_triangles_they_cannot_read():
    """The compiled walks read ``start[i]`` without bounds checks: a bad index is an error, not memory."""
    import pytest

    from replication.surfaces.interpolate import fill_nearest

    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    triangle, alone = np.array([[0, 1, 2]]), np.full((1, 3), -1)
    for start in ([-1], [1], [0, 0]):
        with pytest.raises(ValueError, match="start"):
            nearest_vertices(uv, triangle, alone, [[5.0, 5.0]], start)
        with pytest.raises(ValueError, match="start"):
            fill_nearest(uv, triangle, alone, [[5.0, 5.0]], start)
    # (1, 0) and (0, 1) are equally near: the first in (u, v) order
    assert nearest_vertices(uv, triangle, alone, [[5.0, 5.0]], [0]).tolist() == [2]


def test_the_kernels_index_arrays_are_checked_not_read_out_of_bounds():
    """locate, interpolate_linear, fill_nearest and nearest_vertices hand their index arrays to
    compiled kernels without bounds checks: a vertex index past the points, a neighbour past the
    triangles or a short value array crashed the process or returned memory (1.9e-322)."""
    from replication.errors import InputError
    from replication.surfaces.interpolate import fill_nearest

    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    good, alone, q = np.array([[0, 1, 2]]), np.full((1, 3), -1), np.array([[0.2, 0.2]])
    far = np.array([[5.0, 5.0]])
    cases = [
        (lambda: interpolate_linear(uv, [[0, 1, 2_000_000]], np.zeros(3), q), r"in 0..2, got 0..2000000"),
        (lambda: interpolate_linear(uv, [[0, 1, -1]], np.zeros(3), q), r"must lie in 0..2, got -1..1"),
        (lambda: interpolate_linear(uv, good, np.zeros(1), q), r"per vertex \(3\), got shape \(1,\)"),
        (lambda: locate(uv, good, far, neighbors=[[7_000_000] * 3]), r"0..0 or be negative, got 7000000"),
        (lambda: locate(uv, good, far, neighbors=[[-1, -1]]), r"the triangles' shape \(1, 3\), got \(1, 2\)"),
        (lambda: locate(uv[:, :1], good, far), r"vertex positions must have shape \(n, 2\), got \(3, 1\)"),
        (lambda: nearest_vertices(uv, [[0, 1, 3]], alone, far, [0]), r"must lie in 0..2, got 0..3"),
        (lambda: fill_nearest(uv, good, [[5, -1, -1]], far, [0]), r"must lie in 0..0 or be negative, got 5"),
        # int64 past int32 wrapped into range in the cast (2**32 + 1 became 1) before the check
        (lambda: interpolate_linear(uv, np.array([[0, 1, 2**32 + 1]]), np.zeros(3), q), r"fit in int32, got"),
        (lambda: nearest_vertices(uv, good, alone, far, np.array([2**32])), r"int32, got values 4294967296"),
    ]  # fmt: skip
    for call, match in cases:
        with pytest.raises(InputError, match=match):
            call()
    assert interpolate_linear(uv, good, np.array([1.0, 2.0, 3.0]), q)[0] == pytest.approx(1.6)


@pytest.mark.filterwarnings("ignore::replication.errors.DuplicatePointsWarning")
@pytest.mark.parametrize("backend", ["sweephull", "scipy"])
@pytest.mark.parametrize("step", [None, 1.0])
def test_raster_in_pieces_matches_one_sequential_pass(monkeypatch, step, backend):
    """Large triangulations are rasterized in ``_RUNS`` pieces on threads into one grid; a
    node on an edge or a vertex goes to the lowest-index triangle containing it, as in one
    pass. Lattice clouds put grid nodes exactly on edges and vertices: grids of unit and
    half-unit steps over a unit lattice put many nodes on a vertex or an edge. Both backends'
    adjacencies decide the owner of such a node."""
    from replication.surfaces import _grid

    at_half_steps = on_vertices = 0
    for seed in range(4):
        surface = adt(random_cloud(400 + 91 * seed, step=step, rng=seed), backend=backend)
        xy, tri, nbr = surface.projected(), surface.triangles, surface.neighbors
        depth = surface.points[:, surface.depth_axis]
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        grids = [(np.linspace(lo[0], hi[0], 41 + seed), np.linspace(lo[1], hi[1], 37))]
        if step:
            span = np.rint(hi - lo).astype(int)
            grids += [tuple(np.linspace(lo[k], hi[k], f * span[k] + 1) for k in (0, 1)) for f in (1, 2)]
        for u, v in grids:
            owner, out = _grid.raster(xy, tri, nbr, depth, u, v)
            assert tri.shape[0] < _grid._PIECES_MIN  # the reference is the single pass
            monkeypatch.setattr(_grid, "_PIECES_MIN", 1)
            pieces_owner, pieces_out = _grid.raster(xy, tri, nbr, depth, u, v)
            monkeypatch.undo()
            assert np.array_equal(pieces_owner, owner)
            inside = owner >= 0
            assert inside.any() and (~inside).any()
            assert np.array_equal(pieces_out[inside], out[inside])
            nodes = np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)[inside]
            is_vertex = (nodes[:, None, :] == xy[None, :, :]).all(axis=2).any(axis=1)
            on_vertices += int(is_vertex.sum())
            # on an edge wherever the triangulation has one there (axis-parallel or diagonal)
            at_half_steps += int((np.all(np.mod(nodes - lo, 0.5) == 0, axis=1) & ~is_vertex).sum())
    if step:  # the lattice cases reached the paths they are here for
        assert on_vertices > 1000 and at_half_steps > 1000, (on_vertices, at_half_steps)
