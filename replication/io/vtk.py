"""Triangle-surface files: compact legacy VTK (ASCII) and binary VTK XML (``.vtp``).

The paper's ADT files are VTK (section 5, item 5) and their sizes are compared with NURBS
files in Table 1, so the legacy writer is deliberately compact: a four-line header, one
``x y z`` line per vertex with the shortest decimal representation that reads back to the
same float64 (``3`` rather than ``3.0``), and one ``3 a b c`` line per triangle. Points are
declared ``double`` so that the round trip through VTK is exact.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np

from replication.errors import CloudFileError, InputError, OutputError, escaped, shortened
from replication.io.atomic import atomic_path, atomic_write_text
from replication.io.paths import dangling, lookup
from replication.io.vtkload import vtk_imports

__all__ = [
    "SURFACE_FORMATS",
    "TriangleMesh",
    "format_number",
    "legacy_vtk_text",
    "shortest_decimals",
    "read_surface",
    "surface_format",
    "write_surface",
    "write_vtk",
    "write_vtp",
]

SurfaceFormat = Literal["vtk", "vtp"]
SURFACE_FORMATS: tuple[str, ...] = ("vtk", "vtp")


class TriangleMesh(Protocol):
    """Anything with ``points`` (n, 3) and ``triangles`` (m, 3): a Surface or ClosedSurface."""

    points: np.ndarray
    triangles: np.ndarray


def _strip_zero(text: str) -> str:
    return text[:-2] if text.endswith(".0") else text


def format_number(value: float) -> str:
    """Shortest text that reads back to the same float64, without a trailing ``.0``."""
    return _strip_zero(repr(float(value)))


def shortest_decimals(values: np.ndarray) -> list[str]:
    """:func:`format_number` of every value, formatted by one C-level ``repr`` of the list.

    Python's ``repr`` of a list of floats prints each with the shortest round-trip decimal,
    separated by ``", "``; only a token's end can be ``.0`` before a separator, so stripping
    it there gives the same text as formatting value by value, 2-3x faster.
    """
    flat = np.asarray(values, dtype=np.float64).ravel()
    if flat.size == 0:
        return []
    return repr(flat.tolist())[1:-1].replace(".0, ", ", ").removesuffix(".0").split(", ")


def legacy_vtk_text(
    points: np.ndarray, triangles: np.ndarray, *, title: str = "ADT surface", digits: int | None = None
) -> str:
    """The compact legacy-VTK (version 3.0, ASCII, POLYDATA) text of a triangle mesh.

    ``digits=None`` writes the shortest exact decimals; an integer writes that many
    significant digits (``%g``), a lossy variant used to compare formats at equal precision.
    """
    points = np.asarray(points, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"points must have shape (n, 3), got {points.shape}")
    if triangles.ndim != 2 or triangles.shape[1] != 3:
        raise InputError(f"triangles must have shape (m, 3), got {triangles.shape}")
    if "\n" in title or len(title) > 255:
        raise InputError(f"a VTK title is one line of at most 255 characters, got {title!r}")
    header = (
        f"# vtk DataFile Version 3.0\n{title}\nASCII\nDATASET POLYDATA\nPOINTS {points.shape[0]} double\n"
    )
    # column-wise formatting: about 3x faster than formatting point by point
    if digits is None:
        columns = [shortest_decimals(points[:, k]) for k in range(3)]
    else:
        number = f"{{:.{int(digits)}g}}".format
        columns = [[_strip_zero(v) for v in map(number, points[:, k].tolist())] for k in range(3)]
    point_lines = "".join(map("{} {} {}\n".format, *columns))
    polygons = f"POLYGONS {triangles.shape[0]} {4 * triangles.shape[0]}\n"
    triangle_lines = "".join(map("3 {} {} {}\n".format, *triangles.T.tolist()))
    return header + point_lines + polygons + triangle_lines


def _mesh(mesh: TriangleMesh, path: str | os.PathLike[str], fmt: SurfaceFormat) -> TriangleMesh:
    """``mesh`` if it has points and triangles and ``path``'s suffix does not name the other format.

    An array, a NURBS or a file name whose suffix says the other format gave an AttributeError
    or a file that :func:`read_surface` could not open (XML in a ``.vtk`` file).
    """
    if not (hasattr(mesh, "points") and hasattr(mesh, "triangles")):
        hint = (
            "; a NURBS is written with write_nurbs()"
            if hasattr(mesh, "patch") or hasattr(mesh, "net_shape")
            else "; a point cloud with save_cloud()"
            if isinstance(mesh, np.ndarray)
            else ""
        )
        raise InputError(
            "a surface to write needs points and triangles (a Surface from adt()), got "
            f"{type(mesh).__name__}{hint}"
        )
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix in SURFACE_FORMATS and suffix != fmt:
        raise InputError(
            f"{os.fspath(path)!r} names a .{suffix} file, but the format written is {fmt} "
            f"({'legacy VTK' if fmt == 'vtk' else 'VTK XML'}): name it .{fmt}, or use write_{suffix}()"
        )
    return mesh


def write_vtk(mesh: TriangleMesh, path: str | os.PathLike[str], *, title: str = "ADT surface") -> int:
    """Write a compact legacy-VTK ASCII file atomically; return its size in bytes.

    Raises
    ------
    InputError
        ``mesh`` without points and triangles, or a ``.vtp`` file name.
    """
    mesh = _mesh(mesh, path, "vtk")
    return atomic_write_text(path, legacy_vtk_text(mesh.points, mesh.triangles, title=title))


def write_vtp(
    mesh: TriangleMesh,
    path: str | os.PathLike[str],
    *,
    compress: bool = False,
) -> int:
    """Write a binary VTK XML PolyData (``.vtp``) file atomically; return its size in bytes.

    The data are appended raw (not base64), 64-bit headers; ``compress=True`` adds zlib
    compression (half the size, about 30x slower). Raw writing of a 1e6-point surface takes
    about 0.1 s.
    """
    mesh = _mesh(mesh, path, "vtp")
    with vtk_imports():
        from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
        from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    points = np.ascontiguousarray(mesh.points, dtype=np.float64)
    triangles = np.asarray(mesh.triangles, dtype=np.int64)
    vtk_points = vtkPoints()
    vtk_points.SetData(numpy_to_vtk(points, deep=True))
    cells = vtkCellArray()
    offsets = np.arange(0, 3 * triangles.shape[0] + 1, 3, dtype=np.int64)
    cells.SetData(
        numpy_to_vtkIdTypeArray(offsets, deep=True),
        numpy_to_vtkIdTypeArray(np.ascontiguousarray(triangles.ravel()), deep=True),
    )
    poly = vtkPolyData()
    poly.SetPoints(vtk_points)
    poly.SetPolys(cells)
    writer = vtkXMLPolyDataWriter()
    writer.SetInputData(poly)
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetHeaderTypeToUInt64()
    if compress:
        writer.SetCompressorTypeToZLib()
    else:
        writer.SetCompressorTypeToNone()
    with atomic_path(path) as tmp:
        if _vtk_can_name(tmp):
            _vtk_write(writer, tmp, path)
        else:  # VTK takes UTF-8 names only: write elsewhere, then copy the bytes in
            with tempfile.TemporaryDirectory(prefix="replication-vtp-") as scratch:
                staged = Path(scratch) / "surface.vtp"
                _vtk_write(writer, staged, path)
                tmp.write_bytes(staged.read_bytes())
        size = tmp.stat().st_size
    return size


def _vtk_can_name(path: Path) -> bool:
    """Whether VTK, which takes file names as UTF-8 text, can open ``path`` by name.

    A file name that is not valid UTF-8 (bytes that Python carries as surrogate escapes)
    cannot be passed to VTK at all.
    """
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _vtk_write(writer: object, target: Path, path: str | os.PathLike[str]) -> None:
    """Write with VTK, its messages silenced; a failure is one line with VTK's first reason."""
    writer.SetFileName(str(target))  # type: ignore[attr-defined]
    with _vtk_messages() as messages:
        done = writer.Write()  # type: ignore[attr-defined]
    if done != 1:
        raise OutputError(f"VTK could not write {path}: {_write_failure(writer.GetErrorCode(), messages)}")  # type: ignore[attr-defined]


