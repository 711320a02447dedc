"""The SPH study's verdicts and its report (sph.md), from ``replication reproduce --quick``."""

import numpy as np
import pandas as pd
import pytest

from replication.casestudy import JetConfig
from replication.casestudy.sph import engine_available, score
from replication.cli import main
from replication.experiments.sph import SPHStudyConfig
from replication.experiments.sph_claims import hypotheses, verdict
from replication.report.sph import render_sph
from replication.report.store import read_csv

needs_engine = pytest.mark.skipif(
    not engine_available(), reason='the SPH engine is not installed (pip install ".[sph]")'
)


@pytest.mark.parametrize(
    ("flat", "bucket", "expected"),
    [
        (21.0, 18.0, "consistent"),
        (21.96 * 1.16, 19.08, "bucket only"),
        (22.0, 5.0, "flat plate only"),
        (19.5, 20.0, "no (wrong order)"),
        (2.4, 4.4, "no"),
        (float("nan"), 4.4, "not simulated"),
    ],
)
def test_verdicts(flat, bucket, expected):
    assert verdict(flat, bucket) == expected


def synthetic_runs(flat_peak, bucket_peak, exponent=1.0):
    """Runs as the study tabulates them, with chosen impact peaks (c = 10 V and 20 V)."""
    jet = JetConfig()
    rows = []
    common = {"status": "ok", "peak_time_ms": 1.0, "rho_q_v_N": jet.momentum_flux}
    for shape, mean, peak in (("flat plate", 2.4, flat_peak), ("pelton bucket", 4.3, bucket_peak)):
        rows.append(
            {"shape": shape, "method": "dfsph", "radius_mm": 0.5, "sound_speed_m_s": np.nan, "mean_N": mean,
             "fx_N": 0.01, "peak_N": 9.0, "max_step_N": 12.0, **common}
        )  # fmt: skip
        for factor in (10.0, 20.0):
            rows.append(
                {"shape": shape, "method": "wcsph", "radius_mm": 0.75, "sound_speed_m_s": factor * 4.34,
                 "mean_N": mean, "fx_N": 0.0, "peak_N": peak * (factor / 10) ** exponent,
                 "max_step_N": 1.1 * peak * (factor / 10) ** exponent, **common}
            )  # fmt: skip
    shapes = pd.DataFrame({"shape": ["flat plate", "pelton bucket"], "thin_sheet_fy_N": [0.0, 0.3]})
    return pd.DataFrame(rows), shapes, jet


def test_hypotheses_from_known_runs():
    runs, shapes, jet = synthetic_runs(flat_peak=20.0, bucket_peak=18.0, exponent=0.5)
    h = hypotheses(runs, shapes, jet).set_index("hypothesis")
    assert h.loc["first-impact peak (WCSPH, c = 10 V)", "verdict"] == "consistent"
    assert h.loc["quasi-steady mean force (DFSPH, incompressible)", "verdict"] == "no"
    full = h.loc["the full jet rather than the half (2 x quasi-steady mean, DFSPH)"]
    assert (full["flat_N"], full["bucket_N"]) == (4.8, 8.6)
    assert h.loc["none of these", "verdict"] == "no"  # one reading matched
    assert h["step_sound_exponent_flat"].iloc[0] == pytest.approx(0.5)
    fitted = h.loc["largest single-step force (WCSPH) at the sound speed that fits the flat plate"]
    # the c at which 22 N (at 43.4 m/s) ~ c^0.5 reaches 21.96 N; the bucket's 19.8 N there follows
    assert fitted["flat_N"] == 21.96 and fitted["bucket_N"] == pytest.approx(1.1 * 18.0 * 21.96 / 22.0)
    assert fitted["verdict"] == "consistent" and "c = 43.2 m/s fits the flat plate" in fitted["why"]
    sums = h.loc["sum of the magnitudes of the force components (x, y and z)"]
    assert (sums["flat_N"], sums["bucket_N"]) == pytest.approx((2.41, 4.61))
    runs, shapes, jet = synthetic_runs(flat_peak=22.0, bucket_peak=7.0, exponent=0.0)
    h = hypotheses(runs, shapes, jet).set_index("hypothesis")
    assert h.loc["first-impact peak (WCSPH, c = 10 V)", "verdict"] == "flat plate only"
    fitted = h.loc["largest single-step force (WCSPH) at the sound speed that fits the flat plate"]
    assert np.isnan(fitted["flat_N"]) and fitted["verdict"] == "not determined"  # no growth with c
    assert h.loc["none of these", "verdict"] == "holds"


