"""Compiled kernels of the water-jet model (numba): thin-sheet tracing and mesh checks.

The surface is a height field z(x, y) made of triangles that are counter-clockwise in the
(x, y) plane, so every facet normal points to +z, towards the fluid. Each jet streamlet
strikes one facet and spreads into parcels of the sheet; a parcel is in one of three states:

* **on the surface**: it slides across a facet in a straight line at constant speed; at an
  edge it crosses a concave crease geodesically (the component along the edge is kept, the
  rest is rotated into the next facet), separates at a convex crease, or reaches the
  boundary;
* **flying** above the footprint of the surface: a straight line (no gravity) until it
  strikes a facet again (a new impact) or leaves the footprint;
* **outside** the footprint: it leaves for good unless it re-enters the footprint (a
  non-convex footprint, or after a reflection by the symmetry plane of the half jet).

The surface force is accumulated event by event as mass flow x (velocity before - velocity
after); the symmetry plane y = 0 reflects parcels (v_y -> -v_y) without any force on the
surface. Neighbour codes: ``>= 0`` a triangle, ``BOUNDARY`` the edge of the surface,
``SYMMETRY`` an edge lying on the symmetry plane (half jet only).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from replication import _numbacache
from replication.casestudy._sheetcodes import (
    BOUNDARY,
    ROW_FORCE,
    ROW_OUT,
    ROW_TALLY,
    SYMMETRY,
    TALLY_MASS_HIT,
    TALLY_MASS_OUT,
    TALLY_MASS_TRAPPED,
    TALLY_PARCELS,
    TALLY_SIZE,
    TALLY_STREAMLETS_HIT,
)
from replication.surfaces._sweephull import orient

__all__ = ["BOUNDARY", "SYMMETRY", "first_overlap", "orientations", "prepare", "trace"]

_SURFACE = 0
_FLYING = 1
_OUTSIDE = 2
#: Creases and flights within this angle (radians) of the surface count as flat (rounding).
_FLAT = 1e-9


@njit(cache=True, inline="always")
def _exit_edge(edges, t, px, py, dx, dy):
    """Edge ``k`` of triangle ``t`` through which the ray ``p + s d`` leaves, and ``s >= 0``."""
    best_k = -1
    best_s = np.inf
    scale = abs(dx) + abs(dy)
    for k in range(3):
        ax = edges[t, k, 0]
        ay = edges[t, k, 1]
        ex = edges[t, k, 2]
        ey = edges[t, k, 3]
        den = ex * dy - ey * dx
        if den < edges[t, k, 4] * scale:
            g = ex * (py - ay) - ey * (px - ax)
            s = max(g, 0.0) / -den
            if s < best_s:
                best_s = s
                best_k = k
    return best_k, best_s


@njit(cache=True, inline="always")
def _height(x, y, z, tri, slope, t, px, py):
    a = tri[t, 0]
    return z[a] + slope[t, 0] * (px - x[a]) + slope[t, 1] * (py - y[a])


@njit(cache=True, inline="always")
def _rotate(vx, vy, vz, n1x, n1y, n1z, n2x, n2y, n2z):
    """Rotate v by the rotation that takes the unit normal n1 to n2 (about n1 x n2, the crease).

    Across an edge this is the geodesic carry-over: the component along the edge is kept, the
    rest turns into the next facet, the speed is kept (Rodrigues' formula, k = n1 x n2).
    """
    kx = n1y * n2z - n1z * n2y
    ky = n1z * n2x - n1x * n2z
    kz = n1x * n2y - n1y * n2x
    c = n1x * n2x + n1y * n2y + n1z * n2z
    f = (kx * vx + ky * vy + kz * vz) / (1.0 + c)
    return (
        c * vx + (ky * vz - kz * vy) + f * kx,
        c * vy + (kz * vx - kx * vz) + f * ky,
        c * vz + (kx * vy - ky * vx) + f * kz,
    )


@njit(cache=True)
def _around(x, y, tri, nbr, t, v, dx, dy):
    """Triangle around vertex ``v`` (a vertex of ``t``) whose corner at v holds direction d; -1 if none.

    Turns clockwise around v, then counter-clockwise, until the corner holds d or the
    boundary is reached; the answer does not depend on the sense (mirror-symmetric).
    """
    for sense in range(2):
        cur = t
        for _ in range(tri.shape[0]):
            j = 0 if tri[cur, 0] == v else (1 if tri[cur, 1] == v else 2)
            a = tri[cur, (j + 1) % 3]
            b = tri[cur, (j + 2) % 3]
            after_a = (x[a] - x[v]) * dy - (y[a] - y[v]) * dx >= 0.0  # d not clockwise of v -> a
            before_b = dx * (y[b] - y[v]) - dy * (x[b] - x[v]) >= 0.0  # d not anticlockwise of v -> b
            if after_a and before_b:
                return cur
            nb = nbr[cur, j] if sense == 0 else nbr[cur, (j + 2) % 3]
            if nb < 0:
                break
            cur = nb
    return -1


@njit(cache=True, inline="always")
def _vertex_at(x, y, tri, t, k, px, py, tol):
    """The end of edge k of triangle t within ``tol`` of (px, py), or -1."""
    a = tri[t, k]
    b = tri[t, (k + 1) % 3]
    if (px - x[a]) ** 2 + (py - y[a]) ** 2 <= tol * tol:
        return a
    if (px - x[b]) ** 2 + (py - y[b]) ** 2 <= tol * tol:
        return b
    return -1


@njit(cache=True, error_model="numpy")
def _follow(
    mesh, half, convex, zmax, eps, max_steps, min_split, loss, stack, stack_t, top, force, out, tally
):
    """Follow the parcels ``stack[:top + 1]``, the last first, until each has left.

    A parcel is popped and followed; the backward streams it splits off are pushed in its
    place and followed in turn. ``loss`` is (crease, reimpact): the speed lost turning across
    a concave crease per unit of (1 - cos turn), and the fraction of speed lost at a
    re-impact (0, 0: none, the model).

    One call per streamlet, not per parcel, on purpose: numba takes and drops a reference to
    every array argument of a call (and of a function it inlines) on each entry, atomic
    operations that cost about a fifth of the tracer when they ran once per parcel.
    """
    crease, reimpact = loss[0], loss[1]
    x, y, z, tri, nbr, nrm, slope, bnd, edges = mesh
    while top >= 0:
        px, py, pz, vx, vy, vz, m, root = stack[top]
        t = stack_t[top]
        free = top  # the parcel's slot, free for a split-off stream
        cap = stack.shape[0]
        state = _SURFACE
        mirrored = False
        for _ in range(max_steps):
            if state == _SURFACE:
                k, s = _exit_edge(edges, t, px, py, vx, vy)
                if k < 0:  # at rest
                    break
                px += s * vx
                py += s * vy
                pz = _height(x, y, z, tri, slope, t, px, py)
                n1x, n1y, n1z = nrm[t, 0], nrm[t, 1], nrm[t, 2]
                vv = _vertex_at(x, y, tri, t, k, px, py, 1e3 * eps)
                mirror = False
                if vv >= 0:  # through a vertex: straight to the facet that holds the direction
                    px, py, pz = x[vv], y[vv], z[vv]
                    nb = _around(x, y, tri, nbr, t, vv, vx, vy)
                    if nb < 0 and half and py == 0.0 and vy < 0.0:  # into the mirror image
                        nb = _around(x, y, tri, nbr, t, vv, vx, -vy)
                        mirror = True
                    if nb < 0:
                        nb = BOUNDARY
                else:
                    nb = nbr[t, k]
                    if nb == SYMMETRY:
                        nb = t
                        mirror = True
                if nb == BOUNDARY:
                    state = _OUTSIDE
                    mirrored = False
                    continue
                n2x, n2y, n2z = nrm[nb, 0], nrm[nb, 1], nrm[nb, 2]
                if mirror:  # the facet's mirror image across y = 0
                    n2y = -n2y
                vabs = math.sqrt(vx * vx + vy * vy + vz * vz)
                if vx * n2x + vy * n2y + vz * n2z <= _FLAT * vabs:  # concave or flat: follow the surface
                    wx, wy, wz = _rotate(vx, vy, vz, n1x, n1y, n1z, n2x, n2y, n2z)
                    if crease > 0.0:  # the surrogate's crease loss (issue 11): speed lost with the turn
                        keep = max(0.0, 1.0 - crease * (1.0 - (vx * wx + vy * wy + vz * wz) / (vabs * vabs)))
                        wx, wy, wz = keep * wx, keep * wy, keep * wz
                    force[0] += m * (vx - wx)
                    force[2] += m * (vz - wz)
                    if mirror:  # the symmetry plane takes the y component; fold back
                        wy = -wy
                    else:
                        force[1] += m * (vy - wy)
                    vx, vy, vz = wx, wy, wz
                else:  # convex crease: the sheet separates
                    state = _FLYING
                    if mirror:
                        vy = -vy
                t = nb
            elif state == _FLYING:
                if vz >= 0.0 and pz >= zmax:  # above the surface and rising
                    break
                gap = pz - _height(x, y, z, tri, slope, t, px, py)
                rate = vz - slope[t, 0] * vx - slope[t, 1] * vy
                vabs = math.sqrt(vx * vx + vy * vy + vz * vz)
                if gap <= eps and abs(rate) * nrm[t, 2] <= _FLAT * vabs:  # grazing: back on the surface
                    vn = vx * nrm[t, 0] + vy * nrm[t, 1] + vz * nrm[t, 2]
                    wx, wy, wz = vx - vn * nrm[t, 0], vy - vn * nrm[t, 1], vz - vn * nrm[t, 2]
                    scale = vabs / math.sqrt(wx * wx + wy * wy + wz * wz)
                    force[0] += m * (vx - wx * scale)
                    force[1] += m * (vy - wy * scale)
                    force[2] += m * (vz - wz * scale)
                    vx, vy, vz = wx * scale, wy * scale, wz * scale
                    pz = _height(x, y, z, tri, slope, t, px, py)
                    state = _SURFACE
                    continue
                k, s = _exit_edge(edges, t, px, py, vx, vy)
                # a strike inside this facet; reaching the surface exactly on the far edge hands the
                # decision to the next facet (grazing a ridge is no impact)
                if rate < 0.0 and (gap <= eps or k < 0 or gap + rate * s < -eps):
                    s_hit = max(gap, 0.0) / -rate
                    if k >= 0:
                        s_hit = min(s_hit, s)
                    px += s_hit * vx
                    py += s_hit * vy
                    pz = _height(x, y, z, tri, slope, t, px, py)
                    # a new impact: absorb the normal component, split in the plane of incidence
                    nx, ny, nz = nrm[t, 0], nrm[t, 1], nrm[t, 2]
                    vn = vx * nx + vy * ny + vz * nz
                    tx, ty, tz = vx - vn * nx, vy - vn * ny, vz - vn * nz
                    vn = tx * nx + ty * ny + tz * nz  # project again: exactly in the plane
                    tx, ty, tz = tx - vn * nx, ty - vn * ny, tz - vn * nz
                    tnorm = math.sqrt(tx * tx + ty * ty + tz * tz)
                    back = 0.5 * (1.0 - min(tnorm / vabs, 1.0))
                    keep = 1.0 - reimpact  # the surrogate's re-impact loss (issue 11); 1.0: exact model
                    vout = keep * vabs
                    if back * m >= min_split * root and free < cap:
                        if tnorm > 1e-9 * vabs:
                            dx, dy, dz = tx / tnorm, ty / tnorm, tz / tnorm
                        else:  # head-on (within rounding): split along the facet's x direction
                            dx, dy, dz = 1.0 - nx * nx, -nx * ny, -nx * nz
                            dn = math.sqrt(dx * dx + dy * dy + dz * dz)
                            dx, dy, dz = dx / dn, dy / dn, dz / dn
                        mb = back * m
                        mf = m - mb
                        force[0] += m * vx - (mf - mb) * vout * dx
                        force[1] += m * vy - (mf - mb) * vout * dy
                        force[2] += m * vz - (mf - mb) * vout * dz
                        stack[free, 0], stack[free, 1], stack[free, 2] = px, py, pz
                        stack[free, 3], stack[free, 4], stack[free, 5] = -vout * dx, -vout * dy, -vout * dz
                        stack[free, 6] = mb
                        stack[free, 7] = root
                        stack_t[free] = t
                        free += 1
                        tally[TALLY_PARCELS] += 1.0
                        m = mf
                        vx, vy, vz = vout * dx, vout * dy, vout * dz
                    elif tnorm > 1e-9 * vabs:  # too small to split: keep the momentum, lose speed
                        tx, ty, tz = keep * tx, keep * ty, keep * tz
                        force[0] += m * (vx - tx)
                        force[1] += m * (vy - ty)
                        force[2] += m * (vz - tz)
                        vx, vy, vz = tx, ty, tz
                    else:  # a small parcel striking head-on stops
                        state = -1
                        break
                    state = _SURFACE
                    continue
                if k < 0:  # rising vertically: nothing to strike
                    break
                px += s * vx
                py += s * vy
                pz = max(pz + s * vz, _height(x, y, z, tri, slope, t, px, py))
                vv = _vertex_at(x, y, tri, t, k, px, py, 1e3 * eps)
                if vv >= 0:
                    px, py = x[vv], y[vv]
                    nb = _around(x, y, tri, nbr, t, vv, vx, vy)
                    if nb < 0 and half and py == 0.0 and vy < 0.0:
                        vy = -vy
                        nb = _around(x, y, tri, nbr, t, vv, vx, vy)
                    if nb < 0:
                        nb = BOUNDARY
                else:
                    nb = nbr[t, k]
                if nb >= 0:
                    t = nb
                elif nb == SYMMETRY:
                    vy = -vy
                else:
                    state = _OUTSIDE
                    mirrored = False
            else:  # outside the footprint: leaves unless it comes back over the surface
                if vz >= 0.0 and pz >= zmax:
                    break
                best = np.inf
                best_j = -1
                if not convex or mirrored:
                    dl = math.sqrt(vx * vx + vy * vy)
                    for j in range(bnd.shape[0]):
                        a = tri[bnd[j, 0], bnd[j, 1]]
                        b = tri[bnd[j, 0], (bnd[j, 1] + 1) % 3]
                        ex, ey = x[b] - x[a], y[b] - y[a]
                        den = ex * vy - ey * vx
                        if den > 0.0:  # crossing from the outside to the inside
                            s = -(ex * (py - y[a]) - ey * (px - x[a])) / den
                            if s * dl > 1e3 * eps and s < best:
                                qx, qy = px + s * vx - x[a], py + s * vy - y[a]
                                if 0.0 <= qx * ex + qy * ey <= ex * ex + ey * ey:  # within the edge
                                    best = s
                                    best_j = j
                s_mirror = -py / vy if half and vy < 0.0 else np.inf
                if s_mirror < best:
                    px += s_mirror * vx
                    py = 0.0
                    pz += s_mirror * vz
                    vy = -vy
                    mirrored = True
                    continue
                if best_j < 0:
                    break
                px += best * vx
                py += best * vy
                pz += best * vz
                t = bnd[best_j, 0]
                if pz < _height(x, y, z, tri, slope, t, px, py) - eps:
                    break  # it passes beneath the surface
                state = _FLYING
        else:
            state = -1  # out of steps: trapped
        if state == _OUTSIDE or state == _FLYING:
            tally[TALLY_MASS_OUT] += m
            out[0] += m * vx
            out[1] += m * vy
            out[2] += m * vz
        else:  # stopped on the surface or trapped: the surface absorbs its momentum
            force[0] += m * vx
            force[1] += m * vy
            force[2] += m * vz
            tally[TALLY_MASS_TRAPPED] += m
        top = free - 1


@njit(cache=True)
def _spread(nrm, t, speed, cs, weight):
    """Impact of a streamlet on facet t: parcel directions (unit) and weights; fills ``weight``.

    The weights follow the wrapped-Cauchy density with mean resultant r = sin(theta) about the
    incoming tangential direction, mixed with uniform weights so the discrete resultant is r.
    """
    nx, ny, nz = nrm[t, 0], nrm[t, 1], nrm[t, 2]
    tx, ty, tz = speed * nz * nx, speed * nz * ny, -speed * (nx * nx + ny * ny)
    tnorm = math.sqrt(tx * tx + ty * ty + tz * tz)
    if tnorm > 0.0:
        e1x, e1y, e1z = tx / tnorm, ty / tnorm, tz / tnorm
    else:  # normal incidence on a horizontal facet
        e1x, e1y, e1z = 1.0, 0.0, 0.0
    r = min(tnorm / speed, 1.0)
    n_dir = cs.shape[0]
    total = 0.0
    for k in range(n_dir):
        weight[k] = (1.0 - r * r) / (1.0 - 2.0 * r * cs[k] + r * r)
        total += weight[k]
    resultant = 0.0
    for k in range(n_dir):
        weight[k] /= total
        resultant += weight[k] * cs[k]
    mix = 1.0 - r / resultant if 0.0 < r < resultant else 0.0
    for k in range(n_dir):
        weight[k] = (1.0 - mix) * weight[k] + mix / n_dir
    e2 = (ny * e1z - nz * e1y, nz * e1x - nx * e1z, nx * e1y - ny * e1x)
    return (e1x, e1y, e1z), e2


@njit(cache=True, error_model="numpy", nogil=True)
def trace(
    mesh, half, convex, sx, sy, smass, start, speed, n_dir, min_split, max_steps, loss, first, step, rows
):
    """Trace the streamlets ``first, first + step, ...`` of the jet over the surface.

    Each streamlet's force, momentum out and tally go to its own row of ``rows``, so pieces
    of the jet can be traced on several threads at once (the kernel releases the GIL) and
    the rows added in streamlet order afterwards: the totals do not depend on how the jet
    was cut into pieces.

    Parameters
    ----------
    mesh : tuple
        ``(x, y, z, tri, nbr, nrm, slope, bnd, edges)``: vertex coordinates (m);
        counter-clockwise triangles; the neighbour across edge k (from ``tri[t, k]`` to
        ``tri[t, k + 1]``) or BOUNDARY/SYMMETRY; unit facet normals (n_z > 0); dz/dx and
        dz/dy of each facet; (triangle, edge) of every BOUNDARY edge; for each edge k of
        each triangle its start (x, y), its vector and its parallelism threshold (see
        :func:`prepare`, which builds the tuple).
    half, convex : bool
        Half jet with the symmetry plane y = 0; convex footprint.
    sx, sy, smass : float64 arrays
        Streamlet positions and mass flows; ``start`` is the triangle each strikes (-1: miss).
    speed : float
        Jet speed (m/s); the jet travels along -z.
    n_dir : int
        Parcels a streamlet spreads into at its impact.
    min_split : float
        A re-impact splits off a backward stream only if its mass flow is at least
        ``min_split`` times that of the parcel the streamlet spread into at its impact.
    max_steps : int
        Events after which a parcel that has not left is stopped (trapped, absorbed).
    loss : float64 array, shape (2,)
        The surrogate's losses (crease, re-impact); zeros give the model exactly (see
        :class:`replication.casestudy.jet.SheetLosses`).
    first, step : int
        The streamlets traced: ``range(first, len(sx), step)``.
    rows : float64 array, shape (len(sx), ROW_SIZE)
        Filled in the traced streamlets' rows (other rows are left as they are): the force of
        each on the surface (N), the momentum flux it carries away (N) and its tally of mass
        flows and counts, in the columns that :mod:`._sheetcodes` names.
    """
    x, y, z = mesh[0], mesh[1], mesh[2]
    zmax = z.max()
    # length tolerance, the same for a surface and its mirror image
    eps = 1e-12 * max(np.abs(x).max(), np.abs(y).max(), np.abs(z).max())
    cs = np.empty(n_dir)  # directions of the spread, exactly symmetric about the first one
    sn = np.empty(n_dir)
    for k in range(n_dir):
        if 2 * k <= n_dir:
            cs[k] = math.cos(2.0 * math.pi * k / n_dir)
            sn[k] = math.sin(2.0 * math.pi * k / n_dir)
        else:
            cs[k] = cs[n_dir - k]
            sn[k] = -sn[n_dir - k]
    weight = np.empty(n_dir)
    cap = n_dir + int(1.0 / min_split) + 4
    stack = np.empty((cap, 8))  # position, velocity, mass flow, mass flow of its spread parcel
    stack_t = np.empty(cap, dtype=np.int64)
    f = np.empty(3)  # one streamlet's force, momentum out and tally
    o = np.empty(3)
    count = np.empty(TALLY_SIZE)
    for i in range(first, sx.shape[0], step):
        f[:] = 0.0
        o[:] = 0.0
        count[:] = 0.0
        t0 = start[i]
        if t0 >= 0:
            m0 = smass[i]
            count[TALLY_MASS_HIT] += m0
            count[TALLY_STREAMLETS_HIT] += 1.0
            count[TALLY_PARCELS] += n_dir
            pz0 = _height(x, y, z, mesh[3], mesh[6], t0, sx[i], sy[i])
            e1, e2 = _spread(mesh[5], t0, speed, cs, weight)
            f[2] -= m0 * speed
            for k in range(n_dir):
                stack[k, 0], stack[k, 1], stack[k, 2] = sx[i], sy[i], pz0
                for c in range(3):
                    stack[k, 3 + c] = speed * (cs[k] * e1[c] + sn[k] * e2[c])
                    f[c] -= m0 * weight[k] * stack[k, 3 + c]
                stack[k, 6] = m0 * weight[k]
                stack[k, 7] = m0 * weight[k]
                stack_t[k] = t0
            _follow(
                mesh,
                half,
                convex,
                zmax,
                eps,
                max_steps,
                min_split,
                loss,
                stack,
                stack_t,
                n_dir - 1,
                f,
                o,
                count,
            )
        for c in range(3):
            rows[i, ROW_FORCE + c] = f[c]
            rows[i, ROW_OUT + c] = o[c]
        for c in range(TALLY_SIZE):
            rows[i, ROW_TALLY + c] = count[c]


@njit(cache=True, error_model="numpy", nogil=True)
def prepare(points, tri, raw, half):
    """The mesh tuple of :func:`trace` from vertices (m), CCW triangles and their neighbours.

    With the half jet, vertices within 1e-9 of the largest extent from y = 0 are put on the
    symmetry plane, and boundary edges lying on it become ``SYMMETRY``. The per-edge table
    holds exactly the values the tracer would compute at every step (same operations), so
    results do not change. Returns the mesh and the (possibly moved) vertices.
    """
    n = points.shape[0]
    m = tri.shape[0]
    span = 0.0
    for c in range(3):
        lo = points[0, c]
        hi = points[0, c]
        for i in range(n):
            lo = min(lo, points[i, c])
            hi = max(hi, points[i, c])
        span = max(span, hi - lo)
    if span == 0.0:
        span = 1.0
    x = np.empty(n)
    y = np.empty(n)
    z = np.empty(n)
    for i in range(n):
        x[i] = points[i, 0]
        y[i] = points[i, 1]
        z[i] = points[i, 2]
        if half and abs(y[i]) <= 1e-9 * span:
            y[i] = 0.0
    normal = np.empty((m, 3))
    slope = np.empty((m, 2))
    nbr = np.empty((m, 3), dtype=np.int64)
    n_bnd = 0
    for t in range(m):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ux, uy, uz = x[b] - x[a], y[b] - y[a], z[b] - z[a]
        vx, vy, vz = x[c] - x[a], y[c] - y[a], z[c] - z[a]
        nx = uy * vz - uz * vy
        ny = uz * vx - ux * vz
        nz = ux * vy - uy * vx
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        normal[t, 0] = nx / length
        normal[t, 1] = ny / length
        normal[t, 2] = nz / length
        slope[t, 0] = -normal[t, 0] / normal[t, 2]
        slope[t, 1] = -normal[t, 1] / normal[t, 2]
        for k in range(3):
            nb = raw[t, k]
            if nb < 0 and half and y[tri[t, k]] == 0.0 and y[tri[t, (k + 1) % 3]] == 0.0:
                nb = SYMMETRY
            nbr[t, k] = nb
            n_bnd += nb == BOUNDARY
    bnd = np.empty((n_bnd, 2), dtype=np.int64)
    j = 0
    for t in range(m):
        for k in range(3):
            if nbr[t, k] == BOUNDARY:
                bnd[j, 0] = t
                bnd[j, 1] = k
                j += 1
    moved = np.empty((n, 3))
    for i in range(n):
        moved[i, 0] = x[i]
        moved[i, 1] = y[i]
        moved[i, 2] = z[i]
    edges = np.empty((m, 3, 5))
    for t in range(m):
        for k in range(3):
            a = tri[t, k]
            b = tri[t, (k + 1) % 3]
            ex = x[b] - x[a]
            ey = y[b] - y[a]
            edges[t, k, 0] = x[a]
            edges[t, k, 1] = y[a]
            edges[t, k, 2] = ex
            edges[t, k, 3] = ey
            edges[t, k, 4] = -1e-12 * (abs(ex) + abs(ey))
    return (x, y, z, tri, nbr, normal, slope, bnd, edges), moved


@njit(cache=True, nogil=True)
def orientations(x, y, tri):
    """Exact orientation sign of every triangle in the (x, y) plane."""
    out = np.empty(tri.shape[0])
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        out[t] = orient(x[a], y[a], x[b], y[b], x[c], y[c])
    return out


@njit(cache=True)
def _separated(x, y, tri, i, j):
    """True when an edge of triangle i has every vertex of triangle j on its closed outside."""
    for k in range(3):
        a = tri[i, k]
        b = tri[i, (k + 1) % 3]
        outside = True
        for q in range(3):
            v = tri[j, q]
            if orient(x[a], y[a], x[b], y[b], x[v], y[v]) > 0.0:
                outside = False
                break
        if outside:
            return True
    return False


@njit(cache=True)
def _on_edge(x, y, tri, i, j):
    """True when a vertex of triangle j lies strictly inside an edge of triangle i."""
    for k in range(3):
        a = tri[i, k]
        b = tri[i, (k + 1) % 3]
        for q in range(3):
            v = tri[j, q]
            if v == a or v == b or orient(x[a], y[a], x[b], y[b], x[v], y[v]) != 0.0:
                continue
            ex, ey = x[b] - x[a], y[b] - y[a]
            if (x[v] - x[a]) * ex + (y[v] - y[a]) * ey > 0.0 and (x[b] - x[v]) * ex + (
                y[b] - y[v]
            ) * ey > 0.0:
                return True
    return False


@njit(cache=True, nogil=True)
def first_overlap(x, y, tri):
    """First pair (i, j, kind) of triangles that overlap in (x, y), or (-1, -1, 0).

    ``kind`` is 1 when their interiors intersect and 2 when a vertex of one lies inside an
    edge of the other (a non-conforming mesh). Triangles must be counter-clockwise. A sweep
    along x restricts the exact separating-edge test to pairs whose bounding boxes meet.
    """
    m = tri.shape[0]
    lo_x = np.empty(m)
    hi_x = np.empty(m)
    lo_y = np.empty(m)
    hi_y = np.empty(m)
    for t in range(m):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        lo_x[t] = min(x[a], x[b], x[c])
        hi_x[t] = max(x[a], x[b], x[c])
        lo_y[t] = min(y[a], y[b], y[c])
        hi_y[t] = max(y[a], y[b], y[c])
    order = np.argsort(lo_x)
    for ii in range(m):
        i = order[ii]
        for jj in range(ii + 1, m):
            j = order[jj]
            if lo_x[j] > hi_x[i]:
                break
            if lo_y[j] > hi_y[i] or lo_y[i] > hi_y[j]:
                continue
            if not (_separated(x, y, tri, i, j) or _separated(x, y, tri, j, i)):
                return min(i, j), max(i, j), 1
            if _on_edge(x, y, tri, i, j) or _on_edge(x, y, tri, j, i):
                return min(i, j), max(i, j), 2
    return -1, -1, 0


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
