"""Failure paths of the SPH backend, with stand-in child programs (no engine needed):
a timeout, a crash, the engine's exit(), a blow-up, an interrupt, a missing engine."""

import json
import os
import sys
import textwrap
import time

import numpy as np
import pytest

import replication.casestudy.sph as sph_package
from replication.casestudy import JetConfig, flat_plate_cloud
from replication.casestudy.sph import SPHForce, SPHSettings, score
from replication.casestudy.sph.process import run_child
from replication.cli import main
from replication.errors import InputError, SimulationError, SolverUnavailableError
from replication.io import save_cloud

PROLOGUE = """
import json, os, pathlib, signal, sys, time
run = pathlib.Path(sys.argv[-1])
(run / "pid").write_text(str(os.getpid()))
def progress(t):
    (run / "progress.json").write_text(json.dumps({"time": t, "steps": 1}))
"""

CHILDREN = {
    "sleeps": "progress(0.004)\ntime.sleep(120)",
    "segfaults": "progress(0.002)\nos.kill(os.getpid(), signal.SIGSEGV)",
    "exits": "print('Load scene file: x'); print('[ERROR]: no such scene: x.json', flush=True)\nsys.exit(1)",
    "blows_up": textwrap.dedent("""
        progress(0.003)
        (run / "outcome.json").write_text(json.dumps({"status": "blowup", "reason": "runaway velocities"}))
        os._exit(3)"""),
    "raises": textwrap.dedent("""
        (run / "outcome.json").write_text(json.dumps({"status": "error", "reason": "OSError: libGL.so.1"}))
        os._exit(2)"""),
    "finishes": textwrap.dedent("""
        for k in range(1, 6):
            progress(0.001 * k)
            time.sleep(0.05)
        (run / "outcome.json").write_text(json.dumps({"status": "ok", "reason": None}))"""),
}


@pytest.fixture
def child(tmp_path):
    """A stand-in for the driver: ``child(name)`` -> the command that runs it."""

    def make(name):
        script = tmp_path / f"{name}.py"
        script.write_text(PROLOGUE + CHILDREN[name] + "\n")
        return [sys.executable, str(script)]

    return make


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_a_timeout_kills_the_child(tmp_path, child):
    start = time.monotonic()
    out = run_child(tmp_path, timeout=1.0, command=child("sleeps"), poll=0.05)
    assert time.monotonic() - start < 15
    assert out.status == "timeout" and "no result after 1 s (simulated 4 ms" in out.reason
    assert not alive(int((tmp_path / "pid").read_text()))


def test_a_segfault_is_a_crash(tmp_path, child):
    out = run_child(tmp_path, timeout=30, command=child("segfaults"))
    assert out.status == "crash" and "SIGSEGV" in out.reason and "2 ms" in out.reason


def test_the_engines_exit_is_a_crash_with_its_log_line(tmp_path, child):
    out = run_child(tmp_path, timeout=30, command=child("exits"))
    assert out.status == "crash" and out.returncode == 1
    assert "exited with status 1" in out.reason and "[ERROR]: no such scene: x.json" in out.reason
    assert "Load scene file" in (tmp_path / "engine.log").read_text()  # the child's output is in the log


def test_a_blowup_and_a_caught_error(tmp_path, child):
    out = run_child(tmp_path, timeout=30, command=child("blows_up"))
    assert out.status == "blowup" and out.reason == "runaway velocities at t = 3 ms"
    out = run_child(tmp_path, timeout=30, command=child("raises"))
    assert out.status == "crash" and "OSError: libGL.so.1" in out.reason


def test_progress_is_relayed(tmp_path, child):
    seen = []
    out = run_child(tmp_path, timeout=30, command=child("finishes"), progress=seen.append, poll=0.01)
    assert out.status == "ok" and out.reason is None and out.returncode == 0
    assert seen == sorted(seen) and seen[-1] == pytest.approx(0.005)


def test_an_interrupt_of_the_caller_kills_the_child(tmp_path, child):
    def interrupt(t):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_child(tmp_path, timeout=60, command=child("sleeps"), progress=interrupt, poll=0.05)
    pid = int((tmp_path / "pid").read_text())
    deadline = time.monotonic() + 5
    while alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not alive(pid)


