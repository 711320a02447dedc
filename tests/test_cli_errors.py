"""Every way a user can get a command wrong ends in one clear line, never a traceback."""

import json
import os
import shutil
import socket

import numpy as np
import pytest

from replication.cli import main
from replication.errors import ReplicationError
from replication.io import save_cloud

TINY = ["--runs", "1", "--generations", "2", "--population", "6", "--executor", "serial"]


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err, command):
    return err.startswith(f"replication {command}: error: ") and err.count("\n") == 1


@pytest.fixture
def no_experiment(monkeypatch):
    """Fail loudly if a command starts an experiment: its checks must come first."""

    def started(*args, **kwargs):
        raise AssertionError("the experiment started before the output checks")

    monkeypatch.setattr("replication.experiments.table1.run_table1", started)
    monkeypatch.setattr("replication.experiments.casestudy.run_casestudy", started)
    return started


# ---- output and run directories, checked before any experiment ---------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["table1", "--quick", "--output-dir", "{file}"],
        ["reproduce", "--quick", "--output-dir", "{file}"],
        ["casestudy", *TINY, "--output-dir", "{file}", "--run-dir", "{tmp}/run"],
        ["casestudy", *TINY, "--run-dir", "{file}"],
        ["casestudy", *TINY, "--run-dir", "{file}/sub"],
        ["table1", "--output-dir", "{file}/sub"],
        ["casestudy", *TINY, "--rescore", "sph", "--cache-dir", "{file}", "--run-dir", "{tmp}/run"],
        ["validate-jet", "--quick", "--cache-dir", "{file}", "--output-dir", "{tmp}/out"],
    ],
)
def test_output_or_run_dir_that_is_a_file(capsys, tmp_path, monkeypatch, no_experiment, argv):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    argv = [a.format(file=tmp_path / "afile", tmp=tmp_path) for a in argv]
    code, _, err = run(capsys, *argv)
    assert code == 1 and one_line(err, argv[0]), err
    assert "afile" in err and "not a directory" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


COMMANDS_WRITING_REPORTS = [
    ["table1", "--quick"],
    ["reproduce", "--quick"],
    ["casestudy", *TINY, "--run-dir", "{tmp}/run"],
    ["validate-jet", "--quick", "--cache-dir", "{tmp}/cache"],
    ["sph", "--quick"],
    ["report"],
]


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (argv, name)
        for argv in COMMANDS_WRITING_REPORTS
        for name in ("data", "figures")
        if argv != ["report"] or name != "data"
    ]
    + [(["table1", "--quick"], "data/table1_meshes"), (["reproduce", "--quick"], "data/table1_meshes")],
)
def test_a_file_where_the_reports_subdirectory_goes(capsys, tmp_path, monkeypatch, no_experiment, argv, name):
    """A file named data or figures in the output directory: refused before the work, which
    otherwise ended in "unexpected FileExistsError" when the results were saved."""
    monkeypatch.setattr("replication.experiments.jet_validation.run_validation", no_experiment)
    monkeypatch.setattr("replication.experiments.sph.run_sph_study", no_experiment)
    monkeypatch.setattr("replication.casestudy.sph.require_engine", lambda: None)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out" / name).parent.mkdir(parents=True, exist_ok=True)
    (tmp_path / "out" / name).write_text("x")
    before = sorted(tmp_path.rglob("*"))
    argv = [a.format(tmp=tmp_path) for a in argv]
    code, _, err = run(capsys, *argv, "--output-dir", "out")
    assert code == 1 and one_line(err, argv[0]), err
    assert f"--output-dir out: out/{name} is a file, not a directory" in err
    assert sorted(tmp_path.rglob("*")) == before


def test_a_broken_symbolic_link_as_the_output_directory_is_named_once(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "broken").symlink_to(tmp_path / "nowhere")
    code, _, err = run(capsys, "table1", "--quick", "--output-dir", "broken")
    assert (
        code == 1
        and err == "replication table1: error: --output-dir broken: broken is a broken symbolic link\n"
    )


def test_report_reads_data_it_cannot_write(capsys, tmp_path):
    """``report`` only reads data/: a read-only one (a share, another user's) is no reason to
    refuse, as the writability check of the reports directory briefly did."""
    import shutil
    import subprocess
    from pathlib import Path

    out = tmp_path / "out"
    data = Path(__file__).resolve().parents[1] / "reports" / "data"
    (out / "data").mkdir(parents=True)
    for source in data.glob("sph_*"):  # one report's data (the quickest to draw) is enough
        shutil.copy(source, out / "data" / source.name)
    if subprocess.run(["chattr", "+i", str(out / "data")], capture_output=True).returncode != 0:
        pytest.skip("chattr +i is not available here (it makes a directory read-only even for root)")
    try:
        code, _, err = run(capsys, "report", "--output-dir", str(out))
    finally:
        subprocess.run(["chattr", "-i", str(out / "data")], check=True)
    assert code == 0 and err == "", err
    (tmp_path / "file").mkdir()
    (tmp_path / "file" / "data").write_text("x")
    code, _, err = run(capsys, "report", "--output-dir", str(tmp_path / "file"))
    assert code == 1 and one_line(err, "report") and "no report data under" in err, err
    assert f"run `replication reproduce --output-dir {tmp_path / 'file'}` first" in err, err


def test_data_a_report_cannot_draw_name_the_command_that_made_them_into_their_directory(tmp_path):
    """'regenerate them with `replication table1`' dropped the run's settings (--quick) and
    its directory: run as said, it wrote the paper's settings into reports/."""
    import json

    from replication.cli.reports import _again

    (tmp_path / "data").mkdir()
    assert _again("table1", tmp_path) == f"replication table1 --output-dir {tmp_path}"  # no record
    record = {"command": "replication table1 --quick --output-dir elsewhere"}
    (tmp_path / "data" / "table1_provenance.json").write_text(json.dumps(record))
    assert _again("table1", tmp_path) == f"replication table1 --quick --output-dir {tmp_path}"
    (tmp_path / "data" / "jet_validation_provenance.json").write_text("{not json")
    assert _again("validate-jet", tmp_path) == f"replication validate-jet --output-dir {tmp_path}"
    assert _again("reproduce", tmp_path) == f"replication reproduce --output-dir {tmp_path}"


@pytest.mark.parametrize(
    "argv",
    [
        ["validate-jet", "--quick", "--cache-dir", "{bad}", "--output-dir", "out"],
        ["casestudy", *TINY, "--rescore", "sph", "--cache-dir", "{bad}", "--run-dir", "run"],
        ["casestudy", *TINY, "--solver", "sph", "--cache-dir", "{bad}", "--run-dir", "run"],
    ],
)
def test_an_sph_cache_that_is_not_utf8_is_refused(capsys, tmp_path, monkeypatch, no_experiment, argv):
    # was: every simulation recorded in the cache as a crash (the engine's binding takes UTF-8 paths)
    import os

    monkeypatch.setattr("replication.experiments.jet_validation.run_validation", no_experiment)
    monkeypatch.setattr("replication.casestudy.sph.require_engine", lambda: None)
    monkeypatch.chdir(tmp_path)
    argv = [a.format(bad=os.fsdecode(b"cache\xff")) for a in argv]
    code, _, err = run(capsys, *argv)
    assert code == 1 and one_line(err, argv[0]), err
    assert "--cache-dir cache\\udcff: the SPH engine needs a path that is valid UTF-8" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not __import__("os").path.isdir("/sys/kernel"), reason="needs sysfs (refuses new files)")
