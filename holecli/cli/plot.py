"""``holecli plot``: draw the holes of one scan into a PNG (matplotlib, the optional extra ``plot``).

Also the ``--plot FILE.png|DIR/`` of ``holecli detect`` (:func:`plot_png`, :func:`plot_destination`)
and the plot folder of ``holecli batch --plot`` (:func:`make_plot_folder`). matplotlib is imported
here only when a picture is drawn: ``holecli detect`` and ``holecli batch`` without ``--plot`` never
import it.
"""

from __future__ import annotations

import os

import click

from holecli.cli.exits import EXIT_CODES_HELP, EXIT_INPUT, Failure, exit_code, run_guarded
from holecli.cli.options import (check_verbosity, columns_option, detection_option_decorators, detection_options,
                                 input_format_option,
                                 refuse_same_files, verbosity_option_decorators)
from holecli.cli.outputs import write_outputs
from holecli.cli.source import STDIN, check_stdin_format, measure
from holecli.tally import Tally

MISSING_EXTRA = "holecli plot needs the optional extra: pip install 'holecli[plot]'"


def require_matplotlib():
    """Import matplotlib with the Agg backend.

    Raises
    ------
    Failure
        With the input/output code (3) and :data:`MISSING_EXTRA`, when matplotlib is not installed.
    """
    try:
        import matplotlib
    except ImportError:
        raise Failure(MISSING_EXTRA, EXIT_INPUT) from None
    matplotlib.use("Agg", force=True)
    return matplotlib


# What messages call the picture: "fit.png: cannot write the plot: ...".
PLOT_WHAT = "the plot"


def plot_png(measurement, max_panels=None, dpi=None, unit=None):
    """The PNG of a measurement (:meth:`holecli.measure.Measurement.png`: with the verdict when it was
    checked), not yet written.

    Parameters
    ----------
    measurement : holecli.measure.Measurement
        Measured with ``plot=True``.
    max_panels, dpi, unit
        As for :meth:`holecli.measure.Measurement.png`.

    Returns
    -------
    bytes

    Raises
    ------
    Failure
        matplotlib missing (input/output code).
    """
    require_matplotlib()
    return measurement.png(max_panels=max_panels, dpi=dpi, unit=unit)


def write_plot(path, measurement, max_panels=None, dpi=None, unit=None):
    """Draw a measurement (:func:`plot_png`) and write the PNG to ``path`` atomically.

    Parameters
    ----------
    path : str
        The PNG.
    measurement, max_panels, dpi, unit
        As for :func:`plot_png`.

    Raises
    ------
    Failure
        matplotlib missing, or the file cannot be written (input/output code).
    """
    write_outputs([(path, plot_png(measurement, max_panels=max_panels, dpi=dpi, unit=unit), PLOT_WHAT)])


def is_plot_folder(value):
    """Whether a ``--plot`` value names a folder: an existing one, or any path ending with a separator.

    Parameters
    ----------
    value : str

    Returns
    -------
    bool
    """
    return os.path.isdir(value) or value.endswith(("/", os.sep))


def plot_name(scan):
    """The PNG name of a scan in a plot folder: its stem and ``.png`` (``stdin.png`` for ``-``).

    Parameters
    ----------
    scan : str
        The scan's path as given (``-``: standard input).

    Returns
    -------
    str
    """
    from holecli.inspection import scan_stem  # (not at holecli --help: it imports holecli.tolerance)

    return ("stdin" if scan == STDIN else scan_stem(scan) or "scan") + ".png"


def make_plot_folder(folder):
    """Create the plot folder (and its parents) unless it exists.

    Raises
    ------
    Failure
        With the input/output code: ``FOLDER: cannot create the plot folder: <why>``, or
        ``FOLDER: cannot draw into it: not a folder`` when it is a file.
    """
    shown = folder.rstrip("/" + os.sep) or folder
    if os.path.exists(shown) and not os.path.isdir(shown):
        raise Failure(f"{shown}: cannot draw into it: not a folder", EXIT_INPUT)
    try:
        os.makedirs(shown, exist_ok=True)
    except OSError as error:
        raise Failure(f"{shown}: cannot create the plot folder: {error.strerror or error}", EXIT_INPUT) from None


