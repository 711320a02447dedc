"""Error messages that named the wrong cause or an option the command lacks."""

import numpy as np
import pytest
from test_cli_errors import one_line, run

from replication.cli import main
from replication.errors import InputError


@pytest.mark.parametrize(
    ("rows", "match"),
    [
        ("0,0,0\n1,1,1\n2,2,2\n3,3,3\n", "are collinear"),
        ("1,1,1\n1,1,1\n1,1,2\n", "need at least 3 distinct projected points"),
    ],
)
def test_force_does_not_suggest_an_option_it_lacks(capsys, tmp_path, rows, match):
    """`force` builds its ADT with depth z (the jet's axis): it said "another --depth rule may
    help", an option `force` does not have; `adt` still says it."""
    (tmp_path / "c.csv").write_text("x,y,z\n" + rows)
    code, _, err = run(capsys, "force", tmp_path / "c.csv")
    assert code == 1 and one_line(err, "force") and match in err, err
    assert "--depth" not in err and "surface z(x, y) over an area" in err
    code, _, err = run(capsys, "adt", tmp_path / "c.csv")
    assert code == 1 and one_line(err, "adt") and "--depth" not in err, (
        err
    )  # on one line in 3-D: no rule helps
    assert "the points lie on one line in 3-D (or coincide), so no depth rule can help" in err


@pytest.mark.parametrize(
    ("rows", "argv", "helps"),
    [
        ("0,0,0\n1,0,0\n0,2,0\n1,2,0\n", ["--depth", "max"], True),  # a flat plate seen edge-on
        ("0,0,0\n1,0,0\n0,2,0\n1,2,0\n", ["--depth", "z"], None),  # its own plane: triangulated
        ("0,0,0\n1,2,3\n2,4,6\n", ["--depth", "x"], False),  # one line: no projection helps
        ("5,5,5\n5,5,5\n5,5,5\n", [], False),  # one point three times
    ],
)
def test_adt_suggests_another_depth_rule_only_where_one_helps(capsys, tmp_path, rows, argv, helps):
    # was: "another --depth rule may help" for `adt --random 2` and for three coincident points
    (tmp_path / "c.csv").write_text("x,y,z\n" + rows)
    code, _, err = run(capsys, "adt", tmp_path / "c.csv", *argv)
    if helps is None:
        assert code == 0
        return
    assert code == 1 and one_line(err, "adt")
    assert ("another --depth rule may help" in err) is helps and (
        "no depth rule can help" in err
    ) is not helps


@pytest.mark.parametrize(("scale", "word"), [(1e300, "overflows"), (1e-300, "underflows")])
def test_force_on_extreme_coordinates_names_the_range_not_a_vertical_facet(capsys, tmp_path, scale, word):
    """A random cloud at 1e300 or 1e-300 mm read as "zero area (a vertical facet)": its
    triangles' areas over- or underflowed float64."""
    np.save(tmp_path / "c.npy", np.random.default_rng(0).random((20, 3)) * scale)
    code, _, err = run(capsys, "force", tmp_path / "c.npy", "--no-domain")
    assert code == 1 and one_line(err, "force") and f"area in the x-y projection {word} float64" in err, err
    assert "vertical facet" not in err and "rescale the surface" in err


def test_a_vertical_facet_is_still_named_as_such():
    from replication.casestudy.mesh import check_height_field

    points = np.array([[0.0, 0, 0], [1e-3, 0, 0], [2e-3, 0, 1e-3], [0, 1e-3, 0]])
    with pytest.raises(InputError, match=r"has zero area \(a vertical facet\)"):
        check_height_field(points, np.array([[0, 1, 2], [0, 1, 3]]))
    # on the diagonal y = 3x (exactly), where the rounded products of the sides are not zero
    from fractions import Fraction

    def collinear(x, y):  # exactly, in rational arithmetic
        x, y = [Fraction(float(v)) for v in x], [Fraction(float(v)) for v in y]
        return (x[1] - x[0]) * (y[2] - y[0]) == (x[2] - x[0]) * (y[1] - y[0])

    rng = np.random.default_rng(0)
    tried = 0
    for scale in (1e-3, 2.0**-700, 2.0**700):
        for _ in range(200):
            k = rng.random(3) * scale
            if not collinear(k, 3 * k):
                continue  # 3x rounded: not exactly on the line
            tried += 1
            points = np.column_stack([np.append(k, k.min()), np.append(3 * k, 3 * k.max()), np.arange(4.0)])
            with pytest.raises(InputError, match=r"has zero area \(a vertical facet\)"):
                check_height_field(points, np.array([[0, 1, 2], [0, 1, 3]]))
    assert tried > 50


