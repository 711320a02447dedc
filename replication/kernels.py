"""Compile (or load from numba's on-disk cache) the package's compiled kernels, all at once.

Every kernel is compiled lazily on its first call, and numba caches the machine code next to
the sources, so only the first use in a fresh environment pays for compiling. Callers that
want that cost up front, in one place (the test suite's session start, ``replication
reproduce``, a benchmark setup), call :func:`warm_up`: it runs each kernel once on a tiny
input with the argument types the package uses. Importing this module compiles nothing.

Compiling everything takes about 31 s of one core in a fresh environment (measured on this
project's 2-core machine). numba compiles under the GIL, so ``warm_up(processes=2)`` compiles
the interpolation and jet kernels in a second Python process, into the same on-disk cache,
while this process compiles the triangulator and gridding, then loads the helper's kernels
from the cache (17.5 s in all). The helper starts only when the first kernels had to be
compiled: with a warm cache everything only loads (1.2 s).

Each group first loads numba's kernel of its entries of the ahead-of-time table
(:mod:`replication._aot`) by their one signature; the calls that follow then run numba's
code, and compile their callees. The two groups share only kernels that both compile with the
same argument types (the exact orientation predicate and its helpers; checked with numba's
compile events, each group alone on an empty cache), so both processes write the same cache
entry. Keep it so: numba's cache index is not locked, and two processes compiling one kernel
for different argument types at the same moment could mix up its entries.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

__all__ = ["release_threads", "warm_up"]

#: Seconds to wait for the helper process of ``warm_up(processes=2)``; after that this
#: process compiles what is missing itself (the helper is then stopped).
HELPER_TIMEOUT = 600.0


def warm_up(*, processes: int = 1) -> None:
    """Run every compiled kernel once on tiny inputs (compiling it or loading it from cache).

    Parameters
    ----------
    processes : int
        1: compile everything here. 2 or more: compile the interpolation and water-jet
        kernels in a helper process at the same time (see the module notes); if the helper
        fails, whatever it did not cache is compiled here, so the result is the same either way.
    """
    from numba.core import event

    with _duplicates_expected():
        with event.install_recorder("numba:compile") as compiled:
            bucket = _shared()  # first: both groups would otherwise compile these kernels
        cold = bool(compiled.buffer)  # a fresh cache (or changed sources): worth a second process
        helper = _start_helper() if processes > 1 and cold else None
        try:
            _triangulation()
            if helper is not None:
                try:
                    helper.wait(timeout=HELPER_TIMEOUT)
                except subprocess.TimeoutExpired:  # stuck: what it did not cache is compiled below
                    _stop(helper)
        except BaseException:  # Ctrl-C or an error here: the helper goes too
            if helper is not None:
                _stop(helper)
            raise
        _helper_group(bucket)  # loads what the helper cached; compiles whatever it did not


@contextlib.contextmanager
def _duplicates_expected() -> Iterator[None]:
    """The warm-up's lattice clouds merge points on purpose: no DuplicatePointsWarning."""
    import warnings

    from replication.errors import DuplicatePointsWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        yield


#: The kernels of :data:`replication._aot.KERNELS` that each group loads by their one
#: signature: numba's kernels of small clouds, once loaded, serve every later call instead
#: of the ahead-of-time ones, whose calls would compile nothing. Every kernel of the table is
#: in one group (tested).
TRIANGULATION_KERNELS = ("single", "column_spreads", "raster", "number", "gather", "renumber")
INTERPOLATION_KERNELS = ("locate", "barycentric", "exits", "nearest")
JET_KERNELS = ("sheet_prepare", "sheet_trace", "sheet_orientations", "sheet_first_overlap")


def _load(names: tuple[str, ...]) -> None:
    from replication import _aot

    for name in names:
        _aot.load_numba(name)


def _shared():
    """The kernels both groups use: a small ADT surface with the scipy backend (the jet
    kernels' test surface; about 2 s of compiling)."""
    from replication.surfaces import adt, random_cloud

    lattice = random_cloud(64, step=1.0, rng=0)
    return adt(lattice * [1.0, 1.0, 0.5], depth="z", backend="scipy")


