"""The ``holecli`` command line: a thin layer over :mod:`holecli.io` and :func:`holecli.detect`.

stdout carries data only; messages go to stderr. Heavy modules (scipy, open3d, rich) are imported
inside the commands so that ``holecli --help`` stays fast.
"""

from __future__ import annotations

import io as _stringio
import os
import sys
import time

import click

from holecli import __version__
from holecli.errors import HoleCliError, LoadError, SpecError

# Exit codes: documented here, in every --help and in the README.
EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2  # click's own
EXIT_INPUT = 3
EXIT_NO_HOLE = 4
EXIT_OUT_OF_TOLERANCE = 5
EXIT_FILE_FAILED = 6
EXIT_INTERRUPTED = 130

EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  a hole was measured (and, with tolerance options, every checked hole is in tolerance)\n"
    "  1  internal error (a bug: please report it)\n"
    "  2  usage error (bad option or argument)\n"
    "  3  input error: the file is missing, unreadable, malformed or has too few points; the --spec\n"
    "     file is unreadable or invalid; or the output file cannot be written\n"
    "  4  no hole found (the record is still printed, with \"holes\": [])\n"
    "  5  out of tolerance: a checked hole is out of tolerance or a nominal hole is missing\n"
    "     (the record is still printed; takes precedence over 4)\n"
    "  6  holecli batch only: some file could not be measured\n"
    "  130  interrupted (Ctrl-C or SIGTERM)"
)

BATCH_EXIT_CODES_HELP = (
    "\b\nExit codes (the first that applies):\n"
    "  130  interrupted (Ctrl-C or SIGTERM): the finished records are written, none cut;\n"
    "       run again with --resume to measure the rest\n"
    "  2    usage error (bad option or argument)\n"
    "  3    input error: a PATH is missing or holds no point cloud, the --spec file is unreadable\n"
    "       or invalid, the output cannot be written or resumed\n"
    "  5    some checked hole is out of tolerance, or a nominal hole is missing\n"
    "  6    some file could not be measured (its record has \"error\")\n"
    "  4    some file has no hole\n"
    "  0    every file measured, each with a hole (and in tolerance, where tolerances are given)\n"
    "  1    internal error (a bug: please report it)"
)

CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


class FloatTuple(click.ParamType):
    """Comma-separated numbers, e.g. ``0,0,1`` (spaces allowed)."""

    def __init__(self, count, names):
        self.count = count
        self.name = names

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        from holecli.io.decimal_text import parse_decimal

        parts = [part.strip() for part in str(value).split(",")]
        try:
            numbers = tuple(parse_decimal(part) for part in parts)
        except ValueError:
            self.fail(f"expected {self.count} comma-separated numbers ({self.name}), got {value!r}", param, ctx)
        if len(numbers) != self.count:  # (parse_decimal refuses infinities)
            self.fail(f"expected {self.count} comma-separated finite numbers ({self.name}), got {value!r}",
                      param, ctx)
        return numbers


class Decimal(click.FloatRange):
    """A plain ASCII decimal number, optionally within a range (click's FloatRange, without the
    leniency of ``float``: no ``1_0``, no non-ASCII digits, no ``inf`` or ``nan``)."""

    name = "decimal"

    def convert(self, value, param, ctx):
        from holecli.io.decimal_text import is_decimal

        if isinstance(value, str) and not is_decimal(value.strip()):
            self.fail(f"{value!r} is not a plain decimal number", param, ctx)
        return super().convert(value.strip() if isinstance(value, str) else value, param, ctx)


class ToleranceBand(click.ParamType):
    """A diameter tolerance: ``T`` (symmetric) or ``+U/-L`` (signed upper/lower deviation)."""

    name = "T|+U/-L"

    def convert(self, value, param, ctx):
        from holecli.errors import SpecError
        from holecli.tolerance import Band, parse_band

        if isinstance(value, Band):
            return value
        try:
            return parse_band(value)
        except SpecError as error:
            self.fail(str(error), param, ctx)


