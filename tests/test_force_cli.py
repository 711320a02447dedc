"""``replication force``: the subcommand handler, with a parser built as the main CLI does."""

import argparse
import json
import re

import numpy as np
import pytest

from replication.casestudy import JetConfig, pelton_bucket_cloud, pelton_bucket_surface, surface_force
from replication.casestudy.sph import engine_available
from replication.cli.force import register
from replication.errors import CloudFileError, InputError, OutputError
from replication.io import save_cloud, write_surface


def run(capsys, *argv):
    parser = argparse.ArgumentParser(prog="replication")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    register(sub)
    args = parser.parse_args(list(argv))
    code = args.func(args)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def bucket_csv(tmp_path):
    path = tmp_path / "bucket.csv"
    save_cloud(pelton_bucket_cloud(), path)
    return path


def test_cloud_human_output(capsys, bucket_csv):
    code, out, _ = run(capsys, "force", str(bucket_csv))
    assert code == 0
    expected = surface_force(pelton_bucket_surface()).axial_force
    assert "101 points -> ADT surface" in out and "half jet" in out
    assert f"axial force {expected:.4g} N" in out and len(out.splitlines()) == 4


def test_surface_file_json_matches_the_library(capsys, tmp_path):
    path = tmp_path / "bucket.vtp"
    write_surface(pelton_bucket_surface(), path, "vtp")
    code, out, _ = run(capsys, "force", str(path), "--json")
    assert code == 0
    report = json.loads(out)
    expected = surface_force(pelton_bucket_surface())
    np.testing.assert_allclose(report["force_N"], expected.force, rtol=1e-12, atol=1e-15)
    assert report["axial_force_N"] == pytest.approx(expected.axial_force, rel=1e-12)
    assert report["mass_flow_hit_kg_s"] == pytest.approx(expected.mass_flow_hit)
    assert report["mass_flow_total_kg_s"] == pytest.approx(JetConfig().mass_flow)
    assert report["evaluation_seconds"] > 0
    assert report["jet"]["center_mm"] == [18.0, 0.0] and report["jet"]["diameter_mm"] == 18.0


def test_json_keys_of_the_two_solvers_agree(capsys, bucket_csv, tmp_path, monkeypatch):
    # the thin-sheet JSON lacked "solver" and "over_rho_q_v", the SPH JSON the jet's domain
    import replication.casestudy.sph as sph
    from tests.sph_fake import fake_sph

    monkeypatch.setattr(sph, "require_engine", lambda: None)
    monkeypatch.setattr(sph, "sph_force", lambda *a, progress=None, **k: fake_sph(*a, **k))
    code, out, _ = run(capsys, "force", str(bucket_csv), "--json")
    sheet = json.loads(out)
    code_sph, out, _ = run(
        capsys,
        "force",
        str(bucket_csv),
        "--solver",
        "sph",
        "--run-dir",
        str(tmp_path / "run"),
        "--json",
    )
    sph_json = json.loads(out)
    assert code == code_sph == 0 and sheet["solver"] == "sheet" and sph_json["solver"] == "sph"
    shared = ["input", "vertices", "triangles", "points_merged", "jet", "momentum_flux_N", "units"]
    assert {k: sheet[k] for k in shared} == {k: sph_json[k] for k in shared}
    # unsuffixed keys are SI: the default particle radius, 0.75 mm, is 0.00075 there
    assert sheet["units"].startswith("SI (m, s, kg, N)")
    assert sph_json["settings"]["particle_radius"] == 0.00075
    assert sheet["jet"]["domain_mm"] == [36.0, 30.0, 13.0]
    for report in (sheet, sph_json):
        assert report["over_rho_q_v"] == pytest.approx(report["axial_force_N"] / report["momentum_flux_N"])
        assert report["force_N"][2] == pytest.approx(-report["axial_force_N"])
    # the half jet's y force is the mirrored pair's in SPH: not printed as the half surface's
    assert sheet["force_N"][1] < 0 and sph_json["force_N"][1] is None
    text = ["force", str(bucket_csv), "--solver", "sph", "--run-dir", str(tmp_path / "text")]
    code, out, _ = run(capsys, *text)
    fx, _, fz = sph_json["force_N"]
    assert code == 0 and f"force ({fx + 0.0:.4g}, y not simulated, {fz:.4g}) N" in out.splitlines()


