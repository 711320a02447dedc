"""--resume: settings from the run directory, the printed hint works, runs end bit-identical."""

import functools
import json
import shlex

import pytest

from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import check_run_dir, run_ga
from replication.cli import main

pytestmark = pytest.mark.slow

TINY = GAConfig(runs=1, generations=3, population=6)
TINY_ARGS = ["--runs", "1", "--generations", "3", "--population", "6", "--executor", "serial"]


def _interrupt_after(monkeypatch, generations):
    """Ctrl-C right after ``generations`` more generations were checkpointed (in-process)."""
    from replication.cli.progress import Progress

    class Interrupting(Progress):
        def update(self, steps=1, **postfix):
            super().update(steps, **postfix)
            Interrupting.count += steps
            if Interrupting.count >= generations:
                raise KeyboardInterrupt

    Interrupting.count = 0
    monkeypatch.setattr("replication.cli.casestudy.Progress", Interrupting)


def _state(path):
    state = json.loads(path.read_text())
    state.pop("seconds")  # wall-clock times are not state
    return state


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """Uninterrupted runs (serial, in-process): the TINY run and the quick configuration's 3 runs."""
    from replication.experiments.casestudy import quick_ga_config

    out = {}
    for name, config in (("tiny", TINY), ("quick", quick_ga_config())):
        run_dir = tmp_path_factory.mktemp(name)
        for k in range(config.runs):
            run_ga(config, k, run_dir=run_dir, pool_factory=functools.partial(executor, "serial"))
        out[name] = run_dir
    return out


def _hint(err):
    line = next(line for line in err.splitlines() if line.startswith("interrupted: "))
    return shlex.split(line.split("resume with: ", 1)[1])


def test_only_explicit_settings_are_compared(capsys, tmp_path, monkeypatch, reference):
    import argparse

    from replication.cli.casestudy import plan_casestudy

    monkeypatch.chdir(tmp_path)
    run_dir = tmp_path / "run"
    check_run_dir(run_dir, TINY)  # a run interrupted in generation 0: config.json, no checkpoint
    base = ["casestudy", "--run-dir", str(run_dir), "--resume", "--executor", "serial"]
    assert main([*base, "--population", "8"]) == 1
    err = capsys.readouterr().err.replace(str(run_dir), "RUN_DIR")  # the path may hold "runs"
    assert "--population 8 (the run has 6)" in err and "generations" not in err and "runs" not in err
    assert main([*base, "--quick"]) == 1
    assert "--generations 6 (the run has 3)" in capsys.readouterr().err
    args = argparse.Namespace(
        runs=None, generations=3, population=6, seed=None,  # the recorded settings, given again
        quick=False, run_dir=str(run_dir), resume=True, executor="serial", workers=None, scheduler=None,
        output_dir=None,
    )  # fmt: skip
    plan = plan_casestudy(args)
    assert plan.config == TINY and plan.resume and plan.done_generations == 0
    # the hint keeps where the fitness was evaluated: the report times the evaluations, and a
    # run interrupted on one worker and resumed on all would report another evaluation cost
    assert shlex.split(plan.hint)[-2:] == ["--executor", "serial"]
    on_one = plan_casestudy(argparse.Namespace(**{**vars(args), "executor": "process", "workers": 1}))
    assert shlex.split(on_one.hint)[-4:] == ["--executor", "process", "--workers", "1"]
    # the printed hint's form: no settings at all; the run starts from generation 0 and ends as
    # an uninterrupted one, its report in its own directory (not the paper's settings)
    assert main(base) == 0, capsys.readouterr().err
    assert _state(run_dir / "run-0.json") == _state(reference["tiny"] / "run-0.json")
    assert (run_dir / "report" / "casestudy.md").is_file() and not (tmp_path / "reports").exists()


def test_nothing_to_resume(capsys, tmp_path):
    (tmp_path / "empty").mkdir()
    for run_dir in (tmp_path / "empty", tmp_path / "missing"):
        assert main(["casestudy", "--run-dir", str(run_dir), "--resume"]) == 1
        assert "nothing to resume" in capsys.readouterr().err