@pytest.mark.parametrize("command", ["table1", "reproduce", "casestudy"])
def test_unwritable_output_dir_refused_before_the_experiment(
    capsys, tmp_path, monkeypatch, no_experiment, command
):
    monkeypatch.chdir(tmp_path)
    extra = [*TINY, "--run-dir", tmp_path / "run"] if command == "casestudy" else ["--quick"]
    code, _, err = run(capsys, command, *extra, "--output-dir", "/sys/kernel/replication-reports")
    assert code == 1 and one_line(err, command) and "is not writable" in err, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not __import__("os").path.isdir("/sys/kernel"), reason="needs sysfs (refuses new files)")
def test_unwritable_working_directory_for_the_default_run_dir(capsys, monkeypatch, no_experiment):
    monkeypatch.chdir("/sys/kernel")
    code, _, err = run(capsys, "casestudy", *TINY)
    assert code == 1 and "the GA run directory casestudy-runs/run-" in err and "is not writable" in err


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{bad", "malformed JSON"),
        ("[1, 2]", "expected a JSON object"),
        ('{"population": 6}', "missing setting"),
        (b"\xff\xfe", "not UTF-8"),
    ],
)
def test_corrupt_config_json(capsys, tmp_path, no_experiment, content, match):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    config = run_dir / "config.json"
    config.write_bytes(content if isinstance(content, bytes) else content.encode())
    for resume in ([], ["--resume"]):
        code, _, err = run(capsys, "casestudy", *TINY[-2:], "--run-dir", run_dir, *resume)
        assert code == 1 and one_line(err, "casestudy") and str(config) in err and match in err, err


def test_a_run_directory_holding_a_user_s_files_is_refused(capsys, tmp_path, no_experiment):
    """casestudy --run-dir put its checkpoints among a directory's unrelated files (force
    --run-dir refused the same); a directory holding only what a run writes is taken."""
    from replication.casestudy.rundir import foreign_entries

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("mine")
    code, _, err = run(capsys, "casestudy", *TINY, "--run-dir", mine)
    assert code == 1 and one_line(err, "casestudy"), err
    assert f"--run-dir {mine} holds files that are not a GA run's (thesis.tex)" in err
    assert sorted(p.name for p in mine.iterdir()) == ["thesis.tex"]  # nothing written
    ours = tmp_path / "ours"
    (ours / "report").mkdir(parents=True)
    for name in ("config.json", ".lock", "run-0.json", "run-12.json", "fitness.json",
                 ".config.json.h1-42-ab.tmp.json", ".run-3.json.h1-42-cd.tmp.json"):  # fmt: skip
        (ours / name).write_text("")
    assert foreign_entries(ours, own=("fitness.json", "report")) == []
    for name in (".DS_Store", "Thumbs.db", "desktop.ini", ".directory", "._run-0.json"):  # a file browser's
        (ours / name).write_text("")
    assert foreign_entries(ours, own=("fitness.json", "report")) == []
    for name in ("run-x.json", ".notes.tmp.json", "config.json.bak", "run-1.json~"):
        (ours / name).write_text("")
    assert foreign_entries(ours, own=("fitness.json", "report")) == sorted(
        [".notes.tmp.json", "config.json.bak", "run-1.json~", "run-x.json"]
    )
    assert foreign_entries(tmp_path / "absent") == []
    (mine / "thesis.tex").unlink()
    (mine / ".DS_Store").write_text("")  # a directory the user only looked at in the Finder
    code, _, err = run(capsys, "casestudy", *TINY, "--run-dir", mine)
    assert "not a GA run's" not in err and "the experiment started" in err, err  # past the checks


# ---- executors ------------------------------------------------------------------------------------


def _closed_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_fails_fast_in_one_line(capsys, tmp_path, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.chdir(tmp_path)
    address = f"tcp://127.0.0.1:{_closed_port()}"
    code, _, err = run(capsys, "casestudy", *TINY[:6], "--scheduler", address)
    assert code == 1 and f"cannot reach a dask scheduler at {address}" in err
    # was: "GA run directory: ... (after an interruption, resume with: ...)" first, for a
    # directory then removed again
    assert err.count("\n") == 1 and err.startswith("replication casestudy: error:"), err
    assert list(tmp_path.iterdir()) == []


def test_a_tls_scheduler_without_tls_settings_is_named_as_such(capsys, tmp_path, monkeypatch):
    # was: "something answers there but not in dask's protocol", though nothing was contacted
    pytest.importorskip("dask.distributed")
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "casestudy", *TINY[:6], "--scheduler", "tls://127.0.0.1:9")
    last = err.splitlines()[-1]
    assert (
        code == 1
        and last.startswith("replication casestudy: error: cannot connect")
        and "TLS expects" in last
    )
    assert "not in dask's protocol" not in err and "Traceback" not in err


@pytest.mark.parametrize(
    "address", ["notanaddress::", "tcp://host-without-port", "xyz://a:1", "tcp://127.0.0.1:99999"]
)  # the last said "Connection refused"
def test_malformed_scheduler_address_refused_before_work(
    capsys, tmp_path, monkeypatch, no_experiment, address
):
    pytest.importorskip("dask.distributed")
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "casestudy", *TINY[:6], "--scheduler", address)
    assert code == 1 and one_line(err, "casestudy") and "is not a dask scheduler address" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("options", "match"),
    [
        (["--executor", "serial", "--workers", "3"], "does not apply to the serial executor"),
        (["--executor", "serial", "--scheduler", "tcp://127.0.0.1:8786"], "does not use"),
        (["--executor", "process", "--scheduler", "tcp://127.0.0.1:8786"], "does not use"),
        (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "give one of them"),
    ],
)
def test_executor_options_that_would_be_ignored(capsys, tmp_path, monkeypatch, no_experiment, options, match):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "casestudy", *TINY[:6], *options)
    assert code == 2 and one_line(err, "casestudy") and match in err  # a misused command line


# ---- report -------------------------------------------------------------------------------------


@pytest.fixture
def report_copy(quick_reports, tmp_path):
    """A copy of the quick run's case-study data (rendering it fails before any figure)."""
    out = tmp_path / "rep"
    shutil.copytree(quick_reports / "data", out / "data", ignore=shutil.ignore_patterns("table1*"))
    return out


