"""The thin-sheet GA's best surfaces re-scored by SPH (``casestudy --rescore sph``, issue 11 item 3).

Most tests replace the engine by ``fake_sph`` (force 1 + mean height, blow-up for a surface
wholly at 13 mm), so that selection, cache, resume, failures and the report are checked in
milliseconds; one test runs the real engine at coarse particles.
"""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import replication.casestudy.sph as sph_package
from replication.casestudy import rescore as rescore_module
from replication.casestudy.checkpoints import WORST, GARun
from replication.casestudy.ga import GAConfig, genome_from_points, points_from_genome, random_genome
from replication.casestudy.rescore import RescoreConfig, rescore_runs, top_distinct
from replication.casestudy.shapes import flat_plate_cloud, pelton_bucket_cloud, pelton_bucket_surface
from replication.casestudy.sph import SPHSettings, engine_available
from replication.casestudy.sph import score as sph_score
from replication.cli import main
from replication.errors import InputError
from replication.experiments.casestudy_rescore import PAPER_EVALUATIONS, rescore_cost
from replication.report.casestudy_rescore import RESCORE_FILES, rescore_section, save_rescore_data
from replication.report.store import write_json
from sph_fake import CALLS, fake_sph

CONFIG = GAConfig(population=6, generations=2, runs=2)
SETTINGS = SPHSettings(particle_radius=1e-3, duration=0.016)


@pytest.fixture(autouse=True)
def _reset():
    CALLS.clear()


def genome(cloud):
    return genome_from_points(cloud, CONFIG)


def state(run, clouds, fitness):
    population = np.stack([genome(c) for c in clouds])
    return GARun(run, CONFIG.generations, population, np.asarray(fitness, dtype=float), {})


def plates_run(run=0):
    """Plates at 3, 3 (a repeated elite), 2, 1, and a failed evaluation."""
    p3 = flat_plate_cloud(3)
    clouds = [flat_plate_cloud(1), p3, flat_plate_cloud(2), p3, flat_plate_cloud(5)]
    return state(run, clouds, [1.0, 3.0, 2.0, 3.0, WORST])


def test_the_top_k_are_the_best_distinct_surfaces_repeats_and_failures_left_out():
    spiky = points_from_genome(random_genome(CONFIG, rng=np.random.default_rng(7)), CONFIG)
    # a random surface, twice (a repeated elite) and with its points listed backwards (the same
    # surface: the ADT of points in general position does not depend on their order)
    clouds = [flat_plate_cloud(1), spiky, flat_plate_cloud(2), spiky, spiky[::-1], flat_plate_cloud(5)]
    run = state(0, clouds, [1.0, 3.0, 2.0, 3.0, 3.0, WORST])
    top = top_distinct(run, CONFIG, 3)
    assert [(c.rank, c.index, c.fitness) for c in top] == [(1, 1, 3.0), (2, 2, 2.0), (3, 0, 1.0)]
    assert [c.name for c in top] == ["GA run 0 #1", "GA run 0 #2", "GA run 0 #3"]
    assert [float(c.points[:, 2].mean()) for c in top[1:]] == [2.0, 1.0]
    # fewer distinct surfaces than asked: all of them, the failed evaluation never
    assert [c.index for c in top_distinct(run, CONFIG, 10)] == [1, 2, 0]
    assert [c.index for c in top_distinct(run, CONFIG, 1)] == [1]


@pytest.mark.parametrize("top", [0, -1, 1.5, True])
def test_top_must_be_a_positive_integer(top):
    with pytest.raises(InputError, match="top must be a positive integer"):
        RescoreConfig(top=top)
    with pytest.raises(InputError, match="top must be a positive integer"):
        top_distinct(plates_run(), CONFIG, top)


def rescore(tmp_path, states=None, top=2):
    states = states or [plates_run(0), state(1, [pelton_bucket_cloud(), flat_plate_cloud(4)], [5.0, 4.0])]
    config = RescoreConfig(top=top, settings=SETTINGS, cache_dir=tmp_path / "cache")
    return rescore_runs(states, CONFIG, config, simulate=fake_sph)


