"""Writing a command's outputs: all of them or none (:func:`write_outputs`), one to stdout or a file
(:func:`emit`)."""

from __future__ import annotations

import errno
import os

from holecli.cli.exits import EXIT_INPUT, Failure, write_stdout

def emit(text, output, what="output"):
    """Write ``text`` to stdout, or to the ``--output`` file: :func:`write_outputs` with one output.

    Parameters
    ----------
    text : str
        The whole output.
    output : str or None
        None or ``-`` for stdout; else a file (see :func:`write_outputs`).
    what : str
        What it is, for the error message (``cannot write output``).

    Returns
    -------
    None

    Raises
    ------
    Failure
        With the input/output code, when the output cannot be written.
    """
    write_outputs([(output, text, what)])


def write_outputs(outputs):
    """Write every output of a run, all or none (:class:`holecli.io.outfile.Outputs`).

    Every file is first written whole into a temporary next to it; only when all of them are, and
    every device or FIFO is open (one without a reader is refused), do the streams get their data
    (stdout first, as given) and the temporaries replace their files. A failure anywhere replaces no
    file and prints nothing: an earlier result stays as it was.

    Parameters
    ----------
    outputs : list of (str or None, str or bytes, str)
        ``(path, content, what)``: the path (None or ``-``: stdout; a regular file, new path,
        symbolic link, device or FIFO as :func:`holecli.io.outfile.write_bytes` takes it); the
        content (text is written as UTF-8); what it is, for the error message (``"output"``,
        ``"the plot"``, ``"the corrected targets"``).

    Returns
    -------
    None

    Raises
    ------
    Failure
        With the input/output code, ``PATH: cannot write WHAT: <why>``, when an output cannot be
        written (stdout: see :func:`holecli.cli.exits.write_stdout`).
    BrokenPipeError
        When the reader of stdout or of a FIFO went away (handled by :func:`run_guarded`: 141).
    """
    from holecli.io.outfile import STDOUT, Outputs

    def to_stdout(payload):
        write_stdout(payload.decode("utf-8", "surrogateescape"))

    what_of = {}
    with Outputs(write_stdout=to_stdout) as transaction:
        try:
            for path, content, what in outputs:
                path = STDOUT if path is None else path
                what_of.setdefault(path, what)
                payload = content.encode("utf-8", "surrogateescape") if isinstance(content, str) else content
                transaction.add(path, payload)
            transaction.commit()
        except BrokenPipeError as error:  # a FIFO whose reader went away (see run_guarded)
            raise BrokenPipeError(errno.EPIPE, os.strerror(errno.EPIPE), error.filename) from None
        except OSError as error:
            path = error.filename if error.filename in what_of else None
            shown = path if path is not None else (error.filename or "output")
            raise Failure(f"{shown}: cannot write {what_of.get(path, 'output')}: {error.strerror or error}",
                          EXIT_INPUT) from None
