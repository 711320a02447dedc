"""File sizes in the four representation families (Table 1 storage claim, paper section 5)."""

import numpy as np
import pandas as pd
import pytest

from replication.experiments.storage import (
    EQUAL_PRECISION,
    FAMILIES,
    storage_monte_carlo,
    storage_row,
    summarize_storage,
)
from replication.io.nurbs import smesh_text
from replication.io.vtk import legacy_vtk_text
from replication.surfaces import Box, random_cloud
from replication.surfaces.nurbs import clamped_uniform_knots
from replication.surfaces.patch import NurbsPatch

POINTS = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 1.0], [0.0, 12.0, 2.5]])
TRIANGLES = np.array([[0, 1, 2]])


def _patch(m=3):
    k = clamped_uniform_knots(m, 2)
    u, v = np.meshgrid(np.linspace(0, 1, m), np.linspace(0, 1, m), indexing="ij")
    net = np.stack([u, v, u * v / 3], axis=-1)
    return NurbsPatch(2, 2, k, k, net, np.ones((m, m)))


def test_known_counts_and_bytes():
    row = storage_row(POINTS, TRIANGLES, _patch())
    assert (row["vertices"], row["triangles"], row["control_points"], row["knots"]) == (3, 1, 9, 12)
    assert row["binary32_adt"] == 4 * 2 + 12 * 3 + 12 * 1  # counts, float32 xyz, int32 indices
    assert row["binary32_nurbs"] == 4 * 4 + 4 * 12 + 16 * 9  # degrees and sizes, knots, xyzw
    assert row["floor_adt"] == 12 * 3  # triangles recomputed
    assert row["floor_nurbs"] == 12 * 9 + 4 * 12  # net and knots, weights 1 not stored
    assert row["ascii_exact_adt"] == len(legacy_vtk_text(POINTS, TRIANGLES))
    assert row["ascii_6_nurbs"] == len(smesh_text(_patch(), digits=6))
    assert row["adt_point_bytes_ascii_exact"] == len("0 0 0\n10 0 1\n0 12 2.5\n")
    assert row["adt_point_bytes_ascii_6"] == row["adt_point_bytes_ascii_exact"]  # short numbers


def test_six_digits_shorten_long_decimals_only():
    long = POINTS + np.array([1 / 3, 2 / 7, 0.0])
    row = storage_row(long, TRIANGLES, _patch())
    assert row["ascii_6_adt"] < row["ascii_exact_adt"]
    assert row["adt_point_bytes_ascii_6"] == len(
        "0.333333 0.285714 0\n10.3333 0.285714 1\n0.333333 12.2857 2.5\n"
    )


def test_families_are_listed_once():
    keys = [k for k, _ in FAMILIES]
    assert len(set(keys)) == 4 and set(EQUAL_PRECISION) < set(keys) and "ascii_exact" not in EQUAL_PRECISION


def _kinds():
    box = Box.from_bounds((0, 36, 0, 30, 0, 13))
    return {
        "lattice": lambda n, k: random_cloud(n, box, step=1.0, rng=np.random.default_rng([1, n, k])),
        "continuous": lambda n, k: random_cloud(n, box, rng=np.random.default_rng([1, n, k, 1])),
    }


@pytest.fixture(scope="module")
def small_run():
    import warnings

    from replication.errors import DuplicatePointsWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        return storage_monte_carlo((9, 60), 3, _kinds())


def test_monte_carlo_is_deterministic_and_complete(small_run):
    import warnings

    from replication.errors import DuplicatePointsWarning

    assert len(small_run) == 2 * 3 * 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        again = storage_monte_carlo((9, 60), 3, _kinds())
    pd.testing.assert_frame_equal(small_run, again)
    continuous = small_run[small_run["coordinates"] == "continuous"]
    assert (continuous["vertices"] == continuous["n"]).all()  # no lattice merges
    assert (continuous["control_points"] == continuous["n"]).all()  # an n-point net


