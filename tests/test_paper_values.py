"""The paper's numbers appear exactly as the paper prints them, in every report and CSV."""

import pandas as pd
import pytest

from replication.errors import InputError
from replication.experiments.paper import (
    PAPER_CASESTUDY,
    PAPER_TABLE1,
    PAPER_TABLE1_STATEMENTS,
    PaperStatement,
    PaperValue,
    all_paper_values,
)

#: How a paper value was misquoted before (rounded, reformatted or padded by the CSV writer).
MISQUOTES = ("1.38e+03", "5.91e+03", "9.6 MB", "21.960000", "19.079999", "0.0038000", "2,400 appears")


def test_registry_quotes_digits_and_units():
    quotes = {v.quote for v in all_paper_values().values()}
    for expected in ("306 bytes", "1376 bytes", "0.0038 s", "0.018 s", "5912 bytes", "0.0129 s", "21.96 N",
                     "19.08 N", "107.53 s", "9.60 MB", "2400 simulations", "almost half",
                     "almost 3 times faster"):  # fmt: skip
        assert expected in quotes
    assert PAPER_CASESTUDY["megabytes_per_simulation"].value == 9.6
    assert float(PAPER_TABLE1["adt_s_9"]) == 0.0038


def test_a_quote_must_match_its_value():
    with pytest.raises(InputError, match="does not match"):
        PaperValue("1376 bytes", 1380.0, "section 4")
    with pytest.raises(InputError, match="outer spaces"):
        PaperValue(" 306 bytes", 306.0, "section 4")
    with pytest.raises(InputError, match="outer spaces"):
        PaperStatement("the difference grows ", "section 4")
    assert str(PAPER_TABLE1_STATEMENTS["similar"]).startswith("It can be concluded with 95% confidence")


@pytest.mark.slow
def test_table1_report_and_csv_quote_the_paper_verbatim(quick_reports):
    text = (quick_reports / "table1.md").read_text()
    claims = pd.read_csv(quick_reports / "data/table1_claims.csv")
    quoted = set(claims["paper"].dropna())
    for key, value in PAPER_TABLE1.items():
        assert value.quote in text, key
        assert value.quote in quoted, key  # the CSV cell is the quotation itself
    # the worded claims (grows, similar, reduced) are quoted beside their verdicts, with no ratio
    for key, statement in PAPER_TABLE1_STATEMENTS.items():
        rows = claims[claims["paper"] == statement.quote]
        assert not rows.empty and statement.quote in text, key
        assert rows["ratio_ours_to_paper"].isna().all(), key
    assert claims["paper"].notna().all()  # every claim row says what the paper says
    raw = (quick_reports / "data/table1_claims.csv").read_text()
    for bad in MISQUOTES:
        assert bad not in text and bad not in raw, bad


@pytest.mark.slow
def test_casestudy_report_and_csv_quote_the_paper_verbatim(quick_reports):
    text = (quick_reports / "casestudy.md").read_text()
    claims = pd.read_csv(quick_reports / "data/casestudy_claims.csv")
    shapes = pd.read_csv(quick_reports / "data/casestudy_shapes.csv").set_index("shape")
    for key, value in PAPER_CASESTUDY.items():
        assert value.quote in text, key
        assert value.quote in set(claims["paper"].dropna()), key
    assert shapes.loc["flat plate", "paper_sph"] == "21.96 N"
    assert shapes.loc["pelton bucket", "paper_sph"] == "19.08 N"
    index = (quick_reports / "index.md").read_text()
    assert "21.96 N" in index and "19.08 N" in index and "almost half" in index
    for name in ("casestudy_claims.csv", "casestudy_shapes.csv"):
        raw = (quick_reports / "data" / name).read_text()
        for bad in MISQUOTES:
            assert bad not in raw, (name, bad)
    for bad in MISQUOTES:
        assert bad not in text, bad
