"""Force of a water jet on a faceted height-field surface: a validated thin-sheet model.

The paper (section 6) scores each surface by the force of a water jet on it, computed with
the SPH solver DualSPHysics (107.53 s per simulation on a GPU). This module replaces that
simulation by an inviscid thin-sheet momentum balance that runs in milliseconds:

1. **Streamlets.** The jet cross-section (a half disk y >= 0 for the paper's half jet, the
   whole disk with ``full_jet``) is cut by a polar grid into ``resolution`` rings of equal
   width, each split into sectors about as long as they are wide; a streamlet sits at the
   area centroid of its sector and carries the mass flow rho V dA (the cell areas add up
   to the jet's area exactly).
2. **Impact.** A streamlet striking a facet at angle theta from its normal loses its normal
   momentum; the rest spreads in the tangent plane at the jet speed (Bernoulli) into
   ``4 * resolution`` parcels at equally spaced directions, weighted by the wrapped-Cauchy
   density with mean resultant r = sin(theta) about the incoming tangential direction
   (mixed with the uniform weights so the discrete resultant is exactly r): a frictionless
   facet takes no tangential force.
3. **Sheet.** A parcel slides along its facet; across a concave crease its velocity is
   carried over geodesically (the component along the edge kept, the rest rotated into the
   next facet, speed kept); at a convex crease it separates and flies straight (no gravity)
   until it leaves or strikes the surface again. A re-impact absorbs the normal component
   and splits the parcel in the plane of incidence into a forward and a backward stream of
   mass fractions (1 + s)/2 and (1 - s)/2, s = |tangential velocity| / speed.
4. **Leaving.** A parcel leaves with its velocity when it crosses the boundary of the surface
   (the edge of its footprint) or rises above the surface. With the half jet the symmetry
   plane y = 0 reflects parcels (v_y -> -v_y) and takes the y force of that reflection.

The force on the surface is the sum of mass flow x (velocity before - velocity after) over
every event; it equals mass flow x (velocity in - velocity out) summed over the streamlets.

**Bounds and their errors.** A re-impact splits off a backward stream only when its mass
flow is at least ``MIN_SPLIT_FRACTION`` (1/64) of the spread parcel it descends from, so each
spread parcel ends as at most 64 parcels. An unsplit re-impact sends the whole parcel forward
with its tangential velocity (speed s V instead of V): the momentum is exact at the event,
but the backward stream it stands for (mass fraction b = (1 - s)/2) then travels with the
forward one, which misplaces at most 2 b m V of outflow momentum, less than 2/64 of the
spread parcel's momentum flux per event. Measured: a threshold of 1/256 instead changes the
bucket's force by 0.09 % and that of random 101-point ADT surfaces by 0.2 % (median; 0.6 %
at most). A parcel that has not left after ``MAX_STEPS_PER_TRIANGLE`` events per triangle is
stopped and its momentum absorbed (reported as trapped mass flow; none was seen on
thousands of random ADT surfaces).

**Ties.** Rounding-level ties are decided so that the half jet gives half the full jet on
the mirrored surface: creases and flights within 1e-9 rad of the surface count as flat, a
sheet sliding along an edge stays on it, a ray reaching the surface exactly on a facet edge
lets the next facet decide, and a parcel passing through a vertex goes straight to the
facet whose corner holds its direction. The remaining asymmetry is a parcel whose carried-
over velocity leaves that facet again at once and is handed on round the vertex, in the
opposite order in the mirror image (differences up to 2e-5 rho Q V, seen on 5 of 1000
random surfaces; none on the case-study shapes).
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from replication._aot import kernel
from replication.casestudy import _sheetcodes as codes
from replication.casestudy.coverage import warn_if_too_coarse, warn_if_units_differ
from replication.casestudy.jetconfig import JetConfig  # re-exported: jet.JetConfig keeps working
from replication.casestudy.losses import SheetLosses
from replication.casestudy.mesh import check_domain, check_height_field, weld
from replication.casestudy.units import to_metres
from replication.errors import DegenerateInputError, InputError
from replication.surfaces._threads import frozen, run
from replication.surfaces.interpolate import locate_valid, triangle_neighbors

if TYPE_CHECKING:  # pragma: no cover
    from replication.surfaces import Surface

__all__ = [
    "DEFAULT_RESOLUTION",
    "MAX_RESOLUTION",
    "MIN_SPLIT_FRACTION",
    "JetConfig",
    "SheetLosses",
    "JetForce",
    "jet_force",
    "jet_streamlets",
    "surface_force",
]

#: Rings of streamlets across the jet radius (with 4 x as many spreading directions).
DEFAULT_RESOLUTION = 8
#: Smallest backward stream split off at a re-impact, as a fraction of its spread parcel.
MIN_SPLIT_FRACTION = 1.0 / 64.0
#: A parcel is stopped (trapped) after this many events per triangle of the surface.
MAX_STEPS_PER_TRIANGLE = 8
#: Pieces the jet's streamlets are cut into (every PIECES-th streamlet in each), traced on up
#: to as many threads (:func:`replication.surfaces._threads.run`). Each streamlet's force is
#: summed on its own and the streamlets are added in order, so the result does not depend
#: on the pieces or the threads.
PIECES = 2
#: Above the default resolutions the work grows as the resolution's cube (seconds at 128,
#: tens of seconds at 256): it is cut into ``PIECES`` pieces per this many rings, so that a
#: Ctrl-C is taken between pieces of well under a second and ``progress`` hears of each.
RINGS_PER_PIECE = 4


@dataclass(frozen=True, eq=False)
class JetForce:
    """The force of the jet on a surface and how the jet's mass flow was accounted for.

    Attributes
    ----------
    force : ndarray of float64, shape (3,)
        Force of the water on the surface (N).
    momentum_out : ndarray of float64, shape (3,)
        Momentum flux of the water leaving the surface (N).
    mass_flow_total : float
        Mass flow of the modelled jet (kg/s).
    mass_flow_hit : float
        Mass flow of the streamlets that strike the surface (kg/s); the rest misses.
    mass_flow_out : float
        Mass flow that leaves the surface (kg/s).
    mass_flow_trapped : float
        Mass flow stopped on the surface after the step limit (kg/s), normally 0;
        ``mass_flow_out + mass_flow_trapped == mass_flow_hit``.
    n_streamlets, n_streamlets_hit, n_parcels : int
        Streamlets of the jet, those striking the surface, and sheet parcels traced.
    resolution : int
    config : JetConfig
    """

    force: np.ndarray
    momentum_out: np.ndarray
    mass_flow_total: float
    mass_flow_hit: float
    mass_flow_out: float
    mass_flow_trapped: float
    n_streamlets: int
    n_streamlets_hit: int
    n_parcels: int
    resolution: int
    config: JetConfig

    @property
    def axial_force(self) -> float:
        """Force along the jet axis (N), positive when the jet pushes the surface along -z."""
        return float(-self.force[2]) + 0.0  # + 0.0: a jet that misses gives 0 N, not -0 N

    def as_dict(self) -> dict[str, Any]:
        """Plain numbers (SI units) for JSON and tables."""
        return {
            "force_N": [float(v) for v in self.force],
            "axial_force_N": self.axial_force,
            "momentum_out_N": [float(v) for v in self.momentum_out],
            "mass_flow_total_kg_s": self.mass_flow_total,
            "mass_flow_hit_kg_s": self.mass_flow_hit,
            "mass_flow_out_kg_s": self.mass_flow_out,
            "mass_flow_trapped_kg_s": self.mass_flow_trapped,
            "streamlets": self.n_streamlets,
            "streamlets_hit": self.n_streamlets_hit,
            "parcels": self.n_parcels,
            "resolution": self.resolution,
        }


#: The finest resolution accepted: the work grows as its cube (40 s for the Pelton bucket at 256,
#: 32 times the default, against 4.8 s at 128; 100000 ran out of memory building the streamlets).
MAX_RESOLUTION = 256


def _check_resolution(resolution: int) -> int:
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
        raise InputError(f"resolution must be a positive integer, got {resolution=!r}")
    if resolution > MAX_RESOLUTION:
        raise InputError(
            f"resolution must be at most {MAX_RESOLUTION} (the work grows as its cube: tens of seconds "
            f"per force at {MAX_RESOLUTION}), got {resolution=!r}"
        )
    return int(resolution)


@functools.lru_cache(maxsize=32)
def jet_streamlets(config: JetConfig, resolution: int = DEFAULT_RESOLUTION) -> tuple[np.ndarray, np.ndarray]:
    """Streamlet positions (m) and mass flows (kg/s) of the jet's cross-section.

    Ring i (of ``resolution`` rings of equal width) is cut into round(pi (i + 1/2)) sectors
    over the half disk y >= 0; the full jet adds their mirror images. Each streamlet sits at
    the area centroid of its sector. The arrays are read-only (the result is cached).

    Notes
    -----
    Paper section 6: the 18 mm jet, of which the SPH model simulates the half y >= 0.
    """
    resolution = _check_resolution(resolution)
    radius = config.diameter / 2
    dr = radius / resolution
    xy, area = [], []
    for i in range(resolution):
        r1, r2 = i * dr, (i + 1) * dr
        n = max(1, round(math.pi * (i + 0.5)))
        width = math.pi / n
        r_c = (2 / 3) * (r2**3 - r1**3) / (r2**2 - r1**2) * math.sin(width / 2) / (width / 2)
        theta = (np.arange(n) + 0.5) * width
        xy.append(np.column_stack([r_c * np.cos(theta), r_c * np.sin(theta)]))
        area.append(np.full(n, (r2**2 - r1**2) * width / 2))
    pos = np.concatenate(xy)
    cell = np.concatenate(area)
    if config.full_jet:
        pos = np.concatenate([pos, pos * [1.0, -1.0]])
        cell = np.concatenate([cell, cell])
    pos = pos + np.asarray(config.center)
    mass = config.density * config.velocity * cell
    pos.flags.writeable = False
    mass.flags.writeable = False
    return pos, mass


@functools.lru_cache(maxsize=32)
def _streamlet_arrays(
    config: JetConfig, resolution: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`jet_streamlets` as the tracer takes them: positions, x and y (contiguous;
    writable, as its compiled signature has them, and never written) and mass flows."""
    xy, mass = jet_streamlets(config, resolution)
    return xy, np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1]), frozen(mass)


