"""Signals that stop a run: Ctrl-C (SIGINT) and SIGTERM become exceptions that unwind through `finally` blocks, also
when they arrive inside C code that swallows Python exceptions.

CasADi's IPOPT interface checks for signals between iterations, catches the KeyboardInterrupt that Python's SIGINT
handler raises, and returns a failed status ("NonIpopt_Exception_Thrown"; IPOPT's own handler answers
"User_Requested_Stop"); a solver that then tries its next strategy would ignore the user. `interruptible()` around
such a call records the exception raised by the signal handler and raises it again once the call returns (and
drops CasADi's warning line about it, so that the interrupt is reported once, by the caller).
"""
from __future__ import annotations

import contextlib
import signal
import socket
import sys
import threading
from typing import Iterator

class Terminated(BaseException):
    """SIGTERM received (BaseException, like KeyboardInterrupt: `except Exception` does not swallow it)."""


def raise_terminated(signum: int, frame) -> None:
    raise Terminated()


@contextlib.contextmanager
def terminate_raises() -> Iterator[None]:
    """Within the block SIGTERM raises Terminated (so that temporary files are cleaned up); main thread only."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class _Recorder:
    def __init__(self):
        self.exc: BaseException | None = None

    def wrap(self, previous):
        def handler(signum, frame):
            try:
                previous(signum, frame)
            except BaseException as exc:  # noqa: BLE001 - kept to be raised again after the C call returns
                self.exc = exc
                raise
        return handler


class _WithoutInterruptNotice:
    """sys.stderr minus CasADi's warning about the exception it caught: the caller reports the interrupt itself,
    in one line (CasADi writes its warnings through Python's sys.stderr)."""

    def __init__(self, stream, rec: _Recorder):
        self.stream, self.rec = stream, rec
        self.dropping = False  # inside a CasADi warning line written after the interrupt (it comes in pieces)

    def write(self, text: str) -> int:
        if self.rec.exc is not None and (self.dropping or text.startswith("CasADi - ")
                                         or "KeyboardInterruptException" in text):
            self.dropping = "\n" not in text
            return len(text)
        return self.stream.write(text)

    def __getattr__(self, name):
        return getattr(self.stream, name)


@contextlib.contextmanager
def interruptible() -> Iterator[_Recorder]:
    """Around a C call that may swallow signal exceptions: after it returns, the exception a SIGINT/SIGTERM handler
    raised during the call is raised again. Handlers that are not Python callables (default kill, ignore) are left
    alone; outside the main thread signals are not Python's to handle, so nothing is wrapped.

    A signal whose Python handler never ran during the call (C code that checks for signals itself and consumes
    the pending flag) is still seen: Python's C-level handler writes every signal number to the wakeup fd, and a
    SIGINT/SIGTERM found there without a recorded exception calls the handler after the call. A SIGINT the process
    inherited as ignored (a background job of a non-interactive shell) stays ignored, as in any Unix program."""
    rec = _Recorder()
    if threading.current_thread() is not threading.main_thread():
        yield rec
        return
    saved = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        prev = signal.getsignal(sig)
        if callable(prev):
            saved[sig] = prev
            signal.signal(sig, rec.wrap(prev))
    wake_r, wake_w = socket.socketpair()
    wake_r.setblocking(False)
    wake_w.setblocking(False)
    old_fd = signal.set_wakeup_fd(wake_w.fileno(), warn_on_full_buffer=False)
    stderr, sys.stderr = sys.stderr, _WithoutInterruptNotice(sys.stderr, rec)
    arrived = b""
    try:
        yield rec
    finally:
        sys.stderr = stderr
        signal.set_wakeup_fd(old_fd)
        try:
            arrived = wake_r.recv(4096)
        except BlockingIOError:  # nothing arrived
            pass
        wake_r.close()
        wake_w.close()
        for sig, prev in saved.items():
            signal.signal(sig, prev)
    if rec.exc is not None:
        raise rec.exc
    for sig, handler in saved.items():
        if int(sig) in arrived:
            handler(int(sig), None)  # raises (KeyboardInterrupt / Terminated) for the handlers this module expects


def progress_bar(**kwargs):
    """A tqdm bar whose clean-up survives a Ctrl-C that lands inside its own constructor: tqdm's __del__ then finds
    no `pos` and prints a traceback at garbage collection, after the run has reported its interrupt in one line."""
    from tqdm import tqdm

    class _Bar(tqdm):
        def __del__(self):
            if hasattr(self, "pos"):
                super().__del__()

    return _Bar(**kwargs)
