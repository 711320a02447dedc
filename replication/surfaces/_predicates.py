"""Exact geometric predicates for float64 coordinates (numba).

The orientation and in-circle tests of a Delaunay triangulation decide every topological
choice, so rounding must never flip their sign. Both are computed adaptively, after
J. R. Shewchuk, "Adaptive precision floating-point arithmetic and fast robust geometric
predicates" (1997): a floating-point evaluation with a rigorous error bound answers almost
every call; when the bound does not settle the sign, the determinant is evaluated exactly as a
sum of non-overlapping floating-point expansions. The answers are exact for any finite
inputs whose products neither overflow nor underflow.

Written for this project from the published algorithms (error bounds ``ccwerrboundA`` and
``iccerrboundA``; the exact in-circle determinant is Shewchuk's ``incircleexact``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache

__all__ = ["incircle", "incircle_perturbed", "orient"]

_EPS = 2.0**-53
_SPLITTER = 134217729.0  # 2**27 + 1, Dekker's splitter for float64
_CCW_ERRBOUND = (3.0 + 16.0 * _EPS) * _EPS
_ICC_ERRBOUND = (10.0 + 96.0 * _EPS) * _EPS


@njit(cache=True)
def _two_sum(a, b):
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@njit(cache=True)
def _fast_two_sum(a, b):  # requires |a| >= |b|
    x = a + b
    return x, b - (x - a)


@njit(cache=True)
def _two_product(a, b):
    x = a * b
    c = _SPLITTER * a
    ahi = c - (c - a)
    alo = a - ahi
    c = _SPLITTER * b
    bhi = c - (c - b)
    blo = b - bhi
    err = x - ahi * bhi
    err -= alo * bhi
    err -= ahi * blo
    return x, alo * blo - err


@njit(cache=True)
def _two_two_diff(a1, a0, b1, b0, out):
    """``out[0:4] = (a1 + a0) - (b1 + b0)`` exactly, least significant component first."""
    i, x0 = _two_sum(a0, -b0)
    j, _0 = _two_sum(a1, i)
    _0, x1 = _two_sum(_0, -b1)
    x3, x2 = _two_sum(j, _0)
    out[0] = x0
    out[1] = x1
    out[2] = x2
    out[3] = x3


@njit(cache=True)
def _sum(elen, e, flen, f, h):
    """h = e + f for non-overlapping expansions (fast_expansion_sum_zeroelim); return its length."""
    eindex = 0
    findex = 0
    hindex = 0
    enow = e[0]
    fnow = f[0]
    if (fnow > enow) == (fnow > -enow):
        q = enow
        eindex += 1
    else:
        q = fnow
        findex += 1
    if eindex < elen and findex < flen:
        enow = e[eindex]
        fnow = f[findex]
        if (fnow > enow) == (fnow > -enow):
            q, hh = _fast_two_sum(enow, q)
            eindex += 1
        else:
            q, hh = _fast_two_sum(fnow, q)
            findex += 1
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
        while eindex < elen and findex < flen:
            enow = e[eindex]
            fnow = f[findex]
            if (fnow > enow) == (fnow > -enow):
                q, hh = _two_sum(q, enow)
                eindex += 1
            else:
                q, hh = _two_sum(q, fnow)
                findex += 1
            if hh != 0.0:
                h[hindex] = hh
                hindex += 1
    while eindex < elen:
        q, hh = _two_sum(q, e[eindex])
        eindex += 1
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
    while findex < flen:
        q, hh = _two_sum(q, f[findex])
        findex += 1
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
    if q != 0.0 or hindex == 0:
        h[hindex] = q
        hindex += 1
    return hindex


@njit(cache=True)
def _scale(elen, e, b, h):
    """h = b * e for a non-overlapping expansion e (scale_expansion_zeroelim); return its length."""
    c = _SPLITTER * b
    bhi = c - (c - b)
    blo = b - bhi
    hindex = 0
    q, hh = _two_product_presplit(e[0], b, bhi, blo)
    if hh != 0.0:
        h[hindex] = hh
        hindex += 1
    for i in range(1, elen):
        p1, p0 = _two_product_presplit(e[i], b, bhi, blo)
        s, hh = _two_sum(q, p0)
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
        q, hh = _fast_two_sum(p1, s)
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
    if q != 0.0 or hindex == 0:
        h[hindex] = q
        hindex += 1
    return hindex


@njit(cache=True)
def _two_product_presplit(a, b, bhi, blo):
    x = a * b
    c = _SPLITTER * a
    ahi = c - (c - a)
    alo = a - ahi
    err = x - ahi * bhi
    err -= alo * bhi
    err -= ahi * blo
    return x, alo * blo - err


@njit(cache=True)
def _orient_exact(ax, ay, bx, by, cx, cy):
    """Exact sign of (a - c) x (b - c) from the six products of the expanded determinant."""
    t1 = np.empty(4)
    t2 = np.empty(4)
    t3 = np.empty(4)
    s1 = np.empty(8)
    s2 = np.empty(12)
    p1, p0 = _two_product(ax, by)
    q1, q0 = _two_product(ay, bx)
    _two_two_diff(p1, p0, q1, q0, t1)  # ax by - ay bx
    p1, p0 = _two_product(bx, cy)
    q1, q0 = _two_product(by, cx)
    _two_two_diff(p1, p0, q1, q0, t2)  # bx cy - by cx
    p1, p0 = _two_product(cx, ay)
    q1, q0 = _two_product(cy, ax)
    _two_two_diff(p1, p0, q1, q0, t3)  # cx ay - cy ax
    n = _sum(t1.shape[0], t1, t2.shape[0], t2, s1)
    n = _sum(n, s1, t3.shape[0], t3, s2)
    top = s2[n - 1]
    return 1.0 if top > 0.0 else (-1.0 if top < 0.0 else 0.0)


@njit(cache=True)
def orient(ax, ay, bx, by, cx, cy):
    """Sign of the signed area of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear."""
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    bound = _CCW_ERRBOUND * (abs(left) + abs(right))
    if det > bound:
        return 1.0
    if -det > bound:
        return -1.0
    return _orient_exact(ax, ay, bx, by, cx, cy)


@njit(cache=True)
def _lifted(e1, e2, e3, px, py, work, out):
    """out = (px^2 + py^2) * (e1 + e2 + e3) for 4-term expansions; return its length."""
    s8 = work[0:8]
    s12 = work[8:20]
    x24 = work[20:44]
    x48 = work[44:92]
    y24 = work[92:116]
    y48 = work[116:164]
    n = _sum(e1.shape[0], e1, e2.shape[0], e2, s8)
    n = _sum(n, s8, e3.shape[0], e3, s12)
    nx = _scale(n, s12, px, x24)
    nx = _scale(nx, x24, px, x48)
    ny = _scale(n, s12, py, y24)
    ny = _scale(ny, y24, py, y48)
    return _sum(nx, x48, ny, y48, out)


@njit(cache=True)
def _incircle_exact(ax, ay, bx, by, cx, cy, dx, dy):
    """Exact sign of the in-circle determinant (Shewchuk's incircleexact)."""
    ab = np.empty(4)
    bc = np.empty(4)
    cd = np.empty(4)
    da = np.empty(4)
    ac = np.empty(4)
    bd = np.empty(4)
    p1, p0 = _two_product(ax, by)
    q1, q0 = _two_product(bx, ay)
    _two_two_diff(p1, p0, q1, q0, ab)
    p1, p0 = _two_product(bx, cy)
    q1, q0 = _two_product(cx, by)
    _two_two_diff(p1, p0, q1, q0, bc)
    p1, p0 = _two_product(cx, dy)
    q1, q0 = _two_product(dx, cy)
    _two_two_diff(p1, p0, q1, q0, cd)
    p1, p0 = _two_product(dx, ay)
    q1, q0 = _two_product(ax, dy)
    _two_two_diff(p1, p0, q1, q0, da)
    p1, p0 = _two_product(ax, cy)
    q1, q0 = _two_product(cx, ay)
    _two_two_diff(p1, p0, q1, q0, ac)
    p1, p0 = _two_product(bx, dy)
    q1, q0 = _two_product(dx, by)
    _two_two_diff(p1, p0, q1, q0, bd)
    work = np.empty(164)
    adet = np.empty(96)
    bdet = np.empty(96)
    cdet = np.empty(96)
    ddet = np.empty(96)
    # cofactors (incircleexact): bcd = bc + cd - bd, cda = cd + da + ac, dab = da + ab + bd,
    # abc = ab + bc - ac; det = |a|^2 bcd - |b|^2 cda + |c|^2 dab - |d|^2 abc
    mac = -ac
    mbd = -bd
    na = _lifted(bc, cd, mbd, ax, ay, work, adet)
    nb = _lifted(cd, da, ac, bx, by, work, bdet)
    nc = _lifted(da, ab, bd, cx, cy, work, cdet)
    nd = _lifted(ab, bc, mac, dx, dy, work, ddet)
    for i in range(nb):
        bdet[i] = -bdet[i]
    for i in range(nd):
        ddet[i] = -ddet[i]
    ab_det = np.empty(192)
    cd_det = np.empty(192)
    total = np.empty(384)
    n1 = _sum(nc, cdet, na, adet, ab_det)
    n2 = _sum(nb, bdet, nd, ddet, cd_det)
    n = _sum(n1, ab_det, n2, cd_det, total)
    top = total[n - 1]
    return 1.0 if top > 0.0 else (-1.0 if top < 0.0 else 0.0)


@njit(cache=True)
def _incircle_filter(ax, ay, bx, by, cx, cy, dx, dy):
    adx = ax - dx
    ady = ay - dy
    bdx = bx - dx
    bdy = by - dy
    cdx = cx - dx
    cdy = cy - dy
    bc1 = bdx * cdy
    bc2 = cdx * bdy
    alift = adx * adx + ady * ady
    ca1 = cdx * ady
    ca2 = adx * cdy
    blift = bdx * bdx + bdy * bdy
    ab1 = adx * bdy
    ab2 = bdx * ady
    clift = cdx * cdx + cdy * cdy
    det = alift * (bc1 - bc2) + blift * (ca1 - ca2) + clift * (ab1 - ab2)
    permanent = (abs(bc1) + abs(bc2)) * alift + (abs(ca1) + abs(ca2)) * blift + (abs(ab1) + abs(ab2)) * clift
    bound = _ICC_ERRBOUND * permanent
    if det > bound:
        return 1.0
    if -det > bound:
        return -1.0
    return 2.0  # undecided


@njit(cache=True)
def incircle(ax, ay, bx, by, cx, cy, dx, dy):
    """Sign of the in-circle determinant: +1 when d lies inside the circle through the
    counter-clockwise a, b, c, -1 outside, 0 on it (exact)."""
    sign = _incircle_filter(ax, ay, bx, by, cx, cy, dx, dy)
    return sign if sign != 2.0 else _incircle_exact(ax, ay, bx, by, cx, cy, dx, dy)


@njit(cache=True, inline="always")
def _before(ax, ay, bx, by):
    """1 when a comes before b in lexicographic (x, then y) order, else 0."""
    return 1 if ax < bx or (ax == bx and ay < by) else 0


@njit(cache=True)
def _cocircular_side(ax, ay, bx, by, cx, cy, dx, dy):
    """The side of d, on the circle through the counter-clockwise a, b, c, after a symbolic
    perturbation that ranks the four distinct points in lexicographic (x, then y) order.

    The perturbation of O. Devillers and M. Teillaud, "Perturbations for Delaunay and weighted
    Delaunay 3D triangulations", Computational Geometry 44 (2011), section 3, in the plane (as
    in CGAL's ``Delaunay_triangulation_2``): the point last in lexicographic order is lifted
    by the largest infinitesimal, the one before it by the next, so the first of the two that
    is d puts d outside, and otherwise an orientation decides. Two ranks always settle it.
    """
    ra = _before(bx, by, ax, ay) + _before(cx, cy, ax, ay) + _before(dx, dy, ax, ay)
    rb = _before(ax, ay, bx, by) + _before(cx, cy, bx, by) + _before(dx, dy, bx, by)
    rc = _before(ax, ay, cx, cy) + _before(bx, by, cx, cy) + _before(dx, dy, cx, cy)
    for rank in (3, 2):
        if ra != rank and rb != rank and rc != rank:  # d has this rank
            return -1.0
        if rc == rank:
            side = orient(ax, ay, bx, by, dx, dy)
        elif rb == rank:
            side = orient(ax, ay, dx, dy, cx, cy)
        else:
            side = orient(dx, dy, bx, by, cx, cy)
        if side != 0.0:
            return side
    return -1.0


@njit(cache=True)
def incircle_perturbed(ax, ay, bx, by, cx, cy, dx, dy):
    """:func:`incircle` with co-circular ties broken by a symbolic perturbation: +1 or -1, never 0.

    Four co-circular points (the corners of every square of a lattice) have two Delaunay
    triangulations; the perturbation (see :func:`_cocircular_side`) decides by the points'
    lexicographic order, so the triangulation built with it is the one Delaunay triangulation
    of the perturbed points: it depends on the point set only, never on the order in which
    the points come (a file's row order) or are inserted. The points must be distinct, and
    a, b, c counter-clockwise.
    """
    sign = _incircle_filter(ax, ay, bx, by, cx, cy, dx, dy)
    if sign == 2.0:
        sign = _incircle_exact(ax, ay, bx, by, cx, cy, dx, dy)
    return sign if sign != 0.0 else _cocircular_side(ax, ay, bx, by, cx, cy, dx, dy)


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
