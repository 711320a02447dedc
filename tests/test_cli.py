"""The ``replication`` command line: contract, errors, JSON, determinism."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from geometry import DIAGONAL_CLOUD
from replication.cli import main
from replication.io import load_cloud, read_surface, save_cloud


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def cloud_file(tmp_path):
    path = tmp_path / "cloud.csv"
    save_cloud(np.random.default_rng(0).random((40, 3)) * [30, 20, 5], path)
    return path


def test_adt_from_file_human_output(capsys, cloud_file, tmp_path):
    out_path = tmp_path / "s.vtk"
    code, out, err = run(capsys, "adt", str(cloud_file), "-o", str(out_path))
    assert code == 0, err
    assert "40 points -> 40 vertices" in out and "depth axis z" in out
    assert f"wrote {out_path}" in out and f"{out_path.stat().st_size:,} bytes" in out
    points, _ = read_surface(out_path)
    np.testing.assert_array_equal(points, load_cloud(cloud_file))
    triangle = tmp_path / "one.csv"
    triangle.write_text("x,y,z\n0,0,0\n1,0,1\n0,1,2\n")
    code, out, _ = run(capsys, "adt", str(triangle))
    assert code == 0 and "3 points -> 3 vertices, 1 triangle\n" in out  # was "1 triangles"


def test_adt_json_is_one_object(capsys, cloud_file, tmp_path):
    out_path = tmp_path / "s.vtp"
    code, out, _ = run(capsys, "adt", str(cloud_file), "-o", str(out_path), "--json", "--depth", "max")
    assert code == 0
    report = json.loads(out)
    assert report["depth_axis"] == "x" and report["depth_rule"] == "max"
    assert report["projection_axes"] == ["y", "z"]
    assert report["format"] == "vtp" and report["bytes"] == out_path.stat().st_size
    assert report["points"] == report["vertices"] == 40 and report["points_merged"] == 0
    assert report["triangles"] > 0 and report["backend"] == ["sweephull"]


def test_adt_random_is_reproducible(capsys, tmp_path):
    args = ["adt", "--random", "101", "--seed", "7", "--step", "1", "--json"]
    code1, out1, _ = run(
        capsys, *args, "-o", str(tmp_path / "a.vtk"), "--save-cloud", str(tmp_path / "a.npy")
    )
    code2, out2, _ = run(capsys, *args, "-o", str(tmp_path / "b.vtk"))
    assert code1 == code2 == 0
    assert (tmp_path / "a.vtk").read_bytes() == (tmp_path / "b.vtk").read_bytes()
    r1 = json.loads(out1)
    assert r1["seed"] == 7 and r1["box"] == [0, 36, 0, 30, 0, 13] and r1["step"] == 1
    assert r1["points"] == 101 and r1["points_merged"] == 101 - r1["vertices"]
    cloud = load_cloud(tmp_path / "a.npy")
    assert cloud.shape == (101, 3) and np.all(cloud == np.round(cloud))


def test_adt_random_box_and_no_output(capsys):
    code, out, _ = run(capsys, "adt", "--random", "30", "--seed", "1", "--box", "0", "1", "0", "1", "0", "9")
    assert code == 0 and "no output file written" in out
    assert "depth axis" in out


def test_adt_closed_surface(capsys, tmp_path):
    t = 2 * np.pi * np.arange(16) / 16
    ring = np.column_stack([np.cos(t), np.sin(t), np.zeros(16)])
    caps = np.array([[0.1, 0.2, 0.5], [-0.3, 0.1, 0.4], [0.0, -0.2, -0.5], [0.2, 0.3, -0.3]])
    save_cloud(np.vstack([ring, caps]), tmp_path / "closed.xyz")
    code, out, _ = run(
        capsys, "adt", str(tmp_path / "closed.xyz"), "--split", "z=0", "-o", str(tmp_path / "c.vtk")
    )
    assert code == 0 and "closed (watertight)" in out
    code, out, _ = run(capsys, "adt", str(tmp_path / "closed.xyz"), "--split", "z=0", "--json")
    report = json.loads(out)
    assert report["closed"] is True and report["points_on_plane"] == 16 and report["vertices"] == 20


def test_duplicates_reported_not_warned_twice(capsys, tmp_path):
    save_cloud(np.array([[0, 0, 1.0], [0, 0, 3.0], [1, 0, 0], [0, 1, 0]]), tmp_path / "d.csv")
    code, out, err = run(capsys, "adt", str(tmp_path / "d.csv"), "--depth", "z")
    assert code == 0 and "merged 1 point(s)" in out and err == ""
    code, out, err = run(capsys, "adt", str(tmp_path / "d.csv"), "--depth", "z", "--duplicates", "raise")
    assert code == 1 and "rows 0, 1" in err
    code, out, err = run(capsys, "nurbs", str(tmp_path / "d.csv"), "--depth", "z", "--net", "3x3")
    assert code == 0 and "merged 1 point(s) sharing a projected position (policy mean)" in out and err == ""
    code, out, _ = run(capsys, "nurbs", str(tmp_path / "d.csv"), "--depth", "z", "--net", "3x3", "--json")
    assert json.loads(out)["points_merged"] == 1
    # compare merged them without a word, and duplicate rows change the net it reports
    from replication.surfaces import random_cloud

    cloud = random_cloud(60, rng=5)
    save_cloud(np.vstack([cloud, cloud[:5]]), tmp_path / "dup.csv")
    code, out, err = run(capsys, "compare", str(tmp_path / "dup.csv"))
    assert code == 0 and err == ""
    assert (
        "merged 5 point(s) sharing a projected position (policy mean); the NURBS net is sized by all 65"
        in out
    )
    assert json.loads(run(capsys, "compare", str(tmp_path / "dup.csv"), "--json")[1])["points_merged"] == 5
    save_cloud(cloud, tmp_path / "c.csv")
    code, out, err = run(capsys, "compare", str(tmp_path / "c.csv"))
    assert code == 0 and "merged" not in out


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("1,2,3\n4,5\n", "line 2 has 2 column(s)"),
        ("1,2,3\n4,x,6\n", "'x' is not a number"),
        ("", "empty"),
        ("1,2,3\nnan,1,1\n", "NaN or infinite coordinates on 1 line(s): 2"),
        ("0,0,0\n1,1,0\n2,2,1\n", "collinear"),
        ("0,0,0\n0,0,1\n1,1,0\n", "at least 3 distinct"),
    ],
)
def test_bad_input_one_line_error_and_no_output(capsys, tmp_path, content, match):
    (tmp_path / "bad.csv").write_text(content)
    out_path = tmp_path / "out.vtk"
    code, out, err = run(capsys, "adt", str(tmp_path / "bad.csv"), "-o", str(out_path), "--depth", "z")
    assert code == 1
    assert match in err and err.startswith("replication adt: error: ") and err.count("\n") == 1
    assert not out_path.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["adt", "missing.csv"], "not found"),
        (
            ["adt", "--random", "5", "--seed", "1", "-o", "/no/such/dir/s.vtk"],
            "output directory does not exist",
        ),
        (["adt", "--random", "5", "-o", "s.stl"], "suffix"),
    ],
)
def test_usage_problems_exit_1(capsys, tmp_path, monkeypatch, argv, match):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 1 and match in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["adt"], "give a point-cloud file INPUT"),
        (["adt", "--seed", "1", "x.csv"], "--seed applies only with --random"),
        (["adt", "x.csv", "--random", "4"], "not both"),
        (["adt", "--random", "5", "--box", "1", "0", "0", "1", "0", "1"], "--box 1 0 0 1 0 1: box has xmin"),
        (["adt", "--random", "50", "--split", "q=1"], "--split: split plane 'q=1'"),  # exited 1
    ],
)
def test_options_that_do_not_go_together_exit_2(capsys, tmp_path, monkeypatch, argv, match):
    """A misused command line, as argparse's own errors: exit status 2 (they exited 1)."""
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 2 and match in err and err.count("\n") == 1 and "(see 'replication adt --help')" in err
    assert list(tmp_path.iterdir()) == []


