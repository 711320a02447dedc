"""The case study end to end: report structure, numbers equal the CSV data, CLI and resume."""

import json

import numpy as np
import pandas as pd
import pytest

from mdtables import find, number, parse_tables
from replication.cli import main

pytestmark = pytest.mark.slow


def test_report_structure(quick_reports):
    text = (quick_reports / "casestudy.md").read_text()
    for heading in ("## What was run", "## The paper's numbers beside ours", "## Reference shapes",
                    "## Fig. 8", "## Fig. 9", "## Runs", "## What differs from the paper",
                    "## How this report was made"):  # fmt: skip
        assert heading in text, heading
    assert "Quick run" in text and "- Command: `replication reproduce --quick" in text
    for name in ("casestudy_fig8.png", "casestudy_fig8.svg", "casestudy_fig9.png", "casestudy_best_run0.png"):
        assert (quick_reports / "figures" / name).is_file(), name
    assert "[Figs. 8 and 9](casestudy.md)" in (quick_reports / "index.md").read_text()


def test_the_evaluation_cost_states_its_rounds_which_scale_with_the_ga(quick_reports):
    from replication.experiments.casestudy import default_timing_repeats, quick_ga_config

    prov = json.loads((quick_reports / "data/casestudy_provenance.json").read_text())
    rounds = default_timing_repeats(quick_ga_config())
    assert prov["evaluation_timing"]["repeats"] == rounds == 21
    text = (quick_reports / "casestudy.md").read_text()
    assert f"Cost of one evaluation (ADT + jet model, {rounds} rounds, " in text
    evaluation = pd.read_csv(quick_reports / "data/casestudy_evaluation.csv")
    assert list(evaluation["individual"]) == ["flat plate", "pelton bucket", "random"]
    assert (evaluation["q1"] <= evaluation["median"]).all()
    assert (evaluation["median"] <= evaluation["q3"]).all()


def test_claims_and_shapes_equal_csv(quick_reports):
    found = parse_tables((quick_reports / "casestudy.md").read_text())
    claims = pd.read_csv(quick_reports / "data/casestudy_claims.csv")
    shown = find(found, "claim", "verdict", "why")
    assert len(shown) == len(claims)
    for (_, row), (_, data) in zip(shown.iterrows(), claims.iterrows()):
        assert row["claim"] == data["claim"] and row["verdict"].strip("*") == data["verdict"]
        assert abs(number(row["ours"]) - data["ours"]) <= 5e-4 * abs(data["ours"])  # 4 significant digits
        if data["claim"] == "neither the flat plate nor the bucket is the optimum":  # issue 11, item 4
            assert "the thin-sheet model's (the GA's fitness)" in row["why"] and "SPH" in row["why"]
    shapes = pd.read_csv(quick_reports / "data/casestudy_shapes.csv")
    shown = find(found, "shape", "paper, SPH")
    for (_, row), (_, data) in zip(shown.iterrows(), shapes.iterrows()):
        assert abs(number(row["ours [N]"]) - data["axial_N"]) <= 5e-4 * data["axial_N"]
        assert row["paper, SPH"] == data["paper_sph"]  # verbatim, with its unit


def test_runs_table_equals_csv(quick_reports):
    found = parse_tables((quick_reports / "casestudy.md").read_text())
    runs = pd.read_csv(quick_reports / "data/casestudy_runs.csv")
    shown = find(found, "best force [N]", "saved by cache")
    for (_, row), (_, data) in zip(shown.iterrows(), runs.iterrows()):
        assert abs(number(row["best force [N]"]) - data["best_N"]) <= 5e-4 * data["best_N"]
        assert number(row["evaluations"]) == data["evaluations"]
        assert number(row["saved by cache"]) == data["cache_hits"]
    history = pd.read_csv(quick_reports / "data/casestudy_history.csv")
    best = history.groupby("run")["best_so_far"].last().to_numpy()
    np.testing.assert_allclose(best, runs["best_N"])


TINY = ["--runs", "2", "--generations", "3", "--population", "6", "--executor", "serial"]


def test_casestudy_cli_json_and_resume(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    args = ["casestudy", *TINY, "--run-dir", "run", "--output-dir", "out", "--json"]
    assert main(args) == 0
    first = json.loads(capsys.readouterr().out)
    assert len(first["runs"]) == 2 and first["evaluations"] + first["saved_by_cache"] == 2 * 3 * 6
    assert all(len(v) == 3 for v in first["best_so_far_N"].values())
    assert set(first["reference_shapes_N"]) == {"flat plate", "pelton bucket"}
    assert (tmp_path / "out" / "casestudy.md").is_file()
    prov = json.loads((tmp_path / "out" / "data" / "casestudy_provenance.json").read_text())
    assert prov["evaluation_timing"]["repeats"] == 5  # 36 evaluations: not outnumbered by the timing

    # the run directory holds checkpoints: refused without --resume, nothing overwritten
    assert main(args) == 1
    assert "--resume" in capsys.readouterr().err
    # resuming finished runs reproduces the same results
    assert main([*args, "--resume"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["runs"] == first["runs"] and again["best_so_far_N"] == first["best_so_far_N"]
    # other settings are refused
    assert main(["casestudy", *TINY[:4], "--population", "8", "--executor", "serial", "--run-dir", "run",
                 "--output-dir", "out", "--resume"]) == 1  # fmt: skip
    assert "--population 8 (the run has 6)" in capsys.readouterr().err


def test_casestudy_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["casestudy", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for phrase in ("--resume", "--scheduler", "--workers", "checkpointed"):
        assert phrase in out


def test_resume_needs_a_run_directory_with_checkpoints(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["casestudy", *TINY, "--resume"]) == 2  # --resume without --run-dir: misused
    assert "name the directory to resume" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["casestudy", *TINY, "--resume", "--run-dir", "empty"]) == 1
    assert "nothing to resume" in capsys.readouterr().err


_RENDER = """
import sys
from replication.report import parallel
from replication.report.casestudy import render_casestudy
from replication.report.table1 import render_table1

decided = []  # whether each render forked its figure workers, asked when it draws them
fork_is_safe = parallel.fork_is_safe
parallel.fork_is_safe = lambda: decided.append(fork_is_safe()) or decided[-1]
render_table1(sys.argv[1], workers=2)
render_casestudy(sys.argv[1], workers=2)
print(*decided)
"""


def test_figures_drawn_on_two_processes_are_the_files_of_the_reports(quick_reports, tmp_path):
    """Table 1 and the case study rendered with their figures on two forked processes (a fresh
    interpreter: the test process itself may have rendered with VTK) give the reports' files
    byte for byte. Those are a one-process render's too: ``test_report_rerenders_from_data_alone``
    (test_table1_report.py) re-renders every report in one process and compares every file."""
    import shutil
    import subprocess
    import sys

    two = tmp_path / "two"
    shutil.copytree(quick_reports / "data", two / "data")
    command = [sys.executable, "-c", _RENDER, str(two)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    # both reports' figures really went to forked workers: Table 1's drawing left the
    # process able to fork for the case study's
    assert done.stdout.split() == ["True", "True"]
    for report in ("table1", "casestudy"):
        drawn = sorted(p.name for p in (two / "figures").glob(f"{report}_*"))
        assert drawn == sorted(p.name for p in (quick_reports / "figures").glob(f"{report}_*"))
        assert any(name.endswith(".png") for name in drawn) and any(name.endswith(".svg") for name in drawn)
        for name in [f"{report}.md", *(f"figures/{name}" for name in drawn)]:
            assert (two / name).read_bytes() == (quick_reports / name).read_bytes(), name
