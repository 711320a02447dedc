"""The SPH study's simulations run several at once, with results independent of how many."""

import dataclasses
import os
import subprocess
import sys
import time

import pandas as pd
import pytest

from replication.casestudy.evaluate import executor
from replication.errors import InputError
from replication.experiments.sph import SPHStudyConfig, run_sph_study
from sph_fake import fake_study_score

CONFIG = SPHStudyConfig(radii=(1.25e-3, 1.0e-3), wcsph=((1.25e-3, 10.0),), duration=0.014)


def test_a_study_on_two_worker_processes_equals_one_run_one_after_another():
    serial = run_sph_study(CONFIG, score=fake_study_score)
    seen: list[str] = []
    with executor("process", workers=2) as pool:
        parallel = run_sph_study(
            CONFIG, score=fake_study_score, executor=pool, max_parallel=2, on_run=seen.append
        )
    labels = [run.label for run in CONFIG.runs()]
    assert sorted(seen) == sorted(labels) and len(seen) == len(labels)  # every run reported once
    # rows in the study's order, whatever order the simulations finished in
    assert list(parallel.runs["radius_mm"]) == [1e3 * run.radius for run in CONFIG.runs()]
    for name in ("runs", "series", "shapes", "hypotheses"):
        pd.testing.assert_frame_equal(getattr(serial, name), getattr(parallel, name))
    assert serial.provenance["simulations_at_once"] == 1 and parallel.provenance["simulations_at_once"] == 2


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"radii": (1e-3, 1e-3)}, r"study radii must be distinct, got \(0.001, 0.001\)"),
        ({"wcsph": ((1e-3, 10.0), (1e-3, 10.0))}, "study wcsph runs must be distinct"),
    ],
)
def test_a_study_run_listed_twice_is_refused(changes, match):
    # was: simulated once, the cache giving the second, yet counted as run twice on the page
    with pytest.raises(InputError, match=match):
        dataclasses.replace(CONFIG, **changes)


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_max_parallel_must_be_a_positive_integer(bad):
    with pytest.raises(InputError, match="max_parallel must be a positive integer"):
        run_sph_study(CONFIG, score=fake_study_score, max_parallel=bad)


_CTRL_C_ABANDONS = """
import sys, time
from replication.casestudy.evaluate import executor

try:
    with executor("process", workers=2, abandon_on_interrupt=True) as pool:
        futures = [pool.submit(time.sleep, 600) for _ in range(2)]
        while not all(f.running() for f in futures):
            time.sleep(0.01)
        print(*[p.pid for p in pool._processes.values()], flush=True)
        time.sleep(0.5)
        raise KeyboardInterrupt
except KeyboardInterrupt:
    sys.exit(130)
"""


def test_ctrl_c_ends_an_abandoning_pool_at_once_and_leaves_no_worker():
    """The SPH study keeps nothing of an unfinished simulation: Ctrl-C does not wait for them."""
    started = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-c", _CTRL_C_ABANDONS], capture_output=True, text=True, timeout=300
    )
    assert time.monotonic() - started < 120  # not the 600 s of the tasks
    assert done.returncode == 130, done.stderr
    assert done.stderr == ""  # no traceback, no warning from the pool's leftovers
    for pid in map(int, done.stdout.split()):
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)  # ended (and reaped by the parent before it exited)


@pytest.mark.skipif(not __import__("replication.casestudy.sph", fromlist=["x"]).engine_available(),
                    reason='the SPH engine is not installed (pip install ".[sph]")')  # fmt: skip
def test_a_study_stopped_by_ctrl_c_keeps_its_finished_simulations_in_the_cache(tmp_path, monkeypatch):
    """`replication sph` kept nothing of a run stopped by Ctrl-C: a full study starts over."""
    from replication.casestudy import sph_batch
    from replication.casestudy.sph import sph_force

    quick = SPHStudyConfig.quick()
    finished: list[str] = []

    def stop_after_two(label: str) -> None:
        finished.append(label)
        if len(finished) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sph_study(quick, cache_dir=tmp_path / "cache", on_run=stop_after_two)
    assert len(list((tmp_path / "cache").glob("??/*"))) == 2
    simulated: list[int] = []

    def counting(*args, **kwargs):
        simulated.append(1)
        return sph_force(*args, **kwargs)

    monkeypatch.setattr("replication.casestudy.sph.sph_force", counting)
    again = run_sph_study(quick, cache_dir=tmp_path / "cache")
    assert len(simulated) == len(quick.runs()) - 2  # only what was missing
    assert again.provenance["sph_cache_hits"] == 2  # counted for the report's note on wall times
    fresh = run_sph_study(quick)  # no cache: the same study
    assert "sph_cache_hits" not in fresh.provenance
    for name in ("series", "shapes", "hypotheses"):
        pd.testing.assert_frame_equal(getattr(again, name), getattr(fresh, name))
    columns = [c for c in fresh.runs.columns if not c.startswith("wall_s")]  # (timings)
    pd.testing.assert_frame_equal(again.runs[columns], fresh.runs[columns])
    assert sph_batch.code_digest()  # (the cache's key includes the SPH code)


def test_the_sph_command_says_where_an_interrupted_study_s_simulations_are(tmp_path, monkeypatch, capsys):
    from replication.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("replication.casestudy.sph.require_engine", lambda: "2.19.0")
    monkeypatch.setattr("replication.experiments.sph.run_sph_study", interrupted)
    monkeypatch.chdir(tmp_path)
    assert main(["sph", "--quick", "--workers", "1", "--cache-dir", "cache"]) == 130
    err = capsys.readouterr().err
    cache = (tmp_path / "cache").resolve()
    assert f"interrupted: the simulations that finished are kept in the SPH cache {cache}; the same" in err


def test_a_cached_crash_is_simulated_again_and_a_cached_blowup_is_not(tmp_path, monkeypatch):
    """A crash is the machine's (no memory, a full disk): reusing it made every rerun fail."""
    from types import SimpleNamespace

    import numpy as np

    from replication.casestudy import sph_batch

    entries = {"crash": SimpleNamespace(ok=False, status="crash", wall_seconds=1.0),
               "blowup": SimpleNamespace(ok=False, status="blowup", wall_seconds=1.0),
               "short timeout": SimpleNamespace(ok=False, status="timeout", wall_seconds=5.0)}  # fmt: skip
    simulated = []
    monkeypatch.setattr(sph_batch, "cache_key", lambda *a, **k: "k" * 64)
    monkeypatch.setattr(sph_batch, "_simulate_into_cache", lambda *a, **k: simulated.append(1) or "fresh")
    for name, expected in (("crash", "fresh"), ("blowup", entries["blowup"]), ("short timeout", "fresh")):
        monkeypatch.setattr(sph_batch, "read_entry", lambda *a, entry=entries[name]: entry)
        got = sph_batch.cached_sph_force(np.zeros((3, 3)), np.array([[0, 1, 2]]), None, None,
                                         cache_dir=tmp_path, timeout=60.0)  # fmt: skip
        assert got == expected, name
    assert len(simulated) == 2


def test_the_sph_cache_is_checked_before_any_work(tmp_path, monkeypatch, capsys):
    from replication.cli import main

    monkeypatch.setattr("replication.casestudy.sph.require_engine", lambda: "2.19.0")
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".sph-cache").write_text("a file where the cache goes")
    # was: "unexpected FileExistsError", after the study had started
    assert main(["sph", "--quick", "--output-dir", "out"]) == 1
    err = capsys.readouterr().err
    assert "the SPH cache" in err and ".sph-cache" in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()
