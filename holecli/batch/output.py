"""Writing a batch's records and resuming an interrupted batch: :class:`RecordWriter` (JSON Lines or
CSV, one write per record), :class:`BatchOutput` (the locked output file, what an earlier run wrote),
the options a resumed run must share with it, and :func:`files_to_do` (what a resumed run has left).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import stat

from holecli.batch.pool import PARENT_ONLY_DESCRIPTORS
from holecli.errors import HoleCliError
from holecli.measure import resolved_path
from holecli.report import BATCH_CSV_COLUMNS, CSV_COLUMNS, csv_text, to_json_line
from holecli.tally import FileSummary

FORMATS = ("jsonl", "csv")

# The batch CSV header before the provenance columns (schema 1, records without schema_version).
_SCHEMA_1_COLUMNS = CSV_COLUMNS[:CSV_COLUMNS.index("schema_version")] + ("error", "path")
# The batch CSV header of schema 2.1 (and 2.0 since the decision rules), before the notes column.
_SCHEMA_2_1_COLUMNS = CSV_COLUMNS[:CSV_COLUMNS.index("notes")] + ("error", "path")
# The batch CSV header of schema 2.2 before issue 25's u_* columns.
_SCHEMA_2_2_COLUMNS = CSV_COLUMNS[:CSV_COLUMNS.index("u_center_in_plane")] + ("error", "path")


class ResumeError(HoleCliError, ValueError):
    """The output file of an earlier run cannot be resumed: it is not a batch output of this format."""




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
