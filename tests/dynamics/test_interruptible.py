"""`interruptible()`: a Ctrl-C that arrives during a C call which swallows the exception is raised again once the
call returns, whether or not its Python handler ran inside the call; nothing is raised when no signal came."""
from __future__ import annotations

import os
import signal
import time

import pytest

from ancf_sym.util.interrupts import interruptible


def _deliver(sig: int) -> None:
    os.kill(os.getpid(), sig)
    time.sleep(0.01)  # the handler runs at the next bytecode boundary after delivery


def test_swallowed_exception_is_raised_after_the_call():
    with pytest.raises(KeyboardInterrupt):
        with interruptible():
            try:
                _deliver(signal.SIGINT)
            except KeyboardInterrupt:  # what CasADi does with the exception inside IPOPT
                pass


def test_signal_whose_handler_never_ran_is_raised_after_the_call():
    """Code inside the call replaces the handler and consumes the signal (its pending flag) itself: the wakeup fd
    still saw it."""
    with pytest.raises(KeyboardInterrupt):
        with interruptible():
            ours = signal.signal(signal.SIGINT, lambda s, f: None)
            _deliver(signal.SIGINT)
            signal.signal(signal.SIGINT, ours)


def test_no_signal_no_exception_and_handlers_restored():
    before = signal.getsignal(signal.SIGINT), signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(before[1])
    with interruptible():
        pass
    assert signal.getsignal(signal.SIGINT) is before[0]
    assert signal.set_wakeup_fd(before[1]) == before[1]
