"""One command at a time writes reports into a directory (replication.io.locks)."""

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from replication.cli import main
from replication.io import locks


def _held_elsewhere(out: Path) -> subprocess.Popen:
    """Another process holding ``out`` as a command writing there would."""
    key = str(Path(os.path.abspath(out)).resolve())
    script = (
        "import fcntl, os, sys, time\n"
        f"fd = os.open({str(locks._lock_file(key))!r}, os.O_RDONLY | os.O_CREAT, 0o644)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\n"
        "print('held', flush=True)\n"
        "time.sleep(60)\n"
    )
    holder = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    return holder


def _stop(holder: subprocess.Popen) -> None:
    holder.kill()
    holder.wait()
    holder.stdout.close()


@pytest.mark.parametrize(
    "command",
    [
        ["table1", "--quick"],
        ["casestudy", "--quick", "--run-dir", "RUN"],
        ["validate-jet", "--quick"],
        ["report"],
    ],
)
def test_a_second_command_writing_the_same_reports_directory_is_refused(
    tmp_path, monkeypatch, capsys, command
):
    # was: two case studies into one --output-dir, both exit 0, one's page over the other's data
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "mix"
    if command == ["report"]:
        out.mkdir()
    holder = _held_elsewhere(tmp_path / "other" / ".." / "mix")  # the same directory by another name
    try:
        start = time.monotonic()
        assert main([*command, "--output-dir", str(out)]) == 1
        assert time.monotonic() - start < 10  # refused before any work
    finally:
        _stop(holder)
    err = capsys.readouterr().err
    assert f"--output-dir {out} is in use by another command writing its reports there" in err
    assert err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == (["mix"] if command == ["report"] else [])


def test_the_hold_is_released_when_the_command_ends_and_is_reentrant(tmp_path):
    out = tmp_path / "r"
    with locks.held_until_the_command_ends():
        locks.hold_reports_dir(out)
        locks.hold_reports_dir(out)  # reproduce draws several reports into one directory
        assert len(locks._HELD) == 1
    assert locks._HELD == {}
    _stop(_held_elsewhere(out))  # free again: another process takes it
    locks.hold_reports_dir(out)  # outside a command: the library holds nothing
    assert locks._HELD == {}
