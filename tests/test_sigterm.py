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
from replication.sigterm import EXIT_STATUS, Terminated, handler_installed, sigterm_interrupts, terminating


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
    assert isinstance(caught.value, Terminated) and terminating()
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
        assert not terminating()


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
