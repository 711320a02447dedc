"""warm_up compiles every kernel with the argument types the package uses.

numba reports a compilation (not a load from its on-disk cache) as a "numba:compile" event,
and a kernel called with argument types it has not seen yet in this process gains a signature
(compiled, or loaded from the cache). The workload runs in a fresh interpreter after warm_up:
a signature it adds, or a compilation, is one that warm_up misses, whatever the state of the
cache and whichever tests ran before in this process.
"""

import json
import subprocess
import sys

import pytest

from replication.kernels import warm_up

_WORKLOAD = """
import json, sys, warnings
import numpy as np
from numba.core import event
from numba.core.dispatcher import Dispatcher
from replication.errors import DuplicatePointsWarning
from replication.kernels import warm_up

def signatures():
    found = {}
    for name, module in list(sys.modules.items()):
        if name == "replication" or name.startswith("replication."):
            for attr, value in list(vars(module).items()):
                if isinstance(value, Dispatcher):
                    found[f"{name}.{attr}"] = {str(s) for s in value.signatures}
    return found

warm_up()
from replication.casestudy.jet import jet_force, surface_force
from replication.compare import compare
from replication.surfaces import adt, random_cloud
from replication.surfaces.nurbs import fit_nurbs

before = signatures()
compiled = event.RecordingListener()
event.register("numba:compile", compiled)
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
event.unregister("numba:compile", compiled)
added = {k: sorted(v - before.get(k, set())) for k, v in signatures().items() if v - before.get(k, set())}
names = sorted({str(e.data["dispatcher"]) for _, e in compiled.buffer if e.is_start})
print(json.dumps({"added": added, "compiled": names}))
"""


def test_after_warm_up_a_full_workload_compiles_nothing():
    done = subprocess.run([sys.executable, "-c", _WORKLOAD], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.splitlines()[-1])
    assert result == {"added": {}, "compiled": []}, result


# ---- warm_up(processes=2): the jet kernels compiled in a helper process ------------------------
# (the real thing, compiling into a fresh cache on two cores, is the session start of a fresh
# clone, which the test above then checks; these tests check what happens around the helper)


def _cold_shared(monkeypatch):
    """Make warm_up see a cold cache: its first step compiles something genuinely new."""
    import numba

    import replication.kernels as kernels

    shared = kernels._shared

    def cold():
        numba.njit(lambda x: x + 1)(1)  # not cached: a real "numba:compile" event
        return shared()

    monkeypatch.setattr(kernels, "_shared", cold)


def _helper(monkeypatch, code):
    import subprocess
    import sys

    import replication.kernels as kernels

    started = []

    def start():
        started.append(subprocess.Popen([sys.executable, "-c", code]))
        return started[-1]

    monkeypatch.setattr(kernels, "_start_helper", start)
    return started


def test_warm_up_loads_numbas_kernel_of_every_ahead_of_time_entry():
    """Each kernel of the table is in one warm-up group, and after warm_up numba's serves it."""
    from replication import _aot, kernels

    groups = (kernels.TRIANGULATION_KERNELS, kernels.INTERPOLATION_KERNELS, kernels.JET_KERNELS)
    names = [name for group in groups for name in group]
    assert sorted(names) == sorted(_aot.KERNELS)  # each exactly once
    warm_up()
    for name in _aot.KERNELS:
        assert _aot.kernel(name) is _aot._jit(name), name


def test_warm_up_starts_no_helper_when_the_cache_is_warm(monkeypatch):
    started = _helper(monkeypatch, "pass")
    warm_up(processes=2)
    assert started == []


def test_a_failing_helper_changes_nothing_but_the_time(monkeypatch):
    _cold_shared(monkeypatch)
    started = _helper(monkeypatch, "raise SystemExit(3)")
    warm_up(processes=2)
    assert [p.returncode for p in started] == [3]  # started, waited for; this process did the rest
    test_after_warm_up_a_full_workload_compiles_nothing()


def test_a_stuck_helper_is_stopped_after_the_timeout(monkeypatch):
    import replication.kernels as kernels

    _cold_shared(monkeypatch)
    started = _helper(monkeypatch, "import time; time.sleep(60)")
    monkeypatch.setattr(kernels, "HELPER_TIMEOUT", 0.5)
    warm_up(processes=2)
    assert len(started) == 1 and started[0].returncode is not None  # killed, not left running


def test_ctrl_c_during_warm_up_stops_the_helper(monkeypatch):
    import replication.kernels as kernels

    _cold_shared(monkeypatch)
    started = _helper(monkeypatch, "import time; time.sleep(60)")

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(kernels, "_triangulation", interrupted)
    with pytest.raises(KeyboardInterrupt):
        warm_up(processes=2)
    assert len(started) == 1 and started[0].returncode is not None


def test_the_real_helper_imports_this_package_whatever_the_working_directory(tmp_path, monkeypatch):
    # numba caches next to the sources: a helper that imported another copy of the package
    # (a checkout in the working directory, say) would compile into the wrong cache
    import replication.kernels as kernels

    (tmp_path / "replication").mkdir()
    (tmp_path / "replication" / "__init__.py").write_text("raise ImportError('the wrong copy')\n")
    monkeypatch.chdir(tmp_path)
    helper = kernels._start_helper()  # on a warm cache it only loads the kernels
    assert helper is not None and helper.wait(timeout=120) == 0