def test_argparse_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["adt", "--random", "-3"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["adt", "--depth", "middle", "x.csv"])
    assert exc.value.code == 2


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["adt", "--random", "0"], "replication adt: error: argument --random"),
        (["adt", "--bogus", "x.csv"], "replication adt: error: unrecognized arguments: --bogus"),
        (["force", "x.csv", "--depth", "x"], "replication force: error: unrecognized arguments: --depth x"),
        (["no-such-command"], "replication: error: argument COMMAND: invalid choice"),
    ],
)
def test_a_usage_error_is_one_line_that_names_the_command(capsys, argv, said):
    # argparse printed its whole usage block first (9 lines), and unknown options were blamed
    # on the top level ("replication: error: ...")
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith(said) and "--help" in err


@pytest.mark.parametrize("argv", [["--help"], ["adt", "--help"], ["reproduce", "--help"]])
def test_help(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "usage: replication" in out


def test_every_command_s_help_has_examples(capsys):
    """The README says every command explains its options with examples; the top level,
    reproduce, table1, report and sph had none."""
    from replication.cli import COMMANDS

    for argv in ([], *([name] for name in COMMANDS)):
        with pytest.raises(SystemExit):
            main([*argv, "--help"])
        out = capsys.readouterr().out
        examples = out.split("examples:\n", 1)[-1]
        assert "examples:" in out and examples.startswith("  replication "), argv
        # each example runs a command that exists
        for line in examples.splitlines():
            if line.startswith("  replication ") and not line.startswith("  replication COMMAND"):
                assert line.split()[1] in COMMANDS, line


def test_adt_help_explains_for_newcomers(capsys):
    with pytest.raises(SystemExit):
        main(["adt", "--help"])
    out = capsys.readouterr().out
    for phrase in ("examples:", "--random", "--split", "--duplicates", "depth axis", "eq. 7"):
        assert phrase in out


def test_python_dash_m_entry_point():
    result = subprocess.run(
        [sys.executable, "-m", "replication", "--version"], capture_output=True, text=True, check=True
    )
    assert result.stdout.startswith("replication ")


def test_the_quick_exit_keeps_the_output_and_the_exit_status(tmp_path, capsys):
    """The console entry freezes the command's objects before exiting (cli.run): the file it
    wrote is complete and the same as in-process main's, and errors keep their status."""
    command = [sys.executable, "-m", "replication", "adt", "--random", "300", "--seed", "4"]
    done = subprocess.run([*command, "-o", str(tmp_path / "a.vtk")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert main(["adt", "--random", "300", "--seed", "4", "-o", str(tmp_path / "b.vtk")]) == 0
    assert (tmp_path / "a.vtk").read_bytes() == (tmp_path / "b.vtk").read_bytes()
    assert done.stdout == capsys.readouterr().out.replace(str(tmp_path / "b.vtk"), str(tmp_path / "a.vtk"))
    missing = subprocess.run([*command[:4], str(tmp_path / "missing.csv")], capture_output=True, text=True)
    assert missing.returncode == 1 and len(missing.stderr.strip().splitlines()) == 1
    usage = subprocess.run([*command[:4], "--no-such-option"], capture_output=True, text=True)
    assert usage.returncode == 2


# ---- nurbs and compare ------------------------------------------------------------------------


def test_nurbs_writes_a_file_geomdl_reads(capsys, cloud_file, tmp_path):
    from replication.io.nurbs import read_nurbs

    out_path = tmp_path / "n.smesh"
    code, out, err = run(capsys, "nurbs", str(cloud_file), "-o", str(out_path))
    assert code == 0, err
    assert "degree 2" in out and "control net" in out and f"{out_path.stat().st_size:,} bytes" in out
    patch = read_nurbs(out_path)
    assert patch.degree_u == 2 and patch.net_shape[0] * patch.net_shape[1] == 40


def test_nurbs_json(capsys, tmp_path):
    code, out, _ = run(
        capsys,
        "nurbs",
        "--random",
        "45",
        "--seed",
        "3",
        "-o",
        str(tmp_path / "n.json"),
        "--json",
        "--evaluator",
        "fast",
    )
    assert code == 0
    r = json.loads(out)
    assert r["net"] == [9, 5] and r["net_rule"] == "exact" and r["degree"] == [2, 2]
    assert r["knots_u"][:3] == [0, 0, 0] and r["bytes"] == (tmp_path / "n.json").stat().st_size
    assert r["format"] == "json" and r["evaluator"] == "fast"


def test_nurbs_bad_degree_for_the_cloud(capsys):
    code, _, err = run(capsys, "nurbs", "--random", "9", "--seed", "1", "--degree", "3")
    assert code == 1 and "16 control points" in err


def test_compare_human(capsys, cloud_file):
    code, out, err = run(capsys, "compare", str(cloud_file))
    assert code == 0, err
    for phrase in (
        "pairing nurbs-samples",
        "pairing cloud-points",
        "paired t-test",
        "Wilcoxon",
        "TOST",
        "Cohen",
    ):
        assert phrase in out
    assert "rounding noise" not in out  # a random cloud: real deviations


def test_compare_text_states_the_papers_verdict_as_the_json_does(capsys, tmp_path):
    # was: each test's line said "-> paper's verdict: ..." (one similar, one different), and the
    # combined verdict of the JSON was nowhere in the text; nor was the sign of the difference
    from replication import random_cloud

    for seed in range(6):
        save_cloud(random_cloud(60, rng=np.random.default_rng(seed)), tmp_path / "c.csv")
        code, text, _ = run(capsys, "compare", str(tmp_path / "c.csv"))
        code_json, out, _ = run(capsys, "compare", str(tmp_path / "c.csv"), "--json")
        report = json.loads(out)
        assert code == code_json == 0 and report["differences"] == "ADT depth - NURBS depth at each pair"
        verdicts = [line.split()[2] for line in text.splitlines() if line.startswith("  paper's verdict")]
        assert verdicts == [p["statistics"]["paper_verdict"] for p in report["pairings"].values()]
        assert text.count("(ADT - NURBS; 95% CI") == 2 and "-> paper's verdict" not in text


def test_compare_says_when_the_tests_compare_rounding_noise(capsys, tmp_path):
    """A plane on a lattice: ADT and NURBS agree to 7e-16, yet the t-test rejected (p = 0.00025);
    rounding is no evidence of a difference, and the output says so, in words and in the JSON."""
    g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0), indexing="ij"), -1).reshape(-1, 2)
    save_cloud(np.column_stack([g, 0.1 * (g[:, 0] + g[:, 1])]), tmp_path / "plane.csv")
    code, out, _ = run(capsys, "compare", str(tmp_path / "plane.csv"))
    assert code == 0 and "paper's verdict    similar (neither test rejects;" in out
    assert "float64 rounding of depths of range 1.8 and size 1.8 (up to 1.8e-12): the surfaces agree" in out
    # the interval and d_z of the noise (an interval off 0, a "medium" d_z) are said to be its own
    means = [line for line in out.splitlines() if line.startswith("  mean difference")]
    assert len(means) == 2 and all(line.endswith(" (rounding noise)") for line in means), means
    assert out.count("the mean difference, its interval and d_z below are those of the noise") == 2
    code, out, _ = run(capsys, "compare", str(tmp_path / "plane.csv"), "--json")
    r = json.loads(out)
    assert all(
        r["pairings"][name]["statistics"]["rounding_only"] for name in ("nurbs-samples", "cloud-points")
    )