def test_hint_after_an_interrupted_reproduce_quick(capsys, tmp_path, monkeypatch, reference):
    """reproduce --quick, Ctrl-C in the GA stage; the printed command finishes the reports."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {0}, raising=False)  # one usable CPU: serial
    monkeypatch.setattr(
        "replication.cli.reports._run_table1", lambda out, quick, command, workers=None: out / "table1.md"
    )
    monkeypatch.setattr("replication.casestudy.sph.engine_available", lambda: False)  # 6 s, not the point
    _interrupt_after(monkeypatch, 4)  # during the second of the three quick runs
    out = tmp_path / "quick-reports"
    assert main(["reproduce", "--quick", "--output-dir", str(out)]) == 130
    hint = _hint(capsys.readouterr().err)
    assert hint[hint.index("--output-dir") + 1] == str(out)
    run_dir = tmp_path / hint[hint.index("--run-dir") + 1]
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert main([*hint[1:], "--executor", "serial"]) == 0, capsys.readouterr().err
    for k in range(3):
        assert _state(run_dir / f"run-{k}.json") == _state(reference["quick"] / f"run-{k}.json")
    text = (out / "casestudy.md").read_text()
    assert "Quick run" in text and "[Figs. 8 and 9](casestudy.md)" in (out / "index.md").read_text()


def test_a_run_directory_in_use_is_refused_and_left_as_it_is(capsys, tmp_path, monkeypatch):
    """Two commands on one run directory at once: the second one, whose settings differed, used to
    delete the first one's config.json and directory on its way out (both runs lost). It is now
    refused before it writes or removes anything, with the same settings too (no mixed runs)."""
    from replication.casestudy.rundir import CONFIG_NAME, hold, write_config

    monkeypatch.chdir(tmp_path)
    run_dir = tmp_path / "shared"
    argv = ["casestudy", "--run-dir", str(run_dir), "--executor", "serial", "--runs", "1"]
    argv += ["--generations", "3", "--population", "6"]
    with hold(run_dir):  # the first command, running
        assert main(argv) == 1
        assert "shared is in use by another command running the GA there" in capsys.readouterr().err
        assert sorted(p.name for p in run_dir.iterdir()) == [".lock"]
        write_config(run_dir, TINY)  # it gets going: same settings as the second command's
        assert main(argv) == 1 and "in use" in capsys.readouterr().err
        assert sorted(p.name for p in run_dir.iterdir()) == [".lock", CONFIG_NAME]
    assert main(argv) == 0, capsys.readouterr().err  # free again: the second command runs
    assert (run_dir / "run-0.json").is_file()


def test_two_commands_started_in_the_same_second_get_run_directories_of_their_own(
    capsys, tmp_path, monkeypatch
):
    """Default run directories were named by the second: two commands started in the same second
    chose one name before either created it (``reproduce`` creates it only after Table 1, minutes
    later), and the later one was refused as "in use" or found the other's checkpoints."""
    import datetime as dt
    import os

    from replication.cli import casestudy as cli_casestudy

    class SameSecond(dt.datetime):
        @classmethod
        def now(cls, tz=None):
            return cls(2026, 11, 23, 9, 45, 0)

    monkeypatch.setattr(cli_casestudy.dt, "datetime", SameSecond)
    monkeypatch.chdir(tmp_path)
    with monkeypatch.context() as other:
        other.setattr(os, "getpid", os.getppid)  # another process: the first command, still planning
        first = cli_casestudy._new_run_dir()
    assert main(["casestudy", *TINY_ARGS]) == 0, capsys.readouterr().err
    (second,) = (tmp_path / "casestudy-runs").iterdir()
    assert second.name.startswith("run-20261123-094500-") and (second / "run-0.json").is_file()
    assert not (tmp_path / first).exists()  # the first command's directory is still its own to create


