"""Scoring many surfaces with SPH: the content-addressed cache, resume, failures, parallelism.

The engine is replaced by ``fake_sph`` (same signature as ``sph_force``), which writes a
result whose force is a known function of the surface, so these tests run anywhere in
milliseconds; the real engine runs in ``test_jet_validation.py``.
"""

import concurrent.futures as cf
import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from replication.casestudy import JetConfig, flat_plate_cloud, sph_batch
from replication.casestudy.sph import SPHSettings
from replication.casestudy.sph_batch import (
    Plan,
    Scored,
    SurfaceTask,
    cache_key,
    code_digest,
    entry_path,
    read_entry,
    score_surfaces,
)
from replication.errors import InputError, SimulationError
from replication.surfaces import adt, random_cloud
from sph_fake import CALLS, REFUSED, RUNNING, fake_sph

SETTINGS = SPHSettings(particle_radius=1e-3, duration=0.016)
JET = JetConfig()


@pytest.fixture(autouse=True)
def _reset():
    CALLS.clear()
    RUNNING[:] = [0, 0]


def plate(height):
    s = adt(flat_plate_cloud(height), depth="z")
    return SurfaceTask(f"plate {height}", s.points, s.triangles)


def score(tasks, cache, **kwargs):
    return score_surfaces(tasks, SETTINGS, jet=JET, cache_dir=cache, simulate=fake_sph, **kwargs)


def test_a_rerun_reads_every_result_from_the_cache(tmp_path):
    tasks = [plate(h) for h in (1, 2, 3)]
    first = score(tasks, tmp_path)
    assert [s.status for s in first] == ["ok"] * 3 and not any(s.cached for s in first)
    assert [s.result.mean_axial for s in first] == [2.0, 3.0, 4.0]
    assert sorted(CALLS) == ["1", "2", "3"]
    CALLS.clear()
    again = score(tasks, tmp_path)
    assert CALLS == [] and all(s.cached for s in again)
    assert [s.result.mean_axial for s in again] == [2.0, 3.0, 4.0]
    assert [s.key for s in again] == [s.key for s in first]
    entry = entry_path(tmp_path, first[0].key)
    assert entry.parent.name == first[0].key[:2] and (entry / "result.json").is_file()
    assert not (entry / "column.pda").exists()  # large, regenerable inputs are dropped
    surface = json.loads((entry / "surface.json").read_text())
    assert surface["name"] == "plate 1" and np.array_equal(surface["points"], tasks[0].points)
    assert read_entry(tmp_path, first[0].key).mean_axial == 2.0


def test_equal_surfaces_are_simulated_once_and_keep_their_names(tmp_path):
    a, b = plate(4), plate(4)
    b = dataclasses.replace(b, name="the same plate")
    scored = score([a, b], tmp_path)
    assert CALLS == ["4"] and [s.name for s in scored] == ["plate 4", "the same plate"]
    assert scored[0].key == scored[1].key


def test_an_interrupted_run_resumes_where_it_stopped(tmp_path):
    tasks = [plate(h) for h in (1, 2, 3, 4)]

    def stop(scored):
        if len(CALLS) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        score(tasks, tmp_path, on_result=stop)
    assert sorted(CALLS) == ["1", "2"]
    CALLS.clear()
    scored = score(tasks, tmp_path)
    assert sorted(CALLS) == ["3", "4"]  # the finished two are not simulated again
    assert [s.cached for s in scored] == [True, True, False, False]
    assert not list(tmp_path.glob("*/.*partial*"))  # no scratch directory is left behind


def test_a_simulation_killed_midway_leaves_nothing_a_rerun_would_trust(tmp_path, monkeypatch):
    """A simulation interrupted before it finished (its files half written) is not an entry."""

    def dies(points, triangles, config, settings, *, timeout, run_dir):
        Path(run_dir).mkdir(parents=True)
        (Path(run_dir) / "steps.csv").write_text("step,time_s\n1,0.0")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        score_surfaces([plate(1)], SETTINGS, jet=JET, cache_dir=tmp_path, simulate=dies)
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]
    assert score([plate(1)], tmp_path)[0].status == "ok" and CALLS == ["1"]


def test_failures_are_recorded_the_study_carries_on_and_a_retry_is_asked_for(tmp_path):
    tasks = [plate(1), plate(13), plate(2)]  # 13 mm: "blowup"
    scored = score(tasks, tmp_path)
    assert [s.status for s in scored] == ["ok", "blowup", "ok"]
    assert scored[1].reason == "runaway velocities" and (scored[1].path / "result.json").is_file()
    CALLS.clear()
    assert score(tasks, tmp_path)[1].status == "blowup" and CALLS == []  # recorded, not retried
    again = score(tasks, tmp_path, retry_failed=True)
    assert CALLS == ["13"] and again[1].status == "blowup" and not again[1].cached


