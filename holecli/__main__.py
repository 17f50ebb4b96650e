"""The ``holecli`` program (also ``python -m holecli``).

Signals are handled before anything heavy is imported (see :mod:`holecli.interrupts`), and stderr
carries holecli's own messages only: library warnings (numpy's ``RuntimeWarning``) are silenced
unless warnings were asked for with ``-W`` or ``PYTHONWARNINGS``. BLAS starts with one thread unless
``OPENBLAS_NUM_THREADS`` (or ``MKL_NUM_THREADS``) says otherwise (see :mod:`holecli.threads`).

When the command is done, the garbage it left is collected and what is still alive is frozen
(:func:`prepare_exit`): the interpreter's teardown then no longer walks and frees, object by object, the
modules numpy and scipy are made of, which took a one-shot ``holecli detect`` some 20-30 ms of its 0.4 s
(not after a command that used process pools).
"""

import gc
import sys

from holecli import interrupts, threads


def main():
    """Run the ``holecli`` program: signal handlers first, then the command line.

    Returns
    -------
    None
        Exits the process with the command's exit code.
    """
    interrupts.install()
    threads.start_blas_single_threaded()  # before numpy is imported (see holecli.threads)
    if not sys.warnoptions:
        import warnings

        warnings.simplefilter("ignore")
    from holecli.cli import main as command_line

    try:
        return command_line()
    finally:
        prepare_exit()


def prepare_exit():
    """Make the interpreter's exit cheap: collect the garbage now, then freeze what is left.

    The collection finalizes every unreachable object as the interpreter's own last collection would
    (``__del__`` methods and weak reference callbacks run). :func:`gc.freeze` then moves the living
    objects (mostly the imported modules' functions, classes and tables) out of the collector's reach,
    so that the collections of the teardown skip them: they are freed with the process, as they would be
    by ``os._exit``, but the exit stays the ordinary one (``atexit`` handlers run, threads are joined,
    and standard output and error are flushed).

    Not after a command that used process pools (``batch``, ``serve``: :mod:`multiprocessing` is
    imported): their semaphores, pipes and shared memory are released by finalizers at the exit, which
    must see every object; the few milliseconds matter only to a one-shot ``detect``.

    Returns
    -------
    None
    """
    if "multiprocessing" in sys.modules:
        return
    gc.collect()
    gc.freeze()


if __name__ == "__main__":
    sys.exit(main())