def test_ctrl_c_while_the_report_data_are_saved_keeps_the_previous_data_set(capsys, tmp_path, monkeypatch):
    """A second case study into the same --output-dir, stopped as it wrote its provenance: the
    first run's tables were already replaced, so `report` showed seed 6's runs under seed 5's
    header. Now the previous data set stays whole and the hint finishes the second. (The second
    run has the first's settings: one of others may not replace its data set at all.)"""
    import replication.report.casestudy as report_casestudy

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "mix"
    first = ["casestudy", *TINY_ARGS, "--seed", "5", "--output-dir", str(out), "--run-dir", "r5"]
    assert main(first) == 0
    before = {p.name: p.read_bytes() for p in (out / "data").iterdir()}
    real = report_casestudy.write_json

    def ctrl_c(data, path):
        raise KeyboardInterrupt

    monkeypatch.setattr(report_casestudy, "write_json", ctrl_c)
    second = ["casestudy", *TINY_ARGS, "--seed", "5", "--output-dir", str(out), "--run-dir", "r6"]
    assert main(second) == 130
    err = capsys.readouterr().err
    assert "interrupted while saving the data: every run is complete in r6" in err
    assert {p.name: p.read_bytes() for p in (out / "data").iterdir()} == before
    monkeypatch.setattr(report_casestudy, "write_json", real)
    hint = shlex.split(err.split("save them with: ", 1)[1].splitlines()[0])
    assert main(hint[1:]) == 0
    provenance = json.loads((out / "data" / "casestudy_provenance.json").read_text())
    assert "r6" in provenance["command"] and "r6" not in before["casestudy_provenance.json"].decode()


def test_ctrl_c_held_while_the_data_are_moved_into_place_says_they_were_saved(capsys, tmp_path, monkeypatch):
    """The Ctrl-C came as the new data were moved into place, so it was held until they all
    were; the message said the previous data were as they were, and offered to save again."""
    import os
    import signal

    monkeypatch.chdir(tmp_path)
    real_replace = os.replace
    sent = []

    def replace(src, dst):
        if os.path.basename(os.path.dirname(dst)) == "data" and not sent:  # publishing the data set
            sent.append(dst)
            os.kill(os.getpid(), signal.SIGINT)
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    assert main(["casestudy", *TINY_ARGS, "--seed", "6", "--output-dir", "out", "--run-dir", "r6"]) == 130
    err = capsys.readouterr().err
    assert len(sent) == 1 and "are as they were" not in err, err
    assert "interrupted once the data were saved in out/data: draw the report with: " in err
    assert err.strip().splitlines()[-1].startswith("replication casestudy: interrupted after writing ")
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    provenance = json.loads((tmp_path / "out" / "data" / "casestudy_provenance.json").read_text())
    assert provenance["config"]["seed"] == 6  # the new data, all of them
    hint = shlex.split(err.split("draw the report with: ", 1)[1].splitlines()[0])
    assert hint == ["replication", "report", "--output-dir", "out"] and main(hint[1:]) == 0


@pytest.mark.slow
def test_the_printed_resume_works_however_soon_the_command_is_killed(tmp_path):
    """The resume line came about a second before config.json was written: a command killed in
    that window (SIGKILL, a lost machine) left a hint that answered "nothing to resume"."""
    import os
    import signal
    import subprocess
    import sys

    command = [sys.executable, "-m", "replication", "casestudy", *TINY_ARGS, "--output-dir", "out",
               "--run-dir", "run"]  # fmt: skip
    process = subprocess.Popen(command, cwd=tmp_path, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                               text=True, start_new_session=True)  # fmt: skip
    try:
        line = process.stderr.readline()
        os.killpg(process.pid, signal.SIGKILL)  # at once, once the hint is out
    finally:
        process.kill()
        process.communicate()
    assert line.startswith("GA run directory: run (after an interruption, resume with: "), line
    hint = shlex.split(line.split("resume with: ", 1)[1].rstrip().removesuffix(")"))
    previous = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(hint[1:]) == 0
    finally:
        os.chdir(previous)
    assert json.loads((tmp_path / "run" / "run-0.json").read_text())["generation"] == 3


def test_ctrl_c_while_table1_is_drawn_says_the_data_are_saved(capsys, tmp_path, monkeypatch):
    def ctrl_c(out, workers=1):
        raise KeyboardInterrupt

    saved = []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("replication.experiments.table1.run_table1", lambda config, **kw: "results")
    monkeypatch.setattr("replication.report.table1.save_table1_data", lambda *args: saved.append(args))
    monkeypatch.setattr("replication.report.table1.render_table1", ctrl_c)
    assert main(["table1", "--quick", "--output-dir", "out dir"]) == 130
    err = capsys.readouterr().err
    assert [(res, str(out)) for res, out in saved] == [("results", "out dir")]
    assert "interrupted while drawing the report: its data are saved in out dir/data" in err
    hint = shlex.split(err.split("draw it with: ", 1)[1].splitlines()[0])
    assert hint == ["replication", "report", "--output-dir", "out dir"]
    assert err.strip().splitlines()[-1] == "replication table1: interrupted"


