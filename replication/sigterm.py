"""SIGTERM during a command: stop as a Ctrl-C would, at once, losing nothing.

``kill PID``, ``docker stop``, systemd, and a batch scheduler at the end of a job's time send
SIGTERM. Python's default for it ends the process on the spot, skipping every ``finally``: a
GA run stopped without the "resume with" line it prints on Ctrl-C, a file being written left
its temporary behind, and the workers of a process pool were left to notice their parent's
death. While :func:`sigterm_interrupts` is active (the ``replication`` command's whole run),
SIGTERM instead raises :class:`Terminated`, a :class:`KeyboardInterrupt`, so every path that
handles Ctrl-C handles it too: checkpoints stay whole, temporaries are removed, the resume
line is printed, and the command exits with 143 (128 + SIGTERM).

The one difference from Ctrl-C is that SIGTERM does not wait: the first Ctrl-C lets the
evaluations and SPH simulations under way finish (minutes for a simulation), whereas a
process that is told to terminate abandons them at once, as a second Ctrl-C does
(:func:`terminating` tells the executors, :func:`replication.casestudy.evaluate.executor`).
Only the first SIGTERM is taken: a second one, which a supervisor may send while the command
unwinds, is ignored, so it cannot cut the clean-up short (SIGKILL still ends the process).
Python only reports an exception raised in a finalizer or a weakref callback, so the first
raise can be lost: the GA's guard then stops the run between evaluations
(:func:`terminating`), and a block that ends normally after a SIGTERM raises it at its end.
Moves of finished files into place hold SIGTERM, as they hold Ctrl-C
(:func:`replication.io.atomic.interrupt_deferred`).

Notes
-----
Infrastructure for the long runs of the paper's section 6 case study and section 4's
Table 1 experiment; the paper itself says nothing about signals.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType

__all__ = [
    "EXIT_STATUS",
    "Terminated",
    "handler_installed",
    "sigterm_interrupts",
    "terminated",
    "terminating",
]

#: The exit status of a command ended by SIGTERM, as a shell reports a process it killed.
EXIT_STATUS = 128 + signal.SIGTERM

_terminated = False


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised as an interrupt that does not wait for the work under way."""


def terminating() -> bool:
    """Whether SIGTERM arrived in the :func:`sigterm_interrupts` block running now (False outside one).

    A raise of :class:`Terminated` can be lost (Python only reports an exception raised in
    code such as a fork hook or a finalizer): long runs also look at this between their steps.
    """
    return _terminated and handler_installed()


def terminated() -> bool:
    """Whether SIGTERM arrived in the last :func:`sigterm_interrupts` block (the command's exit status)."""
    return _terminated


def _on_sigterm(signum: int, frame: FrameType | None) -> None:
    global _terminated
    if _terminated:  # only the first: a second would cut the clean-up of the first short
        return
    _terminated = True
    raise Terminated


def handler_installed() -> bool:
    """Whether SIGTERM is this module's (raising :class:`Terminated`) in this process now."""
    return signal.getsignal(signal.SIGTERM) is _on_sigterm


@contextlib.contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """While the block runs, SIGTERM raises :class:`Terminated` (see the module notes).

    Only in the main thread and only over the system's default for SIGTERM: a program with
    its own handler, or one that ignores SIGTERM, keeps it. :func:`terminated` is reset on
    entry and keeps its answer after the block, for the caller's exit status.
    """
    global _terminated
    _terminated = False
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return
    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if _terminated:  # its raise was lost (in a finalizer, a weakref callback): the exit status still says so
        raise Terminated