def _only(out, experiment):
    for path in (out / "data").glob("*"):
        if path.is_file() and not path.name.startswith(experiment):
            path.unlink()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("casestudy_runs.csv", 'garbage"\n\x00\x01,"\n1,2,3\n', "casestudy_runs.csv"),
        ("casestudy_runs.csv", "", "not a readable CSV table"),
        ("casestudy_runs.csv", "run,best_N\n0,1.0\n", "missing column(s) seed"),
        ("casestudy_provenance.json", "{bad", "malformed JSON"),
        ("casestudy_provenance.json", "{}", "casestudy data under"),
        ("table1_provenance.json", "[1]", "expected a JSON object"),
        ("table1_montecarlo.csv", "n,quantity\n9,x\n", "table1_montecarlo.csv: no rows for n = "),
    ],
)
def test_report_with_corrupt_data(capsys, quick_reports, tmp_path, name, content, match):
    report_copy = tmp_path / "rep"
    experiment = name.split("_")[0]
    shutil.copytree(quick_reports / "data", report_copy / "data", ignore=shutil.ignore_patterns("*meshes*"))
    _only(report_copy, experiment)
    for provenance in (report_copy / "data").glob("*_provenance.json"):  # (the meshes left out, and the
        record = json.loads(provenance.read_text())  # damage on purpose: each file's own checks speak)
        record.pop("data_files", None)
        provenance.write_text(json.dumps(record))
    (report_copy / "data" / name).write_text(content)
    code, _, err = run(capsys, "report", "--output-dir", report_copy)
    assert code == 1 and one_line(err, "report") and match in err, err


@pytest.mark.slow
def test_report_readme_problems(capsys, report_copy, tmp_path):
    (tmp_path / "plain.md").write_text("no markers\n")
    (tmp_path / "swapped.md").write_text(
        "<!-- headline:end -->\n<!-- headline:start -->\n"
    )  # was: IndexError
    cases = [
        (tmp_path / "missing.md", "no such file"),
        (tmp_path, "is a directory"),
        (tmp_path / "plain.md", "no <!-- headline:start -->"),
        (tmp_path / "swapped.md", "marker comes before"),
    ]
    for readme, match in cases:
        code, _, err = run(capsys, "report", "--output-dir", report_copy, "--readme", readme)
        assert code == 1 and one_line(err, "report") and match in err, err
    index = report_copy / "index.md"
    index.write_text("<!-- headline:start -->\n<!-- headline:end -->\n")
    code, _, err = run(capsys, "report", "--output-dir", report_copy, "--readme", index)
    assert code == 1 and one_line(err, "report") and "--readme" in err and "are the same file" in err, err


def test_report_with_other_settings_leaves_the_committed_page(capsys, tmp_path, monkeypatch):
    """`report --performance --commits 1` redrew the committed reports/performance.md (and the
    README's speed block) with one commit: another setting needs a directory named for it."""
    reports = tmp_path / "reports"
    (reports / "data").mkdir(parents=True)
    (reports / "performance.md").write_text("committed\n")
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "report", "--performance", "--commits", "1")
    assert code == 2 and one_line(err, "report") and "--commits 1" in err and "--output-dir" in err, err
    code, _, err = run(capsys, "report", "--commits", "3")
    assert code == 2 and one_line(err, "report") and "add --performance" in err, err
    assert (reports / "performance.md").read_text() == "committed\n"
    assert sorted(p.name for p in reports.rglob("*")) == ["data", "performance.md"]
    code, out, err = run(capsys, "report", "--performance", "--commits", "1", "--output-dir", reports)
    assert "--commits" not in err  # named on purpose: allowed (here it fails later, for want of data)


def test_report_without_a_reports_directory(capsys, tmp_path, monkeypatch):
    code, _, err = run(capsys, "report", "--output-dir", tmp_path / "none")
    assert code == 1 and one_line(err, "report") and "does not exist" in err
    # the run it asks for makes that directory (it named the default reports/)
    assert f"run `replication reproduce --output-dir {tmp_path / 'none'}` first" in err, err
    # with other settings too: it spoke of "the committed reports/performance.md, which shows 5
    # commits" where there is none
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "report", "--performance", "--commits", "10")
    assert code == 1 and one_line(err, "report") and "reports directory reports does not exist" in err, err
    assert "run `replication reproduce` first" in err, err  # the default directory: the plain command


def test_report_into_a_directory_where_no_file_can_be_created(capsys, tmp_path, monkeypatch):
    # was: "unexpected PermissionError" from the first figure written, after rendering began
    # (root ignores permission bits, so the refusal of the probe file is simulated)
    import replication.io.paths as paths

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(paths.tempfile, "TemporaryFile", refuse)
    (tmp_path / "data").mkdir()
    code, _, err = run(capsys, "report", "--output-dir", tmp_path)
    assert code == 1 and one_line(err, "report") and "is not writable: Permission denied" in err, err
    assert [p.name for p in tmp_path.iterdir()] == ["data"]


# ---- surfaces -------------------------------------------------------------------------------------


def test_tessellation_that_cannot_fit_in_memory(capsys):
    code, _, err = run(capsys, "nurbs", "--random", "20", "--seed", "1", "--tessellation", "100000x100000")
    assert code == 1 and one_line(err, "nurbs")
    assert "needs about 4.09 TiB of memory" in err and "10,000,000,000 samples" in err


def test_compare_samples_that_cannot_fit_in_memory(capsys):
    # was: "unexpected MemoryError: Unable to allocate 74.5 GiB" after building both surfaces
    code, _, err = run(capsys, "compare", "--random", "20", "--seed", "1", "--samples", "100000x100000")
    assert code == 1 and one_line(err, "compare"), err
    assert "--samples 100000x100000 needs about 1.46 TiB of memory" in err and "choose fewer samples" in err


def test_a_random_cloud_that_cannot_fit_in_memory_is_refused_before_it_is_drawn(
    capsys, tmp_path, monkeypatch
):
    # was: "unexpected MemoryError" at 1e11 points, and the kernel's OOM killer at 1e9
    def drawn(*args, **kwargs):
        raise AssertionError("the cloud was drawn before the memory check")

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("replication.surfaces.random_cloud", drawn)
    code, _, err = run(capsys, "adt", "--random", "100000000000", "--seed", "1")
    assert code == 1 and one_line(err, "adt") and "unexpected" not in err, err
    assert "--random 100000000000 needs about 11.6 TiB of memory" in err and "choose fewer points" in err
    monkeypatch.setattr("replication.cli.resources.available_memory", lambda: 2**30)  # 1 GiB free
    for argv, need in (
        (["adt", "--random", "10000000"], "1.19 GiB"),
        (["adt", "--random", "2000000", "-o", "out.vtk"], "1.73 GiB"),
        (["nurbs", "--random", "2000000"], "1.86 GiB"),
        (["compare", "--random", "1000000"], "1.58 GiB"),
    ):
        code, _, err = run(capsys, *argv)
        assert code == 1 and one_line(err, argv[0]) and f"needs about {need} of memory" in err, err
        assert "1 GiB is available" in err
    # 4 million points need about 0.5 GiB beyond what the process holds: the check lets them be
    # drawn (the estimate was the peak over the point count, 1.12 GiB, which refused runs that fit)
    code, _, err = run(capsys, "adt", "--random", "4000000")
    assert "the cloud was drawn before the memory check" in err, err