class Failure(Exception):
    """A failure already phrased for the user: ``Error: <message>`` and an exit code."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


def fail(message, code):
    click.echo(f"Error: {message}", err=True)
    sys.exit(code)


def run_guarded(function, *args, **kwargs):
    """Run a command body, turning every expected failure into one line on stderr and an exit code.

    Within it SIGINT and SIGTERM raise KeyboardInterrupt (see :mod:`holecli.interrupts`), so that a
    write in progress cleans up after itself before the exit with 130.
    """
    from holecli import interrupts

    try:
        with interrupts.raising():
            return function(*args, **kwargs)
    except Failure as failure:
        if interrupts.received() is None:
            fail(str(failure), failure.code)
        _interrupted()
    except KeyboardInterrupt:
        _interrupted()
    except BrokenPipeError:
        # The reader of stdout went away (e.g. `| head`): nothing more to say to it.
        _detach_stdout()
        sys.stderr.close()
        sys.exit(EXIT_OK)
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
    """Write ``text`` to stdout at once; :class:`Failure` (input/output code) when it cannot be written
    (a full disk behind a redirection), with stdout detached so that the exit does not try again."""
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


def _detach_stdout():
    # What stdout still buffers would be flushed again at exit, and fail again, with a traceback
    # of the interpreter's own: point the descriptor at /dev/null instead.
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


@click.group(context_settings=CONTEXT, epilog=EXIT_CODES_HELP)
@click.version_option(__version__, "--version", "-V", prog_name="holecli")
def main():
    """Measure drilled holes in 3D scans: center, diameter and surface normal.

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format table
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0
      holecli batch scans/ --recursive --output results.jsonl
      holecli simulate scene.ply
    """


def measure_file(path, options):
    """:func:`holecli.detect_file` for the command line: its errors phrased for the user.

    Parameters
    ----------
    path : str
        The point-cloud file.
    options : dict
        Keyword arguments of :func:`holecli.detect` (see :func:`detection_options`).

    Returns
    -------
    Detection
        The detection, with ``file`` and ``dropped_points`` filled in.

    Raises
    ------
    Failure
        With the input-error code, when the file cannot be read or its points cannot be measured
        (the message of :func:`holecli.batch.failure_message`, as ``holecli batch`` records it).
    """
    from holecli.batch import failure_message
    from holecli.pipeline import detect_file

    try:
        return detect_file(path, **options)
    except HoleCliError as error:
        raise Failure(failure_message(path, error), EXIT_INPUT) from None


def detection_options(method, view_dir, min_diameter, max_holes, full_only):
    """The ``detect`` keyword arguments of the command-line options; usage error for paper + options."""
    if method == "paper":
        given = [name for name, value in (("--view-dir", view_dir), ("--min-diameter", min_diameter),
                                          ("--max-holes", max_holes), ("--full-only", full_only or None))
                 if value is not None]
        if given:
            raise click.UsageError(f"{', '.join(given)} cannot be used with --method paper")
        return {"method": "paper"}
    return {"method": method, "view_dir": view_dir, "min_diameter": min_diameter, "max_holes": max_holes,
            "full_only": full_only}


def detection_option_decorators(function):
    """The detection options shared by ``detect`` and ``batch``."""
    options = [
        click.option("--method", type=click.Choice(["robust", "paper"]), default="robust", show_default=True,
                     help="robust: every hole, robust to noise and clutter, bias-corrected; "
                          "paper: the published method (one hole, clean data)."),
        click.option("--view-dir", type=FloatTuple(3, "X,Y,Z"), default=None,
                     help="Sensor viewing direction: slide points along it onto the plane instead of "
                          "projecting orthogonally (e.g. 0,0,1)."),
        click.option("--min-diameter", type=Decimal(min=0), default=None,
                     help="Smallest hole diameter reported, file units [default: 6 gap scales of the "
                          "sampling, see README]."),
        click.option("--max-holes", type=click.IntRange(min=1), default=None,
                     help="Report at most N holes (the largest)."),
        click.option("--full-only", is_flag=True, help="Leave out holes cut by the border of the scan."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


# What messages call the values of holecli.tolerance.nominal_spec on the command line.
TOLERANCE_OPTION_NAMES = {
    "diameter": "--nominal-diameter", "tolerance": "--tolerance", "center": "--nominal-center",
    "position_tolerance": "--position-tolerance", "normal": "--nominal-normal", "max_tilt": "--max-tilt",
}


def tolerance_option_decorators(function):
    """The tolerance options shared by ``detect`` and ``batch``."""
    options = [
        click.option("--nominal-diameter", type=Decimal(min=0, min_open=True), default=None,
                     metavar="D", help="Nominal hole diameter, checked with --tolerance."),
        click.option("--tolerance", type=ToleranceBand(), default=None,
                     help="Diameter tolerance: T for +-T, or the upper/lower deviation as on a drawing, "
                          "e.g. +0.036/-0 (an H9 fit), 0.036/-0.010."),
        click.option("--nominal-center", type=FloatTuple(3, "X,Y,Z"), default=None,
                     help="Nominal hole center: the checks apply to the hole nearest to it (other holes "
                          "are not checked) and it gets position_deviation."),
        click.option("--position-tolerance", type=Decimal(min=0), default=None, metavar="R",
                     help="Largest distance of the measured center from --nominal-center in the plane "
                          "of the hole."),
        click.option("--nominal-normal", type=FloatTuple(3, "X,Y,Z"), default=None,
                     help="Nominal surface normal (either sign): tilt_deg is reported."),
        click.option("--max-tilt", type=Decimal(min=0, max=90), default=None, metavar="DEG",
                     help="Largest angle between the hole's normal and --nominal-normal, degrees."),
        click.option("--spec", "spec_file", type=click.Path(path_type=str), default=None, metavar="FILE",
                     help="TOML file of the part's nominal holes ([[hole]] tables, see README); "
                          "not with the options above."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


def nominal_from_options(nominal_diameter, tolerance, nominal_center, position_tolerance, nominal_normal,
                         max_tilt, spec_file):
    """The :class:`holecli.tolerance.Spec` of the nominal options, or None (none given, or --spec);
    click usage errors for combinations that do not make sense."""
    from holecli.tolerance import nominal_spec

    values = {"diameter": nominal_diameter, "tolerance": tolerance, "center": nominal_center,
              "position_tolerance": position_tolerance, "normal": nominal_normal, "max_tilt": max_tilt}
    given = [TOLERANCE_OPTION_NAMES[key] for key, value in values.items() if value is not None]
    if spec_file is not None:
        if given:
            raise click.UsageError(f"--spec cannot be combined with {', '.join(given)}")
        return None
    if not given:
        return None
    try:
        return nominal_spec(**values, names=TOLERANCE_OPTION_NAMES)
    except SpecError as error:
        raise click.UsageError(str(error)) from None


# A spec file lists a part's holes, a panel spec a part's features: a few kB. Anything much larger is
# not one of them.
MAX_SPEC_BYTES = 16 << 20


def read_spec(path):
    """The :class:`holecli.tolerance.Spec` of a spec file; :class:`Failure` with the input-error code."""
    from holecli.tolerance import parse_spec

    text = read_small_text(path, "a spec")
    try:
        return parse_spec(text, source=path)
    except SpecError as error:
        raise Failure(f"{path}: {error}", EXIT_INPUT) from None


def read_small_text(path, what):
    """The UTF-8 text of ``path``, a small TOML file (``what``: ``"a spec"``, ``"a panel spec"``);
    :class:`Failure` with the input-error code.

    Only a regular file of at most :data:`MAX_SPEC_BYTES` is read (never a device such as
    ``/dev/zero``, a FIFO, which would block, or a folder).
    """
    import stat

    from holecli.io import file_kind

    try:
        status = os.stat(path)
        if not stat.S_ISREG(status.st_mode):
            raise Failure(f"{path}: not a regular file ({file_kind(status.st_mode)}): {what} must be a TOML file",
                          EXIT_INPUT)
        if status.st_size > MAX_SPEC_BYTES:
            raise Failure(f"{path}: {status.st_size} bytes is too large for {what} file "
                          f"(at most {MAX_SPEC_BYTES} bytes)", EXIT_INPUT)
        with open(path, "rb") as stream:
            data = stream.read(MAX_SPEC_BYTES + 1)
    except OSError as error:
        raise Failure(f"{path}: cannot read: {error.strerror or error}", EXIT_INPUT) from None
    if len(data) > MAX_SPEC_BYTES:
        raise Failure(f"{path}: too large for {what} file (more than {MAX_SPEC_BYTES} bytes)", EXIT_INPUT)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise Failure(f"{path}: not a UTF-8 text file", EXIT_INPUT) from None


def render(records, fmt):
    """The text of ``records`` (detection dicts) in the requested format."""
    from holecli import report

    if fmt == "json":
        return "".join(report.to_json(record) for record in records)
    if fmt == "csv":
        buffer = _stringio.StringIO()
        report.write_csv(records, buffer)
        return buffer.getvalue()
    return render_table(records)


def render_table(records):
    from rich.console import Console
    from rich.table import Table

    buffer = _stringio.StringIO()
    console = Console(file=buffer, width=140, force_terminal=False, color_system=None)
    for record in records:
        plane = record["plane"]
        verdict = record.get("verdict")
        caption = f"plane rms {plane['rms']:.4g}, {record['elapsed_ms']:.1f} ms"
        if verdict is not None:
            caption += (f"; {'IN' if verdict['in_tolerance'] else 'OUT OF'} TOLERANCE: {verdict['checked']} "
                        f"checked, {verdict['out_of_tolerance']} out")
            if verdict["missing"]:
                caption += ", missing: " + ", ".join(str(name) for name in verdict["missing"])
        table = Table(title=f"{record['file']}  ({record['points']} points, method {record['method']})",
                      caption=caption)
        columns = ["hole", "center x", "center y", "center z", "diameter", "normal", "rim pts", "fit rms", "partial"]
        if verdict is not None:
            columns.append("tolerance")
        for column in columns:
            table.add_column(column, justify="right")
        for hole in record["holes"]:
            cells = [
                str(hole["index"]), *(f"{v:.4f}" for v in hole["center"]), f"{hole['diameter']:.4f}",
                "(" + ", ".join(f"{v:.4f}" for v in hole["normal"]) + ")", str(hole["rim_points"]),
                f"{hole['fit_rms']:.2g}", "yes" if hole.get("partial") else "no",
            ]
            if verdict is not None:
                name = f"{hole['name']}: " if hole.get("name") else ""
                if hole["in_tolerance"] is None:
                    cells.append(name + "not checked")
                else:
                    cells.append(name + ("in" if hole["in_tolerance"] else "OUT: " + ", ".join(hole["failed_checks"])))
            table.add_row(*cells)
        if not record["holes"]:
            table.add_row("-", "", "", "", "no hole found", *[""] * (len(columns) - 5))
        console.print(table)
        if "rejected" in record:
            console.print(_rejected_table(record["rejected"]))
    return buffer.getvalue()


def _rejected_table(rejected):
    from rich.table import Table

    def number(value):
        return "" if value is None else (str(value) if isinstance(value, int) else f"{value:.4g}")

    table = Table(title=f"{len(rejected)} candidate{'' if len(rejected) == 1 else 's'} not reported as holes")
    for column in ("check", "center x", "center y", "center z", "size", "value", "limit", "why"):
        table.add_column(column, justify="left" if column in ("check", "why") else "right")
    for rejection in rejected:
        table.add_row(rejection["check"], *(f"{v:.4f}" for v in rejection["center"]), f"{rejection['diameter']:.4f}",
                      number(rejection["value"]), number(rejection["limit"]), rejection["reason"])
    return table


def emit(text, output):
    """Write ``text`` to stdout (``output`` None or ``-``), or to ``output`` as :func:`holecli.io.outfile.write_text`
    does: atomically onto a regular file or a new path, directly onto a device or FIFO, through a
    symbolic link onto its target."""
    if output is None or output == "-":
        write_stdout(text)
        return
    from holecli.io.outfile import write_text

    try:
        write_text(output, text)
    except OSError as error:
        raise Failure(f"{output}: cannot write output: {error.strerror or error}", EXIT_INPUT) from None


@main.command(epilog=EXIT_CODES_HELP)
@click.argument("scan", type=click.Path(path_type=str))
@click.option("--format", "fmt", type=click.Choice(["json", "csv", "table"]), default="json", show_default=True,
              help="Output format: JSON record, CSV (one row per hole) or a table for people.")
@click.option("--output", "-o", type=click.Path(dir_okay=False, path_type=str),
              help="Write the result to this file (a regular file atomically; - is stdout) instead of stdout.")
@click.option("--explain", is_flag=True,
              help="Also list every candidate that is not a hole, with the check that refused it "
                   "(\"rejected\" in JSON, a second table with --format table).")
@detection_option_decorators
@tolerance_option_decorators
def detect(scan, fmt, output, explain, method, view_dir, min_diameter, max_holes, full_only, nominal_diameter,
           tolerance, nominal_center, position_tolerance, nominal_normal, max_tilt, spec_file):
    """Measure the holes in SCAN (.ply, .pcd, .csv, .txt or .xyz).

    Prints center, diameter and normal of every hole as JSON (units those of the file). With
    tolerance options or --spec, every checked hole also gets its deviations and "in_tolerance",
    and the record a "verdict".

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format csv --output result.csv
      holecli detect scan.pcd --view-dir 0,0,1 --full-only --format table
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0
      holecli detect scan.ply --nominal-center 3.65,5.14,5.53 --position-tolerance 0.1 \\
          --nominal-normal 0.18,-0.5,0.85 --max-tilt 1
      holecli detect scan.ply --spec part.toml --format table
      holecli detect scan.ply --explain --format table
    """
    if explain and fmt == "csv":
        raise click.UsageError("--explain needs --format json or table (CSV has one row per hole)")
    options = detection_options(method, view_dir, min_diameter, max_holes, full_only)
    nominal = nominal_from_options(nominal_diameter, tolerance, nominal_center, position_tolerance,
                                   nominal_normal, max_tilt, spec_file)

    def body():
        from holecli.tolerance import check

        spec = read_spec(spec_file) if spec_file is not None else nominal
        record = measure_file(scan, options).to_dict(explain=explain)
        if spec is not None:
            record = check(record, spec)
        emit(render([record], fmt), output)
        return record

    record = run_guarded(body)
    if not record["holes"]:
        click.echo(f"holecli: no hole found in {scan}", err=True)
    verdict = record.get("verdict")
    if verdict is not None and not verdict["in_tolerance"]:
        missing = f", missing: {', '.join(str(name) for name in verdict['missing'])}" if verdict["missing"] else ""
        click.echo(f"holecli: out of tolerance: {verdict['out_of_tolerance']} of {verdict['checked']} checked "
                   f"holes{missing} in {scan}", err=True)
        sys.exit(EXIT_OUT_OF_TOLERANCE)
    sys.exit(EXIT_OK if record["holes"] else EXIT_NO_HOLE)


@main.command(epilog="\b\nExit codes: 0 written, 2 usage error, 3 the scene or the output is invalid.")
@click.argument("output", type=click.Path(dir_okay=False, path_type=str))
@click.option("--diameter", type=Decimal(min=0, min_open=True), default=3.0, show_default=True,
              help="Hole diameter (ignored when --hole is given).")
@click.option("--center", type=FloatTuple(2, "X,Y"), default="1,1", show_default=True,
              help="Hole center in the surface frame (ignored when --hole is given).")
@click.option("--hole", "holes", type=FloatTuple(3, "X,Y,DIAMETER"), multiple=True,
              help="A hole X,Y,DIAMETER in the surface frame; repeat for several holes.")
@click.option("--no-hole", is_flag=True, help="Scan a plain surface without any hole.")
@click.option("--spacing", type=Decimal(min=0, min_open=True), default=0.0908, show_default=True,
              help="Point spacing h (along a scan line).")
@click.option("--extent", type=FloatTuple(4, "XMIN,XMAX,YMIN,YMAX"), default="-3,5,-3,5", show_default=True,
              help="Scanned patch in the surface frame.")
@click.option("--pattern", type=click.Choice(["grid", "stripes", "jittered", "random"]), default="grid",
              show_default=True, help="Sampling pattern.")
@click.option("--line-pitch", type=Decimal(min=0, min_open=True), default=None,
              help="Distance between scan lines for --pattern stripes [default: 3 x spacing].")
@click.option("--scan-angle", type=Decimal(), default=0.0, show_default=True,
              help="Direction of the scan lines in the surface frame, degrees.")
@click.option("--rotation", type=FloatTuple(3, "AX,AY,AZ"), default=None,
              help="Rotation in degrees about x, then y, then z (world axes) [default: 32,0,20; with --panel "
                   "or --mesh: none, the part's frame].")
@click.option("--translation", type=FloatTuple(3, "X,Y,Z"), default=None,
              help="Translation after the rotation [default: 3,4,5; with --panel or --mesh: none] (with "
                   "--panel/--mesh: into a robot base frame, e.g. 1200,-300,800).")
@click.option("--noise-z", type=Decimal(min=0), default=0.0, show_default=True,
              help="Gaussian noise sigma on the world z coordinate (the paper's noise).")
@click.option("--noise-normal", type=Decimal(min=0), default=0.0, show_default=True,
              help="Gaussian noise sigma along the surface normal.")
@click.option("--inside-points", type=click.IntRange(min=0), default=0, show_default=True,
              help="Random points inside each hole (reflections; the paper's Fig. 5 uses 10 and 100).")
@click.option("--countersink", type=Decimal(min=0, min_open=True), default=None,
              help="Countersink diameter at the surface (100-degree cone) for every hole.")
@click.option("--bore-depth", type=Decimal(min=0), default=0.0, show_default=True,
              help="Depth of bore-wall points below the surface (0: none).")
@click.option("--bottom-depth", type=Decimal(min=0), default=0.0, show_default=True,
              help="Blind holes: the flat floor at this depth below the surface is scanned (0: a through "
                   "hole); at least --bore-depth.")
@click.option("--outliers", type=Decimal(min=0, max=1), default=0.0, show_default=True,
              help="Fraction of gross outliers.")
@click.option("--ragged", type=Decimal(min=0), default=0.0, show_default=True,
              help="Amplitude of a ragged outer border (0: straight).")
@click.option("--nan-points", type=click.IntRange(min=0), default=0, show_default=True,
              help="NaN rows to append, as a profiler writes for missed points.")
@click.option("--panel", "panel_file", type=click.Path(dir_okay=False, path_type=str), default=None, metavar="SPEC",
              help="Scan a panel built from the TOML spec SPEC (sheets with holes, see README) with the laser "
                   "profiler.")
@click.option("--mesh", "mesh_file", type=click.Path(dir_okay=False, path_type=str), default=None, metavar="PART",
              help="Scan the triangle mesh PART (.stl, .ply, .obj, .off) with the laser profiler.")
@click.option("--target", type=FloatTuple(3, "X,Y,Z"), default=None,
              help="Profiler: the point the sensor aims at [default: the middle of the part, on its side "
                   "facing the sensor].")
@click.option("--standoff", type=Decimal(min=0, min_open=True), default=100.0, show_default=True,
              help="Profiler: distance from the sensor to --target along --view.")
@click.option("--view", type=FloatTuple(3, "X,Y,Z"), default="0,0,-1", show_default=True,
              help="Profiler: viewing direction, from the sensor toward the part.")
@click.option("--line", type=FloatTuple(3, "X,Y,Z"), default="1,0,0", show_default=True,
              help="Profiler: direction of the laser line (perpendicular to --view); the robot moves along "
                   "line x view.")
@click.option("--line-length", type=Decimal(min=0, min_open=True), default=None,
              help="Profiler: field of view along the line [default: the part's extent].")
@click.option("--scan-length", type=Decimal(min=0, min_open=True), default=None,
              help="Profiler: length of the robot's travel [default: the part's extent].")
@click.option("--parallel-rays", is_flag=True,
              help="Profiler: parallel rays (a profiler's uniform-X output) instead of a fan from the laser.")
@click.option("--triangulation-deg", type=Decimal(min=0, max=80), default=25.0, show_default=True,
              help="Profiler: angle between the laser and the camera; points the camera cannot see are lost.")
@click.option("--max-incidence-deg", type=Decimal(min=0, max=90), default=75.0, show_default=True,
              help="Profiler: points on faces steeper than this to the ray are lost.")
@click.option("--range-noise", type=Decimal(min=0), default=0.0, show_default=True,
              help="Profiler: Gaussian noise sigma along each ray.")
@click.option("--range-quantum", type=Decimal(min=0), default=0.0, show_default=True,
              help="Profiler: ranges rounded to multiples of this (0: none), e.g. 0.001.")
@click.option("--dropout", type=Decimal(min=0, max=1, max_open=True), default=0.0, show_default=True,
              help="Profiler: fraction of points lost at random.")
@click.option("--jitter", type=Decimal(min=0), default=0.0, show_default=True,
              help="Profiler: sigma of the robot's position error, per profile.")
@click.option("--keep-nan", is_flag=True, help="Profiler: a NaN row for every lost point, as profilers write.")
@click.option("--metres", is_flag=True, help="Profiler: write the points in metres (the part is in mm).")
@click.option("--float64", is_flag=True,
              help="Profiler: write double precision [default: float32, as sensors write].")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed.")
@click.option("--truth", "truth_path", type=click.Path(dir_okay=False, path_type=str), default=None,
              help="Where to write the ground truth [default: OUTPUT with .truth.json].")
@click.pass_context
def simulate(ctx, output, diameter, center, holes, no_hole, spacing, extent, pattern, line_pitch, scan_angle, rotation,
             translation, noise_z, noise_normal, inside_points, countersink, bore_depth, bottom_depth, outliers, ragged,
             nan_points, panel_file, mesh_file, target, standoff, view, line, line_length, scan_length, parallel_rays,
             triangulation_deg, max_incidence_deg, range_noise, range_quantum, dropout, jitter, keep_nan, metres,
             float64, seed, truth_path):
    """Write a synthetic scan to OUTPUT (.ply, .pcd, .csv, .txt or .xyz) and its ground truth.

    The defaults reproduce the paper's Table I scene: a 3 mm hole at (1, 1) on a 0.0908 mm grid
    over [-3, 5]^2, rotated (32, 0, 20) degrees and translated by (3, 4, 5). With --panel or
    --mesh, a laser line profiler on a robot scans a CAD part instead (ray-cast, with occlusion):
    --spacing is then its point pitch and --line-pitch its profile pitch.

    \b
    Examples:
      holecli simulate table1.ply
      holecli simulate noisy.csv --noise-z 0.0272 --seed 3
      holecli simulate stripes.pcd --pattern stripes --spacing 0.05 --line-pitch 0.15 \\
          --hole 0,0,3 --hole 5,0,4 --extent -3,8,-3,3
      holecli simulate panel.ply --panel sample_clouds/panel.toml --spacing 0.1 --range-noise 0.005
      holecli simulate part.ply --mesh part.stl --view 0,-0.42,-0.91 --translation 1200,-300,800
    """
    if panel_file is not None or mesh_file is not None:
        sys.exit(run_guarded(_simulate_part, ctx, output, panel_file, mesh_file, truth_path, seed))
    profiler_only = [name for name in _PROFILER_OPTIONS if _given(ctx, name)]
    if profiler_only:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in profiler_only)} need --panel or --mesh")
    rotation = rotation if rotation is not None else (32.0, 0.0, 20.0)
    translation = translation if translation is not None else (3.0, 4.0, 5.0)

    def body():
        import json
        from pathlib import Path

        from holecli.io import SUPPORTED_EXTENSIONS, save_points
        from holecli.io.outfile import write_text
        from holecli.simulation import synth

        if Path(output).suffix.lower() not in SUPPORTED_EXTENSIONS:
            raise Failure(f"{output}: unsupported extension (expected {', '.join(SUPPORTED_EXTENSIONS)})",
                          EXIT_INPUT)
        specs = () if no_hole else holes or ((center[0], center[1], diameter),)
        try:
            scene = synth.SceneSpec(
                holes=tuple(synth.HoleSpec(center=(x, y), diameter=d, countersink_diameter=countersink,
                                           bore_depth=bore_depth, bottom_depth=bottom_depth,
                                           inside_points=inside_points)
                            for x, y, d in specs),
                extent=extent, spacing=spacing, pattern=pattern, line_pitch=line_pitch,
                scan_angle_deg=scan_angle, rotation_deg=rotation, translation=translation,
                noise_world_z=noise_z, noise_normal=noise_normal, outlier_fraction=outliers,
                ragged_border=ragged, nan_points=nan_points)
            scan = synth.make_scan(scene, seed)
        except ValueError as error:
            raise Failure(f"{output}: invalid scene: {error}", EXIT_INPUT) from None
        truth = dict(scan.truth, seed=seed, file=Path(output).name)
        target = truth_path or str(Path(output).with_suffix(".truth.json"))
        try:
            save_points(output, scan.points)
            write_text(target, json.dumps(truth, indent=2) + "\n")
        except OSError as error:
            raise Failure(f"{output}: cannot write: {error.strerror or error}", EXIT_INPUT) from None
        click.echo(f"wrote {len(scan.points)} points to {output} and the ground truth to {target}", err=True)
        return EXIT_OK

    sys.exit(run_guarded(body))


# The options of simulate that only a profiler scan of a part uses, and those only a synthetic scene uses.
_PROFILER_OPTIONS = ("target", "standoff", "view", "line", "line_length", "scan_length", "parallel_rays",
                     "triangulation_deg", "max_incidence_deg", "range_noise", "range_quantum", "dropout", "jitter",
                     "keep_nan", "metres", "float64")
_SYNTHETIC_OPTIONS = ("diameter", "center", "holes", "no_hole", "extent", "pattern", "scan_angle", "noise_z",
                      "noise_normal", "inside_points", "countersink", "bore_depth", "bottom_depth", "outliers",
                      "ragged", "nan_points")


def _given(ctx, name):
    from click.core import ParameterSource

    return ctx.get_parameter_source(name) not in (ParameterSource.DEFAULT, None)


def _option_name(name):
    return "--hole" if name == "holes" else "--" + name.replace("_", "-")


def _simulate_part(ctx, output, panel_file, mesh_file, truth_path, seed):
    """``holecli simulate --panel/--mesh``: the profiler's scan of a part, and its truth."""
    import json
    from pathlib import Path

    import numpy as np

    from holecli.errors import SpecError
    from holecli.io import SUPPORTED_EXTENSIONS, save_points
    from holecli.io.outfile import write_text

    p = ctx.params
    if panel_file is not None and mesh_file is not None:
        raise click.UsageError("give --panel or --mesh, not both")
    synthetic = [name for name in _SYNTHETIC_OPTIONS if _given(ctx, name)]
    if synthetic:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in synthetic)} cannot be used with "
                               f"{'--panel' if panel_file else '--mesh'} (they describe a synthetic scene)")
    if Path(output).suffix.lower() not in SUPPORTED_EXTENSIONS:
        raise Failure(f"{output}: unsupported extension (expected {', '.join(SUPPORTED_EXTENSIONS)})", EXIT_INPUT)
    source = panel_file or mesh_file
    try:
        vertices, triangles, features, part = _load_part(panel_file, mesh_file, p["view"])
        spec = _profiler_spec(p, vertices)
        from holecli.simulation.scan_part import scan_part

        scanned = scan_part(vertices, triangles, features, spec, rng=seed)
    except (SpecError, ValueError) as error:
        raise Failure(f"{source}: {error}", EXIT_INPUT) from None
    truth = dict(scanned.truth, part=part, seed=seed, file=Path(output).name,
                 units="m" if p["metres"] else "mm")
    target = truth_path or str(Path(output).with_suffix(".truth.json"))
    points = scanned.scan.points
    try:
        save_points(output, points, float32=not p["float64"])
        write_text(target, json.dumps(truth, indent=2) + "\n")
    except OSError as error:
        raise Failure(f"{output}: cannot write: {error.strerror or error}", EXIT_INPUT) from None
    finite = int(np.isfinite(points).all(axis=1).sum())
    click.echo(f"wrote {len(points)} points ({finite} measured) to {output} and the ground truth "
               f"({len(truth['holes'])} holes) to {target}", err=True)
    return EXIT_OK


