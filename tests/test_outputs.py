"""Outputs never destroy inputs or each other, and a failed command leaves no new file behind."""

import os

import numpy as np
import pytest

from replication.cli import main
from replication.errors import OutputError
from replication.io import save_cloud


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def cloud(tmp_path):
    path = tmp_path / "c.csv"
    save_cloud(np.random.default_rng(3).integers(0, 30, (40, 3)).astype(float), path)
    return path


def _aliases(path):
    """Other names of ``path``: ./ prefix, a symbolic link, a hard link, a detour through '..'."""
    d = path.parent
    os.symlink(path.name, d / "link.csv")
    os.link(path, d / "hard.csv")
    return {
        "same": path,
        "dot": d / "." / path.name,
        "detour": d / ".." / d.name / path.name,
        "symlink": d / "link.csv",
        "hardlink": d / "hard.csv",
    }


@pytest.mark.parametrize("alias", ["same", "dot", "detour", "symlink", "hardlink"])
@pytest.mark.parametrize("command", [["adt", "--format", "vtk"], ["nurbs", "--format", "smesh"]])
def test_output_over_the_input_is_refused_before_any_work(capsys, cloud, alias, command):
    before = cloud.read_bytes()
    target = _aliases(cloud)[alias]
    code, out, err = run(capsys, command[0], cloud, *command[1:], "-o", target)
    assert code == 1 and out == ""
    assert "is the same file as INPUT" in err and err.count("\n") == 1, err
    assert cloud.read_bytes() == before


@pytest.mark.parametrize("command", ["adt", "nurbs", "compare"])
def test_save_cloud_over_the_output_is_refused(capsys, tmp_path, command):
    target = tmp_path / "F.csv"
    extra = (
        []
        if command == "compare"
        else ["-o", tmp_path / "./F.csv", "--format", "vtk" if command == "adt" else "smesh"]
    )
    code, _, err = run(capsys, command, "--random", "30", "--seed", "1", "--save-cloud", target, *extra)
    if command == "compare":  # compare writes no other file: --save-cloud alone is fine
        assert code == 0 and target.is_file()
        return
    assert code == 1 and "are the same file" in err and "--save-cloud" in err
    assert not target.exists()


def test_save_cloud_and_output_both_written_when_distinct(capsys, tmp_path):
    code, out, _ = run(capsys, "adt", "--random", "30", "--seed", "1", "--save-cloud", tmp_path / "c.csv",
                       "-o", tmp_path / "s.vtk")  # fmt: skip
    assert code == 0 and (tmp_path / "c.csv").is_file() and (tmp_path / "s.vtk").is_file()
    assert f"wrote the cloud to {tmp_path / 'c.csv'}" in out


def test_a_failed_command_leaves_no_saved_cloud(capsys, tmp_path):
    # a 1 mm lattice in a 1 x 0 x 5 box has 2 distinct (x, y) positions: no surface
    box = ["--box", "0", "1", "0", "0", "0", "5", "--step", "1", "--depth", "z"]
    outputs = ["--save-cloud", tmp_path / "c.csv", "-o", tmp_path / "s.vtk"]
    code, _, err = run(capsys, "adt", "--random", "30", "--seed", "1", *box, *outputs)
    assert code == 1 and err.startswith("replication adt: error:")
    assert sorted(tmp_path.iterdir()) == []


def test_failed_second_write_removes_the_first(capsys, tmp_path, monkeypatch):
    import replication.io

    def broken(*args, **kwargs):
        raise OutputError("disk full")

    monkeypatch.setattr(replication.io, "save_cloud", broken)
    code, _, err = run(capsys, "adt", "--random", "30", "--seed", "1", "--save-cloud", tmp_path / "c.csv",
                       "-o", tmp_path / "s.vtk")  # fmt: skip
    assert code == 1 and "disk full" in err
    assert sorted(tmp_path.iterdir()) == []


def _existing_outputs(tmp_path):
    """-o and --save-cloud files that exist before the command, with their contents."""
    outputs = {tmp_path / "s.vtk": "the old surface\n", tmp_path / "c.csv": "x,y,z\n1,2,3\n"}
    for path, text in outputs.items():
        path.write_text(text)
    return outputs


