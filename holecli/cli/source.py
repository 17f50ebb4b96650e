"""Standard input as a scan (SCAN ``-``): the name that means it, the refusal without
``--input-format``, and the reading of the cloud on it."""

from __future__ import annotations

import os
import sys

import click

from holecli.cli.exits import EXIT_INPUT, Failure
from holecli.cli.options import INPUT_FORMATS

# The SCAN that means standard input.
STDIN = "-"


def check_stdin_format(scan, input_format):
    """Refuse SCAN ``-`` (standard input) without ``--input-format``: a stream has no extension.

    Raises
    ------
    click.UsageError
    """
    if scan == STDIN and input_format is None:
        raise click.UsageError(f"SCAN - (stdin) needs --input-format {'|'.join(INPUT_FORMATS)}: "
                               "a stream has no extension to tell its format")


def read_stdin(input_format, scan=None, columns=None):
    """The cloud on standard input (``holecli detect -``), read by :func:`holecli.io.read_stream`.

    Parameters
    ----------
    input_format : str
        ``--input-format``.
    scan : int, optional
        ``--scan`` (an E57 stream's scan).
    columns : tuple, optional
        ``--columns`` (a text table's x, y, z columns).

    Returns
    -------
    holecli.io.Cloud
        Named ``<stdin>``.

    Raises
    ------
    LoadError
        When stdin is a terminal (nothing is piped in: reading would wait for typing), is too long
        (:data:`holecli.io.MAX_STREAM_BYTES`) or holds no valid cloud of the format.
    """
    from holecli.errors import LoadError
    from holecli.io import STDIN_NAME, read_stream

    stream = getattr(sys.stdin, "buffer", sys.stdin)  # the bytes: binary PLY and PCD
    if stream is None:  # started with stdin closed (<&-)
        raise LoadError(STDIN_NAME, "closed: there is no standard input to read")
    try:
        terminal = os.isatty(stream.fileno())
    except (OSError, ValueError):  # no descriptor (a test's stream): not a terminal
        terminal = False
    if terminal:
        raise LoadError(STDIN_NAME, f"is a terminal: pipe or redirect a cloud into it "
                                    f"(holecli detect - --input-format {input_format} < scan.{input_format})")
    return read_stream(stream, input_format, scan=scan, columns=columns)


def measure(scan, options, scan_index=None, **how):
    """:func:`holecli.measure_scan` of a SCAN argument (a file, or ``-``: standard input, read by
    :func:`read_stdin`), its failures phrased for the user.

    Parameters
    ----------
    scan : str
        SCAN as given; ``-`` is standard input.
    options : dict
        Keyword arguments of :func:`holecli.detect` (see :func:`holecli.cli.options.detection_options`)
        and, with ``--input-format``, ``input_format`` (needed for standard input), with
        ``--columns``, ``columns``.
    scan_index : int, optional
        ``--scan``: the scan of an E57 file (default: every scan).
    **how
        Keyword arguments of :func:`holecli.measure_scan`: ``units``, ``spec``, ``explain``, ``plot``.

    Returns
    -------
    holecli.measure.Measurement

    Raises
    ------
    Failure
        With the input-error code, when the scan cannot be read or measured (the message of
        :func:`holecli.measure.failure_message`, as ``holecli batch`` records it), or its record not
        checked (a scan tied to a hole by ``--name`` that holds several).
    """
    from holecli.io import STDIN_NAME
    from holecli.measure import MeasureError, measure_scan

    options = dict(options)
    input_format = options.pop("input_format", None)
    columns = options.pop("columns", None)
    read = None
    if scan == STDIN:
        def read():
            return read_stdin(input_format, scan_index, columns)
    try:
        return measure_scan(scan, read=read, name=STDIN_NAME if scan == STDIN else None, scan=scan_index,
                            input_format=input_format, columns=columns, **how, **options)
    except MeasureError as error:
        if error.stage == "units":  # (refused by the options before: a bug, shown with its traceback)
            raise error.__cause__ from None
        raise Failure(str(error), EXIT_INPUT) from None
