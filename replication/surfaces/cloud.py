"""Point clouds: random clouds in a box (paper eq. 1-4) and validation of user clouds."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import astuple, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import CloudFileError, CloudFileWarning, InputError, shortened, shown

__all__ = [
    "Box",
    "CASE_STUDY_BOX",
    "MAX_LATTICE_VALUES",
    "as_cloud",
    "lattice_count",
    "lattice_values",
    "make_rng",
    "random_cloud",
    "underflow",
    "RNGLike",
]

RNGLike = int | np.random.Generator | None


@dataclass(frozen=True)
class Box:
    """Axis-aligned domain ``[xmin, xmax] x [ymin, ymax] x [zmin, zmax]`` (paper eq. 1).

    A zero-width side (``min == max``) is allowed: every point then has that coordinate.
    """

    xmin: float
    xmax: float
    ymin: float
    ymax: float
    zmin: float
    zmax: float

    def __post_init__(self) -> None:
        values = astuple(self)
        if not all(np.isfinite(values)):
            raise InputError(f"box bounds must be finite, got {values}")
        for name, lo, hi in zip("xyz", values[0::2], values[1::2]):
            if lo > hi:
                raise InputError(f"box has {name}min > {name}max: {lo} > {hi}")

    @classmethod
    def from_bounds(cls, bounds: Sequence[float]) -> Box:
        """Build from ``(xmin, xmax, ymin, ymax, zmin, zmax)``."""
        values = tuple(float(b) for b in bounds)
        if len(values) != 6:
            raise InputError(f"a box needs 6 bounds (xmin xmax ymin ymax zmin zmax), got {len(values)}")
        return cls(*values)

    @property
    def lower(self) -> np.ndarray:
        return np.array([self.xmin, self.ymin, self.zmin])

    @property
    def upper(self) -> np.ndarray:
        return np.array([self.xmax, self.ymax, self.zmax])


#: The case study's domain in millimetres (paper section 6): 36 x 30 x 13 mm.
CASE_STUDY_BOX = Box(0.0, 36.0, 0.0, 30.0, 0.0, 13.0)


#: Most lattice values per axis: beyond 2^53 the indices k are no longer exact in float64.
MAX_LATTICE_VALUES = 2**53


def lattice_count(lo: float, hi: float, step: float) -> int:
    """Number of lattice coordinates ``lo + k * step`` inside ``[lo, hi]`` (k = 0, 1, ...)."""
    if not (np.isfinite(step) and step > 0):
        raise InputError(f"discretisation step must be positive and finite, got {step=}")
    with np.errstate(over="ignore"):  # a step of 5e-324: an infinite count, named below
        last = np.floor((hi - lo) / step * (1 + 1e-12) + 1e-9)
    if not last < MAX_LATTICE_VALUES:
        count = f"{last + 1:.3g}" if np.isfinite(last) else "more than 1.8e308"
        raise InputError(
            f"discretisation step {step:g} is too fine for the range [{lo:g}, {hi:g}]: "
            f"{count} lattice values, at most 2^53 per axis"
        )
    return int(last) + 1


def lattice_values(lo: float, hi: float, step: float) -> np.ndarray:
    """Lattice coordinates ``lo + k * step`` inside ``[lo, hi]`` (k = 0, 1, ...)."""
    return lo + step * np.arange(lattice_count(lo, hi, step))


def random_cloud(
    n: int,
    box: Box = CASE_STUDY_BOX,
    *,
    step: float | None = None,
    rng: RNGLike = None,
) -> np.ndarray:
    """Draw ``n`` random points in ``box``, continuous or on a lattice.

    Parameters
    ----------
    n : int
        Number of points (paper eq. 2), at least 1.
    box : Box or sequence of 6 floats
        The domain (paper eq. 1), or its bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)``;
        default the case study's 36 x 30 x 13 mm.
    step : float, optional
        Discretisation step: coordinates are drawn uniformly from the lattice
        ``min + k * step`` inside the box (the case study uses 1 mm). ``None`` draws
        continuous uniform coordinates.
    rng : int, numpy.random.Generator or None
        Seed or generator; ``np.random.default_rng(rng)`` is called once.

    Returns
    -------
    ndarray of float64, shape (n, 3)

    Notes
    -----
    Paper section 3.2, steps 1-3, eq. 1-4: each coordinate is drawn independently and
    uniformly; repeated draws of the same lattice node are possible (they are merged by ADT
    according to its duplicate policy).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"number of points must be a positive integer, got {n=!r}")
    if not isinstance(box, Box):
        if isinstance(box, (str, bytes)) or not isinstance(box, Sequence | np.ndarray):
            raise InputError(
                f"box must be a Box or its 6 bounds (xmin, xmax, ymin, ymax, zmin, zmax), got {box!r}"
                + ("; a seed goes in rng=" if isinstance(box, (int, np.integer, np.random.Generator)) else "")
            )
        box = Box.from_bounds(box)
    gen = make_rng(rng)
    lo, hi = box.lower, box.upper
    with np.errstate(over="ignore"):
        wide = np.flatnonzero(~np.isfinite(hi - lo))
    if wide.size:  # lo + (hi - lo) * u would be inf or NaN
        k = int(wide[0])
        raise InputError(
            f"the box's {'xyz'[k]} side {lo[k]:g}..{hi[k]:g} is wider than float64's largest number "
            f"({np.finfo(np.float64).max:.4g}): no point can be drawn in it"
        )
    if step is None:
        return lo + (hi - lo) * gen.random((int(n), 3))
    columns = []
    for axis in range(3):  # lattice_values(...)[k] without the lattice (fine steps make it huge)
        count = lattice_count(lo[axis], hi[axis], step)
        columns.append(lo[axis] + step * gen.integers(0, count, size=int(n)))
    return np.column_stack(columns)