def test_counts_explain_the_binary_and_floor_ratios(small_run):
    # continuous clouds at n = 60: ADT about 2V triangles -> binary ADT about twice NURBS; floor about equal
    big = small_run[(small_run["coordinates"] == "continuous") & (small_run["n"] == 60)]
    assert (big["triangles"] > 1.7 * big["vertices"]).all()
    assert ((big["binary32_adt"] / big["binary32_nurbs"]).between(1.5, 2.5)).all()
    assert ((big["floor_adt"] / big["floor_nurbs"]).between(0.85, 1.0)).all()


def test_summary_is_the_median_over_clouds(small_run):
    summary = summarize_storage(small_run)
    assert len(summary) == 2 * 2 * len(FAMILIES)
    row = summary[
        (summary["n"] == 60) & (summary["coordinates"] == "lattice") & (summary["family"] == "floor")
    ]
    group = small_run[(small_run["n"] == 60) & (small_run["coordinates"] == "lattice")]
    assert row["ratio"].iloc[0] == pytest.approx(float(np.median(group["floor_adt"] / group["floor_nurbs"])))
    assert row["count"].iloc[0] == 3


def test_a_data_set_records_the_checksums_of_its_files_and_reading_checks_them(tmp_path):
    import hashlib
    import json

    from replication.errors import ReportDataError
    from replication.report.store import data_set, read_provenance, write_json

    data = tmp_path / "data"
    with data_set(data, "x_provenance.json", checksums=True) as staged:
        (staged / "x_a.csv").write_text("a\n1\n2\n")
        (staged / "sub").mkdir()
        (staged / "sub" / "m.vtk").write_bytes(b"mesh")
        write_json({"command": "replication x"}, staged / "x_provenance.json")
    record = json.loads((data / "x_provenance.json").read_text())
    assert record["data_files"] == {
        "sub/m.vtk": {"sha256": hashlib.sha256(b"mesh").hexdigest(), "bytes": 4},
        "x_a.csv": {"sha256": hashlib.sha256(b"a\n1\n2\n").hexdigest(), "bytes": 6},
    }
    assert read_provenance(data, "x_provenance.json", "replication x")["command"] == "replication x"
    (data / "x_a.csv").write_text("a\n1\n")
    with pytest.raises(
        ReportDataError,
        match=r"x_a.csv differs from the file saved with x_provenance.json .*"
        r"run `replication x --output-dir \S+` again",
    ):
        read_provenance(data, "x_provenance.json", "replication x")
    record.pop("data_files")  # a set saved before checksums were recorded: read as it is
    (data / "x_provenance.json").write_text(json.dumps(record))
    assert read_provenance(data, "x_provenance.json", "replication x") == record


@pytest.mark.parametrize(
    ("command", "again"),
    [
        ("replication table1", "replication table1 --output-dir 'my reports'"),
        (
            "replication table1 --quick --output-dir /elsewhere",
            "replication table1 --quick --output-dir 'my reports'",
        ),
        (
            "replication sph --output-dir=/x --workers 2",
            "replication sph --workers 2 --output-dir 'my reports'",
        ),
        ("replication sph 'unclosed", "replication sph 'unclosed"),  # not a command line: as it is
        # a case study's run directory holds checkpoints: without --resume it is refused
        (
            "replication casestudy --seed 5 --run-dir r",
            "replication casestudy --seed 5 --run-dir r --resume --output-dir 'my reports'",
        ),
        (
            "replication casestudy --run-dir=r --resume",
            "replication casestudy --run-dir=r --resume --output-dir 'my reports'",
        ),
        ("replication casestudy --seed 5", "replication casestudy --seed 5 --output-dir 'my reports'"),
    ],
)
def test_a_rerun_writes_into_the_directory_reported(command, again):
    # the committed validation study records --output-dir /work/wt-study/reports, a directory of
    # the machine that ran it: "run ... again" named it for a copy of the reports anywhere
    from replication.report.store import rerun_into

    assert rerun_into(command, "my reports") == again


@pytest.mark.parametrize(
    ("out", "word"), [("-e", "./-e"), ("-my reports", "'./-my reports'"), ("./-e", "./-e")]
)
def test_a_rerun_into_a_directory_named_like_an_option_says_it_as_a_path(out, word):
    # `replication reproduce --output-dir -e`, pasted as printed, was "expected one argument"
    from replication.report.store import rerun_into

    assert rerun_into("replication reproduce", out) == f"replication reproduce --output-dir {word}"
