"""warm_up compiles every kernel with the argument types the package uses.

numba reports a compilation (not a load from its on-disk cache) as a "numba:compile" event.
In a fresh clone the session start runs warm_up, so a workload that still compiles something
afterwards uses a kernel, or an argument type, that warm_up misses; with a warm cache the
test passes either way.
"""

import warnings

import numpy as np
from numba.core import event

from replication.errors import DuplicatePointsWarning
from replication.kernels import warm_up


def test_after_warm_up_a_full_workload_compiles_nothing():
    warm_up()  # cheap when the session start has already run it
    from replication.casestudy.jet import jet_force, surface_force
    from replication.compare import compare
    from replication.surfaces import adt, random_cloud
    from replication.surfaces.nurbs import fit_nurbs

    compiled = event.RecordingListener()
    event.register("numba:compile", compiled)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DuplicatePointsWarning)
            big = random_cloud(30_000, rng=1)  # blocks, merges, parallel partition
            surface = adt(big)
            fit_nurbs(big, evaluator="fast", triangulation=surface)
            for cloud in (random_cloud(300, rng=2), random_cloud(300, step=1.0, rng=3)):
                compare(cloud)
                adt(cloud, backend="scipy")
            bucket = adt(random_cloud(101, step=1.0, rng=4) * [1.0, 1.0, 0.5], depth="z")
            surface_force(bucket)
            jet_force(bucket.points, np.array(bucket.triangles, dtype=np.int64))
    finally:
        event.unregister("numba:compile", compiled)
    names = sorted({str(e.data["dispatcher"]) for _, e in compiled.buffer if e.is_start})
    assert names == [], names