def _load_part(panel_file, mesh_file, view):
    """(vertices, triangles, features in the part's frame, a description of the part) of --panel or --mesh."""
    if panel_file is not None:
        from holecli.simulation.panel import build_panel, panel_truth, parse_panel_toml

        panel = build_panel(parse_panel_toml(read_small_text(panel_file, "a panel spec")))
        truth = panel_truth(panel)
        return panel.vertices, panel.triangles, truth["features"], {"panel": truth["panel"], "source": panel_file}
    from holecli.errors import LoadError
    from holecli.simulation.mesh_truth import mesh_truth
    from holecli.simulation.profiler import load_mesh

    try:
        vertices, triangles = load_mesh(mesh_file)
    except LoadError as error:
        raise Failure(str(error), EXIT_INPUT) from None
    truth = mesh_truth(vertices, triangles, view=view)
    # The diameter of a hole is the edge at the surface: the circle through the edge polygon's vertices.
    features = [dict(feature, diameter=feature.get("edge_diameter")) for feature in truth["features"]]
    return vertices, triangles, features, {"mesh": mesh_file, "vertices": len(vertices), "triangles": len(triangles)}


def _profiler_spec(p, vertices):
    """The :class:`holecli.simulation.profiler.ProfilerSpec` of simulate's options; lengths and target default
    to the part's extent and its middle, on its side facing the sensor."""
    import numpy as np

    from holecli.simulation.profiler import ProfilerSpec

    view = np.asarray(p["view"], dtype=np.float64)
    line = np.asarray(p["line"], dtype=np.float64)
    if np.linalg.norm(view) == 0 or np.linalg.norm(line) == 0:
        raise ValueError("--view and --line must not be zero")
    view, line = view / np.linalg.norm(view), line / np.linalg.norm(line)
    motion = np.cross(line, view)
    if np.linalg.norm(motion) < 1e-6:
        raise ValueError("--line must not be along --view")
    motion /= np.linalg.norm(motion)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    if p["target"] is not None:
        target = np.asarray(p["target"], dtype=np.float64)
    else:
        middle = 0.5 * (low + high)
        # on the part's side facing the sensor: as far against the view as its nearest vertex
        target = middle + (float(np.min(vertices @ view)) - float(middle @ view)) * view
    line_length = p["line_length"] or float(np.ptp(vertices @ line))
    scan_length = p["scan_length"] or float(np.ptp(vertices @ motion))
    frame = None
    if p["rotation"] is not None or p["translation"] is not None:
        from holecli.simulation.synth import rotation_matrix

        matrix = np.eye(4)
        matrix[:3, :3] = rotation_matrix(p["rotation"] or (0.0, 0.0, 0.0))
        matrix[:3, 3] = p["translation"] or (0.0, 0.0, 0.0)
        frame = tuple(map(tuple, matrix))
    return ProfilerSpec(target=tuple(target), standoff=p["standoff"], view=tuple(view), line=tuple(line),
                        line_length=line_length, scan_length=scan_length, point_pitch=p["spacing"],
                        line_pitch=p["line_pitch"] or p["spacing"], fan=not p["parallel_rays"],
                        triangulation_deg=p["triangulation_deg"], max_incidence_deg=p["max_incidence_deg"],
                        range_noise=p["range_noise"], range_quantum=p["range_quantum"], dropout=p["dropout"],
                        jitter=p["jitter"], keep_nan=p["keep_nan"], frame=frame,
                        unit_scale=1e-3 if p["metres"] else 1.0, float32=not p["float64"])