@pytest.mark.parametrize("version", ["v1", "v2"])
def test_a_containers_memory_limit_counts_as_what_is_available(tmp_path, monkeypatch, version):
    # MemAvailable is the machine's: inside a container with a lower limit a command the
    # machine could hold was killed by the container's limit, after the check had passed
    from replication.cli import resources

    if version == "v2":
        membership, group = "0::/job/7\n", tmp_path / "job" / "7"
        files = {"memory.max": "1073741824\n", "memory.current": "268435456\n"}
    else:
        membership, group = "5:cpu:/\n4:memory:/job/7\n", tmp_path / "memory" / "job" / "7"
        files = {"memory.limit_in_bytes": "1073741824\n", "memory.usage_in_bytes": "268435456\n"}
    group.mkdir(parents=True)
    for name, text in files.items():
        (group / name).write_text(text)
    (tmp_path / "cgroup").write_text(membership)
    assert resources.cgroup_headroom(tmp_path, tmp_path / "cgroup") == 3 * 2**28  # 1 GiB less 256 MiB
    # no limit ("max", or v1's huge number), or no readable group: no headroom of its own
    (group / next(iter(files))).write_text("max\n" if version == "v2" else f"{2**63 - 4096}\n")
    assert resources.cgroup_headroom(tmp_path, tmp_path / "cgroup") is None
    assert resources.cgroup_headroom(tmp_path, tmp_path / "missing") is None
    monkeypatch.setattr(resources, "cgroup_headroom", lambda: 2**28)
    monkeypatch.setattr(resources, "_mem_available", lambda: 2**34)
    assert resources.available_memory() == 2**28  # the smaller of the two
    monkeypatch.setattr(resources, "cgroup_headroom", lambda: None)
    assert resources.available_memory() == 2**34


def test_margin_and_alpha_must_be_finite(capsys):
    for option, value in (
        ("--margin", "inf"), ("--margin", "nan"), ("--margin", "-0.1"), ("--alpha", "1.5"), ("--alpha", "0.5")
    ):  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            main(["compare", "--random", "30", "--seed", "1", option, value])
        assert exc.value.code == 2 and "expected" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["compare", "--random", "30", "--seed", "1", "--alpha", "0.6"])
    assert "expected a significance level strictly between 0 and 0.5" in capsys.readouterr().err


def test_malformed_vtk_files_give_one_line_and_no_vtk_log(capfd, tmp_path):
    bad_vtk = tmp_path / "bad.vtk"
    bad_vtk.write_text(
        "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 0 0\n1 0\n"
    )
    bad_vtp = tmp_path / "bad.vtp"
    bad_vtp.write_text('<VTKFile type="PolyData"><PolyData><Piece NumberOfPoints="3">')
    for path in (bad_vtk, bad_vtp):
        assert main(["force", str(path)]) == 1
        out, err = capfd.readouterr()  # file descriptors: VTK writes to fd 2 directly
        assert one_line(err, "force") and "not a readable VTK surface" in err, err


def test_a_vtk_file_that_is_not_utf8_text_gives_one_line(capfd, tmp_path):
    # was: "replication force: error: unexpected TypeError: a bytes-like object is required, not 'str'"
    (tmp_path / "bad1.vtk").write_bytes(b"\xff\xfe not vtk\n")
    assert main(["force", str(tmp_path / "bad1.vtk")]) == 1
    out, err = capfd.readouterr()
    assert (
        one_line(err, "force") and r"not a readable VTK surface (VTK: Unrecognized file type: \xff\xfe" in err
    )


def test_jet_that_misses_prints_zero_not_minus_zero(capsys, tmp_path):
    save_cloud(np.random.default_rng(0).integers(0, 13, (40, 3)).astype(float), tmp_path / "c.csv")
    code, out, err = run(capsys, "force", tmp_path / "c.csv", "--center", "500", "0", "--no-domain")
    numbers = out.split("\n", 1)[1]  # the first line echoes the path, which may hold "-0" (pytest-0)
    assert code == 0 and "axial force 0 N = 0.000 rho Q V" in numbers and "-0" not in numbers
    assert "warning: the jet misses the surface" in err
    code, out, _ = run(capsys, "force", tmp_path / "c.csv", "--center", "500", "0", "--no-domain", "--json")
    assert json.loads(out)["axial_force_N"] == 0 and "-0.0" not in out.split('"axial_force_N"')[1][:8]


def test_a_jet_that_partly_misses_the_surface_says_how_much(capsys, tmp_path):
    # was: silence, "4.408 N" for the full jet on a mesh in y >= 0 that half the jet passed by
    # (the --full-jet example of `force --help`, on the mesh the help says how to make)
    from replication.casestudy.shapes import pelton_bucket_cloud

    save_cloud(pelton_bucket_cloud(), tmp_path / "bucket.csv")
    code, out, err = run(capsys, "force", tmp_path / "bucket.csv")  # the half jet strikes it whole
    assert code == 0 and "0.5522 kg/s, 0.5522 kg/s on the surface" in out and err == ""
    code, out, err = run(capsys, "force", tmp_path / "bucket.csv", "--full-jet", "--center", "18", "0")
    assert code == 0 and "1.104 kg/s, 0.5522 kg/s on the surface" in out and err.count("\n") == 1
    assert err.startswith(
        "warning: 50.0 % of the jet's mass flow (0.5522 of 1.104 kg/s, 101 of 202 streamlets"
    )
    assert (
        "the surface lies in y >= 0 only, and half the jet (its part in y < 0) passes it by (without" in err
    )
    save_cloud(pelton_bucket_cloud() * [1.0, -1.0, 1.0], tmp_path / "mirrored.csv")
    code, out, err = run(capsys, "force", tmp_path / "mirrored.csv", "--full-jet", "--center", "18", "0")
    assert code == 0 and "the surface lies in y <= 0 only, and half the jet (its part in y > 0)" in err
    assert "takes a surface in y >= 0: mirror it" in err
    # off the centre line, reaching across y = 0: the part in y < 0, and no advice to drop --full-jet
    code, out, err = run(capsys, "force", tmp_path / "bucket.csv", "--full-jet", "--center", "18", "5")
    assert code == 0 and err.rstrip().endswith("the part of the jet in y < 0 passes it by")
    # missing off an edge the jet does not reach across y = 0: no word of y = 0
    code, out, err = run(capsys, "force", tmp_path / "bucket.csv", "--full-jet", "--center", "36", "15")
    assert code == 0 and err.rstrip().endswith("check --center and where the surface lies")
    code, out, err = run(capsys, "force", tmp_path / "bucket.csv", "--center", "30", "0")
    missed = json.loads(run(capsys, "force", tmp_path / "bucket.csv", "--center", "30", "0", "--json")[1])
    share = 1 - missed["mass_flow_hit_kg_s"] / missed["mass_flow_total_kg_s"]
    assert 0 < share < 0.5 and err.startswith(f"warning: {100 * share:.1f} % of the jet's mass flow")
    assert err.rstrip().endswith("check --center and where the surface lies") and err.count("\n") == 1
    code, _, err = run(capsys, "force", tmp_path / "bucket.csv", "--center", "30", "0", "--json")
    assert code == 0 and "misses the surface" in err  # on stderr whatever the output format