def _write_failure(code: int, messages: list[str]) -> str:
    """Why a VTK writer failed: its error code (an errno below VTK's own codes), else its message."""
    import re

    with vtk_imports():
        from vtkmodules.vtkCommonMisc import vtkErrorCode

    if 0 < code < vtkErrorCode.FirstVTKErrorCode:  # VTK passes the system's errno on
        return os.strerror(code)
    if code:  # "OutOfDiskSpaceError" -> "out of disk space"
        name = vtkErrorCode.GetStringFromErrorCode(code).removesuffix("Error")
        return re.sub(r"(?<!^)(?=[A-Z])", " ", name).lower()
    return messages[0] if messages else "no reason given"


def surface_format(path: str | os.PathLike[str], fmt: str | None = None) -> SurfaceFormat:
    """The surface format named by ``fmt`` or, if ``None``, by the suffix of ``path``."""
    if fmt is None:
        fmt = Path(path).suffix.lower().lstrip(".")
        if fmt not in SURFACE_FORMATS:
            raise InputError(
                f"cannot tell the surface format from {str(path)!r}: use a .vtk or .vtp suffix "
                "or name the format"
            )
    if fmt not in SURFACE_FORMATS:
        raise InputError(f"unknown surface format {fmt!r}; choose one of {SURFACE_FORMATS}")
    return fmt  # type: ignore[return-value]


