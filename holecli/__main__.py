"""The ``holecli`` program (also ``python -m holecli``).

Signals are handled before anything heavy is imported (see :mod:`holecli.interrupts`), and stderr
carries holecli's own messages only: library warnings (numpy's ``RuntimeWarning``) are silenced
unless warnings were asked for with ``-W`` or ``PYTHONWARNINGS``.
"""

import sys

from holecli import interrupts


def main():
    """Run the ``holecli`` program: signal handlers first, then the command line.

    Returns
    -------
    None
        Exits the process with the command's exit code.
    """
    interrupts.install()
    if not sys.warnoptions:
        import warnings

        warnings.simplefilter("ignore")
    from holecli.cli import main as command_line

    return command_line()


if __name__ == "__main__":
    sys.exit(main())
