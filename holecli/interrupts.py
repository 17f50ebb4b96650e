"""Ctrl-C and SIGTERM in the ``holecli`` program, from its first moment to its last.

:func:`install` is the first thing the program does, before any heavy import. Until a command's
body runs, and again after it, nothing is being written: a signal then prints ``Error: interrupted``
and ends the process with exit code 130 at once (no traceback, whatever is being imported). While a
body runs (:func:`raising`), a signal raises :class:`KeyboardInterrupt` instead, so that the body
can clean up (an atomic write removes its temporary file) before the command exits with 130.

Within :func:`deferred` a signal waits until the block ends, then acts as above: a worker process
being launched is never cut off between its start and the data it starts from.

A KeyboardInterrupt raised where Python cannot pass it on (a weak reference's callback, such as the
one importlib's module locks use, or a ``__del__``) is "ignored" by the interpreter. The signal is
still recorded: :func:`check`, called before anything is committed (an atomic rename) and when a body
returns, raises it again, and the interpreter's "Exception ignored" report of it is not printed.

Only the standard library is imported here.
"""

from __future__ import annotations

import os
import signal
import sys
from contextlib import contextmanager

__all__ = ["EXIT_INTERRUPTED", "check", "deferred", "install", "installed", "raising", "received", "record"]

EXIT_INTERRUPTED = 130
SIGNALS = ("SIGINT", "SIGTERM")

_raise = False
_installed = False
_received = None
_deferring = False
_pending = None


def _handle(number, frame):
    global _pending
    if _deferring:
        _pending = number
        return
    if _raise:
        record(number)
        raise KeyboardInterrupt
    try:
        os.write(2, b"Error: interrupted\n")
    finally:
        os._exit(EXIT_INTERRUPTED)


def install():
    """Handle SIGINT and SIGTERM as described in the module's docstring (main thread only).

    Returns
    -------
    None

    Raises
    ------
    ValueError
        When called from a thread other than the main thread (from :func:`signal.signal`).
    """
    global _installed
    for name in SIGNALS:
        signal.signal(getattr(signal, name), _handle)
    if not _installed:
        sys.unraisablehook = _quiet_about_our_interrupt(sys.unraisablehook)
    _installed = True


def _quiet_about_our_interrupt(hook):
    """``hook``, except for the KeyboardInterrupt of a received signal that the interpreter could not
    raise (it is raised again by :func:`check`)."""

    def unraisable(report):
        if isinstance(report.exc_value, KeyboardInterrupt) and _raise and _received is not None:
            return
        hook(report)

    return unraisable


def check():
    """Raise :class:`KeyboardInterrupt` when a signal came in the current :func:`raising` block.

    The handler raised it already; this raises it again where the first one was swallowed (see the
    module's docstring). Call it before committing anything.

    Returns
    -------
    None

    Raises
    ------
    KeyboardInterrupt
        When :func:`received` is not None inside a :func:`raising` block.
    """
    if _raise and _received is not None:
        raise KeyboardInterrupt


def record(number):
    """Note that signal ``number`` is raising KeyboardInterrupt (see :func:`received`).

    Parameters
    ----------
    number : int
        The signal's number.

    Returns
    -------
    None
    """
    global _received
    _received = number


def received():
    """The signal that raised :class:`KeyboardInterrupt` in a :func:`raising` block, or None.

    The exception does not always arrive as itself: raised while a C extension initialises (an import
    inside the block), it comes out as that import's ``ImportError``. Whatever a body raised after a
    signal was received is the interrupt's doing.

    Returns
    -------
    int or None
        The signal's number, or None when none came in the current (or last) block.
    """
    return _received


def installed() -> bool:
    """Whether :func:`install` ran: this is the ``holecli`` program, not a library user or a test.

    Returns
    -------
    bool
    """
    return _installed


@contextmanager
def raising():
    """Within this block, SIGINT and SIGTERM raise :class:`KeyboardInterrupt` (and :func:`received`
    says which came; it starts as None).

    Only after :func:`install`; the previous behaviour comes back when the block ends (blocks nest).

    Returns
    -------
    context manager
        Yields None.

    Raises
    ------
    KeyboardInterrupt
        When SIGINT or SIGTERM arrives inside the block (with the handlers of :func:`install`).
    """
    global _raise, _received
    previous, _raise = _raise, True
    _received = None
    try:
        yield
    finally:
        _raise = previous


@contextmanager
def deferred():
    """Within this block SIGINT and SIGTERM wait: when it ends, the first that came acts as it would
    have (exit 130 at once, or :class:`KeyboardInterrupt` inside :func:`raising`).

    For steps that must not be cut in the middle: a spawned worker process launched but not yet sent
    the data it starts from would die of an ``EOFError`` with a traceback on the shared stderr, and its
    pool's semaphores would be left to multiprocessing's resource tracker. Blocks nest (the outermost
    acts). Without :func:`install` it changes nothing.

    Returns
    -------
    context manager
        Yields None.

    Raises
    ------
    KeyboardInterrupt
        At the block's end, when a signal came inside it within :func:`raising`.
    """
    global _deferring, _pending
    previous, _deferring = _deferring, True
    try:
        yield
    finally:
        _deferring = previous
        if not previous and _pending is not None:
            number, _pending = _pending, None
            _handle(number, None)