def plot_destination(value, scan):
    """The PNG that ``--plot VALUE`` of ``holecli detect SCAN`` writes, the folder created if needed.

    Parameters
    ----------
    value : str
        ``--plot``: a file (``fit.png``), or a folder (existing, or ending with ``/``) that then gets
        ``<scan stem>.png`` (:func:`plot_name`).
    scan : str
        SCAN.

    Returns
    -------
    str

    Raises
    ------
    Failure
        See :func:`make_plot_folder`.
    """
    if is_plot_folder(value):
        make_plot_folder(value)
    return plot_path_of(value, scan)


def plot_path_of(value, scan):
    """The PNG that ``--plot VALUE`` of ``holecli detect SCAN`` names (nothing is made).

    Parameters
    ----------
    value, scan : str
        As for :func:`plot_destination`.

    Returns
    -------
    str
        ``value``, or ``value/<scan stem>.png`` when it names a folder (:func:`is_plot_folder`).
    """
    return os.path.join(value, plot_name(scan)) if is_plot_folder(value) else value


def plot_path_type():
    return click.Path(dir_okay=False, path_type=str)


@click.command(epilog=EXIT_CODES_HELP)
@click.argument("scan", type=click.Path(allow_dash=True, path_type=str))
@click.option("--output", "-o", type=plot_path_type(), required=True,
              help="The PNG to write (atomically; a FIFO must have its reader). Never SCAN itself.")
@input_format_option("Read SCAN in this format, whatever its extension; needed for - (stdin).")
@columns_option
@click.option("--scan", "scan_index", type=click.IntRange(min=0), default=None, metavar="N",
              help="Draw scan N (from 0) of a multi-scan E57 file [default: every scan, merged].")
@click.option("--units", type=click.Choice(("mm", "m", "in")), default=None,
              help="The unit of the file's coordinates [default: the file's (E57: m), else not known]; when known, "
                   "the picture is drawn in mm.")
@click.option("--max-panels", type=click.IntRange(min=1), default=None, metavar="N",
              help="Draw the first N holes only [default: every hole].")
@click.option("--dpi", type=click.IntRange(min=20, max=600), default=100, show_default=True,
              help="Resolution of the PNG (the figure is 14 in wide).")
@detection_option_decorators
@verbosity_option_decorators
def plot(scan, output, input_format, columns, scan_index, units, max_panels, dpi, method, view_dir, min_diameter, max_holes,
         full_only, gauge_depth, quiet, verbose):
    """Draw the holes found in SCAN into a PNG, for an inspector: per hole the points around it seen
    along its normal (coloured by height above the surface) with the fitted edge circle, its center,
    the countersink and bore circles, the rim points used and rejected, the points inside the hole and
    a scale bar; the edge's radial residuals against the angle; and a box of its values (diameter ± U,
    center, normal, type, countersink, warnings, verdict). Lengths in mm when the unit is known (--units,
    E57), else in the file's units. (holecli detect --plot and holecli batch --plot draw the same, with
    the tolerance verdict, each diameter check's nominal circle and tolerance zone, and a note where U
    is wider than the zone.)

    Needs matplotlib: pip install 'holecli[plot]'.

    \b
    Examples:
      holecli plot scan.ply -o fit.png
      holecli plot scan.ply -o fit.png --max-panels 2 --dpi 60
      holecli plot scan.pcd -o fit.png --view-dir 0,0,-1 --full-only
    """
    check_verbosity(quiet, verbose)
    check_stdin_format(scan, input_format)
    options = detection_options(method, view_dir, min_diameter, max_holes, full_only, gauge_depth)
    if input_format is not None:
        options["input_format"] = input_format
    if columns is not None:
        options["columns"] = columns

    def body():
        refuse_same_files([("SCAN", scan)], [("-o/--output", output)])  # before anything is read
        require_matplotlib()  # before the detection: a missing extra is said at once
        measurement = measure(scan, options, scan_index, plot=True)
        write_plot(output, measurement, max_panels=max_panels, dpi=dpi, unit=units)
        return measurement

    measurement = run_guarded(body)
    detection = measurement.detection
    if not quiet:
        click.echo(f"holecli: {len(detection.holes)} hole{'' if len(detection.holes) == 1 else 's'} of "
                   f"{detection.file} drawn in {output}", err=True)
    raise SystemExit(exit_code(Tally.of([measurement.record])))
