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