def write_surface(mesh: TriangleMesh, path: str | os.PathLike[str], fmt: str | None = None) -> int:
    """Write a surface as legacy VTK (``.vtk``) or VTK XML (``.vtp``); return bytes written.

    A ``fmt`` that contradicts the suffix (``fmt="vtp"`` for ``x.vtk``) is refused: the file
    would be misread by every reader that goes by the suffix, :func:`read_surface` included.
    """
    if surface_format(path, fmt) == "vtk":
        return write_vtk(mesh, path)
    return write_vtp(mesh, path)


@contextlib.contextmanager
def _vtk_messages() -> Iterator[list[str]]:
    """Silence VTK (its output window and its logger) and collect its error messages.

    Without this a malformed file makes VTK print several coloured log lines (and
    multi-line pipeline dumps) on stderr before the one-line error this package reports.
    """
    with vtk_imports():
        from vtkmodules.vtkCommonCore import vtkLogger, vtkOutputWindow, vtkStringOutputWindow

    previous = vtkOutputWindow.GetInstance()
    window = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(window)
    cutoff = vtkLogger.GetCurrentVerbosityCutoff()
    messages: list[str] = []
    try:
        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)  # what pyvista.vtk_verbosity("off") does
        yield messages
    finally:
        vtkLogger.SetStderrVerbosity(cutoff)
        vtkOutputWindow.SetInstance(previous)
        text = window.GetOutput()
        if isinstance(text, bytes):  # not UTF-8: VTK quotes the bytes of a file that is not text
            text = text.decode("utf-8", errors="backslashreplace")
        for block in text.split("\n\n"):
            lines = [line.strip() for line in block.strip().splitlines()]
            if len(lines) >= 2 and lines[0].startswith("ERROR"):
                # one line, not too long: random bytes quoted as the "file type" filled the terminal
                messages.append(shortened(escaped(lines[1].split("): ", 1)[-1]), head=100, tail=40))


def _cells(mesh: Any) -> str:
    """What a mesh that is not all triangles holds, in words ("10 vertex cell(s) (points, not faces)")."""
    with vtk_imports():
        from vtkmodules.util.numpy_support import vtk_to_numpy

    kinds = []
    for count, kind in ((mesh.n_verts, "vertex cell(s) (points, not faces)"), (mesh.n_lines, "line(s)"),
                        (mesh.n_strips, "triangle strip(s)")):  # fmt: skip
        if count:
            kinds.append(f"{count} {kind}")
    sizes = np.bincount(np.diff(vtk_to_numpy(mesh.GetPolys().GetOffsetsArray())).astype(np.int64))
    kinds += [f"{c} triangle(s)" if n == 3 else f"{c} polygon(s) of {n} corners"
              for n, c in enumerate(sizes) if c]  # fmt: skip
    return ", ".join(kinds) or "no faces"


#: How far a polygon's corners may lie from its plane, relative to its size, for it to count as
#: flat: cut either way, such a polygon gives surfaces that differ by less than a millionth of
#: its size (a quad written with 6 significant digits bends by about 1e-6 of it).
FLAT_POLYGON = 1e-6
#: ... or, for coordinates far from the origin, this many units of the points' own precision
#: (float32 points carry about 1e-7 of their magnitude, float64 2e-16).
FLAT_ROUNDING = 64