#: The thin-sheet model exactly (no surrogate losses), as the tracer takes it (never written).
_NO_LOSSES = SheetLosses().as_array()


@functools.cache
def _default_config() -> JetConfig:
    """The paper's jet, validated once (frozen: one instance serves every call)."""
    return JetConfig()


def _trace(
    points: np.ndarray,
    triangles: np.ndarray,
    convex: bool,
    config: JetConfig,
    resolution: int,
    neighbors: np.ndarray | None = None,
    losses: SheetLosses | None = None,
    progress: Callable[[int], None] | None = None,
) -> JetForce:
    """Run the compiled model on a validated mesh (metres, CCW triangles; their neighbours,
    if known, e.g. an ADT surface's own adjacency)."""
    half = not config.full_jet
    given = triangles  # an ADT surface's are int32, as the point location takes them
    triangles = frozen(triangles, np.int64)
    raw = triangle_neighbors(triangles) if neighbors is None else neighbors
    mesh, points = kernel("sheet_prepare")(frozen(points, np.float64), triangles, frozen(raw, np.int64), half)
    xy, sx, sy, mass = _streamlet_arrays(config, resolution)
    start = locate_valid(points[:, :2], given, raw, xy, convex=convex)
    max_steps = MAX_STEPS_PER_TRIANGLE * triangles.shape[0] + 64
    jet = (sx, sy, mass, start.astype(np.int64), float(config.velocity), 4 * resolution)
    loss = _NO_LOSSES if losses is None else losses.as_array()
    rows = np.zeros((sx.size, codes.ROW_SIZE))
    trace = kernel("sheet_trace")
    common = (mesh, half, bool(convex), *jet, MIN_SPLIT_FRACTION, max_steps, loss)
    count = PIECES * max(1, resolution // (PIECES * RINGS_PER_PIECE))
    pieces = [functools.partial(trace, *common, j, count, rows) for j in range(count)]
    if progress is not None:
        pieces = _reporting(pieces, [len(range(j, sx.size, count)) for j in range(count)], progress)
    run(pieces)  # side by side: numba's kernel and the ahead-of-time one both release the GIL
    # the streamlets' rows added in order: the same sums whatever ran the pieces
    total = rows.sum(axis=0)
    values = total.tolist()
    if not all(map(math.isfinite, values[: codes.ROW_TALLY])):  # a safety net, never seen
        raise DegenerateInputError("the jet force is not finite: the surface has degenerate facets")
    tally = values[codes.ROW_TALLY :]
    if not tally[codes.TALLY_STREAMLETS_HIT]:  # it misses: tell a jet elsewhere from one too coarse

        def streamlets(finer: int) -> np.ndarray:
            return xy if finer == resolution else jet_streamlets.__wrapped__(config, finer)[0]  # not cached

        warn_if_too_coarse(
            points[:, :2],
            triangles,
            raw,
            convex,
            config,
            resolution,
            streamlets,
            MAX_RESOLUTION,
            stacklevel=3,
        )
        warn_if_units_differ(points[:, :2], triangles, config, stacklevel=3)
    total.flags.writeable = False  # before the views are taken: they inherit it
    force = total[codes.ROW_FORCE : codes.ROW_FORCE + 3]
    out = total[codes.ROW_OUT : codes.ROW_OUT + 3]
    return JetForce(
        force=force,
        momentum_out=out,
        mass_flow_total=config.mass_flow,
        mass_flow_hit=tally[codes.TALLY_MASS_HIT],
        mass_flow_out=tally[codes.TALLY_MASS_OUT],
        mass_flow_trapped=tally[codes.TALLY_MASS_TRAPPED],
        n_streamlets=int(mass.size),
        n_streamlets_hit=int(tally[codes.TALLY_STREAMLETS_HIT]),
        n_parcels=int(tally[codes.TALLY_PARCELS]),
        resolution=resolution,
        config=config,
    )


def _reporting(
    pieces: list[Callable[[], Any]], sizes: list[int], progress: Callable[[int], None]
) -> list[Callable[[], Any]]:
    """The pieces, each telling ``progress`` the streamlets traced so far once it has run (one
    call at a time, whichever thread ran the piece)."""
    lock = threading.Lock()
    done = [0]

    def piece(k: int) -> None:
        pieces[k]()
        with lock:
            done[0] += sizes[k]
            progress(done[0])

    return [functools.partial(piece, k) for k in range(len(pieces))]


def jet_force(
    points: ArrayLike,
    triangles: ArrayLike,
    config: JetConfig | None = None,
    *,
    resolution: int = DEFAULT_RESOLUTION,
    losses: SheetLosses | None = None,
    progress: Callable[[int], None] | None = None,
) -> JetForce:
    """Force of the water jet on a triangulated height-field surface.

    Parameters
    ----------
    points : array_like, shape (n, 3)
        Vertices in millimetres (the paper's unit).
    triangles : array_like of int, shape (m, 3)
        Any triangulation of a height field z(x, y): triangles must not overlap or stand
        vertically in the x-y projection; counter-clockwise in (x, y) (a mesh whose
        triangles are all clockwise is reversed). Vertices with equal coordinates are merged.
    config : JetConfig, optional
        The jet (default: the paper's half jet).
    resolution : int
        Rings of streamlets across the jet radius; the impact spreads into
        ``4 * resolution`` directions.
    losses : SheetLosses, optional
        Speed lost at creases and re-impacts (the surrogate of issue 11); default none: the
        thin-sheet model exactly.
    progress : callable, optional
        Called with the number of streamlets traced so far (of ``JetForce.n_streamlets``)
        as each piece of them finishes, one call at a time, from the thread that traced it.
        The pieces are finer at fine resolutions (``RINGS_PER_PIECE``); the force does not
        depend on them.

    Returns
    -------
    JetForce

    Raises
    ------
    InputError
        Non-finite coordinates, bad indices, a mesh that is not a height field over x-y, a
        surface outside the domain (or below y = 0 with the half jet), a bad resolution.

    Warns
    -----
    JetResolutionWarning
        The surface lies under the jet but no streamlet strikes it: the streamlets are coarser
        than the surface (the message names a resolution that puts streamlets on it).

    Notes
    -----
    Paper section 6 (the water-jet case study); the model is described in the module notes.
    A jet that misses the surface is not an error: its force is zero.
    """
    from replication.surfaces import as_cloud

    config = _default_config() if config is None else config
    resolution = _check_resolution(resolution)
    pts = to_metres(as_cloud(points, name="surface points"))
    try:
        tri = np.asarray(triangles)
    except (TypeError, ValueError) as exc:
        raise InputError(f"triangles must be integer vertex indices: {exc}") from exc
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0:
        raise InputError(f"triangles must have shape (m, 3) with m >= 1, got shape {tri.shape}")
    if not np.issubdtype(tri.dtype, np.integer):
        raise InputError(f"triangles must be integer vertex indices, got dtype {tri.dtype}")
    tri = np.array(tri, dtype=np.int64)  # a writable copy: one compiled signature
    if tri.min() < 0 or tri.max() >= pts.shape[0]:
        raise InputError(
            f"triangle vertex indices must lie in 0..{pts.shape[0] - 1}, got {tri.min()}..{tri.max()}"
        )
    check_domain(pts, config, np.unique(tri))
    pts, tri = weld(pts, tri)
    tri, convex = check_height_field(pts, tri)
    return _trace(pts, tri, convex, config, resolution, losses=losses, progress=progress)


def surface_force(
    surface: Surface, config: JetConfig | None = None, *, resolution: int = DEFAULT_RESOLUTION
) -> JetForce:
    """Force of the water jet on an ADT surface built with ``depth="z"`` (millimetres).

    An ADT surface is a Delaunay triangulation of its projection, so it is a valid height
    field over a convex footprint by construction and skips the mesh checks of
    :func:`jet_force`.

    Raises
    ------
    InputError
        Not a Surface, a depth axis other than z, a bad resolution.

    Warns
    -----
    JetResolutionWarning
        As :func:`jet_force`: no streamlet strikes the surface under the jet.

    Notes
    -----
    Paper section 6: the fitness of a surface in the genetic algorithm.
    """
    config = _default_config() if config is None else config
    resolution = _check_resolution(resolution)
    from replication.surfaces.adt import Surface

    if not isinstance(surface, Surface):  # (an array's "no attribute 'depth_axis'" named nothing)
        raise InputError(
            f"surface must be a Surface from adt(points, depth='z'), got {type(surface).__name__}; "
            "jet_force() takes any triangulated height field as points and triangles"
        )
    if surface.depth_axis != 2:
        raise InputError(
            f"the jet travels along -z, so the surface must be a height field over x-y (depth axis z), "
            f"got depth axis {surface.depth_axis_name}; build it with adt(points, depth='z')"
        )
    pts = to_metres(surface.points)
    bounds = (pts.min(axis=0), pts.max(axis=0))  # not finite when a coordinate is not (nan included)
    if not all(map(math.isfinite, [*bounds[0].tolist(), *bounds[1].tolist()])):
        raise InputError("surface points must be finite")
    check_domain(pts, config, bounds=bounds)
    return _trace(pts, surface.triangles, True, config, resolution, surface.neighbors)