def test_ctrl_c_held_while_table1_s_data_are_published_says_they_were_saved(capsys, tmp_path, monkeypatch):
    from pathlib import Path

    from replication.io.atomic import note_written

    def saved_then_ctrl_c(results, out):
        exc = KeyboardInterrupt()
        note_written(exc, [Path(out) / "data" / "table1_provenance.json"])  # as data_set does
        raise exc

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("replication.experiments.table1.run_table1", lambda config, **kw: "results")
    monkeypatch.setattr("replication.report.table1.save_table1_data", saved_then_ctrl_c)
    assert main(["table1", "--quick", "--output-dir", "out"]) == 130
    first, last = capsys.readouterr().err.strip().splitlines()
    assert first == "interrupted once the data were saved in out/data: draw the report with: " + shlex.join(
        ["replication", "report", "--output-dir", "out"]
    )
    assert last == "replication table1: interrupted after writing 1 file (out/data/table1_provenance.json)"


@pytest.mark.parametrize("when", ["saved", "drawn"])
def test_the_sph_study_says_its_data_are_saved_when_interrupted_after_saving_them(
    when, capsys, tmp_path, monkeypatch
):
    """table1 and casestudy said where their saved data were, and how to draw them, when a
    Ctrl-C came once they were saved; the SPH study (and validate-jet, which shares the
    code) ended with a bare "interrupted"."""
    from replication.io.atomic import note_written

    def saved_then_ctrl_c(results, out):
        exc = KeyboardInterrupt()
        note_written(exc, [out / "data" / "sph_provenance.json"])
        raise exc

    def ctrl_c(out):
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("replication.casestudy.sph.require_engine", lambda: None)
    monkeypatch.setattr("replication.experiments.sph.run_sph_study", lambda config, **kw: "results")
    if when == "saved":
        monkeypatch.setattr("replication.report.sph.save_sph_data", saved_then_ctrl_c)
    else:
        monkeypatch.setattr("replication.report.sph.save_sph_data", lambda results, out: None)
        monkeypatch.setattr("replication.report.sph.render_sph", ctrl_c)
    assert main(["sph", "--quick", "--output-dir", "out", "--workers", "1"]) == 130
    lines = capsys.readouterr().err.strip().splitlines()
    draw = shlex.join(["replication", "report", "--output-dir", "out"])
    if when == "saved":
        assert lines[-2] == f"interrupted once the data were saved in out/data: draw the report with: {draw}"
        assert lines[-1] == "replication sph: interrupted after writing 1 file (out/data/sph_provenance.json)"
    else:
        said = f"interrupted while drawing the report: its data are saved in out/data; draw it with: {draw}"
        assert lines[-2:] == [said, "replication sph: interrupted"]


@pytest.mark.parametrize("command", ["table1", "casestudy"])
def test_an_error_while_the_report_is_drawn_says_the_data_are_saved(command, capsys, tmp_path, monkeypatch):
    """A full disk while the figures were drawn left the new data beside the earlier run's page,
    and the one-line error did not say so."""
    from replication.errors import OutputError

    def full_disk(out, workers=1):
        raise OutputError(f"cannot write {out}/figures/fig.png: No space left on device")

    monkeypatch.chdir(tmp_path)
    if command == "table1":
        monkeypatch.setattr("replication.experiments.table1.run_table1", lambda config, **kw: "results")
        monkeypatch.setattr("replication.report.table1.save_table1_data", lambda *args: None)
        monkeypatch.setattr("replication.report.table1.render_table1", full_disk)
        argv = ["table1", "--quick", "--output-dir", "out"]
    else:
        monkeypatch.setattr("replication.report.casestudy.render_casestudy", full_disk)
        argv = ["casestudy", *TINY_ARGS, "--output-dir", "out", "--run-dir", "r"]
    assert main(argv) == 1
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last == (
        f"replication {command}: error: cannot write out/figures/fig.png: No space left on device; the new "
        "data are saved in out/data: once that is fixed, draw the report with: "
        "replication report --output-dir out"
    )