def test_the_share_of_a_partly_missed_jet_never_rounds_to_none_or_all_of_it():
    # was: "1e+02 %" for 201 of 202 streamlets missing (:.2g), "5e-05 %" for a sliver
    from types import SimpleNamespace

    from replication.casestudy import JetConfig
    from replication.cli.jet_misses import partly_missed

    points, triangles = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 2.0, 0.0]]), np.array([[0, 1, 2]])
    config = JetConfig(full_jet=True, center=(0.018, 0.05))
    for hit, shown in ((1e-9, "> 99.9"), (0.004, "99.6"), (0.5, "50.0"), (0.9996, "< 0.1")):
        result = SimpleNamespace(
            mass_flow_total=1.0, mass_flow_hit=hit, n_streamlets=10_000, n_streamlets_hit=5
        )
        assert partly_missed(result, config, points, triangles).startswith(f"warning: {shown} % of the jet's")
    for n_hit in (0, 10_000):  # none strikes (said otherwise) or all do: no warning
        result = SimpleNamespace(
            mass_flow_total=1.0, mass_flow_hit=0.5, n_streamlets=10_000, n_streamlets_hit=n_hit
        )
        assert partly_missed(result, config, points, triangles) is None


def test_a_jet_coarser_than_the_surface_says_so_not_that_it_misses(capsys, tmp_path):
    # was: "the jet misses the surface ... (check --center ...)" for a 1000 mm jet over the whole surface
    save_cloud(np.random.default_rng(1).random((101, 3)) * [36, 30, 13], tmp_path / "c.csv")
    code, out, err = run(capsys, "force", tmp_path / "c.csv", "--diameter", "1000")
    assert code == 0 and "axial force 0 N" in out and "misses" not in err and "--center" not in err
    assert err.startswith("warning: the surface lies under the jet, but none of the jet's 101 streamlets")
    assert "rings 62.5 mm wide" in err and "resolution 16 is the first to put streamlets on it" in err
    assert err.count("\n") == 1


def test_random_bytes_npy_never_advises_pickle(capsys, tmp_path):
    (tmp_path / "r.npy").write_bytes(np.random.default_rng(0).bytes(300))
    np.save(tmp_path / "o.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    for name, match in (("r.npy", "not a .npy array file"), ("o.npy", "holds Python objects")):
        code, _, err = run(capsys, "adt", tmp_path / name)
        assert code == 1 and one_line(err, "adt") and match in err
        assert "allow_pickle" not in err and "pickle.load" not in err


def test_npy_cut_short_or_not_coordinates_is_one_line(capsys, tmp_path):
    import io

    buf = io.BytesIO()  # a header claiming 10**11 points, and no data: was "unexpected MemoryError"
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10**11, 3)})
    (tmp_path / "bighdr.npy").write_bytes(buf.getvalue())
    np.save(tmp_path / "bool.npy", np.ones((5, 3), dtype=bool))
    np.save(tmp_path / "date.npy", np.zeros((5, 3), dtype="M8[s]"))
    for name, match in (
        ("bighdr.npy", "truncated or damaged"),
        ("bool.npy", "got booleans (dtype bool)"),
        ("date.npy", "got dates and times (dtype datetime64[s])"),
    ):
        code, _, err = run(capsys, "adt", tmp_path / name)
        words = err.replace(str(tmp_path), "TMP")  # the echoed path is the machine's, not the message
        assert code == 1 and one_line(err, "adt") and match in err and "unexpected" not in words, err


def test_underflowing_coordinates_are_named(capsys, tmp_path):
    """Tiny clouds are scaled exactly and triangulate; a projection axis whose extent is tiny
    next to the coordinates underflows and is named as such (not as collinear)."""
    rng = np.random.default_rng(0)
    for scale in (1e-300, 1e-150):
        np.save(tmp_path / "tiny.npy", rng.random((20, 3)) * scale)
        assert run(capsys, "adt", tmp_path / "tiny.npy")[0] == 0
    thin = np.column_stack([rng.random(20) * 1e-320, rng.random(20), rng.random(20)])
    np.save(tmp_path / "thin.npy", thin)
    code, _, err = run(capsys, "adt", tmp_path / "thin.npy", "--depth", "z")
    assert code == 1 and one_line(err, "adt") and "coordinates underflow" in err and "collinear" not in err
    assert "next to the largest coordinate" in err
    subnormal = np.array(
        [[0.0, 0.0, 1.0], [1e-310, 1e-310, 2.0], [2e-310, 2e-310, 3.0]]
    )  # was: OverflowError
    np.save(tmp_path / "subnormal.npy", subnormal)
    code, _, err = run(capsys, "adt", tmp_path / "subnormal.npy", "--depth", "z")
    assert code == 1 and one_line(err, "adt") and "collinear" in err and "unexpected" not in err
    # a square's corner beside a subnormal x: was "all 5 distinct projected points are collinear"
    square = np.array([[0, 0, 1.0], [1, 0, 0], [0, 1, 0], [5e-324, 0, 3], [1, 1, 0]])
    np.save(tmp_path / "square.npy", square)
    code, _, err = run(capsys, "adt", tmp_path / "square.npy", "--depth", "z")
    assert code == 1 and one_line(err, "adt") and "collinear" not in err.split("square.npy: ", 1)[-1]
    assert "the coordinates underflow: x = 4.94e-324 of point 3 (counted from 0) is below 1.49e-154" in err
    np.save(tmp_path / "line.npy", np.column_stack([np.arange(4.0), np.zeros(4), np.ones(4)]))
    code, _, err = run(capsys, "adt", tmp_path / "line.npy", "--depth", "z")
    said = err.split("line.npy: ", 1)[-1]  # (the file's path holds this test's name)
    assert code == 1 and one_line(err, "adt") and "collinear" in said and "underflow" not in said


def test_an_ambiguous_first_line_0_1_2_is_one_line(capsys, tmp_path):
    (tmp_path / "floats.csv").write_text("0,1,2\n1.5,2,3\n4,5.25,6\n7,8,1.5\n")
    for command in ("adt", "compare"):
        code, _, err = run(capsys, command, tmp_path / "floats.csv")
        assert code == 1 and one_line(err, command) and "either pandas' header" in err, err


def test_build_seconds_excludes_loading_the_kernels(capsys, monkeypatch):
    import replication.cli.surfaces as cli_surfaces
    import replication.surfaces

    events = []
    real_adt = replication.surfaces.adt

    class Clock:
        now = 100.0

        def perf_counter(self):
            events.append("clock")
            self.now += 0.25
            return self.now

    def warm(kind, args):
        events.append("warm")
        return 0.5

    def adt(*args, **kwargs):
        events.append("adt")
        return real_adt(*args, **kwargs)

    monkeypatch.setattr(cli_surfaces, "time", Clock())
    monkeypatch.setattr(cli_surfaces, "warm_up", warm)
    monkeypatch.setattr(replication.surfaces, "adt", adt)
    code, out, _ = run(capsys, "adt", "--random", "50", "--seed", "1", "--json")
    report = json.loads(out)
    assert code == 0 and events == ["warm", "clock", "adt", "clock"]
    assert report["build_seconds"] == 0.25 and report["startup_seconds"] == 0.5