@pytest.mark.parametrize(
    ("failure", "code", "message"),
    [(OutputError("cannot write c.csv: Permission denied"), 1, "Permission denied"),
     (KeyboardInterrupt(), 130, "interrupted")],
)  # fmt: skip
def test_a_failed_second_write_leaves_existing_outputs_untouched(
    capsys, tmp_path, monkeypatch, failure, code, message
):
    # the surface was replaced, then the cloud failed: "error: cannot write ..." (or "interrupted")
    # with the old surface gone
    import replication.io

    def second_write_fails(*args, **kwargs):
        raise failure

    before = _existing_outputs(tmp_path)
    monkeypatch.setattr(replication.io, "save_cloud", second_write_fails)
    result = run(capsys, "adt", "--random", "30", "--seed", "1", "-o", tmp_path / "s.vtk",
                 "--save-cloud", tmp_path / "c.csv")  # fmt: skip
    assert result[0] == code and message in result[2]
    assert {path: path.read_text() for path in tmp_path.iterdir()} == before  # and no temporary left


@pytest.mark.parametrize("surface_existed", [True, False])
def test_a_failed_move_puts_back_the_outputs_already_moved(capsys, tmp_path, monkeypatch, surface_existed):
    # all or none holds for the moves too: the surface moved into place, then the cloud's move failed
    real_replace = os.replace

    def replace(src, dst):
        if os.path.basename(dst) == "c.csv":  # the cloud's own move (a backup's goes to s.vtk)
            raise OSError(28, "No space left on device")
        real_replace(src, dst)

    before = _existing_outputs(tmp_path)
    if not surface_existed:
        (tmp_path / "s.vtk").unlink()
        del before[tmp_path / "s.vtk"]
    monkeypatch.setattr(os, "replace", replace)
    code, _, err = run(capsys, "adt", "--random", "30", "--seed", "1", "-o", tmp_path / "s.vtk",
                       "--save-cloud", tmp_path / "c.csv")  # fmt: skip
    assert code == 1 and "No space left on device" in err and err.count("\n") == 1, err
    assert {path: path.read_text() for path in tmp_path.iterdir()} == before  # and no temporary left


def test_all_outputs_replaced_together_on_success(capsys, tmp_path):
    _existing_outputs(tmp_path)
    code, _, _ = run(capsys, "adt", "--random", "30", "--seed", "1", "-o", tmp_path / "s.vtk",
                     "--save-cloud", tmp_path / "c.csv")  # fmt: skip
    assert code == 0 and sorted(p.name for p in tmp_path.iterdir()) == ["c.csv", "s.vtk"]  # no backup left
    assert (tmp_path / "s.vtk").read_text().startswith("# vtk DataFile")
    assert (tmp_path / "c.csv").read_text().count("\n") == 31


def test_a_command_that_ignores_sigint_is_not_interrupted_by_it(capsys, tmp_path, monkeypatch):
    """A command started with SIGINT ignored (``replication adt ... &`` from a script, or under
    ``nohup``) keeps ignoring it: the section that holds a Ctrl-C while the outputs are moved
    into place must not turn an ignored SIGINT into an interruption."""
    import signal

    real_replace = os.replace
    sent = []

    def replace(src, dst):
        sent.append(dst)
        os.kill(os.getpid(), signal.SIGINT)  # on every move, and so before, during and after the hold
        real_replace(src, dst)

    _existing_outputs(tmp_path)
    monkeypatch.setattr(os, "replace", replace)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        code, _, err = run(capsys, "adt", "--random", "30", "--seed", "1", "-o", tmp_path / "s.vtk",
                           "--save-cloud", tmp_path / "c.csv")  # fmt: skip
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN  # the command left it ignored
    finally:
        signal.signal(signal.SIGINT, previous)
    assert code == 0 and err == "" and len(sent) >= 2, err
    assert (tmp_path / "s.vtk").read_text().startswith("# vtk DataFile")
    assert (tmp_path / "c.csv").read_text().count("\n") == 31


