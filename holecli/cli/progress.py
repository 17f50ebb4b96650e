"""What the commands show on stderr besides errors: the progress bar (or plain lines) and the summary of
``holecli batch``, the status line of a long ``holecli detect`` (:class:`DetectStatus`), and the
``--verbose`` account of a record (:func:`verbose_text`)."""

from __future__ import annotations

import sys

import click


def stderr_is_terminal(stream=None):
    """Whether ``stream`` (stderr by default) is a terminal; False when it cannot tell.

    Parameters
    ----------
    stream : text file, optional

    Returns
    -------
    bool
    """
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _number(value, digits=4):
    return "none" if value is None else f"{value:.{digits}g}"


def columns_text(columns):
    """The columns of a text table read as x, y, z, for people: ``x_mm,y_mm,z_mm (1,2,3 of 5, 0-based; unit mm
    from the header)``, ``columns 0,1,2 of 7, 0-based; no header``.

    Parameters
    ----------
    columns : dict
        A record's ``input_columns`` (:meth:`holecli.io.text.TableColumns.to_dict`).

    Returns
    -------
    str
    """
    indices = ",".join(str(index) for index in columns["indices"])
    how = [f"{indices} of {columns['width']}, 0-based"]
    if columns["given"]:
        how.append("given by --columns")
    if columns["unit"]:
        how.append(f"unit {columns['unit']} from the header")
    if columns["names"] is None:
        return f"columns {'; '.join(how + ['no header'])}"
    return f"{','.join(columns['names'])} ({'; '.join(how)})"


def verbose_text(record):
    """The ``--verbose`` account of one record: the scales the pipeline chose, the holes' notes (why a
    value is null) and where the time went.

    Parameters
    ----------
    record : dict
        A ``detect`` record (:meth:`holecli.Detection.to_dict`), or a batch error record (nothing is
        said of it: its error is reported as such).

    Returns
    -------
    str
        Lines starting with ``holecli: ``, each ending in a newline; empty for an error record.
    """
    if "error" in record or "scales" not in record:
        return ""
    scales, options, timing = record["scales"], record.get("options") or {}, record.get("timing") or {}
    lines = [f"{record['file']}: {record['points']} points ({record['dropped_points']} dropped), "
             f"method {record['method']}, schema {record.get('schema_version')}, "
             f"holecli {record.get('holecli_version')}"]
    if record.get("input_columns"):
        lines.append(f"  columns read as x, y, z: {columns_text(record['input_columns'])}")
    if record["method"] == "robust":
        if scales["line_pitch"] is not None:
            pattern = f"line pitch {_number(scales['line_pitch'])} (stripes)"
        elif scales["lattice"]:
            pattern = "no stripes, a square grid"
        else:
            pattern = "no stripes, irregular"
        lines.append(f"  point spacing {_number(scales['point_spacing'])}, gap scale {_number(scales['gap_scale'])}, "
                     f"{pattern}; height noise {_number(scales['height_noise'], 3)}")
        effective = scales["min_diameter"]
        if options.get("min_diameter") is not None:
            how = "given"
        elif scales["gap_scale"]:
            how = f"default: {effective / scales['gap_scale']:.3g} gap scales"
        else:
            how = "default"
        lines.append(f"  minimum diameter {_number(effective)} ({how})")
    else:
        lines.append(f"  triangle area bound {_number(scales.get('triangle_area_bound'))} (Eq. 12); no minimum "
                     f"diameter")
    holes, rejected = len(record["holes"]), record["candidates"] - len(record["holes"])
    lines.append(f"  {record['candidates']} candidate{'' if record['candidates'] == 1 else 's'} tried: "
                 f"{holes} hole{'' if holes == 1 else 's'}, {rejected} rejected")
    # the notes: why a value is null (the warnings are said without --verbose too)
    lines.extend(f"  hole {hole['index']} note: {note['code']}: {note['message']}"
                 for hole in record["holes"] for note in hole.get("notes", ()))
    stages = ", ".join(f"{name} {ms:.1f}" for name, ms in (timing.get("stages") or {}).items())
    read = timing.get("read_ms")
    lines.append(f"  time {timing.get('elapsed_ms', 0.0):.1f} ms: {stages} ms"
                 + ("" if read is None else f" (reading the file {read:.1f} ms)"))
    return "".join(f"holecli: {line}\n" for line in lines)


class DetectStatus:
    """The status line of ``holecli detect`` on stderr: a spinner with the file and the running stage.

    Shown only when stderr is a terminal and not ``--quiet`` (never in a pipe, a file or a log); rich is
    imported only then. Gone when the ``with`` block ends (transient). :meth:`stage` is the
    ``progress`` callback of :func:`holecli.detect`.

    Parameters
    ----------
    scan : str
        The file being measured.
    quiet : bool
        ``--quiet``: no status line.
    console : rich.console.Console, optional
        Where to draw it (tests pass one with ``force_terminal``); by default a console on stderr,
        when stderr is a terminal.

    Attributes
    ----------
    shown : bool
        Whether a status line is drawn at all.
    """

    def __init__(self, scan, quiet=False, console=None):
        self._scan = scan
        self._status = None
        self.shown = not quiet and (console is not None or stderr_is_terminal())
        if self.shown:
            if console is None:
                from rich.console import Console

                console = Console(stderr=True, highlight=False)
            from rich.markup import escape

            self._name = escape(str(scan))
            self._status = console.status(f"reading {self._name}", spinner="dots")

    def __enter__(self):
        if self._status is not None:
            self._status.start()
        return self

    def __exit__(self, *exc_info):
        if self._status is not None:
            self._status.stop()
        return False

    def stage(self, name):
        """Show that stage ``name`` of the detection runs (the ``progress`` callback of ``detect``).

        Parameters
        ----------
        name : str
        """
        if self._status is not None:
            self._status.update(f"measuring {self._name}: {name}")