# ---- file names the system refuses ---------------------------------------------------------------

LONG = "a" * 300  # longer than any file system's 255-byte limit on one name: ENAMETOOLONG


@pytest.mark.parametrize(
    "argv, match",
    [
        (["adt", "--random", "50", "--seed", "1", "-o", f"{LONG}.vtk"], "cannot write"),
        (["adt", f"{LONG}.csv"], "cannot read the point-cloud file"),
        (["adt", "--random", "50", "--save-cloud", f"{LONG}.csv"], "cannot write"),
        (["nurbs", "--random", "50", "-o", f"{LONG}.json"], "cannot write"),
        (["compare", f"{LONG}.npy"], "cannot read the point-cloud file"),
        (["force", f"{LONG}.vtk"], "cannot read the surface file"),
        (["report", "--output-dir", LONG], "reports directory"),
        (["table1", "--quick", "--output-dir", LONG], "--output-dir"),
        (["sph", "--quick", "--output-dir", LONG], "--output-dir"),
        (["casestudy", "--quick", "--run-dir", LONG], "--run-dir"),
        (["casestudy", *TINY, "--output-dir", LONG, "--run-dir", "run"], "--output-dir"),
    ],
)
def test_a_file_name_too_long_is_one_line_naming_it(
    capsys, tmp_path, monkeypatch, no_experiment, argv, match
):
    # was: "unexpected OSError: [Errno 36] File name too long: 'aaaa...' (run with --debug ...)"
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 1 and one_line(err, argv[0]), err
    assert match in err and "File name too long" in err and f"{'a' * 40}...{'a' * 10}" in err, err
    assert "unexpected" not in err and "--debug" not in err and len(err) < 200, err


def test_system_refusals_are_one_line_without_the_debug_hint(capsys, monkeypatch):
    import errno

    def refuse(exc):
        def command(args):
            raise exc

        monkeypatch.setattr("replication.cli.surfaces._cmd_adt", command)

    refuse(OSError(errno.EACCES, "Permission denied", "/some/file.vtk"))
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and err == "replication adt: error: /some/file.vtk: Permission denied\n", err
    refuse(MemoryError("Unable to allocate 74.5 GiB for an array with shape (10000000000,)"))
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and one_line(err, "adt"), err
    assert "error: not enough memory: Unable to allocate 74.5 GiB" in err and "unexpected" not in err
    assert "--debug" in err  # every MemoryError that reached here so far was a missing input check
    refuse(OSError("no file named"))  # an OSError without a file name: still unexpected
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and "unexpected OSError: no file named" in err and "--debug" in err
    # a file that exists where the code wanted to create one is a bug's symptom, not the system's answer
    refuse(FileExistsError(errno.EEXIST, "File exists", "out/data"))
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and "unexpected FileExistsError" in err and "--debug" in err
    refuse(OSError(errno.EBADF, "Bad file descriptor", 987654))  # a descriptor, not a name: no crash
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and one_line(err, "adt") and "987654" in err
    refuse(OSError(errno.EACCES, "Permission denied", 987654))
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and err == "replication adt: error: 987654: Permission denied\n", err
    for exc in (MemoryError("out"), OSError(errno.ENAMETOOLONG, "File name too long", LONG)):
        refuse(exc)
        with pytest.raises(type(exc)):
            main(["adt", "--random", "5", "--debug"])


# ---- the catch-all ------------------------------------------------------------------------------


def test_unexpected_errors_are_one_line_with_a_debug_hint(capsys, monkeypatch):
    def boom(args):
        raise RuntimeError("something nobody foresaw\nover two lines")

    monkeypatch.setattr("replication.cli.surfaces._cmd_adt", boom)
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 1 and one_line(err, "adt")
    assert "unexpected RuntimeError: something nobody foresaw over two lines" in err
    assert "run with --debug for the traceback" in err
    for argv in (["--debug", "adt", "--random", "5"], ["adt", "--random", "5", "--debug"]):
        with pytest.raises(RuntimeError, match="nobody foresaw"):
            main(argv)


def test_interrupt_inside_compiled_code_exits_130(capsys, monkeypatch):
    def interrupted(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("<function trace> returned a result with an exception set") from exc

    monkeypatch.setattr("replication.cli.surfaces._cmd_adt", interrupted)
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 130 and err == "replication adt: interrupted\n"


def _reported_by_python(exc: BaseException) -> None:
    """Raise ``exc`` in a ctypes callback, where Python only reports it (as in LLVM's
    object-cache callback during numba's compile) and the caller goes on."""
    import ctypes

    def callback():
        raise exc

    ctypes.CFUNCTYPE(None)(callback)()


@pytest.mark.parametrize("failure", [RuntimeError, ReplicationError])
def test_a_ctrl_c_that_python_could_only_report_ends_the_command_as_interrupted(capsys, monkeypatch, failure):
    """Ctrl-C during a cold compile of numba's kernels raised inside LLVM's object-cache
    callback: Python printed "Exception ignored on calling ctypes callback function" with a
    traceback, the compile went on, and numba's cache save then failed, so the command ended
    in "unexpected RuntimeError: no compiled object yet". The failure after a lost Ctrl-C
    is the interrupt: one line, exit 130."""

    def cut_short(args):
        _reported_by_python(KeyboardInterrupt())
        raise failure("no compiled object yet for <Library 'f' at 0x7f>")

    monkeypatch.setattr("replication.cli.surfaces._cmd_adt", cut_short)
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 130 and err == "replication adt: interrupted\n"


def test_a_lost_ctrl_c_leaves_a_finished_command_alone_and_other_reports_to_python(capsys, monkeypatch):
    """A command that finishes after a lost Ctrl-C did its work (exit 0, nothing said); an
    exception other than an interrupt that Python can only report still reaches the hook in
    place, which the command puts back when it ends."""
    import sys

    reported = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)
    real = __import__("replication.cli.surfaces", fromlist=["_cmd_adt"])._cmd_adt

    def finishes(args):
        _reported_by_python(KeyboardInterrupt())
        _reported_by_python(ValueError("a finalizer's own bug"))
        return real(args)

    monkeypatch.setattr("replication.cli.surfaces._cmd_adt", finishes)
    code, out, err = run(capsys, "adt", "--random", "20", "--seed", "1", "--json")
    assert code == 0 and err == "" and json.loads(out)["vertices"] == 20
    assert [type(r.exc_value) for r in reported] == [ValueError]
    assert sys.unraisablehook == reported.append


