"""The README's set-up commands are the ones CI runs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _setup_commands():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Set-up", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.+?)\n```", section, flags=re.S)


def test_exactly_two_setup_commands():
    commands = _setup_commands()
    assert len(commands) == 2 and all("\n" not in c for c in commands)
    assert commands[0].endswith("replication reproduce")
    assert commands[1].endswith("python -m pytest")


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text()
    assert _setup_commands()[1] in ci.splitlines()


def test_readme_headline_block_matches_the_committed_reports():
    """The README's headline numbers are generated from reports/data (refresh them with
    ``replication report --readme README.md`` after regenerating the reports)."""
    import pytest

    from replication.report.index import END, START, headline

    if not (ROOT / "reports" / "data").is_dir():
        pytest.skip("no committed reports yet")
    text = (ROOT / "README.md").read_text()
    block = text.split(START, 1)[1].split(END, 1)[0].strip().splitlines()
    assert block == headline(ROOT / "reports")


def test_a_quick_run_leaves_the_checkout_readme_and_reports_refresh_it(quick_reports, tmp_path, capsys):
    """The README's two commands in order stay green on any machine: reports drawn into a
    checkout's reports/ rewrite the README headline block from their data (``reproduce`` with the
    paper's settings, or ``report``); a quick run goes to reports-quick/ and leaves it alone."""
    import shutil

    from replication.cli import main
    from replication.report.index import END, START, headline

    committed = (ROOT / "README.md").read_text()
    assert quick_reports.name == "reports-quick"
    assert (quick_reports.parent / "README.md").read_text() == committed  # the stand-in checkout's
    for name in ("README.md", "pyproject.toml"):
        shutil.copy(ROOT / name, tmp_path / name)
    out = shutil.copytree(quick_reports, tmp_path / "reports")
    assert main(["report", "--output-dir", str(out)]) == 0
    assert f"wrote {tmp_path / 'README.md'}\n" in capsys.readouterr().out
    text = (tmp_path / "README.md").read_text()
    block = text.split(START, 1)[1].split(END, 1)[0].strip().splitlines()
    assert block == headline(out) and block  # the quick data's numbers, not the committed ones
    assert block != headline(ROOT / "reports")
    assert text.split(START)[0] == committed.split(START)[0] and text.split(END)[1] == committed.split(END)[1]


def test_reports_outside_a_checkout_touch_no_readme(tmp_path):
    from replication.cli.outputs import checkout_readme

    (tmp_path / "reports").mkdir()
    (tmp_path / "README.md").write_text("<!-- headline:start -->\n<!-- headline:end -->\n")
    assert checkout_readme(tmp_path / "reports") is None  # no pyproject.toml of this project
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "other"\n')
    assert checkout_readme(tmp_path / "reports") is None
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "replication"\n')
    assert checkout_readme(tmp_path / "reports") == tmp_path / "README.md"
    assert checkout_readme(tmp_path / "reports-quick") is None  # only the canonical reports/


def test_one_quick_reports_test_runs_first_and_the_others_last():
    """conftest's order: the worker that takes the first test needing the shared quick
    reports builds them while the other worker runs tests that do not need them."""
    from types import SimpleNamespace

    from conftest import pytest_collection_modifyitems

    def item(name, *fixtures):
        return SimpleNamespace(name=name, fixturenames=[*fixtures, "tmp_path"])

    reports = ("quick_reports_copy", "quick_reports")
    items = [item("a"), item("r1", *reports[1:]), item("b"), item("r2", *reports)]
    items += [item("c"), item("r3", *reports)]
    pytest_collection_modifyitems(None, None, items)
    assert [i.name for i in items] == ["r1", "a", "b", "c", "r2", "r3"]
    alone = [item("a"), item("r1", "quick_reports"), item("b")]
    pytest_collection_modifyitems(None, None, alone)
    assert [i.name for i in alone] == ["a", "r1", "b"]  # one such test: nobody waits, order kept


def test_the_readme_block_keeps_the_file_s_line_ends_and_its_link(tmp_path):
    """A CRLF README was rewritten with LF line ends, and a README that is a symbolic link was
    replaced by a file while its target kept the old block."""
    from replication.report.index import END, START, update_readme

    real = tmp_path / "real.md"
    real.write_bytes(f"# Title\r\n\r\n{START}\r\nOLD-BLOCK-LINE\r\n{END}\r\ntail\r\n".encode())
    link = tmp_path / "README.md"
    link.symlink_to(real)
    update_readme(link, ROOT / "reports")
    data = real.read_bytes()
    assert link.is_symlink() and b"OLD-BLOCK-LINE" not in data
    assert data.count(b"\n") == data.count(b"\r\n") > 6
    assert data.startswith(b"# Title\r\n\r\n") and data.endswith(f"{END}\r\ntail\r\n".encode())


def test_readme_speed_block_and_performance_page_match_the_asv_archive(tmp_path):
    """The README's speed goals and reports/performance.md are drawn from the committed asv
    archive (refresh both with ``replication report --performance`` after an asv run)."""
    import shutil

    from replication.report.asv_archive import ARCHIVE
    from replication.report.performance import render_performance, speed_table
    from replication.report.speed_goals import END, START

    text = (ROOT / "README.md").read_text()
    block = text.split(START, 1)[1].split(END, 1)[0].strip("\n").split("\n")
    assert block == "\n".join(speed_table(ROOT / "reports")).split("\n")
    (tmp_path / "data").mkdir()
    shutil.copy(ROOT / "reports" / "data" / ARCHIVE, tmp_path / "data" / ARCHIVE)
    page = render_performance(None, tmp_path).read_text(encoding="utf-8")
    assert page == (ROOT / "reports" / "performance.md").read_text(encoding="utf-8")