def test_full_jet_options(capsys, tmp_path):
    cloud = pelton_bucket_cloud()
    both = np.vstack([cloud, cloud[cloud[:, 1] > 0] * [1, -1, 1]])
    path = tmp_path / "both.npy"
    save_cloud(both, path)
    code, out, _ = run(
        capsys, "force", str(path), "--full-jet", "--center", "18", "0", "--resolution", "4", "--json"
    )
    report = json.loads(out)
    assert code == 0 and report["jet"]["full_jet"] and report["resolution"] == 4
    assert report["mass_flow_total_kg_s"] == pytest.approx(JetConfig(full_jet=True).mass_flow)
    code, out, _ = run(
        capsys, "force", str(path), "--full-jet", "--diameter", "6", "--velocity", "2", "--json"
    )
    report = json.loads(out)
    assert report["momentum_flux_N"] == pytest.approx(1000 * np.pi * 0.003**2 * 4)


def test_domain_options(capsys, tmp_path):
    path = tmp_path / "big.csv"
    save_cloud(pelton_bucket_cloud() * [2, 1, 1], path)
    with pytest.raises(InputError, match="outside the domain"):
        run(capsys, "force", str(path))
    assert run(capsys, "force", str(path), "--no-domain")[0] == 0
    assert run(capsys, "force", str(path), "--domain", "72", "30", "13")[0] == 0
    with pytest.raises(InputError, match="not both"):
        run(capsys, "force", str(path), "--domain", "72", "30", "13", "--no-domain")


def test_bad_options(capsys, bucket_csv):
    with pytest.raises(InputError, match="--full-jet"):  # a value that needs another option
        run(capsys, "force", str(bucket_csv), "--center", "18", "5")


def test_unreadable_inputs(capsys, tmp_path):
    with pytest.raises(CloudFileError, match="not found"):
        run(capsys, "force", str(tmp_path / "missing.csv"))
    (tmp_path / "mesh.stl").write_text("solid")
    with pytest.raises(CloudFileError, match=r"\.vtp"):
        run(capsys, "force", str(tmp_path / "mesh.stl"))
    (tmp_path / "broken.vtk").write_text("not a vtk file")
    with pytest.raises(CloudFileError):
        run(capsys, "force", str(tmp_path / "broken.vtk"))


@pytest.mark.parametrize("where", ["steps.csv", "inner/cloud.csv"])
def test_an_sph_run_directory_that_holds_the_input_is_refused(capsys, tmp_path, where):
    """The simulation writes steps.csv, series.csv, ... into --run-dir: a cloud named steps.csv
    there was overwritten by the engine's output (exit 0)."""
    run_dir = tmp_path / "rd"
    path = run_dir / where
    path.parent.mkdir(parents=True)
    save_cloud(pelton_bucket_cloud(), path)
    before = path.read_bytes()
    with pytest.raises(
        InputError, match=r"--run-dir .* holds INPUT .*: the simulation writes its files there"
    ):
        run(capsys, "force", str(path), "--solver", "sph", "--run-dir", str(run_dir))
    assert path.read_bytes() == before


def test_a_duration_with_no_window_is_refused_before_the_run_dir_is_made(capsys, bucket_csv, tmp_path):
    # was: an empty --run-dir left behind (and a 0 % progress bar) before the refusal
    with pytest.raises(InputError, match="leaves no quasi-steady window"):
        run(
            capsys,
            "force",
            str(bucket_csv),
            "--solver",
            "sph",
            "--duration",
            "1",
            "--run-dir",
            str(tmp_path / "r"),
        )
    assert not (tmp_path / "r").exists() and capsys.readouterr().err == ""


def test_sound_speed_without_wcsph_is_refused(capsys, bucket_csv):
    # the default DFSPH has no speed of sound: the option was ignored without a word
    with pytest.raises(InputError, match="--sound-speed applies only with --sph-method wcsph"):
        run(capsys, "force", str(bucket_csv), "--solver", "sph", "--sound-speed", "5")


