"""The NURBS baseline (section 3.1) and the fast evaluator."""

import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from replication.errors import DegenerateInputError, DuplicatePointsWarning, InputError
from replication.surfaces import adt, random_cloud
from replication.surfaces.bspline import evaluate, evaluate_grid, invert, parameter_grid
from replication.surfaces.nurbs import (
    NurbsPatch,
    clamped_uniform_knots,
    control_net_shape,
    fit_nurbs,
    grid_depths,
)

PAPER_ASPECT = 36 / 30  # the case-study box, wider along x


@pytest.mark.parametrize(
    ("n", "expected"),
    [(9, (3, 3)), (45, (9, 5)), (100, (10, 10)), (169, (13, 13)), (200, (20, 10))],
)
def test_net_for_table1_counts(n, expected):
    shape = control_net_shape(n, PAPER_ASPECT)
    assert (shape.m_u, shape.m_v) == expected and shape.rule == "exact" and shape.size == n


def test_net_follows_the_aspect_ratio():
    s = control_net_shape(45, 1 / PAPER_ASPECT)
    assert (s.m_u, s.m_v) == (5, 9)
    s = control_net_shape(200, 1 / 1.9)
    assert (s.m_u, s.m_v) == (10, 20)


@pytest.mark.parametrize(
    ("n", "aspect"),
    # extreme aspects: 100 points 1e8 times wider than deep once got a 101649 x 3 net (a 73 MB file)
    [(101, 1.2), (202, 1.0), (201, 1.0), (97, 3.0)]
    + [(100, 1e8), (100, 1e-8), (101, 1e12), (9, 1e300), (10, 1.7e308)],
)
def test_fallback_net_has_at_least_n_nodes(n, aspect):
    s = control_net_shape(n, aspect)
    assert s.rule == "fallback" and s.size >= n and min(s.m_u, s.m_v) >= 3
    assert s.size < n + max(s.m_u, s.m_v)  # no more than one extra row or column


def test_degree_three_needs_four_per_direction():
    s = control_net_shape(169, 1.0, degree=3)
    assert (s.m_u, s.m_v) == (13, 13)
    with pytest.raises(InputError, match=r"4 x 4 = 16 control points.*only 9"):
        control_net_shape(9, 1.0, degree=3)
    with pytest.raises(InputError, match="only 8 points"):
        control_net_shape(8, 1.0, degree=2)


@pytest.mark.parametrize("degree", [0, -1, 2.5, True])
def test_bad_degree(degree):
    with pytest.raises(InputError, match="degree"):
        control_net_shape(100, 1.0, degree=degree)


def test_clamped_uniform_knots():
    np.testing.assert_array_equal(clamped_uniform_knots(3, 2), [0, 0, 0, 1, 1, 1])
    np.testing.assert_allclose(clamped_uniform_knots(5, 2), [0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1])
    np.testing.assert_allclose(clamped_uniform_knots(6, 3), [0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1])
    for m, p in ((9, 2), (10, 2), (13, 3), (20, 1)):
        k = clamped_uniform_knots(m, p)
        assert k.size == m + p + 1 and np.all(np.diff(k) >= 0)
        np.testing.assert_allclose(np.diff(k[p : m + 1]), 1 / (m - p))  # uniform interior
    with pytest.raises(InputError, match="cannot carry"):
        clamped_uniform_knots(2, 2)


