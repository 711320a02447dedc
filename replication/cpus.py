"""The CPUs this process may run on: the default number of worker processes everywhere.

``os.cpu_count()`` counts the machine's CPUs, not those this process is allowed to use: in a
container or under ``taskset`` limited to 1 of 64 CPUs, a default of ``os.cpu_count()``
workers starts 64 processes that take turns on one core. Every default worker count of the
package (executors, the CLI's ``--workers``, kernel warm-up, SPH simulations at once) is
therefore :func:`usable_cpus`.

Notes
-----
Infrastructure for the paper's section 6 case study (parallel fitness evaluations) and the
Table 1 experiment (section 4); the paper itself says nothing about processes.
"""

from __future__ import annotations

import os

__all__ = ["usable_cpus"]


def usable_cpus() -> int:
    """The CPUs this process may run on: its affinity where the system tells it, else all.

    Returns
    -------
    int
        At least 1.
    """
    affinity = getattr(os, "sched_getaffinity", None)
    if affinity is not None:
        try:
            return max(1, len(affinity(0)))
        except OSError:  # a system that has the call but refuses it
            pass
    return os.cpu_count() or 1