def test_compare_says_a_p_value_that_underflowed_is_below_the_smallest_double(capsys, tmp_path):
    # a surface of 1600 lattice points whose mean difference is far inside the TOST margin:
    # both one-sided p-values underflow to 0.0, which printed as "p = 0"
    x, y = (a.ravel().astype(float) for a in np.meshgrid(np.arange(40), np.arange(40)))
    z = 5 * np.sin(x / 3) + 3 * np.cos(y / 4) + 0.2 * x + np.random.default_rng(1).integers(0, 3, x.size)
    save_cloud(np.column_stack([x, y, z]), tmp_path / "c.csv")
    code, out, _ = run(capsys, "compare", str(tmp_path / "c.csv"), "--json")
    tost = [r["statistics"]["tost_p"] for r in json.loads(out)["pairings"].values()]
    assert code == 0 and 0.0 in tost  # the case: the JSON keeps the number as computed
    code, out, _ = run(capsys, "compare", str(tmp_path / "c.csv"))
    assert code == 0 and "p < 2.2e-308 -> equivalent" in out and "p = 0 " not in out
    assert "p = 0.8984  -> fails to reject" in out  # the others as before


def test_compare_json_has_everything(capsys, cloud_file):
    code, out, _ = run(capsys, "compare", str(cloud_file), "--json", "--margin", "0.1")
    assert code == 0
    r = json.loads(out)
    assert r["margin_fraction"] == 0.1 and r["depth_axis"] == "z"
    for name in ("nurbs-samples", "cloud-points"):
        p = r["pairings"][name]
        st = p["statistics"]
        assert p["pairs"] == st["n"] and p["candidates"] >= p["pairs"]
        assert 0 <= st["t_test"]["p_value"] <= 1 and 0 <= st["wilcoxon"]["p_value"] <= 1
        assert isinstance(st["equivalent"], bool) and st["paper_verdict"] in ("similar", "different")
        assert st["rounding_only"] is False
        assert st["margin"] == pytest.approx(0.1 * r["depth_range"])
        assert len(st["ci95"]) == 2


