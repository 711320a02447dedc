"""The SPH backend (optional extra ``sph``): one coarse simulation of the flat plate.

Skipped (NotImplementedError in setup) where the engine is not installed. Times the whole
evaluation a GA would pay for (scene, child process, engine, analysis) and tracks its
force, so a slowdown or a change of result shows up across commits.
"""

import importlib.util

from .common import quiet


def _settings():
    from replication.casestudy.sph import SPHSettings

    return SPHSettings(particle_radius=1.25e-3, duration=0.014)


class SPHFlatPlate:
    """The paper's half jet on the flat plate: r = 1.25 mm, 14 ms simulated, DFSPH, one thread."""

    number = 1
    repeat = 3
    rounds = 1
    warmup_time = 0
    timeout = 600

    def setup(self):
        if importlib.util.find_spec("pysplishsplash") is None:
            raise NotImplementedError('the SPH engine is not installed (pip install ".[sph]")')
        quiet()
        from replication.casestudy.shapes import flat_plate_surface

        self.surface = flat_plate_surface()

    def time_simulation(self):
        from replication.casestudy.sph import surface_sph_force

        surface_sph_force(self.surface, None, _settings()).check()

    def track_axial_force(self):
        from replication.casestudy.sph import surface_sph_force

        return surface_sph_force(self.surface, None, _settings()).check().mean_axial

    track_axial_force.unit = "N"