def _bends(
    points: np.ndarray, offsets: np.ndarray, connectivity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each polygon's largest distance of a corner from its plane, over its size (0 for a flat one).

    The plane is the one through the corners' centroid with Newell's normal (computed from the
    corners less their centroid, so that coordinates far from the origin do not cancel), which
    is the normal of a flat polygon of any shape (convex or not) and the best plane of a warped
    quad. Returns the cells of more than three corners, their bends, the largest coordinate
    magnitude of each over its size (what the points' rounding is relative to), and the area
    each encloses (half the length of Newell's normal).
    """
    sizes = np.diff(offsets)
    cells = np.flatnonzero(sizes > 3)
    bends, magnitudes, areas = np.zeros(cells.size), np.zeros(cells.size), np.zeros(cells.size)
    for corners in np.unique(sizes[cells]):  # one vectorised pass per number of corners
        which = sizes[cells] == corners
        p = points[connectivity[offsets[cells[which]][:, None] + np.arange(corners)]]  # (m, corners, 3)
        centred = p - p.mean(axis=1, keepdims=True)
        normal = np.cross(centred, np.roll(centred, -1, axis=1)).sum(axis=1)
        length = np.linalg.norm(normal, axis=1)
        areas[which] = length / 2  # the area the corners enclose (lobes of a bow tie cancel)
        unit = np.divide(normal, length[:, None], out=np.zeros_like(normal), where=length[:, None] > 0)
        away = np.abs(np.einsum("mkd,md->mk", centred, unit)).max(axis=1)
        extent = np.linalg.norm(p.max(axis=1) - p.min(axis=1), axis=1)
        bends[which] = np.divide(away, extent, out=np.zeros_like(away), where=extent > 0)
        magnitudes[which] = np.divide(
            np.abs(p).max(axis=(1, 2)), extent, out=np.zeros_like(away), where=extent > 0
        )
    return cells, bends, magnitudes, areas


def _as_triangles(path: Path, mesh: Any) -> Any:
    """A mesh of triangles, flat polygons and triangle strips, cut into triangles.

    A strip is a list of triangles, and a flat polygon is the same surface however it is cut,
    so both are read. A polygon whose corners do not lie in one plane (a warped quad) has no
    one surface: which diagonal cuts it decides where the water goes, so it is refused, as
    are vertex and line cells (points and curves, not faces) and polygons of fewer than three
    corners. Flat means within :data:`FLAT_POLYGON` of the polygon's size, or within
    :data:`FLAT_ROUNDING` units of the points' precision (float32 or float64).
    """
    with vtk_imports():
        from vtkmodules.util.numpy_support import vtk_to_numpy

    polys = mesh.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray()).astype(np.int64)
    if mesh.n_verts or mesh.n_lines or (np.diff(offsets) < 3).any():
        raise CloudFileError(
            f"{path}: the surface must consist of faces of three or more corners; it holds {_cells(mesh)}"
        )
    connectivity = vtk_to_numpy(polys.GetConnectivityArray()).astype(np.int64)
    raw = np.asarray(mesh.points)
    eps = float(np.finfo(raw.dtype).eps) if raw.dtype.kind == "f" else float(np.finfo(np.float64).eps)
    cells, bends, magnitudes, areas = _bends(np.asarray(raw, dtype=np.float64), offsets, connectivity)
    warped = bends > np.maximum(FLAT_POLYGON, FLAT_ROUNDING * eps * magnitudes)
    if warped.any():
        first = int(np.argmax(warped))
        raise CloudFileError(
            f"{path}: {int(warped.sum())} of its {cells.size} polygon(s) of more than 3 corners are not flat "
            f"(cell {int(cells[first])}, counted from 0, bends by {bends[first]:.2g} of its size), so the "
            "surface between their corners depends on how they are cut into triangles: triangulate the "
            "mesh as you mean it (pyvista: mesh.triangulate())"
        )
    cut = mesh.triangulate()
    strips = vtk_to_numpy(mesh.GetStrips().GetOffsetsArray()).astype(np.int64)
    made = int((np.diff(offsets) - 2).sum() + (np.diff(strips) - 2).sum())  # n - 2 per face or strip
    if cut.n_cells != made or not cut.is_all_triangles:  # VTK drops a polygon it cannot cut
        raise CloudFileError(
            f"{path}: its faces make {made} triangle(s), but only {cut.n_cells} could be cut from them: a "
            "polygon crosses itself or repeats its corners; triangulate the mesh as you mean it (pyvista: "
            "mesh.triangulate())"
        )
    _check_cut_areas(path, cut, np.diff(offsets), cells, areas)
    return cut


def _check_cut_areas(path: Path, cut: Any, sizes: np.ndarray, cells: np.ndarray, areas: np.ndarray) -> None:
    """Refuse polygons whose triangles cover another area than the polygon encloses.

    VTK cuts the polygons in their order, ``n - 2`` triangles each, before the strips; a
    polygon that crosses itself (a bow tie) encloses less than its triangles cover, and its
    triangles overlap or turn clockwise, which the force model would blame on a triangle the
    file never held.
    """
    made = int((sizes - 2).sum())
    tri = np.asarray(cut.faces, dtype=np.int64).reshape(-1, 4)[:made, 1:]
    p = np.asarray(cut.points, dtype=np.float64)
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    cover = np.linalg.norm(np.cross(b - a, c - a), axis=1) / 2
    covered = np.bincount(np.repeat(np.arange(sizes.size), sizes - 2), weights=cover, minlength=sizes.size)
    wrong = np.abs(covered[cells] - areas) > FLAT_POLYGON * covered[cells]
    if wrong.any():
        first = int(np.argmax(wrong))
        raise CloudFileError(
            f"{path}: {int(wrong.sum())} polygon(s) cross themselves (cell {int(cells[first])}, counted "
            f"from 0, encloses an area of {areas[first]:.3g} but its triangles cover "
            f"{covered[cells[first]]:.3g}); "
            "triangulate the mesh as you mean it (pyvista: mesh.triangulate())"
        )


def read_surface(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle surface (``.vtk`` or ``.vtp``) with VTK; return (points, triangles).

    VTK's own messages are not printed; the first of them is quoted in the error.

    Raises
    ------
    CloudFileError
        Missing or unreadable file, or a mesh that is not made of faces that are triangles,
        triangle strips or flat polygons (those are cut into triangles; see
        :func:`_as_triangles`).
    """
    with vtk_imports():
        import pyvista as pv
        from vtkmodules.vtkIOLegacy import vtkPolyDataReader
        from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    if not os.fspath(path):
        raise CloudFileError("no surface file named: the file name is empty")
    path = Path(path)
    found = lookup(path, CloudFileError, "cannot read the surface file")
    if found.is_dir:
        raise CloudFileError(f"expected a surface file, got a directory: {path}")
    if not found.is_file:
        raise CloudFileError(f"surface file not found: {path}{dangling(path)}")
    reader = vtkPolyDataReader() if surface_format(path) == "vtk" else vtkXMLPolyDataReader()
    with contextlib.ExitStack() as stack:
        source = path
        if not _vtk_can_name(path):  # VTK takes UTF-8 names only: read a copy
            scratch = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="replication-vtk-")))
            source = scratch / f"surface{path.suffix.lower()}"
            shutil.copyfile(path, source)
        messages = stack.enter_context(_vtk_messages())
        reader.SetFileName(str(source))
        reader.Update()
        output = reader.GetOutput()
    why = f" (VTK: {messages[0]})" if messages else ""
    if messages or output is None:
        raise CloudFileError(f"{path}: not a readable VTK surface{why}")
    mesh = pv.wrap(output)
    if not isinstance(mesh, pv.PolyData) or mesh.n_points == 0:
        raise CloudFileError(f"{path}: no surface (points and triangles) in the file{why}")
    if mesh.n_cells == 0:
        raise CloudFileError(f"{path}: points but no triangles in the file (is it cut short?){why}")
    if mesh.n_strips or not mesh.is_all_triangles:  # (pyvista calls triangles and strips "all triangles")
        mesh = _as_triangles(path, mesh)
    points = np.asarray(mesh.points, dtype=np.float64)
    triangles = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 4)[:, 1:]
    return points, triangles