class _StopRequests:
    """SIGINT and SIGTERM handling of ``holecli batch``.

    Before :meth:`defer`, either signal raises KeyboardInterrupt (nothing is written yet). After it,
    a signal only sets :attr:`signal`, which the batch loop checks between records: an exception can
    then never cut a record in the middle of its write.
    """

    SIGNALS = ("SIGINT", "SIGTERM")

    def __init__(self):
        self.signal = None
        self._deferred = False
        self._previous = {}

    def __enter__(self):
        import signal

        for name in self.SIGNALS:
            number = getattr(signal, name)
            try:
                self._previous[number] = signal.signal(number, self._handle)
            except ValueError:  # not the main thread: leave the signals alone
                pass
        return self

    def __exit__(self, *exc_info):
        import signal

        for number, handler in self._previous.items():
            signal.signal(number, handler)
        return False

    def defer(self):
        self._deferred = True

    def _handle(self, number, frame):
        if not self._deferred:
            from holecli import interrupts

            interrupts.record(number)
            raise KeyboardInterrupt
        self.signal = number


def _batch_summary(tally, seconds, checked, earlier, output):
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


def batch_exit_code(tally):
    """The exit code of a batch from its counts, by the documented precedence."""
    if tally.out_of_tolerance or tally.missing:
        return EXIT_OUT_OF_TOLERANCE
    if tally.failed:
        return EXIT_FILE_FAILED
    if tally.without_hole:
        return EXIT_NO_HOLE
    return EXIT_OK


