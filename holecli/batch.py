"""Measure many scans: find the files, measure them in worker processes, stream and resume the records.

The command line's ``holecli batch`` is a thin layer over this module:

* :func:`find_scans` turns files and folders into a sorted list of point-cloud files;
* :func:`measure_record` is the record of one file (the ``detect`` record, with the tolerance
  verdicts of a spec, or ``{"file", "error"}``);
* :func:`measure_all` runs it in a pool of worker processes and yields each record as its file
  finishes;
* :class:`RecordWriter` writes each record as JSON Lines or CSV with one write and a flush, so that an
  interrupted run leaves only whole lines;
* :class:`BatchOutput` holds the output file locked for the run and, to resume, reads what an
  interrupted run wrote (cutting off a partial last line); :func:`files_to_do` leaves out the files
  already there, and :class:`Tally` counts records for the summary and the exit code.

Nothing here prints or exits, and nothing imports click.
"""

from __future__ import annotations

import csv
import fnmatch
import importlib
import io
import json
import math
import os
import re
import signal
import stat
import time
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass, field

from holecli.errors import HoleCliError, LoadError
from holecli.io import SUPPORTED_EXTENSIONS
from holecli.report import BATCH_CSV_COLUMNS, CSV_COLUMNS, csv_text, to_json_line

__all__ = ["DEFAULT_FILE_TIMEOUT", "FORMATS", "BatchOutput", "FileSummary", "FileTimeout", "OutputBusyError",
           "RecordWriter", "ResumeError", "ResumeOptionsError", "Tally", "default_jobs", "error_record", "failure_message", "files_to_do",
           "find_scans", "internal_error_message", "measure_all", "measure_record", "plot_files", "resolved_path",
           "scan_stem", "timeout_message", "unlistable_message"]

FORMATS = ("jsonl", "csv")

# The batch CSV header before the provenance columns (schema 1, records without schema_version).
_SCHEMA_1_COLUMNS = CSV_COLUMNS[:CSV_COLUMNS.index("schema_version")] + ("error", "path")
# The batch CSV header of schema 2.1 (and 2.0 since the decision rules), before the notes column.
_SCHEMA_2_1_COLUMNS = CSV_COLUMNS[:CSV_COLUMNS.index("notes")] + ("error", "path")
# The batch CSV header of schema 2.2 before issue 25's u_* columns.
_SCHEMA_2_2_COLUMNS = CSV_COLUMNS[:CSV_COLUMNS.index("u_center_in_plane")] + ("error", "path")

# Files handed to the pool ahead of the free workers, per worker: enough to keep every worker busy
# while the parent writes, few enough that an interrupt has little queued work to throw away.
_QUEUED_PER_WORKER = 2

# A binary_compressed PCD needs open3d; its header (a dozen short lines) is within this many bytes.
_PCD_HEADER_BYTES = 4096
_COMPRESSED_PCD = re.compile(rb"^DATA[ \t]+binary_compressed\b", re.IGNORECASE | re.MULTILINE)


#: Seconds a worker may spend on one file (``--file-timeout``; 0 or None: no limit): far more than a
#: scan of 10^7 points takes, so that only a file that makes a reader or a library loop or wait
#: forever reaches it.
DEFAULT_FILE_TIMEOUT = 600.0


class FileTimeout(BaseException):
    """Raised in a batch worker when its file's time limit has passed (from a SIGALRM handler).

    A BaseException, so that no ``except Exception`` of the pipeline or a library takes it for one of
    its own errors and goes on.
    """


# What measure_record lets through rather than turning it into an error record: requests to stop
# (which a caller outside a batch worker expects to get) and a file's time limit (its own message).
_PASSED_ON = (KeyboardInterrupt, SystemExit, GeneratorExit, FileTimeout)


class ResumeError(HoleCliError, ValueError):
    """The output file of an earlier run cannot be resumed: it is not a batch output of this format."""


# --------------------------------------------------------------------------------------------------
# Finding the files


