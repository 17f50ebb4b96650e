"""The options that ``holecli detect`` and ``holecli batch`` share (their parameter types are in
:mod:`holecli.cli.types`, the spec and registration files they read in :mod:`holecli.cli.files`; both
are imported here, so that a command takes its options from one place).

* the detection options (``--method``, ``--view-dir``, ...): :func:`detection_option_decorators` and
  their ``detect`` keyword arguments, :func:`detection_options`;
* the tolerance options (``--nominal-diameter``, ``--spec``, ...): :func:`tolerance_option_decorators`,
  :func:`nominal_from_options` (and :func:`holecli.cli.files.read_spec`);
* ``--input-format``: :func:`input_format_option`; ``--columns``: :func:`columns_option`.
* ``--quiet`` and ``--verbose`` of every command: :func:`verbosity_option_decorators`.
* ``--fail-on-warning`` of ``detect`` and ``batch``: :func:`fail_on_warning_option` (:func:`holecli.cli.exits.warned` tests it).
* ``--decision-rule`` and ``--coverage-factor`` (with the tolerance options): :func:`decision_from_options`,
  :func:`with_decision`.
* the output options of every command (``--output``, ``--plot``, ``--targets-output``):
  :func:`holecli.cli.files.refuse_same_files`, which keeps an output from replacing an input or another output.

Nothing heavy is imported at module level: ``holecli --help`` builds these options.
"""

from __future__ import annotations

import os

import click

from holecli.cli.exits import EXIT_USAGE, Failure
# (the commands take their option pieces from here: the types and files are imported for them too)
from holecli.cli.files import (MAX_SPEC_BYTES, read_registration, read_small_bytes, read_small_text,  # noqa: F401
                               read_spec, refuse_same_files)
from holecli.cli.types import Columns, CsvFields, Decimal, FloatTuple, HoleTie, ToleranceBand, WarningCodes  # noqa: F401
from holecli.errors import SpecError
# The formats of --input-format, the values of --decision-rule and the default --coverage-factor
# (standard library only: building the options imports neither the readers nor numpy).
from holecli.vocabulary import DECISION_RULES, DEFAULT_COVERAGE_FACTOR, INPUT_FORMATS


def input_format_option(help_text):
    """The ``--input-format`` option of ``detect`` and ``batch``.

    Parameters
    ----------
    help_text : str
        Its help, which says what it applies to for the command.

    Returns
    -------
    callable
        The click option decorator (parameter ``input_format``: one of :data:`INPUT_FORMATS`, or
        None).
    """
    return click.option("--input-format", type=click.Choice(INPUT_FORMATS, case_sensitive=False), default=None,
                        help=help_text)


# What --columns says in every command's help.
COLUMNS_HELP = ("The x, y, z columns of a text table (.csv, .txt, .xyz): three header names (case ignored) or "
                "0-based indices, e.g. x_mm,y_mm,z_mm or 1,2,3 [default: the columns the header names x, y, z "
                "(x_mm, X [mm], pos_x, //X, ...), else the first three; a table where that is a guess is "
                "refused with its columns]. Refused for other formats.")


def columns_option(function):
    """The ``--columns`` option of the commands that read scans (parameter ``columns``: a tuple or None).

    Parameters
    ----------
    function : callable
        A click command's function.

    Returns
    -------
    callable
        ``function`` with the option applied.
    """
    return click.option("--columns", type=Columns(), default=None, help=COLUMNS_HELP)(function)


