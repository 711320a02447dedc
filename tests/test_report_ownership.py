"""Who writes reports/: the paper's settings only; other runs report beside their run or elsewhere."""

import argparse
import shutil

import pandas as pd
import pytest

from replication.cli import main


def _args(**changes):
    base = dict(quick=False, runs=None, generations=None, population=None, seed=None, run_dir=None,
                resume=False, executor="serial", workers=None, scheduler=None, output_dir=None)  # fmt: skip
    return argparse.Namespace(**{**base, **changes})


@pytest.mark.parametrize(
    ("changes", "where", "noted"),
    [
        ({}, "reports", False),
        ({"generations": 50, "population": 48}, "reports", False),  # the paper's values, given explicitly
        ({"quick": True}, "reports-quick", False),
        ({"runs": 1}, "RUN/report", True),
        ({"seed": 7}, "RUN/report", True),
        ({"quick": True, "population": 24}, "RUN/report", True),
        ({"runs": 1, "output_dir": "mine"}, "mine", False),
        ({"output_dir": "reports"}, "reports", False),
    ],
)
def test_where_the_case_study_reports(tmp_path, monkeypatch, changes, where, noted):
    from replication.cli.casestudy import plan_casestudy

    monkeypatch.chdir(tmp_path)
    plan = plan_casestudy(_args(run_dir="RUN", **changes))
    assert str(plan.out) == where and bool(plan.note) == noted
    if noted:
        assert "settings differ from the paper's" in plan.note and "(paper: " in plan.note
    assert list(tmp_path.iterdir()) == []  # planning creates nothing


def _checkout(root):
    """A stand-in for a checkout of the project: its README and pyproject.toml, no reports yet."""
    from pathlib import Path

    source = Path(__file__).resolve().parents[1]
    for name in ("README.md", "pyproject.toml"):
        shutil.copy(source / name, root / name)
    return (root / "README.md").read_text()