@pytest.mark.parametrize("signum", ["SIGINT", "SIGTERM"])
def test_a_signal_while_the_outputs_are_moved_says_they_were_written(capsys, tmp_path, monkeypatch, signum):
    """A Ctrl-C held while the files were moved into place was reported as a bare "interrupted",
    so the new files looked unwritten; it now says which files the command had written."""
    import signal

    from replication.sigterm import sigterm_interrupts

    real_replace = os.replace
    sent = []

    def replace(src, dst):
        if not sent:  # the first move: the signal is held until the last one is done
            sent.append(signum)
            os.kill(os.getpid(), getattr(signal, signum))
        real_replace(src, dst)

    _existing_outputs(tmp_path)
    monkeypatch.setattr(os, "replace", replace)
    if signum == "SIGTERM":  # main installs the handler around the command, as the console script
        monkeypatch.setattr("replication.cli.sigterm_interrupts", sigterm_interrupts)
    code, _, err = run(capsys, "adt", "--random", "30", "--seed", "1", "-o", tmp_path / "s.vtk",
                       "--save-cloud", tmp_path / "c.csv")  # fmt: skip
    said = "interrupted" if signum == "SIGINT" else "terminated (SIGTERM)"
    assert (code, sent) == ((130 if signum == "SIGINT" else 143), [signum])
    files = f"{tmp_path / 's.vtk'}, {tmp_path / 'c.csv'}"
    assert err == f"replication adt: {said} after writing 2 files ({files})\n"
    assert (tmp_path / "s.vtk").read_text().startswith("# vtk DataFile")  # the new files, whole
    assert (tmp_path / "c.csv").read_text().count("\n") == 31
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.csv", "s.vtk"]  # no temporary or backup


def test_a_ctrl_c_before_the_moves_names_no_file(tmp_path):
    from replication.io.atomic import all_or_none, atomic_write_text, written_before

    with pytest.raises(KeyboardInterrupt) as caught, all_or_none():
        atomic_write_text(tmp_path / "a.txt", "a")
        raise KeyboardInterrupt
    assert written_before(caught.value) == () and not list(tmp_path.iterdir())


@pytest.mark.skipif(not os.path.isdir("/sys/kernel"), reason="needs sysfs, where no file can be created")
@pytest.mark.parametrize(
    ("command", "option", "name"),
    [("adt", "-o", "s.vtk"), ("adt", "--save-cloud", "c.csv"), ("nurbs", "-o", "s.smesh"),
     ("compare", "--save-cloud", "c.csv")],
)  # fmt: skip
def test_an_unwritable_output_directory_is_refused_before_any_work(
    capsys, monkeypatch, command, option, name
):
    # was found only when written: a 20 s run of 1e6 points, then "cannot write ...: Permission denied"
    # (sysfs refuses new files even to root, whom permission bits do not stop)
    def started(*args, **kwargs):
        raise AssertionError("the work started before the output checks")

    monkeypatch.setattr("replication.cli.surfaces.load_or_generate", started)
    monkeypatch.setattr("replication.cli.compare.load_or_generate", started)
    code, out, err = run(capsys, command, "--random", "30", "--seed", "1", option, f"/sys/kernel/{name}")
    assert code == 1 and out == "" and err.count("\n") == 1, err
    assert f"cannot write /sys/kernel/{name}: the directory /sys/kernel is not writable" in err, err


def test_a_directory_that_takes_no_new_files_is_not_called_unwritable_for_another_reason(capsys, tmp_path):
    """/proc refuses new files with ENOENT: "the directory /proc is not writable: No such file
    or directory" said two things at once."""
    code, out, err = run(capsys, "adt", "--random", "30", "-o", "/proc/x.vtk")
    assert code == 1 and out == "", err
    said = "cannot write /proc/x.vtk: the directory /proc cannot hold new files: No such file or directory"
    assert err == f"replication adt: error: {said}\n"
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "data").symlink_to("/proc")  # a report directory's data directory too
    code, out, err = run(capsys, "table1", "--quick", "--output-dir", tmp_path / "out")
    assert code == 1 and out == "", err
    assert err.endswith(f"{tmp_path / 'out' / 'data'} cannot hold new files: No such file or directory\n"), (
        err
    )


@pytest.mark.parametrize(
    ("command", "option", "name"),
    [("adt", "-o", "s.vtk/"), ("adt", "-o", "s.vtk/."), ("adt", "--save-cloud", "c.csv/"),
     ("nurbs", "-o", "s.smesh/"), ("compare", "--save-cloud", "c.csv/")],
)  # fmt: skip
def test_an_output_name_ending_in_a_slash_is_refused_before_any_work(
    capsys, tmp_path, monkeypatch, command, option, name
):
    # -o out.vtk/ printed "wrote out.vtk/" and replaced the file out.vtk (Path drops the slash)
    def started(*args, **kwargs):
        raise AssertionError("the work started before the output checks")

    monkeypatch.setattr("replication.cli.surfaces.load_or_generate", started)
    monkeypatch.setattr("replication.cli.compare.load_or_generate", started)
    file = tmp_path / name.split("/")[0]
    file.write_text("old\n")
    code, out, err = run(capsys, command, "--random", "30", "--seed", "1", option, f"{tmp_path}/{name}")
    assert code == 1 and out == "" and err.count("\n") == 1, err
    assert f"cannot write {tmp_path}/{name}: {file} is not a directory" in err, err
    assert file.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == [file.name]


