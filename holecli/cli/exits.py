"""Exit codes, and how a command body ends: :class:`Failure`, :func:`run_guarded`, :func:`write_stdout`.

Every command runs its body in :func:`run_guarded`: an expected failure becomes one line
``Error: <message>`` on stderr and its exit code, Ctrl-C and SIGTERM the exit with 130 (after the body
cleaned up), a reader of stdout that stopped reading (``| head -1``) the exit with 141
(:func:`broken_pipe`). The codes are documented here, in every ``--help`` (:data:`EXIT_CODES_HELP`,
:data:`BATCH_EXIT_CODES_HELP`) and in the docs (``docs/reference/exit-codes.md``).
"""

from __future__ import annotations

import os
import sys

import click

# Exit codes: documented here, in every --help and in docs/reference/exit-codes.md.
EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2  # click's own
EXIT_INPUT = 3
EXIT_NO_HOLE = 4
EXIT_OUT_OF_TOLERANCE = 5
EXIT_FILE_FAILED = 6
EXIT_WARNING = 7  # --fail-on-warning: a hole has a selected warning
EXIT_UNDECIDED = 8  # --decision-rule guarded: no check failed, but conformance of some is not proved
EXIT_INTERRUPTED = 130
# 128 + SIGPIPE (13), what a shell reports for a program killed by SIGPIPE (`yes | head -1` under
# `set -o pipefail`): the reader of the output stopped reading before its end.
EXIT_BROKEN_PIPE = 141

EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  a hole was measured (and, with tolerance options, every checked hole is in tolerance)\n"
    "  1  internal error (a bug: please report it)\n"
    "  2  usage error (bad option or argument; an output that is the same file as an input or as\n"
    "     another output)\n"
    "  3  input error: the file is missing, unreadable, malformed or has too few points; the --spec\n"
    "     file is unreadable or invalid; or an output cannot be written (then none is written)\n"
    "  4  no hole found (the record is still printed, with \"holes\": [])\n"
    "  5  out of tolerance: a checked hole is out of tolerance or has a check not measured, or a\n"
    "     nominal hole is missing (the record is still printed; takes precedence over 4)\n"
    "  6  holecli batch only: some file could not be measured\n"
    "  7  --fail-on-warning: a hole has one of the warnings given (the record is still printed;\n"
    "     5 and 8 take precedence)\n"
    "  8  undecided (--decision-rule guarded): no check failed and no nominal hole is missing, but a\n"
    "     check's value +- its expanded uncertainty straddles a limit, or its uncertainty is not\n"
    "     known (the record is still printed; 5 takes precedence over 8, 8 over 7 and 4)\n"
    "  130  interrupted (Ctrl-C or SIGTERM)\n"
    "  141  broken pipe: the reader of the output (| head -1) stopped reading before its end"
)

BATCH_EXIT_CODES_HELP = (
    "\b\nExit codes (the first that applies):\n"
    "  130  interrupted (Ctrl-C or SIGTERM): the finished records are written, none cut;\n"
    "       run again with --resume to measure the rest\n"
    "  141  broken pipe: the reader of the output (| head -1) stopped reading; the batch stopped\n"
    "       as when interrupted\n"
    "  2    usage error (bad option or argument)\n"
    "  3    input error: a PATH is missing or holds no point cloud, the --spec file is unreadable\n"
    "       or invalid, the output cannot be written or resumed, the --store cannot be opened\n"
    "       or written\n"
    "  5    some checked hole is out of tolerance or has a check not measured, or a nominal hole\n"
    "       is missing\n"
    "  8    --decision-rule guarded: no check failed, but some check is undecided (its value +- its\n"
    "       expanded uncertainty straddles a limit, or its uncertainty is not known)\n"
    "  6    some file could not be measured (its record has \"error\")\n"
    "  7    --fail-on-warning: some hole has one of the warnings given\n"
    "  4    some file has no hole\n"
    "  0    every file measured, each with a hole (and in tolerance, where tolerances are given)\n"
    "  1    internal error (a bug: please report it)"
)


def warned(codes, selected):
    """Whether warning ``codes`` (an iterable of strings) include one that ``--fail-on-warning`` selects.

    Parameters
    ----------
    codes : iterable of str
    selected : frozenset or None
        ``--fail-on-warning``'s value.

    Returns
    -------
    bool
    """
    if not selected:
        return False
    codes = set(codes)
    return bool(codes) if "any" in selected else bool(codes & selected)


def exit_code(tally, fail_on_warning=None):
    """The exit code of a command from the counts of its records, by the documented precedence: the one
    place that derives it, for ``detect``, ``batch``, ``plot`` and ``register``.

    Parameters
    ----------
    tally : holecli.tally.Tally
        The counts of every record of the command (one record for ``detect`` and ``plot``; for
        ``register`` a failed verdict counts as out of tolerance, an outlier or inconsistent holes as
        undecided).
    fail_on_warning : frozenset, optional
        ``--fail-on-warning``.

    Returns
    -------
    int
        :data:`EXIT_OUT_OF_TOLERANCE`, else :data:`EXIT_UNDECIDED` (a hole with an undecided check and
        none failed, ``--decision-rule guarded``), else :data:`EXIT_FILE_FAILED`, else
        :data:`EXIT_WARNING` (a hole has a warning that ``fail_on_warning`` selects), else
        :data:`EXIT_NO_HOLE`, else :data:`EXIT_OK` (an interrupt, 130, is decided by the command).
    """
    if tally.out_of_tolerance or tally.missing:
        return EXIT_OUT_OF_TOLERANCE
    if tally.undecided:
        return EXIT_UNDECIDED
    if tally.failed:
        return EXIT_FILE_FAILED
    if warned(tally.warning_codes, fail_on_warning):
        return EXIT_WARNING
    if tally.without_hole:
        return EXIT_NO_HOLE
    return EXIT_OK


