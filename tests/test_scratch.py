"""Scratch directories that a command killed outright (SIGKILL) leaves are removed by the next one."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from replication.io import scratch
from replication.io.atomic import writer_tag


@pytest.fixture
def tmpdir_here(tmp_path, monkeypatch):
    monkeypatch.setattr(scratch.tempfile, "gettempdir", lambda: str(tmp_path))
    return tmp_path


def _ended_tag():
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    return writer_tag().replace(str(os.getpid()), ended.stdout.decode().strip(), 1)


def test_a_scratch_directory_is_removed_at_the_end_even_after_an_error(tmpdir_here):
    with pytest.raises(RuntimeError), scratch.scratch_directory("replication-x-") as path:
        (path / "big.bin").write_bytes(b"x" * 1000)
        assert path.parent == tmpdir_here and path.name.startswith("replication-x-" + writer_tag())
        raise RuntimeError
    assert list(tmpdir_here.iterdir()) == []


def test_the_next_one_removes_only_those_of_ended_processes_of_its_kind(tmpdir_here):
    """A killed `table1` left a 120 KB directory in the temporary directory at every kill."""
    abandoned = tmpdir_here / f"replication-x-{_ended_tag()}abc"
    running = tmpdir_here / f"replication-x-{writer_tag()}def"  # this process: it runs
    foreign = tmpdir_here / "replication-x-1.otherhost-ghi"  # another machine's
    other_kind = tmpdir_here / f"replication-y-{_ended_tag()}jkl"  # not this kind: not looked at
    untagged = tmpdir_here / "replication-x-q1w2e3"  # somebody else's naming
    for path in (abandoned, running, foreign, other_kind, untagged):
        (path / "sub").mkdir(parents=True)
    with scratch.scratch_directory("replication-x-") as path:
        assert path.is_dir()
    assert sorted(p.name for p in tmpdir_here.iterdir()) == sorted(
        p.name for p in (running, foreign, other_kind, untagged)
    )