@pytest.fixture
def fake_engine(monkeypatch, child):
    """sph_force with the engine 'installed' and a stand-in child (also where the engine is not)."""
    import replication.casestudy.sph as sph_package

    monkeypatch.setattr(score, "require_engine", lambda: "2.19.0")
    monkeypatch.setattr(sph_package, "require_engine", lambda: "2.19.0")  # what the command line asks

    def use(name):
        command = child(name)
        real = score.run_child
        monkeypatch.setattr(score, "run_child", lambda d, **kw: real(d, **{**kw, "command": command}))

    return use


def test_a_failed_simulation_is_a_result_with_its_reason(tmp_path, fake_engine):
    fake_engine("segfaults")
    cloud = flat_plate_cloud()
    from replication.surfaces import adt

    s = adt(cloud, depth="z")
    result = score.sph_force(s.points, s.triangles, JetConfig(), SPHSettings(particle_radius=1e-3),
                             run_dir=tmp_path / "run")  # fmt: skip
    assert result.status == "crash" and "SIGSEGV" in result.reason and not result.ok
    assert np.isnan(result.mean_axial) and np.isnan(result.peak_axial) and result.steps == 0
    with pytest.raises(
        SimulationError, match=r"SPH simulation failed \(crash\): the engine crashed \(SIGSEGV\)"
    ):
        result.check()
    back = SPHForce.from_dict(json.loads(json.dumps(result.as_dict(), allow_nan=False)))
    assert back.status == "crash" and back.key == result.key and np.isnan(back.mean_axial)
    assert back.settings == result.settings and back.jet == result.jet
    assert (tmp_path / "run" / "result.json").is_file() and (tmp_path / "run" / "scene.json").is_file()


def test_input_errors_come_before_the_engine(monkeypatch):
    monkeypatch.setattr(score, "ENGINE", "no_such_engine_module")
    with pytest.raises(InputError, match="outside the domain"):
        score.sph_force([[0, 0, 0], [90, 0, 0], [0, 9, 0]], [[0, 1, 2]])
    with pytest.raises(SolverUnavailableError, match=r'pip install "\.\[sph\]"'):
        score.sph_force([[0, 0, 0], [9, 0, 0], [0, 9, 0]], [[0, 1, 2]])


def test_engine_missing_is_one_line_on_the_command_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(score, "ENGINE", "no_such_engine_module")
    assert not score.engine_available() and not sph_package.engine_available()
    path = tmp_path / "flat.csv"
    save_cloud(flat_plate_cloud(), path)
    assert main(["force", str(path), "--solver", "sph", "--json"]) == 1
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith("replication force: error: the SPH solver") and 'pip install ".[sph]"' in err
    assert main(["sph", "--quick", "--output-dir", str(tmp_path / "r")]) == 1
    assert 'pip install ".[sph]"' in capsys.readouterr().err


def test_a_failed_simulation_is_one_line_on_the_command_line(monkeypatch, tmp_path, capsys, fake_engine):
    fake_engine("sleeps")
    monkeypatch.setattr(score, "DEFAULT_TIMEOUT", 0.5)
    path = tmp_path / "flat.csv"
    save_cloud(flat_plate_cloud(), path)
    code = main(["force", str(path), "--solver", "sph", "--particle-radius", "1", "--timeout", "0.5"])
    out, err = capsys.readouterr()
    assert code == 1 and out == ""
    lines = [line for line in err.splitlines() if "error" in line]
    assert lines == [lines[0]] and "SPH simulation failed (timeout): no result after 0.5 s" in lines[0]


def test_sph_options_need_the_sph_solver(tmp_path, capsys):
    path = tmp_path / "flat.csv"
    save_cloud(flat_plate_cloud(), path)
    assert main(["force", str(path), "--particle-radius", "1"]) == 2  # a misused command line
    assert "--particle-radius applies only with --solver sph" in capsys.readouterr().err


def run_in_worker(run_dir, command):
    """What an executor's worker does for the GA: start the child, wait, report its status."""
    return run_child(run_dir, timeout=60, command=command).status


def test_the_child_starts_from_a_daemonic_pool_worker(tmp_path, child):
    """multiprocessing cannot start children from daemonic workers (multiprocessing.Pool, dask);
    a subprocess can, which is why the engine runs in one."""
    import multiprocessing

    with multiprocessing.get_context("spawn").Pool(1) as pool:
        assert pool.apply(run_in_worker, (tmp_path, child("finishes"))) == "ok"