def batch_summary(tally, seconds, checked, earlier, output):
    """The summary line of a batch (after ``holecli batch: ``, or inside the interrupted message).

    Parameters
    ----------
    tally : holecli.tally.Tally
        The counts of every file, the earlier run's included.
    seconds : float
        Wall time of this run.
    checked : bool
        Whether tolerances were checked (a spec or tolerance options were given).
    earlier : int
        Files whose records came from the earlier run (``--resume``).
    output : str or None
        The ``--output`` file, named when ``earlier`` is not zero.

    Returns
    -------
    str
        e.g. ``3 files: 3 measured, 0 failed; 5 holes found; tolerances not checked; 2 doubtful
        holes (points_inside 1, rim_gap 2); 1.2 s`` (that part only when a hole has a warning; notes
        are not counted). With tolerances, parts and holes are counted apart: ``parts rejected: 1 of 3;
        holes out of tolerance: 2, nominal holes missing: 0`` (a part, a file, is rejected when a hole
        of it is out of tolerance or a nominal hole is missing).
    """
    def count(number, noun):
        return f"{number} {noun}{'' if number == 1 else 's'}"

    text = (f"{count(tally.files, 'file')}: {tally.measured} measured, {tally.failed} failed; "
            f"{count(tally.holes, 'hole')} found")
    if tally.without_hole:
        text += f" ({count(tally.without_hole, 'file')} without a hole)"
    if checked:
        # parts (files) and holes are counted apart, each under its own label (issue 25, item 10)
        undecided_parts = f", undecided: {tally.undecided_parts}" if tally.undecided_parts else ""
        undecided = f", undecided: {tally.undecided}" if tally.undecided else ""
        text += (f"; parts rejected: {tally.rejected_parts} of {tally.measured}{undecided_parts}; "
                 f"holes out of tolerance: {tally.out_of_tolerance}{undecided}, nominal holes missing: "
                 f"{tally.missing}")
    else:
        text += "; tolerances not checked"
    if tally.doubtful_holes:
        codes = ", ".join(f"{code} {n}" for code, n in sorted(tally.warning_codes.items()))
        text += f"; {count(tally.doubtful_holes, 'doubtful hole')} ({codes})"
    text += f"; {seconds:.1f} s"
    if earlier:
        text += f" ({count(earlier, 'file')} from the earlier run in {output})"
    return text


class BatchDisplay:
    """stderr of ``holecli batch``: a rich progress bar on a terminal, plain lines otherwise.

    rich is imported only for the bar: a batch run by a script does not pay for it. Use it as a
    context manager (the bar shows inside the ``with`` block and is gone after it).

    Parameters
    ----------
    total : int
        The number of files this run measures (the bar's end).
    checked : bool
        Whether tolerances are checked: the bar then also counts the parts (files) rejected.
    quiet : bool
        ``--quiet``: no bar, and :meth:`message` says only what is marked as an error.
    """

    def __init__(self, total, checked, quiet=False):
        self._checked = checked
        self._quiet = quiet
        self._progress = None
        if not quiet and stderr_is_terminal():
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

            self._console = Console(stderr=True, highlight=False, soft_wrap=True)
            # auto_refresh=False: no refresh thread, so the worker processes are forked from a
            # single-threaded parent; the batch loop refreshes the bar at least five times a second.
            self._progress = Progress(TextColumn("measuring"), BarColumn(), MofNCompleteColumn(),
                                      TextColumn("{task.fields[status]}"), TimeRemainingColumn(),
                                      console=self._console, auto_refresh=False, transient=True)
            self._task = self._progress.add_task("batch", total=total, status="")

    def __enter__(self):
        if self._progress is not None:
            self._progress.start()
        return self

    def __exit__(self, *exc_info):
        if self._progress is not None:
            self._progress.stop()
        return False

    def update(self, completed, tally, seconds):
        """Redraw the bar (nothing without a terminal).

        Parameters
        ----------
        completed : int
            Files of this run measured so far.
        tally : holecli.tally.Tally
            The counts so far.
        seconds : float
            Time since the run started, for the rate.
        """
        if self._progress is None:
            return
        status = f"{tally.holes} holes, {tally.failed} failed"
        if self._checked:
            status += f", parts rejected: {tally.rejected_parts}"
        status += f", {completed / seconds if seconds > 0 else 0.0:.1f} files/s"
        self._progress.update(self._task, completed=completed, status=status)
        self._progress.refresh()

    def message(self, text, error=False):
        """Write the line ``text`` to stderr (above the bar, when there is one).

        Parameters
        ----------
        text : str
            The message, printed as it is (no rich markup).
        error : bool
            An error (a file that failed, the run interrupted): said even with ``--quiet``.
        """
        if self._quiet and not error:
            return
        if self._progress is not None:
            self._console.print(text, markup=False)
        else:
            click.echo(text, err=True)
