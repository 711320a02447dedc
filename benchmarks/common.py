"""Inputs shared by the benchmarks: fixed-seed continuous clouds in the case-study box."""

import warnings

import numpy as np

#: Table 1's point counts (paper section 4).
PAPER_NS = [9, 45, 100, 169, 200]
#: Scale set for ADT (the foundation issue's 1e6-point target).
SCALE_NS = [1_000, 10_000, 100_000, 1_000_000]


def cloud(n, seed=1234):
    """A continuous random cloud of n points in the 36 x 30 x 13 mm box (distinct points)."""
    from replication.surfaces import random_cloud

    return random_cloud(int(n), rng=np.random.default_rng([seed, int(n)]))


def scratch_dir():
    """A scratch directory for write benchmarks, on tmpfs (/dev/shm) when there is one.

    The writers fsync before renaming (atomic writes); on a disk that adds a latency that
    varies by a factor 2 between runs and would hide regressions of the code itself.
    """
    import os
    import tempfile

    shm = "/dev/shm"
    use = shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else None
    return tempfile.mkdtemp(prefix="asv-", dir=use)


def quiet():
    """Silence duplicate-merge warnings in benchmark processes (lattice inputs)."""
    from replication.errors import DuplicatePointsWarning

    warnings.simplefilter("ignore", DuplicatePointsWarning)


def warn_if_stale_kernels():
    """Say on stderr when this checkout's ahead-of-time kernels are stale (side-by-side scripts).

    A stale module is refused, so commands fall back to numba and pay its start-up (about 1 s
    per process): timings of commands would not be those of an installed release.
    """
    import sys

    from replication import _aot

    if _aot.stale():
        print(
            "warning: the ahead-of-time kernels were built from other sources and are not used; "
            "rebuild them first: python -m replication._aotbuild",
            file=sys.stderr,
        )
