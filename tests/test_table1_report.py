"""The quick Table 1 run end to end: report structure, and its numbers equal the CSV data."""

import re

import numpy as np
import pandas as pd
import pytest

from mdtables import close, find, number, parse_tables, triple
from replication.cli import main

pytestmark = pytest.mark.slow


def test_files_exist(quick_reports):
    names = ("index.md", "table1.md", "figures/table1_fig6.png", "figures/table1_fig6.svg",
             "figures/table1_scale.png", "figures/table1_n9_overlay.png", "data/table1_provenance.json",
             "data/table1_claims.csv", "data/table1_montecarlo_raw.csv",
             "data/table1_meshes/n200_adt.vtk")  # fmt: skip
    for name in names:
        assert (quick_reports / name).is_file(), name


def test_report_structure_and_provenance(quick_reports):
    text = (quick_reports / "table1.md").read_text()
    for heading in ("## Does the paper's conclusion survive?", "## Set-up", "## Table 1: one cloud per n",
                    "## The paper's numbers beside ours", "## Fig. 6", "## Monte Carlo", "## Scale sweep",
                    "## How this report was made"):  # fmt: skip
        assert heading in text, heading
    assert "Quick run" in text
    items = ("- Command: `replication reproduce --quick", "- Code: git commit", "- Machine:", "- Software:",
             "- Seeds:", "- Run time:", "- Date (UTC):")  # fmt: skip
    for item in items:
        assert item in text, item
    for image in re.findall(r"\]\((figures/[^)]+)\)", text):
        assert (quick_reports / image).is_file(), image
    assert "[Table 1 and Fig. 6](table1.md)" in (quick_reports / "index.md").read_text()


def test_sizes_table_equals_csv(quick_reports):
    tables = parse_tables((quick_reports / "table1.md").read_text())
    shown = find(tables, "ADT file [bytes]", "merged points")
    sizes = pd.read_csv(quick_reports / "data/table1_sizes.csv")
    clouds = pd.read_csv(quick_reports / "data/table1_clouds.csv")
    for _, row in shown.iterrows():
        n = int(row["n"])
        head = sizes[(sizes["n"] == n) & sizes["headline"]].set_index("method")["bytes"]
        assert number(row["ADT file [bytes]"]) == head["ADT"]
        assert number(row["NURBS file [bytes]"]) == head["NURBS"]
        assert close(number(row["ADT / NURBS"]), head["ADT"] / head["NURBS"])
        c = clouds[clouds["n"] == n].iloc[0]
        assert number(row["vertices"]) == c["vertices"] and number(row["triangles"]) == c["triangles"]


def test_timing_table_equals_csv(quick_reports):
    tables = parse_tables((quick_reports / "table1.md").read_text())
    shown = find(tables, "NURBS geomdl / ADT", "ADT + write [ms]")
    timings = pd.read_csv(quick_reports / "data/table1_timings.csv")
    for _, row in shown.iterrows():
        n = int(row["n"])
        checks = (("ADT [ms]", "adt [s]", 1e3), ("NURBS geomdl [ms]", "nurbs_geomdl [s]", 1e3),
                  ("NURBS geomdl / ADT", "nurbs_geomdl/adt", 1.0))  # fmt: skip
        for column, quantity, scale in checks:
            data = timings[(timings["n"] == n) & (timings["quantity"] == quantity)].iloc[0]
            for got, want in zip(triple(row[column]), (data["median"], data["q1"], data["q3"])):
                assert close(got, scale * want), (n, column)


def test_stats_table_equals_csv(quick_reports):
    tables = parse_tables((quick_reports / "table1.md").read_text())
    shown = find(tables, "t-test p", "TOST p")
    stats = pd.read_csv(quick_reports / "data/table1_stats.csv")
    assert len(shown) == len(stats)
    for (_, row), (_, data) in zip(shown.iterrows(), stats.iterrows()):
        assert int(row["n"]) == data["n"] and row["pairing"] == data["pairing"]
        assert number(row["pairs"]) == data["pairs"]
        for column, key in (("t-test p", "t_p"), ("Wilcoxon p", "wilcoxon_p"), ("TOST p", "tost_p"),
                            ("RMS [% of depth range]", "rms_pct")):  # fmt: skip
            assert close(number(row[column]), data.get(key, np.nan)), (row["n"], column)


def test_claims_table_equals_csv(quick_reports):
    tables = parse_tables((quick_reports / "table1.md").read_text())
    shown = find(tables, "claim", "verdict", "ours / paper")
    claims = pd.read_csv(quick_reports / "data/table1_claims.csv")
    assert len(shown) == len(claims)
    for (_, row), (_, data) in zip(shown.iterrows(), claims.iterrows()):
        assert row["claim"] == data["claim"]
        assert row["verdict"].strip("*") == data["verdict"]
        assert close(number(row["ours / paper"]), data["ratio_ours_to_paper"])
        ours = row["ours (median [IQR])"]
        got = triple(ours)[0] if "[" in ours else number(ours.split()[0])
        assert close(got, data["ours"]), data["claim"]


