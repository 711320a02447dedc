"""Provenance: the commit of the project checkout, and code-only dirtiness."""

import subprocess
from pathlib import Path

import pytest

from replication.provenance import cpu_model, git_state, provenance

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def in_checkout():
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")


def test_git_state_of_the_checkout(in_checkout):
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    state = git_state(ROOT)
    assert state["commit"] == head and isinstance(state["dirty"], bool)


def test_regenerated_reports_do_not_make_the_code_dirty(in_checkout):
    """Only replication/ and pyproject.toml count (a report being rewritten is not a code change)."""
    dirty = subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=no", "--", "replication", "pyproject.toml"],
        cwd=ROOT, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    assert git_state(ROOT)["dirty"] == bool(dirty)


def test_outside_a_checkout_of_the_project(tmp_path, monkeypatch):
    subprocess.run(["git", "init", "-q"], cwd=tmp_path, check=True)  # another repository
    monkeypatch.chdir(tmp_path)
    state = git_state(tmp_path)
    # falls back to the package's own checkout (editable install) or reports nothing
    assert state["commit"] is None or len(state["commit"]) == 40


def test_provenance_record():
    record = provenance("replication table1", experiment="x", seeds="s")
    assert record["command"] == "replication table1" and record["experiment"] == "x"
    assert record["cores"] >= 1 and record["cpu"] == cpu_model()
    assert record["versions"]["numpy"] and "date_utc" in record