@pytest.mark.parametrize("n", [9, 45, 100, 169, 200])
def test_fit_matches_documented_rules(n):
    cloud = random_cloud(n, step=1.0, rng=n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        s = fit_nurbs(cloud)
    p = s.patch
    m_u, m_v = p.net_shape
    assert (m_u, m_v) == (s.net.m_u, s.net.m_v)
    assert p.degree_u == p.degree_v == 2
    np.testing.assert_array_equal(p.knots_u, clamped_uniform_knots(m_u, 2))
    np.testing.assert_array_equal(p.knots_v, clamped_uniform_knots(m_v, 2))
    np.testing.assert_array_equal(p.weights, 1.0)
    assert not p.rational
    # control points: a uniform grid over the bounding box of the projected cloud
    np.testing.assert_allclose(
        p.control_points[:, 0, 0], np.linspace(cloud[:, 0].min(), cloud[:, 0].max(), m_u)
    )
    np.testing.assert_allclose(
        p.control_points[0, :, 1], np.linspace(cloud[:, 1].min(), cloud[:, 1].max(), m_v)
    )
    assert s.tessellation.shape == (50, 50, 3) and s.evaluator == "geomdl"
    assert 0 <= s.n_filled < m_u * m_v


def test_planar_cloud_gives_planar_nurbs():
    rng = np.random.default_rng(1)
    xy = np.vstack([[[0, 0], [10, 0], [0, 8], [10, 8]], rng.random((40, 2)) * [10, 8]])
    cloud = np.column_stack([xy, 0.3 * xy[:, 0] - 0.2 * xy[:, 1] + 1.0])
    s = fit_nurbs(cloud, depth="z")
    assert s.n_filled == 0
    pts = evaluate(s.patch, np.random.default_rng(2).random((500, 2)))
    np.testing.assert_allclose(pts[:, 2], 0.3 * pts[:, 0] - 0.2 * pts[:, 1] + 1.0, atol=1e-12)


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_bilinear_height_field_is_reproduced_exactly(degree):
    """Control points on z = f(x, y) bilinear: the NURBS is f exactly (partition of unity)."""
    x, y = np.meshgrid(np.linspace(0, 12, 6), np.linspace(-3, 5, 5), indexing="ij")
    z = (1.5 + 0.4 * x) * (2.0 - 0.3 * y)
    cloud = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    s = fit_nurbs(cloud, degree=degree, net=(6, 5), depth="z")
    assert s.n_filled == 0
    pts = evaluate(s.patch, np.random.default_rng(3).random((400, 2)))
    np.testing.assert_allclose(pts[:, 2], (1.5 + 0.4 * pts[:, 0]) * (2.0 - 0.3 * pts[:, 1]), atol=1e-12)


def _random_patch(rng, m_u, m_v, p, rational):
    pts = rng.normal(size=(m_u, m_v, 3))
    w = rng.random((m_u, m_v)) + 0.5 if rational else np.ones((m_u, m_v))
    return NurbsPatch(p, p, clamped_uniform_knots(m_u, p), clamped_uniform_knots(m_v, p), pts, w)


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize(("m_u", "m_v", "p"), [(3, 3, 2), (20, 20, 2), (9, 5, 3), (4, 7, 1)])
def test_fast_evaluator_agrees_with_geomdl(rational, m_u, m_v, p):
    patch = _random_patch(np.random.default_rng(m_u * m_v + p), m_u, m_v, p, rational)
    geo = patch.to_geomdl()
    geo.sample_size_u, geo.sample_size_v = 17, 13
    reference = np.asarray(geo.evalpts).reshape(17, 13, 3)
    np.testing.assert_allclose(evaluate_grid(patch, (17, 13)), reference, rtol=0, atol=1e-12)


def test_fast_and_geomdl_tessellations_agree():
    cloud = random_cloud(100, rng=4)
    a = fit_nurbs(cloud, evaluator="geomdl").tessellation
    b = fit_nurbs(cloud, evaluator="fast").tessellation
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


@pytest.mark.parametrize("rational", [False, True])
def test_inversion_recovers_known_parameters(rational):
    rng = np.random.default_rng(5)
    patch = _random_patch(rng, 8, 6, 2, rational)
    # make the net a height field over (x, y): monotone x along u, y along v
    pts = np.array(patch.control_points)
    pts[..., 0] = np.linspace(0, 10, 8)[:, None] + 0.3 * rng.random((8, 6))
    pts[..., 1] = np.linspace(0, 6, 6)[None, :] + 0.2 * rng.random((8, 6))
    patch = NurbsPatch(2, 2, patch.knots_u, patch.knots_v, pts, patch.weights)
    params = np.vstack([rng.random((200, 2)), [[0, 0], [1, 1], [0, 0.5], [1e-7, 1 - 1e-7]]])
    targets = evaluate(patch, params)[:, :2]
    inv = invert(patch, targets, (0, 1))
    assert inv.converged.all() and inv.residual.max() <= 1e-9
    np.testing.assert_allclose(inv.params, params, atol=1e-7)
    np.testing.assert_allclose(inv.points[:, :2], targets, atol=1e-9)


def test_inversion_reports_targets_outside_the_footprint():
    s = fit_nurbs(random_cloud(100, rng=6), tessellation=None)
    targets = np.array([[-5.0, 10.0], [18.0, 45.0], [18.0, 15.0]])
    inv = invert(s.patch, targets, s.projection_axes)
    np.testing.assert_array_equal(inv.converged, [False, False, True])


def test_parameter_grid_order_matches_geomdl():
    g = parameter_grid((3, 2))
    np.testing.assert_array_equal(g, [[0, 0], [0, 1], [0.5, 0], [0.5, 1], [1, 0], [1, 1]])


def test_grid_fill_counts_nodes_outside_the_hull():
    cloud = np.array([[5, 5, 1.0], [6, 5, 2.0], [5, 6, 3.0], [0, 0, 0.0], [10, 10, 0.0]])
    from replication.surfaces import adt

    g = grid_depths(adt(cloud, depth="z"), (3, 3))
    # the hull is a thin quadrilateral along the diagonal: the four off-diagonal corners and
    # edge midpoints are outside
    assert g.n_filled == int(g.filled.sum()) and 0 < g.n_filled < 9
    assert g.depth[0, 0] == 0.0 and g.depth[2, 2] == 0.0


def test_bad_inputs():
    with pytest.raises(InputError, match="NaN"):
        fit_nurbs([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]] * 4)
    with pytest.raises(DegenerateInputError, match="collinear"):
        fit_nurbs(np.column_stack([np.arange(12.0), np.arange(12.0), np.zeros(12)]), depth="z")
    with pytest.raises(InputError, match="only 5 points"):
        fit_nurbs(random_cloud(5, rng=0))
    with pytest.raises(InputError, match="cannot carry degree 3"):
        fit_nurbs(random_cloud(50, rng=0), degree=3, net=(3, 10))
    with pytest.raises(InputError, match="tessellation"):
        fit_nurbs(random_cloud(50, rng=0), tessellation=(1, 5))
    with pytest.raises(InputError, match="evaluator"):
        fit_nurbs(random_cloud(50, rng=0), evaluator="matlab")