def test_a_run_dir_in_use_by_another_force_command_is_refused(capsys, bucket_csv, tmp_path, monkeypatch):
    # two simulations writing one --run-dir at once: one said "ok" with a NaN force
    import replication.casestudy.sph as sph
    from replication.casestudy.rundir import hold
    from tests.sph_fake import fake_sph

    monkeypatch.setattr(sph, "require_engine", lambda: None)
    monkeypatch.setattr(sph, "sph_force", lambda *a, progress=None, **k: fake_sph(*a, **k))
    with hold(tmp_path / "r"), pytest.raises(InputError, match="--run-dir .*r is in use by another command"):
        run(capsys, "force", str(bucket_csv), "--solver", "sph", "--run-dir", str(tmp_path / "r"))


def test_an_sph_run_directory_with_the_users_files_is_refused(capsys, bucket_csv, tmp_path):
    """The simulation deleted and replaced steps.csv, series.csv, result.json and scene.json of a
    directory the user named, and said "ok"."""
    mine = tmp_path / "mydata"
    mine.mkdir()
    for name in ("steps.csv", "series.csv", "result.json", "scene.json"):
        (mine / name).write_text("precious\n")
    with pytest.raises(InputError, match=r"--run-dir .*mydata holds files that are not an earlier"):
        run(capsys, "force", str(bucket_csv), "--solver", "sph", "--run-dir", str(mine))
    (mine / "notes.txt").write_text("mine\n")
    (mine / "job.json").write_text("{}\n")  # a simulation's marker does not cover a stranger
    with pytest.raises(InputError, match=r"\(notes\.txt\)"):
        run(capsys, "force", str(bucket_csv), "--solver", "sph", "--run-dir", str(mine))
    assert all((mine / name).read_text() == "precious\n" for name in ("steps.csv", "result.json"))


def test_a_file_browser_s_files_do_not_make_a_run_directory_anyone_s(tmp_path):
    """A directory the user only looked at in the Finder holds .DS_Store: still empty."""
    from replication.cli.sph import _check_run_dir

    looked_at = tmp_path / "looked-at"
    looked_at.mkdir()
    for name in (".DS_Store", "Thumbs.db", "desktop.ini", ".directory", "._scene.json"):
        (looked_at / name).write_text("")
    _check_run_dir(str(looked_at))  # no error
    (looked_at / "notes.txt").write_text("mine\n")
    with pytest.raises(InputError, match=r"\(notes\.txt\)"):
        _check_run_dir(str(looked_at))


def test_an_sph_run_directory_that_is_a_file_is_one_line(capsys, bucket_csv, tmp_path):
    # was: "unexpected FileExistsError" once the simulation made its directory
    (tmp_path / "afile").write_text("hi\n")
    with pytest.raises(OutputError, match=r"--run-dir .*afile is a file, not a directory"):
        run(capsys, "force", str(bucket_csv), "--solver", "sph", "--run-dir", str(tmp_path / "afile"))
    assert (tmp_path / "afile").read_text() == "hi\n"


@pytest.mark.parametrize("where", ["name", "working directory"])
def test_an_sph_run_directory_that_is_not_utf8_is_refused(capsys, bucket_csv, tmp_path, monkeypatch, where):
    # was: a 6-line "SPH simulation failed (crash): ... TypeError: init(): incompatible function
    # arguments": the engine's binding takes its (absolute) paths as UTF-8 text
    import os

    from replication.casestudy import sph

    monkeypatch.setattr(sph, "require_engine", lambda: None)
    monkeypatch.setattr(sph, "sph_force", lambda *a, **k: pytest.fail("the simulation started"))
    bad = os.fsdecode(b"sph\xff")
    if where == "working directory":
        (tmp_path / bad).mkdir()
        monkeypatch.chdir(tmp_path / bad)
        run_dir, match = (
            "run",
            r"--run-dir run: .* valid UTF-8, and its absolute path .*sph\\udcff.*run is not",
        )
    else:
        run_dir, match = (
            str(tmp_path / bad),
            r"--run-dir .*sph\\udcff: the SPH engine needs a path that is valid UTF-8$",
        )
    with pytest.raises(InputError, match=match):
        run(capsys, "force", str(bucket_csv), "--solver", "sph", "--run-dir", run_dir)
    assert not (tmp_path / bad / "run").exists() and not (tmp_path / "run").exists()