@main.command(epilog=BATCH_EXIT_CODES_HELP)
@click.argument("paths", metavar="PATH...", nargs=-1, required=True, type=click.Path(path_type=str))
@click.option("--recursive", "-r", is_flag=True, help="Also take the clouds in the subfolders of each folder.")
@click.option("--pattern", metavar="GLOB", default=None,
              help="Take only the clouds in folders whose name matches GLOB (case-insensitive; a GLOB with "
                   "a / is matched against the path below the folder), e.g. 'part7_*'.")
@click.option("--format", "fmt", type=click.Choice(["jsonl", "csv"]), default="jsonl", show_default=True,
              help="JSON Lines (one detect record per file) or CSV (one row per hole).")
@click.option("--output", "-o", type=click.Path(dir_okay=False, path_type=str), default=None,
              help="Write the records to this file (each as soon as its file is measured) instead of stdout.")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None, metavar="N",
              help="Worker processes [default: the number of cores].")
@click.option("--resume", is_flag=True,
              help="Keep the records already in --output, skip their files and append the others.")
@click.option("--explain", is_flag=True,
              help="Records also list every candidate that is not a hole, with the check that refused it "
                   "(\"rejected\"; JSON Lines only).")
@detection_option_decorators
@tolerance_option_decorators
def batch(paths, recursive, pattern, fmt, output, jobs, resume, explain, method, view_dir, min_diameter, max_holes,
          full_only, nominal_diameter, tolerance, nominal_center, position_tolerance, nominal_normal, max_tilt,
          spec_file):
    """Measure every point cloud in the folders and files PATH.

    A folder contributes the .ply, .pcd, .csv, .txt and .xyz files directly in it (any case; with
    --recursive also those below it), in sorted order; a file named on the command line is measured
    as it is. Each record (the JSON of holecli detect) is written as soon as its file is measured; a
    file that cannot be measured gives {"file": ..., "error": ...} and the batch goes on. Progress and
    a summary go to stderr. Ctrl-C or SIGTERM stop cleanly; --resume then finishes the run.

    \b
    Examples:
      holecli batch scans/ --output results.jsonl
      holecli batch scans/ --recursive --pattern 'panel7_*' --format csv -o panel7.csv
      holecli batch scans/ --spec part.toml --jobs 4 -o shift.jsonl
      holecli batch scans/ --spec part.toml -o shift.jsonl --resume
      holecli batch scans/*.ply --nominal-diameter 3 --tolerance 0.02 | jq -c 'select(.verdict.in_tolerance | not)'
    """
    options = detection_options(method, view_dir, min_diameter, max_holes, full_only)
    nominal = nominal_from_options(nominal_diameter, tolerance, nominal_center, position_tolerance,
                                   nominal_normal, max_tilt, spec_file)
    if resume and (output is None or output == "-"):
        raise click.UsageError("--resume needs --output (the file to go on with)")
    if explain and fmt == "csv":
        raise click.UsageError("--explain needs --format jsonl (CSV has one row per hole)")

    def body(stop):
        from holecli import batch as batching
        from holecli.io import SUPPORTED_EXTENSIONS

        spec = read_spec(spec_file) if spec_file is not None else nominal
        try:
            files = batching.find_scans(paths, recursive=recursive, pattern=pattern,
                                        exclude=[output] if output else ())
        except LoadError as error:
            raise Failure(str(error), EXIT_INPUT) from None
        if not files:
            raise Failure(f"{', '.join(paths)}: no point-cloud files ({', '.join(SUPPORTED_EXTENSIONS)})"
                          + (f" matching {pattern!r}" if pattern else "") + " found", EXIT_INPUT)
        output_file = None
        try:
            if output is not None and output != "-":
                try:
                    output_file = batching.BatchOutput(output, fmt, resume=resume)
                except (batching.ResumeError, batching.OutputBusyError) as error:
                    raise Failure(str(error), EXIT_INPUT) from None
                except OSError as error:
                    action = "resume" if resume else "write output"
                    raise Failure(f"{output}: cannot {action}: {error.strerror or error}", EXIT_INPUT) from None
                write, earlier, header = output_file.write, output_file.earlier, output_file.needs_header
            else:
                write, earlier, header = write_stdout, [], True
            todo = batching.files_to_do(files, earlier)
            return run_batch(batching, todo, options, spec, jobs or batching.default_jobs(), write, fmt, header,
                             earlier, output, stop, explain)
        finally:
            if output_file is not None:
                output_file.close()

    with _StopRequests() as stop:
        sys.exit(run_guarded(body, stop))


