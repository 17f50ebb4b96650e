"""Ctrl-C and SIGTERM in the ``holecli`` program, from its first moment to its last.

:func:`install` is the first thing the program does, before any heavy import. Until a command's
body runs, and again after it, nothing is being written: a signal then prints ``Error: interrupted``
and ends the process with exit code 130 at once (no traceback, whatever is being imported). While a
body runs (:func:`raising`), a signal raises :class:`KeyboardInterrupt` instead, so that the body
can clean up (an atomic write removes its temporary file) before the command exits with 130.

Only the standard library is imported here.
"""

from __future__ import annotations

import os
import signal
from contextlib import contextmanager

__all__ = ["EXIT_INTERRUPTED", "install", "installed", "raising"]

EXIT_INTERRUPTED = 130
SIGNALS = ("SIGINT", "SIGTERM")

_raise = False
_installed = False


def _handle(number, frame):
    if _raise:
        raise KeyboardInterrupt
    try:
        os.write(2, b"Error: interrupted\n")
    finally:
        os._exit(EXIT_INTERRUPTED)


def install():
    """Handle SIGINT and SIGTERM as described in the module's docstring (main thread only)."""
    global _installed
    for name in SIGNALS:
        signal.signal(getattr(signal, name), _handle)
    _installed = True


def installed() -> bool:
    """Whether :func:`install` ran: this is the ``holecli`` program, not a library user or a test."""
    return _installed


@contextmanager
def raising():
    """Within this block, SIGINT and SIGTERM raise :class:`KeyboardInterrupt`."""
    global _raise
    previous, _raise = _raise, True
    try:
        yield
    finally:
        _raise = previous