def test_report_rerenders_from_data_alone(quick_reports_copy, monkeypatch, capsys):
    import replication.experiments.table1 as experiment

    copy = quick_reports_copy
    before = (copy / "table1.md").read_text()

    def forbidden(*args, **kwargs):
        raise AssertionError("re-rendering must not run the experiment")

    monkeypatch.setattr(experiment, "run_table1", forbidden)
    figures = {p.name: p.read_bytes() for p in (copy / "figures").iterdir()}
    pages = {p: p.read_bytes() for p in copy.glob("*.md")}
    assert main(["report", "--output-dir", str(copy)]) == 0
    assert (copy / "table1.md").read_text() == before
    # every page re-rendered from the data is the page reproduce wrote, and `report` says it
    # left each as it was (it said "wrote" of every page, also of those it left untouched)
    out = capsys.readouterr().out
    assert {p: p.read_bytes() for p in copy.glob("*.md")} == pages
    assert "wrote" not in out and out.count("unchanged ") == len(pages) >= 3, out
    assert f"unchanged {copy / 'table1.md'}" in out
    # every report's figures drawn again, here in one process, are the files reproduce drew
    # (on its workers): test_casestudy_report.py compares a two-process render with those
    redrawn = {p.name: p.read_bytes() for p in (copy / "figures").iterdir()}
    assert redrawn.keys() == figures.keys() and any(name.startswith("casestudy_") for name in figures)
    assert [name for name in figures if redrawn[name] != figures[name]] == []


def test_report_without_data_is_a_clear_error(tmp_path, capsys):
    assert main(["report", "--output-dir", str(tmp_path)]) == 1
    assert "no report data" in capsys.readouterr().err


def test_storage_table_equals_csv(quick_reports):
    from replication.experiments.storage import FAMILIES

    family_key = {text: key for key, text in FAMILIES}
    tables = parse_tables((quick_reports / "table1.md").read_text())
    shown = find(tables, "family", "equal precision", "ADT / NURBS, n = 200")
    storage = pd.read_csv(quick_reports / "data/table1_storage.csv").set_index(["family", "coordinates", "n"])
    claims = pd.read_csv(quick_reports / "data/table1_claims.csv")
    assert len(shown) == 8  # four families, two kinds of coordinates
    for _, row in shown.iterrows():
        for n in sorted(storage.index.get_level_values("n").unique()):
            data = storage.loc[(family_key[row["family"]], row["coordinates"], n)]
            got = triple(row[f"ADT / NURBS, n = {n}"])
            want = data[["ratio", "ratio_q1", "ratio_q3"]].to_numpy(float)
            assert np.allclose(got, want, atol=0.005), (row["family"], n)
        claim = claims[claims["claim"].str.contains(row["family"], regex=False)
                       & claims["claim"].str.contains(row["coordinates"], regex=False)]  # fmt: skip
        assert row["verdict"].strip("*") == claim["verdict"].iloc[0]


def test_headline_states_the_storage_verdict(quick_reports):
    from replication.experiments.table1_claims import STORAGE_HEADLINE

    claims = pd.read_csv(quick_reports / "data/table1_claims.csv")
    storage = claims[claims["claim"].str.startswith(STORAGE_HEADLINE)].iloc[0]
    line = next(
        s for s in (quick_reports / "index.md").read_text().splitlines() if s.startswith("- **Storage**")
    )
    assert f"**{storage['verdict']}** at equal precision" in line
    for family in ("6 significant digits", "float32 binary", "information floor", "lattice / continuous"):
        assert family in line
    text = (quick_reports / "table1.md").read_text()
    assert "What the paper's 9-point files suggest" in text and "characters per coordinate" in text


def test_a_quick_report_judges_no_speed_claim(quick_reports):
    """A quick run's 3 repeat pairs decide no timing claim, so its verdicts do not move with the load."""
    claims = pd.read_csv(quick_reports / "data/table1_claims.csv")
    speed = claims[claims["claim"].str.startswith("ADT is almost 3 times faster")]
    assert len(speed) == 2 and (speed["verdict"] == "cannot be decided").all()
    assert speed["why"].str.contains("only 3 repeat pairs per n").all()
    line = next(
        s for s in (quick_reports / "index.md").read_text().splitlines() if s.startswith("- **Speed**")
    )
    assert "**cannot be decided** / **cannot be decided**" in line and "only 3 repeat pairs" in line
