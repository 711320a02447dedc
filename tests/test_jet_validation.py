"""The validation study end to end: tables and report with a stand-in engine, then on the real
engine (CI-sized: three surfaces, coarse particles) from the command line, with its cache."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from replication.casestudy.ga import GAConfig
from replication.casestudy.sph import engine_available
from replication.cli import main
from replication.errors import InputError
from replication.experiments.jet_validation import ValidationConfig, run_validation
from replication.experiments.jet_validation_tables import SPH_COLUMN
from replication.experiments.rank_stats import kendall_tau_b, spearman
from replication.report.jet_validation import render_jet_validation, save_jet_validation_data
from sph_fake import CALLS, fake_sph

SMALL = ValidationConfig(
    radius=1e-3, resolution_radii=(1.5e-3, 1e-3), angles_deg=(10.0,), bowl_depths_mm=(13.0,),
    resolution_surfaces=("flat plate", "Pelton bucket", "random 00"), random_surfaces=4,
    ga=GAConfig(population=6, generations=2, runs=1), ga_top=2, bootstrap=200,
)  # fmt: skip


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    return run_validation(SMALL, cache_dir=cache, simulate=fake_sph), cache


def test_every_surface_is_scored_both_ways(small_study):
    results, _ = small_study
    table = results.surfaces
    assert list(table["surface"][:4]) == [
        "flat plate",
        "plate inclined 10 deg",
        "bowl 13 mm",
        "Pelton bucket",
    ]
    assert (
        list(table["family"]).count("GA winner") == 2 and list(table["family"]).count("random lattice") == 4
    )
    assert (table["sph_status"] == "ok").all()
    # the stand-in's force is 1 + the surface's mean height; the flux is 1 kg/s at 4.34 m/s
    vertices = results.vertices.groupby("surface", sort=False)["z_mm"].mean()
    np.testing.assert_allclose(table.set_index("surface")["sph_N"], 1 + vertices[table["surface"]])
    np.testing.assert_allclose(table[SPH_COLUMN], table["sph_N"] / 4.34)
    assert table.loc[0, "model_over_rho_q_v"] == pytest.approx(1.0)  # the flat plate
    assert (
        results.triangles.groupby("surface").size()[table["surface"]].tolist() == table["triangles"].tolist()
    )


def test_agreement_is_that_of_the_tables_columns(small_study):
    results, _ = small_study
    table, overall = results.surfaces, results.agreement.iloc[0]
    assert overall["scope"] == "all surfaces" and overall["n"] == len(table)
    assert overall["spearman"] == pytest.approx(spearman(table["model_over_rho_q_v"], table[SPH_COLUMN]))
    assert overall["kendall"] == pytest.approx(kendall_tau_b(table["model_over_rho_q_v"], table[SPH_COLUMN]))
    assert overall["spearman_low"] <= overall["spearman"] <= overall["spearman_high"]
    assert set(results.agreement["scope"]) >= {"family: plate", "family: random lattice"}


def test_the_resolution_study_is_scored_at_each_radius_and_shares_the_cache(small_study):
    results, cache = small_study
    res = results.resolution
    assert sorted(res["radius_mm"].unique()) == [1.0, 1.5] and len(res) == 6
    # the stand-in does not depend on the radius: converged, the ranking unchanged
    assert results.convergence["max_change"].max() == 0.0
    fine = res[res["radius_mm"] == 1.0].set_index("surface")["sph_key"]
    assert (results.surfaces.set_index("surface").loc[fine.index, "sph_key"] == fine).all()
    distinct = set(results.surfaces["sph_key"]) | set(res["sph_key"])
    assert results.provenance["simulations"] == len(distinct) == results.surfaces["sph_key"].nunique() + 3


def test_a_rerun_simulates_nothing_and_gives_the_same_tables(small_study):
    results, cache = small_study
    CALLS.clear()
    again = run_validation(SMALL, cache_dir=cache, simulate=fake_sph, simulate_missing=False)
    assert CALLS == [] and again.surfaces["sph_cached"].all()
    columns = ["surface", "model_N", "sph_N", "sph_key"]
    pd.testing.assert_frame_equal(again.surfaces[columns], results.surfaces[columns])
    pd.testing.assert_frame_equal(again.agreement, results.agreement)  # the bootstrap is seeded


def test_the_report_renders_from_its_data(small_study, tmp_path):
    results, _ = small_study
    save_jet_validation_data(results, tmp_path)
    text = render_jet_validation(tmp_path).read_text()
    overall = results.agreement.iloc[0]
    assert f"Spearman {overall['spearman']:.2f} [{overall['spearman_low']:.2f}" in text
    assert "| GA run 0 #1 | GA winner |" in text and "## Resolution study" in text
    for name in ("jet_validation_scatter", "jet_validation_resolution"):
        assert (tmp_path / "figures" / f"{name}.png").is_file()
    back = pd.read_csv(tmp_path / "data" / "jet_validation_surfaces.csv")
    assert back["surface"].tolist() == results.surfaces["surface"].tolist()


def test_the_surfaces_are_kept_with_the_cache_and_read_back(small_study, monkeypatch):
    """A later run reads the stored surface set: a changed triangulator cannot change them."""
    from replication.experiments import jet_surface_set

    results, cache = small_study
    stored = json.loads(jet_surface_set.set_path(cache, SMALL).read_text())
    assert [s["name"] for s in stored["surfaces"]] == results.surfaces["surface"].tolist()
    assert (cache / "ga-runs").is_dir()

    def broken(*args, **kwargs):
        raise AssertionError("surfaces built again")

    monkeypatch.setattr(jet_surface_set, "reference_surfaces", broken)
    surfaces, built_by = jet_surface_set.study_surfaces(SMALL, cache_dir=cache)
    assert [s.name for s in surfaces] == [s["name"] for s in stored["surfaces"]]
    assert built_by == stored["built_by"] == results.provenance["surfaces_built_by"]
    with pytest.raises(AssertionError, match="built again"):
        jet_surface_set.study_surfaces(SMALL, cache_dir=cache, rebuild=True)


def test_bad_configurations_name_the_problem(tmp_path):
    with pytest.raises(InputError, match="one of the resolution study's radii"):
        ValidationConfig(radius=0.6e-3)
    with pytest.raises(InputError, match="between 0.1 and 5 mm"):
        ValidationConfig(radius=9e-3, resolution_radii=(9e-3,))
    bad = dataclasses.replace(ValidationConfig.quick(), resolution_surfaces=("no such surface",))
    with pytest.raises(InputError, match="not in the study"):
        run_validation(bad, cache_dir=tmp_path, simulate=fake_sph)


needs_engine = pytest.mark.skipif(
    not engine_available(), reason='the SPH engine is not installed (pip install ".[sph]")'
)


@needs_engine
def test_the_study_runs_end_to_end_on_three_surfaces_and_reruns_from_its_cache(tmp_path, capsys, monkeypatch):
    """Acceptance (issue 11): ``validate-jet --quick``: flat plate, bucket and a random lattice
    surface with coarse SPH (r = 1.25 mm, a resolution study at 1.5 and 1.25 mm), then the
    report again from the cache alone, and as a stage of ``reproduce``."""
    monkeypatch.chdir(tmp_path)  # the default cache: ./.sph-cache
    out, cache = tmp_path / "reports", tmp_path / ".sph-cache"
    argv = ["validate-jet", "--quick", "--output-dir", str(out)]
    assert main(argv) == 0
    assert "3 surfaces: thin-sheet model vs SPH Spearman" in capsys.readouterr().out
    table = pd.read_csv(out / "data" / "jet_validation_surfaces.csv").set_index("surface")
    assert (table["sph_status"] == "ok").all()  # (read from the cache the resolution study filled)
    flat, bucket = table.loc["flat plate", SPH_COLUMN], table.loc["Pelton bucket", SPH_COLUMN]
    assert 0.8 <= flat <= 1.3 and 1.15 * flat < bucket < 2.0  # momentum theory, as in test_sph
    assert (out / "jet_validation.md").is_file() and (
        out / "figures" / "jet_validation_scatter.png"
    ).is_file()
    entries = [p for p in cache.glob("??/*") if (p / "result.json").is_file()]
    # 3 surfaces x 2 radii (the study radius is shared with the resolution study) + 1 shifted repeat
    assert len(entries) == 7
    provenance = json.loads((out / "data" / "jet_validation_provenance.json").read_text())
    assert provenance["simulations"] == 6 and provenance["simulation_seconds"] > 0
    repeat = pd.read_csv(out / "data" / "jet_validation_repeatability.csv")
    assert repeat["surface"].tolist() == ["random 00"] and repeat["status_shifted"].tolist() == ["ok"]
    assert abs(repeat["sph_change"].iloc[0]) < 0.3  # a 0.6 mm shift is no new surface
    noise = pd.read_csv(out / "data" / "jet_validation_noise.csv")
    assert noise["sigma"].iloc[0] == pytest.approx(abs(repeat["sph_change"].iloc[0]) / np.sqrt(2))

    assert main([*argv, "--from-cache"]) == 0
    again = pd.read_csv(out / "data" / "jet_validation_surfaces.csv").set_index("surface")
    assert again["sph_cached"].all()
    pd.testing.assert_series_equal(again[SPH_COLUMN], table[SPH_COLUMN])
    provenance = json.loads((out / "data" / "jet_validation_provenance.json").read_text())
    assert provenance["simulation_seconds"] == 0

    from replication.casestudy.sph_batch import CACHE_ENV
    from replication.cli.validate_run import reproduce_stage

    elsewhere = tmp_path / "elsewhere"  # no .sph-cache here: the environment names the cache
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    monkeypatch.setenv(CACHE_ENV, str(cache))
    path, note = reproduce_stage(tmp_path / "reproduced", True, "replication reproduce --quick")
    assert note == "" and path.is_file()
    staged = pd.read_csv(tmp_path / "reproduced" / "data" / "jet_validation_surfaces.csv").set_index(
        "surface"
    )
    pd.testing.assert_series_equal(staged[SPH_COLUMN], table[SPH_COLUMN])


def test_reproduce_skips_the_study_without_a_filled_cache(tmp_path, monkeypatch):
    from replication.casestudy.sph_batch import CACHE_ENV
    from replication.cli.validate_run import reproduce_stage

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(CACHE_ENV, raising=False)
    path, note = reproduce_stage(tmp_path / "out", False, "replication reproduce")
    assert path is None and ("run `replication validate-jet` first" in note or "not installed" in note)
    assert not (tmp_path / "out").exists()


def test_the_cache_is_the_environments_or_the_working_directorys(tmp_path, monkeypatch):
    from replication.casestudy.sph_batch import CACHE_ENV, default_cache_dir

    monkeypatch.delenv(CACHE_ENV, raising=False)
    assert default_cache_dir() == Path(".sph-cache")
    monkeypatch.setenv(CACHE_ENV, "")  # empty: unset
    assert default_cache_dir() == Path(".sph-cache")
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    assert default_cache_dir() == tmp_path / "cache"


def test_without_a_cache_reproduce_re_renders_the_saved_study_and_leaves_its_data(
    small_study, tmp_path, monkeypatch
):
    """A fresh clone has the committed data but no SPH cache: the stage renders the report from
    those CSV files and writes none of them (nor removes any)."""
    from replication.casestudy.sph_batch import CACHE_ENV
    from replication.cli.validate_run import reproduce_stage

    results, _ = small_study
    out = tmp_path / "reports"
    save_jet_validation_data(results, out)
    before = {p.name: p.read_bytes() for p in (out / "data").iterdir()}
    monkeypatch.chdir(tmp_path)  # no .sph-cache here
    monkeypatch.delenv(CACHE_ENV, raising=False)
    path, note = reproduce_stage(out, False, "replication reproduce")
    assert path == out / "jet_validation.md" and "re-rendered from the saved data" in note
    assert {p.name: p.read_bytes() for p in (out / "data").iterdir()} == before
    text = path.read_text()
    overall = results.agreement.iloc[0]
    assert f"Spearman {overall['spearman']:.2f}" in text
    assert (out / "figures" / "jet_validation_scatter.png").is_file()
    (out / "data" / "jet_validation_noise.csv").unlink()  # incomplete data: not a study, skipped
    path, note = reproduce_stage(out, False, "replication reproduce")
    assert path is None and ("validate-jet" in note or "not installed" in note)  # (with or without SPH)


def test_from_cache_fails_naming_what_is_missing(tmp_path, capsys, monkeypatch):
    # before any work: an empty cache ran the study's GAs first (seconds to minutes)
    import replication.experiments.jet_surface_set as surface_set

    monkeypatch.setattr(surface_set, "build_surfaces", lambda *a, **k: pytest.fail("surfaces built"))
    argv = ["validate-jet", "--quick", "--from-cache", "--cache-dir", str(tmp_path / "empty"),
            "--output-dir", str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "missing from the cache: run without --from-cache" in err and len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


def test_from_cache_with_a_cache_dir_that_is_a_file(tmp_path, capsys):
    # was: "unexpected NotADirectoryError" (without --from-cache: tests/test_cli_errors.py)
    (tmp_path / "afile").write_text("x")
    argv = ["validate-jet", "--quick", "--from-cache", "--cache-dir", str(tmp_path / "afile"),
            "--output-dir", str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert (
        "--cache-dir" in err and "afile is a file, not a directory" in err and len(err.splitlines()) == 1
    ), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_the_asv_benchmark_tracks_the_models_spearman_against_the_saved_study(
    small_study, tmp_path, monkeypatch
):
    """The ``track_`` benchmark rescores the saved surfaces with the model and finds the study's
    Spearman and Kendall; without data it is skipped (NotImplementedError)."""
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1]))
    from benchmarks.benchmark_jet_validation import ModelRanksLikeSPH

    results, _ = small_study
    save_jet_validation_data(results, tmp_path)
    bench = ModelRanksLikeSPH()
    bench.data_dir = tmp_path / "data"
    bench.setup()
    overall = results.agreement.iloc[0]
    assert bench.track_model_spearman() == pytest.approx(overall["spearman"], abs=1e-12)
    assert bench.track_model_kendall() == pytest.approx(overall["kendall"], abs=1e-12)
    bench.data_dir = tmp_path / "nothing here"
    with pytest.raises(NotImplementedError, match="no committed SPH study data"):
        bench.setup()


@pytest.mark.parametrize(
    ("extra", "named"), [(["--timeout", "1"], "--timeout 1"), (["--ga-run-dir", "ga"], "--ga-run-dir ga")]
)
def test_a_study_with_other_settings_does_not_replace_the_committed_report(
    tmp_path, capsys, monkeypatch, extra, named
):
    # was: validate-jet --timeout 1 replaced reports/jet_validation.md (and the README headline)
    # with a study of 0 surfaces
    monkeypatch.chdir(tmp_path)
    assert main(["validate-jet", *extra, "--cache-dir", "cache"]) == 2  # needs --output-dir: misused
    err = capsys.readouterr().err
    assert f"with {named} the study may differ from the committed one in reports/" in err
    assert "name a report directory with --output-dir" in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_a_study_in_which_no_simulation_succeeded_writes_nothing(tmp_path, capsys, monkeypatch):
    # was: exit 0 and a report (and README headline) of 0 surfaces, Spearman nan
    import replication.casestudy.sph as sph_package
    import sph_fake

    monkeypatch.setattr(sph_package, "require_engine", lambda: "2.19.0")
    monkeypatch.setattr(sph_package, "sph_force", fake_sph)
    monkeypatch.setattr(sph_fake, "FORCE_STATUS", "timeout")
    out = tmp_path / "out"
    argv = ["validate-jet", "--quick", "--executor", "serial", "--cache-dir", str(tmp_path / "cache"),
            "--output-dir", str(out)]  # fmt: skip
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "error: no simulation succeeded (" in err and " timeout" in err and "nothing was written" in err, (
        err
    )
    assert not out.exists()


def test_from_cache_refuses_rebuilding_the_surfaces(tmp_path, capsys, monkeypatch):
    # was: the GA and every stage ran (seconds to minutes), ga-runs/ and surfaces/ were written into
    # the cache --from-cache promised not to change, and only then "37 simulation(s) missing"
    import replication.experiments.jet_surface_set as surface_set

    monkeypatch.setattr(surface_set, "build_surfaces", lambda *a, **k: pytest.fail("surfaces built"))
    argv = ["validate-jet", "--quick", "--from-cache", "--rebuild-surfaces", "--cache-dir",
            str(tmp_path / "empty"), "--output-dir", str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--from-cache changes nothing in the SPH cache, but --rebuild-surfaces" in err, err
    assert len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("quick", "ga_run_dir", "message"),
    [
        (True, "ga", "--ga-run-dir ga: the quick study has no GA winners to score"),
        (True, "afile", "--ga-run-dir afile: the quick study has no GA winners to score"),
        (False, "afile", "--ga-run-dir afile is a file, not a directory of GA runs"),
        (False, "afile/sub", "--ga-run-dir afile/sub cannot be created: afile is a file"),
    ],
)
def test_a_ga_run_dir_that_would_be_ignored_or_is_a_file(
    tmp_path, capsys, monkeypatch, quick, ga_run_dir, message
):
    # was: with --quick (no GA) --ga-run-dir was ignored, whatever it named, and the report written
    import replication.experiments.jet_surface_set as surface_set

    monkeypatch.setattr(surface_set, "build_surfaces", lambda *a, **k: pytest.fail("surfaces built"))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    quick_flag = ["--quick"] if quick else []
    argv = [
        "validate-jet",
        *quick_flag,
        "--cache-dir",
        "cache",
        "--ga-run-dir",
        ga_run_dir,
        "--output-dir",
        "out",
    ]
    assert main(argv) == (2 if quick else 1)  # --quick with --ga-run-dir: a misused command line
    err = capsys.readouterr().err
    assert message in err and len(err.splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]
