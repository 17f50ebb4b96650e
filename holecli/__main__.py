"""The ``holecli`` program (also ``python -m holecli``).

Signals are handled before anything heavy is imported (see :mod:`holecli.interrupts`), and stderr
carries holecli's own messages only: library warnings (numpy's ``RuntimeWarning``) are silenced
unless warnings were asked for with ``-W`` or ``PYTHONWARNINGS``. BLAS starts with one thread unless
``OPENBLAS_NUM_THREADS`` (or ``MKL_NUM_THREADS``) says otherwise (see :mod:`holecli.threads`).
"""

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

    return command_line()


if __name__ == "__main__":
    sys.exit(main())
