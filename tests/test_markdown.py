"""Number formats of the reports (replication.report.markdown)."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from replication.report.markdown import fmt, iqr, table


@pytest.mark.parametrize(
    ("fraction", "percent"),
    [(0.785, "79 %"), (0.955, "95 %"), (0.475, "47 %"), (1.0, "100 %"), (0.0, "0 %"), (0.995, "99 %")],
)
def test_a_percentage_agrees_with_the_fraction_at_two_decimals(fraction, percent):
    # a fraction printed both ways in one report (a table in percent, a sentence in .2f) must
    # not read 78 % beside 0.79: both round the same decimal digits
    assert fmt(fraction, "pct") == percent
    assert fmt(fraction, "pct") == f"{round(100 * float(format(fraction, '.2f')))} %"


@given(st.floats(0.0, 1.0))
def test_percent_and_two_decimals_always_agree(fraction):
    two = format(fraction, ".2f")
    assert fmt(fraction, "pct") == f"{int(two.replace('.', ''))} %"


def test_missing_values_and_other_formats():
    assert fmt(None) == fmt(math.nan) == "–"
    assert fmt(True) == "yes" and fmt(False) == "no"
    assert fmt(1234.6, "int") == "1,235"
    assert iqr(1.0, 0.5, 2.0) == "1 [0.5, 2]"
    assert table([["a", "1"]], ["x", "y"]) == "| x | y |\n| :--- | ---: |\n| a | 1 |"


def test_a_page_that_differs_only_in_its_render_commit_is_kept(tmp_path, monkeypatch):
    """`replication report` in a clone re-drew every page with only its "rendered by" commit
    changed, so a command that changed nothing left the committed reports modified."""
    from replication.report import markdown
    from replication.report.pages import marked

    page = tmp_path / "table1.md"
    old = "# T\n\n- Code: git commit `aaa` (computed the data); rendered by commit `aaa`\n- x: 1\n"
    page.write_text(marked(old))  # a page as written, with its marker line
    stamp = page.stat().st_mtime_ns
    same = old.replace("rendered by commit `aaa`", "rendered by commit `bbb (with uncommitted changes)`")
    assert markdown.write_report(page, same) == page
    assert page.read_text() == marked(old) and page.stat().st_mtime_ns == stamp
    changed = same.replace("x: 1", "x: 2")  # any other change is written, with its render commit
    markdown.write_report(page, changed)
    assert page.read_text() == marked(changed)
    fresh = tmp_path / "new.md"  # and a page not yet there is written
    markdown.write_report(fresh, old)
    assert fresh.read_text() == marked(old)


def test_the_provenance_section_names_its_record_file():
    from replication.report.markdown import provenance_section

    record = {"command": "replication table1", "commit": "abc", "run_seconds": 1.0}
    assert "data/table1_provenance.json" not in provenance_section(record)
    text = provenance_section(record, "data/table1_provenance.json")
    assert text.endswith("- The whole record, configuration included: `data/table1_provenance.json`")