def test_rescoring_gives_known_forces_and_a_rerun_simulates_nothing(tmp_path):
    first = rescore(tmp_path)
    f = first.surfaces
    assert list(f["surface"]) == [
        "flat plate", "pelton bucket", "GA run 0 #1", "GA run 0 #2", "GA run 1 #1", "GA run 1 #2",
    ]  # fmt: skip
    # fake force: 1 + mean height (N); the bucket of run 1 is the reference itself, simulated once
    assert f.loc[2:, "sph_N"].tolist()[:2] == [4.0, 3.0] and f.loc[5, "sph_N"] == 5.0
    assert f.loc[0, "sph_N"] == 1.0 and f.loc[4, "same_as"] == "pelton bucket"
    assert f["same_as"].tolist().count("") == 5 and f.loc[4, "sph_N"] == f.loc[1, "sph_N"]
    assert f.loc[2:, "thin_sheet_N"].tolist() == [3.0, 2.0, 5.0, 4.0]
    assert f["status"].eq("ok").all() and not f["cached"].any()
    assert len(CALLS) == 5  # six rows, one surface twice
    assert math.isclose(f.loc[2, "sph_over_rho_q_v"], 4.0 / CONFIG.jet.momentum_flux)

    CALLS.clear()
    again = rescore(tmp_path)  # resumed: everything from the cache
    assert CALLS == [] and again.surfaces["cached"].all()
    columns = [c for c in f.columns if c != "cached"]
    pd.testing.assert_frame_equal(again.surfaces[columns], f[columns])
    fresh = rescore(tmp_path / "other")  # deterministic: another cache, the same scores
    pd.testing.assert_frame_equal(fresh.surfaces, f)


def test_an_interrupted_rescoring_resumes_with_what_it_finished(tmp_path):
    rescore(tmp_path, top=1)  # a first pass that stopped after the best of each run
    CALLS.clear()
    full = rescore(tmp_path, top=2)
    assert sorted(CALLS) == ["2", "4"]  # only the surfaces not simulated before
    assert full.surfaces["cached"].tolist() == [True, True, True, False, True, False]


def test_a_failed_simulation_is_recorded_with_its_reason(tmp_path):
    blowing = state(0, [flat_plate_cloud(13), flat_plate_cloud(2)], [9.0, 2.0])
    f = rescore(tmp_path, [blowing]).surfaces
    row = f.set_index("surface").loc["GA run 0 #1"]
    assert row["status"] == "blowup" and row["reason"] == "runaway velocities" and math.isnan(row["sph_N"])
    assert f.set_index("surface").loc["GA run 0 #2", "sph_N"] == 3.0  # the rest carries on


def results_with_rescore(tmp_path, states=None):
    done = rescore(tmp_path, states)
    runs = pd.DataFrame({"evaluations": [8, 8], "cache_hits": [4, 4]})
    cost = rescore_cost(
        done.surfaces, wall_seconds=done.wall_seconds, thin_sheet_seconds=0.004, runs=runs, config=CONFIG,
        cores=2, workers=1,
    )  # fmt: skip

    class Results:
        rescore = done.surfaces
        rescore_cost = cost

    return Results, cost


def test_the_cost_table_projects_the_papers_ga_from_the_measured_simulations(tmp_path):
    _, cost = results_with_rescore(tmp_path)
    c = cost.set_index("item")["value"]
    assert c["thin-sheet evaluation"] == 4.0  # ms
    assert c["SPH simulation"] > 0 and c["simulations run"] == 5 and c["simulations read from the cache"] == 0
    assert c["--solver sph evaluations (paper's GA)"] == round(PAPER_EVALUATIONS * 8 / 12)
    one, two = c["--solver sph, 1 worker"], c["--solver sph, 2 workers"]
    assert math.isclose(one, 4800 * c["SPH simulation"] / 3600) and math.isclose(two, one / 2)
    assert math.isclose(c["--solver sph, 64 workers"], one / 64)


