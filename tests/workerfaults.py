"""Faults injected into worker processes, for the executors' tests.

A process pool's workers import this module by name (a spawned process gets the parent's
``sys.path``, and pytest puts ``tests/`` on it); dask's workers cannot import ``tests/``, so
tests that ship these objects to a dask cluster pickle this module by value
(:func:`pickled_by_value`).
"""

import contextlib
import os


class DiesOnceWhenArmed:
    """A fitness whose first evaluation after the file ``armed`` appears kills its worker process.

    It dies only once per ``died`` file (created atomically by the dying worker), so the
    evaluation it abandoned succeeds when the executor runs it again.
    """

    def __init__(self, inner, armed, died):
        self.inner, self.armed, self.died = inner, str(armed), str(died)

    def __call__(self, genome):
        if os.path.exists(self.armed):
            try:
                os.close(os.open(self.died, os.O_CREAT | os.O_EXCL))
            except FileExistsError:
                pass
            else:
                os._exit(1)  # the worker dies mid-evaluation, its task with it
        return self.inner(genome)


@contextlib.contextmanager
def pickled_by_value(*modules):
    """Let cloudpickle ship ``modules`` (and this one) by value, for workers that cannot import them."""
    import sys

    import cloudpickle

    modules = [sys.modules[__name__], *modules]
    for module in modules:
        cloudpickle.register_pickle_by_value(module)
    try:
        yield
    finally:
        for module in modules:
            cloudpickle.unregister_pickle_by_value(module)
