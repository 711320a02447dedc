"""Verdict rules for the paper's claims (Table 1 report)."""

import numpy as np
import pandas as pd
import pytest

from replication.experiments.claims import (
    PAPER,
    combine,
    factor_verdict,
    share_verdict,
    table1_claims,
)


@pytest.mark.parametrize(
    ("ours", "paper", "smaller", "verdict"),
    [
        (0.5, 0.5, True, "holds"),
        (0.7, 0.5, True, "holds"),  # within x1.5
        (0.2, 0.5, True, "partly holds"),  # smaller, but by far more than "half"
        (1.2, 0.5, True, "does not hold"),  # ADT larger
        (3.0, 3.0, False, "holds"),
        (70.0, 3.0, False, "partly holds"),  # faster, but 70x not 3x
        (0.8, 3.0, False, "does not hold"),  # ADT slower
        (np.nan, 3.0, False, "cannot be compared"),
    ],
)
def test_factor_verdict(ours, paper, smaller, verdict):
    assert factor_verdict(ours, paper, smaller_is_adt_better=smaller) == verdict


def test_combine_and_share():
    assert combine(["holds", "holds"]) == "holds"
    assert combine(["does not hold"] * 3) == "does not hold"
    assert combine(["holds", "does not hold"]) == "partly holds"
    assert share_verdict({9: np.nan, 45: 0.95, 100: 0.99}, lambda f: f >= 0.9) == "holds"
    assert share_verdict({9: 0.5, 45: 0.95}, lambda f: f >= 0.9) == "partly holds"
    assert share_verdict({9: 0.5, 45: 0.6}, lambda f: f >= 0.9) == "does not hold"
    assert share_verdict({9: np.nan}, lambda f: f >= 0.9) == "cannot be compared"


def _synthetic(size_ratio, time_ratio, similar, rms):
    ns = (9, 200)
    mc, timings = [], []
    for i, n in enumerate(ns):
        quantities = (("adt_bytes", 300.0), ("nurbs_bytes", 300.0 / size_ratio[i]),
                      ("size_ratio", size_ratio[i]), ("size_difference", 100.0 * (i + 1)),
                      ("time_difference_geomdl", 0.01 * (i + 1)),
                      ("a_rms_pct", rms[i]), ("b_rms_pct", rms[i]))  # fmt: skip
        for q, v in quantities:
            mc.append({"n": n, "quantity": q, "median": v, "q1": v, "q3": v})
        for q in ("a_both_similar", "b_both_similar", "a_equivalent", "b_equivalent"):
            mc.append({"n": n, "quantity": q, "fraction": similar[i]})
        for q, v in (("adt [s]", 0.001), ("nurbs_geomdl [s]", 0.001 * time_ratio[i]),
                     ("nurbs_geomdl/adt", time_ratio[i]), ("nurbs_fast/adt", time_ratio[i])):  # fmt: skip
            timings.append({"n": n, "quantity": q, "median": v, "q1": v, "q3": v})
    return pd.DataFrame(mc), pd.DataFrame(timings), ns


def test_table1_claims_verdicts_follow_the_numbers():
    mc, timings, ns = _synthetic(
        size_ratio=(0.5, 0.45), time_ratio=(3.0, 2.5), similar=(1.0, 0.95), rms=(8.0, 4.0)
    )
    claims = table1_claims(mc, timings, ns).set_index("claim")
    verdict = {k.split(" (")[0]: v for k, v in claims["verdict"].items()}
    assert verdict["ADT needs about half the storage of NURBS"] == "holds"
    assert verdict["ADT is about 3 times faster than NURBS"] == "holds"
    assert verdict["the NURBS-ADT difference in file size grows with n"] == "holds"
    assert verdict["the deviation shrinks as n grows"] == "holds"
    assert verdict["deviation under 5 %"] == "partly holds"
    assert verdict["ADT file size, 9 points"] == "cannot be compared"
    row = claims.loc["ADT file size, 9 points"]
    assert row["paper"] == PAPER["adt_bytes_9"] and row["ratio_ours_to_paper"] == pytest.approx(300 / 306)


def test_table1_claims_negative_case():
    mc, timings, ns = _synthetic(
        size_ratio=(1.5, 1.2), time_ratio=(0.5, 0.8), similar=(0.2, 0.1), rms=(4.0, 8.0)
    )
    verdicts = table1_claims(mc, timings, ns)["verdict"].tolist()
    assert verdicts.count("holds") == 2  # only the two "difference grows" claims
    assert "does not hold" in verdicts


def test_combine_of_nothing_comparable():
    assert combine(["cannot be compared"] * 3) == "cannot be compared"
    assert combine(["cannot be compared", "holds"]) == "holds"