def test_a_temporary_directory_that_is_not_utf8_is_refused_where_simulations_run_in_it(
    capsys, bucket_csv, tmp_path, monkeypatch
):
    # without --run-dir the simulation runs under TMPDIR: a name that is not UTF-8 crashed it too
    import os
    import tempfile

    from replication.casestudy import sph
    from replication.cli import main

    monkeypatch.setattr(sph, "require_engine", lambda: None)
    monkeypatch.setattr(sph, "sph_force", lambda *a, **k: pytest.fail("the simulation started"))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / os.fsdecode(b"tmp\xff")))
    match = (
        r"the temporary directory \(TMPDIR\) .*tmp\\udcff: the SPH engine needs a path that is valid UTF-8"
    )
    with pytest.raises(InputError, match=match):
        run(capsys, "force", str(bucket_csv), "--solver", "sph")
    assert main(["sph", "--quick", "--output-dir", str(tmp_path / "out")]) == 1
    assert re.search(match, capsys.readouterr().err) and not (tmp_path / "out").exists()


@pytest.mark.skipif(not engine_available(), reason='the SPH engine is not installed (pip install ".[sph]")')
def test_an_earlier_simulations_run_directory_is_reused(capsys, bucket_csv, tmp_path):
    """What the engine writes is what the run-directory check calls a simulation's own."""
    from replication.cli.sph import SIMULATION_ENTRIES

    run_dir = tmp_path / "rd"
    args = ["force", str(bucket_csv), "--solver", "sph", "--run-dir", str(run_dir), "--particle-radius", "2"]
    assert run(capsys, *args)[0] == 0
    assert {entry.name for entry in run_dir.iterdir()} <= SIMULATION_ENTRIES
    assert run(capsys, *args)[0] == 0  # an earlier simulation's files are replaced


@pytest.mark.parametrize(
    ("options", "match"),
    [
        (["--center", "18", "nan", "--full-jet"], "argument --center: expected a finite number, got 'nan'"),
        (
            ["--diameter", "1e-300"],
            "argument --diameter: expected a diameter of at least 1e-57 mm (the range the force model "
            "computes in), got '1e-300'",
        ),
        (
            ["--diameter", "1e300"],
            "argument --diameter: expected a diameter of at most 1e+63 mm (the range the force model "
            "computes in), got '1e300'",
        ),
        # was: "expected a diameter from 1e-57 to 1e+63 mm", a range that says nothing about a zero
        (["--diameter", "0"], "argument --diameter: expected a finite positive diameter in mm, got '0'"),
        (["--diameter", "-18"], "argument --diameter: expected a finite positive diameter in mm, got '-18'"),
        (["--diameter", "inf"], "argument --diameter: expected a finite positive diameter in mm, got 'inf'"),
        # Python reads "1_8" as 18
        (["--diameter", "1_8"], "argument --diameter: expected a finite positive diameter in mm, got '1_8'"),
        (["--velocity", "4_34"], "argument --velocity: expected a positive number, got '4_34'"),
        (["--velocity", "-4"], "argument --velocity: expected a finite positive number, got '-4'"),
        (["--density", "inf"], "argument --density: expected a finite positive number, got 'inf'"),
        (["--domain", "36", "0", "13"], "argument --domain: expected a finite positive number, got '0'"),
    ],
)
def test_jet_options_are_refused_as_given_in_millimetres(capsys, bucket_csv, options, match):
    # was: "jet center (x, y) must be 2 finite numbers, got (0.018, nan)", in metres, and exit 1
    # (--diameter 1e-300: an unexpected ZeroDivisionError before that), while --resolution 0 exited 2
    from replication.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["force", str(bucket_csv), *options])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and match in err and err.count("\n") == 1, err