def make_rng(rng: RNGLike) -> np.random.Generator:
    """``np.random.default_rng(rng)``, with an InputError naming a bad seed
    (:func:`replication.params.generator`)."""
    from replication.params import generator

    return generator(rng)


#: numpy kinds that numpy converts to float64 silently but that are no coordinates.
_NOT_COORDINATES = {"b": "booleans", "M": "dates and times", "m": "time spans"}


def _named_columns(points: object, name: str) -> object:
    """A pandas DataFrame or a structured array as its three columns in x, y, z order.

    Column and field names say which is which axis by the rules of a cloud file's header
    (:func:`replication.io.axisnames.axis_order`): a frame with columns ``z, x, y`` is the
    same cloud as a ``.csv`` headed ``z,x,y`` or a ``.npy`` with fields ``z, x, y`` (its
    columns were taken in their order, so the axes were swapped). Names that say no axis
    leave the columns in their order. Other inputs are returned as they are.
    """
    if isinstance(points, np.ndarray) and points.dtype.names is not None:
        mask = np.ma.getmaskarray(points) if isinstance(points, np.ma.MaskedArray) else None
        hidden = 0 if mask is None else sum(int(np.count_nonzero(mask[field])) for field in mask.dtype.names)
        if hidden:  # (np.ma.is_masked cannot read a structured mask)
            raise InputError(
                f"{name}: {hidden} masked value(s): numpy would use the values hidden under the mask; drop "
                "those points or fill them first"
            )

        from replication.io.npyclouds import unstructured

        try:
            return unstructured(Path(name), points)
        except CloudFileError as exc:  # not a file: the error of an argument
            raise InputError(str(exc)) from None
    columns = getattr(points, "columns", None)
    if columns is None or not hasattr(points, "to_numpy"):
        return points
    if len(columns) != 3:
        shown_names = ", ".join(map(str, list(columns)[:8])) + (", ..." if len(columns) > 8 else "")
        raise InputError(
            f"{name}: a frame of {len(columns)} columns ({shown_names}): a cloud is three columns, x, y "
            "and z; select them (frame[[...]], or frame.xs(...) of hierarchical columns)"
        )
    try:
        order = _column_order(columns, name)
    except CloudFileError as exc:  # not a file: the error of an argument
        raise InputError(str(exc)) from None
    # (by position through numpy: a frame-like object need not have pandas' .iloc)
    return points if order is None else np.asarray(points.to_numpy())[:, order]