def test_a_task_that_raises_is_an_error_not_cached_and_the_others_finish(tmp_path):
    high = np.array(plate(1).points)
    high[0, 2] = REFUSED  # fake_sph refuses it
    bad = SurfaceTask("bad", high, plate(1).triangles)
    scored = score([plate(1), bad, plate(2)], tmp_path)
    assert [s.status for s in scored] == ["ok", "error", "ok"]
    assert "InputError: surface refused" in scored[1].reason and scored[1].path is None
    assert read_entry(tmp_path, scored[1].key) is None


def test_without_simulating_a_missing_surface_is_reported_missing(tmp_path):
    score([plate(1)], tmp_path)
    CALLS.clear()
    scored = score([plate(1), plate(2)], tmp_path, simulate_missing=False)
    assert [s.status for s in scored] == ["ok", "missing"] and CALLS == []


def test_the_plan_counts_cached_missing_and_to_simulate_apart(tmp_path):
    """The plan said "N from the cache" of surfaces that were missing from it (not simulated
    without simulate_missing); it now counts them apart, and says how many run at once."""
    plans = []
    score([plate(1)], tmp_path, on_plan=plans.append)
    score([plate(1), plate(2), plate(2)], tmp_path, simulate_missing=False, on_plan=plans.append)
    score([plate(h) for h in range(1, 6)], tmp_path, max_parallel=2, on_plan=plans.append)
    score([plate(1), plate(9)], tmp_path, max_parallel=4, on_plan=plans.append)
    assert plans == [Plan(0, 0, 1, 1), Plan(1, 1, 0, 0), Plan(1, 0, 4, 2), Plan(1, 0, 1, 1)]
    assert [p.distinct for p in plans] == [1, 2, 5, 2]


def test_at_most_max_parallel_simulations_run_at_once(tmp_path):
    with cf.ThreadPoolExecutor(max_workers=4) as pool:
        scored = score([plate(h) for h in range(1, 9)], tmp_path, executor=pool, max_parallel=2)
    assert all(s.ok for s in scored) and len(CALLS) == 8
    assert RUNNING[1] == 2


def test_a_broken_executor_is_one_error_naming_the_fix(tmp_path):
    pool = cf.ProcessPoolExecutor(1)
    pool.shutdown()
    pool._broken = "a worker died"  # what a killed worker leaves
    with pytest.raises(SimulationError, match="run again to resume"):
        score([plate(1)], tmp_path, executor=pool)


def test_the_key_covers_surface_jet_settings_engine_and_sph_code(monkeypatch):
    task = plate(1)
    key = cache_key(task.points, task.triangles, JET, SETTINGS, engine="2.19.0")
    assert key == cache_key(task.points.copy(), task.triangles.copy(), JET, SETTINGS, engine="2.19.0")
    other = plate(2)
    variants = [
        cache_key(other.points, other.triangles, JET, SETTINGS, engine="2.19.0"),
        cache_key(task.points, task.triangles[:, [1, 2, 0]], JET, SETTINGS, engine="2.19.0"),
        cache_key(task.points, task.triangles, JetConfig(velocity=4.0), SETTINGS, engine="2.19.0"),
        cache_key(
            task.points,
            task.triangles,
            JET,
            dataclasses.replace(SETTINGS, settle_time=0.008),
            engine="2.19.0",
        ),  # fmt: skip
        cache_key(task.points, task.triangles, JET, SETTINGS, engine="2.19.1"),
    ]
    monkeypatch.setattr(sph_batch, "code_digest", lambda: "0" * 64)
    variants.append(cache_key(task.points, task.triangles, JET, SETTINGS, engine="2.19.0"))
    assert len({key, *variants}) == len(variants) + 1


def test_the_code_digest_is_that_of_the_sph_package_sources():
    from replication.casestudy import sph

    digest = hashlib.sha256()
    files = sorted(Path(sph.__file__).parent.glob("*.py"))
    assert {"driver.py", "score.py", "analysis.py"} <= {p.name for p in files}
    for path in files:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    assert code_digest() == digest.hexdigest()


def test_bad_inputs_name_the_problem(tmp_path):
    with pytest.raises(InputError, match="shape"):
        SurfaceTask("x", np.zeros((3, 2)), [[0, 1, 2]])
    with pytest.raises(InputError, match="integer"):
        SurfaceTask("x", np.zeros((3, 3)), [[0.0, 1.0, 2.0]])
    with pytest.raises(InputError, match="max_parallel"):
        score([plate(1)], tmp_path, max_parallel=0)
    with pytest.raises(InputError, match="SPHSettings"):
        score_surfaces([plate(1)], {"particle_radius": 1e-3}, cache_dir=tmp_path, simulate=fake_sph)
    s = adt(random_cloud(30, rng=1), depth="x")
    with pytest.raises(InputError, match="depth axis z"):
        SurfaceTask.from_surface("bucket", s)


