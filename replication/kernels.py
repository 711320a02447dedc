"""Compile (or load from numba's on-disk cache) the package's compiled kernels, all at once.

Every kernel is compiled lazily on its first call, and numba caches the machine code next to
the sources, so only the first use in a fresh environment pays for compiling. Callers that
want that cost up front, in one place (the test suite's session start, a benchmark setup),
call :func:`warm_up`: it runs each kernel once on a tiny input with the argument types the
package uses. Importing this module compiles nothing.
"""

from __future__ import annotations

__all__ = ["release_threads", "warm_up"]


def warm_up() -> None:
    """Run every compiled kernel once on tiny inputs (compiling it or loading it from cache)."""
    import warnings

    import numpy as np

    from replication.casestudy.jet import jet_force, surface_force
    from replication.errors import DuplicatePointsWarning
    from replication.surfaces import _raster, _triangulate, adt, random_cloud
    from replication.surfaces._threads import frozen
    from replication.surfaces.interpolate import interpolate_linear, nearest_vertices
    from replication.surfaces.nurbs import fit_nurbs

    cloud = random_cloud(64, rng=0)
    lattice = random_cloud(64, step=1.0, rng=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        for points in (cloud, lattice):
            surface = adt(points)  # the one-call path for small clouds
            adt(points, backend="scipy")  # the hash grouping
            for levels in (0, 1):  # one block (general path), and blocks with merges and partition
                _triangulate._triangulate(frozen(points, np.float64), (0, 1), levels)
        owners = tuple(np.full((2, 2), -1, dtype=np.int32) for _ in range(_raster._RUNS))
        _raster._combine(owners, tuple(np.zeros((2, 2)) for _ in range(_raster._RUNS)), 0, 2)
        fit_nurbs(cloud, evaluator="fast", triangulation=surface, tessellation=(4, 4))
        uv = surface.projected()
        depth = surface.points[:, surface.depth_axis]
        interpolate_linear(uv, surface.triangles, depth, uv[:3] * 2, neighbors=surface.neighbors,
                           nearest_outside=True)  # fmt: skip
        interpolate_linear(uv, surface.triangles, depth, uv[:3], convex=False)
        nearest_vertices(uv, surface.triangles, surface.neighbors, uv[:3], np.zeros(3, np.int32))
        bucket = adt(lattice * [1.0, 1.0, 0.5], depth="z")
        surface_force(bucket)
        jet_force(bucket.points, bucket.triangles)


def release_threads() -> None:
    """Stop the idle threads of the kernels' thread pool (they restart when next needed).

    Call it between stages of a long command: once only the main thread runs, the case
    study's worker processes are forked (milliseconds) rather than spawned (about a second
    each, issue 15).
    """
    from replication.surfaces._threads import release

    release()
