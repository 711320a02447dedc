"""One BLAS thread where BLAS threads cannot help: executor workers and tiny products.

numpy and scipy each ship an OpenBLAS, and each starts a pool of one thread per core. A
call that OpenBLAS splits across its pool waits for every thread of the pool; when the
cores are busy (other programs, or the workers of this project's own executors), a pool
thread can wait a long time for a core, and a call that needs a millisecond stalls for
seconds. Measured on a 2-core machine with both cores kept busy (issue 15; the machine was
also shared, so absolute numbers are loaded-machine numbers): ``scipy.spatial.Delaunay(p)
.transform`` of 200 points, which dispatches 382 tiny LAPACK solves to the pool, took a
median 98 ms and up to 4.3 s with the default 2-thread pool, and 1.1 ms (at most 14 ms)
with one thread; a (1e6 x 3) @ (3 x 3) product took 101 ms against 19 ms.

The choice made here:

* **Executor workers run with one BLAS thread.** The GA's parallelism is its executor's
  (one worker process per core); BLAS threads in a worker would only compete with the
  other workers. :func:`limit_worker_blas` is the process pool's initializer and the setup
  of a dask worker plugin (:mod:`replication.casestudy.daskplugin`), so every worker,
  including one that replaces a dead worker, gets the limit.
* **Tiny or memory-bound products run under** :func:`single_blas_thread`: the library's
  matrix products have an inner dimension of 3 (coordinate frames), so threads cannot
  speed them up, only stall them.
* **The calling process keeps its BLAS pool** outside those blocks: a user's own large
  linear algebra is theirs to tune (``threadpoolctl`` or ``OPENBLAS_NUM_THREADS``).
* **numba's threads are not touched.** Only libraries that threadpoolctl reports with
  ``user_api == "blas"`` are limited, never OpenMP runtimes (which numba's parallel kernels
  may use), and ``NUMBA_NUM_THREADS`` is never set.

An audit of the library's hot paths (the number of times OpenBLAS dispatched work to its
pool, counted with a debugger breakpoint) found no dispatch at the paper's sizes (ADT with
either backend, NURBS fitting, paired comparison, jet force, one GA fitness evaluation, at
200 points) and, at 1e5 points, only the frame products of :func:`closed_adt`, which now
run under :func:`single_blas_thread`.

Notes
-----
Infrastructure for the paper's section 6 case study (parallel fitness evaluations) and
section 3.2's closed surfaces; the paper itself says nothing about threads.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator

__all__ = ["BLAS_ENV", "blas_threads", "limit_worker_blas", "single_blas_thread"]

#: Environment variables that set the thread count of a BLAS library when it is loaded
#: (OpenBLAS, MKL, BLIS). Set in worker processes, so libraries loaded later and child
#: processes also start with one thread. OMP_NUM_THREADS is deliberately absent (numba).
BLAS_ENV: tuple[str, ...] = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")

_cached: tuple[int, object] | None = None


def _controller():
    """A threadpoolctl controller of the loaded libraries, rebuilt after new imports.

    Building one looks up every loaded shared library (about 2 ms); limiting through a
    built one takes about 15 us. Shared libraries are loaded by imports, so the controller
    is rebuilt whenever the number of imported modules has changed.
    """
    global _cached
    from threadpoolctl import ThreadpoolController

    key = len(sys.modules)
    if _cached is None or _cached[0] != key:
        controller = ThreadpoolController()
        _cached = (len(sys.modules), controller)  # the import above may have added modules
    return _cached[1]


def blas_threads() -> dict[str, int]:
    """Thread count of every BLAS library loaded in this process, by library file name.

    Returns
    -------
    dict
        ``{"libscipy_openblas64_-....so": 2, ...}`` (threadpoolctl's ``threadpool_info``).

    Notes
    -----
    Used to check executor workers (paper section 6 case study).
    """
    from threadpoolctl import threadpool_info

    return {
        os.path.basename(info["filepath"]): int(info["num_threads"])
        for info in threadpool_info()
        if info["user_api"] == "blas"
    }


def limit_worker_blas() -> None:
    """Give this process one BLAS thread, for good (an executor worker's initializer).

    Sets :data:`BLAS_ENV` to 1, so BLAS libraries loaded later (scipy's, when a task first
    imports scipy) and child processes start with one thread, and limits the libraries
    already loaded through threadpoolctl. Does not import scipy (worker start-up stays
    fast) and does not touch OpenMP or numba threads.

    Notes
    -----
    Paper section 6: each fitness evaluation of the GA is one task on one worker.
    """
    from threadpoolctl import threadpool_limits

    for name in BLAS_ENV:
        os.environ[name] = "1"
    threadpool_limits(limits=1, user_api="blas")


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Run the block with one BLAS thread, restoring the previous counts afterwards.

    For products whose work is tiny or memory-bound (an inner dimension of 3), which a
    thread pool cannot speed up but can stall on a busy machine. Costs about 15 us, and
    nothing is changed when every BLAS library already has one thread (executor workers),
    so concurrent blocks in one worker cannot restore each other's counts. (In a process
    whose threads run such blocks concurrently while BLAS has a pool, the last block to
    exit restores the count it found; the count is process-wide in OpenBLAS.)

    Notes
    -----
    Used by the closed surfaces of paper section 3.2 (rotations into the split plane's frame).
    """
    blas = _controller().select(user_api="blas")
    if all(lib.num_threads == 1 for lib in blas.lib_controllers):
        yield
        return
    with blas.limit(limits=1):
        yield
