"""A saved data set is replaced only by a run of its own settings or when it is a quick run's,
and a reports directory says which of its data sets are not the paper's settings."""

import json
import shutil
from pathlib import Path

import pytest

from replication.cli import main
from replication.report.settings import (
    QUICK,
    describe,
    replacement_refused,
    saved_settings,
    settings_note,
)

COMMITTED = Path(__file__).resolve().parents[1] / "reports" / "data"


def _provenance(data: Path, prefix: str, **record) -> None:
    data.mkdir(parents=True, exist_ok=True)
    (data / f"{prefix}_provenance.json").write_text(json.dumps(record))


def _copy_data_set(prefix: str, into: Path) -> dict[str, bytes]:
    """The committed data set ``prefix`` (made with the paper's settings) copied into ``into/data``;
    the bytes of every file there."""
    data = into / "data"
    data.mkdir(parents=True, exist_ok=True)
    for path in COMMITTED.glob(f"{prefix}_*"):
        if path.is_dir():
            shutil.copytree(path, data / path.name)
        else:
            shutil.copy(path, data / path.name)
    return _contents(into)


def _contents(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_the_settings_a_data_set_was_saved_with(tmp_path):
    from replication.casestudy.ga import GAConfig
    from replication.experiments.casestudy import quick_ga_config

    data = tmp_path / "data"
    assert saved_settings(data, "table1") is None  # nothing saved
    _provenance(data, "table1", config={"quick": True})  # Table 1 records quick in its configuration
    assert saved_settings(data, "table1") == QUICK
    _provenance(data, "sph", quick=False, config={})
    assert saved_settings(data, "sph") == ()
    paper = GAConfig().as_dict()
    _provenance(data, "casestudy", quick=False, config=paper)
    assert saved_settings(data, "casestudy") == ()
    _provenance(data, "casestudy", quick=False, config={**paper, "seed": 7}, solver={"kind": "sph"})
    assert saved_settings(data, "casestudy") == ("seed 7 (paper: 2019)", "--solver sph")
    _provenance(data, "casestudy", quick=True, config=quick_ga_config().as_dict(), rescore={})
    assert saved_settings(data, "casestudy") == (*QUICK, "--rescore sph")
    (data / "jet_validation_provenance.json").write_text("{not json")  # the report refuses it, when drawn
    assert saved_settings(data, "jet_validation") is None
    for prefix in ("table1", "sph", "jet_validation", "casestudy"):  # the committed ones: the paper's
        assert saved_settings(COMMITTED, prefix) == ()


@pytest.mark.parametrize(
    ("saved", "run", "refused"),
    [
        ((), (), False),  # a regeneration
        (QUICK, (), False),  # a quick run is a minute's smoke test: anything may replace it
        (QUICK, ("seed 7 (paper: 2019)",), False),
        ((), QUICK, True),  # the audit's case: a quick run over the paper's
        (("seed 7 (paper: 2019)",), (), True),  # a run of other settings, which may have taken hours
        (("seed 7 (paper: 2019)",), ("seed 8 (paper: 2019)",), True),
        (("seed 7 (paper: 2019)",), ("seed 7 (paper: 2019)",), False),
        ((*QUICK, "--solver sph"), QUICK, True),  # a quick run scored by SPH is not a minute's
    ],
)
def test_which_data_sets_a_run_may_replace(tmp_path, saved, run, refused):
    from replication.casestudy.ga import GAConfig
    from replication.experiments.casestudy import quick_ga_config

    quick = saved[:1] == QUICK
    config = quick_ga_config().as_dict() if quick else GAConfig().as_dict()
    for item in saved[1 if quick else 0 :]:
        if item.startswith("seed "):
            config["seed"] = int(item.split()[1])
    record = {"quick": quick, "config": config, **({"solver": {}} if "--solver sph" in saved else {})}
    _provenance(tmp_path, "casestudy", **record)
    assert saved_settings(tmp_path, "casestudy") == saved
    why = replacement_refused(tmp_path, "casestudy", run)
    assert (why is not None) == refused
    if refused:
        assert why == (
            f"holds a case study with {describe(saved)} (data/casestudy_provenance.json) "
            f"that a run with {describe(run)} would replace"
        ).replace("(data/", f"({tmp_path.name}/")


@pytest.mark.parametrize(
    ("command", "prefixes", "kind"),
    [
        (["table1", "--quick"], ["table1"], "a Table 1 run"),
        (["reproduce", "--quick"], ["table1", "casestudy"], "a Table 1 run"),
        (["sph", "--quick"], ["sph"], "an SPH study"),
        (["validate-jet", "--quick"], ["jet_validation"], "a jet-model validation study"),
        (["casestudy", "--quick"], ["casestudy"], "a case study"),
        (["casestudy", "--runs", "1", "--generations", "2"], ["casestudy"], "a case study"),
        (["casestudy", "--solver", "sph"], ["casestudy"], "a case study"),
    ],
)
def test_a_run_of_other_settings_does_not_replace_a_saved_data_set(
    tmp_path, monkeypatch, capsys, command, prefixes, kind
):
    # was: `table1 --quick --output-dir DIR`, DIR holding a full run, replaced its data without a
    # word, and DIR's index put the quick Table 1 beside the full case study
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "mine"
    for prefix in prefixes:
        _copy_data_set(prefix, out)
    before = _contents(tmp_path)
    assert main([*command, "--output-dir", "mine"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert f"--output-dir mine holds {kind} with the paper's settings (data/" in err
    assert "name another directory, or move mine/data/" in err and "_* away first" in err
    assert _contents(tmp_path) == before  # refused before any work: no run directory, no page
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_the_data_sets_in_the_way_are_named_as_a_shell_reads_them(tmp_path, monkeypatch, capsys):
    """ "move my reports/data/table1_* away" was three words to a shell: the path is quoted."""
    import subprocess

    monkeypatch.chdir(tmp_path)
    _copy_data_set("table1", tmp_path / "my reports")
    assert main(["table1", "--quick", "--output-dir", "my reports"]) == 2
    err = capsys.readouterr().err
    said = err.split("or move ", 1)[1].split(" away first", 1)[0]
    assert said == "'my reports/data/table1'_*", err
    listed = subprocess.run(["sh", "-c", f"ls -d {said}"], capture_output=True, text=True, check=True)
    expected = sorted(
        f"my reports/data/{p.name}" for p in (tmp_path / "my reports" / "data").glob("table1_*")
    )
    assert sorted(listed.stdout.splitlines()) == expected and expected


def test_a_data_set_in_the_way_under_a_dash_directory_is_named_as_a_path(tmp_path, monkeypatch, capsys):
    # "move -dash/data/table1_* away": mv took -dash/... for options ("invalid option -- 'd'")
    monkeypatch.chdir(tmp_path)
    _copy_data_set("table1", tmp_path / "-dash")
    assert main(["table1", "--quick", "--output-dir", "./-dash"]) == 2
    assert "or move ./-dash/data/table1_* away first" in capsys.readouterr().err


def test_a_run_replaces_its_own_settings_and_a_quick_run(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    tiny = ["casestudy", "--runs", "1", "--generations", "2", "--population", "6", "--executor", "serial"]
    _provenance(tmp_path / "mine" / "data", "casestudy", quick=True, config={})  # a quick run's
    assert main([*tiny, "--output-dir", "mine", "--run-dir", "one"]) == 0
    first = json.loads((tmp_path / "mine" / "data" / "casestudy_provenance.json").read_text())
    assert "one" in first["command"]
    assert main([*tiny, "--output-dir", "mine", "--run-dir", "two"]) == 0  # the same settings again
    second = json.loads((tmp_path / "mine" / "data" / "casestudy_provenance.json").read_text())
    assert "two" in second["command"]
    capsys.readouterr()
    assert main([*tiny[:-4], "--population", "8", "--output-dir", "mine", "--run-dir", "three"]) == 2
    assert "population 6 (paper: 48)" in capsys.readouterr().err
    assert not (tmp_path / "three").exists()


def test_the_index_names_data_sets_of_other_settings(quick_reports, tmp_path):
    from replication.report.index import render_index

    index = (quick_reports / "index.md").read_text()
    assert "(section 6) (*quick run*: reduced settings, a smoke test)" in index
    assert "- *Not the paper's settings*: the Table 1 run with --quick; " in index
    # the committed reports: the paper's settings, nothing said
    assert (
        settings_note(COMMITTED, "table1") == ""
        and "Not the paper's" not in (COMMITTED.parent / "index.md").read_text()
    )
    # a case study with another seed, beside Table 1 with the paper's settings
    _copy_data_set("table1", tmp_path)
    _copy_data_set("casestudy", tmp_path)
    path = tmp_path / "data" / "casestudy_provenance.json"
    record = json.loads(path.read_text())
    record["config"]["seed"] = 7  # the checksums are those of the other files: still whole
    path.write_text(json.dumps(record))
    text = render_index(tmp_path).read_text()
    assert "- *Not the paper's settings*: the case study with seed 7 (paper: 2019). Numbers drawn" in text
    assert "(*other settings*: seed 7 (paper: 2019))" not in text  # no casestudy.md here: not linked
    (tmp_path / "casestudy.md").write_text((COMMITTED.parent / "casestudy.md").read_text())
    assert "(*other settings*: seed 7 (paper: 2019))" in render_index(tmp_path).read_text()


def test_a_quick_page_names_itself_in_its_reproduce_block(quick_reports):
    table1 = (quick_reports / "table1.md").read_text()
    assert "# a reduced run for smoke testing (under a minute) (this report)\n" in table1
    assert "replication table1            # the full run, then renders it" in table1
    committed = (COMMITTED.parent / "table1.md").read_text()
    assert "replication table1            # the full run (this report), then renders it" in committed


def test_report_does_not_fill_a_checkout_s_readme_from_other_reports(
    quick_reports, tmp_path, monkeypatch, capsys
):
    # was: `report --output-dir reports-quick --readme README.md` wrote the quick numbers into
    # the checkout's README, whose headline states the committed reports' numbers
    from test_report_ownership import _checkout

    monkeypatch.chdir(tmp_path)
    readme = _checkout(tmp_path)
    shutil.copytree(quick_reports, tmp_path / "reports-quick")
    assert main(["report", "--output-dir", "reports-quick", "--readme", "README.md"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1
    assert "--readme README.md is a checkout's README, whose headline states the numbers of its" in err
    assert (tmp_path / "README.md").read_text() == readme
    (tmp_path / "link.md").symlink_to("README.md")  # a link to it: its target is what is written
    assert main(["report", "--output-dir", "reports-quick", "--readme", "link.md"]) == 2
    assert "--readme link.md is a checkout's README" in capsys.readouterr().err
    assert main(["report", "--output-dir", "reports-quick", "--readme", "/dev/stdout"]) == 1
    assert "--readme /dev/stdout names an open file descriptor" in capsys.readouterr().err
    assert (tmp_path / "README.md").read_text() == readme
    shutil.copy(tmp_path / "README.md", tmp_path / "copy.md")  # a copy is anyone's to fill
    assert main(["report", "--output-dir", "reports-quick", "--readme", "copy.md"]) == 0
    assert "Not the paper's settings" in (tmp_path / "copy.md").read_text()


def test_quick_page_wording():
    import pandas as pd

    from replication.report.table1 import _exponent, _span

    assert _span(pd.Series([100.0, 99.8]), ".0f") == "100"  # was "100-100 %"
    assert _span(pd.Series([11.2, 26.0]), ".0f") == "11-26"
    assert _exponent(1.04, float("nan")) == "1.04 (too few sizes for a standard error)"  # was "± –"
    assert _exponent(1.04, 0.012) == "1.04 ± 0.01"


_KILLED_WHILE_PUBLISHING = """
import os, signal, sys
from pathlib import Path
from replication.report import store
real, moved = store._publish, []
def dying(source, target):
    if len(moved) == 1:
        os.kill(os.getpid(), signal.SIGKILL)
    moved.append(target)
    real(source, target)
store._publish = dying
with store.data_set(Path(sys.argv[1]), "table1_provenance.json") as staged:
    (staged / "table1_a.csv").write_text("paper a\\n")
    (staged / "table1_b.csv").write_text("paper b\\n")
    (staged / "table1_provenance.json").write_text('{"config": {"quick": false}}\\n')
"""


def test_a_save_killed_while_it_publishes_is_the_data_set_a_run_may_not_replace(
    tmp_path, monkeypatch, capsys
):
    # a run of the paper's settings killed while it published over a quick run's data left no
    # provenance: the check saw nothing in the way, and a quick run finished the killed save
    # and put its own data over it without a word
    import subprocess
    import sys

    monkeypatch.chdir(tmp_path)
    data = tmp_path / "mine" / "data"
    _provenance(data, "table1", config={"quick": True})
    (data / "table1_a.csv").write_text("quick a\n")
    killed = subprocess.run([sys.executable, "-c", _KILLED_WHILE_PUBLISHING, str(data)], check=False)
    assert killed.returncode == -9 and not (data / "table1_provenance.json").exists()
    assert main(["table1", "--quick", "--output-dir", "mine"]) == 2
    assert "holds a Table 1 run with the paper's settings" in capsys.readouterr().err
    assert (data / "table1_a.csv").read_text() == "paper a\n"  # the killed save, finished


def test_sph_settings_of_a_rescored_case_study_are_its_settings(tmp_path):
    from replication.report.settings import sph_option

    base = {"quick": True, "config": {}}
    _provenance(tmp_path, "casestudy", **base, rescore={"top": 2, "settings": {"particle_radius": 0.0015}})
    rescored = "--rescore sph (--top 2, --particle-radius 1.5 mm)"
    assert saved_settings(tmp_path, "casestudy") == (*QUICK, rescored)
    # another top or radius is another run; the defaults are named by the option alone
    assert replacement_refused(tmp_path, "casestudy", (*QUICK, "--rescore sph (--top 1)")) is not None
    assert replacement_refused(tmp_path, "casestudy", saved_settings(tmp_path, "casestudy")) is None
    assert sph_option("--solver sph", None) == "--solver sph"
    from replication.casestudy.sph.settings import SPHSettings

    assert sph_option("--solver sph", SPHSettings().as_dict(), 5) == "--solver sph"


@pytest.mark.parametrize(
    ("command", "options"),
    [
        ("replication validate-jet --rebuild-surfaces --cache-dir /c --output-dir /r", ()),
        ("replication validate-jet --timeout 60 --ga-run-dir 'a b'", ("--timeout 60", "--ga-run-dir a b")),
        ("replication validate-jet --timeout=60.0 --from-cache", ()),  # nothing simulated: no timeout
        ("replication validate-jet --ga-run-dir=ga", ("--ga-run-dir ga",)),
    ],
)
def test_a_validation_study_s_other_settings_are_read_from_its_command(tmp_path, command, options):
    # a study of another GA's winners replaced the committed one without a word, labelled the paper's
    _provenance(tmp_path, "jet_validation", quick=False, config={}, command=command)
    assert saved_settings(tmp_path, "jet_validation") == options
    assert (replacement_refused(tmp_path, "jet_validation", ()) is None) == (options == ())


def test_a_report_whose_data_lost_their_provenance_is_marked_and_left_out_of_the_headline(
    quick_reports, tmp_path, capsys
):
    shutil.copytree(quick_reports, tmp_path / "q")
    (tmp_path / "q" / "data" / "table1_provenance.json").unlink()  # a removed file
    assert main(["report", "--output-dir", str(tmp_path / "q")]) == 0
    assert "holds table1 tables without their provenance" in capsys.readouterr().err
    index = (tmp_path / "q" / "index.md").read_text()
    line = next(line for line in index.splitlines() if line.startswith("- [Table 1 and Fig. 6](table1.md)"))
    assert line.endswith(
        "(*out of date*: its data under data/ have no provenance, so it is not drawn from them)"
    )
    assert "**Storage**" not in index and "**Case study**" in index  # unchecked numbers are not headlines