class Failure(Exception):
    """A failure already phrased for the user: ``Error: <message>`` and an exit code."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


def fail(message, code):
    """Print ``Error: <message>`` on stderr and exit with ``code``.

    Parameters
    ----------
    message : str
        One line, phrased for the user.
    code : int
        The exit code.

    Returns
    -------
    None

    Raises
    ------
    SystemExit
        Always.
    """
    click.echo(f"Error: {message}", err=True)
    sys.exit(code)


def run_guarded(function, *args, **kwargs):
    """Run a command body, turning every expected failure into one line on stderr and an exit code.

    Within it SIGINT and SIGTERM raise KeyboardInterrupt (see :mod:`holecli.interrupts`), so that a
    write in progress cleans up after itself before the exit with 130.

    Parameters
    ----------
    function : callable
        The command's body.
    *args, **kwargs
        Its arguments.

    Returns
    -------
    object
        What ``function`` returns.

    Raises
    ------
    SystemExit
        With the code of a :class:`Failure` (after ``Error: <message>`` on stderr), with
        :data:`EXIT_INTERRUPTED` after a signal (``Error: interrupted``), or with
        :data:`EXIT_BROKEN_PIPE` when the reader of the output went away (see :func:`broken_pipe`).
    Exception
        Anything else ``function`` raises without a signal: a bug, shown with its traceback.
    """
    from holecli import interrupts

    try:
        with interrupts.raising():
            result = function(*args, **kwargs)
            interrupts.check()  # a signal whose KeyboardInterrupt was swallowed on the way
            return result
    except Failure as failure:
        if interrupts.received() is None:
            fail(str(failure), failure.code)
        _interrupted()
    except KeyboardInterrupt:
        _interrupted()
    except BrokenPipeError as error:
        # The reader of the output went away (e.g. `| head -1`): nothing more to say to it.
        broken_pipe(error.filename or "stdout")
        sys.exit(EXIT_BROKEN_PIPE)
    except Exception:
        # A signal's KeyboardInterrupt can come out as another exception (an ImportError, when it hit
        # a C extension's initialisation inside an import): after a signal, that is the interrupt.
        if interrupts.received() is None:
            raise
        _interrupted()


def _interrupted():
    """Say so and leave with 130 (see :func:`run_guarded`)."""
    from holecli import interrupts

    click.echo("Error: interrupted", err=True)
    # The body has cleaned up (its finally blocks ran on the way here). Leave at once: a
    # KeyboardInterrupt that hit a C extension's initialisation can make CPython end the process by
    # SIGINT at exit (status -2) instead of with the code asked for.
    if interrupts.installed():
        try:
            sys.stdout.flush()
        except OSError:
            pass
        os._exit(EXIT_INTERRUPTED)
    sys.exit(EXIT_INTERRUPTED)


def write_stdout(text):
    """Write ``text`` to stdout at once.

    Parameters
    ----------
    text : str
        Whole lines; written as UTF-8 (a file name that is not UTF-8 as its own bytes).

    Returns
    -------
    None

    Raises
    ------
    Failure
        With the input/output code, when stdout cannot be written (a full disk behind a
        redirection); stdout is then detached, so that the exit does not try again.
    BrokenPipeError
        When the reader of stdout went away (handled by :func:`run_guarded`).
    """
    try:
        stream = getattr(sys.stdout, "buffer", None)
        if stream is None:
            sys.stdout.write(text)
        else:
            # UTF-8 bytes, a file name that is not UTF-8 as its own bytes (as ls prints it)
            sys.stdout.flush()
            stream.write(text.encode("utf-8", "surrogateescape"))
            stream.flush()
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except OSError as error:
        _detach_stdout()
        raise Failure(f"stdout: cannot write output: {error.strerror or error}", EXIT_INPUT) from None


def broken_pipe(name, message=None):
    """Deal with a reader of the output that went away: stdout pointed at /dev/null, one line on stderr.

    Afterwards nothing that stdout still buffers can fail again at the interpreter's exit (no
    ``Exception ignored ... BrokenPipeError``); when stderr is that pipe too (``2>&1 | head -1``),
    the line is dropped and stderr is pointed at /dev/null as well.

    Parameters
    ----------
    name : str
        The output whose reader went away (``"stdout"``, or a FIFO given as ``--output``).
    message : str, optional
        The line to print instead of ``Error: <name>: broken pipe (...)``.

    Returns
    -------
    None
    """
    _detach_stdout()
    try:
        click.echo(message or f"Error: {name}: broken pipe (its reader stopped reading before the end)", err=True)
    except (OSError, ValueError):
        _detach(sys.stderr)


def _detach_stdout():
    # What stdout still buffers would be flushed again at exit, and fail again, with a traceback
    # of the interpreter's own: point the descriptor at /dev/null instead.
    _detach(sys.stdout)


def _detach(stream):
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, stream.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass
