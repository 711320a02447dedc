"""NURBS surface files that carry everything a NURBS needs and that geomdl reads back.

``.smesh`` (headline, compact ASCII)
    geomdl's surface-mesh format: dimension, degrees, net size, the two knot vectors and
    every control point with its weight (x y z w), u varying fastest. geomdl's own writer
    prints 18 fixed decimals; this writer prints the shortest decimal that reads back to
    the same float64 (as the compact VTK writer does), so the file is complete, exact and as
    small as the format allows. Read back with ``geomdl.exchange.import_smesh``.
``.json``
    geomdl's JSON exchange format (``export_json``, indented), byte for byte as geomdl writes
    it (:func:`json_text`; tested against geomdl's writer) but without building a geomdl
    surface and without the pure-Python indenting encoder over every number: geomdl took
    11.7 s for the file of a million-point cloud's net. Read back with
    ``geomdl.exchange.import_json``.

geomdl's ``export_cfg`` is broken and its ``exchange_vtk`` writes vertices only, so neither
is used.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from replication.errors import CloudFileError, InputError
from replication.io.atomic import atomic_write_text
from replication.io.vtk import format_number, shortest_decimals
from replication.surfaces.nurbs import NurbsPatch

__all__ = ["NURBS_FORMATS", "json_text", "nurbs_format", "read_nurbs", "smesh_text", "write_nurbs"]

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


#: Placeholders for the two long lists of the JSON text, filled in by :func:`json_text`.
_POINTS, _WEIGHTS = "@@control points@@", "@@weights@@"


def json_text(patch: NurbsPatch) -> str:
    """The text geomdl's ``export_json`` writes for ``patch.to_geomdl()``.

    geomdl stores a NURBS's control points weighted (``x * w``) and exports them unweighted
    (``(x * w) / w``), normalises the knot vectors to [0, 1] through an 18-decimal rounding,
    and indents with ``json.dumps(indent=4)``; the same float64 operations give the same
    numbers here, and :func:`repr` the same decimals as the ``json`` module. The short parts
    go through ``json.dumps``; the control points and weights are joined in one pass.
    """
    import json

    from geomdl import NURBS, knotvector

    fresh = NURBS.Surface()  # geomdl's defaults that the file records (delta, rational)
    m_u, m_v = patch.net_shape
    weights = patch.weights.reshape(-1)
    with np.errstate(over="ignore"):
        weighted = patch.control_points.reshape(-1, 3) * weights[:, None]
    if not np.isfinite(weighted).all():  # geomdl would write Infinity: not JSON, and not the net
        k = int(np.flatnonzero(~np.isfinite(weighted).all(axis=1))[0])
        raise InputError(
            f"control point {k} times its weight overflows float64 (geomdl stores x * w): the net cannot "
            "be written as geomdl's JSON; write .smesh, which stores the points unweighted"
        )
    points = weighted / weights[:, None]
    surface = {
        "type": "spline",
        "rational": fresh.rational,
        "dimension": 3,
        "degree_u": patch.degree_u,
        "degree_v": patch.degree_v,
        "knotvector_u": knotvector.normalize(patch.knots_u.tolist()),
        "knotvector_v": knotvector.normalize(patch.knots_v.tolist()),
        "size_u": m_u,
        "size_v": m_v,
        "control_points": {"points": _POINTS, **({"weights": _WEIGHTS} if fresh.rational else {})},
        "delta": list(fresh.delta),
    }
    text = json.dumps({"shape": {"type": "surface", "count": 1, "data": [surface]}}, indent=4)
    indent = " " * (text.index(f'"points": "{_POINTS}"') - text.rindex("\n", 0, text.index(_POINTS)) - 1)
    inner, number = indent + " " * 4, indent + " " * 8
    row = f"{inner}[\n{number}{{}},\n{number}{{}},\n{number}{{}}\n{inner}]"
    x, y, z = (map(repr, points[:, k].tolist()) for k in range(3))
    listed = "[\n" + ",\n".join(map(row.format, x, y, z)) + f"\n{indent}]"
    text = text.replace(f'"{_POINTS}"', listed, 1)
    if fresh.rational:
        values = f",\n{inner}".join(map(repr, weights.tolist()))
        text = text.replace(f'"{_WEIGHTS}"', f"[\n{inner}{values}\n{indent}]", 1)
    return text


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
    """Write a NURBS patch atomically as ``.smesh`` or ``.json``; return the bytes written.

    ``patch`` may also be the :class:`~replication.surfaces.nurbs.NurbsSurface` that
    ``fit_nurbs`` returns (its ``patch`` is written).

    Raises
    ------
    InputError
        Not a NURBS, an unknown format, or a format that contradicts the file's suffix.
    """
    if not isinstance(patch, NurbsPatch) and isinstance(getattr(patch, "patch", None), NurbsPatch):
        patch = patch.patch  # the NurbsSurface of fit_nurbs
    if not isinstance(patch, NurbsPatch):
        raise InputError(
            f"write_nurbs takes a NurbsPatch or the NurbsSurface of fit_nurbs, got {type(patch).__name__}"
        )
    fmt = nurbs_format(path, fmt)
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix in NURBS_FORMATS and suffix != fmt:  # a file its name says is the other format
        raise InputError(f"{os.fspath(path)!r} names a .{suffix} file, but the format asked for is {fmt}")
    if fmt == "smesh":
        return atomic_write_text(path, smesh_text(patch))
    return atomic_write_text(path, json_text(patch))


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
