"""File sizes of ADT and NURBS surfaces in four representation families, over random clouds.

The paper (section 5, item 1) says ADT needs "almost half" the storage of NURBS without
saying how either file was written. A size ratio depends on the representation as much as
on the method, so this module measures both surfaces of every cloud in each family,
treating the two methods alike within a family:

``ascii_exact``
    shortest exact ASCII: compact legacy VTK for ADT, compact smesh for NURBS, every number
    with the shortest decimal that reads back to the same float64 (the headline formats).
``ascii_6``
    fixed precision ASCII: the same two formats with every number at 6 significant digits
    (C's ``%g``: trailing zeros dropped), the same digits for both methods.
``binary32``
    raw binary, complete files: ADT = two int32 counts, float32 x y z per vertex and int32
    indices per triangle; NURBS = four int32 (degrees, net size), float32 knots and float32
    x y z w per control point. Neither needs a rule to be read back.
``floor``
    the information floor in float32, assuming the reader knows the method: ADT stores its
    vertices only (the triangles are recomputed: ADT is a deterministic function of the
    points); NURBS stores its control net (x y z) and its knot vectors (weights are all 1
    and not stored). Were the knots recomputed too (they are clamped and uniform), NURBS
    would shrink by 4 bytes per knot; were the net's x, y recomputed from its uniform grid,
    it would need 4 bytes per control point plus 16.

Why the families disagree, in counts: an ADT file stores V <= n vertices (3 numbers each)
and about 2V triangles (3 indices each), about 9V numbers; a NURBS file with an n-point net
stores n control points (4 numbers each with the weight) and m_u + m_v + 2(p + 1) knots,
about 4n numbers. At equal bytes per number ADT is therefore about twice as large; it comes
out smaller only where its numbers are much shorter than NURBS's, as integer-millimetre
coordinates and small indices are in ASCII beside the long decimals of a gridded net.

Two kinds of coordinates are measured: the lattice clouds of the Table 1 experiment
(integer millimetres) and continuous clouds in the same box (points not on a lattice, as
scanned clouds are).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable
from concurrent.futures import Executor
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from replication.errors import DuplicatePointsWarning
from replication.experiments.timing import summarize
from replication.io.nurbs import smesh_text
from replication.io.vtk import legacy_vtk_text
from replication.surfaces import adt
from replication.surfaces.nurbs import fit_nurbs
from replication.surfaces.patch import NurbsPatch

__all__ = [
    "FAMILIES",
    "EQUAL_PRECISION",
    "COORDINATES",
    "storage_row",
    "ordered_map",
    "storage_monte_carlo",
    "storage_sizes",
    "summarize_storage",
]

#: (key, description) of each representation family, in report order.
FAMILIES: tuple[tuple[str, str], ...] = (
    ("ascii_exact", "shortest exact ASCII (legacy VTK / smesh)"),
    ("ascii_6", "ASCII at 6 significant digits (legacy VTK / smesh)"),
    ("binary32", "raw binary, float32 numbers and int32 indices, complete"),
    ("floor", "information floor, float32: ADT vertices / NURBS net + knots"),
)
#: Families in which both methods store their numbers at the same precision.
EQUAL_PRECISION: tuple[str, ...] = ("ascii_6", "binary32", "floor")
#: (key, description) of the kinds of coordinates.
COORDINATES: tuple[tuple[str, str], ...] = (
    ("lattice", "integer millimetres (1 mm lattice)"),
    ("continuous", "continuous (not on a lattice)"),
)
DIGITS = 6


def _point_text_bytes(points: np.ndarray, digits: int | None) -> int:
    """Bytes of the point lines of a compact legacy-VTK file (the rest is header and triangles)."""
    empty = np.zeros((0, 3), dtype=np.int64)
    return len(legacy_vtk_text(points, empty, digits=digits)) - len(legacy_vtk_text(points[:0], empty))


def storage_row(points: np.ndarray, triangles: np.ndarray, patch: NurbsPatch) -> dict[str, Any]:
    """Counts and bytes of one ADT surface and one NURBS patch in every family.

    Returns a flat dict: ``vertices``, ``triangles``, ``control_points``, ``knots``,
    ``adt_point_bytes_<family>`` for the ASCII families, and ``<family>_adt`` /
    ``<family>_nurbs`` bytes for every family.
    """
    n_v, n_t = int(points.shape[0]), int(triangles.shape[0])
    n_c = int(np.prod(patch.net_shape))
    n_k = int(patch.knots_u.size + patch.knots_v.size)
    row: dict[str, Any] = {"vertices": n_v, "triangles": n_t, "control_points": n_c, "knots": n_k}
    for family, digits in (("ascii_exact", None), ("ascii_6", DIGITS)):
        row[f"{family}_adt"] = len(legacy_vtk_text(points, triangles, digits=digits).encode())
        row[f"{family}_nurbs"] = len(smesh_text(patch, digits=digits).encode())
        row[f"adt_point_bytes_{family}"] = _point_text_bytes(points, digits)
    row["binary32_adt"] = 4 * 2 + 12 * n_v + 12 * n_t
    row["binary32_nurbs"] = 4 * 4 + 4 * n_k + 16 * n_c
    row["floor_adt"] = 12 * n_v
    row["floor_nurbs"] = 12 * n_c + 4 * n_k
    return row


def ordered_map(
    executor: Executor | None, function: Callable[[Any], Any], jobs: list[Any], chunksize: int = 1
) -> Iterable[Any]:
    """``function`` over ``jobs``, results in order: on ``executor``, or here, one after another,
    when it is None (a plain loop: Ctrl-C and errors stop it at once)."""
    return map(function, jobs) if executor is None else executor.map(function, jobs, chunksize=chunksize)


def storage_sizes(
    clouds: dict[str, Callable[[int, int], np.ndarray]], degree: int, job: tuple[int, int, str]
) -> dict[str, Any]:
    """The row of :func:`storage_monte_carlo` for one ``job = (n, replicate, coordinates)``.

    A function of its arguments alone, so that it runs the same in any process.
    """
    n, k, kind = job
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)  # a worker may be a fresh process
        cloud = clouds[kind](n, k)
        surface = adt(cloud)
        nurbs = fit_nurbs(cloud, degree=degree, tessellation=None, triangulation=surface)
    return {
        "n": n,
        "replicate": k,
        "coordinates": kind,
        **storage_row(surface.points, surface.triangles, nurbs.patch),
    }


def storage_monte_carlo(
    ns: Iterable[int],
    replicates: int,
    clouds: dict[str, Callable[[int, int], np.ndarray]],
    *,
    degree: int = 2,
    progress: Callable[[Iterable[Any], str, int], Iterable[Any]] | None = None,
    executor: Executor | None = None,
    chunksize: int = 1,
) -> pd.DataFrame:
    """Sizes of both surfaces in every family for ``replicates`` clouds per n and kind.

    Parameters
    ----------
    ns : iterable of int
        Point counts.
    replicates : int
        Clouds per n and kind of coordinates (replicates 1..replicates).
    clouds : dict
        Kind of coordinates -> ``cloud(n, replicate)`` returning an (n, 3) array (picklable
        when ``executor`` is a process pool).
    degree : int
        NURBS degree.
    progress : callable, optional
        ``progress(iterable, description, total)``.
    executor : concurrent.futures.Executor, optional
        Where the clouds are measured (default: here, one after another); the result is the
        same either way.
    chunksize : int
        Clouds per task of a process pool.

    Returns
    -------
    pandas.DataFrame
        One row per (n, replicate, coordinates) with the columns of :func:`storage_row`.

    Notes
    -----
    Paper section 5, item 1 (storage), and Table 1's file sizes.
    """
    jobs = [(n, k, kind) for k in range(1, replicates + 1) for n in ns for kind in clouds]
    measure = partial(storage_sizes, clouds, degree)
    rows: Iterable[dict[str, Any]] = ordered_map(executor, measure, jobs, chunksize)
    if progress is not None:
        rows = progress(rows, f"storage in {len(FAMILIES)} families", len(jobs))
    frame = pd.DataFrame(list(rows))
    return frame.sort_values(["coordinates", "n", "replicate"], kind="stable", ignore_index=True)


def summarize_storage(raw: pd.DataFrame) -> pd.DataFrame:
    """Per (n, coordinates, family): median bytes of each method, the ratio ADT / NURBS
    (median, quartiles and count over the clouds) and the median counts behind them."""
    rows = []
    for (kind, n), group in raw.groupby(["coordinates", "n"], sort=False):
        counts = {c: float(group[c].median()) for c in ("vertices", "triangles", "control_points", "knots")}
        for family, _ in FAMILIES:
            ratio = summarize(group[f"{family}_adt"] / group[f"{family}_nurbs"])
            row = {"n": n, "coordinates": kind, "family": family,
                   "adt_bytes": float(group[f"{family}_adt"].median()),
                   "nurbs_bytes": float(group[f"{family}_nurbs"].median()),
                   "ratio": ratio["median"], "ratio_q1": ratio["q1"], "ratio_q3": ratio["q3"],
                   "count": ratio["count"], **counts}  # fmt: skip
            if f"adt_point_bytes_{family}" in group:
                row["adt_point_bytes"] = float(group[f"adt_point_bytes_{family}"].median())
            rows.append(row)
    return pd.DataFrame(rows)