def test_the_report_section_appears_only_with_rescoring_data(tmp_path):
    out = tmp_path / "report"
    data = out / "data"
    data.mkdir(parents=True)
    assert rescore_section(out) == ""
    blowing = [state(0, [flat_plate_cloud(13), pelton_bucket_cloud(), flat_plate_cloud(12)], [9.0, 5.0, 6.0])]
    results, _ = results_with_rescore(tmp_path, blowing)
    save_rescore_data(results, data)
    write_json({"rescore": {"top": 2, "settings": SETTINGS.as_dict()}}, data / "casestudy_provenance.json")
    text = rescore_section(out)
    assert text.startswith("## The GA's best surfaces re-scored by SPH") and text.endswith("\n\n")
    assert "particle radius 1 mm, 16 ms simulated" in text
    # ranked by SPH: plate at 12 mm (13 N) first; the bucket's own copy is not a GA surface beating it
    lines = [line for line in text.splitlines() if line.startswith("| ") and "---" not in line][1:]
    assert lines[0].startswith("| 1 | GA run 0 #2 |")
    failed = next(line for line in lines if "GA run 0 #1 " in line)
    assert failed.startswith("| – |") and "| blowup: runaway velocities |" in failed
    assert "Best by SPH: **GA run 0 #2**, 13 N" in text
    assert "1 of 1 GA surfaces beat the bucket by SPH" in text
    assert "--solver sph, 64 workers" in text

    # a run without rescoring into the same directory leaves no stale section behind
    class Plain:
        rescore = None

    save_rescore_data(Plain, data)
    assert not any((data / name).exists() for name in RESCORE_FILES) and rescore_section(out) == ""


TINY = ["casestudy", "--runs", "1", "--generations", "2", "--population", "6", "--executor", "serial"]


@pytest.fixture
def fake_engine(monkeypatch):
    monkeypatch.setattr(sph_package, "require_engine", lambda: "2.19.0")
    monkeypatch.setattr(sph_package, "sph_force", fake_sph)


#: A tiny GA re-scored by the fake engine: its 2 best surfaces per run, coarse particles.
RESCORED = [*TINY, "--run-dir", "run", "--output-dir", "out", "--rescore", "sph", "--top", "2",
            "--particle-radius", "1", "--duration", "16", "--cache-dir", "cache", "--json"]  # fmt: skip


def test_casestudy_rescore_runs_end_to_end_and_resumes_from_the_cache(
    tmp_path, monkeypatch, capsys, fake_engine
):
    monkeypatch.chdir(tmp_path)
    args = RESCORED
    assert main(args) == 0
    out, err = capsys.readouterr()
    first = json.loads(out)
    assert [r["surface"] for r in first["rescore"]][:2] == ["flat plate", "pelton bucket"]
    assert not any(r["cached"] for r in first["rescore"]) and CALLS
    simulated = len(CALLS)  # the cost ahead is counted before the first simulation, then counted down
    assert (
        f"SPH re-scoring: {simulated} distinct surfaces, 0 from the cache, {simulated} to simulate, "
        "1 at a time\n" in err  # the serial executor's one
    )
    assert f"; 1/{simulated}, about " in err and f"; {simulated}/{simulated}, the last)" in err
    report = (tmp_path / "out" / "casestudy.md").read_text()
    assert "## The GA's best surfaces re-scored by SPH" in report and "Best by SPH" in report
    assert (tmp_path / "out" / "data" / "casestudy_rescore_cost.csv").is_file()
    CALLS.clear()
    assert main([*args, "--resume"]) == 0
    out, err = capsys.readouterr()
    again = json.loads(out)
    assert CALLS == [] and all(r["cached"] for r in again["rescore"])
    lines = err.splitlines()
    plan = lines.index(
        f"SPH re-scoring: {simulated} distinct surfaces, {simulated} from the cache, 0 to simulate"
    )
    assert plan < min(k for k, line in enumerate(lines) if line.endswith("(cache)"))  # the plan first
    assert [r["sph_N"] for r in again["rescore"]] == [r["sph_N"] for r in first["rescore"]]


