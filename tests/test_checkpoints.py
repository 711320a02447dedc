"""GA run directories: every checkpoint and config.json is validated when it is read."""

import functools
import json
import shutil

import pytest

from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import load_run, run_ga
from replication.cli import main
from replication.errors import InputError

SMALL = GAConfig(population=8, generations=4, elites=2, seed=7)
serial = functools.partial(executor, "serial")


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    """A complete 4-generation run of run 0 (the original, copied by each test)."""
    run_dir = tmp_path_factory.mktemp("ga") / "run"
    run_ga(SMALL, 0, run_dir=run_dir, pool_factory=serial)
    return run_dir


@pytest.fixture
def run_dir(finished_run, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(finished_run, copy)
    return copy


def _edit(run_dir, change):
    path = run_dir / "run-0.json"
    state = json.loads(path.read_text())
    change(state)
    path.write_text(json.dumps(state))
    return path


def _set(key, value):
    return lambda s: s.__setitem__(key, value)


CORRUPTIONS = [
    (_set("generation", 99), "generation 99 is outside 1..4"),
    (_set("generation", 0), "generation 0 is outside 1..4"),
    (lambda s: s["fitness"].pop(), "fitness has 7 values, expected 8"),
    (lambda s: s["population"].pop(), "population has 7 genomes, expected 8"),
    (lambda s: s["population"][3].__setitem__(5, 999), "genome 3 lies outside the lattice"),
    (lambda s: s["population"][2].__setitem__(0, -1), "genome 2 lies outside the lattice"),
    (lambda s: s["population"][1].pop(), "genome 1 is not a list of 303 integers"),
    (lambda s: s["population"][0].__setitem__(0, 1.5), "genome 0 is not a list of 303 integers"),
    (lambda s: s["fitness"].__setitem__(4, 1e9), "fitness of genome 4"),
    (lambda s: s["fitness"].__setitem__(4, "4.4"), "finite numbers or null"),
    (lambda s: s["history"].pop(), "history has 3 entries for 4 generation(s)"),
    (_set("rng_state", {"bit_generator": "MT19937"}), "rng_state is not the state of numpy's PCG64"),
    (_set("rng_state", {"bit_generator": "PCG64", "state": {"state": "x"}}), "not a valid PCG64 state"),
    (_set("run", 1), "checkpoint of run 1, expected run 0"),
    (lambda s: s.pop("cache"), "missing field(s) cache"),
    (_set("cache", {}), "genome 0 is not in the evaluation cache"),
    # found by an adversarial review: a run-0.json copied from a run seeded 6 into this one (seed
    # 7) resumed and was reported as seed 7; a generator state out of range raised OverflowError;
    # a history value that is not a number failed only after the whole GA had run
    (_set("seed", [6, 0]), "checkpoint of a run seeded [6, 0], expected [7, 0]"),
    (lambda s: s["rng_state"]["state"].__setitem__("state", -5), "not a valid PCG64 state"),
    (lambda s: s["history"][0].__setitem__("best", "x"), "history entry 1: best must be a number, got 'x'"),
    (
        lambda s: s["history"][1].__setitem__("evaluations", 2.5),
        "history entry 2: evaluations must be an integer",
    ),
]


@pytest.mark.parametrize(("change", "fault"), CORRUPTIONS)
def test_inconsistent_checkpoint_is_refused_naming_file_and_fault(run_dir, change, fault):
    path = _edit(run_dir, change)
    with pytest.raises(InputError) as exc:
        load_run(run_dir, 0)
    message = str(exc.value)
    assert message.startswith(f"{path}: not a valid GA checkpoint: ") and fault in message, message
    with pytest.raises(InputError, match="not a valid GA checkpoint"):
        run_ga(SMALL, 0, run_dir=run_dir, pool_factory=serial, resume=True)


@pytest.mark.parametrize(
    ("content", "fault"),
    [("{not json", "malformed JSON"), ("", "malformed JSON"), ("[]", "expected a JSON object, got list")],
)
def test_unreadable_checkpoint(run_dir, content, fault):
    (run_dir / "run-0.json").write_text(content)
    with pytest.raises(InputError, match=fault):
        load_run(run_dir, 0)


def test_checkpoint_without_config_is_refused(run_dir):
    (run_dir / "config.json").unlink()
    with pytest.raises(InputError, match=r"holds GA checkpoints \(run-0.json\) but no config.json"):
        load_run(run_dir, 0)
    with pytest.raises(InputError, match="but no config.json"):
        run_ga(SMALL, 0, run_dir=run_dir, pool_factory=serial, resume=True)


@pytest.mark.parametrize(
    ("change", "fault"),
    [
        (lambda c: c.pop("population"), "missing setting(s) population"),
        (lambda c: c.__setitem__("colour", "red"), "unknown setting(s) colour"),
        (lambda c: c.__setitem__("population", 2), "population must be at least 4"),
        (lambda c: c.__setitem__("population", "8"), "population must be an integer"),
        (lambda c: c["jet"].__setitem__("diameter", -1), "jet diameter must be positive"),
        (lambda c: c.__setitem__("jet", [1]), "jet must be a JSON object"),
    ],
)
def test_invalid_config_json_is_refused(run_dir, change, fault):
    path = run_dir / "config.json"
    config = json.loads(path.read_text())
    change(config)
    path.write_text(json.dumps(config))
    with pytest.raises(InputError) as exc:
        run_ga(SMALL, 0, run_dir=run_dir, pool_factory=serial, resume=True)
    assert str(exc.value).startswith(f"{path}: not a valid GA configuration: ") and fault in str(exc.value)


def test_cli_refuses_a_bad_checkpoint_before_any_work(capsys, run_dir, monkeypatch):
    _edit(run_dir, _set("generation", 99))

    def started(*args, **kwargs):
        raise AssertionError("the experiment started before the checkpoints were checked")

    monkeypatch.setattr("replication.experiments.casestudy.run_casestudy", started)
    assert main(["casestudy", "--run-dir", str(run_dir), "--resume", "--executor", "serial"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "run-0.json: not a valid GA checkpoint: generation 99" in err


def test_checkpoints_record_their_seed_and_older_ones_without_it_still_load(run_dir):
    assert json.loads((run_dir / "run-0.json").read_text())["seed"] == [7, 0]
    _edit(run_dir, lambda s: s.pop("seed"))  # as written before the seed was recorded
    assert load_run(run_dir, 0, SMALL).seed is None


def test_a_valid_checkpoint_still_resumes(run_dir):
    state = load_run(run_dir, 0)
    assert state is not None and state.generation == 4
    again = run_ga(SMALL, 0, run_dir=run_dir, pool_factory=serial, resume=True)
    assert again.state() == state.state()


def test_numpy_integer_settings_are_written_as_json(tmp_path):
    """GAConfig accepted numpy integers but kept them: config.json could not be written
    ('Object of type int64 is not JSON serializable'), nor the checkpoint's seed."""
    import numpy as np

    config = GAConfig(population=np.int64(8), generations=np.int32(4), elites=2, seed=np.int64(7))
    assert config == SMALL and type(config.seed) is int and type(config.population) is int
    run_ga(config, 0, run_dir=tmp_path / "run", pool_factory=serial)
    assert json.loads((tmp_path / "run" / "run-0.json").read_text())["seed"] == [7, 0]
