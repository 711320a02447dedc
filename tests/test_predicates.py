"""The adaptive exact predicates agree with rational arithmetic, degenerate cases included."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from geometry import incircle_q, orient_q
from replication.surfaces._predicates import _incircle_exact, _orient_exact, incircle, orient

# magnitudes whose products of four neither overflow nor underflow (the predicates' domain)
coordinates = st.one_of(
    st.integers(-6, 6).map(float),
    st.integers(-6, 6).map(lambda k: k * 0.1),
    st.integers(-6, 6).map(lambda k: k * 1e-3),
    st.floats(-1e3, 1e3, allow_nan=False).filter(lambda v: v == 0 or abs(v) > 1e-30),
)
points = st.tuples(coordinates, coordinates)


@given(points, points, points)
def test_orientation_is_exact(a, b, c):
    expected = orient_q(a, b, c)
    assert orient(*a, *b, *c) == expected
    assert _orient_exact(*a, *b, *c) == expected


@given(points, points, points, points)
def test_in_circle_is_exact(a, b, c, d):
    side = orient_q(a, b, c)
    if side == 0:
        return
    if side < 0:
        b, c = c, b
    expected = incircle_q(a, b, c, d)
    assert incircle(*a, *b, *c, *d) == expected
    assert _incircle_exact(*a, *b, *c, *d) == expected


def test_nearly_degenerate_cases_are_decided_exactly():
    rng = np.random.default_rng(3)
    for _ in range(2000):
        a, b, c = (tuple(p) for p in rng.integers(-3, 4, size=(3, 2)).astype(float) * 0.1)
        if orient_q(a, b, c) == 0 or 0.0 in a:  # (a nudge of 0 is subnormal: outside the domain)
            continue
        if orient_q(a, b, c) < 0:
            b, c = c, b
        # a vertex nudged by one unit in the last place: on the circle and the edges, within rounding
        d = tuple(np.nextafter(np.array(a), np.array(a) + rng.choice([-1.0, 1.0], 2)))
        assert incircle(*a, *b, *c, *d) == incircle_q(a, b, c, d)
        assert orient(*a, *b, *d) == orient_q(a, b, d)


def test_cocircular_square_and_collinear_triples():
    assert incircle(0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0) == 0.0
    assert incircle(0.0, 0.0, 0.1, 0.0, 0.1, 0.1, 0.0, 0.1) == incircle_q(
        (0.0, 0.0), (0.1, 0.0), (0.1, 0.1), (0.0, 0.1)
    )
    assert orient(0.1, 0.1, 0.3, 0.3, 0.7, 0.7) == 0.0
    assert orient(0.0, 0.0, 1.0, 0.0, 0.5, 1e-300) == 1.0
    assert orient(0.0, 0.0, 1.0, 0.0, 0.5, -1e-300) == -1.0
    eps = np.nextafter(0.5, 1.0)
    assert orient(0.5, 0.5, 12.0, 12.0, eps, 0.5) == -1.0


def test_the_perturbed_in_circle_test_is_the_exact_one_off_the_circle():
    from replication.surfaces._predicates import incircle_perturbed

    rng = np.random.default_rng(11)
    for a, b, c, d in rng.integers(-3, 4, size=(3000, 4, 2)).astype(float):
        if orient(*a, *b, *c) <= 0 or len({tuple(a), tuple(b), tuple(c), tuple(d)}) < 4:
            continue
        exact, perturbed = incircle(*a, *b, *c, *d), incircle_perturbed(*a, *b, *c, *d)
        assert perturbed in (-1.0, 1.0)
        assert perturbed == exact or exact == 0.0


def test_the_perturbation_cuts_a_square_along_its_anti_diagonal():
    """Known answer: (0, 1) is 'inside' the circle of (0, 0), (1, 0), (1, 1) (the last point in
    lexicographic order is (1, 1), and (0, 0), (1, 0), (0, 1) turn counter-clockwise), so the
    diagonal (0, 0)-(1, 1) flips to (1, 0)-(0, 1), which the other pair of triangles keeps."""
    from replication.surfaces._predicates import incircle_perturbed

    assert incircle(0, 0, 1, 0, 1, 1, 0, 1) == 0.0
    assert incircle_perturbed(0, 0, 1, 0, 1, 1, 0, 1) == 1.0
    assert incircle_perturbed(0, 0, 1, 0, 0, 1, 1, 1) == -1.0


def test_the_perturbation_is_one_answer_per_edge_on_every_co_circular_lattice_quadruple():
    """A consistent perturbation: an edge is illegal seen from either of its triangles, and the
    answer does not depend on which corner of the triangle comes first."""
    import itertools

    from replication.surfaces._predicates import incircle_perturbed

    lattice = [(float(x), float(y)) for x in range(4) for y in range(4)]
    checked = 0
    for p, q, r, s in itertools.permutations(lattice, 4):
        if orient(*p, *q, *r) <= 0 or orient(*q, *p, *s) <= 0 or incircle(*p, *q, *r, *s) != 0.0:
            continue
        checked += 1
        side = incircle_perturbed(*p, *q, *r, *s)
        assert incircle_perturbed(*q, *p, *s, *r) == side  # the same edge from the other side
        assert incircle_perturbed(*q, *r, *p, *s) == incircle_perturbed(*r, *p, *q, *s) == side
    assert checked > 500