@pytest.mark.parametrize(
    ("command", "named"),
    [
        (["reproduce", "--quick"], "--quick"),
        (["table1", "--quick"], "--quick"),
        (["sph", "--quick"], "--quick"),
        (["casestudy", "--quick"], "--quick"),
        (
            ["casestudy", "--runs", "1", "--generations", "2"],
            "generations 2 (paper: 50) and runs 1 (paper: 3)",
        ),
        (["casestudy", "--rescore", "sph"], "--rescore sph"),
        # the quick settings given one by one are named as given
        (
            ["casestudy", "--population", "12", "--generations", "6"],
            "population 12 (paper: 48) and generations 6 (paper: 50)",
        ),
        (["validate-jet", "--timeout", "1"], "--timeout 1"),
        (["validate-jet", "--timeout", "1", "--ga-run-dir", "ga"], "--timeout 1 and --ga-run-dir ga"),
        (["report", "--performance", "--commits", "3"], "--commits 3"),
    ],
)
def test_a_run_with_other_settings_never_writes_a_checkout_s_committed_reports(
    tmp_path, monkeypatch, capsys, command, named
):
    # was: `casestudy --runs 1 --generations 2 --population 8 --output-dir reports` replaced the
    # committed case study and put "best GA surfaces 4.41-4.41 N" into the README's headline
    monkeypatch.chdir(tmp_path)
    readme = _checkout(tmp_path)
    if command[0] == "report":
        (tmp_path / "reports").mkdir()  # report redraws what is there
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main([*command, "--output-dir", "reports"]) == 2
    err = capsys.readouterr().err
    assert "--output-dir reports is a checkout's committed reports" in err
    assert f"a run with {named} would replace them: name another directory" in err
    assert len(err.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # refused before any work
    assert (tmp_path / "README.md").read_text() == readme


def test_the_paper_s_settings_and_other_directories_are_not_refused(tmp_path, monkeypatch):
    from replication.cli.casestudy import plan_casestudy
    from replication.cli.outputs import check_not_committed

    monkeypatch.chdir(tmp_path)
    _checkout(tmp_path)
    assert str(plan_casestudy(_args(run_dir="RUN", output_dir="reports")).out) == "reports"  # the paper's
    assert str(plan_casestudy(_args(run_dir="RUN", runs=1, output_dir="mine")).out) == "mine"
    check_not_committed(tmp_path / "reports-quick", ["--quick"])  # not the committed reports/
    check_not_committed(tmp_path / "reports", [])  # nothing custom
    (tmp_path / "elsewhere").mkdir()
    check_not_committed(tmp_path / "elsewhere" / "reports", ["--quick"])  # no checkout beside it
    with pytest.raises(Exception, match="committed reports"):  # the same directory by another name
        check_not_committed(tmp_path / "elsewhere" / ".." / "reports", ["--quick"])
    # a checkout whose reports/ is a symbolic link to a store elsewhere: it was not recognised
    (tmp_path / "store").mkdir()
    (tmp_path / "linked").mkdir()
    _checkout(tmp_path / "linked")
    (tmp_path / "linked" / "reports").symlink_to(tmp_path / "store", target_is_directory=True)
    with pytest.raises(Exception, match="committed reports"):
        check_not_committed(tmp_path / "linked" / "reports", ["--quick"])
    check_not_committed(tmp_path / "store", ["--quick"])  # the store by its own name is not reports/
    # inside the committed reports: `table1 --quick --output-dir reports/figures` wrote its report there
    (tmp_path / "reports" / "figures").mkdir(parents=True)
    for inside in ("reports/figures", "reports/figures/new", "linked/reports/data"):
        with pytest.raises(
            Exception, match=f"--output-dir {tmp_path / inside} is inside a checkout's committed"
        ):
            check_not_committed(tmp_path / inside, ["--quick"])


@pytest.mark.parametrize(
    ("command", "linked"),
    [
        (["table1", "--quick"], "data"),
        (["table1", "--quick"], "figures"),
        (["table1", "--quick"], "data/table1_meshes"),
        (["table1"], "data"),  # the paper's settings too: its pages here, its data there
        (["casestudy", "--runs", "1", "--generations", "2", "--run-dir", "run"], "figures"),
        (["report"], "data"),
    ],
)
def test_a_subdirectory_linked_into_the_committed_reports_is_refused(
    tmp_path, monkeypatch, capsys, command, linked
):
    """`table1 --quick --output-dir trial` with trial/data a link to reports/data replaced the
    committed data set (and `report` then drew it into the committed pages and the README)."""
    monkeypatch.chdir(tmp_path)
    readme = _checkout(tmp_path)
    committed = tmp_path / "reports" / linked
    committed.mkdir(parents=True)
    (committed / "kept.csv").write_text("x\n1\n")
    trial = tmp_path / "trial" / linked
    trial.parent.mkdir(parents=True, exist_ok=True)
    trial.symlink_to(committed, target_is_directory=True)
    assert main([*command, "--output-dir", "trial"]) == 2
    err = capsys.readouterr().err
    leads = f"--output-dir trial: its {linked}/ leads into {tmp_path / 'reports'}, a checkout's committed"
    assert leads in err
    assert len(err.splitlines()) == 1
    assert [p.name for p in committed.iterdir()] == ["kept.csv"]
    assert (tmp_path / "README.md").read_text() == readme
    assert not (tmp_path / "run").exists()  # refused before the GA's run directory was made


def test_resuming_keeps_the_run_s_own_destination(tmp_path, monkeypatch):
    from replication.casestudy.ga import GAConfig
    from replication.casestudy.runner import check_run_dir
    from replication.cli.casestudy import plan_casestudy

    monkeypatch.chdir(tmp_path)
    check_run_dir("paper", GAConfig())
    check_run_dir("trial", GAConfig(runs=1, population=24, generations=5))
    assert str(plan_casestudy(_args(run_dir="paper", resume=True)).out) == "reports"
    assert str(plan_casestudy(_args(run_dir="trial", resume=True)).out) == "trial/report"


@pytest.mark.slow
def test_a_render_that_fails_on_its_data_removes_no_figure(capsys, quick_reports, tmp_path):
    """The stale figures were cleared before the data was read: a provenance without the
    duplicate policy (or a shapes table without the flat plate) failed the render after all
    six case-study figures were gone, while the old casestudy.md still linked to them."""
    import json

    out = tmp_path / "rep"
    shutil.copytree(quick_reports / "data", out / "data", ignore=shutil.ignore_patterns("table1*"))
    shutil.copytree(quick_reports / "figures", out / "figures")
    before = sorted(p.name for p in (out / "figures").iterdir())
    provenance = out / "data" / "casestudy_provenance.json"
    record = json.loads(provenance.read_text())
    del record["config"]["duplicates"]
    provenance.write_text(json.dumps(record))
    assert main(["report", "--output-dir", str(out)]) == 1
    assert sorted(p.name for p in (out / "figures").iterdir()) == before
    capsys.readouterr()


def _forget_checksums(provenance):
    """A provenance without the checksums of its files, as a set saved before they were recorded."""
    import json

    record = json.loads(provenance.read_text())
    record.pop("data_files")
    provenance.write_text(json.dumps(record))


def test_report_states_settings_and_keeps_no_stale_figures(capsys, quick_reports, tmp_path):
    out = tmp_path / "rep"
    shutil.copytree(quick_reports / "data", out / "data", ignore=shutil.ignore_patterns("table1*"))
    shutil.copytree(quick_reports / "figures", out / "figures")
    (out / "figures" / "mine.png").write_bytes(b"not ours")
    assert (out / "figures" / "casestudy_best_run2.png").is_file() and (
        out / "figures" / "table1_fig6.png"
    ).is_file()
    for name in ("best", "runs", "history"):  # the data of a rerun with runs 0 and 1 only
        path = out / "data" / f"casestudy_{name}.csv"
        frame = pd.read_csv(path)
        frame[frame["run"] < 2].to_csv(path, index=False)
    _forget_checksums(out / "data" / "casestudy_provenance.json")  # as a save would have recorded them
    assert main(["report", "--output-dir", str(out)]) == 0
    figures = sorted(p.name for p in (out / "figures").iterdir())
    assert "casestudy_best_run2.png" not in figures and "casestudy_best_run1.png" in figures
    assert "mine.png" in figures and "table1_fig6.png" in figures  # not the case study's: kept
    text = (out / "casestudy.md").read_text()
    assert (
        "**Quick run (a reduced GA for smoke testing)**: population 12 (paper: 48); generations 6 (paper: 50)"
        in text
    )
    assert "Settings (the paper's except as stated at the top)" in text
    assert "replication casestudy               # the paper's settings (this report)" not in text
    assert "replication reproduce --quick" in text.split("## Reproduce")[1]  # the command that made it


def test_no_import_circle_in_the_command_line_package():
    """cli modules import one way (the casestudy <-> reports pair included), at any depth."""
    import ast
    from pathlib import Path

    import replication.cli

    package = Path(replication.cli.__file__).parent
    graph = {}
    for path in package.glob("*.py"):
        module = f"replication.cli.{path.stem}" if path.stem != "__init__" else "replication.cli"
        targets = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("replication.cli"):
                names = [f"{node.module}.{a.name}" for a in node.names]
                targets |= {
                    n for n in names if n.rsplit(".", 1)[-1] in {p.stem for p in package.glob("*.py")}
                }
                targets.add(node.module)
        graph[module] = {t for t in targets if t != module and t != "replication.cli"}

    def reaches(start, goal, seen=()):
        return any(
            t == goal or (t not in seen and reaches(t, goal, (*seen, t))) for t in graph.get(start, ())
        )

    circles = sorted(m for m in graph if reaches(m, m))
    assert circles == [], circles


@pytest.mark.slow
def test_every_data_file_is_named_by_a_report(quick_reports):
    """Data no page points to cannot be found by a reader: table1_meshes/, the agreement table
    and the provenance records were named by none."""
    pages = {p.stem: p.read_text() for p in quick_reports.glob("*.md")}
    everything = "\n".join(pages.values())
    data = quick_reports / "data"
    for path in sorted(data.iterdir()):
        name = path.name
        prefix = next((stem for stem in pages if name.startswith(f"{stem}_")), None)
        named = (f"data/{name}/" if path.is_dir() else f"data/{name}") in everything or (
            prefix is not None
            and f"`_{name[len(prefix) + 1 :]}`" in pages[prefix]  # `_series.csv` beside data/...
        )
        assert named, name