def detection_options(method, view_dir, min_diameter, max_holes, full_only, gauge_depth=None):
    """The ``detect`` keyword arguments of the command-line detection options.

    Parameters
    ----------
    method : {"robust", "paper"}
        ``--method``.
    view_dir, min_diameter, max_holes, full_only, gauge_depth
        ``--view-dir``, ``--min-diameter``, ``--max-holes``, ``--full-only``, ``--gauge-depth`` (None
        or False when not given).

    Returns
    -------
    dict
        Keyword arguments of :func:`holecli.detect` (and :func:`holecli.detect_file`).

    Raises
    ------
    click.UsageError
        When ``--method paper`` is given with any of the other options.
    """
    if method == "paper":
        given = [name for name, value in (("--view-dir", view_dir), ("--min-diameter", min_diameter),
                                          ("--max-holes", max_holes), ("--full-only", full_only or None),
                                          ("--gauge-depth", gauge_depth))
                 if value is not None]
        if given:
            raise click.UsageError(f"{', '.join(given)} cannot be used with --method paper")
        return {"method": "paper"}
    return {"method": method, "view_dir": view_dir, "min_diameter": min_diameter, "max_holes": max_holes,
            "full_only": full_only, "gauge_depth": gauge_depth}


def _applied(options, function):
    """``function`` with the click ``options`` applied, the first of them shown first in ``--help``."""
    for option in reversed(options):
        function = option(function)
    return function


def detection_option_decorators(function):
    """The detection options shared by ``detect`` and ``batch``.

    Parameters
    ----------
    function : callable
        A click command's function.

    Returns
    -------
    callable
        ``function`` with the options applied.
    """
    options = [
        click.option("--method", type=click.Choice(["robust", "paper"]), default="robust", show_default=True,
                     help="robust: every hole, robust to noise and clutter, bias-corrected; "
                          "paper: the published method (one hole, clean data)."),
        click.option("--view-dir", type=FloatTuple(3, "X,Y,Z"), default=None,
                     help="Sensor viewing direction: slide points along it onto the plane instead of "
                          "projecting orthogonally (e.g. 0,0,1)."),
        click.option("--min-diameter", type=Decimal(min=0), default=None,
                     help="Smallest hole diameter reported, file units (or --output-units) [default: 6 gap "
                          "scales of the sampling, see docs/guide/detect.md]."),
        click.option("--max-holes", type=click.IntRange(min=1), default=None,
                     help="Report at most N holes (the largest)."),
        click.option("--full-only", is_flag=True, help="Leave out holes cut by the border of the scan."),
        click.option("--gauge-depth", type=Decimal(min=0), default=None, metavar="DEPTH",
                     help="Also give each countersink's diameter at DEPTH below the surface "
                          "(countersink.diameter_at_depth, what a countersink gauge reads), file units (or "
                          "--output-units)."),
    ]
    return _applied(options, function)


UNIT_NAMES = ("mm", "m", "in")


def reading_option_decorators(function):
    """The options of ``detect`` and ``batch`` about the file: ``--scan``, ``--units``, ``--output-units``.

    Parameters
    ----------
    function : callable
        A click command's function (it gets ``scan_index``, ``units`` and ``output_units``).

    Returns
    -------
    callable
        ``function`` with the options applied.
    """
    options = [
        click.option("--scan", "scan_index", type=click.IntRange(min=0), default=None, metavar="N",
                     help="Measure scan N (from 0) of a multi-scan E57 file [default: every scan, each moved "
                          "by its pose, merged]; any other file holds one scan, 0."),
        click.option("--units", type=click.Choice(UNIT_NAMES), default=None,
                     help="The unit of the file's coordinates [default: unspecified; E57: m]."),
        click.option("--output-units", type=click.Choice(UNIT_NAMES), default=None,
                     help="Give every length of the record in this unit (needs the file's: --units, or E57); "
                          "length options and tolerances are then in it too."),
    ]
    return _applied(options, function)


def unit_choice(units, output_units, files=None):
    """The :class:`holecli.units.UnitChoice` of ``--units`` and ``--output-units``.

    Parameters
    ----------
    units, output_units : str or None
        The options.
    files : sequence of str, optional
        The files to measure, when known: ``--output-units`` without ``--units`` is allowed when
        they are all E57 (whose unit is metres by the standard).

    Returns
    -------
    holecli.units.UnitChoice

    Raises
    ------
    click.UsageError
        ``--output-units`` without ``--units`` for files whose unit is not known.
    """
    from holecli.units import UnitChoice

    if output_units is not None and units is None:
        if files is not None and files and all(os.path.splitext(str(path))[1].lower() == ".e57" for path in files):
            units = "m"
        else:
            raise click.UsageError("--output-units needs --units, the unit of the file's coordinates "
                                   "(only E57 files declare theirs, metres)")
    return UnitChoice(units, output_units)