def test_scored_is_ok_only_for_a_finished_simulation():
    assert Scored("a", "k", "ok", None, None, True, None).ok
    assert not Scored("a", "k", "timeout", "slow", None, False, None).ok


def test_a_timeout_under_a_shorter_limit_is_simulated_again(tmp_path, monkeypatch):
    # validate-jet --timeout 0.001 cached 3 timeouts that every later run, at the default
    # 3600 s, reused as failures ("no simulation succeeded")
    import sph_fake

    monkeypatch.setattr(sph_fake, "FORCE_STATUS", "timeout")  # the fake takes 0.02 s of wall time
    first = score([plate(1)], tmp_path, timeout=0.01)
    assert first[0].status == "timeout" and CALLS == ["1"]
    assert score([plate(1)], tmp_path, timeout=0.015)[0].cached  # a limit no longer: the same timeout
    monkeypatch.setattr(sph_fake, "FORCE_STATUS", None)
    again = score([plate(1)], tmp_path, timeout=60)
    assert again[0].status == "ok" and not again[0].cached and CALLS == ["1", "1"]


def test_an_entry_published_meanwhile_by_another_command_is_used(tmp_path, monkeypatch):
    # two validate-jet commands on one cache: the rename into an entry the other had just published
    # failed (Directory not empty) and was recorded as the simulation failing
    import shutil

    real_replace = sph_batch.os.replace
    raced = []

    def other_command_first(src, dst):
        if not raced and Path(src).is_dir():  # the other command publishes its entry just before
            raced.append(dst)
            twin = Path(f"{src}-other")
            shutil.copytree(src, twin)
            real_replace(twin, dst)
        return real_replace(src, dst)

    monkeypatch.setattr(sph_batch.os, "replace", other_command_first)
    result = score([plate(1)], tmp_path)
    assert raced and result[0].status == "ok" and result[0].result.mean_axial == 2.0
    assert list(tmp_path.rglob(".*partial*")) == []


@pytest.mark.parametrize("failure", ["ours", "system"])
def test_a_cache_that_cannot_be_written_stops_the_study_in_one_line(tmp_path, failure):
    """A full disk under the SPH cache was recorded as a failed simulation of every surface, and
    the command drew a report made of such failures and exited 0."""
    import errno

    from replication.errors import OutputError

    def full_disk(points, triangles, config, settings, *, timeout, run_dir):
        if points[:, 2].max() < 2:  # the first plate is simulated; the disk is full from the next
            return fake_sph(points, triangles, config, settings, timeout=timeout, run_dir=run_dir)
        if failure == "ours":
            raise OutputError(f"cannot write {run_dir}/solid.obj: No space left on device")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OutputError, match=r"^cannot simulate into the SPH cache .*No space left on device; "
                       r"the simulations finished before are kept there"):  # fmt: skip
        tasks = [plate(1), plate(2), plate(3)]
        score_surfaces(tasks, SETTINGS, jet=JET, cache_dir=tmp_path, simulate=full_disk)
    assert score([plate(1)], tmp_path, simulate_missing=False)[0].status == "ok"  # kept: no rerun needed


def test_other_system_errors_of_a_task_are_recorded_as_its_failure(tmp_path):
    def refused(points, triangles, config, settings, *, timeout, run_dir):
        raise PermissionError(13, "Permission denied")

    scored = score_surfaces([plate(1)], SETTINGS, jet=JET, cache_dir=tmp_path, simulate=refused)
    assert scored[0].status == "error" and "Permission denied" in scored[0].reason


def test_scratch_directories_of_killed_simulations_are_removed_by_the_next_run(tmp_path):
    """A simulation killed outright (SIGKILL) left its scratch directory in the cache for good."""
    import os
    import subprocess
    import sys

    from replication.io.atomic import writer_tag

    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    dead_tag = writer_tag().replace(str(os.getpid()), ended.stdout.decode().strip(), 1)
    key = "ab" + "0" * 62
    abandoned = tmp_path / "ab" / f".{key}{sph_batch.PARTIAL}{dead_tag}1234abcd"
    running = tmp_path / "ab" / f".{key}{sph_batch.PARTIAL}{writer_tag()}5678abcd"  # this process: alive
    foreign = tmp_path / "cd" / f".{'cd' + '0' * 62}{sph_batch.PARTIAL}1.otherhost-9abc"  # another machine
    for path in (abandoned, running, foreign):
        (path / "engine").mkdir(parents=True)
        (path / "engine" / "state.bin").write_bytes(b"x" * 100)
    assert score([plate(1)], tmp_path)[0].status == "ok"
    assert not abandoned.exists() and running.exists() and foreign.exists()