def test_an_object_an_interrupt_cut_short_says_nothing_as_it_is_freed(capsys, monkeypatch):
    """Ctrl-C while llvmlite built an object left it without its handle: freed after
    "replication adt: interrupted", its finalizer printed "Exception ignored in ObjectRef.__del__"
    and an AttributeError traceback. Before the interrupt, such reports still reach Python."""
    import sys

    reported = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)

    class HalfBuilt:
        def __init__(self, interrupt):
            if interrupt:
                raise KeyboardInterrupt  # (the object lives on in the traceback's frame)

        def __del__(self):
            raise AttributeError("'PassBuilder' object has no attribute '_as_parameter_'")

    def interrupted(args):
        HalfBuilt(interrupt=False)  # freed before any interrupt: reported as ever
        HalfBuilt(interrupt=True)

    monkeypatch.setattr("replication.cli.surfaces._cmd_adt", interrupted)
    code, _, err = run(capsys, "adt", "--random", "5")
    assert code == 130 and err == "replication adt: interrupted\n"
    assert [type(r.exc_value) for r in reported] == [AttributeError] and sys.unraisablehook == reported.append


def test_a_sigterm_lost_in_a_callback_ends_the_command_as_terminated_without_a_traceback(
    capsys, monkeypatch, tmp_path
):
    """SIGTERM's own raise, lost in a callback, printed Python's "Exception ignored" traceback;
    the command still ends as terminated (143) when its block ends (replication.sigterm)."""
    import signal

    real = __import__("replication.cli.surfaces", fromlist=["_cmd_adt"])._cmd_adt

    def terminated_in_a_callback(args):
        import ctypes

        ctypes.CFUNCTYPE(None)(lambda: os.kill(os.getpid(), signal.SIGTERM))()
        return real(args)

    monkeypatch.setattr("replication.cli.surfaces._cmd_adt", terminated_in_a_callback)
    code, _, err = run(capsys, "adt", "--random", "20", "--seed", "1", "-o", tmp_path / "s.vtk")
    assert code == 143 and err == "replication adt: terminated (SIGTERM)\n"


