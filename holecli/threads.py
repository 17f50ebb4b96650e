"""One BLAS thread while holecli measures.

numpy's BLAS (OpenBLAS) starts a thread per core and uses them even for the thin ``(n, 3) @ (3, 3)``
products the pipeline is made of, where waking and joining the threads costs more than the product: on
a 2-core machine a 10^6-point detect took 2.3 s of CPU with two BLAS threads and 1.4 s with one. Two
processes doing it at once (``holecli batch --jobs 2``) oversubscribe the cores. holecli's own
parallelism (threads over holes, worker processes over files) is coarse; BLAS's is not worth it here.

:func:`single_blas_thread` limits every loaded BLAS library to one thread for the duration of a
``with`` block (threadpoolctl) and puts the previous limits back after it. OpenBLAS takes a limit only
from the main thread of the process (set or restored from another thread, it keeps its setting), so
only a block in the main thread limits anything: ``holecli`` and its batch workers call ``detect``
there; a program that calls it from threads of its own keeps BLAS's threads, and its own limits are
never left changed. The libraries are looked up once per process (about 1.4 ms), at the first call:
by then the modules that measure are imported, and with them every BLAS they use (numpy's, and
scipy's own).

:func:`start_blas_single_threaded` is for the ``holecli`` program, before numpy is imported: OpenBLAS
reads ``OPENBLAS_NUM_THREADS`` once, when it loads, and otherwise starts a thread per core at import,
which costs about 0.1 s of CPU (a third of numpy's import) that a one-shot ``holecli detect`` or each
batch worker paid for nothing.
"""

from __future__ import annotations

import os
import sys
import threading

#: The variables BLAS libraries read their thread count from when they load (OpenBLAS, numpy's and
#: scipy's from PyPI; MKL, in conda's numpy).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
from contextlib import contextmanager

_depth = 0
_controller = None


@contextmanager
def single_blas_thread():
    """Run the block with every BLAS library limited to one thread (in the main thread only).

    Yields
    ------
    None
    """
    global _depth
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    limiter = _limit_blas(1) if _depth == 0 else None
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        if limiter is not None:
            limiter.restore_original_limits()


def _limit_blas(threads):
    """A threadpoolctl limiter that caps the BLAS libraries loaded at the first call at ``threads``."""
    global _controller
    from threadpoolctl import ThreadpoolController

    if _controller is None:
        _controller = ThreadpoolController()
    return _controller.limit(limits=threads, user_api="blas")


def start_blas_single_threaded(environ=None):
    """Have the BLAS libraries start with one thread, unless the user has set their thread count.

    Sets each of :data:`BLAS_THREAD_VARIABLES` that is unset to ``"1"`` in ``environ`` (the process's
    environment by default, which worker processes inherit). It takes effect only if numpy is not yet
    imported, so it is called first thing by the ``holecli`` program; a library user's process is left
    alone.

    Parameters
    ----------
    environ : MutableMapping, optional
        The environment to set (default ``os.environ``).

    Returns
    -------
    list of str
        The variables that were set.
    """
    environ = os.environ if environ is None else environ
    unset = [name for name in BLAS_THREAD_VARIABLES if not environ.get(name)]
    for name in unset:
        environ[name] = "1"
    return unset
