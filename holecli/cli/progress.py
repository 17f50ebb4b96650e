"""What ``holecli batch`` shows on stderr: the progress bar (or plain lines) and the summary."""

from __future__ import annotations

import sys

import click


def batch_summary(tally, seconds, checked, earlier, output):
    """The summary line of a batch (after ``holecli batch: ``, or inside the interrupted message).

    Parameters
    ----------
    tally : holecli.batch.Tally
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
        e.g. ``3 files: 3 measured, 0 failed; 5 holes found; tolerances not checked; 1.2 s``.
    """
    def count(number, noun):
        return f"{number} {noun}{'' if number == 1 else 's'}"

    text = (f"{count(tally.files, 'file')}: {tally.measured} measured, {tally.failed} failed; "
            f"{count(tally.holes, 'hole')} found")
    if tally.without_hole:
        text += f" ({count(tally.without_hole, 'file')} without a hole)"
    if checked:
        text += f"; {tally.out_of_tolerance} out of tolerance, {count(tally.missing, 'nominal hole')} missing"
    else:
        text += "; tolerances not checked"
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
        Whether tolerances are checked: the bar then also counts the holes out of tolerance.
    """

    def __init__(self, total, checked):
        self._checked = checked
        self._progress = None
        try:
            terminal = sys.stderr.isatty()
        except (AttributeError, ValueError):
            terminal = False
        if terminal:
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
        tally : holecli.batch.Tally
            The counts so far.
        seconds : float
            Time since the run started, for the rate.
        """
        if self._progress is None:
            return
        status = f"{tally.holes} holes, {tally.failed} failed"
        if self._checked:
            status += f", {tally.out_of_tolerance + tally.missing} out of tolerance"
        status += f", {completed / seconds if seconds > 0 else 0.0:.1f} files/s"
        self._progress.update(self._task, completed=completed, status=status)
        self._progress.refresh()

    def message(self, text):
        """Write the line ``text`` to stderr (above the bar, when there is one).

        Parameters
        ----------
        text : str
            The message, printed as it is (no rich markup).
        """
        if self._progress is not None:
            self._console.print(text, markup=False)
        else:
            click.echo(text, err=True)