@pytest.mark.parametrize("diameter", ["1e63", "1e-57"])
def test_the_diameters_the_option_names_as_bounds_are_accepted(capsys, bucket_csv, diameter):
    # was: "expected a diameter of at most 1e+63 mm ..., got '1e63'" (1000 * 1e60 is 9.999999999999999e62,
    # and 1e63 mm is 1.0000000000000001e60 m, past the model's bound)
    from replication.cli import main

    assert main(["force", str(bucket_csv), "--diameter", diameter, "--json"]) == 0
    capsys.readouterr()


def test_a_resolution_beyond_the_model_s_is_a_misused_option(capsys, bucket_csv):
    """--resolution 100000 ran out of memory once; the library refuses it (exit 1) and so does
    the option itself now, before reading the surface, as it refuses 0 (exit 2)."""
    from replication.cli import main

    for value in ("0", "257", "100000"):
        with pytest.raises(SystemExit) as exc:
            main(["force", str(bucket_csv), "--resolution", value])
        err = capsys.readouterr().err
        assert exc.value.code == 2 and err.count("\n") == 1
        assert f"argument --resolution: expected an integer from 1 to 256, got {value}" in err


@pytest.mark.parametrize("full_jet", [False, True])
def test_an_sph_run_says_before_it_starts_that_part_of_the_jet_will_miss(
    capsys, bucket_csv, tmp_path, monkeypatch, full_jet
):
    """A simulation takes minutes: that half the full jet passes a surface in y >= 0 by is
    known from the thin-sheet model's streamlets in milliseconds, and said first; a jet that
    strikes the surface whole says nothing."""
    import replication.casestudy.sph as sph
    from tests.sph_fake import fake_sph

    said = []

    def simulated(*a, progress=None, **k):
        said.append(capsys.readouterr().err)  # what was printed before the simulation started
        return fake_sph(*a, **k)

    monkeypatch.setattr(sph, "require_engine", lambda: None)
    monkeypatch.setattr(sph, "sph_force", simulated)
    jet = ["--full-jet", "--center", "18", "0"] if full_jet else []
    code, _, err = run(
        capsys, "force", str(bucket_csv), "--solver", "sph", "--run-dir", str(tmp_path / "r"), *jet
    )
    assert code == 0 and "misses" not in err  # after the simulation: its progress only
    (before,) = said
    if full_jet:
        assert before.startswith(
            "warning: 50.0 % of the jet's mass flow (0.5522 of 1.104 kg/s, 101 of 202 of the thin-sheet "
            "model's streamlets) misses the surface, and the simulated force will be that of the rest; "
            "the surface lies in y >= 0 only"
        )
        assert before.count("warning") == 1
    else:
        assert "warning" not in before and "misses" not in before


def test_the_check_before_a_simulation_is_advice_and_never_stops_it(monkeypatch):
    """Whatever the thin-sheet model makes of a surface (its safety net refuses a non-finite
    force), the SPH simulation still runs: the check says nothing rather than fail."""
    import replication.casestudy as casestudy
    from replication.casestudy import JetConfig
    from replication.cli.jet_misses import sph_coverage_warning
    from replication.errors import DegenerateInputError

    def refused(*args, **kwargs):
        raise DegenerateInputError("the jet force is not finite")

    points, triangles = pelton_bucket_cloud()[:3], np.array([[0, 1, 2]])
    monkeypatch.setattr(casestudy, "jet_force", refused)
    assert sph_coverage_warning(points, triangles, JetConfig()) is None


def test_a_fine_resolution_shows_its_progress(capsys, bucket_csv, monkeypatch):
    # was: 21-25 s of silence at --resolution 256
    import replication.cli.force as force

    code, out, err = run(capsys, "force", str(bucket_csv), "--resolution", "16")
    assert code == 0 and err == ""  # milliseconds of work: no display
    monkeypatch.setattr(force, "PROGRESS_FROM", 16)
    code, out, err = run(capsys, "force", str(bucket_csv), "--resolution", "16")
    streamlets = int(out.split(" streamlets, ")[0].rsplit(" ", 1)[1])
    assert code == 0 and f"jet streamlets traced (resolution 16): {streamlets}/{streamlets} done" in err
