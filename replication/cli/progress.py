"""Progress of long work on stderr: a live bar on a terminal, plain lines in a log.

On a terminal a tqdm bar is drawn and stays visible when it finishes, so the screen shows
what was done. When stderr is not a terminal (a log file, CI, a pipe) carriage-return
updates would pile up as one unreadable line, so the progress is written as complete lines
instead: one at every tenth of the work and one when it finishes, with the elapsed time.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterable, Iterator
from typing import Any, TextIO

__all__ = ["Progress", "progress", "progress_bar", "stage"]

#: Plain-line mode reports at every this fraction of the work (and at the end).
LINE_STEP = 0.1


class Progress:
    """A progress display of ``total`` steps: a tqdm bar or plain lines (see the module notes)."""

    def __init__(self, total: int, description: str, *, initial: int = 0, file: TextIO | None = None) -> None:
        self.total = max(int(total), 0)
        self.description = description
        self.file = file if file is not None else sys.stderr
        self.done = initial
        self.postfix = ""
        self.started = time.perf_counter()
        self._next_line = (
            LINE_STEP * (int(initial / self.total / LINE_STEP + 1e-9) + 1) if self.total else 1.0
        )
        self._closed = False
        self._printed_at: int | None = None
        self._bar: Any = None
        if _is_terminal(self.file):
            from tqdm import tqdm

            self._bar = tqdm(
                total=self.total,
                initial=initial,
                desc=description,
                file=self.file,
                leave=True,
                dynamic_ncols=True,
            )

    def update(self, steps: int = 1, **postfix: Any) -> None:
        """Record ``steps`` completed steps; ``postfix`` values are shown beside the count."""
        self.done += steps
        if postfix:
            self.postfix = ", ".join(f"{k}={v}" for k, v in postfix.items())
        if self._bar is not None:
            if postfix:
                self._bar.set_postfix(postfix, refresh=False)
            self._bar.update(steps)
        elif self.total and self.done < self.total and self.done / self.total >= self._next_line - 1e-12:
            while self._next_line <= self.done / self.total + 1e-12:
                self._next_line += LINE_STEP
            self._line()
        if self.done >= self.total:  # finished: say so now, with the time the work took
            self.close()

    def write(self, message: str) -> None:
        """A line of its own on the display's stream, without breaking a live bar."""
        if self._bar is not None:
            self._bar.write(message, file=self.file)
        else:
            print(message, file=self.file, flush=True)

    def close(self) -> None:
        """Finish the display: the bar stays, or a last line says what was completed."""
        if self._closed:
            return
        self._closed = True
        if self._bar is not None:
            self._bar.close()
        elif self.done >= self.total or self._printed_at != self.done:
            self._line(final=True)

    def _line(self, final: bool = False) -> None:
        self._printed_at = self.done
        elapsed = time.perf_counter() - self.started
        state = "done" if final and self.done >= self.total else f"{self._percent()} %"
        extra = f", {self.postfix}" if self.postfix else ""
        print(
            f"{self.description}: {self.done}/{self.total} {state} ({elapsed:.1f} s{extra})",
            file=self.file,
            flush=True,
        )

    def _percent(self) -> str:
        return f"{100 * self.done / self.total:.0f}" if self.total else "100"

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _is_terminal(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def progress(total: int, description: str) -> Progress:
    """A :class:`Progress` on stderr."""
    return Progress(total, description)


def progress_bar(items: Iterable[Any], description: str, total: int) -> Iterator[Any]:
    """Iterate over ``items`` while showing progress on stderr (the experiments' hook)."""
    with Progress(total, description) as bar:
        for item in items:
            yield item
            bar.update(1)


#: From this many points on, adt, nurbs and compare say when their long steps start and end
#: (seconds: 7 s to write a 2e6-point surface as text, 19 s to fit and write a 1e6-point NURBS
#: as JSON, 20 s to compare a 1e6-point cloud).
LARGE_CLOUD = 250_000


@contextlib.contextmanager
def stage(description: str, *, shown: bool = True) -> Iterator[None]:
    """One long step of work that reports no progress of its own (a library call on a large
    cloud, a large file written): a line on stderr as it starts and one with its time when it
    ends (none when it fails: the error says why). ``shown=False`` prints nothing."""
    if not shown:
        yield
        return
    print(f"{description} ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    yield
    print(f"{description}: done ({time.perf_counter() - start:.1f} s)", file=sys.stderr, flush=True)