def test_a_box_wider_than_float64_is_named(capsys, tmp_path):
    """`--box 0 1 0 1 -1e308 1e308` printed numpy's overflow warning, then blamed NaN coordinates."""
    code, _, err = run(
        capsys,
        "adt",
        "--random",
        "20",
        "--box",
        "0",
        "1",
        "0",
        "1",
        "-1e308",
        "1e308",
        "-o",
        tmp_path / "s.vtk",
    )
    assert code == 1 and one_line(err, "adt") and "z side -1e+308..1e+308 is wider than" in err, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv", [["--executor", "dask"], ["--scheduler", "tcp://127.0.0.1:8786"]])
def test_dask_missing_is_named_before_a_run_directory_is_made(capsys, tmp_path, monkeypatch, argv):
    """Without dask, `casestudy --executor dask` made a run directory, printed how to resume
    it, failed at the first generation and deleted the directory again."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a)
    )
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "casestudy", "--quick", "--run-dir", "runs/r", *argv)
    assert code == 1 and one_line(err, "casestudy") and 'pip install ".[dask]"' in err, err
    assert "replication[" not in err  # PyPI's replication is another project
    assert out == "" and list(tmp_path.iterdir()) == []


def test_smaller_messages_say_what_is_wrong(capsys, tmp_path):
    (tmp_path / "notes.txt").write_text("not a directory\n")
    (tmp_path / "c.csv").write_text("x,y,z\n0,0,0\n0,1,0\n1,0.5,1\n0,0,2\n2,2,2\n")
    # was: "output directory does not exist: notes.txt"
    code, _, err = run(capsys, "adt", tmp_path / "c.csv", "-o", tmp_path / "notes.txt" / "s.vtk")
    assert code == 1 and one_line(err, "adt") and "notes.txt is a file, not a directory" in err, err
    # rows are counted from 0 (the file's lines from 1): said, as the lines are
    code, _, err = run(capsys, "adt", tmp_path / "c.csv", "--duplicates", "raise")
    assert code == 1 and one_line(err, "adt") and "(rows 0, 1, counted from 0)" in err, err
    bad = np.random.default_rng(0).random((6, 3))
    bad[3, 1] = np.nan
    np.save(tmp_path / "nan.npy", bad)
    code, _, err = run(capsys, "adt", tmp_path / "nan.npy")
    assert code == 1 and one_line(err, "adt") and "1 row(s), counted from 0: 3" in err, err
    # was: "sample_shape must be two integers of at least 2", an argument no user typed
    for command, option in (("compare", "--samples"), ("nurbs", "--tessellation")):
        with pytest.raises(SystemExit) as exc:
            main([command, str(tmp_path / "c.csv"), option, "1x1"])
        err = capsys.readouterr().err
        assert (
            exc.value.code == 2
            and one_line(err, command)
            and f"argument {option}: expected at least 2" in err
        )


def test_an_unparsable_first_line_is_named_not_taken_for_a_header(tmp_path):
    """ "1;2;3" has no number a reader takes, so it was taken for a header and line 2 blamed."""
    from replication.errors import CloudFileError
    from replication.io import load_cloud

    (tmp_path / "semi.csv").write_text("1;2;3\n4;5;6\n7;8;9\n")
    with pytest.raises(CloudFileError, match=r"line 1 has 1 column\(s\), expected 3 \(x, y, z\): '1;2;3'"):
        load_cloud(tmp_path / "semi.csv")
    (tmp_path / "named.csv").write_text("x;y;z\n4,5,6\n7,8,9\n0,1,1\n")  # a header still has letters
    assert load_cloud(tmp_path / "named.csv").shape == (3, 3)


def test_a_line_break_in_a_file_name_stays_on_the_error_s_line(capsys, tmp_path):
    code, _, err = run(capsys, "adt", tmp_path / "no\nsuch.csv")
    assert code == 1 and one_line(err, "adt") and "no\\nsuch.csv" in err, err
    with pytest.raises(SystemExit) as exc:
        main(["adt", "--random", "5", "extra\nword", "more"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and one_line(err, "adt"), err
