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
"""

from __future__ import annotations

import threading
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