def test_compare_matches_the_library(capsys, cloud_file):
    from replication.compare import compare

    code, out, _ = run(capsys, "compare", str(cloud_file), "--json")
    lib = compare(load_cloud(cloud_file))
    st = json.loads(out)["pairings"]["cloud-points"]["statistics"]
    assert st["t_test"]["p_value"] == lib.statistics["cloud-points"].t_test.p_value


def test_compare_too_few_pairs_is_reported_not_an_error(capsys, tmp_path):
    small = DIAGONAL_CLOUD
    save_cloud(small, tmp_path / "s.csv")
    code, out, _ = run(capsys, "compare", str(tmp_path / "s.csv"), "--samples", "2x2", "--depth", "z")
    assert code == 0 and "too few pairs" in out
    code, out, _ = run(
        capsys, "compare", str(tmp_path / "s.csv"), "--samples", "2x2", "--depth", "z", "--json"
    )
    assert json.loads(out)["pairings"]["nurbs-samples"]["statistics"] is None


@pytest.mark.parametrize("bad", ["5", "5x", "axb", "0x4"])
def test_bad_net_argument(bad):
    with pytest.raises(SystemExit) as exc:
        main(["compare", "x.csv", "--net", bad])
    assert exc.value.code == 2


# ---- found in review ------------------------------------------------------------------------


