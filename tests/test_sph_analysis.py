"""SPH settings, content keys and the force analysis (no engine needed)."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from replication.casestudy import JetConfig, flat_plate_surface
from replication.casestudy.sph import SPHSettings, content_key
from replication.casestudy.sph.analysis import read_steps, running_mean_max, summarize_force
from replication.casestudy.sph.driver import STEPS_HEADER, blowup_reason
from replication.casestudy.sph.settings import timeline
from replication.errors import CloudFileError, InputError


def steps_of(dt, axial, lateral=None):
    """A driver-like step table with the given step sizes and axial force (N along the jet)."""
    dt = np.asarray(dt, dtype=float)
    axial = np.asarray(axial, dtype=float)
    lateral = np.zeros((dt.size, 2)) if lateral is None else np.asarray(lateral, dtype=float)
    return {"time": np.cumsum(dt), "dt": dt, "fx": lateral[:, 0], "fy": lateral[:, 1], "fz": -axial}


# --- settings --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"particle_radius": 0.0}, "particle_radius"),
        ({"particle_radius": 1.0}, "between 0.1 and 5 mm"),
        ({"duration": float("nan")}, "duration"),
        ({"method": "isph"}, "method"),
        ({"sound_speed": -3.0}, "sound_speed"),
        ({"threads": 0}, "threads"),
        ({"gravity": -9.81}, "gravity"),
        ({"min_time_step": 1e-3}, "min_time_step"),
        ({"peak_window": True}, "peak_window"),
    ],
)
def test_bad_settings_name_the_value(kwargs, match):
    with pytest.raises(InputError, match=match):
        SPHSettings(**kwargs)


def test_settings_round_trip_and_derived_values():
    s = SPHSettings(particle_radius=0.5e-3, method="wcsph", threads=2)
    assert SPHSettings.from_dict(json.loads(json.dumps(s.as_dict()))) == s
    with pytest.raises(InputError, match="unknown SPH settings: colour"):
        SPHSettings.from_dict({**s.as_dict(), "colour": 1})
    assert s.support_radius == pytest.approx(2e-3)
    assert s.speed_of_sound(4.34) == pytest.approx(43.4)  # 10 V by default
    assert s.time_step_limit(4.34) == pytest.approx(0.4 * 1e-3 / (43.4 + 4.34))
    assert SPHSettings().speed_of_sound(4.34) is None and SPHSettings().time_step_limit(4.34) == 1e-4


def test_timeline_of_the_default_run():
    t = timeline(SPHSettings(particle_radius=1e-3, duration=0.02), 4.34, 0.018)
    assert t.gap == pytest.approx(0.006) and t.contact == pytest.approx(0.006 / 4.34)
    assert t.window == pytest.approx((0.006 / 4.34 + 0.006, 0.02 - 0.018 / 4.34))
    assert t.column_length == pytest.approx(4.34 * 0.02 - 0.006)
    with pytest.raises(InputError, match="leaves no quasi-steady window.*at least"):
        timeline(SPHSettings(duration=0.009), 4.34, 0.018)


def test_content_key_is_stable_and_sensitive(tmp_path):
    s = flat_plate_surface()
    pts, tri = s.points * 1e-3, np.asarray(s.triangles, dtype=np.int64)
    jet, base = JetConfig(), SPHSettings()
    key = content_key(pts, tri, jet, base)
    assert len(key) == 64 and key == content_key(pts.copy(), tri.copy(), JetConfig(), SPHSettings())
    others = {
        content_key(pts, tri, jet, dataclasses.replace(base, particle_radius=1e-3)),
        content_key(pts, tri, jet, dataclasses.replace(base, threads=2)),
        content_key(pts, tri, JetConfig(full_jet=True), base),
        content_key(pts + [0, 0, 1e-6], tri, jet, base),
        content_key(pts, tri[::-1], jet, base),
    }
    assert key not in others and len(others) == 5
    # the same key in another interpreter (no dependence on hash randomisation)
    np.save(tmp_path / "p.npy", pts)
    np.save(tmp_path / "t.npy", tri)
    code = (
        "import numpy as np; from replication.casestudy import JetConfig; "
        "from replication.casestudy.sph import SPHSettings, content_key; "
        f"print(content_key(np.load({str(tmp_path / 'p.npy')!r}), np.load({str(tmp_path / 't.npy')!r}), "
        "JetConfig(), SPHSettings()))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == key


# --- analysis --------------------------------------------------------------------------------


def test_constant_force_known_answers():
    rng = np.random.default_rng(5)
    dt = rng.uniform(2e-5, 8e-5, 400)  # about 20 ms of irregular steps
    s = summarize_force(steps_of(dt, np.full(dt.size, 3.0)), (0.005, 0.012), bin_width=1e-3, peak_window=1e-4)
    assert s.mean_force[2] == pytest.approx(-3.0, rel=1e-12) and s.std_axial == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(s.bin_force[:, 2], -3.0, rtol=1e-12)
    assert (
        s.peak_axial == pytest.approx(3.0) and s.max_axial == pytest.approx(3.0) and s.max_step_axial == 3.0
    )
    half = summarize_force(steps_of(dt, np.full(dt.size, 3.0)), (0.005, 0.012), bin_width=1e-3,
                           peak_window=1e-4, scale=0.5)  # fmt: skip
    assert half.mean_force[2] == pytest.approx(-1.5, rel=1e-12)


def test_impact_pulse_known_answers():
    """Steps of 50 us; 10 N from 1.00 to 1.20 ms, 1 N elsewhere, 4 N from 9 to 10 ms."""
    dt = np.full(400, 5e-5)
    t0 = np.cumsum(dt) - dt
    axial = np.where((t0 >= 1.0e-3 - 1e-12) & (t0 < 1.2e-3 - 1e-12), 10.0, 1.0)
    axial[(t0 >= 9e-3 - 1e-12) & (t0 < 10e-3 - 1e-12)] = 4.0
    s = summarize_force(steps_of(dt, axial), (0.004, 0.012), bin_width=1e-3, peak_window=1e-4)
    assert s.peak_axial == pytest.approx(10.0) and 1.0e-3 - 1e-9 <= s.peak_time <= 1.1e-3 + 1e-9
    wide = summarize_force(steps_of(dt, axial), (0.004, 0.012), bin_width=1e-3, peak_window=5e-4)
    assert wide.peak_axial == pytest.approx((0.2 * 10 + 0.3 * 1) / 0.5)
    assert s.mean_force[2] == pytest.approx(-(7 * 1.0 + 1 * 4.0) / 8)  # window 4-12 ms
    bins = -s.bin_force[:, 2]
    assert bins[1] == pytest.approx(0.2 * 10 + 0.8 * 1) and bins[9] == pytest.approx(4.0)
    assert s.std_axial == pytest.approx(np.std([1] * 5 + [4] + [1] * 2, ddof=1))
    assert s.max_axial == pytest.approx(10.0)  # the impact, not the later plateau


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1e-5, 2e-3))
def test_running_mean_max_is_the_maximum(seed, width):
    rng = np.random.default_rng(seed)
    dt = rng.uniform(1e-5, 2e-4, 60)
    force = rng.normal(0, 1, 60)
    time = np.cumsum(dt)
    best, start = running_mean_max(time, dt, force, width, 0.0, float(time[-1]))
    if width > time[-1]:
        assert np.isnan(best)
        return
    knots = np.concatenate([[0.0], time])
    impulse = np.concatenate([[0.0], np.cumsum(force * dt)])

    def mean(s):
        return (np.interp(s + width, knots, impulse) - np.interp(s, knots, impulse)) / width

    assert mean(start) == pytest.approx(best, rel=1e-9, abs=1e-12)
    grid = np.linspace(0.0, time[-1] - width, 2000)
    assert np.all(mean(grid) <= best + 1e-9)


def test_a_run_that_stopped_early_has_bins_but_no_window():
    dt = np.full(100, 5e-5)  # 5 ms only
    s = summarize_force(steps_of(dt, np.ones(100)), (0.006, 0.010), bin_width=1e-3, peak_window=1e-4)
    assert s.bin_force.shape == (5, 3) and np.isnan(s.mean_force).all() and np.isnan(s.peak_axial)


def test_read_steps(tmp_path):
    path = tmp_path / "steps.csv"
    path.write_text(STEPS_HEADER + "\n")
    assert read_steps(path)["time"].shape == (0,)
    path.write_text(STEPS_HEADER + "\n1,1e-05,1e-05,0.5,-0.5,-2.0,4.34\n2,2e-05,1e-05,0.0,0.0,-3.0,4.35\n")
    steps = read_steps(path)
    np.testing.assert_array_equal(steps["fz"], [-2.0, -3.0])
    path.write_text(path.read_text() + "3,3e-05,1e-05,0.0,0")  # cut short by a crash
    np.testing.assert_array_equal(read_steps(path)["fz"], [-2.0, -3.0])
    with pytest.raises(CloudFileError, match="missing"):
        read_steps(tmp_path / "absent.csv")


def test_blowup_reasons():
    ok = np.zeros(3)
    kw = {"max_speed": 43.4, "min_time_step": 1e-8}
    assert blowup_reason(ok, 4.4**2, 5e-5, **kw) is None
    assert blowup_reason(np.array([np.nan, 0, 0]), 1.0, 5e-5, **kw) == "non-finite velocities"
    assert blowup_reason(ok, float("nan"), 5e-5, **kw) == "non-finite velocities"
    assert "runaway velocities: a particle reached 50 m/s" in blowup_reason(ok, 2500.0, 5e-5, **kw)
    assert "time step collapse" in blowup_reason(ok, 1.0, 1e-8, **kw)
