"""The paper's genetic algorithm (section 6): configuration, genomes and operators.

The paper: "the chromosomes were defined as the coordinates of points that form the surface.
Random selection, 2 point crossover reproduction and random mutation of 0.01% were the
operators used for optimization. Initial population of 48 individuals made of 101 coordinate
points ... consisted of a flat surface, an approximation of existing Pelton turbine bucket and
randomly generated surfaces. The 4 elite individuals from each generation were carried
forward". Its 2400 simulations are 48 individuals x 50 generations.

Definitions used here (documented and tested):

* **Genome**: the 101 points on the 1 mm lattice of the 36 x 30 x 13 mm domain, stored as
  integer lattice indices in point-major order ``x0 y0 z0 x1 y1 z1 ...`` (303 integers).
* **Gene**: one coordinate of one point (one of the 303 integers).
* **Mutation**: each gene independently, with probability ``mutation_rate`` (0.01 % = 1e-4),
  is replaced by a value drawn uniformly from the *other* lattice values of its axis (so a
  mutation always changes the gene). At 303 genes this is 0.03 mutations per child: the
  paper's rate makes mutation nearly absent.
* **Crossover**: two-point; two cut positions 1 <= i < j <= 302 are drawn uniformly and the
  children swap the genes in [i, j) (whole points or single coordinates may be exchanged).
* **Selection**: random: both parents are drawn uniformly (without replacement) from the whole
  population, whatever their fitness; selective pressure comes from elitism alone.
* **Elitism**: the ``elites`` (4) fittest individuals enter the next generation unchanged;
  the other places are filled by children, two per pair of parents.
* **Generations**: ``generations`` (50) populations are evaluated, the initial one included,
  so a run evaluates at most 48 x 50 = 2400 individuals, as in the paper.
* **Initial population**: the flat plate and the Pelton-bucket approximation
  (:mod:`.shapes`), and ``population - 2`` random genomes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from replication.casestudy.jet import DEFAULT_RESOLUTION, MAX_RESOLUTION, JetConfig
from replication.casestudy.units import to_millimetres
from replication.errors import InputError
from replication.params import generator
from replication.surfaces.cloud import lattice_count

__all__ = [
    "GAConfig",
    "genome_bounds",
    "genome_from_points",
    "initial_population",
    "mutate",
    "next_generation",
    "points_from_genome",
    "random_genome",
    "select_parents",
    "two_point_crossover",
]


#: The largest GA population taken: beyond it the genomes and their surfaces fill the memory
#: of a workstation before the first generation is scored (1e8 grew by 60 MB/s, unstoppable).
MAX_POPULATION = 100_000


@dataclass(frozen=True)
class GAConfig:
    """Every setting of the case-study GA, with the paper's values as defaults."""

    population: int = 48
    generations: int = 50
    runs: int = 3
    elites: int = 4
    points: int = 101
    mutation_rate: float = 1e-4
    seed: int = 2019
    box: tuple[float, float, float, float, float, float] = (0.0, 36.0, 0.0, 30.0, 0.0, 13.0)
    step: float = 1.0
    resolution: int = DEFAULT_RESOLUTION
    duplicates: str = "mean"
    jet: JetConfig = JetConfig()

    def __post_init__(self) -> None:
        for name in ("population", "generations", "runs", "points", "resolution", "elites"):
            value = getattr(self, name)
            minimum = 0 if name == "elites" else 1
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
                raise InputError(f"GA {name} must be an integer >= {minimum}, got {value!r}")
            object.__setattr__(self, name, int(value))  # numpy integers: not JSON (config.json)
        if self.resolution > MAX_RESOLUTION // 4:
            raise InputError(
                f"GA resolution must be at most {MAX_RESOLUTION // 4} (the case study also scores its "
                f"reference shapes at 4x, and the jet model takes at most {MAX_RESOLUTION}), "
                f"got resolution={self.resolution}"
            )
        if self.population < 4:
            raise InputError(
                f"GA population must be at least 4 (two seeds and a pair), got {self.population}"
            )
        if self.population > MAX_POPULATION:  # each individual is a genome and a surface in memory
            raise InputError(
                f"GA population must be at most {MAX_POPULATION:,} (its genomes alone take "
                f"{self.population * self.points * 3 * 8 / 2**30:.3g} GiB), got {self.population}"
            )
        if not self.elites < self.population:
            raise InputError(
                f"GA population must be larger than its elites (the {self.elites} fittest individuals "
                f"carried over unchanged), got population={self.population}"
            )
        if self.points < 3:
            raise InputError(f"a surface needs at least 3 points, got points={self.points}")
        if not 0.0 <= self.mutation_rate <= 1.0:
            raise InputError(f"mutation rate is a probability per gene, got {self.mutation_rate}")
        if not self.step > 0:
            raise InputError(f"lattice step must be positive, got {self.step}")
        lo, hi = np.asarray(self.box[0::2], float), np.asarray(self.box[1::2], float)
        if len(self.box) != 6 or np.any(hi <= lo):
            raise InputError(
                f"box must be (xmin, xmax, ymin, ymax, zmin, zmax) with min < max, got {self.box}"
            )
        for k in range(3):  # the genes index each axis's lattice: a step too fine for it is named here
            lattice_count(self.box[2 * k], self.box[2 * k + 1], self.step)
        if self.duplicates not in ("mean", "min", "max", "first"):
            raise InputError(
                f"duplicate policy must merge ('mean', 'min', 'max', 'first'), got {self.duplicates!r}"
            )
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"GA seed must be a non-negative integer, got {self.seed!r}")
        object.__setattr__(self, "seed", int(self.seed))
        if self.jet.domain is not None:  # every lattice point must lie in the jet model's domain
            domain_mm = to_millimetres(self.jet.domain)
            if lo.min() < 0 or np.any(hi > domain_mm * (1 + 1e-9)):
                raise InputError(
                    f"box {self.box} (mm) must lie inside the jet domain {domain_mm.tolist()} mm"
                )
        # the initial population seeds the flat plate and the bucket: they must fit this genome
        from replication.casestudy.shapes import flat_plate_cloud

        try:
            genome_from_points(flat_plate_cloud(), self)
        except InputError as exc:
            raise InputError(
                "the initial population seeds the flat plate and the Pelton bucket, 101 points on the 1 mm "
                f"lattice of the 36 x 30 x 13 mm box; points={self.points}, box={self.box}, "
                f"step={self.step} cannot hold them ({exc})"
            ) from exc

    @property
    def genes(self) -> int:
        return 3 * self.points

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary (the jet configuration included)."""
        d = asdict(self)
        d["jet"] = asdict(self.jet)
        d["box"] = list(self.box)
        d["jet"]["center"] = list(self.jet.center)
        if self.jet.domain is not None:
            d["jet"]["domain"] = list(self.jet.domain)
        return d


def genome_bounds(config: GAConfig) -> np.ndarray:
    """Largest lattice index of each gene (its axis's number of lattice values minus 1)."""
    per_axis = [lattice_count(config.box[2 * k], config.box[2 * k + 1], config.step) - 1 for k in range(3)]
    return np.tile(np.asarray(per_axis, dtype=np.int64), config.points)


def points_from_genome(genome: np.ndarray, config: GAConfig) -> np.ndarray:
    """The (points, 3) coordinates in millimetres of a genome."""
    lo = np.asarray(config.box[0::2], float)
    return lo + config.step * np.asarray(genome, dtype=np.float64).reshape(-1, 3)


def genome_from_points(points: np.ndarray, config: GAConfig) -> np.ndarray:
    """The genome of lattice points; raises InputError for points off the lattice or domain."""
    lo = np.asarray(config.box[0::2], float)
    index = (np.asarray(points, dtype=np.float64) - lo) / config.step
    genome = np.rint(index).astype(np.int64).ravel()
    if index.shape != (config.points, 3) or not np.allclose(index.ravel(), genome, atol=1e-9):
        raise InputError(
            f"expected {config.points} points on the {config.step:g} mm lattice, got shape {index.shape}"
        )
    if np.any(genome < 0) or np.any(genome > genome_bounds(config)):
        raise InputError("points outside the case-study domain")
    return genome


def random_genome(config: GAConfig, *, rng: int | np.random.Generator | None) -> np.ndarray:
    """A genome with every gene uniform on its axis's lattice."""
    rng = generator(rng)
    return rng.integers(0, genome_bounds(config) + 1)


def two_point_crossover(
    a: np.ndarray, b: np.ndarray, *, rng: int | np.random.Generator | None
) -> tuple[np.ndarray, np.ndarray]:
    """Swap the genes between two distinct cut positions; returns two children."""
    rng = generator(rng)
    n = a.shape[0]
    if b.shape != a.shape or n < 3:
        raise InputError(f"crossover needs two genomes of equal length >= 3, got {a.shape} and {b.shape}")
    i, j = np.sort(rng.choice(np.arange(1, n), size=2, replace=False))
    c1, c2 = a.copy(), b.copy()
    c1[i:j], c2[i:j] = b[i:j], a[i:j]
    return c1, c2


def mutate(
    genome: np.ndarray, rate: float, bounds: np.ndarray, *, rng: int | np.random.Generator | None
) -> np.ndarray:
    """Replace each gene with probability ``rate`` by another value of its axis's lattice."""
    rng = generator(rng)
    hit = rng.random(genome.shape[0]) < rate
    out = genome.copy()
    if hit.any():
        # a uniform draw among the bounds[k] values other than the current one
        draw = rng.integers(0, bounds[hit])  # in [0, bound - 1]
        out[hit] = draw + (draw >= genome[hit])
    return out


def select_parents(size: int, *, rng: int | np.random.Generator | None) -> tuple[int, int]:
    """Random selection: two distinct individuals, uniformly."""
    rng = generator(rng)
    i, j = rng.choice(size, size=2, replace=False)
    return int(i), int(j)


def initial_population(config: GAConfig, *, rng: int | np.random.Generator | None) -> np.ndarray:
    """The flat plate, the Pelton-bucket approximation and random genomes."""
    rng = generator(rng)
    from replication.casestudy.shapes import flat_plate_cloud, pelton_bucket_cloud

    seeds = [genome_from_points(cloud, config) for cloud in (flat_plate_cloud(), pelton_bucket_cloud())]
    randoms = [random_genome(config, rng=rng) for _ in range(config.population - len(seeds))]
    return np.vstack(seeds + randoms)


def next_generation(
    population: np.ndarray, fitness: np.ndarray, config: GAConfig, *, rng: int | np.random.Generator | None
) -> np.ndarray:
    """Elites unchanged, then children of randomly selected pairs (crossover, mutation).

    Fitness ties are broken by the index in the population (a stable sort), so the result
    depends only on the population, its fitness and the generator's state.
    """
    rng = generator(rng)
    order = np.argsort(-np.nan_to_num(fitness, nan=-np.inf), kind="stable")
    children = [population[k].copy() for k in order[: config.elites]]
    bounds = genome_bounds(config)
    while len(children) < config.population:
        i, j = select_parents(population.shape[0], rng=rng)
        for child in two_point_crossover(population[i], population[j], rng=rng):
            if len(children) < config.population:
                children.append(mutate(child, config.mutation_rate, bounds, rng=rng))
    return np.vstack(children)