def test_negative_seed_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["adt", "--random", "10", "--seed", "-1"])
    assert exc.value.code == 2 and "non-negative" in capsys.readouterr().err


def test_split_refuses_a_depth_rule(capsys, tmp_path):
    save_cloud(np.random.default_rng(0).random((30, 3)) - 0.5, tmp_path / "c.csv")
    code, _, err = run(capsys, "adt", str(tmp_path / "c.csv"), "--split", "z=0", "--depth", "x")
    assert code == 2 and "--depth x does not apply with --split" in err
    # refused before the cloud is read (it came after loading and warming the kernels)
    code, _, err = run(capsys, "adt", str(tmp_path / "missing.csv"), "--split", "z=0", "--depth", "x")
    assert code == 2 and "--depth x does not apply with --split" in err


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs /proc")
def test_unwritable_output_is_a_one_line_error(capsys):
    code, _, err = run(capsys, "adt", "--random", "10", "--seed", "1", "-o", "/proc/x.vtk")
    assert (
        code == 1
        and err.startswith("replication adt: error: cannot write /proc/x.vtk")
        and err.count("\n") == 1
    )


def test_json_output_is_strict_even_for_numpy_nan(capsys):
    from replication.cli.common import emit_json

    emit_json({"a": np.float64("nan"), "b": np.float32("inf"), "c": [np.int64(3)], "d": float("nan")})
    assert json.loads(capsys.readouterr().out) == {"a": None, "b": "inf", "c": [3], "d": None}


