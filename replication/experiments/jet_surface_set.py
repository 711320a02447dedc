"""The validation study's set of surfaces: built once, then kept with the SPH cache.

The SPH results are tied to exact geometries (the cache is keyed by them), and a surface
of the study depends on more than its seed: on the triangulator's choice among co-circular
lattice points, and through the GA's fitness on every detail of the model. So the study
builds its surfaces once (:func:`build_surfaces`), stores them beside the cache as JSON
(points, triangles, family, the GA fitness that selected them, the commit that built them)
and reads them back on every later run: a change of the triangulator or the model does not
silently turn hours of simulations into cache misses. ``rebuild=True`` builds them afresh.
The GA's runs are kept there too (:func:`ga_run_directory`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from replication.casestudy.ga import GAConfig
from replication.casestudy.jet import jet_force
from replication.errors import CloudFileError, InputError
from replication.experiments.jet_surfaces import (
    StudySurface,
    ga_winners,
    random_lattice_surfaces,
    reference_surfaces,
)
from replication.io.atomic import atomic_write_text

__all__ = ["SET_FORMAT", "build_surfaces", "ga_run_directory", "set_path", "study_surfaces"]

SET_FORMAT = 1


def _digest(data: Any) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def ga_run_directory(cache_dir: str | Path, ga: GAConfig) -> Path:
    """Where the study keeps its GA runs by default: beside the SPH cache, one per configuration."""
    return Path(cache_dir) / "ga-runs" / _digest(ga.as_dict())


def _defining(config: Any) -> dict[str, Any]:
    """The configuration fields that decide which surfaces the study has."""
    return {
        "angles_deg": list(config.angles_deg),
        "bowl_depths_mm": list(config.bowl_depths_mm),
        "random_surfaces": config.random_surfaces,
        "seed": config.seed,
        "ga": None if config.ga is None else config.ga.as_dict(),
        "ga_top": config.ga_top,
    }


def set_path(cache_dir: str | Path, config: Any) -> Path:
    """The stored surface set of a configuration: ``cache_dir/surfaces/<digest>.json``."""
    return Path(cache_dir) / "surfaces" / f"{_digest(_defining(config))}.json"


def build_surfaces(
    config: Any, *, ga_run_dir: str | Path | None = None, pool_factory: Any = None
) -> list[StudySurface]:
    """Every surface of the study, validated for the thin-sheet model (and so for SPH).

    The GA runs are read from (or run into) ``ga_run_dir``; default: a temporary directory.
    """
    from replication.casestudy.evaluate import executor

    surfaces = reference_surfaces(config.angles_deg, config.bowl_depths_mm)
    if config.ga is not None and config.ga_top > 0:
        pool_factory = pool_factory or functools.partial(executor, "serial")
        if ga_run_dir is None:
            from replication.io.scratch import scratch_directory

            with scratch_directory("replication-ga-") as tmp:
                surfaces += ga_winners(config.ga, config.ga_top, run_dir=tmp, pool_factory=pool_factory)
        else:
            surfaces += ga_winners(config.ga, config.ga_top, run_dir=ga_run_dir, pool_factory=pool_factory)
    surfaces += random_lattice_surfaces(config.random_surfaces, config.ga or GAConfig(), rng=config.seed)
    _check(surfaces, config)
    return surfaces


def _check(surfaces: list[StudySurface], config: Any) -> None:
    names = [s.name for s in surfaces]
    if len(set(names)) != len(names):
        raise InputError(f"surface names must be unique, got {names}")
    missing = sorted(set(config.resolution_surfaces) - set(names))
    if missing:
        raise InputError(f"resolution-study surfaces not in the study: {', '.join(missing)}")
    for s in surfaces:  # the model's full mesh checks (height field, domain, y >= 0): SPH uses the same
        jet_force(s.points, s.triangles, config.jet)


def _save(path: Path, surfaces: list[StudySurface], config: Any) -> None:
    from replication.provenance import git_state

    data = {
        "format": SET_FORMAT,
        "config": _defining(config),
        "built_by": git_state(),
        "surfaces": [
            {
                "name": s.name, "family": s.family, "stratum": s.stratum,
                "ga_fitness": None if math.isnan(s.ga_fitness) else s.ga_fitness,
                "points": s.points.tolist(), "triangles": s.triangles.tolist(),
            }
            for s in surfaces
        ],
    }  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(data) + "\n")


def _load(path: Path, config: Any) -> tuple[list[StudySurface], dict[str, Any]]:
    try:
        data = json.loads(path.read_text())
        if data.get("format") != SET_FORMAT or data["config"] != json.loads(json.dumps(_defining(config))):
            raise ValueError("it belongs to another configuration or format")
        surfaces = [
            StudySurface(
                s["name"],
                s["family"],
                s["stratum"],
                np.asarray(s["points"], dtype=np.float64),
                np.asarray(s["triangles"], dtype=np.int64),
                ga_fitness=math.nan if s["ga_fitness"] is None else float(s["ga_fitness"]),
            )  # fmt: skip
            for s in data["surfaces"]
        ]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise CloudFileError(f"{path}: not a readable surface set of this study ({exc}); rebuild it") from exc
    return surfaces, data.get("built_by", {})


def study_surfaces(
    config: Any,
    *,
    cache_dir: str | Path,
    ga_run_dir: str | Path | None = None,
    pool_factory: Any = None,
    rebuild: bool = False,
) -> tuple[list[StudySurface], dict[str, Any]]:
    """The study's surfaces: read from the set stored with the cache, or built and stored.

    Returns the surfaces and the git state of the commit that built them. An explicit
    ``ga_run_dir`` (another GA's winners) always builds afresh and stores nothing.
    """
    path = set_path(cache_dir, config)
    if ga_run_dir is None and not rebuild and path.is_file():
        surfaces, built_by = _load(path, config)
        _check(surfaces, config)
        return surfaces, built_by
    explicit = ga_run_dir is not None
    if ga_run_dir is None and config.ga is not None:
        ga_run_dir = ga_run_directory(cache_dir, config.ga)
    surfaces = build_surfaces(config, ga_run_dir=ga_run_dir, pool_factory=pool_factory)
    from replication.provenance import git_state

    if not explicit:
        _save(path, surfaces, config)
    return surfaces, git_state()