@pytest.mark.parametrize("json_out", [True, False])
def test_a_rescore_whose_every_simulation_failed_exits_1_after_its_report(
    tmp_path, monkeypatch, capsys, fake_engine, json_out
):
    # was: exit status 0, as if SPH had judged the GA's winners
    import sph_fake

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sph_fake, "FORCE_STATUS", "timeout")
    args = RESCORED if json_out else [a for a in RESCORED if a != "--json"]
    assert main(args) == 1
    out, err = capsys.readouterr()
    rows = pd.read_csv(tmp_path / "out" / "data" / "casestudy_rescore.csv")
    ga = rows[rows["kind"] == "GA"]
    total, distinct, ga_distinct = len(rows), rows["key"].nunique(), ga["key"].nunique()
    assert len(ga) == 2 and distinct == len(CALLS)  # a surface listed twice is simulated once
    assert err.splitlines()[-1] + "\n" == (
        f"replication casestudy: error: no GA surface was judged by SPH: every simulation of the GA's 2 "
        f"surface(s) failed ({ga_distinct} timeout); {Path('out') / 'casestudy.md'} gives each one's reason\n"
    )
    if json_out:  # the object is printed whole before the error
        assert all(r["status"] == "timeout" for r in json.loads(out)["rescore"])
    else:  # simulations counted once each, as the report's cost table counts them
        assert (
            f"SPH re-scoring: {total} surfaces, {distinct} distinct (0 from the cache, {distinct} failed)"
            in out
        )
        assert "ended after 0.0 s" in err and "simulated in" not in err
    assert "| timeout: forced timeout |" in (tmp_path / "out" / "casestudy.md").read_text()
    # one surface judged is a result: exit 0
    monkeypatch.setattr(sph_fake, "FORCE_STATUS", None)
    assert main([*args, "--resume"]) == 0


def test_a_resume_may_change_the_sph_timeout_and_simulates_again_what_timed_out(
    tmp_path, monkeypatch, capsys, fake_engine
):
    # was: --resume --sph-timeout 100 of a run whose limit (0.01 s) was too short was refused,
    # and the run could only be started over
    import sph_fake

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sph_fake, "FORCE_STATUS", "timeout")
    assert main([*RESCORED, "--sph-timeout", "0.01"]) == 1
    capsys.readouterr()
    CALLS.clear()
    monkeypatch.setattr(sph_fake, "FORCE_STATUS", None)
    resume = [
        "casestudy",
        "--run-dir",
        "run",
        "--resume",
        "--output-dir",
        "out",
        "--executor",
        "serial",
        "--json",
    ]
    assert main([*resume, "--sph-timeout", "100"]) == 0
    rescored = json.loads(capsys.readouterr().out)["rescore"]
    assert CALLS and all(r["status"] == "ok" and not r["cached"] for r in rescored)
    assert json.loads((tmp_path / "run" / "rescore.json").read_text())["sph_timeout"] == 100
    CALLS.clear()
    assert main(resume) == 0 and CALLS == []  # the new limit is the run's from now on


def test_a_rescore_that_judged_only_the_reference_shapes_exits_1():
    from replication.cli.casestudy_sph import check_rescored
    from replication.errors import SimulationError

    class Results:
        rescore = pd.DataFrame({
            "surface": ["flat plate", "pelton bucket", "GA run 0 #1", "GA run 0 #2", "GA run 1 #1"],
            "kind": ["reference", "reference", "GA", "GA", "GA"],
            "status": ["ok", "ok", "blowup", "timeout", "blowup"],
            "key": ["a", "b", "c", "d", "c"],  # run 1's winner is run 0's
        })  # fmt: skip

    refusal = r"^no GA surface was judged by SPH: every simulation of the GA's 3 surface\(s\) failed "
    with pytest.raises(SimulationError, match=refusal + r"\(1 blowup, 1 timeout\); r.md gives"):
        check_rescored(Results, "r.md")
    Results.rescore.loc[3, "status"] = "ok"
    check_rescored(Results, "r.md")  # one GA surface judged: a result


