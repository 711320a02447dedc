"""Progress on stderr: plain complete lines in logs, bars that stay visible on a terminal."""

import io

from replication.cli.progress import Progress, progress_bar


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_log_gets_plain_lines_at_every_tenth_and_a_final_one():
    log = io.StringIO()
    with Progress(200, "GA generations", file=log) as bar:
        for k in range(200):
            bar.update(1, run=k // 100, best="4.402 N")
    text = log.getvalue()
    lines = text.splitlines()
    assert "\r" not in text and text.endswith("\n")
    assert len(lines) == 10 and all(line.startswith("GA generations: ") for line in lines)
    assert lines[0].startswith("GA generations: 20/200 10 % (") and lines[-1].startswith(
        "GA generations: 200/200 done ("
    )
    assert "run=1, best=4.402 N" in lines[-1]


def test_an_unfinished_bar_says_how_far_it_got():
    log = io.StringIO()
    with Progress(7, "stage", file=log, initial=2) as bar:
        bar.update(1)
    assert log.getvalue().splitlines() == [log.getvalue().splitlines()[-1]]
    assert log.getvalue().startswith("stage: 3/7 43 % (")


def test_progress_bar_wraps_an_iterable():
    items = list(progress_bar(iter(range(5)), "items", 5))
    assert items == [0, 1, 2, 3, 4]


def test_terminal_bar_stays_visible_when_finished():
    screen = Terminal()
    with Progress(3, "Monte Carlo", file=screen) as bar:
        for _ in range(3):
            bar.update(1)
    final = screen.getvalue().rstrip("\n").split("\r")[-1]
    assert final.startswith("Monte Carlo: 100%") and "3/3" in final  # not erased (tqdm leave=True)


def test_a_message_between_updates_is_a_line_of_its_own():
    log = io.StringIO()
    with Progress(2, "SPH", file=log) as bar:
        bar.write("  random 03: timeout: no result after 60 s")
        bar.update(2)
    assert log.getvalue().splitlines()[0] == "  random 03: timeout: no result after 60 s"
    screen = Terminal()
    with Progress(2, "SPH", file=screen) as bar:
        bar.write("  a failure")
        bar.update(2)
    assert "  a failure\n" in screen.getvalue()


def test_the_sph_stage_writes_plain_lines_into_a_log(monkeypatch, tmp_path, capsys):
    """The SPH study's progress (``replication sph``, reproduce's SPH stage) follows the rule."""
    import replication.cli.sph as cli_sph
    import replication.experiments.sph as experiment
    import replication.report.sph as report

    def fake_study(config, *, command, quick, on_run, **executor):
        for k in range(len(config.runs())):
            on_run(f"run {k}")
        return "results"

    monkeypatch.setattr(experiment, "run_sph_study", fake_study)
    monkeypatch.setattr(report, "save_sph_data", lambda results, out: None)
    monkeypatch.setattr(report, "render_sph", lambda out: out / "sph.md")
    cli_sph.run_sph_report(tmp_path, quick=True, command="replication sph --quick")
    err = capsys.readouterr().err
    assert "\r" not in err and err.splitlines()[-1].startswith("SPH simulations: ")
    assert " done (" in err.splitlines()[-1]