def _column_order(columns: Any, name: str) -> list[int] | None:
    """The x, y, z order a frame's column names say (None: their order).

    The levels of hierarchical columns are read one by one, and so are the parts of tuple
    labels (``to_flat_index()``): the level that names the axes decides, wherever it is
    (``("pos", "x")`` as ``("x", "mean")`` from a ``groupby().agg``). Their tuples as text
    named no axis, so ``z, x, y`` under one heading kept its order. A level whose names do not
    make an order (``("z", "w", "v")`` beside ``("x", "y", "z")``) is passed over when another
    level makes one; levels that make different orders are refused.
    """
    from replication.io.axisnames import axis_name, axis_order, lone_axis_message

    labels = list(columns)
    if getattr(columns, "nlevels", 1) > 1:
        levels = [[str(v) for v in columns.get_level_values(k)] for k in range(columns.nlevels)]
    elif labels and all(isinstance(c, tuple) for c in labels) and len({len(c) for c in labels}) == 1:
        levels = [[str(c[k]) for c in labels] for k in range(len(labels[0]))]
    else:
        flat = [str(c) for c in labels]
        order = axis_order(Path(name), flat, what="columns")
        _warn_lone([lone_axis_message(Path(name), flat, what="columns")])
        return order
    orders: dict[int, list[int]] = {}
    refused: list[CloudFileError] = []
    for k, level in enumerate(levels):
        if any(axis_name(label) in ("x", "y", "z") for label in level):
            try:
                orders[k] = axis_order(Path(name), level, what="columns") or [0, 1, 2]
            except CloudFileError as exc:
                refused.append(exc)
    if not orders and refused:
        raise refused[0]
    if len({tuple(order) for order in orders.values()}) > 1:
        said = "; ".join(f"level {k}: {', '.join(levels[k])}" for k in orders)
        raise InputError(
            f"{name}: the column levels name different axes for the same columns ({said}): name the "
            "axes in one level"
        )
    if orders:  # (the levels that name an axis all name one only: which other is x is a guess)
        _warn_lone([lone_axis_message(Path(name), levels[k], what="columns") for k in orders])
    order = next(iter(orders.values()), None)
    return None if order == [0, 1, 2] else order


def _warn_lone(messages: list[str | None]) -> None:
    """Warn with the first message when every one is a warning (a frame's columns that name
    one axis only, ``lat, lon, z``: see :func:`replication.io.axisnames.lone_axis_message`)."""
    if messages and all(m is not None for m in messages):
        import warnings

        warnings.warn(messages[0], CloudFileWarning, stacklevel=5)


def _refuse_text(arr: np.ndarray, name: str) -> None:
    """Refuse coordinates given as text: numpy converts strings by its own, looser rules
    (``'1_000'`` is 1000, ``' 2 '`` is 2) where a cloud file, a ``.npy`` of text and
    :func:`~replication.io.load_cloud` refuse them, so one cloud gave other points in memory
    than from its file. Text arrays, and object arrays (a DataFrame's text columns, as numpy
    converts them) holding a string, are refused."""
    if arr.size == 0:  # (no text to convert: the shape's or emptiness' error says what is wrong)
        return
    if arr.dtype.kind in "US":
        text = arr.ravel()[0]
    elif arr.dtype.kind == "O":
        values = arr.ravel().tolist()
        if not any(issubclass(kind, (str, bytes)) for kind in set(map(type, values))):
            return
        text = next(v for v in values if isinstance(v, (str, bytes)))
    else:
        return
    raise InputError(
        f"{name} holds text (such as {shortened(str(text))!r}), not numbers: numpy would convert it by its "
        "own rules ('1_000' is 1000); convert the coordinates to numbers first, or read the file with "
        "replication.io.load_cloud"
    )