def test_a_closed_pipe_ends_the_command_quietly(capsys, monkeypatch):
    """``replication adt ... --json | head -c 100`` ended in 'unexpected BrokenPipeError'."""
    import io
    import sys

    class Closed(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    assert main(["adt", "--random", "20", "--seed", "1", "--json"]) == 141
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("fails", ["write", "flush"])
def test_a_full_standard_output_is_one_line_that_says_so(capsys, monkeypatch, tmp_path, fails):
    """``replication adt ... > /dev/full`` said "unexpected OSError: [Errno 28] No space left on
    device", as if the surface file had failed; a block-buffered stdout failed only at exit."""
    import errno
    import io
    import sys

    class Full(io.StringIO):
        def write(self, text):
            if fails == "write":
                raise OSError(errno.ENOSPC, "No space left on device")
            return len(text)

        def flush(self):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(sys, "stdout", Full())
    assert main(["adt", "--random", "20", "--seed", "1", "-o", str(tmp_path / "s.vtk")]) == 1
    err = capsys.readouterr().err
    assert one_line(err, "adt") and "unexpected" not in err and "--debug" not in err, err
    assert "cannot write the standard output: No space left on device" in err, err
    assert (tmp_path / "s.vtk").read_text().startswith("# vtk DataFile")  # the file itself is complete


@pytest.mark.skipif(not __import__("os").path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("buffered", [True, False])
def test_standard_output_on_a_full_device(tmp_path, buffered):
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if not buffered:
        env["PYTHONUNBUFFERED"] = "1"
    command = [sys.executable, "-m", "replication", "adt", "--random", "20", "--seed", "1", "-o", "s.vtk"]
    with open("/dev/full", "w") as full:
        done = subprocess.run(command, stdout=full, stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env)
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith("replication adt: error: cannot write the standard output: No space left")
    assert done.stderr.count("\n") == 1, done.stderr  # no "Exception ignored" at exit
    assert (tmp_path / "s.vtk").read_text().startswith("# vtk DataFile")


@pytest.mark.skipif(not __import__("os").path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("args", [["--help"], ["adt", "--help"], ["--version"]])
def test_help_and_version_on_a_full_device_say_so(args):
    """``--help > /dev/full`` exited 0 with nothing written; ``--version`` printed a traceback."""
    import subprocess
    import sys

    with open("/dev/full", "w") as full:
        command = [sys.executable, "-m", "replication", *args]
        done = subprocess.run(command, stdout=full, stderr=subprocess.PIPE, text=True)
    name = "replication adt" if args[0] == "adt" else "replication"
    assert done.returncode == 1
    assert done.stderr == f"{name}: error: cannot write the standard output: No space left on device\n"


@pytest.mark.parametrize("buffered", [True, False])
@pytest.mark.parametrize("args", [["--help"], ["table1", "--help"], ["--version"]])
def test_help_and_version_into_a_closed_pipe_end_quietly(args, buffered):
    """``replication --version | true``: was a BrokenPipeError traceback (exit 0 when buffered)."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if not buffered:
        env["PYTHONUNBUFFERED"] = "1"
    reader = subprocess.Popen([sys.executable, "-c", "pass"], stdin=subprocess.PIPE)
    reader.wait()  # gone before anything is written: the pipe has no reader
    command = [sys.executable, "-m", "replication", *args]
    done = subprocess.run(command, stdout=reader.stdin, stderr=subprocess.PIPE, text=True, env=env)
    reader.stdin.close()
    assert done.returncode == 141 and done.stderr == "", done.stderr


def test_an_error_message_that_stderr_cannot_take_keeps_its_status(capsys, monkeypatch):
    import errno
    import io
    import sys

    class Full(io.StringIO):
        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(sys, "stderr", Full())
    with pytest.raises(SystemExit) as exc:
        main(["adt", "--bogus"])
    assert exc.value.code == 2  # argparse's usage error, said or not


def test_report_says_which_tables_lack_their_provenance(capsys, tmp_path):
    # a save killed while it published its files leaves them without provenance: say so, do not skip silently
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "sph_runs.csv").write_text("a\n1\n")
    (tmp_path / "data" / "table1_scale.csv").write_text("a\n1\n")
    code, _, err = run(capsys, "report", "--output-dir", tmp_path)
    # one line: it said "run `replication sph` again", then "run `replication reproduce` first"
    assert code == 1 and err.count("\n") == 1, err
    assert f"no report drawn: {tmp_path}/data holds table1 and sph tables without their provenance" in err
    assert (
        f"run `replication table1 --output-dir {tmp_path}` and `replication sph --output-dir {tmp_path}` "
        "again" in err
    )
    import shutil
    from pathlib import Path

    committed = Path(__file__).resolve().parents[1] / "reports" / "data"
    for path in committed.glob("casestudy_*"):  # a data set that is drawn: the others are a warning
        shutil.copy(path, tmp_path / "data" / path.name)
    (tmp_path / "data" / "table1_scale.csv").unlink()
    code, _, err = run(capsys, "report", "--output-dir", tmp_path)
    assert code == 0 and err.startswith(f"warning: {tmp_path}/data holds sph tables without their provenance")
    assert f"run `replication sph --output-dir {tmp_path}` again" in err


@pytest.mark.slow
def test_tables_without_provenance_beside_a_quick_run_are_made_again_with_quick(capsys, quick_reports_copy):
    # the hint named the paper's settings: a full run into reports-quick/, beside a quick run's data
    out = quick_reports_copy
    (out / "data" / "table1_provenance.json").unlink()
    code, _, err = run(capsys, "report", "--output-dir", out)
    assert code == 0 and f"run `replication table1 --quick --output-dir {out}` again" in err, err
    import json

    record = json.loads((out / "data" / "casestudy_provenance.json").read_text())
    record["config"], record["quick"] = {}, False  # a paper-settings case study beside them
    (out / "data" / "casestudy_provenance.json").write_text(json.dumps(record))
    from replication.cli.reports import _all_quick

    assert not _all_quick(out / "data")
    assert not _all_quick(out / "nothing-here")  # no settings recorded: the paper's command


def test_ctrl_c_while_the_command_line_is_parsed_is_one_line(capsys, monkeypatch):
    # Ctrl-C in the first second (the command's module being imported) printed a traceback
    import replication.cli as cli

    def interrupted(commands=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["casestudy", "--quick"]) == 130
    assert capsys.readouterr().err == "replication casestudy: interrupted\n"


def test_a_closed_standard_output_loses_nothing(capsys, tmp_path, monkeypatch):
    """With the standard output closed (``>&-``) sys.stdout is None: print() drops the text and
    the command succeeds. The guard of a full standard output made it an unexpected error."""
    import sys

    monkeypatch.setattr(sys, "stdout", None)
    assert main(["adt", "--random", "20", "--seed", "1", "-o", str(tmp_path / "s.vtk")]) == 0
    assert (tmp_path / "s.vtk").is_file() and sys.stdout is None


@pytest.mark.parametrize(
    ("command", "content"),
    [
        ("adt", "x,y,z\n1,2,3\n4,5,6\n"),
        ("nurbs", "x,y,z\n1,2,3\n4,5,6\n"),
        ("adt", "x,y,z\n0,0,1\n1,1,2\n2,2,3\n"),
    ],  # fmt: skip
)
def test_an_error_about_the_data_of_a_file_names_the_file(command, content, tmp_path, capsys, monkeypatch):
    """'need at least 3 distinct projected points, got 2' did not say which file had two."""
    from replication.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "pts.csv").write_text(content)
    assert main([command, "pts.csv"]) == 1
    err = capsys.readouterr().err
    named = err.startswith(f"replication {command}: error: pts.csv: ")
    assert named and err.count("\n") == 1, err


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["adt", "--random", "20", "--split", "z=abc"], "--split: split plane must look like"),  # was exit 1
        (["adt", "--random", "20", "--format", "vtk"], "--format vtk applies only with -o"),  # was ignored
        (["nurbs", "--random", "20", "--format", "json"], "--format json applies only with -o"),
    ],  # fmt: skip
)
def test_misused_options_are_usage_errors_before_any_work(argv, said, capsys):
    from replication.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert said in err and err.count("\n") == 1 and f"(see 'replication {argv[0]} --help')" in err, err


def test_a_readme_that_is_a_device_is_not_called_a_directory(capsys, tmp_path, monkeypatch):
    from replication.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "reports" / "data").mkdir(parents=True)
    assert main(["report", "--readme", "/dev/null"]) == 1
    err = capsys.readouterr().err
    assert "--readme /dev/null is a device, FIFO or socket, not a README file" in err, err


@pytest.mark.parametrize(
    "argv",
    [
        ["adt", "ok.csv", "-o", "out.xyz"],
        ["nurbs", "ok.csv", "-o", "out.xyz"],
        ["adt", "ok.csv", "--save-cloud", "x.foo"],
    ],  # fmt: skip
)
def test_an_error_about_an_option_is_not_blamed_on_the_input_file(argv, tmp_path, capsys, monkeypatch):
    """Review: the input's name was put before every error, 'ok.csv: cannot tell the surface
    format from out.xyz' among them."""
    from replication.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "ok.csv").write_text("x,y,z\n1,2,3\n2,3,4\n5,1,2\n6,6,6\n")
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"replication {argv[0]}: error: ") and "ok.csv" not in err, err


@pytest.mark.parametrize("command", ["adt", "nurbs", "compare", "force"])
def test_an_empty_input_name_is_a_misused_command_line(command, capsys):
    """`adt ""` exited 1 where an empty `-o ""` exits 2."""
    from replication.cli import main

    assert main([command, ""]) == 2
    err = capsys.readouterr().err
    assert "INPUT is empty" in err and err.count("\n") == 1, err


def test_a_dangling_link_is_not_just_not_found(tmp_path, capsys, monkeypatch):
    from replication.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "dead.csv").symlink_to("gone.csv")
    (tmp_path / "a.csv").symlink_to("b.csv")
    (tmp_path / "b.csv").symlink_to("a.csv")
    (tmp_path / "loop.vtp").symlink_to("a.csv")
    assert main(["adt", "dead.csv"]) == 1
    assert "dead.csv (a symbolic link to gone.csv, which does not exist)" in capsys.readouterr().err
    assert main(["adt", "a.csv"]) == 1
    assert "a.csv (a loop of symbolic links)" in capsys.readouterr().err
    assert main(["force", "loop.vtp"]) == 1
    assert "surface file not found: loop.vtp (a loop of symbolic links)" in capsys.readouterr().err
    assert main(["adt", "absent.csv"]) == 1
    assert capsys.readouterr().err.rstrip().endswith("point-cloud file not found: absent.csv")


@pytest.mark.parametrize(
    ("shape", "said"),
    [
        ("points", "the surface must consist of faces of three or more corners; it holds 10 vertex cell(s)"),
        ("lines", "consist of faces of three or more corners; it holds 1 line(s), 2 polygon(s) of 4 corners"),
        (
            "warped",
            "4 of its 4 polygon(s) of more than 3 corners are not flat (cell 0, counted from 0, bends",
        ),
    ],
)
def test_a_mesh_of_other_cells_says_what_it_holds(shape, said, tmp_path, capsys):
    import pyvista as pv

    from replication.cli import main

    if shape == "points":
        mesh = pv.PolyData(np.random.default_rng(0).random((10, 3)))
    elif shape == "lines":
        mesh = pv.Plane(i_resolution=2, j_resolution=1)
        mesh.lines = [2, 0, 1]
    else:
        mesh = pv.Plane(i_resolution=2, j_resolution=2, center=(18, 0, 0), i_size=20, j_size=20)
        mesh.points[:, 2] = 5 + 0.01 * (mesh.points[:, 0] - 18) * mesh.points[:, 1]
    mesh.save(tmp_path / "m.vtp")
    assert main(["force", str(tmp_path / "m.vtp"), "--full-jet"]) == 1
    err = capsys.readouterr().err
    assert said in err and err.count("\n") == 1