def find_scans(paths, recursive=False, pattern=None, exclude=(), input_format=None, exclude_folders=(),
               unlistable=None) -> list:
    """The point-cloud files to measure, sorted, each once.

    Parameters
    ----------
    paths : sequence of str
        Files and folders. A file is taken as it is (a file holecli cannot read gives an error record
        later). A folder contributes the files directly in it whose extension (any case) is one
        holecli reads (with ``input_format``: every file, whatever its extension); with ``recursive``
        also those in its subfolders. Hidden files and folders (a name starting with ``.``) are
        skipped, and symbolic links to folders are not followed.
    recursive : bool
        Also look in subfolders.
    pattern : str, optional
        A glob the files found in folders must also match, case-insensitively: against the file
        name, or against the path below the given folder when the pattern holds a ``/``.
    exclude : iterable of str
        Files to leave out (the batch's own output file).
    input_format : str, optional
        The format every file will be read in (``--input-format``): the extension then no longer
        selects the files of a folder, only ``pattern`` does.
    exclude_folders : iterable of str
        Folders none of whose files (at any depth, symbolic links resolved) are taken, even when
        given by name (the batch's plot folder: with ``input_format`` its PNGs would be).
    unlistable : list, optional
        Where to put each subfolder that cannot be listed (no permission, a name too long for the
        system), as ``(folder, message)``, its message one line (see :func:`unlistable_message`);
        the batch gives each an error record. Without it such a subfolder raises LoadError: a
        folder's files are never silently left out.

    Returns
    -------
    list of str
        Paths spelled from the given ones (``folder/name``), sorted; a file reached twice (given
        twice, or given and found in a folder) is listed once, under the first spelling in order.

    Raises
    ------
    LoadError
        When a path does not exist, or a folder given cannot be listed (or a subfolder, without
        ``unlistable``).
    """
    excluded = {os.path.realpath(path) for path in exclude}
    found, not_listed = [], []
    for path in paths:
        path = os.fspath(path)
        if os.path.isdir(path):
            found.extend(_scan_folder(path, recursive, pattern, any_extension=input_format is not None,
                                      unlistable=not_listed))
        elif os.path.exists(path):
            found.append(path)
        else:
            raise LoadError(path, "no such file or folder")
    folders = [os.path.realpath(folder) for folder in exclude_folders]
    unique, seen = [], set(excluded)
    for path in sorted(found):
        real = os.path.realpath(path)
        if any(os.path.commonpath([real, folder]) == folder for folder in folders):
            continue
        if real not in seen:
            seen.add(real)
            unique.append(path)
    if not_listed and unlistable is None:
        raise LoadError(not_listed[0][0], not_listed[0][1].split(": ", 1)[1])
    if unlistable is not None:
        unlistable.extend(sorted(not_listed))
    return unique


def unlistable_message(folder, error) -> str:
    """The one-line message of a subfolder that cannot be listed (its error record's).

    Parameters
    ----------
    folder : str
    error : OSError

    Returns
    -------
    str
    """
    return f"{folder}: cannot list this folder ({error.strerror or error}): its files are not measured"


def _scan_folder(folder, recursive, pattern, any_extension=False, unlistable=None):
    pattern = pattern.lower() if pattern else None

    def cannot_list(error):
        where = error.filename if error.filename is not None else folder
        if os.path.normpath(where) == os.path.normpath(folder):  # a folder given: an input error, as a missing one
            raise LoadError(folder, f"cannot list this folder: {error.strerror or error}")
        unlistable.append((where, unlistable_message(where, error)))

    for root, folders, names in os.walk(folder, onerror=cannot_list):
        folders[:] = sorted(name for name in folders if not name.startswith("."))
        for name in names:
            if name.startswith("."):
                continue
            if not any_extension and os.path.splitext(name)[1].lower() not in SUPPORTED_EXTENSIONS:
                continue
            path = os.path.join(root, name)
            if pattern:
                subject = os.path.relpath(path, folder).replace(os.sep, "/") if "/" in pattern else name
                if not fnmatch.fnmatchcase(subject.lower(), pattern):
                    continue
            if os.path.isfile(path):
                yield path
        if not recursive:
            break


def default_jobs() -> int:
    """The number of cores this process may run on.

    Returns
    -------
    int
        At least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


# --------------------------------------------------------------------------------------------------
# Measuring


def failure_message(path, error) -> str:
    """The one-line message of ``error`` raised while measuring ``path`` (what ``detect`` prints after
    ``Error: ``).

    Parameters
    ----------
    path : str or os.PathLike
    error : Exception
        A :class:`holecli.errors.LoadError` already names its file; any other is prefixed with it.

    Returns
    -------
    str
        One line.
    """
    message = str(error) if isinstance(error, LoadError) else f"{path}: {error}"
    return " ".join(message.splitlines())


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
    from holecli.pipeline import detect_file
    from holecli.units import UnitChoice

    resolved = resolved_path(path)
    try:
        if plot_file is None:
            detection = detect_file(path, **({} if scan is None else {"scan": scan}), **options)
        else:  # the points are drawn too
            from holecli.io import read_cloud
            from holecli.pipeline import read_and_detect

            reading = dict(options)
            input_format = reading.pop("input_format", None)
            columns = reading.pop("columns", None)
            detection, cloud = read_and_detect(
                lambda: read_cloud(path, scan=scan, input_format=input_format, columns=columns),
                scan=scan, input_format=input_format, columns=columns, **reading)
    except HoleCliError as error:
        return error_record(path, failure_message(path, error), resolved)
    except _PASSED_ON:
        raise
    except BaseException as error:  # noqa: BLE001 - a bug in one file must not stop the batch
        # BaseException: a Rust library's panic (lazrs, through pyo3: PanicException) is not an Exception
        return error_record(path, internal_error_message(path, error), resolved)
    try:
        record = (units or UnitChoice()).express(detection.to_dict(explain=explain), detection.units)
    except ValueError as error:  # an output unit without the file's
        return error_record(path, f"{path}: {error}", resolved)
    record["path"] = resolved
    if spec is not None:
        from holecli.inspection import check_record

        try:
            record = check_record(record, spec, path)
        except HoleCliError as error:  # a scan tied to a hole (--name) that holds several
            return error_record(path, str(error), resolved)
    if plot_file is not None:
        problem = _draw(plot_file, detection, cloud.points, record, spec is not None, units)
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


def _draw(plot_file, detection, points, record, checked, units):
    """Draw a file's holes into ``plot_file``; None, or the one-line message of why not."""
    from holecli import plot
    from holecli.io.outfile import write_bytes

    try:
        fig = plot.figure(detection, points, unit=units.file if units is not None else None,
                          checked=record["holes"] if checked else None, checked_unit=record.get("units"))
        payload = plot.png_bytes(fig)
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


