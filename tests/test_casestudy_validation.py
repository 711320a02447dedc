"""The case-study report and the headline say which fitness made each number, with SPH beside it."""

import pandas as pd
import pytest

from replication.report.casestudy_validation import validation_headline, validation_section
from replication.report.store import write_csv

SPH = "sph_over_measured_flux"


def write_study(out, ga_sph, bucket_sph=1.89, surrogate=None):
    """A validation study's data: flat plate, bucket, two GA winners, two random surfaces."""
    rows = [
        ("flat plate", "plate", 1.0, 1.07, float("nan")),
        ("Pelton bucket", "cup", 1.84, bucket_sph, float("nan")),
        ("GA run 0 #1", "GA winner", 1.92, ga_sph, 4.61),
        ("GA run 0 #2", "GA winner", 1.91, ga_sph - 0.05, 4.60),
        ("random 00", "random lattice", 1.82, 1.45, float("nan")),
        ("random 01", "random lattice", 1.80, 1.42, float("nan")),
    ]
    surfaces = pd.DataFrame(rows, columns=["surface", "family", "model_over_rho_q_v", SPH, "ga_fitness_N"])
    surfaces["sph_status"] = "ok"
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    write_csv(surfaces, data / "jet_validation_surfaces.csv")
    agreement = pd.DataFrame([{"scope": "all surfaces", "n": 6, "spearman": 0.31, "spearman_low": -0.5,
                               "spearman_high": 0.9, "top5": 3}])  # fmt: skip
    write_csv(agreement, data / "jet_validation_agreement.csv")
    if surrogate is not None:
        frame = pd.DataFrame([{"scope": "held out", "n": 3, "spearman": surrogate}])
        write_csv(frame, data / "jet_validation_surrogate_agreement.csv")
    write_csv(pd.DataFrame([{"run": 0, "best_N": 4.61}]), data / "casestudy_runs.csv")
    (data / "jet_validation_provenance.json").write_text("{}")  # a saved study has one (see below)


def test_tables_without_their_provenance_are_not_read(tmp_path):
    write_study(tmp_path, ga_sph=2.0)
    assert validation_headline(tmp_path)
    (tmp_path / "data" / "jet_validation_provenance.json").unlink()  # a save cut short, a removed file
    assert validation_headline(tmp_path) == []


def test_without_the_study_the_section_says_the_numbers_are_the_models_alone(tmp_path):
    text = validation_section(tmp_path)
    assert "**thin-sheet model's**" in text and "no claim about optimal shapes" in text
    assert validation_headline(tmp_path) == []


def test_when_sph_ranks_the_ga_winners_below_the_bucket_the_report_says_so(tmp_path):
    write_study(tmp_path, ga_sph=1.40)
    text = validation_section(tmp_path)
    assert "**By SPH none of the GA's winners beats the bucket**" in text
    assert "| Pelton bucket | 1.840 | 1.890 |" in text
    assert "| GA winners (2): best / median | 1.920 / 1.915 | 1.400 / 1.375 |" in text
    assert "Spearman 0.31 [-0.50, 0.90]" in text
    assert "their best fitness values agree" in text  # the study's winners are this report's runs'
    (line,) = validation_headline(tmp_path)
    assert "do not beat the bucket (1.89)" in line and "the optimum found is the model's" in line


def test_when_sph_confirms_the_optimum_the_report_says_that_instead(tmp_path):
    write_study(tmp_path, ga_sph=1.95)
    assert "the optimum holds beyond the model" in validation_section(tmp_path)
    assert "beats the bucket (1.89) too" in validation_headline(tmp_path)[0]


@pytest.mark.parametrize("held_out, verdict", [(0.62, "**SPH must be the fitness of record**"),
                                               (0.93, "it may stand in for SPH")])  # fmt: skip
def test_the_surrogates_held_out_verdict_is_carried(tmp_path, held_out, verdict):
    write_study(tmp_path, ga_sph=1.40, surrogate=held_out)
    assert verdict in validation_section(tmp_path)
    line = validation_headline(tmp_path)[0]
    assert f"Spearman {held_out:.2f} (goal 0.9)" in line
    assert ("SPH must be the fitness of record" in line) == (held_out < 0.9)


def test_other_runs_are_flagged(tmp_path):
    write_study(tmp_path, ga_sph=1.40)
    write_csv(pd.DataFrame([{"run": 0, "best_N": 4.50}]), tmp_path / "data" / "casestudy_runs.csv")
    assert "may not be the ones SPH scored" in validation_section(tmp_path)


def test_the_optimum_claim_says_which_fitness_holds_it(tmp_path):
    from replication.report.casestudy_validation import OPTIMUM_CLAIM, fitness_note

    assert fitness_note(tmp_path, "the bucket takes less force than the flat plate") == ""
    alone = fitness_note(tmp_path, OPTIMUM_CLAIM)
    assert "thin-sheet model's" in alone and "SPH has not checked it" in alone and "model only" in alone
    write_study(tmp_path, ga_sph=1.40)
    text = fitness_note(tmp_path, OPTIMUM_CLAIM)
    assert "by SPH it **does not hold**: best GA winner 1.40, bucket 1.89" in text
    write_study(tmp_path, ga_sph=1.95)
    assert "by SPH it **holds**" in fitness_note(tmp_path, OPTIMUM_CLAIM)
