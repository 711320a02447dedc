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