def as_cloud(points: ArrayLike, *, name: str = "points") -> np.ndarray:
    """Validate a point cloud and return it as a float64 array of shape (n, 3).

    A pandas DataFrame's column names (in any level of hierarchical columns), or a structured
    array's field names, say which column is which axis, as a cloud file's header does
    (``z, x, y`` is reordered; names of no axis keep their order).

    Raises
    ------
    InputError
        Wrong shape, non-numeric or complex values, text (strings are not converted: see
        :func:`_refuse_text`), or NaN/infinite coordinates (the rows are named); column or
        field names that contradict each other (an axis named twice).
    """
    points = _named_columns(points, name)
    if isinstance(points, np.ma.MaskedArray) and np.ma.is_masked(points):
        raise InputError(
            f"{name}: {int(np.ma.count_masked(points))} masked value(s): numpy would use the values "
            "hidden under the mask; drop those points or fill them first"
        )
    try:
        given = points if isinstance(points, np.ndarray) else np.asarray(points)  # converted once
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric, got {type(points).__name__}: {exc}") from exc
    kind = given.dtype.kind
    _refuse_text(given, name)
    complex_values = kind == "c"
    try:
        arr = None if complex_values or kind in _NOT_COORDINATES else np.asarray(given, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric, got {type(points).__name__}: {exc}") from exc
    if kind in _NOT_COORDINATES:  # numpy converts them to numbers without a word
        raise InputError(f"{name} must be coordinates, got {_NOT_COORDINATES[kind]} (dtype {given.dtype})")
    if arr is None:
        raise InputError(
            f"{name} must be real numbers, got complex values (numpy would drop the imaginary parts)"
        )
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"{name} must have shape (n, 3), got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise InputError(f"{name} is empty: no points")
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        raise InputError(
            f"{name}: NaN or infinite coordinates in {bad.size} row(s), counted from 0: {shown(bad)}"
        )
    return arr


#: Coordinates below this fraction of the largest one have squares below float64's smallest
#: normal number (2**-511 squared is 2**-1022).
_SQUARE_UNDERFLOW = 2.0**-511


def underflow(uv: np.ndarray, names: tuple[str, str] = ("u", "v")) -> str | None:
    """Why the projected points cannot be triangulated in float64 because they are too small.

    A triangle's orientation is a difference of products of coordinate differences, of the
    order of the two extents' product. Below float64's smallest normal number (about
    2.2e-308) those products underflow to subnormal numbers or zero and every triangle looks
    flat, so such a cloud would be reported as collinear. The triangulator first scales a
    cloud by a power of two so that its largest coordinate is about 1 (see
    :mod:`.delaunay`), so the extents are compared after that scaling: only extents tiny
    next to the coordinates themselves underflow. So do coordinates below
    :data:`_SQUARE_UNDERFLOW` of the largest one (a point at x = 5e-324 beside x = 0 and
    x = 1): the distances among such points square to zero. A zero extent is a line along an
    axis, not an underflow. Returns a message saying so, or None.
    """
    uv = np.asarray(uv, dtype=np.float64)
    extent = np.ptp(uv, axis=0) if uv.size else np.zeros(2)
    tiny = np.finfo(np.float64).tiny
    top = float(np.abs(uv).max()) if uv.size else 0.0
    if top == 0.0 or np.any(extent == 0.0):
        return None
    exponent = math.frexp(top)[1]
    scaled = np.ldexp(extent, -exponent)  # 2.0 ** 1075 would overflow: ldexp does not
    if scaled[0] * scaled[1] >= tiny:
        # a coordinate tiny next to the largest (5e-324 beside 1): the distances between such
        # points square to zero, and the points beside them look like one
        magnitude = np.abs(uv)  # (scaled down, 5e-324 would round to 0 and hide)
        tiny_ones = (magnitude > 0) & (magnitude < math.ldexp(_SQUARE_UNDERFLOW, exponent))
        small = np.flatnonzero(tiny_ones.any(axis=1))
        if small.size == 0:
            return None
        rounded = np.where(tiny_ones, 0.0, uv)  # collinear without the tiny parts: a line, not underflow
        if np.linalg.matrix_rank(rounded - rounded[0]) < 2:
            return None
        k = int(small[0])
        column = int(np.argmax(tiny_ones[k]))
        return (
            f"the coordinates underflow: {names[column]} = {uv[k, column]:.3g} of point {k} (counted from 0) "
            f"is below {_SQUARE_UNDERFLOW:.3g} of the largest coordinate, {top:.3g}, so distances between "
            f"points that small square to zero and no triangle among them can be told from a line; round "
            f"such coordinates to 0 ({small.size} point(s) have one)"
        )
    return (
        f"the coordinates underflow: the projected points span only {extent[0]:.3g} x {extent[1]:.3g} in "
        f"({names[0]}, {names[1]}), so triangle areas fall below float64's smallest normal number "
        f"({tiny:.3g}) next to the largest coordinate, {top:.3g}, and no triangle can be told from a line; "
        "stretch the thinner axis"
    )
