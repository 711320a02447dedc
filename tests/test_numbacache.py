"""numba's cache of the kernels is flushed when any kernel source changes (replication._numbacache)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from replication._aot import source_digest
from replication._numbacache import STAMP_SUFFIX, _kernels, refresh

_CALL = """
from replication.surfaces import _predicates
print(_predicates.orient(0.0, 0.0, 1.0, 0.0, 0.0, 1.0))
"""


def _run(cache_dir):
    """A fresh interpreter that calls a cached kernel; numba's cache events on stdout."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), NUMBA_DEBUG_CACHE="1")
    done = subprocess.run([sys.executable, "-c", _CALL], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


def _stamp(cache_dir):
    found = list(Path(cache_dir).rglob(f"replication.surfaces._predicates{STAMP_SUFFIX}"))
    assert len(found) == 1, found
    return found[0]


@pytest.mark.slow
def test_a_stale_stamp_makes_numba_compile_the_kernels_again(tmp_path):
    first = _run(tmp_path)
    assert "data saved" in first and "data loaded" not in first  # an empty cache: compiled and saved
    stamp = _stamp(tmp_path)
    assert stamp.read_text() == str(source_digest())
    assert "data loaded" in _run(tmp_path)  # the stamp is current: numba's cached code is used
    stamp.write_text("0")  # as after an edit of any kernel source (the callees' modules included)
    again = _run(tmp_path)
    assert "data saved" in again and "data loaded" not in again  # flushed: compiled afresh
    assert stamp.read_text() == str(source_digest())


def test_only_a_module_s_own_cached_kernels_are_refreshed():
    from replication.surfaces import _sweephull

    names = {name for name, _ in _kernels(vars(_sweephull))}
    assert {"sweep", "legalize", "seed_triangle"} <= names
    assert "orient" not in names and "incircle" not in names  # _predicates' kernels, imported
    assert refresh({"__name__": "nothing", "x": 1}) == []


def test_a_current_stamp_flushes_nothing():
    from replication.surfaces import _moments

    assert refresh(vars(_moments)) == []  # the import has just refreshed it


def test_every_module_with_cached_kernels_refreshes_its_cache():
    """A new kernel module that forgot the call would keep stale code after its callees change."""
    import replication

    package = Path(replication.__file__).parent
    kernel_modules = [p for p in package.rglob("*.py") if "@njit(cache=True" in p.read_text()]
    assert len(kernel_modules) >= 10
    for path in kernel_modules:
        assert "\n_numbacache.refresh(globals())" in path.read_text(), path.relative_to(package)