def verbosity_option_decorators(function):
    """``--quiet/-q`` and ``--verbose/-v``, of every command: what goes to stderr (stdout is data only).

    Parameters
    ----------
    function : callable
        A click command's function; it gets ``quiet`` and ``verbose`` (booleans).

    Returns
    -------
    callable
        ``function`` with the options applied.
    """
    options = [
        click.option("--quiet", "-q", is_flag=True,
                     help="Say nothing on stderr but errors (no progress, status line, summary or notes)."),
        click.option("--verbose", "-v", is_flag=True,
                     help="Also say on stderr what the run chose: the measured scales (point spacing, gap "
                          "scale, line pitch, minimum diameter), the candidates tried and the time per stage."),
    ]
    return _applied(options, function)


def fail_on_warning_option(function):
    """``--fail-on-warning CODE[,CODE...]|doubts|any``: a hole with one of these warnings makes the run end
    with :data:`holecli.cli.exits.EXIT_WARNING` (the output is still written).

    Parameters
    ----------
    function : callable
        A click command's function; it gets ``fail_on_warning`` (None, a frozenset of codes, or
        ``{"any"}``; ``doubts`` is expanded to its codes).

    Returns
    -------
    callable
    """
    return click.option(
        "--fail-on-warning", "fail_on_warning", type=WarningCodes(), default=None,
        help="Exit with 7 when a hole has one of these warnings (a result that may be wrong): comma-separated "
             "codes (e.g. rim_gap,points_inside), or any (every warning; doubts is the same); the output is "
             "still written. Notes (bore_not_seen, axis_not_measured, ...: why a value is null) never fail a run "
             "and are refused here. Codes: docs/reference/warnings.md.")(function)


def check_verbosity(quiet, verbose):
    """Refuse ``--quiet`` with ``--verbose``.

    Parameters
    ----------
    quiet, verbose : bool

    Raises
    ------
    click.UsageError
        When both are given.
    """
    if quiet and verbose:
        raise click.UsageError("--quiet and --verbose cannot be combined")


# What messages call the values of holecli.tolerance.nominal_spec on the command line.
TOLERANCE_OPTION_NAMES = {
    "diameter": "--nominal-diameter", "tolerance": "--tolerance", "center": "--nominal-center",
    "position_tolerance": "--position-tolerance", "normal": "--nominal-normal", "max_tilt": "--max-tilt",
    "countersink_diameter": "--countersink-diameter",
    "countersink_diameter_tolerance": "--countersink-diameter-tolerance",
    "countersink_angle": "--countersink-angle", "countersink_angle_tolerance": "--countersink-angle-tolerance",
    "countersink_depth": "--countersink-depth", "countersink_depth_tolerance": "--countersink-depth-tolerance",
    "bore_diameter": "--bore-diameter", "bore_diameter_tolerance": "--bore-diameter-tolerance",
    "max_perpendicularity": "--max-perpendicularity",
    "countersink_gauge_diameter": "--countersink-gauge-diameter",
    "countersink_gauge_tolerance": "--countersink-gauge-tolerance",
}

# The keyword arguments of holecli.tolerance.nominal_spec by the names of the click parameters
# (the others are the same).
_NOMINAL_SPEC_KEYS = {"nominal_diameter": "diameter", "nominal_center": "center", "nominal_normal": "normal"}

