"""SIGTERM stops a command as Ctrl-C does, without waiting, and exits with 143.

The end-to-end cases (a GA run killed with ``kill PID``, a simulation under way abandoned)
are in ``test_interrupts.py``; these are the handler's own rules.
"""

from __future__ import annotations

import os
import signal
import threading

import pytest

from replication.io.atomic import interrupt_deferred
from replication.sigterm import (
    EXIT_STATUS,
    Terminated,
    handler_installed,
    sigterm_interrupts,
    terminated,
    terminating,
)


@pytest.fixture(autouse=True)
def default_sigterm():
    """Each test starts from the system's default for SIGTERM, and leaves it so."""
    previous = signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    signal.signal(signal.SIGTERM, previous)


def _sigterm():
    os.kill(os.getpid(), signal.SIGTERM)
    for _ in range(1000):  # the handler runs between bytecodes of the main thread
        pass


def test_sigterm_raises_terminated_which_is_an_interrupt():
    with pytest.raises(KeyboardInterrupt) as caught, sigterm_interrupts():
        assert handler_installed() and not terminating()
        _sigterm()
    assert isinstance(caught.value, Terminated) and terminated() and not terminating()  # (block over)
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # restored
    assert EXIT_STATUS == 143


def test_a_second_sigterm_does_not_cut_the_unwinding_short():
    unwound = False
    with pytest.raises(Terminated), sigterm_interrupts():
        try:
            _sigterm()
        finally:
            _sigterm()  # a supervisor's second SIGTERM, during the clean-up
            unwound = True
    assert unwound


def test_each_block_starts_with_no_sigterm_seen():
    with pytest.raises(Terminated), sigterm_interrupts():
        _sigterm()
    with sigterm_interrupts():
        assert not terminating() and not terminated()
    assert not terminated()
    with pytest.raises(Terminated), sigterm_interrupts():
        _sigterm()
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a block that installs nothing resets it too
    with sigterm_interrupts():
        assert not handler_installed()
    assert not terminated()


def test_a_program_s_own_handler_is_left_alone():
    seen = []
    signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))
    with sigterm_interrupts():
        assert not handler_installed()
        _sigterm()
    assert seen == [signal.SIGTERM] and not terminating()


def test_only_the_main_thread_installs_it():
    installed = []
    thread = threading.Thread(target=lambda: installed.append(_installed_in_block()))
    thread.start()
    thread.join()
    assert installed == [False] and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def _installed_in_block():
    with sigterm_interrupts():
        return handler_installed()


def test_moving_files_into_place_holds_sigterm_until_the_end():
    """As it holds Ctrl-C: the moves of ``all_or_none`` and of the report data finish first."""
    steps = []
    with pytest.raises(Terminated), sigterm_interrupts():
        with interrupt_deferred():
            _sigterm()
            steps.append("moved")
        steps.append("after the block")  # not reached: the held SIGTERM is raised at its end
    assert steps == ["moved"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_held_sigterm_comes_before_a_held_ctrl_c():
    with pytest.raises(Terminated), sigterm_interrupts(), interrupt_deferred():
        os.kill(os.getpid(), signal.SIGINT)
        _sigterm()


def test_the_command_line_says_terminated_and_exits_143(capsys, monkeypatch):
    from replication import cli

    def command(args):
        _sigterm()
        return 0

    parser = cli.build_parser(["adt"])
    monkeypatch.setattr(cli, "build_parser", lambda commands: parser)
    monkeypatch.setattr(parser, "parse_known_args", lambda argv: (_namespace(command), []))
    assert cli.main(["adt"]) == 143
    assert capsys.readouterr().err == "replication adt: terminated (SIGTERM)\n"
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def _namespace(func):
    import argparse

    return argparse.Namespace(command="adt", func=func, debug=False)


def test_ctrl_c_is_still_an_interrupt(capsys, monkeypatch):
    from replication import cli

    def command(args):
        raise KeyboardInterrupt

    parser = cli.build_parser(["adt"])
    monkeypatch.setattr(cli, "build_parser", lambda commands: parser)
    monkeypatch.setattr(parser, "parse_known_args", lambda argv: (_namespace(command), []))
    assert cli.main(["adt"]) == 130
    assert capsys.readouterr().err == "replication adt: interrupted\n"


def test_terminating_holds_only_inside_the_block_and_terminated_after_it():
    """A SIGTERM of one command made later Ctrl-Cs in the same process abandon work (review)."""
    with pytest.raises(Terminated), sigterm_interrupts():
        _sigterm()
    assert terminated() and not terminating()  # the exit status knows; executors no longer act on it


def test_the_ga_s_guard_stops_after_a_sigterm_whose_raise_was_lost():
    """A Terminated raised inside a fork hook or a finalizer is only reported: the run went on."""
    from replication.casestudy.interrupts import InterruptGuard

    with pytest.raises(Terminated), sigterm_interrupts(), InterruptGuard() as guard:  # (and at its end)
        try:
            _sigterm()
        except Terminated:
            pass  # lost, as Python loses an exception raised in a fork hook
        assert guard.requested()
        with pytest.raises(Terminated):
            guard.check()


def _worker_signals():
    import signal

    return signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL, signal.SIGTERM in signal.pthread_sigmask(
        signal.SIG_BLOCK, []
    )


def test_workers_start_with_sigterm_held_and_take_it_once_set_up():
    """A forked worker kept the parent's handler (raising Terminated) until its initializer ran."""
    from replication.casestudy.evaluate import executor

    with sigterm_interrupts(), executor("process", workers=1) as pool:
        handled, blocked = pool.submit(_worker_signals).result(timeout=60)
        assert handler_installed()  # the parent's own handler is untouched
        assert signal.SIGTERM not in signal.pthread_sigmask(signal.SIG_BLOCK, [])  # and unblocked again
    assert handled and not blocked  # the worker's own SIGTERM handler (it unwinds), and SIGTERM reaches it


def test_a_command_whose_sigterm_raise_was_lost_still_ends_with_143(capsys, monkeypatch):
    """Python only reports an exception raised in a finalizer: the command ran on and exited 0."""
    import sys

    from replication import cli

    lost = []
    monkeypatch.setattr(sys, "unraisablehook", lambda info: lost.append(info.exc_type))

    class SignalledWhileFinalized:
        def __del__(self):
            _sigterm()  # the handler runs here, and its Terminated goes to sys.unraisablehook

    def command(args):
        SignalledWhileFinalized()
        _sigterm()  # a supervisor's second SIGTERM: ignored, as always
        return 0

    parser = cli.build_parser(["report"])
    monkeypatch.setattr(cli, "build_parser", lambda commands: parser)
    monkeypatch.setattr(parser, "parse_known_args", lambda argv: (_namespace(command), []))
    assert cli.main(["report"]) == 143
    assert lost == []  # taken by the command, not handed to Python's hook (it printed a traceback)
    assert capsys.readouterr().err == "replication adt: terminated (SIGTERM)\n"
