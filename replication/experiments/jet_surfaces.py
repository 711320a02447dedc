"""The surfaces of the jet-model validation study: reference shapes, GA winners, random lattices.

Every surface is a height field z(x, y) in the paper's 36 x 30 x 13 mm domain on the side
y >= 0 of the symmetry plane, so both solvers take it with the paper's half jet: the
thin-sheet model directly, SPH as the whole jet on the surface joined to its mirror image.

Families (and the strata of the calibration / held-out split):

* **plates** - the flat plate of the case study and plates inclined along x (the jet
  strikes them obliquely; the sheet runs off downhill and uphill);
* **cups** - two smooth paraboloid bowls centred on the jet axis and the case study's
  Pelton-bucket approximation: the sheet is turned back smoothly;
* **GA winners** - the best distinct surfaces of each run of the thin-sheet GA;
* **random lattices** - random 101-point genomes of the GA's lattice, as in its initial
  population: spiky surfaces with creases, re-impacts and separations.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from replication.casestudy.ga import GAConfig, points_from_genome, random_genome
from replication.casestudy.mesh import surface_signature
from replication.casestudy.shapes import flat_plate_cloud, pelton_bucket_cloud
from replication.errors import DuplicatePointsWarning, InputError
from replication.surfaces import adt

__all__ = [
    "FAMILIES",
    "StudySurface",
    "bowl_cloud",
    "ga_winners",
    "inclined_plate_cloud",
    "random_lattice_surfaces",
    "reference_surfaces",
    "surface_signature",
]

#: Families of surfaces, in report order.
FAMILIES = ("plate", "cup", "GA winner", "random lattice")
#: Largest inclination of a plate along x that stays in the 13 mm deep domain: atan(13/36).
MAX_INCLINATION_DEG = math.degrees(math.atan2(13.0, 36.0))
#: Bowl grid: 2 mm steps over the domain (19 x 16 nodes).
BOWL_STEP_MM = 2.0


@dataclass(frozen=True, eq=False)
class StudySurface:
    """One surface of the study: name, family, stratum of the split, geometry (mm).

    ``stratum`` groups surfaces that the calibration / held-out split keeps together in
    proportion (the family; the GA winners of one run form a stratum of their own).
    ``model_hint`` is the thin-sheet fitness the GA gave it (GA winners only).
    """

    name: str
    family: str
    stratum: str
    points: np.ndarray
    triangles: np.ndarray
    ga_fitness: float = float("nan")

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise InputError(f"unknown surface family {self.family!r}; one of {FAMILIES}")


def _adt(points: np.ndarray, duplicates: str = "mean") -> Any:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        return adt(points, depth="z", duplicates=duplicates)  # type: ignore[arg-type]


def inclined_plate_cloud(angle_deg: float) -> np.ndarray:
    """The flat plate's 101 lattice (x, y) positions on the plane z = x tan(angle) (mm).

    Notes
    -----
    Paper section 6 domain: the plate rises along x from z = 0 at x = 0; an angle of at
    most atan(13/36) = 19.86 deg keeps it inside the 13 mm depth.
    """
    if not 0 < angle_deg <= MAX_INCLINATION_DEG + 1e-9:
        raise InputError(
            f"plate inclination must lie in (0, {MAX_INCLINATION_DEG:.4g}] deg to fit the domain, "
            f"got {angle_deg}"
        )
    cloud = flat_plate_cloud()
    cloud[:, 2] = np.minimum(cloud[:, 0] * math.tan(math.radians(angle_deg)), 13.0)
    return cloud


def bowl_cloud(depth_mm: float) -> np.ndarray:
    """A smooth paraboloid bowl centred on the jet axis (18, 0): z = depth (r / 18 mm)^2, at most 13.

    Sampled on a 2 mm grid of the domain; with its mirror image in y = 0 it is a whole
    bowl round the jet. ``depth_mm`` is the height reached at r = 18 mm, the domain's half
    length (the rim at the ends x = 0 and x = 36).
    """
    if not 0 < depth_mm <= 13:
        raise InputError(f"bowl depth must lie in (0, 13] mm, got {depth_mm}")
    x = np.arange(0.0, 36.0 + 1e-9, BOWL_STEP_MM)
    y = np.arange(0.0, 30.0 + 1e-9, BOWL_STEP_MM)
    gx, gy = np.meshgrid(x, y, indexing="ij")
    r2 = ((gx - 18.0) ** 2 + gy**2) / 18.0**2
    z = np.minimum(depth_mm * r2, 13.0)
    return np.column_stack([gx.ravel(), gy.ravel(), z.ravel()])


def reference_surfaces(
    angles_deg: tuple[float, ...] = (5.0, 10.0, MAX_INCLINATION_DEG),
    bowl_depths_mm: tuple[float, ...] = (6.5, 13.0),
) -> list[StudySurface]:
    """Flat plate, inclined plates, smooth bowls and the Pelton-bucket approximation."""
    out = []
    s = _adt(flat_plate_cloud())
    out.append(StudySurface("flat plate", "plate", "plate", s.points, s.triangles))
    for angle in angles_deg:
        s = _adt(inclined_plate_cloud(angle))
        out.append(StudySurface(f"plate inclined {angle:.3g} deg", "plate", "plate", s.points, s.triangles))
    for depth in bowl_depths_mm:
        s = _adt(bowl_cloud(depth))
        out.append(StudySurface(f"bowl {depth:g} mm", "cup", "cup", s.points, s.triangles))
    s = _adt(pelton_bucket_cloud())
    out.append(StudySurface("Pelton bucket", "cup", "cup", s.points, s.triangles))
    return out


def random_lattice_surfaces(count: int, config: GAConfig, *, rng: int) -> list[StudySurface]:
    """``count`` random genomes of the GA's lattice (as in its initial population), as surfaces.

    Surface i comes from ``numpy.random.default_rng([rng, i])``, so the first surfaces do not
    depend on ``count``.
    """
    out = []
    for i in range(count):
        genome = random_genome(config, rng=np.random.default_rng([rng, i]))
        s = _adt(points_from_genome(genome, config), config.duplicates)
        out.append(StudySurface(f"random {i:02d}", "random lattice", "random lattice", s.points, s.triangles))
    return out


def ga_winners(
    config: GAConfig, top: int, *, run_dir: str | Path, pool_factory: Any, on_generation: Any = None
) -> list[StudySurface]:
    """The ``top`` best distinct surfaces of the final population of each GA run.

    The runs are read from ``run_dir`` when their checkpoints are there (complete runs are
    not re-run; a partial one is resumed) and run otherwise: the GA is deterministic (run
    k is seeded with ``[config.seed, k]``), so a re-run by the same code gives the same
    populations (code that breaks triangulation ties differently may not). Individuals are
    ranked by their thin-sheet fitness (ties: population order) and kept when their ADT
    surface differs from every better one's.

    Notes
    -----
    Paper section 6: the GA's optimised surfaces (Fig. 9).
    """
    from replication.casestudy.rescore import top_distinct
    from replication.casestudy.runner import load_run, run_ga

    out = []
    for k in range(config.runs):
        state = load_run(run_dir, k)
        if state is None or state.generation < config.generations:
            state = run_ga(
                config,
                k,
                run_dir=run_dir,
                pool_factory=pool_factory,
                resume=True,
                on_generation=on_generation,
            )
        for c in top_distinct(state, config, top):
            out.append(
                StudySurface(c.name, "GA winner", f"GA run {k}", c.points, c.triangles, ga_fitness=c.fitness)
            )
    return out