def test_negative_numbers_in_scientific_notation_are_values(capsys):
    # argparse took "-1e1" for an option: "expected 6 arguments", while "-10" worked
    code, out, err = run(
        capsys, "adt", "--random", "30", "--seed", "1", "--box", "-1e1", "1", "-.5E1", "1", "0", "9", "--json"
    )
    assert code == 0, err
    assert json.loads(out)["box"] == [-10, 1, -5, 1, 0, 9]
    code, out, err = run(
        capsys, "adt", "--random", "30", "--seed", "1", "--box", "-10", "1", "-5", "1", "0", "9", "--json"
    )
    assert code == 0 and json.loads(out)["box"] == [-10, 1, -5, 1, 0, 9]


@pytest.mark.parametrize(("scale", "offset"), [(1.0, 0.0), (1e-3, 0.0), (3.7, 12345.678)])
def test_the_verdict_on_a_plane_does_not_depend_on_units_or_offset(capsys, tmp_path, scale, offset):
    # the t-test on pure rounding noise: "similar" (p = 0.54) in mm, "different" (p = 0.012) in m
    g = np.stack(np.meshgrid(np.arange(5.0), np.arange(4.0), indexing="ij"), -1).reshape(-1, 2)
    plane = np.column_stack([g, 0.5 * g[:, 0] + 0.25 * g[:, 1]]) * scale + offset
    save_cloud(plane, tmp_path / "tilt.csv")
    code, out, _ = run(capsys, "compare", str(tmp_path / "tilt.csv"), "--json")
    pairings = json.loads(out)["pairings"]
    for name in ("nurbs-samples", "cloud-points"):
        st = pairings[name]["statistics"]
        assert st["rounding_only"] and st["paper_verdict"] == "similar", (name, st["t_test"])


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["adt", "--random", "5", "--step", "0"], "--step: expected a finite positive number, got '0'"),
        (["nurbs", "--random", "20", "--degree", "0"], "--degree: expected a positive integer, got 0"),
    ],
)
def test_option_values_out_of_range_exit_2(capsys, tmp_path, monkeypatch, argv, match):
    """Refused by the option, as --resolution 0 or --margin 0 already were (they exited 1, from
    the library, while the same options' other bad values exited 2)."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and match in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["adt", "--random", "50", "--step", "100", "-o", "s.vtk"], "--step 100 leaves a lattice of 1 x 1"),
        (["nurbs", "--random", "50", "--step", "31", "-o", "s.json"], "use a step of at most 30.0, the"),
        (
            ["adt", "--random", "50", "--step", "2", "--box", "0", "1", "0", "1", "0", "10", "-o", "s.vtk"],
            "lattice of 1 x 1 x 6 value(s) in the box, so every point lies on one line",
        ),
    ],
)
def test_a_step_that_puts_every_point_on_a_line_is_named(capsys, tmp_path, monkeypatch, argv, match):
    """It failed with "need at least 3 distinct projected points, got 1", naming neither the
    step nor the box; now a usage error, before any work, in one line."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *argv)
    assert code == 2 and match in err and err.count("\n") == 1 and out == ""
    assert list(tmp_path.iterdir()) == []


def test_the_step_the_lattice_error_suggests_builds(capsys, tmp_path, monkeypatch):
    """The largest step is shown in full: 0.123457 (rounded up past the side) was refused too."""
    monkeypatch.chdir(tmp_path)
    box = ["--box", "0", "0.1234567", "0", "0.1234567", "0", "1"]
    code, _, err = run(capsys, "adt", "--random", "50", "--step", "1", *box, "-o", "s.vtk")
    assert code == 2 and "at most 0.1234567," in err
    argv = ["adt", "--random", "50", "--seed", "2", "--step", "0.1234567", *box, "-o", "s.vtk"]
    code, _, _ = run(capsys, *argv)
    assert code == 0


