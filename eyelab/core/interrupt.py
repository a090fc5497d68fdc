"""Interruption (Ctrl-C's SIGINT, SIGTERM) as a request that survives being swallowed.

While :func:`handling` is active, SIGINT raises :class:`KeyboardInterrupt` and SIGTERM
:class:`Terminated` in the main thread, as usual, and the request is also recorded: native
code that checks for signals and clears the exception (an extension's initialisation, a
library's event loop) cannot make eyelab forget it. :func:`check` raises it again; the
atomic writers (:mod:`eyelab.core.fileio`) call it before a temporary replaces a final
file, so an interrupted command never publishes an output.
"""

from __future__ import annotations

import contextlib
import signal
import threading

#: The signal number asked for (None: none) while :func:`handling` is active.
_REQUESTED: int | None = None


class Terminated(BaseException):
    """SIGTERM, raised in the main thread as Ctrl-C raises KeyboardInterrupt."""


def _raise(signum: int):
    raise KeyboardInterrupt if signum == signal.SIGINT else Terminated


def _handler(signum, frame):
    global _REQUESTED
    _REQUESTED = signum
    _raise(signum)


def requested() -> int | None:
    """The signal number of a pending interruption request, or None."""
    return _REQUESTED


def check() -> None:
    """Raise the pending interruption (KeyboardInterrupt / :class:`Terminated`), if any."""
    if _REQUESTED is not None:
        _raise(_REQUESTED)


@contextlib.contextmanager
def handling():
    """SIGINT and SIGTERM recorded and raised for the block (main thread only; elsewhere a
    no-op); a request still pending when the block ends is raised there, and an exception
    leaving the block after a request carries its signal number as ``eyelab_signal``; the
    previous handlers are restored and the request forgotten after."""
    global _REQUESTED
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _REQUESTED = None
    previous = _install(_handler)
    try:
        yield
        check()          # a request some native code swallowed ends the block too
    except BaseException as e:
        if _REQUESTED is not None:     # whatever the interrupt turned into, say so on it
            with contextlib.suppress(AttributeError, TypeError):
                e.eyelab_signal = _REQUESTED
        raise
    finally:
        _REQUESTED = None          # the request is the block's: later work is not stopped
        _restore(previous)


@contextlib.contextmanager
def deferred():
    """SIGINT and SIGTERM held for the block and delivered when it ends: for native code
    that must not be interrupted half-way (a C extension's module initialisation —
    VTK's segfaults when a Ctrl-C lands in it). Main thread only; elsewhere a no-op. A
    signal that came meanwhile goes to the handler the block replaced, right after it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = []
    previous = _install(lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        _restore(previous)
        for signum in held[:1]:
            h = previous[signum]
            if callable(h):
                h(signum, None)
            elif h == signal.SIG_DFL:
                signal.raise_signal(signum)


@contextlib.contextmanager
def recorded():
    """SIGINT and SIGTERM only recorded for the block, never raised in it: for an event
    loop run by native code (VTK's interactor) whose Python callbacks must not be left by
    an exception — VTK ends the process itself on a KeyboardInterrupt inside one, and
    prints and ignores any other. The loop's own callback polls :func:`requested` and ends
    the loop; :func:`check` after the block raises the request as :func:`handling` would.
    Main thread only; elsewhere a no-op."""
    global _REQUESTED
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def record(signum, frame):
        global _REQUESTED
        _REQUESTED = signum

    previous = _install(record)
    try:
        yield
    finally:
        _restore(previous)


def _install(handler) -> dict:
    """``handler`` for SIGINT and SIGTERM; returns {signal: the handler it replaced}."""
    return {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}


def _restore(previous: dict) -> None:
    """Put back the handlers :func:`_install` replaced (None: one installed outside
    Python, which Python cannot put back: the default then)."""
    for s, h in previous.items():
        signal.signal(s, signal.SIG_DFL if h is None else h)