def test_patch_validation():
    k = clamped_uniform_knots(3, 2)
    pts = np.zeros((3, 3, 3))
    with pytest.raises(InputError, match="weights"):
        NurbsPatch(2, 2, k, k, pts, -np.ones((3, 3)))
    with pytest.raises(InputError, match="knot vector u"):
        NurbsPatch(2, 2, k[::-1], k, pts, np.ones((3, 3)))
    with pytest.raises(InputError, match="shape"):
        NurbsPatch(2, 2, k, k, np.zeros((3, 3, 2)), np.ones((3, 3)))


def test_fit_is_deterministic():
    cloud = random_cloud(100, rng=7)
    a, b = fit_nurbs(cloud), fit_nurbs(cloud)
    np.testing.assert_array_equal(a.patch.control_points, b.patch.control_points)
    np.testing.assert_array_equal(a.tessellation, b.tessellation)


def test_non_finite_weights_and_knots_are_refused():
    k = clamped_uniform_knots(3, 2)
    pts = np.zeros((3, 3, 3))
    with pytest.raises(InputError, match="weights"):
        NurbsPatch(2, 2, k, k, pts, np.full((3, 3), np.nan))
    with pytest.raises(InputError, match="knot vector v must be finite"):
        NurbsPatch(2, 2, k, np.r_[k[:-1], np.nan], pts, np.ones((3, 3)))


