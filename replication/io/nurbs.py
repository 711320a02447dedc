"""NURBS surface files that carry everything a NURBS needs and that geomdl reads back.

``.smesh`` (headline, compact ASCII)
    geomdl's surface-mesh format: dimension, degrees, net size, the two knot vectors and
    every control point with its weight (x y z w), u varying fastest. geomdl's own writer
    prints 18 fixed decimals; this writer prints the shortest decimal that reads back to
    the same float64 (as the compact VTK writer does), so the file is complete, exact and as
    small as the format allows. Read back with ``geomdl.exchange.import_smesh``.
``.json``
    geomdl's JSON exchange format, written by geomdl itself (``export_json``, indented).

geomdl's ``export_cfg`` is broken and its ``exchange_vtk`` writes vertices only, so neither
is used.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from replication.errors import CloudFileError, InputError, OutputError
from replication.io.atomic import atomic_path, atomic_write_text
from replication.io.vtk import format_number, shortest_decimals
from replication.surfaces.nurbs import NurbsPatch

__all__ = ["NURBS_FORMATS", "nurbs_format", "read_nurbs", "smesh_text", "write_nurbs"]

NURBS_FORMATS: tuple[str, ...] = ("smesh", "json")


def smesh_text(patch: NurbsPatch, *, digits: int | None = None) -> str:
    """The compact smesh text of a NURBS patch.

    ``digits=None`` writes the shortest exact decimals; an integer writes that many
    significant digits (lossy, for comparisons at equal precision).
    """
    m_u, m_v = patch.net_shape
    if digits is None:
        numbers = shortest_decimals
    else:

        def numbers(values: np.ndarray) -> list[str]:
            return [format_number(float(f"{v:.{int(digits)}g}")) for v in np.ravel(values).tolist()]

    header = (
        f"3\n{patch.degree_u} {patch.degree_v}\n{m_u} {m_v}\n"
        f"{' '.join(numbers(patch.knots_u))}\n{' '.join(numbers(patch.knots_v))}\n"
    )
    points = patch.control_points.transpose(1, 0, 2).reshape(-1, 3)  # u varies fastest
    columns = [numbers(points[:, k]) for k in range(3)] + [numbers(patch.weights.T)]
    rows = "".join(map("{} {} {} {}\n".format, *columns))
    return header + rows + "1\n"  # geomdl's trailing flag (not read back)


def nurbs_format(path: str | os.PathLike[str], fmt: str | None = None) -> str:
    """The NURBS format named by ``fmt`` or by the suffix of ``path``."""
    if fmt is None:
        fmt = Path(path).suffix.lower().lstrip(".")
        if fmt not in NURBS_FORMATS:
            raise InputError(f"cannot tell the NURBS format from {str(path)!r}: use a .smesh or .json suffix")
    if fmt not in NURBS_FORMATS:
        raise InputError(f"unknown NURBS format {fmt!r}; choose one of {NURBS_FORMATS}")
    return fmt


def write_nurbs(patch: NurbsPatch, path: str | os.PathLike[str], fmt: str | None = None) -> int:
    """Write a NURBS patch atomically as ``.smesh`` or ``.json``; return the bytes written."""
    if nurbs_format(path, fmt) == "smesh":
        return atomic_write_text(path, smesh_text(patch))
    from geomdl import exchange
    from geomdl.exceptions import GeomdlException

    with atomic_path(path) as tmp:
        try:
            exchange.export_json(patch.to_geomdl(), str(tmp))
        except GeomdlException as exc:  # geomdl's own writer wraps the system's error (a full disk)
            cause = exc.__cause__ or exc.__context__
            if not isinstance(cause, OSError):  # any other error it wraps too: not a write's, raise it
                raise
            raise OutputError(f"cannot write {path}: {cause.strerror or cause}") from exc
        size = tmp.stat().st_size
    return size


def read_nurbs(path: str | os.PathLike[str], fmt: str | None = None) -> NurbsPatch:
    """Read a NURBS patch written by :func:`write_nurbs` (or by geomdl) with geomdl's readers."""
    from geomdl import exchange

    path = Path(path)
    if not path.is_file():
        raise CloudFileError(f"NURBS file not found: {path}")
    kind = nurbs_format(path, fmt)
    try:
        surfaces = exchange.import_smesh(str(path)) if kind == "smesh" else exchange.import_json(str(path))
        surf = surfaces[0]
        m_u, m_v = surf.ctrlpts_size_u, surf.ctrlpts_size_v
        points = np.asarray(surf.ctrlpts, dtype=np.float64).reshape(m_u, m_v, 3)
        weights = np.asarray(surf.weights if surf.rational else [1.0] * (m_u * m_v), dtype=np.float64)
        return NurbsPatch(
            degree_u=surf.degree_u,
            degree_v=surf.degree_v,
            knots_u=np.asarray(surf.knotvector_u, dtype=np.float64),
            knots_v=np.asarray(surf.knotvector_v, dtype=np.float64),
            control_points=points,
            weights=weights.reshape(m_u, m_v),
        )
    except InputError as exc:
        raise CloudFileError(f"{path}: not a valid NURBS surface ({exc})") from exc
    except Exception as exc:  # geomdl raises assorted types on malformed files
        raise CloudFileError(
            f"{path}: not a readable {kind} NURBS file ({type(exc).__name__}: {exc})"
        ) from exc
