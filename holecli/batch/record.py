"""The record of one file of a batch (:func:`measure_record`: :func:`holecli.measure_scan`, its
failures turned into error records), its picture in a plot folder, and what the messages call a file.
"""

from __future__ import annotations

import os

from holecli import __version__
from holecli.inspection import scan_stem
from holecli.measure import MeasureError, measure_scan, resolved_path
from holecli.results import SCHEMA_VERSION


class FileTimeout(BaseException):
    """Raised in a batch worker when its file's time limit has passed (from a SIGALRM handler).

    A BaseException, so that no ``except Exception`` of the pipeline or a library takes it for one of
    its own errors and goes on.
    """


# What measure_record lets through rather than turning it into an error record: requests to stop
# (which a caller outside a batch worker expects to get) and a file's time limit (its own message).
_PASSED_ON = (KeyboardInterrupt, SystemExit, GeneratorExit, FileTimeout)


def measure_record(path, options, spec=None, explain=False, scan=None, units=None, plot_file=None) -> dict:
    """The record of one file.

    Parameters
    ----------
    path : str
        The point-cloud file.
    options : dict
        Keyword arguments of :func:`holecli.detect_file`: those of :func:`holecli.detect`, and
        ``input_format``.
    spec : holecli.tolerance.Spec or holecli.inspection.Inspection, optional
        Tolerances to check the holes against (an Inspection: mapped by a registration, holes tied
        by name; see :func:`holecli.inspection.check_record`).
    explain : bool
        Also give the record ``rejected``, the candidates that are not holes (``detect --explain``).
    scan : int, optional
        The scan of an E57 file (default: every scan, merged).
    units : holecli.units.UnitChoice, optional
        The file's unit and the record's (``--units``, ``--output-units``): the record is converted
        (:meth:`holecli.units.UnitChoice.express`) before the tolerance check, whose values are in
        the output unit.
    plot_file : str, optional
        Also draw the holes into this PNG (:func:`holecli.plot.figure`, with the verdict when
        ``spec`` is given; matplotlib, the extra ``plot``), written atomically. A PNG that cannot be
        written (or drawn) makes the record an error record whose message still gives the result
        (the holes found, their diameters, the verdict): the error record has no other field.

    Returns
    -------
    dict
        The ``detect`` record (``Detection.to_dict()`` of :func:`holecli.detect_file`, and the
        verdicts of :func:`holecli.tolerance.check` when ``spec`` is given) and ``path``, the file's
        :func:`resolved_path`; for a file that cannot be measured ``{"file": path, "path": ...,
        "error": message}``. An unexpected exception (a bug) becomes such an
        error record too, so that one file cannot stop a batch.
    """
    resolved = resolved_path(path)
    try:
        measurement = measure_scan(path, scan=scan, units=units, spec=spec, explain=explain,
                                   plot=plot_file is not None, resolve_path=True, **options)
    except MeasureError as error:
        return error_record(path, str(error), resolved)
    except _PASSED_ON:
        raise
    except BaseException as error:  # noqa: BLE001 - a bug in one file must not stop the batch
        # BaseException: a Rust library's panic (lazrs, through pyo3: PanicException) is not an Exception
        return error_record(path, internal_error_message(path, error), resolved)
    record = measurement.record
    if plot_file is not None:
        problem = _draw(plot_file, measurement)
        if problem is not None:
            return error_record(path, f"{problem} ({path} was measured: {_result_text(record)})", resolved)
    return record


def internal_error_message(path, error) -> str:
    """The one-line message of an unexpected exception (a bug, in holecli or in a library) raised
    while measuring ``path``.

    Parameters
    ----------
    path : str or os.PathLike
    error : BaseException

    Returns
    -------
    str
    """
    try:
        text = str(error)
    except BaseException:  # noqa: BLE001 - even its message may fail
        text = "(its message cannot be shown)"
    problem = " ".join(f"{type(error).__name__}: {text}".splitlines())
    return f"{path}: internal error (a bug: please report it; holecli detect shows the traceback): {problem}"


def _draw(plot_file, measurement):
    """Draw a file's holes into ``plot_file`` (:meth:`holecli.measure.Measurement.png`); None, or the
    one-line message of why not."""
    from holecli.io.outfile import write_bytes

    try:
        payload = measurement.png()
    except Exception as error:  # noqa: BLE001 - a bug in the drawing must not stop the batch
        problem = " ".join(f"{type(error).__name__}: {error}".splitlines())
        return f"{plot_file}: internal error (a bug: please report it) drawing the plot: {problem}"
    try:
        write_bytes(plot_file, payload)
    except OSError as error:
        return f"{plot_file}: cannot write the plot: {error.strerror or error}"
    return None


def _result_text(record):
    """The result of a record in a few words: ``1 hole, diameter 2.4981 mm; out of tolerance``."""
    holes = record.get("holes", ())
    unit = f" {record['units']}" if record.get("units") else ""
    text = f"{len(holes)} hole{'' if len(holes) == 1 else 's'}"
    if holes:
        shown = ", ".join(f"{hole['diameter']:.4f}" for hole in holes[:4]) + (", ..." if len(holes) > 4 else "")
        text += f", diameter{'' if len(holes) == 1 else 's'} {shown}{unit}"
    verdict = record.get("verdict")
    if verdict is not None:
        text += "; " + ("in tolerance" if verdict["in_tolerance"] else "out of tolerance"
                        if verdict["out_of_tolerance"] or verdict["missing"] else "undecided")
    return text


def plot_files(paths, folder) -> dict:
    """The PNG of each scan in the plot folder: its stem, made unique by ``-2``, ``-3``, ...

    Parameters
    ----------
    paths : sequence of str
        Every scan of the batch, in input order (those already done by an earlier run too, so that
        a resumed run names its scans as the first did).
    folder : str
        The plot folder.

    Returns
    -------
    dict
        ``{path: folder/<stem>.png}``; the second scan with a stem (compared case-insensitively, for
        the file systems that do) gets ``<stem>-2.png``, the third ``<stem>-3.png``, skipping a name
        already taken.

    Examples
    --------
    >>> plot_files(["a/x.ply", "b/x.ply", "x-2.csv", "c/X.pcd"], "plots")
    {'a/x.ply': 'plots/x.png', 'b/x.ply': 'plots/x-2.png', 'x-2.csv': 'plots/x-2-2.png', 'c/X.pcd': 'plots/X-3.png'}
    """
    taken, files = set(), {}
    for path in paths:
        stem = scan_stem(path) or "scan"
        name, number = stem, 1
        while name.casefold() in taken:
            number += 1
            name = f"{stem}-{number}"
        taken.add(name.casefold())
        files[path] = os.path.join(folder, name + ".png")
    return files


def error_record(path, message, resolved=None) -> dict:
    """The record of a file that could not be measured.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    message : str
        Why, in one line.
    resolved : str, optional
        Its :func:`resolved_path` (computed when not given).

    Returns
    -------
    dict
        ``{"schema_version", "holecli_version", "file", "path", "error"}``.
    """
    return {"schema_version": SCHEMA_VERSION, "holecli_version": __version__, "file": str(path),
            "path": resolved_path(path) if resolved is None else resolved, "error": message}
