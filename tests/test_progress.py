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