def test_rescore_progress_counts_down_at_the_measured_rate(tmp_path, capsys):
    from replication.casestudy.sph_batch import Plan, Scored
    from replication.cli.casestudy_sph import RescoreProgress

    now = [100.0]
    progress = RescoreProgress(clock=lambda: now[0])
    ok = fake_sph(flat_plate_cloud(12), None, CONFIG.jet, SETTINGS, timeout=1, run_dir=tmp_path)
    blown = dataclasses.replace(ok, status="blowup", reason="runaway")
    progress.plan(Plan(1, 0, 5, 2))  # two at once: the executor's workers, a cluster's too
    progress(Scored("flat plate", "k", "ok", None, ok, True, None))
    now[0] += 600.0  # two at once: the first two end 10 min in, then three more two at a time
    progress(Scored("GA run 0 #1", "k", "ok", None, ok, False, None))  # its partner ends now too
    progress(Scored("GA run 0 #2", "k", "blowup", "runaway", blown, False, None))
    now[0] += 600.0
    progress(Scored("GA run 0 #3", "k", "error", "a dead worker", None, False, None))
    progress(Scored("GA run 0 #4", "k", "ok", None, ok, False, None))
    now[0] += 600.0
    progress(Scored("GA run 0 #5", "k", "ok", None, ok, False, None))
    assert capsys.readouterr().err.splitlines() == [
        "SPH re-scoring: 6 distinct surfaces, 1 from the cache, 5 to simulate, 2 at a time",
        "SPH flat plate: 13 N (cache)",
        "SPH GA run 0 #1: 13 N (simulated in 0.0 s; 1/5, about 15 min left)",  # 3 x 10 min / 2
        "SPH GA run 0 #2: blowup: runaway (ended after 0.0 s; 2/5, about 15 min left)",
        "SPH GA run 0 #3: error: a dead worker (3/5, about 13 min left)",  # 2 x 20 min / 3
        "SPH GA run 0 #4: 13 N (simulated in 0.0 s; 4/5, about 5 min left)",
        "SPH GA run 0 #5: 13 N (simulated in 0.0 s; 5/5, the last)",
    ]


def test_rescore_progress_says_what_is_missing_from_the_cache_and_that_nothing_runs(capsys):
    from replication.casestudy.sph_batch import Plan
    from replication.cli.casestudy_sph import RescoreProgress

    RescoreProgress().plan(Plan(2, 1, 0, 0))
    RescoreProgress().plan(Plan(0, 0, 3, 3))
    assert capsys.readouterr().err.splitlines() == [
        "SPH re-scoring: 3 distinct surfaces, 2 from the cache, 1 missing from it, 0 to simulate",
        "SPH re-scoring: 3 distinct surfaces, 0 from the cache, 3 to simulate, 3 at a time",
    ]


def test_a_plain_resume_continues_the_runs_rescoring_and_other_options_are_refused(
    tmp_path, monkeypatch, capsys, fake_engine
):
    # was: `casestudy --run-dir run --resume` dropped the SPH step and wrote its report into
    # the directory its settings alone chose (another run's report); --resume --top 3 of a
    # run with --top 2 was accepted
    monkeypatch.chdir(tmp_path)
    assert main(RESCORED) == 0
    rescored = json.loads(capsys.readouterr().out)["rescore"]
    assert json.loads((tmp_path / "run" / "rescore.json").read_text()) == {
        "cache_dir": str((tmp_path / "cache").resolve()), "duration": 16.0, "particle_radius": 1.0,
        "rescore": "sph", "top": 2,
    }  # fmt: skip
    CALLS.clear()
    assert main(["casestudy", "--run-dir", "run", "--resume", "--output-dir", "out", "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert [r["sph_N"] for r in again["rescore"]] == [r["sph_N"] for r in rescored] and CALLS == []
    # the same options again, the cache by another path from another directory: the same run
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    again = [
        "--run-dir",
        "../run",
        "--resume",
        "--output-dir",
        "../out",
        "--top",
        "2",
        "--cache-dir",
        "../cache",
    ]
    assert main(["casestudy", *again, "--json"]) == 0 and CALLS == []
    capsys.readouterr()
    monkeypatch.chdir(tmp_path)
    for extra, named in (
        (["--top", "3"], "--top 3 (the run has 2)"),
        (["--cache-dir", "other"], f"(the run has {(tmp_path / 'cache').resolve()})"),
        (["--duration", "20"], "--duration 20 (the run has 16.0)"),
        (["--solver", "sph"], "--solver sph"),
    ):
        assert main(["casestudy", "--run-dir", "run", "--resume", *extra]) == 1
        err = capsys.readouterr().err
        assert (
            "holds a run re-scored with other SPH options: " in err and named in err and err.count("\n") == 1
        )
    (tmp_path / "run" / "rescore.json").write_text("{not json")
    assert main(["casestudy", "--run-dir", "run", "--resume"]) == 1
    assert "rescore.json: not a readable record of the run's --rescore options" in capsys.readouterr().err


def test_a_resume_may_repeat_an_option_at_its_default(tmp_path, monkeypatch, capsys, fake_engine):
    # was: --top 5 (the default) refused on resume as "the run has its default"
    monkeypatch.chdir(tmp_path)
    first = [*TINY, "--run-dir", "run", "--output-dir", "out", "--rescore", "sph", "--particle-radius", "1",
             "--duration", "16", "--cache-dir", "cache"]  # fmt: skip
    assert main(first) == 0
    capsys.readouterr()
    assert json.loads((tmp_path / "run" / "rescore.json").read_text())["top"] == 5
    assert main(["casestudy", "--run-dir", "run", "--resume", "--output-dir", "out", "--top", "5"]) == 0


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--particle-radius", "1"], "--particle-radius applies only with --rescore sph or --solver sph"),
        (["--solver", "sph", "--top", "3"], "--top applies only with --rescore sph"),
        (["--solver", "sph", "--rescore", "sph"], "give one of them"),
        (["--yes"], "--yes applies only with --solver sph"),
        (["--top", "3"], "--top applies only with --rescore sph"),
        (["--rescore", "sph", "--duration", "5"], "leaves no quasi-steady window"),
        (["--rescore", "sph", "--particle-radius", "9"], "particle_radius must lie between 0.1 and 5 mm"),
    ],
)
def test_bad_sph_options_are_refused_before_any_work(
    tmp_path, monkeypatch, capsys, fake_engine, extra, message
):
    monkeypatch.chdir(tmp_path)
    misused = "applies only" in message or "give one of them" in message  # options, not values
    assert main([*TINY, "--run-dir", "run", *extra]) == (2 if misused else 1)
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_top_below_one_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main([*TINY, "--rescore", "sph", "--top", "0"])
    assert exc.value.code == 2 and "--top" in capsys.readouterr().err