def test_triangulation_must_belong_to_the_cloud():
    from replication.surfaces import adt

    a, b = random_cloud(50, rng=1), random_cloud(60, rng=2)
    with pytest.raises(InputError, match="triangulation is of 50 points, the cloud has 60"):
        fit_nurbs(b, triangulation=adt(a))
    # was: another cloud of as many points gave the triangulation's cloud's NURBS, silently
    c = random_cloud(50, rng=3)
    with pytest.raises(InputError, match=r"not built from these points: point 0 has x = .*, its vertex 0 "):
        fit_nurbs(c, triangulation=adt(a))
    # the same lattice at other depths (Table 1's clouds share their lattice)
    lattice = _lattice(np.random.default_rng(4))
    other = lattice.copy()
    other[7, 2] += 0.5
    with pytest.raises(InputError, match=r"point 7 has z = "):
        fit_nurbs(other, triangulation=adt(lattice, depth="z"))
    with pytest.raises(
        InputError, match=r"triangulation must be the cloud's Surface from adt\(\), got ndarray"
    ):
        fit_nurbs(a, triangulation=a)


def _lattice(rng):
    """42 distinct lattice positions (7 x 6) at random depths."""
    u, v = np.meshgrid(np.arange(7.0), np.arange(6.0), indexing="ij")
    return np.column_stack([u.ravel(), v.ravel(), rng.random(42) * 3])


def test_a_triangulation_with_merged_points_fits_its_own_cloud():
    """Merged points keep the policy's depth: only the projection and unmerged depths are compared."""
    from replication.surfaces import adt

    cloud = _lattice(np.random.default_rng(5))
    cloud = np.vstack([cloud, cloud[:6] + [0, 0, 1.0]])  # six positions twice, at other depths
    with pytest.warns(UserWarning, match="merged 6 point"):
        surface = adt(cloud, depth="z", duplicates="mean")
    assert surface.n_merged == 6 and len(cloud) == 48
    ours = fit_nurbs(cloud, triangulation=surface, tessellation=None)
    with pytest.warns(UserWarning, match="merged 6 point"):
        again = fit_nurbs(cloud, depth="z", tessellation=None)
    np.testing.assert_array_equal(ours.patch.control_points, again.patch.control_points)
    moved = cloud.copy()
    moved[-1, 0] += 1e-9  # a merged point elsewhere in the plane
    with pytest.raises(InputError, match=r"point 47 has x = "):
        fit_nurbs(moved, triangulation=surface)
    moved = cloud.copy()
    moved[20, 2] += 1  # an unmerged point at another depth
    with pytest.raises(InputError, match=r"point 20 has z = "):
        fit_nurbs(moved, triangulation=surface)


def test_a_patch_copies_arrays_the_caller_can_change_and_keeps_its_own_read_only_ones():
    from replication.surfaces.patch import NurbsPatch

    rng = np.random.default_rng(3)
    writable = rng.random((5, 4, 3))
    patch = _random_patch(rng, 5, 4, 2, False)
    mine = NurbsPatch(2, 2, patch.knots_u, patch.knots_v, writable, np.ones((5, 4)))
    writable[0, 0, 0] = 99.0  # the caller's array changes; the patch does not
    assert mine.control_points[0, 0, 0] != 99.0 and not mine.control_points.flags.writeable
    frozen = writable.copy()
    frozen.flags.writeable = False
    kept = NurbsPatch(2, 2, patch.knots_u, patch.knots_v, frozen, np.ones((5, 4)))
    assert kept.control_points is frozen  # read-only and its own data: nobody else can change it
    view = frozen[:, :2]  # read-only but a view: copied
    copied = NurbsPatch(2, 2, patch.knots_u, patch.knots_v[:-2], view, np.ones((5, 2)))
    assert copied.control_points is not view