def _triangulation() -> None:
    """The sweep-hull triangulator and the NURBS gridding."""
    import numpy as np

    from replication.surfaces import _partition, _raster, _triangulate, adt, random_cloud
    from replication.surfaces._threads import frozen
    from replication.surfaces.nurbs import fit_nurbs

    _load(TRIANGULATION_KERNELS)
    cloud = random_cloud(64, rng=0)
    lattice = random_cloud(64, step=1.0, rng=0)
    for points in (cloud, lattice):
        surface = adt(points)  # the one-call path for small clouds
        adt(points, backend="scipy")  # the hash grouping
        for levels in (0, 1):  # one block (general path), and blocks with merges and partition
            _triangulate._triangulate(frozen(points, np.float64), (0, 1), levels)
        _partition.magnitude(frozen(points, np.float64), (0, 1))  # the range check of clouds above SMALL
    # the pieces of a large gridding (no triangles here: the call compiles the kernel)
    xy, values, axis = frozen(surface.projected()), frozen(surface.points[:, 2]), frozen(np.arange(2.0))
    tri, nbr = frozen(surface.triangles, np.int32), frozen(surface.neighbors, np.int32)
    owner, out = np.full((2, 2), -1, dtype=np.int32), np.empty((2, 2))
    _raster._raster_shared(xy, tri, nbr, values, axis, axis, 0, 0, owner, out)
    fit_nurbs(lattice, evaluator="fast", triangulation=surface, tessellation=(4, 4))  # the last surface's


def _interpolation(surface) -> None:
    """The point location and interpolation kernels (the NURBS gridding's nearest fill too)."""
    import numpy as np

    from replication.surfaces.interpolate import fill_nearest, interpolate_linear, nearest_vertices

    _load(INTERPOLATION_KERNELS)
    uv = surface.projected()
    depth = surface.points[:, surface.depth_axis]
    far = uv.max(axis=0, keepdims=True) + 1.0  # outside the hull, as a grid node of the gridding
    fill_nearest(uv, surface.triangles, surface.neighbors, far, np.zeros(1, np.int32))
    interpolate_linear(uv, surface.triangles, depth, uv[:3] * 2, neighbors=surface.neighbors,
                       nearest_outside=True)  # fmt: skip
    interpolate_linear(uv, surface.triangles, depth, uv[:3], convex=False)
    nearest_vertices(uv, surface.triangles, surface.neighbors, uv[:3], np.zeros(3, np.int32))


def _jet(bucket) -> None:
    """The water-jet model's kernels, on a surface and on a bare mesh."""
    from replication.casestudy.jet import jet_force, surface_force

    _load(JET_KERNELS)
    surface_force(bucket)
    jet_force(bucket.points, bucket.triangles)


def _helper_group(bucket) -> None:
    """What the helper of ``warm_up(processes=2)`` compiles: the interpolation kernels first
    (this process's NURBS gridding loads two of them near its end), then the jet model's."""
    _interpolation(bucket)
    _jet(bucket)


def _helper_main() -> None:
    """The helper process of ``warm_up(processes=2)``: its group of kernels, into the cache."""
    with _duplicates_expected():
        _helper_group(_shared())


def _start_helper() -> subprocess.Popen | None:
    """Start the helper (same interpreter, environment and package); None if it cannot start.

    The package's own directory goes first on the helper's path: numba caches next to the
    sources, so a helper that imported another copy (a checkout in the working directory,
    say) would compile into the wrong cache.
    """
    root = str(Path(__file__).resolve().parents[1])
    code = f"import sys; sys.path.insert(0, {root!r}); import replication.kernels as k; k._helper_main()"
    try:
        return subprocess.Popen(
            [sys.executable, "-c", code],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except OSError:
        return None


def _stop(helper: subprocess.Popen) -> None:
    helper.kill()
    helper.wait()


def release_threads() -> None:
    """Stop the idle threads of the kernels' thread pool (they restart when next needed).

    Call it between stages of a long command: once only the main thread runs, the case
    study's worker processes are forked (milliseconds) rather than spawned (about a second
    each, issue 15).
    """
    from replication.surfaces._threads import release

    release()