# The checks of a nominal value with a band: (value option, its metavar, its help, an example band).
_FEATURE_OPTIONS = (
    ("--countersink-diameter", "D", "Nominal countersink diameter at the surface, checked against the "
                                    "countersink's diameter with --countersink-diameter-tolerance.", "+0.1/-0"),
    ("--countersink-angle", "DEG", "Nominal included angle of the countersink, degrees, checked with "
                                   "--countersink-angle-tolerance (100 +-1: --countersink-angle 100 "
                                   "--countersink-angle-tolerance 1).", "+1/-0.5"),
    ("--countersink-depth", "D", "Nominal countersink depth (along the axis, from the surface to the cone's "
                                 "lower edge), checked with --countersink-depth-tolerance.", "0.05"),
    ("--bore-diameter", "D", "Nominal diameter of the bore below the edge (its fitted cylinder), checked "
                             "with --bore-diameter-tolerance.", "+0.036/-0"),
)


def tolerance_option_decorators(function):
    """The tolerance options shared by ``detect`` and ``batch``.

    Parameters
    ----------
    function : callable
        A click command's function.

    Returns
    -------
    callable
        ``function`` with the options applied.
    """
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
    ]
    for name, metavar, help_text, example in _FEATURE_OPTIONS:
        if name == "--countersink-angle":
            value_type = Decimal(min=0, max=180, min_open=True, max_open=True,
                                 hint=f"a number of degrees; give its tolerance with {name}-tolerance")
        else:
            value_type = Decimal(min=0, min_open=True, hint=f"a number; give its tolerance with {name}-tolerance")
        what = "degrees, " if name == "--countersink-angle" else ""
        options += [
            click.option(name, type=value_type, default=None, metavar=metavar, help=help_text),
            click.option(f"{name}-tolerance", type=ToleranceBand(), default=None,
                         help=f"Tolerance of {name}, {what}as --tolerance: T for +-T, or the upper/lower "
                              f"deviation +U/-L (e.g. {example})."),
        ]
    options += [
        click.option("--countersink-gauge-diameter", type=Decimal(min=0, min_open=True, hint="a number; give its "
                     "tolerance with --countersink-gauge-tolerance"), default=None, metavar="D",
                     help="Nominal countersink gauge reading: the countersink's diameter at --gauge-depth below the "
                          "surface (countersink.diameter_at_depth), checked with --countersink-gauge-tolerance; "
                          "needs --gauge-depth."),
        click.option("--countersink-gauge-tolerance", type=ToleranceBand(), default=None,
                     help="Tolerance of --countersink-gauge-diameter, as --tolerance: T for +-T, or the upper/lower "
                          "deviation +U/-L (e.g. +0.1/-0)."),
        click.option("--max-perpendicularity", type=Decimal(min=0, max=90), default=None, metavar="DEG",
                     help="Largest angle between the hole's axis (from its countersink cone, bore or floor) "
                          "and its surface normal, degrees."),
        click.option("--spec", "spec_file", type=click.Path(path_type=str), default=None, metavar="FILE",
                     help="TOML file of the part's nominal holes ([[hole]] tables, see docs/guide/tolerances.md; "
                          "units = \"in\" at its top converts its lengths into the scan's unit); not with the options "
                          "above."),
        click.option("--decision-rule", type=click.Choice(DECISION_RULES), default=None,
                     help="How a check is decided (ISO 14253-1): simple, by the measured value alone "
                          "[default]; guarded, pass only when the value +- its expanded uncertainty U is "
                          "inside the limits, fail when wholly outside, else undecided (exit 8); a value "
                          "without an uncertainty is undecided. Needs tolerance options or --spec."),
        click.option("--coverage-factor", type=Decimal(min=0, min_open=True), default=None, metavar="K",
                     help="Coverage factor k of the expanded uncertainty U = k * u (u the standard "
                          "uncertainty in the record) [default: 2]. Needs tolerance options or --spec."),
    ]
    return _applied(options, function)