def test_the_writers_refuse_a_name_ending_in_a_slash(tmp_path):
    (tmp_path / "c.csv").write_text("old\n")
    with pytest.raises(OutputError, match="c.csv is not a directory"):
        save_cloud(np.zeros((3, 3)), f"{tmp_path}/c.csv/")
    with pytest.raises(OutputError, match=r"new.csv does not exist \(a name ending in '/' names a directory"):
        save_cloud(np.zeros((3, 3)), f"{tmp_path}/new.csv/")  # was: "new.csv is not a directory"
    assert [p.name for p in tmp_path.iterdir()] == ["c.csv"]


@pytest.mark.parametrize(
    ("command", "option"),
    [("adt", "--save-cloud"), ("adt", "-o"), ("nurbs", "--save-cloud"), ("nurbs", "-o"),
     ("compare", "--save-cloud")],
)  # fmt: skip
def test_an_empty_output_name_is_a_misused_option(capsys, tmp_path, monkeypatch, command, option):
    # --save-cloud '' was ignored without a word (the cloud not saved, exit 0)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main([command, "--random", "30", "--seed", "1", option, ""])
    out, err = capsys.readouterr()
    assert exc.value.code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith(f"replication {command}: error: argument {option}"), err
    assert "expected a file name, got ''" in err
    assert list(tmp_path.iterdir()) == []
    from replication.io.atomic import atomic_write_text

    with pytest.raises(OutputError, match="an empty file name"):  # the writers refuse it too
        atomic_write_text("", "x")


@pytest.mark.parametrize(
    ("command", "option"),
    [
        ("report", "--output-dir"), ("report", "--asv-results"), ("report", "--readme"),
        ("table1", "--output-dir"), ("reproduce", "--output-dir"), ("casestudy", "--run-dir"),
        ("casestudy", "--output-dir"), ("casestudy", "--cache-dir"), ("force", "--run-dir"),
        ("sph", "--output-dir"), ("validate-jet", "--output-dir"), ("validate-jet", "--cache-dir"),
    ],
)  # fmt: skip
def test_an_empty_directory_name_is_a_misused_option(capsys, tmp_path, monkeypatch, command, option):
    # report --output-dir '' quietly re-rendered reports/, casestudy --run-dir '' made a new run
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main([command, option, ""])
    out, err = capsys.readouterr()
    assert exc.value.code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith(f"replication {command}: error: argument {option}: expected a "), err
    assert err.split("expected a ", 1)[1].startswith(("directory name, got ''", "file name, got ''"))
    assert list(tmp_path.iterdir()) == []


def test_save_cloud_bad_suffix_refused_before_work(capsys, tmp_path):
    code, _, err = run(capsys, "adt", "--random", "30", "--seed", "1", "--save-cloud", tmp_path / "c.dat")
    assert code == 1 and "--save-cloud" in err and "'.dat'" in err


@pytest.mark.parametrize(
    ("command", "name", "fmt", "said"),
    [
        (
            "adt",
            "s.vtk",
            "vtp",
            "-o {} names a .vtk file (legacy VTK, ASCII), but --format vtp writes VTK XML",
        ),
        ("adt", "s.VTP", "vtk", "names a .vtp file (VTK XML, binary), but --format vtk writes legacy VTK"),
        (
            "nurbs",
            "n.json",
            "smesh",
            "names a .json file (geomdl JSON), but --format smesh writes compact smesh",
        ),
    ],
)
def test_a_format_that_contradicts_the_suffix_is_refused_before_work(
    capsys, tmp_path, command, name, fmt, said
):
    # was: a warning, and a .vtk file of VTK XML that force (and any reader going by the
    # suffix) could not open
    code, _, err = run(
        capsys, command, "--random", "20", "--seed", "1", "-o", tmp_path / name, "--format", fmt
    )
    assert code == 2 and said.format(tmp_path / name) in err and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("name", "fmt", "warned"),
    [("s.csv", "vtp", True), ("s.vtp", "vtp", False), ("s.vtk", None, False)],
)
def test_format_under_another_suffix_warns(capsys, tmp_path, name, fmt, warned):
    extra = ["--format", fmt] if fmt else []
    code, _, err = run(capsys, "adt", "--random", "20", "--seed", "1", "-o", tmp_path / name, *extra)
    assert code == 0
    assert ("programs that go by the suffix will misread it" in err) == warned