class _BatchDisplay:
    """stderr of ``holecli batch``: a rich progress bar on a terminal, plain lines otherwise.

    rich is imported only for the bar: a batch run by a script does not pay for it.
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
        if self._progress is None:
            return
        status = f"{tally.holes} holes, {tally.failed} failed"
        if self._checked:
            status += f", {tally.out_of_tolerance + tally.missing} out of tolerance"
        status += f", {completed / seconds if seconds > 0 else 0.0:.1f} files/s"
        self._progress.update(self._task, completed=completed, status=status)
        self._progress.refresh()

    def message(self, text):
        if self._progress is not None:
            self._console.print(text, markup=False)
        else:
            click.echo(text, err=True)


def run_batch(batching, todo, options, spec, jobs, write, fmt, header, earlier, output, stop, explain=False):
    """The measuring loop of ``holecli batch``: records out, progress and summary on stderr."""
    from contextlib import closing

    tally = batching.Tally()
    for summary in earlier:
        tally.add(summary)
    def failed_write(error):
        return Failure(f"{output or 'stdout'}: cannot write output: {error.strerror or error}", EXIT_INPUT)

    try:
        writer = batching.RecordWriter(write, fmt, header=header)
    except BrokenPipeError:
        raise
    except OSError as error:
        raise failed_write(error) from None
    display = _BatchDisplay(len(todo), spec is not None)
    started = time.monotonic()
    measured_now = 0

    def should_stop():
        display.update(measured_now, tally, time.monotonic() - started)
        return stop.signal is not None

    stop.defer()
    records = batching.measure_all(todo, options, spec, jobs=min(jobs, max(1, len(todo))), should_stop=should_stop,
                                   explain=explain)
    with display, closing(records):
        for record in records:
            try:
                try:
                    writer.write(record)
                except ValueError as error:  # a NaN in the record: a bug, but the batch goes on
                    record = {"file": record["file"], "error": f"{record['file']}: internal error (a bug: please "
                                                              f"report it): the record cannot be written: {error}"}
                    writer.write(record)
            except BrokenPipeError:
                raise
            except OSError as error:
                raise failed_write(error) from None
            measured_now += 1
            tally.add(record)
            if "error" in record:
                display.message(f"holecli: failed: {record['error']}")
    summary = _batch_summary(tally, time.monotonic() - started, spec is not None, len(earlier), output)
    if stop.signal is not None and measured_now < len(todo):
        display.message(f"holecli batch: interrupted after {measured_now} of {len(todo)} files ({summary})."
                        + (f" The finished records are in {output}: run again with --resume to measure the rest."
                           if output else ""))
        return EXIT_INTERRUPTED
    display.message(f"holecli batch: {summary}")
    return batch_exit_code(tally)