def scan_stem(path) -> str:
    """A scan's file name without its extension (``scans/A1.ply`` -> ``A1``): what names its PNG
    in a plot folder and, in ``holecli register``, the hole it shows.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
    """
    return os.path.splitext(os.path.basename(os.path.normpath(os.fspath(path))))[0]


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
    from holecli import __version__
    from holecli.results import SCHEMA_VERSION

    return {"schema_version": SCHEMA_VERSION, "holecli_version": __version__, "file": str(path),
            "path": resolved_path(path) if resolved is None else resolved, "error": message}


def resolved_path(path) -> str:
    """The absolute path of ``path`` with every symbolic link resolved: what ``--resume`` matches
    files on, wherever the batch is run from.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
    """
    return os.path.realpath(os.fspath(path))


_WORKER = {}

# Descriptors of the parent that a forked worker must not keep open: the locked output file (a
# worker holding it would keep the lock after the parent is gone).
PARENT_ONLY_DESCRIPTORS = set()

_PR_SET_PDEATHSIG = 1


def _start_worker(options, spec, preload, parent, explain=False, timeout=None, reading=None):
    """Pool initializer: runs once in every worker process (``parent``: the batch's process id;
    ``explain``: records with their ``rejected`` list; ``timeout``: seconds per file, or None;
    ``reading``: the ``scan`` and ``units`` keyword arguments of :func:`measure_record` that are given)."""
    # The parent handles Ctrl-C and SIGTERM and then ends the workers; a worker must not die of the
    # terminal's SIGINT on its own (it would break the pool and lose its record).
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent)
    if timeout:
        import resource

        # A worker killed by its CPU limit (SIGXCPU) dumps no core: the file gets its error record.
        try:
            resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))
        except (ValueError, OSError):
            pass
    for descriptor in PARENT_ONLY_DESCRIPTORS:
        try:
            os.close(descriptor)
        except OSError:
            pass
    # Pay the heavy imports here, once per worker, rather than in the first file's measurement.
    importlib.import_module("holecli.pipeline")
    for name in preload:
        try:
            importlib.import_module(name)
        except (ImportError, OSError):
            pass  # the file that needs it reports the problem itself
    _WORKER.update(options=options, spec=spec, explain=explain, timeout=timeout, reading=reading or {})