def test_a_format_given_for_a_name_without_a_suffix_says_so_in_words(capsys, tmp_path):
    code, _, err = run(
        capsys, "adt", "--random", "20", "--seed", "1", "-o", tmp_path / "surface", "--format", "vtk"
    )
    assert code == 0 and "under a name without a suffix;" in err and ".(no suffix)" not in err


def test_same_file_and_check_distinct(tmp_path):
    from replication.io.paths import check_distinct, same_file

    a = tmp_path / "a.txt"
    a.write_text("x")
    assert same_file(a, tmp_path / "." / "a.txt") and not same_file(a, tmp_path / "b.txt")
    assert same_file(tmp_path / "new.txt", tmp_path / "sub" / ".." / "new.txt")  # neither exists
    check_distinct([("-o", tmp_path / "b.txt")], [("INPUT", a)])
    check_distinct([("-o", None)], [("INPUT", a)])
    with pytest.raises(OutputError, match="-o .* is the same file as INPUT"):
        check_distinct([("-o", a)], [("INPUT", a)])


def test_writable_dir_checks(tmp_path):
    from replication.io.paths import check_writable_dir

    (tmp_path / "file").write_text("x")
    check_writable_dir(tmp_path / "new" / "deeper", "--output-dir")
    assert not (tmp_path / "new").exists()  # checked, not created
    with pytest.raises(OutputError, match="--output-dir .*file is a file, not a directory"):
        check_writable_dir(tmp_path / "file", "--output-dir")
    with pytest.raises(OutputError, match="cannot be created: .*file is a file"):
        check_writable_dir(tmp_path / "file" / "sub", "--output-dir")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]  # no probe file left


@pytest.mark.skipif(os.geteuid() == 0 if hasattr(os, "geteuid") else True, reason="root writes anywhere")
def test_read_only_directory_is_refused(tmp_path):
    from replication.io.paths import check_writable_dir

    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(OutputError, match="is not writable"):
            check_writable_dir(ro / "out", "--output-dir")
    finally:
        ro.chmod(0o755)


@pytest.mark.skipif(not os.path.isdir("/sys/kernel"), reason="needs sysfs, where no file can be created")
def test_unwritable_file_system_is_refused():
    from replication.io.paths import check_writable_dir

    with pytest.raises(
        OutputError, match="/sys/kernel/replication-out is not writable .*would be created in"
    ):
        check_writable_dir("/sys/kernel/replication-out", "--output-dir")


def test_lookup_tells_absent_file_and_directory_and_names_a_refused_path(tmp_path):
    from replication.errors import InputError
    from replication.io.paths import lookup

    (tmp_path / "f").write_text("x")
    cases = [("missing", (False, False, False)), ("f", (True, False, True)), (".", (True, True, False))]
    for name, expected in cases:
        found = lookup(tmp_path / name, InputError, "--x")
        assert (found.exists, found.is_dir, found.is_file) == expected, name
    assert not lookup(tmp_path / "f" / "below", InputError, "--x").exists  # a file as a directory
    assert not lookup("a\0b", InputError, "--x").exists  # as Path.exists() answers
    with pytest.raises(InputError, match=r"^--x /.*\.\.\.a+: File name too long$"):
        lookup(tmp_path / ("a" * 300), InputError, "--x")


def test_a_failed_nested_block_leaves_its_files_out_of_the_outer_one(tmp_path):
    """A nested all_or_none joins the outer one; if it fails and the caller goes on, the files
    it wrote are dropped, not moved into place with the outer block's."""
    from replication.io.atomic import all_or_none, atomic_write_text

    (tmp_path / "b.txt").write_text("old b\n")
    with all_or_none():
        atomic_write_text(tmp_path / "a.txt", "new a\n")
        with pytest.raises(RuntimeError):
            with all_or_none():
                atomic_write_text(tmp_path / "b.txt", "new b\n")
                raise RuntimeError("the inner writer failed")
        assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".")) == ["b.txt"]
    assert (tmp_path / "a.txt").read_text() == "new a\n" and (tmp_path / "b.txt").read_text() == "old b\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]  # no temporary left
