"""The files of one simulation: closed solid (OBJ), water column (partio ASCII), scene, job.

:func:`write_scene` writes everything the child process needs into a run directory; the
scene follows SPlisHSPlasH 2.19's JSON format (``doc/file_format.md`` of the engine).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from replication.casestudy.sph.geometry import closed_solid, jet_column, obj_text, pda_text
from replication.casestudy.sph.settings import METHODS, SPHSettings, Timeline, timeline
from replication.io.atomic import atomic_write_text

if TYPE_CHECKING:  # pragma: no cover
    from replication.casestudy.jet import JetConfig

__all__ = ["Scene", "scene_dict", "write_scene"]

#: Particle (Akinci 2012) boundaries: the only kind that worked for a thin solid here.
BOUNDARY_PARTICLES = 0
#: Regular triangle sampling of the solid's surface at 1.5 particle radii (deterministic;
#: SPlisHSPlasH's Poisson-disk sampling is random).
REGULAR_SAMPLING = 1
#: Cubic spline kernel and gradient.
CUBIC_SPLINE = 0


@dataclass(frozen=True)
class Scene:
    """What was written for a simulation and what the analysis needs to know about it."""

    timeline: Timeline
    column_particles: int
    column_layers: int
    spacing: float  # lattice step of the column, 2 r (m)
    solid_vertices: int
    solid_triangles: int


def scene_dict(
    settings: SPHSettings, config: JetConfig, solid_file: str, column_file: str, first_step: float
) -> dict[str, Any]:
    """The SPlisHSPlasH scene (JSON object) of a jet simulation."""
    speed = config.velocity
    c = settings.speed_of_sound(speed)
    configuration: dict[str, Any] = {
        "particleRadius": settings.particle_radius,
        "simulationMethod": METHODS[settings.method],
        "boundaryHandlingMethod": BOUNDARY_PARTICLES,
        "kernel": CUBIC_SPLINE,
        "gradKernel": CUBIC_SPLINE,
        "gravitation": [0.0, 0.0, -settings.gravity],
        "timeStepSize": first_step,
        "cflMethod": 1,
        "cflFactor": settings.cfl_factor,
        "cflMaxTimeStepSize": settings.time_step_limit(speed),
        "cflMinTimeStepSize": settings.min_time_step,
        "enableZSort": False,  # particle order must not change: the force sums over it
        "stopAt": settings.duration,
        "enablePartioExport": False,
        "enableVTKExport": False,
    }
    if c is not None:
        configuration["WCSPH"] = {
            "stiffness": config.density * c * c / settings.exponent,
            "exponent": settings.exponent,
        }
    material: dict[str, Any] = {"id": "Fluid", "density0": config.density, "maxEmitterParticles": 0}
    if settings.viscosity > 0:
        material.update(viscosityMethod=1, **{"Standard viscosity": {"viscosity": settings.viscosity}})
    else:
        material["viscosityMethod"] = 0
    return {
        "Configuration": configuration,
        "Materials": [material],
        "RigidBodies": [
            {
                "geometryFile": solid_file,
                "translation": [0.0, 0.0, 0.0],
                "rotationAxis": [1.0, 0.0, 0.0],
                "rotationAngle": 0.0,
                "scale": [1.0, 1.0, 1.0],
                "isDynamic": False,
                "isWall": False,
                "samplingMode": REGULAR_SAMPLING,
            }
        ],
        "FluidModels": [
            {
                "particleFile": column_file,
                "translation": [0.0, 0.0, 0.0],
                "scale": [1.0, 1.0, 1.0],
                "initialVelocity": [0.0, 0.0, -speed],
            }
        ],
    }


def write_scene(
    run_dir: Path, points: np.ndarray, triangles: np.ndarray, config: JetConfig, settings: SPHSettings
) -> Scene:
    """Write the solid, the column, the scene and the job file of a simulation into ``run_dir``.

    Parameters
    ----------
    points, triangles
        The simulated surface (metres): a conforming height field, triangles counter-clockwise
        in x-y, already mirrored when the half jet is simulated as a whole one.
    config : JetConfig
        The jet as simulated (its whole cross-section, centred at ``config.center``).

    Notes
    -----
    Paper section 6: the 18 mm jet at 4.34 m/s along -z onto the surface.
    """
    run_dir = Path(run_dir).resolve()
    times = timeline(settings, config.velocity, config.diameter)
    spacing = 2 * settings.particle_radius
    depth = settings.support_radius + 1e-3  # the bottom is beyond the reach of water on top
    solid_points, solid_tris = closed_solid(points, triangles, depth)
    top = float(points[:, 2].max())
    column, layers = jet_column(
        config.center, config.diameter / 2, top + times.gap, times.column_length, spacing
    )
    solid_file, column_file = run_dir / "solid.obj", run_dir / "column.pda"
    atomic_write_text(solid_file, obj_text(solid_points, solid_tris))
    atomic_write_text(column_file, pda_text(column))
    first_step = min(
        settings.time_step_limit(config.velocity), settings.cfl_factor * 0.4 * spacing / config.velocity
    )
    scene = scene_dict(settings, config, str(solid_file), str(column_file), first_step)
    atomic_write_text(run_dir / "scene.json", json.dumps(scene, indent=2) + "\n")
    job = {
        "scene": str(run_dir / "scene.json"),
        "gravity": settings.gravity,
        "max_speed": settings.max_speed_factor * config.velocity,
        "min_time_step": settings.min_time_step,
        "progress_interval": 0.25,
    }
    atomic_write_text(run_dir / "job.json", json.dumps(job, indent=2) + "\n")
    return Scene(
        timeline=times,
        column_particles=int(column.shape[0]),
        column_layers=layers,
        spacing=spacing,
        solid_vertices=int(solid_points.shape[0]),
        solid_triangles=int(solid_tris.shape[0]),
    )