def decision_from_options(decision_rule, coverage_factor, checked):
    """The :class:`holecli.tolerance.Spec` fields of ``--decision-rule`` and ``--coverage-factor``.

    Parameters
    ----------
    decision_rule : {"simple", "guarded"} or None
        ``--decision-rule`` (None: not given, simple).
    coverage_factor : float or None
        ``--coverage-factor`` (None: not given, 2; click has refused anything but a number > 0).
    checked : bool
        Whether tolerance options or ``--spec`` are given.

    Returns
    -------
    dict
        ``decision_rule`` and ``coverage_factor``, for :func:`dataclasses.replace` of the spec.

    Raises
    ------
    click.UsageError
        When either is given without tolerances to check.
    """
    given = [name for name, value in (("--decision-rule", decision_rule), ("--coverage-factor", coverage_factor))
             if value is not None]
    if given and not checked:
        raise click.UsageError(f"{' and '.join(given)} need{'s' if len(given) == 1 else ''} tolerance options "
                               "or --spec (there is nothing to decide without tolerances)")
    return {"decision_rule": decision_rule or "simple",
            "coverage_factor": DEFAULT_COVERAGE_FACTOR if coverage_factor is None else coverage_factor}


def with_decision(spec, decision):
    """``spec`` (or None) with the ``decision`` of :func:`decision_from_options`."""
    import dataclasses

    return None if spec is None else dataclasses.replace(spec, **decision)


def require_gauge_depth(spec, gauge_depth, spec_file=None):
    """Refuse a countersink gauge check without ``--gauge-depth``: its reading would never be measured.

    Parameters
    ----------
    spec : holecli.tolerance.Spec or None
    gauge_depth : float or None
        ``--gauge-depth``.
    spec_file : str or None
        ``--spec``, for the message.

    Raises
    ------
    click.UsageError
        When the command line's nominal has ``countersink_gauge_diameter`` and no gauge depth is given.
    holecli.cli.exits.Failure
        Likewise for a hole of the spec file (exit 2; raised in the command's guarded body).
    """
    if spec is None or gauge_depth is not None:
        return
    from holecli.tolerance import gauge_checked  # here: a detect without tolerances does not import it

    holes = gauge_checked(spec)
    if not holes:
        return
    if spec_file is None:
        raise click.UsageError("--countersink-gauge-diameter needs --gauge-depth (the depth below the surface at "
                               "which the gauge reads the countersink's diameter)")
    names = ", ".join(repr(hole.name) for hole in holes)
    raise Failure(f"{spec_file}: hole {names} {'has' if len(holes) == 1 else 'have'} countersink_gauge_diameter: give "
                  f"--gauge-depth (the depth below the surface at which the gauge reads the countersink's diameter)",
                  EXIT_USAGE)


def nominal_from_options(spec_file=None, **options):
    """The :class:`holecli.tolerance.Spec` of the nominal options.

    Parameters
    ----------
    spec_file : str or None
        ``--spec`` (read later, by :func:`read_spec`, inside the guarded body).
    **options
        The other tolerance options' values by their click parameter names (``nominal_diameter``,
        ``tolerance``, ``nominal_center``, ``position_tolerance``, ``nominal_normal``, ``max_tilt``,
        ``countersink_diameter``, ``countersink_diameter_tolerance``, ..., ``max_perpendicularity``;
        None when not given).

    Returns
    -------
    holecli.tolerance.Spec or None
        None when no tolerance option is given, or ``--spec`` is.

    Raises
    ------
    click.UsageError
        For combinations that do not make sense (``--spec`` with the other options, ``--tolerance``
        without ``--nominal-diameter``, ...).
    """
    values = {_NOMINAL_SPEC_KEYS.get(name, name): value for name, value in options.items()}
    unknown = sorted(set(values) - set(TOLERANCE_OPTION_NAMES))
    if unknown:
        raise TypeError(f"nominal_from_options() got an unexpected keyword argument {unknown[0]!r}")
    given = [TOLERANCE_OPTION_NAMES[key] for key, value in values.items() if value is not None]
    if spec_file is not None:
        if given:
            raise click.UsageError(f"--spec cannot be combined with {', '.join(given)}")
        return None
    if not given:
        return None
    from holecli.tolerance import nominal_spec  # here: a detect without tolerances does not import it

    try:
        return nominal_spec(**values, names=TOLERANCE_OPTION_NAMES)
    except SpecError as error:
        raise click.UsageError(str(error)) from None