def test_a_step_that_leaves_two_axes_with_lattice_values_builds(capsys, tmp_path, monkeypatch):
    """The --step check refuses only a lattice on one line: 2 x 2 x 1 values span a plane."""
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "adt", "--random", "60", "--seed", "1", "--step", "30", "--json")
    assert code == 0 and json.loads(out)["vertices"] == 4


def test_the_files_the_help_examples_name_can_be_made_as_the_help_says(tmp_path, monkeypatch, capsys):
    """`replication force bucket.csv` and `adt sphere.xyz --split z=0` named files that nothing
    shipped and nothing said how to make."""
    import shlex
    import subprocess
    import sys

    from replication.cli.force import EPILOG_FORCE
    from replication.cli.surfaces import EPILOG_ADT

    monkeypatch.chdir(tmp_path)
    for epilog in (EPILOG_FORCE, EPILOG_ADT):
        (line,) = [line.strip() for line in epilog.splitlines() if line.strip().startswith("python -c ")]
        code = shlex.split(line)[2]
        subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path)
    assert main(["force", "bucket.csv"]) == 0
    assert main(["adt", "bucket.csv", "--depth", "z", "-o", "my_mesh.vtp"]) == 0
    assert main(["force", "my_mesh.vtp", "--json"]) == 0
    assert main(["adt", "sphere.xyz", "--split", "z=0", "-o", "closed.vtk"]) == 0
    assert "closed (watertight)" in capsys.readouterr().out


def test_large_clouds_say_when_their_long_steps_start_and_end(capsys, tmp_path, monkeypatch):
    # was: 19 s of silence for `nurbs --random 1000000 -o big.json`, 7 s for a 2e6-point adt -o
    import replication.cli.progress as progress

    out_vtk, out_json = tmp_path / "s.vtk", tmp_path / "n.json"
    code, _, err = run(capsys, "adt", "--random", "60", "-o", str(out_vtk))
    assert code == 0 and err == ""  # a small cloud: nothing to wait for
    monkeypatch.setattr(progress, "LARGE_CLOUD", 50)
    code, _, err = run(capsys, "adt", "--random", "60", "-o", str(tmp_path / "t.vtk"), "--save-cloud",
                       str(tmp_path / "t.csv"))  # fmt: skip
    lines = err.splitlines()
    assert code == 0 and lines[0] == "building the ADT surface of 60 points ..."
    assert lines[1].startswith("building the ADT surface of 60 points: done (") and lines[1].endswith(" s)")
    assert lines[2] == f"writing {tmp_path / 't.vtk'} and {tmp_path / 't.csv'} ..." and len(lines) == 4
    code, _, err = run(capsys, "nurbs", "--random", "60", "-o", str(out_json), "--json")
    assert (
        code == 0
        and err.splitlines()[0]
        == "fitting the NURBS surface to 60 points (geomdl tessellation; --evaluator fast takes a fraction "
        "of the time) ..."
    )
    assert err.splitlines()[2] == f"writing {out_json} ..." and len(err.splitlines()) == 4
    code, _, err = run(capsys, "nurbs", "--random", "60", "--evaluator", "fast")
    assert (
        code == 0 and err.splitlines()[0] == "fitting the NURBS surface to 60 points (fast tessellation) ..."
    )
    code, _, err = run(capsys, "nurbs", "--random", "60")  # nothing written: no writing step
    assert code == 0 and "writing" not in err and err.count("\n") == 2
    # was: 20 s of silence for `compare --random 1000000`; the JSON on stdout stays clean
    code, out, err = run(capsys, "compare", "--random", "60", "--json")
    comparing = "building both surfaces of 60 points and comparing their depths"
    assert code == 0 and err.splitlines()[0] == f"{comparing} ..." and err.count("\n") == 2
    assert err.splitlines()[1].startswith(f"{comparing}: done (") and json.loads(out)["points"] == 60
    monkeypatch.setattr(progress, "LARGE_CLOUD", 1)
    code, _, err = run(capsys, "adt", "--random", "2")  # a failed step: its error, no "done"
    assert (
        code == 1 and "done" not in err and err.splitlines()[0] == "building the ADT surface of 2 points ..."
    )
