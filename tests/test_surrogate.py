"""The surrogate's calibration: a seeded stratified split, a fit that recovers known parameters,
and a judgement on the held-out half only."""

import numpy as np
import pandas as pd
import pytest

from replication.errors import InputError
from replication.experiments.jet_validation_tables import SPH_COLUMN
from replication.experiments.surrogate import CALIBRATION, HELD_OUT, calibrate, judge, split_halves


def study_table(counts):
    rows = []
    for stratum, n in counts.items():
        rows += [{"surface": f"{stratum} {i}", "stratum": stratum} for i in range(n)]
    return pd.DataFrame(rows)


def test_the_split_is_stratified_balanced_and_seeded():
    table = study_table({"plate": 4, "cup": 3, "GA run 0": 5, "GA run 1": 5, "GA run 2": 5, "random": 15})
    halves = split_halves(table, rng=11)
    assert halves.equals(split_halves(table, rng=11)) and not halves.equals(split_halves(table, rng=12))
    counts = halves.groupby(table.set_index("surface")["stratum"]).value_counts().unstack(fill_value=0)
    assert (counts[HELD_OUT] >= 1).all() and (counts[CALIBRATION] >= 1).all()  # every stratum in both
    assert ((counts[CALIBRATION] - counts[HELD_OUT]).abs() <= 1).all()
    assert abs((halves == CALIBRATION).sum() - (halves == HELD_OUT).sum()) <= 1
    np.random.seed(0)  # global state plays no part
    assert split_halves(table, rng=11).equals(halves)


def test_a_stratum_of_one_goes_to_calibration():
    halves = split_halves(study_table({"flat": 1, "random": 4}), rng=1)
    assert halves["flat 0"] == CALIBRATION and (halves == HELD_OUT).sum() == 2


def synthetic(n=12, seed=3):
    """Surfaces carrying two features, and a 'true' force with known losses."""
    rng = np.random.default_rng(seed)
    features = rng.uniform(0, 1, size=(n, 2))
    surfaces = [(np.array([f]), None) for f in features]

    def force(points, triangles, params):
        a, b = points[0]
        return 1.9 - params["reimpact"] * a - params["crease"] * b

    return surfaces, force


def test_the_fit_recovers_known_losses_up_to_a_common_factor():
    surfaces, force = synthetic()
    truth = {"reimpact": 0.3, "crease": 0.5}
    sph = [1.07 * force(p, t, truth) for p, t in surfaces]
    fit = calibrate(
        surfaces, sph, force, {"reimpact": np.linspace(0, 0.6, 7), "crease": np.linspace(0, 1, 11)}
    )
    assert fit.params == pytest.approx(truth) and fit.objective == pytest.approx(0, abs=1e-12)
    assert fit.scale == pytest.approx(1.07)


def test_refinement_finds_values_between_grid_points():
    surfaces, force = synthetic()
    truth = {"reimpact": 0.2 + 0.1 / 3, "crease": 0.5}
    sph = [force(p, t, truth) for p, t in surfaces]
    coarse = calibrate(
        surfaces, sph, force, {"reimpact": [0, 0.1, 0.2, 0.3], "crease": [0, 0.5, 1]}, refine=0
    )
    fine = calibrate(surfaces, sph, force, {"reimpact": [0, 0.1, 0.2, 0.3], "crease": [0, 0.5, 1]}, refine=1)
    assert fine.objective < coarse.objective and fine.params["reimpact"] == pytest.approx(truth["reimpact"])


def test_the_judgement_scores_each_half_apart():
    table = pd.DataFrame({
        "surface": list("abcdefgh"), "sph_status": ["ok"] * 7 + ["timeout"],
        SPH_COLUMN: [1, 2, 3, 4, 5, 6, 7, 8.0], "score": [1, 2, 3, 4, 7, 6, 5, 0.0],
    })  # fmt: skip
    halves = pd.Series([CALIBRATION] * 4 + [HELD_OUT] * 4, index=list("abcdefgh"))
    frame = judge(table, halves, "score", resamples=100, rng=np.random.default_rng(1)).set_index("scope")
    assert frame.loc[CALIBRATION, "spearman"] == 1.0 and frame.loc[HELD_OUT, "n"] == 3  # h failed
    assert frame.loc[HELD_OUT, "spearman"] == -1.0
    assert frame.loc["all surfaces", "n"] == 7


def test_calibration_needs_enough_positive_data():
    surfaces, force = synthetic(2)
    with pytest.raises(InputError, match="at least 3"):
        calibrate(surfaces, [1.0, 1.0], force, {"reimpact": [0.0]})


def test_the_surrogate_fitted_to_a_lossy_model_finds_its_losses_and_ranks_the_held_out_half(tmp_path):
    """Known answer: 'SPH' here is the thin-sheet model with known losses (on the fit's grid);
    the fit on the calibration half recovers them and ranks the held-out half perfectly."""
    from replication.casestudy.ga import GAConfig
    from replication.casestudy.jet import JetConfig, SheetLosses, jet_force
    from replication.experiments.jet_surfaces import random_lattice_surfaces, reference_surfaces
    from replication.experiments.jet_surrogate import departures, fit_surrogate

    jet = JetConfig()
    surfaces = reference_surfaces(angles_deg=(), bowl_depths_mm=(13.0,)) + random_lattice_surfaces(
        6, GAConfig(), rng=3
    )
    truth = SheetLosses(crease=1.0, reimpact=0.4)
    rows = []
    for s in surfaces:
        model = jet_force(s.points, s.triangles, jet).axial_force / jet.momentum_flux
        sph = jet_force(s.points, s.triangles, jet, losses=truth).axial_force / jet.momentum_flux
        rows.append({"surface": s.name, "family": s.family, "stratum": s.stratum, "model_over_rho_q_v": model,
                     SPH_COLUMN: 1.05 * sph, "sph_status": "ok", "model_over_sph": model / (1.05 * sph),
                     "model_parcels": 1})  # fmt: skip
    table = pd.DataFrame(rows)
    fit = fit_surrogate(table, surfaces, jet, resamples=200, rng=np.random.default_rng(1), split_seed=[11, 2])
    params = fit["surrogate_params"].set_index("parameter")["value"]
    assert params["crease"] == pytest.approx(1.0) and params["reimpact"] == pytest.approx(0.4)
    assert params["fit: common factor SPH / surrogate"] == pytest.approx(1.05)
    held = fit["surrogate_agreement"].set_index("scope").loc[HELD_OUT]
    assert held["n"] >= 3 and held["spearman"] == pytest.approx(1.0)
    per = fit["surrogate_surfaces"]
    assert set(per["half"]) == {CALIBRATION, HELD_OUT}
    assert departures(table, surfaces)["feature"].tolist()[0] == "model force / rho Q V"
    # too few SPH scores to fit: no surrogate, said by None
    few = table.assign(sph_status=["ok"] * 2 + ["missing"] * (len(table) - 2))
    assert fit_surrogate(few, surfaces, jet, resamples=10, rng=np.random.default_rng(1), split_seed=1) is None
