"""Damaged report data is refused in one line that names the file, line and column.

``replication report`` used to draw Fig. 8 from a history that had lost rows (a line across
the gap) or whose numbers had a damaged digit (pandas read the column as text, and the
figure drew the text as categories), without a word.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from replication.errors import ReportDataError
from replication.report.casestudy import load_casestudy_data
from replication.report.store import read_csv, write_csv

ROOT = Path(__file__).resolve().parents[1]


def _unsealed(data):
    """The copied data sets without the checksums their saves recorded, as sets saved before
    checksums were: these tests damage the data on purpose, to show that each file's own checks
    still refuse the damage, naming its line and column (a changed file of a set with checksums
    is refused before them, by name: test_a_data_file_changed_after_the_save_is_refused_by_name)."""
    import json

    for provenance in data.glob("*_provenance.json"):
        record = json.loads(provenance.read_text())
        record.pop("data_files", None)
        provenance.write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")
    return data


@pytest.fixture
def casestudy_data(tmp_path):
    """A copy of the committed case-study data."""
    data = tmp_path / "data"
    data.mkdir()
    for path in (ROOT / "reports" / "data").glob("casestudy_*"):
        shutil.copy(path, data / path.name)
    return _unsealed(data)


def _edit(path, change):
    path.write_text(change(path.read_text()))


def test_the_committed_case_study_data_loads(casestudy_data):
    loaded = load_casestudy_data(casestudy_data.parent)
    assert len(loaded["history"]) == loaded["provenance"]["config"]["generations"] * len(loaded["runs"])


def test_a_damaged_number_names_its_line_and_column(casestudy_data):
    path = casestudy_data / "casestudy_history.csv"
    lines = path.read_text().splitlines(keepends=True)
    fields = lines[2].split(",")
    fields[2] = fields[2][:3] + "x" + fields[2][4:]  # column "best" of the second generation
    lines[2] = ",".join(fields)
    path.write_text("".join(lines))
    with pytest.raises(ReportDataError) as caught:
        load_casestudy_data(casestudy_data.parent)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message
    assert "line 3, column best" in message and "is not a number" in message


def _rows_lost(history):
    return history[~((history["run"] == 1) & history["generation"].isin([3, 4]))]


def _last_lost(history):
    return history[~((history["run"] == 1) & (history["generation"] == 50))]


def _row_twice(history):
    return pd.concat([history, history[(history["run"] == 1) & (history["generation"] == 3)]]).sort_values(
        ["run", "generation"], kind="stable"
    )


def _row_beyond(history):
    extra = history[(history["run"] == 1) & (history["generation"] == 50)].assign(generation=51)
    return pd.concat([history, extra]).sort_values(["run", "generation"], kind="stable")


def _generation(value):
    def damage(history):
        history = history.astype({"generation": float})
        history.loc[(history["run"] == 1) & (history["generation"] == 7), "generation"] = value
        return history

    return damage


def _rows_swapped(history):
    order = np.arange(len(history))
    first = int(np.flatnonzero(history["run"].to_numpy() == 1)[5])
    order[[first, first + 1]] = order[[first + 1, first]]
    return history.iloc[order]


@pytest.mark.parametrize(
    ("damage", "said"),
    [
        (_rows_lost, "lacks generation(s) 3, 4"),
        (_last_lost, "lacks generation(s) 50"),
        (_row_twice, "has generation(s) 3 more than once"),
        (_row_beyond, "has generation(s) 51 outside 1-50"),
        (_generation(0), "has generation(s) 0 outside 1-50"),
        (_generation(3.5), "has generation(s) 3.5 outside 1-50"),
        (_generation(float("nan")), "has a row without its generation"),
        (_rows_swapped, "has rows out of order"),
    ],
)
def test_a_damaged_history_is_refused_saying_how(casestudy_data, damage, said):
    path = casestudy_data / "casestudy_history.csv"
    write_csv(damage(pd.read_csv(path)), path)
    with pytest.raises(ReportDataError) as caught:
        load_casestudy_data(casestudy_data.parent)
    assert f"casestudy_history.csv: run 1 {said} (generations 1-50 expected" in str(caught.value)


def test_numbers_may_be_missing_or_true_false_but_not_text(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("a,b,c,d\n1,,x,True\n2,3.5,y,\n")
    frame = read_csv(path, ("a", "b"), strings={"c"})
    assert np.isnan(frame["b"][0]) and frame["b"][1] == 3.5 and frame["d"][0]
    path.write_text("a,b,c\n1,2,x\n2,3.5e,y\n")
    with pytest.raises(ReportDataError, match=r"line 3, column b: '3\.5e' is not a number"):
        read_csv(path, strings={"c"})
    with pytest.raises(ReportDataError, match=r"line 2, column c: 'x' is not a number"):
        read_csv(path, strings={"b"})
    assert list(read_csv(path).columns) == ["a", "b", "c"]  # without strings: not checked
    assert read_csv(path, strings={"b", "c"})["b"][1] == "3.5e"


def _loaders():
    from replication.report.jet_validation import load_jet_validation_data
    from replication.report.sph import load_sph_data
    from replication.report.table1 import load_table1_data

    return {"table1": load_table1_data, "sph": load_sph_data, "jet_validation": load_jet_validation_data,
            "casestudy": load_casestudy_data}  # fmt: skip


@pytest.mark.parametrize("report", ["table1", "sph", "jet_validation", "casestudy"])
def test_every_committed_data_set_passes_the_checks(report):
    loaded = _loaders()[report](ROOT / "reports")
    assert loaded["provenance"]


@pytest.mark.parametrize(
    ("report", "table", "column"),
    [("table1", "montecarlo", "median"), ("table1", "stats", "n"), ("sph", "runs", "radius_mm"),
     ("jet_validation", "surfaces", "vertices"), ("jet_validation", "surrogate_params", "value")],
)  # fmt: skip
def test_a_damaged_number_in_any_report_names_its_file_line_and_column(tmp_path, report, table, column):
    """table1 and sph failed naming neither file nor column; the jet validation drew its page."""
    data = tmp_path / "data"
    ignored = shutil.ignore_patterns("*meshes*", "performance*")
    _unsealed(shutil.copytree(ROOT / "reports" / "data", data, ignore=ignored))
    path = data / f"{report}_{table}.csv"
    frame = pd.read_csv(path)
    assert pd.api.types.is_numeric_dtype(frame[column]) and len(frame) > 1
    lines = path.read_text().splitlines(keepends=True)
    k = list(frame.columns).index(column)
    fields = lines[2].split(",")  # (no quoted commas before these columns)
    fields[k] = fields[k].strip() + "x" + ("\n" if k == len(fields) - 1 else "")
    lines[2] = ",".join(fields)
    path.write_text("".join(lines))
    with pytest.raises(ReportDataError) as caught:
        _loaders()[report](tmp_path)
    message = str(caught.value)
    assert str(path) in message and f"line 3, column {column}:" in message and "is not a number" in message


@pytest.mark.parametrize(
    ("report", "table", "status", "reason"),
    [("sph", "runs", "status", "reason"), ("jet_validation", "surfaces", "sph_status", "sph_reason")],
)
def test_a_failed_simulation_s_reason_is_text_not_damage(tmp_path, report, table, status, reason):
    """A report with a failed SPH run was refused: its reason was taken for a damaged number."""
    data = tmp_path / "data"
    ignored = shutil.ignore_patterns("*meshes*", "performance*")
    _unsealed(shutil.copytree(ROOT / "reports" / "data", data, ignore=ignored))
    path = data / f"{report}_{table}.csv"
    frame = pd.read_csv(path)
    frame[reason] = frame[reason].astype(object)
    frame.loc[0, status] = "blowup"
    frame.loc[0, reason] = "particles left the domain at t = 3.1 ms"
    write_csv(frame, path)
    loaded = _loaders()[report](tmp_path)
    assert loaded[table].loc[0, reason] == "particles left the domain at t = 3.1 ms"


@pytest.mark.parametrize(
    ("table", "damage", "said"),
    [("storage", "delete", "n = 9 lacks the row of coordinates = "),
     ("montecarlo", "duplicate", "the row of n = 9, quantity = adt_bytes is there twice"),
     ("sizes", ",ADT,->,xADT,", "n = 9 lacks the row of method = ADT, format = legacy VTK, 6 significant"),
     ("stats", "9,->9.5,", "n = 9.5 is not one of the run's sizes [9, 45, 100, 169, 200]"),
     ("clouds", "duplicate", "the row of n = 9 is there twice"),
     ("timings_raw", "keep n=9 only", "no rows for n = 45")],
)  # fmt: skip
def test_a_table1_table_that_is_not_whole_is_refused_saying_what_it_lacks(tmp_path, table, damage, said):
    """A row deleted from a table was drawn as missing without a word; a changed method name
    gave 'IndexError: single positional indexer is out-of-bounds'. (The Monte Carlo summary may
    lack a quantity at a size where it is never computable: see the next test.)"""
    from replication.report.table1 import load_table1_data

    data = tmp_path / "data"
    ignored = shutil.ignore_patterns("*meshes*", "performance*")
    _unsealed(shutil.copytree(ROOT / "reports" / "data", data, ignore=ignored))
    path = data / f"table1_{table}.csv"
    lines = path.read_text().splitlines(keepends=True)
    if damage == "delete":
        del lines[2]
    elif damage == "duplicate":
        lines.insert(2, lines[1])
    elif damage == "keep n=9 only":
        lines = [lines[0]] + [line for line in lines[1:] if line.startswith("9,")]
    else:
        old, new = damage.split("->")
        lines[2] = lines[2].replace(old, new, 1) if not old.startswith("9,") else new + lines[1][len(old) :]
    path.write_text("".join(lines))
    with pytest.raises(ReportDataError) as caught:
        load_table1_data(tmp_path)
    assert str(caught.value).startswith(f"{path}: {said}"), str(caught.value)
    # what to run: the command that made the data (table1, or reproduce after the README's
    # run), into the directory of the data (it named `replication table1` and reports/)
    import json

    from replication.report.store import rerun_into

    recorded = json.loads((data / "table1_provenance.json").read_text())["command"]
    assert recorded.startswith(("replication table1", "replication reproduce")), recorded
    assert str(caught.value).endswith(f"regenerate them with `{rerun_into(recorded, tmp_path)}`")
    assert str(caught.value).endswith(f" --output-dir {tmp_path}`")


@pytest.mark.parametrize(
    ("damage", "said"),
    [("one ulp", None),
     ("no fraction", "no column 'fraction'"),
     ("delete", "lacks the row of n = 9, quantity = adt_bytes"),
     ("median", "median of n = 9, quantity = adt_bytes is 1.0, not 242.0 as the raw data give"),
     ("stray", "has a row not in the raw data: n = 9, quantity = nothing")],
)  # fmt: skip
def test_a_monte_carlo_summary_that_is_not_its_raw_data_s_is_refused(tmp_path, damage, said):
    """The summary may lack a quantity at a size where it is never computable, so a deleted
    row could not be told from the summary alone: it was drawn as missing. It is now checked
    against the raw data it is computed from (both at full precision: equal, not close)."""
    from replication.report.table1 import load_table1_data

    data = tmp_path / "data"
    ignored = shutil.ignore_patterns("*meshes*", "performance*")
    _unsealed(shutil.copytree(ROOT / "reports" / "data", data, ignore=ignored))
    path = data / "table1_montecarlo.csv"
    load_table1_data(tmp_path)  # whole as committed
    lines = path.read_text().splitlines(keepends=True)
    assert lines[1].startswith("9,adt_bytes,")
    if damage == "one ulp":  # as pandas 2's reader may read a number back: not damage
        header = lines[0].split(",")
        fields = lines[1].split(",")
        k = header.index("q3")
        fields[k] = f"{np.nextafter(float(fields[k]), np.inf):.17g}"
        lines[1] = ",".join(fields)
    elif damage == "no fraction":
        lines = [line.rsplit(",", 1)[0] + "\n" for line in lines]
    elif damage == "delete":
        del lines[1]
    elif damage == "median":
        fields = lines[1].split(",")
        fields[lines[0].split(",").index("median")] = "1"
        lines[1] = ",".join(fields)
    else:
        lines.insert(2, lines[1].replace("adt_bytes", "nothing"))
    path.write_text("".join(lines))
    if said is None:
        load_table1_data(tmp_path)
        return
    with pytest.raises(ReportDataError) as caught:
        load_table1_data(tmp_path)
    message = str(caught.value)
    assert message.startswith(f"{path}: {said}"), message
    assert "\n" not in message


def test_a_data_file_changed_after_the_save_is_refused_by_name(capsys, quick_reports_copy):
    """``report`` drew a page from data that had lost a row (a surface missing from the SPH
    study, a claim missing from the case study), exit 0: each save now records its files'
    checksums in the provenance, and a file that differs is refused in one line. Every data
    set is checked before any page is drawn: the case study's was refused only after the
    other reports had been drawn again."""
    import json

    from replication.cli import main
    from replication.report.store import rerun_into

    out = quick_reports_copy
    sets = sorted((out / "data").glob("*_provenance.json"))
    assert {p.name for p in sets} >= {"table1_provenance.json", "casestudy_provenance.json"}

    def drawn():  # every page and figure, as the file it is (a page drawn again is a new file)
        files = [*out.glob("*.md"), *(out / "figures").iterdir()]
        return {p.name: (p.stat().st_ino, p.stat().st_mtime_ns, p.read_bytes()) for p in files}

    pages = drawn()
    for provenance in sets:
        files = json.loads(provenance.read_text())["data_files"]
        assert files and all(len(v["sha256"]) == 64 for v in files.values())
        name = next(n for n in files if n.endswith(".csv"))
        path = out / "data" / name
        original = path.read_bytes()
        lines = original.splitlines(keepends=True)
        path.write_bytes(b"".join(lines[:1] + lines[2:]))  # a lost row
        assert main(["report", "--output-dir", str(out)]) == 1
        err = capsys.readouterr().err
        assert f"{path} differs from the file saved with {provenance.name}" in err and err.count("\n") == 1
        command = json.loads(provenance.read_text())["command"]  # the run's own, settings included
        again = rerun_into(command, out)  # into the directory reported, whatever the run named
        assert command.startswith("replication ") and f"run `{again}` again" in err
        assert drawn() == pages  # nothing drawn, not even the pages of the other data sets
        path.write_bytes(original)
    assert main(["report", "--output-dir", str(out)]) == 0  # the files as saved: drawn as before
    capsys.readouterr()
    missing = sets[0]
    name = next(iter(json.loads(missing.read_text())["data_files"]))
    (out / "data" / name).unlink()
    assert main(["report", "--output-dir", str(out)]) == 1
    assert str(out / "data" / name) in capsys.readouterr().err  # (the loader or the record says so)


def test_the_committed_data_sets_match_the_checksums_their_saves_recorded():
    from replication.report.store import read_provenance

    data = ROOT / "reports" / "data"
    for prefix, command in (
        ("table1", "replication table1"),
        ("casestudy", "replication casestudy"),
        ("sph", "replication sph"),
        ("jet_validation", "replication validate-jet"),  # recorded after its save, see the record
    ):
        record = read_provenance(data, f"{prefix}_provenance.json", command)  # raises on a mismatch
        assert record["data_files"] and all(name.startswith(prefix) for name in record["data_files"])


def test_the_headline_is_not_drawn_from_a_changed_data_file(quick_reports_copy):
    """table1 and sph refresh the README headline from every experiment's data: a case-study
    file changed after its save was read there unchecked."""
    from replication.errors import ReportDataError
    from replication.report.index import headline

    assert headline(quick_reports_copy)
    path = quick_reports_copy / "data" / "casestudy_runs.csv"
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:-1]))
    with pytest.raises(ReportDataError, match=r"casestudy_runs.csv differs from the file saved"):
        headline(quick_reports_copy)


def test_report_checks_every_experiment_s_data_with_its_renderer_s_loader():
    """The check before drawing (``cli.reports._check_data_sets``) knows each experiment's
    loader, and it is the one that experiment's renderer calls."""
    import importlib
    import inspect

    from replication.cli.reports import _LOADERS, EXPERIMENTS

    assert set(_LOADERS) == {prefix for prefix, _ in EXPERIMENTS}
    for prefix, loader in _LOADERS.items():
        module, function = loader.split(":")
        module = importlib.import_module(module)
        render = getattr(module, f"render_{prefix}")
        assert f"{function}(" in inspect.getsource(render), (prefix, function)