def _die_with_parent(parent):
    """Have the kernel kill this worker when the batch's process dies, even by SIGKILL (Linux); a
    worker whose parent is already gone exits at once."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the pool's own checks end the worker later
        pass
    if os.getppid() != parent:
        os._exit(1)


def _measure_in_worker(path):
    """The record of ``path``, in a worker: always a record that can be sent to the parent.

    Whatever the file makes a reader or a library raise (a Rust panic, a KeyboardInterrupt or
    SystemExit of a library: the worker ignores SIGINT and is ended by the parent with SIGKILL, so
    none of them is a request to stop) becomes an error record here: an exception sent to the parent
    would end the batch there, or break the pool when it cannot be pickled. A file that takes longer
    than the time limit gets an error record too (:func:`_time_limit`).
    """
    reading = dict(_WORKER["reading"])
    plots = reading.pop("plots", None)
    if plots is not None and path in plots:
        reading["plot_file"] = plots[path]
    timeout = _WORKER.get("timeout")
    try:
        with _time_limit(timeout):
            record = measure_record(path, _WORKER["options"], _WORKER["spec"], _WORKER["explain"], **reading)
    except FileTimeout:
        record = error_record(path, timeout_message(path, timeout))
    except BaseException as error:  # noqa: BLE001 - see the docstring
        record = error_record(path, internal_error_message(path, error))
    return _sendable(path, record)


def timeout_message(path, timeout) -> str:
    """The message of a file that reached the batch's time limit (``--file-timeout``).

    Parameters
    ----------
    path : str or os.PathLike
    timeout : float
        The limit, in seconds.

    Returns
    -------
    str
    """
    return (f"{path}: not measured within the time limit of {timeout:g} s per file (--file-timeout): a reader or "
            f"a library looped or waited on this file, or the file is too large for the limit")


def _sendable(path, record):
    """``record``, or an error record when it cannot be pickled (sent to the parent)."""
    import pickle

    try:
        pickle.dumps(record)
    except BaseException as error:  # noqa: BLE001 - a record the pool cannot send would break it
        return error_record(path, f"{path}: internal error (a bug: please report it): its record cannot be sent to "
                                  f"the batch: {type(error).__name__}")
    return record


def _cpu_seconds():
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


@contextmanager
def _time_limit(seconds):
    """Limit the block to ``seconds`` (None or 0: no limit), in a worker's main thread.

    Two limits, for the two ways a file can hang a worker. SIGALRM after ``seconds`` of wall-clock
    time raises :class:`FileTimeout` as soon as Python code runs (a reader looping in Python, a
    blocked read, which the signal interrupts). A loop in native code never returns to Python, so a
    CPU limit backs it: the soft RLIMIT_CPU is set to the CPU time used so far plus ``seconds`` times
    the cores the worker may use (all its threads count, so that a file measured in several threads
    is not cut before its wall-clock limit), and put back after the block. Past it the kernel sends
    SIGXCPU, which kills the worker; :func:`measure_all` then gives the file an error record.
    """
    if not seconds:
        yield
        return
    import resource

    def expired(number, frame):
        raise FileTimeout

    previous_handler = signal.signal(signal.SIGALRM, expired)
    soft, hard = resource.getrlimit(resource.RLIMIT_CPU)
    budget = math.ceil(_cpu_seconds() + seconds * default_jobs()) + 1
    if hard != resource.RLIM_INFINITY:
        budget = min(budget, hard)
    limited = soft == resource.RLIM_INFINITY or budget < soft
    if limited:
        resource.setrlimit(resource.RLIMIT_CPU, (budget, hard))
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous_handler)
        if limited:
            resource.setrlimit(resource.RLIMIT_CPU, (soft, hard))


def measure_all(paths, options, spec=None, *, jobs=1, should_stop=None, poll_seconds=0.2, explain=False, scan=None,
                units=None, plots=None, file_timeout=None):
    """Measure ``paths`` in ``jobs`` worker processes and yield each record as its file finishes.

    Parameters
    ----------
    paths : sequence of str
        The files, measured in this order (records come in the order they finish).
    options : dict
        Keyword arguments of :func:`holecli.detect_file` (see :func:`measure_record`).
    spec : holecli.tolerance.Spec, optional
        Tolerances checked in the workers.
    jobs : int
        Worker processes (at most one per file). They live for the whole batch: the heavy imports
        (the pipeline, and open3d when a binary_compressed PCD is among the files) are paid once per
        worker, in the pool initializer.
    should_stop : callable, optional
        Called without arguments whenever files have finished (after their records are yielded) and
        at least every ``poll_seconds``; when it returns true the workers are ended at once and the
        generator returns. The records already yielded are the finished ones.
    poll_seconds : float
        See ``should_stop``.
    explain : bool
        Records with their ``rejected`` list (see :func:`measure_record`).
    scan : int, optional
        The scan of each E57 file (see :func:`measure_record`).
    units : holecli.units.UnitChoice, optional
        The file's and the record's units (see :func:`measure_record`).
    plots : dict, optional
        ``{path: PNG}`` (:func:`plot_files`): each file's holes are also drawn, in the worker that
        measures it (see ``plot_file`` of :func:`measure_record`).
    file_timeout : float, optional
        Seconds a worker may spend on one file (None or 0: no limit): past them the file gets an
        error record (:func:`timeout_message`) and the batch goes on. Wall-clock time while Python
        code runs; a loop in native code is ended by a CPU limit of as many seconds per core, which
        kills the worker (see :func:`_time_limit`).

    Yields
    ------
    dict
        The record of each file, see :func:`measure_record`. Whatever a file makes a library raise
        becomes its error record. A file whose worker process dies (a crash in a library, the
        out-of-memory killer, a kill from outside, the CPU limit of ``file_timeout``) is measured
        again alone in a fresh pool, and gets an error record when that worker dies too.
    """
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    should_stop = should_stop or (lambda: False)
    waiting = deque(paths)
    suspects = deque()  # files in flight when a worker died: each is run alone to find the culprit
    alone = set()
    submitted = {}  # path: when it was last given to a worker (time.monotonic)
    context = _pool_context()
    input_format = options.get("input_format")
    preload = ("open3d",) if any(_is_compressed_pcd(path, input_format) for path in paths) else ()
    # --scan and --units/--output-units, passed on only when given
    reading = {key: value for key, value in (("scan", scan), ("units", units), ("plots", plots)) if value is not None}
    while waiting or suspects:
        executor = ProcessPoolExecutor(max_workers=max(1, min(jobs, len(waiting) + len(suspects))),
                                       mp_context=context, initializer=_start_worker,
                                       initargs=(options, spec, preload, os.getpid(), explain, file_timeout or None)
                                       + ((reading,) if reading else ()))
        in_flight = {}
        finished = False
        try:
            while waiting or suspects or in_flight:
                solo = bool(suspects) or any(path in alone for path in in_flight.values())
                limit = 1 if solo else jobs * _QUEUED_PER_WORKER
                while len(in_flight) < limit and (suspects or waiting):
                    path = suspects.popleft() if suspects else waiting.popleft()
                    in_flight[executor.submit(_measure_in_worker, path)] = path
                    submitted[path] = time.monotonic()
                done, _ = wait(in_flight, timeout=poll_seconds, return_when=FIRST_COMPLETED)
                records, broken = [], []
                for future in done:
                    path = in_flight.pop(future)
                    try:
                        records.append(future.result())
                    except BrokenProcessPool:
                        broken.append(path)
                    except BaseException as error:  # noqa: BLE001 - a worker sends records only; never lose a file
                        records.append(error_record(path, internal_error_message(path, error)))
                yield from records
                if broken:
                    # Every file in flight fails with the pool. A file that was measured alone in
                    # its own pool is known to be the one that killed its worker; every other one is
                    # measured again, alone (the killer may have been the out-of-memory killer, or
                    # a signal from outside, rather than the file).
                    wait(in_flight)
                    for future, path in in_flight.items():
                        if future.exception() is None:
                            yield future.result()
                        else:
                            broken.append(path)
                    in_flight.clear()
                    out_of_time = _a_worker_ran_out_of_cpu_time(executor)
                    for path in sorted(broken):
                        # Killed alone by its CPU limit: the exit status says so when the pool still
                        # holds the dead worker; the pool may have dropped it already (a loaded machine),
                        # and a worker alone that died after the time limit ran out was killed by it.
                        overran = file_timeout and time.monotonic() - submitted.get(path, math.inf) >= file_timeout
                        if path in alone and file_timeout and (out_of_time or overran):
                            yield error_record(path, timeout_message(path, file_timeout))
                        elif path in alone:
                            yield error_record(path, f"{path}: the worker process measuring this file died twice, "
                                                     f"the second time measuring it alone (a crash in a library, "
                                                     f"or out of memory)")
                        else:
                            suspects.append(path)
                            alone.add(path)
                    break
                if should_stop():
                    return
            finished = True
        finally:
            _end_pool(executor, graceful=finished)


def _a_worker_ran_out_of_cpu_time(executor):
    """Whether a worker of the broken pool ``executor`` was killed by its CPU limit (SIGXCPU)."""
    processes = list((getattr(executor, "_processes", None) or {}).values())
    for process in processes:
        try:
            process.join(timeout=5)
        except (OSError, ValueError, AssertionError):
            continue
    return any(getattr(process, "exitcode", None) == -signal.SIGXCPU for process in processes)


def _pool_context():
    import multiprocessing

    # fork: a worker starts at once with what the parent has imported (numpy, the readers) and pays
    # only the pipeline's imports, in parallel with the other workers and with the parent's own
    # start. The parent has no other thread when it forks (the progress display is refreshed by hand).
    if "fork" in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


def _end_pool(executor, graceful):
    if not graceful:
        # The workers ignore SIGINT; kill them rather than wait for the files they are measuring.
        for process in list((getattr(executor, "_processes", None) or {}).values()):
            try:
                process.kill()
            except (OSError, ValueError):
                pass
    executor.shutdown(wait=True, cancel_futures=True)


def _is_compressed_pcd(path, input_format=None) -> bool:
    if (input_format or os.path.splitext(str(path))[1].lower()[1:]) != "pcd":
        return False
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False  # never open a FIFO or a device here: it could block the batch forever
        with open(path, "rb") as stream:
            head = stream.read(_PCD_HEADER_BYTES)
    except OSError:
        return False
    return _COMPRESSED_PCD.search(head) is not None


# --------------------------------------------------------------------------------------------------
# Writing and resuming


class RecordWriter:
    """Writes records as JSON Lines or CSV, each with one write and a flush.

    Parameters
    ----------
    write : callable
        Takes the text of one record (one or more whole lines) and writes it at once.
    fmt : {"jsonl", "csv"}
        The format; CSV has the columns :data:`holecli.report.BATCH_CSV_COLUMNS`.
    header : bool
        Write the CSV header now (not when appending to a file that has it).
    columns : sequence of str
        The CSV's columns (``--fields``), by default :data:`holecli.report.BATCH_CSV_COLUMNS`.
    """

    def __init__(self, write, fmt, header=True, columns=BATCH_CSV_COLUMNS):
        if fmt not in FORMATS:
            raise ValueError(f"fmt must be one of {FORMATS}, got {fmt!r}")
        self._write = write
        self.fmt = fmt
        self.columns = tuple(columns)
        if fmt == "csv" and header:
            self._write(csv_text([], self.columns, header=True))

    def write(self, record):
        """Write one record (all the rows of a file in one write, for CSV)."""
        if self.fmt == "jsonl":
            self._write(to_json_line(record))
        else:
            self._write(csv_text([record], self.columns, header=False))


class OutputBusyError(HoleCliError):
    """The output file is locked by another running batch."""


class ResumeOptionsError(HoleCliError):
    """``resume`` with other options than those of the output's first record (issue 25, item 4): the
    output would mix records measured or checked differently. The message names the options."""


class OutputNotEmptyError(HoleCliError):
    """The output file holds something (an earlier run's records) and neither ``resume`` nor
    ``overwrite`` says what to do with it."""


class BatchOutput:
    """The ``--output`` of a batch, held for the whole run.

    A regular file (or a new path, or a symbolic link to either) is opened without being emptied and
    locked (``fcntl.flock``, exclusive): a second batch writing the same file is refused with
    :class:`OutputBusyError` before it changes a byte. Only then is the file emptied, or, with
    ``resume``, read (a last line left without its newline is cut off) and appended to. A character
    device (``/dev/null``) or a FIFO is written directly, never locked, emptied or resumed. Anything
    else is refused.

    Each :meth:`write` is one ``os.write`` (retried only when the system writes part of it).
    File names that are not valid UTF-8 are written as their own bytes (``surrogateescape``).

    Parameters
    ----------
    path : str
        The output file.
    fmt : {"jsonl", "csv"}
        Its format.
    resume : bool
        Keep what the file holds and tell what it holds (:attr:`earlier`, :attr:`needs_header`).
    overwrite : bool
        Empty a file that holds something; without it (or ``resume``) such a file is refused with
        :class:`OutputNotEmptyError` and left as it is.
    expected : dict, optional
        With ``resume``: this run's provenance cells (:func:`provenance_cells` of the options it
        would write); when they differ from the first measured record's (:func:`differing_options`),
        :class:`ResumeOptionsError` is raised before the file is changed.

    Attributes
    ----------
    earlier : list of FileSummary
        One per file already in the output (with ``resume``), in file order.
    needs_header : bool
        True when the file still needs the CSV header (a new, emptied or empty file).
    first_provenance : dict or None
        With ``resume``: the provenance cells of the first record that was measured (not an error
        record), None when there is none.

    Raises
    ------
    OutputBusyError
        When another batch holds the lock.
    OutputNotEmptyError
        When the file holds something and neither ``resume`` nor ``overwrite`` is given.
    ResumeOptionsError
        With ``resume`` and ``expected``, when the options differ from the first record's.
    ResumeError
        With ``resume``, when the file is not a regular file or not a batch output of that format
        (a line that is not a JSON object with a ``file``; a CSV header other than the batch's).
    OSError
        When the file cannot be opened, read or cut.
    """

    def __init__(self, path, fmt, resume=False, overwrite=False, expected=None):
        from holecli.io.outfile import destination

        self.path = path
        self.earlier, self.needs_header = [], True
        self.first_provenance = None
        try:
            kind, _ = destination(path)
        except OSError:
            if resume:
                raise ResumeError(f"{path}: cannot resume: not a regular file") from None
            raise
        if kind == "stream":
            if resume:
                raise ResumeError(f"{path}: cannot resume: not a regular file")
            from holecli.io.outfile import open_stream

            self._descriptor = open_stream(path)  # a FIFO that no process reads is refused, not waited for
            os.set_inheritable(self._descriptor, False)
            return
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        try:
            if not stat.S_ISREG(os.fstat(descriptor).st_mode):  # replaced since the stat above
                raise OSError(22, "not a regular file")
            import fcntl

            try:
                fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise OutputBusyError(f"{path}: another holecli batch is writing this file (it is locked); "
                                      f"wait for it to finish or give another --output") from None
            if resume:
                data = _read_all(descriptor)
                complete = data[: data.rfind(b"\n") + 1]
                self.earlier, self.needs_header = _earlier_records(path, complete, fmt)
                self.first_provenance = _first_provenance(complete, fmt)
                differing = [] if expected is None else differing_options(self.first_provenance, expected)
                if differing:  # before anything is cut: the file stays as it was
                    raise ResumeOptionsError(resume_options_message(path, differing))
                if len(complete) != len(data):
                    os.ftruncate(descriptor, len(complete))
            else:
                size = os.fstat(descriptor).st_size
                if size and not overwrite:
                    raise OutputNotEmptyError(
                        f"{path}: holds {size} bytes, an earlier run's records?: give --resume to add to them "
                        f"or --overwrite to replace them")
                os.ftruncate(descriptor, 0)
            os.lseek(descriptor, 0, os.SEEK_END)
        except BaseException:
            os.close(descriptor)
            raise
        self._descriptor = descriptor
        PARENT_ONLY_DESCRIPTORS.add(descriptor)

    def write(self, text):
        """Write ``text`` at the end of the output in one system call."""
        data = memoryview(text.encode("utf-8", "surrogateescape"))
        while data:
            data = data[os.write(self._descriptor, data):]

    def close(self):
        """Close the file (and release the lock)."""
        if self._descriptor is not None:
            PARENT_ONLY_DESCRIPTORS.discard(self._descriptor)
            os.close(self._descriptor)
            self._descriptor = None

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()
        return False


def _read_all(descriptor):
    os.lseek(descriptor, 0, os.SEEK_SET)
    chunks = []
    while True:
        chunk = os.read(descriptor, 1 << 20)
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)


def _earlier_records(path, complete, fmt):
    """What the whole lines ``complete`` of an earlier run's output hold: (summaries, needs_header)."""
    try:
        # A CSV may hold a file name that is not UTF-8, as its own bytes (see BatchOutput); JSON
        # escapes it, so a JSON Lines file is plain UTF-8 (ASCII) throughout.
        text = complete.decode("utf-8", "surrogateescape" if fmt == "csv" else "strict")
    except UnicodeDecodeError:
        raise ResumeError(f"{path}: cannot resume: not a UTF-8 text file") from None
    if fmt == "jsonl":
        return [FileSummary.of_record(record) for record in _json_records(path, text)], False
    if not text:
        return [], True
    rows = list(csv.reader(io.StringIO(text)))
    if tuple(rows[0]) != BATCH_CSV_COLUMNS:
        header = tuple(rows[0])
        if header == _SCHEMA_1_COLUMNS[:-1]:
            why = " (it was written by holecli 0.1, without the path column: start a new output)"
        elif header == _SCHEMA_1_COLUMNS:
            why = " (it was written before schema 2.0, without the provenance columns: start a new output)"
        elif header == _SCHEMA_2_1_COLUMNS:
            why = " (it was written before schema 2.2, without the notes column: start a new output)"
        elif header == _SCHEMA_2_2_COLUMNS:
            why = " (it was written before the u_* columns of the uncertainties: start a new output)"
        else:
            why = ""
        raise ResumeError(f"{path}: cannot resume: its header is not the header of holecli batch --format csv"
                          + why)
    by_file = {}
    for row in rows[1:]:
        if len(row) != len(BATCH_CSV_COLUMNS):
            raise ResumeError(f"{path}: cannot resume: a row has {len(row)} columns, not {len(BATCH_CSV_COLUMNS)}")
        values = dict(zip(BATCH_CSV_COLUMNS, row))
        by_file.setdefault(values["file"], []).append(values)
    return [FileSummary.of_csv_rows(file, rows) for file, rows in by_file.items()], False


def _json_records(path, text):
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:
            record = None
        if not isinstance(record, dict) or not isinstance(record.get("file"), str):
            raise ResumeError(f"{path}: cannot resume: line {number} is not a holecli batch record")
        yield record


# The provenance cells that --resume compares (holecli.report's CSV columns), with the options that
# set them. spec_file is left out: the same spec read from another folder has another name, and its
# SHA-256 says whether it is the same; rng and settings are not options of the command line.
RESUMED_OPTIONS = {
    "method": "--method", "view_dir": "--view-dir", "min_diameter": "--min-diameter", "max_holes": "--max-holes",
    "full_only": "--full-only", "gauge_depth": "--gauge-depth", "input_format": "--input-format", "scan": "--scan",
    "units": "--units/--output-units", "spec_sha256": "--spec (the file's content)",
    "nominal": "the tolerance options (--nominal-diameter, --tolerance, ...)",
    "decision_rule": "--decision-rule", "coverage_factor": "--coverage-factor",
}


def provenance_cells(record) -> dict:
    """The cells of the options in ``record``'s provenance that ``--resume`` compares.

    Parameters
    ----------
    record : dict
        A record (or a dict with its ``units`` and ``options``, ``options.tolerances`` included).

    Returns
    -------
    dict
        ``{column: cell}`` for the columns of :data:`RESUMED_OPTIONS`, each cell as the batch CSV
        writes it (:func:`holecli.report.csv_cell`).
    """
    from holecli.report import _provenance, csv_cell

    values = _provenance(record)
    return {column: csv_cell(values.get(column)) for column in RESUMED_OPTIONS}


def _first_provenance(complete, fmt):
    """The :func:`provenance_cells` of the first measured record in an output's text, or None."""
    text = complete.decode("utf-8", "surrogateescape")
    if fmt == "jsonl":
        for line in text.splitlines():
            record = json.loads(line) if line.strip() else {}
            if isinstance(record, dict) and isinstance(record.get("options"), dict):
                return provenance_cells(record)
        return None
    rows = list(csv.DictReader(io.StringIO(text)))
    for row in rows:
        if not row.get("error") and row.get("method"):
            return {column: row.get(column) or "" for column in RESUMED_OPTIONS}
    return None


def _same_cell(earlier, now) -> bool:
    """Whether two provenance cells say the same: equal text, or equal numbers (lists, JSON) within
    a relative 1e-9 (a length converted from the output unit to the file's and back)."""
    if earlier == now:
        return True

    def parsed(cell):
        if ";" in cell:
            return [parsed(item) for item in cell.split(";")]
        try:
            return json.loads(cell)
        except ValueError:
            return cell

    def same(a, b):
        if isinstance(a, bool) or isinstance(b, bool):
            return a is b
        if isinstance(a, (int, float)) and isinstance(b, (int, float)):
            return math.isclose(a, b, rel_tol=1e-9, abs_tol=0.0)
        if isinstance(a, list) and isinstance(b, list):
            return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
        if isinstance(a, dict) and isinstance(b, dict):
            return a.keys() == b.keys() and all(same(a[key], b[key]) for key in a)
        return a == b

    return same(parsed(earlier), parsed(now))


def differing_options(earlier, now) -> list:
    """The options whose provenance cells differ between an output's first record and this run.

    Parameters
    ----------
    earlier : dict or None
        :attr:`BatchOutput.first_provenance` (None: no measured record, nothing to compare).
    now : dict
        This run's :func:`provenance_cells`. A ``units`` cell empty here is not compared: the
        earlier records may then carry the unit their files declare (E57), which this run's do too.

    Returns
    -------
    list of (str, str, str)
        ``(column, earlier cell, this run's cell)`` of each differing option, in
        :data:`RESUMED_OPTIONS` order.
    """
    if earlier is None:
        return []
    differing = []
    for column in RESUMED_OPTIONS:
        before, after = earlier.get(column, ""), now.get(column, "")
        if column == "units" and not after:
            continue
        if not _same_cell(before, after):
            differing.append((column, *_differing_keys(before, after)))
    return differing


def _differing_keys(before, after):
    """Two cells of compact JSON objects (the nominal) cut down to their differing keys; others as they are."""
    try:
        a, b = json.loads(before), json.loads(after)
    except ValueError:
        return before, after
    if not isinstance(a, dict) or not isinstance(b, dict):
        return before, after
    keys = [key for key in {**a, **b} if not _same_cell(json.dumps(a.get(key)), json.dumps(b.get(key)))]
    def cut(value):
        return json.dumps({key: value.get(key) for key in keys}, separators=(",", ":"))

    return cut(a), cut(b)


def resume_options_message(path, differing) -> str:
    """The one-line message of :class:`ResumeOptionsError` for :func:`differing_options`."""
    def shown(cell):
        return "none" if cell == "" else (cell if len(cell) <= 100 else cell[:97] + "...")

    parts = "; ".join(f"{RESUMED_OPTIONS[column]}: {shown(before)} there, {shown(after)} now"
                      for column, before, after in differing)
    return (f"{path}: cannot resume with other options than its records were made with ({parts}): give the "
            f"same options, or another --output (or --overwrite to replace its records)")


@dataclass(frozen=True)
class FileSummary:
    """What the summary and the exit code need from the record of one file."""

    file: str
    failed: bool
    holes: int = 0
    out_of_tolerance: int = 0
    undecided: int = 0  # holes with an undecided check and none failed (--decision-rule guarded)
    missing: int = 0
    path: str = ""  # resolved_path of the file; "" in records of holecli 0.1
    warnings: tuple = ()  # per hole, the tuple of its warning codes (never a note's, see _warning_codes)

    @classmethod
    def of_record(cls, record):
        path = record.get("path") if isinstance(record.get("path"), str) else ""
        if "error" in record:
            return cls(file=record["file"], failed=True, path=path)
        verdict = record.get("verdict") or {}
        return cls(file=record["file"], failed=False, holes=len(record.get("holes", ())),
                   out_of_tolerance=verdict.get("out_of_tolerance", 0), undecided=verdict.get("undecided", 0),
                   missing=len(verdict.get("missing", ())),
                   path=path, warnings=tuple(_warning_codes(warning["code"] for warning in hole.get("warnings", ()))
                                             for hole in record.get("holes", ())))

    @classmethod
    def of_csv_rows(cls, file, rows):
        path = rows[0].get("path", "") if rows else ""
        if any(row["error"] for row in rows):
            return cls(file=file, failed=True, path=path)
        holes = [row for row in rows if row["hole"]]
        return cls(file=file, failed=False, holes=len(holes), path=path,
                   # a hole not in tolerance fails a check, or else has an undecided one
                   out_of_tolerance=sum(row["in_tolerance"] == "false" and not _only_undecided(row) for row in holes),
                   undecided=sum(row["in_tolerance"] == "false" and _only_undecided(row) for row in holes),
                   missing=sum(row["in_tolerance"] == "false" for row in rows if not row["hole"]),
                   warnings=tuple(_warning_codes(code for code in (row.get("warnings") or "").split(";") if code)
                                  for row in holes))


def _warning_codes(codes):
    """The warning codes among ``codes``, without the notes' (:data:`holecli.vocabulary.NOTE_CODES`),
    which records before schema 2.2 (a resumed batch's earlier ones) gave as warnings: a note never counts
    as a doubt or fails ``--fail-on-warning``."""
    from holecli.vocabulary import NOTE_CODES

    return tuple(code for code in codes if code not in NOTE_CODES)


def _only_undecided(row):
    """Whether a CSV row's hole has an undecided check and no failed one."""
    return not row.get("failed_checks") and bool(row.get("undecided_checks"))


@dataclass
class Tally:
    """Counts of a batch, for its progress, summary and exit code."""

    files: int = 0
    failed: int = 0
    holes: int = 0
    without_hole: int = 0
    out_of_tolerance: int = 0
    undecided: int = 0
    missing: int = 0
    doubtful_holes: int = 0  # holes with a warning (a doubtful result; notes are not warnings)
    rejected_parts: int = 0  # files (parts) with a hole out of tolerance or a nominal hole missing
    undecided_parts: int = 0  # files with an undecided hole and none out of tolerance or missing
    warning_codes: dict = field(default_factory=dict)  # every warning code -> holes with it

    def add(self, summary):
        """Count one file (a :class:`FileSummary`, or a record)."""
        if isinstance(summary, dict):
            summary = FileSummary.of_record(summary)
        self.files += 1
        if summary.failed:
            self.failed += 1
            return
        self.holes += summary.holes
        self.without_hole += summary.holes == 0
        self.out_of_tolerance += summary.out_of_tolerance
        self.undecided += summary.undecided
        self.missing += summary.missing
        rejected = bool(summary.out_of_tolerance or summary.missing)
        self.rejected_parts += rejected
        self.undecided_parts += not rejected and bool(summary.undecided)
        for codes in summary.warnings:
            self.doubtful_holes += bool(codes)
            for code in set(codes):
                self.warning_codes[code] = self.warning_codes.get(code, 0) + 1

    @property
    def measured(self) -> int:
        return self.files - self.failed


def files_to_do(files, earlier) -> list:
    """The ``files`` that the ``earlier`` records (:class:`FileSummary`) do not hold, matched by
    :func:`resolved_path`, so that a resumed batch may run from another folder than the first. (A
    record of holecli 0.1 has no ``path``: its ``file`` is resolved from the current folder.)

    Parameters
    ----------
    files : sequence of str
        The files of this run, in order.
    earlier : iterable of FileSummary
        The records already in the output.

    Returns
    -------
    list of str
        ``files`` without those already measured, in their order.
    """
    done = {summary.path or resolved_path(summary.file) for summary in earlier}
    return [path for path in files if resolved_path(path) not in done]
