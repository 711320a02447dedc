"""One command at a time writes reports into a directory (replication.io.locks)."""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from replication.cli import main
from replication.errors import OutputError
from replication.io import locks


def _held_elsewhere(out: Path, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Another process holding ``out`` as a command writing there would (its own code)."""
    script = (
        "import sys, time\n"
        "from replication.io import locks\n"
        "with locks.held_until_the_command_ends():\n"
        "    locks.hold_reports_dir(sys.argv[1])\n"
        "    print('held', flush=True)\n"
        "    time.sleep(60)\n"
    )
    holder = subprocess.Popen(
        [sys.executable, "-c", script, str(out)],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
        cwd=Path(locks.__file__).parents[2],  # where `replication` is imported from, installed or not
    )
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


def test_commands_with_different_temporary_directories_exclude_each_other(tmp_path, monkeypatch, capsys):
    # was: the lock file followed $TMPDIR, so `TMPDIR=/a replication casestudy ...` and
    # `TMPDIR=/b replication casestudy ...` into one --output-dir both ran
    (tmp_path / "tmp-a").mkdir()
    (tmp_path / "tmp-b").mkdir()
    out = tmp_path / "mix"
    holder = _held_elsewhere(out, env={**os.environ, "TMPDIR": str(tmp_path / "tmp-a")})
    try:
        monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp-b"))
        monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() reads $TMPDIR again
        assert tempfile.gettempdir() == str(tmp_path / "tmp-b")
        with (
            locks.held_until_the_command_ends(),
            pytest.raises(OutputError, match="in use by another command"),
        ):
            locks.hold_reports_dir(out)
    finally:
        _stop(holder)
    assert not any((tmp_path / "tmp-a").iterdir()) and not any((tmp_path / "tmp-b").iterdir())


def test_another_users_lock_file_is_opened_without_creating_it(tmp_path, monkeypatch):
    # fs.protected_regular refuses O_CREAT on another user's file in a sticky directory
    path = tmp_path / "x.lock"
    path.touch()
    real = os.open

    def protected(name, flags, *mode):
        if flags & os.O_CREAT and not flags & os.O_EXCL:  # (O_EXCL: the file exists, EEXIST)
            raise PermissionError(13, "Permission denied")
        return real(name, flags, *mode)

    monkeypatch.setattr(os, "open", protected)
    path.chmod(0o600)
    fd = locks._open_lock(path)
    try:
        assert os.fstat(fd).st_ino == path.stat().st_ino
        assert path.stat().st_mode & 0o777 == 0o600  # an existing file is never changed
    finally:
        os.close(fd)


def test_a_link_planted_at_the_lock_s_name_is_not_followed(tmp_path):
    # was: the lock file was opened through a symbolic link and made mode 0644, so a link to a
    # private file planted at the (predictable) name in /tmp made that file world-readable
    private = tmp_path / "private"
    private.write_text("secret")
    private.chmod(0o600)
    out = tmp_path / "r"
    path = locks._lock_file(str(out.resolve()))
    path.symlink_to(private)
    try:
        with locks.held_until_the_command_ends():
            locks.hold_reports_dir(out)  # not guarded (as where locks cannot be had), not followed
            assert locks._HELD == {}
        assert private.stat().st_mode & 0o777 == 0o600 and path.is_symlink()
    finally:
        path.unlink()


def test_a_lock_file_released_between_the_two_opens_is_taken_again(tmp_path, monkeypatch):
    # was: the open without O_CREAT found nothing (its holder had just released it), and the
    # command ran unguarded
    path = tmp_path / "x.lock"
    path.touch()
    real = os.open
    calls = []

    def released(name, flags, *mode):
        calls.append(flags)
        if len(calls) == 2:  # the open of the existing file: its holder removed it meanwhile
            os.unlink(name)
        return real(name, flags, *mode)

    monkeypatch.setattr(os, "open", released)
    fd = locks._locked(path)
    try:
        assert fd is not None and len(calls) == 3 and os.fstat(fd).st_ino == path.stat().st_ino
    finally:
        os.close(fd)


def test_the_lock_file_is_removed_when_the_command_ends_and_is_readable_by_all(tmp_path):
    # were: one file left in /tmp per directory ever written (thousands), and a file of mode
    # 0600 under a umask of 077, which another user's command could not open: unguarded
    out = tmp_path / "r"
    path = locks._lock_file(str(out.resolve()))
    old = os.umask(0o077)
    try:
        with locks.held_until_the_command_ends():
            locks.hold_reports_dir(out)
            assert path.stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(old)
    assert not path.exists()


def test_a_lock_file_removed_before_its_lock_is_granted_is_not_the_lock(tmp_path, monkeypatch):
    # a holder removes its file on release: a file opened just before then locks nothing, and
    # two commands could each hold "the" lock, one on the removed file and one on its successor
    path = tmp_path / "x.lock"
    real = locks._open_lock
    opened = []

    def released_meanwhile(p):
        fd = real(p)
        if not opened:
            os.unlink(p)  # its holder released it between our open and our flock
        opened.append(fd)
        return fd

    monkeypatch.setattr(locks, "_open_lock", released_meanwhile)
    fd = locks._locked(path)
    try:
        assert len(opened) == 2 and fd == opened[1]
        assert os.fstat(fd).st_ino == path.stat().st_ino  # the file the path names
    finally:
        os.close(fd)