def test_rescore_without_the_engine_names_the_install_command(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sph_score, "ENGINE", "no_such_engine_module")
    assert main([*TINY, "--run-dir", "run", "--rescore", "sph"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'pip install ".[sph]"' in err
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
@pytest.mark.skipif(not engine_available(), reason='the SPH engine is not installed (pip install ".[sph]")')
def test_the_real_engine_rescores_a_run_at_coarse_particles(tmp_path):
    run = state(0, [flat_plate_cloud(2), flat_plate_cloud(2)], [2.0, 2.0])  # one distinct surface
    config = RescoreConfig(top=2, settings=SETTINGS, cache_dir=tmp_path / "cache")
    f = rescore_runs([run], CONFIG, config).surfaces.set_index("surface")
    assert list(f.index) == ["flat plate", "pelton bucket", "GA run 0 #1"] and f["status"].eq("ok").all()
    rho_q_v = CONFIG.jet.momentum_flux
    assert 0.8 < f.loc["flat plate", "sph_N"] / rho_q_v < 1.3  # momentum theory: rho Q V
    assert f.loc["pelton bucket", "sph_N"] > f.loc["flat plate", "sph_N"]  # a cup turns the sheet back
    again = rescore_runs([run], CONFIG, config).surfaces
    assert again["cached"].all() and again["sph_N"].tolist() == f["sph_N"].tolist()
    assert rescore_module.REFERENCES == ("flat plate", "pelton bucket")


def test_solver_sph_scores_every_individual_and_resumes_from_its_checkpoints(
    tmp_path, monkeypatch, capsys, fake_engine
):
    monkeypatch.chdir(tmp_path)
    args = [*TINY, "--run-dir", "run", "--solver", "sph", "--particle-radius", "1", "--duration", "16",
            "--cache-dir", "cache", "--json"]  # fmt: skip
    assert main(args) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert "--solver sph: 0.02 s per simulation x at most 12 evaluations / 1 worker(s)" in captured.err
    # fake force 1 + mean height: the bucket (in the initial population) wins by SPH
    bucket = 1 + float(pelton_bucket_surface().points[:, 2].mean())
    assert math.isclose(out["runs"][0]["best_N"], bucket, rel_tol=1e-12)
    assert out["report"] == "run/report/casestudy.md"  # never the committed reports/
    report = (tmp_path / "run" / "report" / "casestudy.md").read_text()
    assert "**Fitness: SPH.**" in report and "particle radius 1 mm, 16 ms simulated" in report
    record = json.loads((tmp_path / "run" / "fitness.json").read_text())
    assert record["solver"] == "sph" and record["settings"]["particle_radius"] == 0.001
    # every distinct individual once; the flat plate measured for the estimate is one of them
    assert len(CALLS) == out["evaluations"]
    # resumed: nothing simulated again; another fitness for the same run is refused
    CALLS.clear()
    assert main([*args, "--resume"]) == 0
    assert json.loads(capsys.readouterr().out)["runs"] == out["runs"] and CALLS == []
    assert main([*TINY, "--run-dir", "run", "--resume"]) == 1
    assert (
        "scored by SPH (--duration 16 ms, --particle-radius 1 mm), not the thin-sheet model"
        in capsys.readouterr().err
    )


def _one_simulation_takes_1000_s(monkeypatch):
    """The --solver sph estimate measures its one simulation at 1000 s (the rest as it is)."""
    import replication.casestudy.sph_fitness as sph_fitness

    real = sph_fitness.estimate

    def slow(fitness, *, workers):
        e = real(fitness, workers=workers)
        return sph_fitness.Estimate(1000.0, e.evaluations, e.workers, e.cached)

    monkeypatch.setattr(sph_fitness, "estimate", slow)


def test_solver_sph_prints_its_estimate_and_refuses_more_than_an_hour_without_yes(
    tmp_path, monkeypatch, capsys, fake_engine
):
    monkeypatch.chdir(tmp_path)
    _one_simulation_takes_1000_s(monkeypatch)
    args = [*TINY, "--run-dir", "run", "--solver", "sph", "--particle-radius", "1", "--duration", "16",
            "--cache-dir", "cache"]  # fmt: skip
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "1e+03 s per simulation x at most 12 evaluations / 1 worker(s) = at most 3.33 h" in err
    assert "exceeds 1 h: pass --yes" in err and not (tmp_path / "run" / "run-0.json").exists()


def test_solver_sph_on_a_named_cluster_estimates_with_the_cluster_s_threads(
    tmp_path, monkeypatch, capsys, fake_engine, port_8787_taken
):
    """With --scheduler the estimate divided by 1 worker (the command could not know the
    cluster's size), and asked for --yes when a cluster of several would finish within the hour."""
    distributed = pytest.importorskip("distributed")
    monkeypatch.chdir(tmp_path)
    _one_simulation_takes_1000_s(monkeypatch)
    args = [*TINY[:-2], "--run-dir", "run", "--solver", "sph", "--particle-radius", "1", "--duration", "16",
            "--cache-dir", "cache"]  # fmt: skip
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=3,
        processes=False,
        dashboard_address="127.0.0.1:0",
        scheduler_kwargs={"dashboard": False},
    ) as cluster:
        assert main([*args, "--scheduler", cluster.scheduler_address]) == 1
    err = capsys.readouterr().err
    assert "1e+03 s per simulation x at most 12 evaluations / 3 worker(s) = at most 1.11 h" in err
    assert "exceeds 1 h: pass --yes" in err and not (tmp_path / "run" / "run-0.json").exists()


@pytest.mark.parametrize("sph", [["--rescore", "sph"], ["--rescore", "sph", "--particle-radius", "3"]])
def test_rescore_at_the_papers_settings_reports_into_its_run_dir(tmp_path, monkeypatch, fake_engine, sph):
    # was: the committed reports/casestudy.md gained the re-scored section (the committed study has none)
    from replication.cli import build_parser
    from replication.cli.casestudy import plan_casestudy

    monkeypatch.chdir(tmp_path)
    args = build_parser(["casestudy"]).parse_args(["casestudy", "--run-dir", "run", *sph])
    plan = plan_casestudy(args)
    assert plan.config == GAConfig() and str(plan.out) == "run/report"
    assert plan.note.startswith("--rescore sph: the report goes to run/report/, not reports/")
    # --quick would report into reports-quick/: the note names that one (it said reports/)
    quick = build_parser(["casestudy"]).parse_args(["casestudy", "--quick", "--run-dir", "quick", *sph])
    assert plan_casestudy(quick).note.startswith(
        "--rescore sph: the report goes to quick/report/, not reports-quick/"
    )
    explicit = build_parser(["casestudy"]).parse_args(
        ["casestudy", "--run-dir", "run", *sph, "--output-dir", "reports"]
    )
    assert str(plan_casestudy(explicit).out) == "reports"