def test_study_configuration():
    full, quick = SPHStudyConfig(), SPHStudyConfig.quick()
    assert min(full.radii) <= 0.5e-3 and len(full.radii) >= 3  # down to at most 0.5 mm
    labels = [r.label for r in full.runs()]
    assert len(labels) == len(set(labels)) == 2 * (len(full.radii) + len(full.wcsph))
    assert len(quick.runs()) == 4
    speeds = {r.sound_factor: r.settings(0.02, 4.34).speed_of_sound(4.34) for r in full.runs()}
    assert speeds == {None: None, 10.0: pytest.approx(43.4), 20.0: pytest.approx(86.8)}
    dfsph = full.runs()[0].settings(0.02, 4.34)
    assert dfsph.method == "dfsph" and dfsph.duration == 0.02 and dfsph.sound_speed is None
    with pytest.raises(ValueError, match="half jet"):
        SPHStudyConfig(jet=JetConfig(full_jet=True))


def test_reproduce_skips_the_sph_stage_without_the_engine(monkeypatch, tmp_path, capsys):
    import replication.cli.reports as reports

    monkeypatch.setattr(score, "ENGINE", "no_such_engine_module")
    monkeypatch.setattr(reports, "STAGES", (("sph", "the SPH study"),))
    assert main(["reproduce", "--quick", "--output-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    hint = 'pip install ".[sph]" in the project\'s checkout'
    assert f"[skipped] sph: the SPH solver is not installed ({hint})" in out
    assert not (tmp_path / "sph.md").exists()


@needs_engine
def test_quick_sph_report(quick_reports, quick_reports_copy):
    text = (quick_reports / "sph.md").read_text()
    assert "**Quick run**" in text and "## The paper's forces examined" in text
    runs = read_csv(quick_reports / "data" / "sph_runs.csv")
    assert (runs["status"] == "ok").all() and len(runs) == len(SPHStudyConfig.quick().runs())
    h = read_csv(quick_reports / "data" / "sph_hypotheses.csv")
    assert set(h["paper_flat_N"]) == {21.96} and set(h["paper_bucket_N"]) == {19.08}  # verbatim
    assert "| 21.96 |" in text and "| 19.08 |" in text
    for _, row in h.iterrows():  # every verdict in the report, next to its numbers
        assert f"**{row['verdict']}**" in text
    for name in ("sph_series", "sph_convergence"):
        assert (quick_reports / "figures" / f"{name}.png").is_file()
    assert "[The case study on a real SPH solver](sph.md)" in (quick_reports / "index.md").read_text()
    assert "[sph.md](sph.md)" in (quick_reports / "casestudy.md").read_text()
    assert render_sph(quick_reports_copy).read_text() == text  # re-rendering from the data changes nothing


def test_the_note_on_cached_wall_times_says_how_many_came_from_the_cache():
    # was: "taken from the SPH cache where it held them" also when every simulation was run
    from replication.report.sph import _cache_note

    assert _cache_note({}, 14) == ""  # no cache
    assert _cache_note({"sph_cache": "c", "sph_cache_hits": 0}, 14) == (
        " Every simulation was run for this study (the SPH cache gave none)."
    )
    assert _cache_note({"sph_cache": "c", "sph_cache_hits": 3}, 14).startswith(
        " 3 of the 14 simulations were read from the SPH cache: their wall times are those of the runs"
    )
    assert "where it held them" in _cache_note({"sph_cache": "c"}, 14)  # saved before the count


def test_the_cost_section_names_the_machine_from_the_provenance_and_the_cached_share():
    # was: "measured on a shared 2-core machine while other work ran", whatever ran it
    from replication.report.sph import _cost_context

    prov = {"cpu": "AMD EPYC", "cores": 2}
    assert _cost_context(prov, 14) == (
        "measured on AMD EPYC, 2 cores, which may have run other work: indicative times, not benchmarks"
    )
    assert _cost_context({**prov, "sph_cache": "c", "sph_cache_hits": 0}, 14) == _cost_context(prov, 14)
    assert _cost_context({**prov, "sph_cache": "c", "sph_cache_hits": 3}, 14).endswith(
        "; 3 of the 14 simulations were read from the SPH cache, with the times (and the number at once) "
        "of the runs that made them"
    )
    assert "have the times of the runs that made them" in _cost_context({**prov, "sph_cache": "c"}, 14)
    assert _cost_context({"cpu": None, "cores": None}, 14).startswith(
        "measured on an unnamed CPU, an unknown number of cores,"
    )