def test_ctrl_c_while_the_report_is_drawn_says_the_data_are_saved(capsys, tmp_path, monkeypatch):
    def ctrl_c(out, workers=1):
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("replication.report.casestudy.render_casestudy", ctrl_c)
    argv = ["casestudy", *TINY_ARGS, "--seed", "6", "--output-dir", "out", "--run-dir", "r6"]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "interrupted while drawing the report: its data are saved in out/data" in err
    hint = shlex.split(err.split("draw it with: ", 1)[1].splitlines()[0])
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert hint == ["replication", "report", "--output-dir", "out"] and main(hint[1:]) == 0
    assert (
        json.loads((tmp_path / "out" / "data" / "casestudy_provenance.json").read_text())["config"]["seed"]
        == 6
    )


def test_resume_and_draw_hints_name_directories_that_start_with_a_dash_as_paths(
    capsys, tmp_path, monkeypatch, reference
):
    """``-run`` printed bare in a hint was read by argparse as an option ("expected one argument")."""
    monkeypatch.chdir(tmp_path)
    _interrupt_after(monkeypatch, 1)
    assert main(["casestudy", *TINY_ARGS, "--output-dir=-out", "--run-dir=-run"]) == 130
    hint = _hint(capsys.readouterr().err)
    assert hint[hint.index("--run-dir") + 1] == "./-run" and hint[hint.index("--output-dir") + 1] == "./-out"

    def ctrl_c(out, workers=1):
        raise KeyboardInterrupt

    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("replication.report.casestudy.render_casestudy", ctrl_c)
    assert main(hint[1:]) == 130  # the resume, as printed, runs the GA to its end
    assert _state(tmp_path / "-run" / "run-0.json") == _state(reference["tiny"] / "run-0.json")
    draw = shlex.split(capsys.readouterr().err.split("draw it with: ", 1)[1].splitlines()[0])
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert draw == ["replication", "report", "--output-dir", "./-out"] and main(draw[1:]) == 0
    assert (tmp_path / "-out" / "casestudy.md").is_file()


@pytest.mark.parametrize("how", ["ctrl-c", "full disk"])
def test_an_earlier_run_s_page_left_beside_new_data_says_it_is_out_of_date(
    how, capsys, tmp_path, monkeypatch
):
    """A second case study into the same directory, its drawing cut short: the first run's
    casestudy.md stayed beside the second's data and read as their report."""
    from replication.errors import OutputError
    from replication.report.pages import OUT_OF_DATE, is_ours

    def cut_short(out, workers=1):
        if how == "ctrl-c":
            raise KeyboardInterrupt
        raise OutputError("No space left on device")

    monkeypatch.chdir(tmp_path)
    assert main(["casestudy", *TINY_ARGS, "--output-dir", "out", "--run-dir", "r1"]) == 0
    page = tmp_path / "out" / "casestudy.md"
    first = page.read_text()
    assert OUT_OF_DATE not in first
    monkeypatch.setattr("replication.report.casestudy.render_casestudy", cut_short)
    assert main(["casestudy", *TINY_ARGS, "--output-dir", "out", "--run-dir", "r2"]) == (
        130 if how == "ctrl-c" else 1
    )
    capsys.readouterr()
    marked = page.read_text()
    title, blank, note = marked.splitlines()[:3]
    assert title == first.splitlines()[0] and blank == ""
    assert note == (
        f"{OUT_OF_DATE} drawn from an earlier run's data, which a later run has replaced in data/ "
        "before this page could be drawn again. Draw it with `replication report --output-dir out`."
    )
    assert marked.replace(f"{note}\n\n", "", 1) == first and is_ours(page)
    # the index is drawn after the page: its headline is the earlier run's too
    assert (tmp_path / "out" / "index.md").read_text().splitlines()[2] == note
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert main(["report", "--output-dir", "out"]) == 0
    assert OUT_OF_DATE not in page.read_text() and "r2" in page.read_text()
    assert OUT_OF_DATE not in (tmp_path / "out" / "index.md").read_text()