def test_the_spline_of_unit_weights_is_that_of_the_points():
    """Weights 1 evaluate the points' own spline; a rational patch with weights near 1 agrees."""
    from replication.surfaces.patch import NurbsPatch

    rng = np.random.default_rng(4)
    plain = _random_patch(rng, 6, 5, 2, False)
    assert plain.spline.c.shape == (6, 5, 3)
    nearly = NurbsPatch(2, 2, plain.knots_u, plain.knots_v, plain.control_points, np.full((6, 5), 1 + 1e-15))
    assert nearly.rational and nearly.spline.c.shape == (6, 5, 4)
    params = rng.random((50, 2))
    np.testing.assert_allclose(evaluate(plain, params), evaluate(nearly, params), rtol=0, atol=1e-12)
    for nu in ((1, 0), (0, 1)):
        np.testing.assert_allclose(evaluate(plain, params, nu), evaluate(nearly, params, nu), atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(3, 300),
    lattice=st.booleans(),
    backend=st.sampled_from(["sweephull", "scipy"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_the_hull_s_extremes_are_the_cloud_s(n, lattice, backend, seed):
    """fit_nurbs takes the projected extent from the hull vertices: the same numbers as over every
    vertex, also on lattices (collinear hull points, duplicates)."""
    from replication.surfaces import adt

    rng = np.random.default_rng(seed)
    points = rng.integers(0, 6, (n, 3)).astype(float) if lattice else rng.random((n, 3))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DuplicatePointsWarning)
            surface = adt(points, backend=backend)
    except DegenerateInputError:
        return
    for a in surface.projection_axes:
        column, boundary = surface.points[:, a], surface.points[surface.hull, a]
        assert (boundary.min(), boundary.max()) == (column.min(), column.max())


def test_a_large_cloud_with_duplicates_grids_as_with_qhull():
    """Regression: with two or more duplicates in a cloud above the one-call size, the sweep's
    vertex storage order was overwritten by the duplicates' sort, and the gridding read out of
    bounds (a crash). The order numbers every vertex once; the grid is Qhull's."""
    import dataclasses

    from replication.surfaces import _triangulate, adt

    rng = np.random.default_rng(3)
    points = rng.random((_triangulate.SMALL + 3000, 3))
    points = np.vstack([points, points[:10]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        surface = adt(points)
        ours = fit_nurbs(points, evaluator="fast", tessellation=None, triangulation=surface)
        qhull = fit_nurbs(points, evaluator="fast", tessellation=None, backend="scipy")
    assert surface.backend == "sweephull" and surface.n_vertices == points.shape[0] - 10
    assert np.array_equal(np.sort(surface.vertex_order), np.arange(surface.n_vertices))
    np.testing.assert_array_equal(ours.grid.filled, qhull.grid.filled)
    np.testing.assert_allclose(ours.grid.depth, qhull.grid.depth, rtol=0, atol=1e-12)
    with pytest.raises(InputError, match=r"one entry per vertex \(5048\), got shape \(10,\)"):
        dataclasses.replace(surface, vertex_order=surface.vertex_order[:10])


@pytest.mark.parametrize("n", [5000, 60_000])  # one piece; pieces on threads (over 100 000 triangles)
@pytest.mark.parametrize("how", ["repeats", "out of range", "not integers"])
def test_a_vertex_order_that_is_no_permutation_is_an_error_not_a_crash(how, n):
    """The gridding indexes with Surface.vertex_order unchecked; one of the right shape that
    repeats a vertex, names one past the end, or holds a NaN (which passed both range tests
    and became -2**31 in the cast) crashed fit_nurbs (segmentation fault)."""
    import dataclasses

    from replication.surfaces import adt

    points = np.random.default_rng(3).random((n, 3))
    surface = adt(points)
    order = np.array(surface.vertex_order)
    if how == "repeats":
        order[1] = order[0]
        match = rf"permutation of 0..{n - 1}: it repeats a vertex"
    elif how == "out of range":
        order[0] = 10**9
        match = rf"permutation of 0..{n - 1}, got values 0..1000000000"
    else:
        order = order.astype(float)
        order[0] = np.nan
        match = rf"permutation of 0..{n - 1}, got dtype float64"
    bad = dataclasses.replace(surface, vertex_order=order)
    with pytest.raises(InputError, match=match):
        fit_nurbs(points, evaluator="fast", tessellation=None, triangulation=bad)


@pytest.mark.filterwarnings("ignore::replication.errors.DuplicatePointsWarning")
@pytest.mark.parametrize("pieces", [False, True])
@pytest.mark.parametrize("step", [None, 0.5])
def test_relabel_puts_each_vertex_where_the_order_says(monkeypatch, pieces, step):
    """Known answer: point ``order[k]`` becomes vertex k (its (u, v) and depth), each triangle
    names the new numbers, and the bounds are the points' own; on one thread and in pieces
    (the gather writes each point where the order puts it, reading the points in storage
    order), with duplicates merged on a lattice too."""
    from replication.surfaces import _grid, adt, random_cloud

    surface = adt(random_cloud(3000, step=step, rng=7))
    if pieces:
        monkeypatch.setattr(_grid, "_PIECES_MIN", 1)
    order = surface.vertex_order
    axes = np.array([*surface.projection_axes, surface.depth_axis])
    xy, depth, tri, bounds = _grid.relabel(surface.points, axes, surface.triangles, order)
    np.testing.assert_array_equal(xy, surface.points[order][:, axes[:2]])
    np.testing.assert_array_equal(depth, surface.points[order, axes[2]])
    np.testing.assert_array_equal(order[tri], surface.triangles)
    uv = surface.projected()
    assert bounds == (uv[:, 0].min(), uv[:, 0].max(), uv[:, 1].min(), uv[:, 1].max())


def test_a_cloud_too_small_for_the_gridding_is_an_input_error():
    # was: ZeroDivisionError in the raster kernel at 2**-540 ("unexpected ZeroDivisionError" in the CLI)
    from replication.surfaces import random_cloud
    from replication.surfaces.nurbs import MIN_EXTENT

    cloud = random_cloud(30, rng=4)
    assert (
        fit_nurbs(np.ldexp(cloud, -500), evaluator="fast").patch.net_shape
        == fit_nurbs(cloud, evaluator="fast").patch.net_shape
    )
    for k in (-540, -1000):
        with pytest.raises(InputError, match=f"is below {MIN_EXTENT:.3g}"):
            fit_nurbs(np.ldexp(cloud, k))


def test_a_cloud_too_large_for_the_gridding_is_an_input_error():
    # was: "unexpected ValueError: fill_nearest: a query lies inside the triangulation" from 2**510
    # (extent about 2**517), in nurbs and compare alike
    from replication.compare import compare
    from replication.surfaces import random_cloud
    from replication.surfaces.nurbs import MAX_EXTENT

    cloud = random_cloud(30, rng=4)
    assert np.max(np.abs(cloud)) < 2.0**7
    scaled = np.ldexp(cloud, 493)  # every extent below 2**500
    assert (
        fit_nurbs(scaled, evaluator="fast").patch.net_shape
        == fit_nurbs(cloud, evaluator="fast").patch.net_shape
    )
    for k in (510, 1000):
        with pytest.raises(InputError, match=re.escape(f"is above {MAX_EXTENT:.3g}")):
            fit_nurbs(np.ldexp(cloud, k))
        with pytest.raises(InputError, match=re.escape(f"is above {MAX_EXTENT:.3g}")):
            compare(np.ldexp(cloud, k))


@pytest.mark.parametrize(
    ("name", "value"), [("triangles", 10**6), ("neighbors", 10**6), ("neighbors", -2), ("hull", -1)]
)
def test_a_hand_altered_triangulation_is_refused_not_a_crash(name, value):
    # a Surface changed with dataclasses.replace crashed fit_nurbs (a segmentation fault)
    import dataclasses

    cloud = random_cloud(50, rng=1)
    surface = adt(cloud)
    bad = np.array(getattr(surface, name))
    bad.flat[0] = value
    with pytest.raises(InputError, match=f"triangulation.{name} does not fit"):
        fit_nurbs(cloud, triangulation=dataclasses.replace(surface, **{name: bad}), evaluator="fast")