def registration_option_decorators(plain_name):
    """``--registration FILE`` and ``--name`` of ``detect`` (``plain_name``: ``--name HOLE`` too) and
    ``batch``.

    Returns
    -------
    callable
        A decorator that applies both options.
    """
    scans = "SCAN" if plain_name else "a scan"
    options = [
        click.option("--registration", "registration_file", type=click.Path(dir_okay=False, path_type=str),
                     default=None, metavar="FILE.json",
                     help="holecli register's JSON result: the --spec holes (part frame) are mapped into the "
                          "scans' frame by its transform, and its uncertainty at each hole enters the "
                          "position (and tilt) check's U. Needs --spec."),
        click.option("--name", "name_pairs", type=HoleTie(plain=plain_name), multiple=True,
                     help=f"{scans}'s hole is the spec hole HOLE (SCAN=HOLE, repeatable"
                          f"{'; HOLE alone for SCAN' if plain_name else ''}): checked against it wherever it "
                          "lies, the spec's other holes not expected in that scan. By default a one-hole scan "
                          "whose file stem is a spec hole's name (R1.ply) is that hole, as in holecli register. "
                          "Needs --spec."),
    ]
    return lambda function: _applied(options, function)


def inspection_from_options(spec, spec_file, registration_file, name_pairs, scans=None):
    """``spec`` with ``--registration`` and ``--name`` (:class:`holecli.inspection.Inspection`), or
    ``spec`` itself (the command line's nominal hole without them).

    Parameters
    ----------
    spec : holecli.tolerance.Spec or None
    spec_file : str or None
    registration_file : str or None
    name_pairs : tuple of (str or None, str)
    scans : list of str, optional
        detect's SCAN: every ``--name`` SCAN must be it.

    Raises
    ------
    Failure
        With the usage code: ``--registration`` or ``--name`` without ``--spec``, an unknown hole
        name (naming the spec and its holes), a ``--name`` SCAN that is not detect's SCAN; with the
        input code: a registration that cannot be read.
    """
    if spec_file is None:
        if registration_file is not None or name_pairs:
            option = "--registration" if registration_file is not None else "--name"
            raise Failure(f"{option} needs --spec (the part's nominal holes it applies to)", EXIT_USAGE)
        return spec
    from holecli.inspection import Inspection  # here: a detect without --spec does not import it

    hole_names = [hole.name for hole in spec.holes]
    for scan, hole in name_pairs:
        shown = hole if scan is None else f"{scan}={hole}"
        if hole not in hole_names:
            raise Failure(f"--name {shown}: no hole {hole!r} in {spec_file} (its holes: {', '.join(hole_names)})",
                          EXIT_USAGE)
        if scans is not None and scan is not None:
            from holecli.inspection import tied_hole_name

            if not any(tied_hole_name(path, [(scan, hole)], ())[0] for path in scans):
                raise Failure(f"--name {shown}: {scan} is not SCAN ({', '.join(scans)})", EXIT_USAGE)
    registration = provenance = None
    if registration_file is not None:
        registration, provenance = read_registration(registration_file)
    return Inspection(spec, registration, provenance, tuple(name_pairs))


def fields_option(batch=False):
    """``--fields FIELD[,FIELD...]``: the columns of ``--format csv``, in this order (:class:`CsvFields`).

    Parameters
    ----------
    batch : bool
        ``holecli batch``'s columns (with ``error`` and ``path``).

    Returns
    -------
    callable
        The decorator; the command gets ``fields`` (None, or a tuple of column names).
    """
    return click.option(
        "--fields", "fields", type=CsvFields(batch), default=None,
        help="With --format csv: write only these columns, in this order (comma-separated names of the CSV's "
             "header, e.g. file,hole,diameter,u_diameter,in_tolerance; docs/reference/output.md lists them).")


def check_fields(fields, fmt):
    """Refuse ``--fields`` with a format other than CSV (a JSON record has every field).

    Raises
    ------
    click.UsageError
    """
    if fields is not None and fmt != "csv":
        raise click.UsageError("--fields chooses the columns of --format csv; the JSON record has every field")
