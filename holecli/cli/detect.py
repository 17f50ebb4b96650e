"""``holecli detect``: measure the holes of one scan and print the record (JSON, CSV or a table)."""

from __future__ import annotations

import io as _stringio
import sys

import click

from holecli.cli.exits import EXIT_CODES_HELP, EXIT_OUT_OF_TOLERANCE, EXIT_UNDECIDED, exit_code, run_guarded
from holecli.cli.options import (check_verbosity, columns_option, decision_from_options,
                                 detection_option_decorators,
                                 detection_options, fail_on_warning_option, input_format_option, nominal_from_options,
                                 inspection_from_options, read_spec, reading_option_decorators,
                                 refuse_same_files, registration_option_decorators, require_gauge_depth,
                                 tolerance_option_decorators,
                                 unit_choice,
                                 verbosity_option_decorators, with_decision)
from holecli.cli.options import check_fields, fields_option
from holecli.cli.outputs import write_outputs
from holecli.cli.source import check_stdin_format, measure


def render(records, fmt, fields=None):
    """The text of ``records`` in the requested format.

    Parameters
    ----------
    records : list of dict
        ``detect`` records (:meth:`holecli.Detection.to_dict`, with verdicts when checked).
    fmt : {"json", "jsonl", "csv", "table"}
        ``--format``.
    fields : tuple of str, optional
        ``--fields``: the CSV's columns (default :data:`holecli.report.CSV_COLUMNS`).

    Returns
    -------
    str
        Whole lines: one JSON object per record (indented; on one line for ``jsonl``), CSV with a
        header, or the tables of :func:`render_table`.
    """
    from holecli import report

    if fmt == "json":
        return "".join(report.to_json(record) for record in records)
    if fmt == "jsonl":
        return "".join(report.to_json_line(record) for record in records)
    if fmt == "csv":
        buffer = _stringio.StringIO()
        report.write_csv(records, buffer, columns=fields or report.CSV_COLUMNS)
        return buffer.getvalue()
    return render_table(records)


# A terminal narrower than this gets the narrow table layout: one block of ``field value`` rows per hole.
NARROW_TABLE_BELOW = 100


def table_width():
    """The width ``--format table`` fits its tables to: the terminal's (``COLUMNS`` when set, as
    :func:`shutil.get_terminal_size` reads it), 140 when stdout is not a terminal and ``COLUMNS`` is unset.

    Returns
    -------
    int
    """
    import shutil

    return max(40, shutil.get_terminal_size(fallback=(140, 24)).columns)


def expanded(u, k):
    """``U = k·u`` as table text (``-`` when ``u`` is not known)."""
    return "-" if u is None else f"{k * u:.2g}"


def render_table(records, width=None):
    """The ``--format table`` text of ``records``: one table per record (and one of its rejected
    candidates, with ``--explain``), fitted to ``width``.

    From :data:`NARROW_TABLE_BELOW` columns on, one row per hole (the checks of a checked hole in a
    table of their own below it); narrower, one block of ``field value`` rows per hole. Beside the
    center, the diameter and the values below the edge: their expanded uncertainty ``U = k·u``
    (``k`` the record's coverage factor, 2 when it was not checked), ``-`` when not known.

    Parameters
    ----------
    records : list of dict
        ``detect`` records.
    width : int, optional
        The width of the text (default :func:`table_width`).

    Returns
    -------
    str
        The tables as rich draws them, no line longer than ``width``, without colour.
    """
    from rich.console import Console
    from rich.table import Table

    from holecli.tolerance import DEFAULT_COVERAGE_FACTOR
    from holecli.units import table_decimals

    width = table_width() if width is None else width
    narrow = width < NARROW_TABLE_BELOW
    buffer = _stringio.StringIO()
    console = Console(file=buffer, width=width, force_terminal=False, color_system=None)
    for record in records:
        plane = record["plane"]
        verdict = record.get("verdict")
        unit = record.get("units")
        digits = table_decimals(unit)
        k = (verdict or {}).get("coverage_factor", DEFAULT_COVERAGE_FACTOR)
        caption = (f"plane rms {plane['rms']:.{digits}f} {unit}" if unit else f"plane rms {plane['rms']:.4g}") \
            + f", {record['timing']['elapsed_ms']:.1f} ms"
        if verdict is not None:
            out = verdict["out_of_tolerance"] or verdict["missing"]
            state = "IN TOLERANCE" if verdict["in_tolerance"] else ("OUT OF TOLERANCE" if out else "UNDECIDED")
            caption += f"; {state}: {verdict['checked']} checked, {verdict['out_of_tolerance']} out"
            if verdict.get("undecided"):
                caption += f", {verdict['undecided']} undecided"
            if verdict["missing"]:
                caption += ", missing: " + ", ".join(str(name) for name in verdict["missing"])
            if "decision_rule" in verdict:
                caption += f" ({verdict['decision_rule']} rule, k={verdict['coverage_factor']:g})"
        if record["holes"]:
            caption += f"; U = {k:g}u" + ("" if narrow else ", U ctr in the hole's plane")
        units_note = f", lengths in {unit}" if unit else ""
        title = f"{record['file']}  ({record['points']} points, method {record['method']}{units_note})"
        if narrow:
            _print_narrow(console, record, title, caption, digits, k)
        else:
            _print_wide(console, record, title, caption, digits, k)
        if any((hole.get("countersink") or {}).get("gauge_depth") is not None for hole in record["holes"]):
            console.print(_gauge_table(record["holes"], digits))
        if "rejected" in record:
            console.print(_rejected_table(record["rejected"], digits, narrow))
    return buffer.getvalue()


def _print_wide(console, record, title, caption, digits, k):
    """One row per hole, the checks below, then the tables below the edge and of the codes (100 columns or more)."""
    from rich.table import Table

    verdict = record.get("verdict")
    table = Table(title=title, caption=caption)
    columns = ["hole", "center x", "center y", "center z", "U ctr", "diameter", "U dia", "normal", "rim pts",
               "fit rms", "partial"]
    if verdict is not None:
        columns.append("tolerance")
    for column in columns:  # numbers are never broken: the normal wraps instead
        table.add_column(column, justify="left" if column == "tolerance" else "right",
                         no_wrap=column not in ("normal", "tolerance"))
    for hole in record["holes"]:
        u = hole.get("uncertainty") or {}
        cells = [
            str(hole["index"]), *(f"{v:.{digits}f}" for v in hole["center"]), expanded(u.get("center_in_plane"), k),
            f"{hole['diameter']:.{digits}f}", expanded(u.get("diameter"), k),
            "(" + ", ".join(f"{v:.4f}" for v in hole["normal"]) + ")", str(hole["rim_points"]),
            f"{hole['fit_rms']:.{digits}f}" if record.get("units") else f"{hole['fit_rms']:.2g}",
            "yes" if hole.get("partial") else "no",
        ]
        if verdict is not None:
            cells.append(verdict_state(hole))
        table.add_row(*cells)
    if not record["holes"]:
        table.add_row("-", "", "", "", "", "no hole found", *[""] * (len(columns) - 6))
    console.print(table)
    checked = [hole for hole in record["holes"] if hole.get("in_tolerance") is not None]
    if checked:
        # the verdict of each checked hole, then one row per check (generic: every entry of conformance)
        table = Table(title="checks")
        table.add_column("hole", justify="right", no_wrap=True)
        table.add_column("tolerance; each check: value, limits, U, decision", justify="left")
        for hole in checked:
            table.add_row(str(hole["index"]), verdict_summary(hole))
            for check, entry in (hole.get("conformance") or {}).items():
                table.add_row("", "  " + conformance_text(check, entry))
        console.print(table)
    if any(hole.get("type") for hole in record["holes"]):
        console.print(_shape_table(record["holes"], digits, k))
    codes = _codes_table(record["holes"])
    if codes is not None:
        console.print(codes)


def _print_narrow(console, record, title, caption, digits, k):
    """One block of ``field value`` rows per hole (a terminal narrower than :data:`NARROW_TABLE_BELOW`)."""
    from rich.table import Table

    console.print(title, overflow="fold")
    if not record["holes"]:
        console.print("no hole found")
    for hole in record["holes"]:
        table = Table(title=f"hole {hole['index']}" + (f" ({hole['name']})" if hole.get("name") else ""),
                      show_header=False)
        table.add_column("field", justify="left", no_wrap=True)
        table.add_column("value", justify="left")
        for field, value in hole_fields(hole, digits, k, bool(record.get("units"))):
            table.add_row(field, value)
        console.print(table)
    console.print(caption)


def hole_fields(hole, digits, k, unit_known=True):
    """The ``(field, value)`` rows of a hole in the narrow table: its values with their ``U = k·u``, what
    it shows below the edge, its warnings and notes, and, checked, its verdict and one row per check.

    Parameters
    ----------
    hole : dict
        A hole of a ``detect`` record (checked or not).
    digits : int
        Decimals of a length.
    k : float
        The coverage factor of ``U``.
    unit_known : bool
        Whether the record's unit is known (the fit rms then has ``digits`` decimals).

    Returns
    -------
    list of (str, str)
    """
    u = hole.get("uncertainty") or {}

    def with_u(value, uncertainty, decimals=digits):
        if value is None:
            return "-"
        return f"{value:.{decimals}f}" + ("" if uncertainty is None else f"  U {k * uncertainty:.2g}")

    rows = [("center", ", ".join(f"{v:.{digits}f}" for v in hole["center"])),
            ("U center", f"{expanded(u.get('center_in_plane'), k)} in plane, "
                         f"{expanded(u.get('center_along_normal'), k)} along normal"),
            ("diameter", with_u(hole["diameter"], u.get("diameter"))),
            ("normal", ", ".join(f"{v:.4f}" for v in hole["normal"])
             + ("" if u.get("normal_deg") is None else f"  U {k * u['normal_deg']:.2g} deg")),
            ("rim points", str(hole["rim_points"])),
            ("fit rms", f"{hole['fit_rms']:.{digits}f}" if unit_known else f"{hole['fit_rms']:.2g}"),
            ("partial", "yes" if hole.get("partial") else "no")]
    if hole.get("type"):
        rows.append(("type", hole["type"]))
        for part, key, label, decimals in _SHAPE_VALUES:
            value = (hole.get(part) or {}).get(key) if part else hole.get(key)
            if value is not None:
                uncertainty = ((u.get(part) or {}).get(key) if part else u.get(key))
                rows.append((label, with_u(value, uncertainty, digits if decimals is None else decimals)))
    for kind in ("warnings", "notes"):
        codes = [item["code"] for item in hole.get(kind) or ()]
        if codes:
            rows.append((kind, ", ".join(codes)))
    if "in_tolerance" in hole:
        rows.append(("tolerance", verdict_summary(hole)))
        for check, entry in (hole.get("conformance") or {}).items():
            rows.append(("check", conformance_text(check, entry)))
    return rows


# The values below the edge in the tables: (part of the hole or None, key, label, decimals or None for
# a length's); the uncertainty of each is at the same place in holes[].uncertainty.
_SHAPE_VALUES = (
    ("countersink", "diameter", "csk dia", None), ("countersink", "angle_deg", "csk angle", 2),
    ("countersink", "depth", "csk depth", None), ("countersink", "diameter_at_depth", "csk dia at depth", None),
    ("counterbore", "diameter", "cbore dia", None), ("counterbore", "depth", "cbore depth", None),
    ("bore", "diameter", "bore dia", None), ("bore", "floor_depth", "floor depth", None),
    (None, "perpendicularity_deg", "perp deg", 3),
)


def _shape_table(holes, length_digits=4, k=2.0):
    """The table of what each hole shows below its edge: type, countersink, counterbore, bore, axis
    (lengths with ``length_digits`` decimals), each value over its ``U = k·u`` when known."""
    from rich.table import Table

    def number(value, digits=length_digits, uncertainty=None):
        if value is None:
            return "-"
        return f"{value:.{digits}f}" + ("" if uncertainty is None else f"\nU {k * uncertainty:.2g}")

    rows = []
    for hole in holes:
        countersink, counterbore, bore = (hole.get(key) or {} for key in ("countersink", "counterbore", "bore"))
        u = hole.get("uncertainty") or {}
        u_countersink, u_counterbore, u_bore = (u.get(key) or {} for key in ("countersink", "counterbore", "bore"))
        rows.append([str(hole["index"]), hole.get("type") or "-",
                     number(countersink.get("diameter"), uncertainty=u_countersink.get("diameter")),
                     number(countersink.get("angle_deg"), 2, u_countersink.get("angle_deg")),
                     number(countersink.get("depth"), uncertainty=u_countersink.get("depth")),
                     number(counterbore.get("diameter"), uncertainty=u_counterbore.get("diameter")),
                     number(counterbore.get("depth"), uncertainty=u_counterbore.get("depth")),
                     number(bore.get("diameter"), uncertainty=u_bore.get("diameter")),
                     number(bore.get("floor_depth"), uncertainty=u_bore.get("floor_depth")),
                     number(hole.get("perpendicularity_deg"), 3, u.get("perpendicularity_deg"))])
    table = Table(title="below the edge")
    # the words and the values over their U are never cut: the numbers' headers wrap instead
    for index, column in enumerate(("hole", "type", "csk dia", "csk angle", "csk depth", "cbore dia", "cbore depth",
                                    "bore dia", "floor depth", "perp deg")):
        widest = max((len(line) for row in rows for line in row[index].split("\n")), default=1)
        table.add_column(column, justify="left" if column == "type" else "right", min_width=widest)
    for row in rows:
        table.add_row(*row)
    return table


def _codes_table(holes):
    """The table of the holes' warning and note codes (one a line: the cells as narrow as the longest code),
    None when no hole has any."""
    from rich.table import Table

    rows = [(str(hole["index"]), "\n".join(warning["code"] for warning in hole.get("warnings", [])),
             "\n".join(note["code"] for note in hole.get("notes", [])))
            for hole in holes if hole.get("warnings") or hole.get("notes")]
    if not rows:
        return None
    table = Table(title="warnings and notes")
    for index, column in enumerate(("hole", "warnings", "notes")):
        widest = max((len(line) for row in rows for line in row[index].split("\n")), default=1)
        table.add_column(column, justify="right" if column == "hole" else "left", no_wrap=True,
                         min_width=max(widest, len(column)))
    for row in rows:
        table.add_row(*row)
    return table
def _gauge_table(holes, length_digits=4):
    """The table of the countersink gauge readings (``--gauge-depth``): per countersunk hole the gauge
    depth, the countersink's diameter there, and with a gauge check its nominal, deviation, U and
    decision."""
    from rich.table import Table

    def number(value, signed=False):
        return "-" if value is None else (f"{value:+.{length_digits}f}" if signed else f"{value:.{length_digits}f}")

    table = Table(title="countersink gauge (diameter at the gauge depth)")
    for column in ("hole", "name", "gauge depth", "diameter there", "nominal", "deviation", "U", "decision"):
        table.add_column(column, justify="left" if column in ("name", "decision") else "right")
    for hole in holes:
        countersink = hole.get("countersink") or {}
        if hole.get("type") != "countersunk" and (hole.get("conformance") or {}).get("countersink_gauge") is None:
            continue
        entry = (hole.get("conformance") or {}).get("countersink_gauge")
        measured = countersink.get("diameter_at_depth")
        deviation = None if entry is None else entry["value"]
        nominal = None if entry is None or deviation is None or measured is None else measured - deviation
        table.add_row(str(hole["index"]), hole.get("name") or "-", number(countersink.get("gauge_depth")),
                      number(measured), number(nominal), number(deviation, signed=True),
                      "-" if entry is None or entry["expanded_uncertainty"] is None
                      else f"{entry['expanded_uncertainty']:.2g}",
                      "not checked" if entry is None else entry["decision"])
    return table


# The value a failed check is shown with in the table: the field of the checked hole (a deviation, or
# the measured angle for tilt and perpendicularity).
_FAILED_CHECK_VALUES = {
    "diameter": "diameter_deviation", "tilt": "tilt_deg", "perpendicularity": "perpendicularity_deg",
    "countersink_diameter": "countersink_diameter_deviation", "countersink_angle": "countersink_angle_deviation",
    "countersink_depth": "countersink_depth_deviation", "bore_diameter": "bore_diameter_deviation",
    "countersink_gauge": "countersink_gauge_deviation",
}


def verdict_summary(hole):
    """The first line of :func:`verdict_cell`: the hole's name and ``in``, ``not checked``, ``OUT: ...`` or
    ``UNDECIDED: ...`` (the table's ``tolerance`` column; the checks are in a table of their own)."""
    return verdict_cell(hole).split("\n", 1)[0]


def verdict_state(hole):
    """The ``tolerance`` cell of a hole in the wide table: its name and ``in``, ``OUT``, ``UNDECIDED`` or
    ``not checked`` (what failed and every check are in the table ``checks`` below)."""
    name = f"{hole['name']}: " if hole.get("name") else ""
    if hole["in_tolerance"] is None:
        return name + "not checked"
    if hole["in_tolerance"]:
        return name + "in"
    return name + ("OUT" if hole.get("failed_checks") else "UNDECIDED")


def verdict_cell(hole):
    """The ``tolerance`` cell of a hole in ``--format table``: its name, and ``in``, ``not checked``,
    ``OUT:`` with every failed check and its value or ``UNDECIDED:`` with every undecided check; then,
    for a hole with ``conformance``, one line per check with its value, limits, U and decision.

    Parameters
    ----------
    hole : dict
        A hole of a checked record (:func:`holecli.tolerance.check`).

    Returns
    -------
    str
        E.g. ``"A1: OUT: diameter -0.0029, countersink_angle +1.21, bore_diameter not measured"``
        (deviations signed; ``position`` with its in-plane distance, ``tilt`` and
        ``perpendicularity`` with their angle), and lines such as
        ``"diameter -0.0031 in [+0, +0.036] U 0.004: undecided"`` or
        ``"position 0.061 <= 0.1 U -: fail"`` (U ``-`` when not known).
    """
    name = f"{hole['name']}: " if hole.get("name") else ""
    if hole["in_tolerance"] is None:
        return name + "not checked"
    lines = [name + ("in" if hole["in_tolerance"] else _failures(hole))]
    for check, entry in (hole.get("conformance") or {}).items():
        lines.append(conformance_text(check, entry))
    return "\n".join(lines)


def _failures(hole):
    """``OUT: ...`` with the failed checks and their values, ``; undecided: ...`` with the undecided ones
    (``UNDECIDED: ...`` alone when none failed)."""
    failures = []
    for check in hole["failed_checks"]:
        if check.endswith("_not_measured"):
            failures.append(f"{check.removesuffix('_not_measured')} not measured")
            continue
        if check == "position":
            value = f"{hole['position_deviation']['in_plane']:.4g}"
        else:
            field = _FAILED_CHECK_VALUES.get(check, "")
            number = hole.get(field)
            value = "" if number is None else (f"{number:+.4g}" if field.endswith("_deviation") else f"{number:.4g}")
        failures.append(f"{check} {value}".rstrip())
    undecided = ", ".join(hole.get("undecided_checks") or ())
    if not failures:
        return "UNDECIDED: " + undecided
    return "OUT: " + ", ".join(failures) + (f"; undecided: {undecided}" if undecided else "")


def conformance_text(check, entry):
    """One check of a hole's ``conformance`` as text: ``diameter -0.0031 in [+0, +0.036] U 0.004: undecided``.

    Parameters
    ----------
    check : str
        The check's name.
    entry : dict
        Its conformance entry (``value``, ``lower``, ``upper``, ``expanded_uncertainty``, ``decision``).

    Returns
    -------
    str
        A deviation and a band's limits signed; a largest value (``lower`` None) as ``<= limit``;
        ``not measured`` for a null value, ``U -`` for an uncertainty not known.
    """
    band = entry["lower"] is not None
    value = entry["value"]
    value_text = "not measured" if value is None else (f"{value:+.4g}" if band else f"{value:.4g}")
    limits = f"in [{entry['lower']:+.4g}, {entry['upper']:+.4g}]" if band else f"<= {entry['upper']:.4g}"
    expanded = entry["expanded_uncertainty"]
    return f"{check} {value_text} {limits} U {'-' if expanded is None else f'{expanded:.2g}'}: {entry['decision']}"


def refused_summary(checks, explain=False):
    """Why no hole was reported, for the "no hole found" line: `` (3 candidates refused: 2 below_min_diameter,
    1 not_round; --explain lists them)``, most frequent first; empty when no candidate was examined."""
    if not checks:
        return " (no candidate: the surface has no empty region a hole would leave)"
    counts = {}
    for check in checks:
        counts[check] = counts.get(check, 0) + 1
    reasons = ", ".join(f"{count} {check}" for check, count in sorted(counts.items(), key=lambda item: (-item[1], item[0])))
    plural = "" if len(checks) == 1 else "s"
    hint = "" if explain else "; --explain lists them"
    return f" ({len(checks)} candidate{plural} refused: {reasons}{hint})"


def _rejected_table(rejected, digits=4, narrow=False):
    from rich.table import Table

    def number(value):
        return "" if value is None else (str(value) if isinstance(value, int) else f"{value:.4g}")

    table = Table(title=f"{len(rejected)} candidate{'' if len(rejected) == 1 else 's'} not reported as holes")
    if narrow:  # the check, then the candidate's values and why on lines of their own
        table.add_column("check", justify="left", no_wrap=True)
        table.add_column("candidate", justify="left")
        for rejection in rejected:
            table.add_row(rejection["check"],
                          "center " + ", ".join(f"{v:.{digits}f}" for v in rejection["center"])
                          + f"\nsize {rejection['diameter']:.{digits}f}, value {number(rejection['value']) or '-'}, "
                            f"limit {number(rejection['limit']) or '-'}\n{rejection['reason']}")
        return table
    for column in ("check", "center x", "center y", "center z", "size", "value", "limit", "why"):
        table.add_column(column, justify="left" if column in ("check", "why") else "right",
                         no_wrap=column == "check")
    for rejection in rejected:
        table.add_row(rejection["check"], *(f"{v:.{digits}f}" for v in rejection["center"]),
                      f"{rejection['diameter']:.{digits}f}",
                      number(rejection["value"]), number(rejection["limit"]), rejection["reason"])
    return table


def scale_hint(factor, scan_unit, spec_unit):
    """The words of :func:`holecli.tolerance.unit_scale_match`'s answer, for the far-from-spec hint:
    ``every spec hole matches a measured one with the scan's coordinates times 1000: the scan may be in m
    and the spec in mm; give --units m``."""
    shown = f"{factor:g}" if factor >= 1 else f"1/{1 / factor:g}"
    return (f"every spec hole matches a measured one with the scan's coordinates times {shown}: the scan may be "
            f"in {scan_unit} and the spec in {spec_unit}; give --units {scan_unit} (and units = \"{spec_unit}\" "
            f"in the spec)")


def unit_mismatch_hint(record):
    """`` (2 holes with unit_mismatch: the scan and the tolerances may be in different units; see the warning)``
    for the out-of-tolerance line of a record whose holes have that warning; else empty."""
    from holecli.units import UNIT_MISMATCH

    count = sum(any(w["code"] == UNIT_MISMATCH for w in hole.get("warnings", ())) for hole in record["holes"])
    if not count:
        return ""
    return (f" ({count} hole{'' if count == 1 else 's'} with {UNIT_MISMATCH}: the scan and the tolerances may be "
            f"in different units; see the warning)")


def spec_units_line(record):
    """The stderr line of a record whose spec declared a unit the scan's was taken to be (the scan's unit
    not known): ``holecli: warning: FILE: spec_units_assumed: ...``; else None."""
    verdict = record.get("verdict") or {}
    if not verdict.get("spec_units_assumed"):
        return None
    unit = verdict["spec_units"]
    return (f"holecli: warning: {record['file']}: spec_units_assumed: the spec is in {unit} and the scan's unit is "
            f"not known: the scan is taken to be in {unit} (give --units to say it)")


def min_diameter_hint(record, min_diameter):
    """``; --min-diameter 2 is larger than the whole scan (about 0.0253 across): is it in the scan's unit?
    ...`` for the "no hole found" line, when the given ``--min-diameter`` (in the record's unit) exceeds
    the scan's size (:func:`holecli.units.min_diameter_beyond_scan`); else empty."""
    from holecli.units import min_diameter_beyond_scan

    scales = record.get("scales") or {}
    size = min_diameter_beyond_scan(min_diameter, record.get("points", 0), scales.get("point_spacing"))
    if size is None:
        return ""
    return (f"; --min-diameter {min_diameter:g} is larger than the whole scan (about {size:.3g} across): is it in "
            f"the scan's unit? (--units and --output-units say the units)")


def warning_lines(record):
    """The stderr lines of a record's doubtful results: ``holecli: warning: FILE hole N: code: message``
    for each warning of a hole (the notes, which say why a value is null, are in the record, and with
    ``--verbose`` on stderr: a scan straight down a bore gives ``bore_not_seen`` on every hole).

    Parameters
    ----------
    record : dict
        A ``detect`` record.

    Returns
    -------
    list of str
    """
    return [f"holecli: warning: {record['file']} hole {hole['index']}: {warning['code']}: {warning['message']}"
            for hole in record.get("holes", ()) for warning in hole.get("warnings", ())]


def zone_note_lines(record):
    """The stderr lines of the checks that a guarded decision can never pass (their U exceeds the
    tolerance zone, note ``uncertainty_exceeds_tolerance``):
    ``holecli: note: FILE hole N (NAME): uncertainty_exceeds_tolerance: diameter: 2U = ...``.

    Parameters
    ----------
    record : dict
        A ``detect`` record (checked, or not: then there is none).

    Returns
    -------
    list of str
    """
    from holecli.tolerance import UNCERTAINTY_NOTE

    lines = []
    for hole in record.get("holes", ()):
        name = f" ({hole['name']})" if hole.get("name") else ""
        lines.extend(f"holecli: note: {record['file']} hole {hole['index']}{name}: {note['code']}: {note['message']}"
                     for note in hole.get("notes", ()) if note["code"] == UNCERTAINTY_NOTE)
    return lines


def undecided_line(record):
    """The stderr line of a record whose verdict is undecided (no check failed, some undecided):
    ``holecli: undecided: 1 of 2 checked holes (guarded, k=2: conformance not proved) in FILE``.

    Parameters
    ----------
    record : dict
        A checked ``detect`` record.

    Returns
    -------
    str
    """
    verdict = record["verdict"]
    unknown = sum(any(entry["reason"] == "uncertainty_unknown" for entry in (hole.get("conformance") or {}).values())
                  for hole in record["holes"])
    without = f", {unknown} with an uncertainty not known" if unknown else ""
    rule = f"{verdict['decision_rule']}, k={verdict['coverage_factor']:g}"
    return (f"holecli: undecided: {verdict['undecided']} of {verdict['checked']} checked holes{without} "
            f"({rule}: conformance not proved) in {record['file']}")


@click.command(epilog=EXIT_CODES_HELP)
@click.argument("scan", type=click.Path(allow_dash=True, path_type=str))
@input_format_option("Read SCAN in this format, whatever its extension (scan.asc as xyz); needed for - (stdin).")
@columns_option
@click.option("--format", "fmt", type=click.Choice(["json", "jsonl", "csv", "table"]), default="json", show_default=True,
              help="Output format: JSON record (indented), JSON Lines (the record on one compact line, as batch "
                   "writes it: for appending to a log), CSV (one row per hole) or a table for people (fitted to the "
                   "terminal, with U = k·u beside the values; a block per hole under 100 columns).")
@fields_option()
@click.option("--output", "-o", type=click.Path(dir_okay=False, allow_dash=True, path_type=str),
              help="Write the result to this file (a regular file atomically; - is stdout) instead of stdout; "
                   "with --plot, both are written or neither. Never SCAN, --spec or the --plot file.")
@click.option("--plot", "plot_file", type=click.Path(path_type=str), default=None, metavar="FILE.png|DIR/",
              help="Also draw the holes into this PNG, as holecli plot does, with the verdict when tolerances are "
                   "given; a folder (existing, or ending with /: created) gets SCAN's stem .png "
                   "(needs pip install 'holecli[plot]').")
@click.option("--explain", is_flag=True,
              help="Also list every candidate that is not a hole, with the check that refused it "
                   "(\"rejected\" in JSON, a second table with --format table).")
@reading_option_decorators
@detection_option_decorators
@tolerance_option_decorators
@registration_option_decorators(plain_name=True)
@fail_on_warning_option
@verbosity_option_decorators
def detect(scan, input_format, columns, fmt, fields, output, plot_file, explain, scan_index, units, output_units,
           method, view_dir, min_diameter, max_holes, full_only, gauge_depth, spec_file, decision_rule,
           coverage_factor, registration_file, name_pairs, fail_on_warning, quiet, verbose, **nominal_options):
    """Measure the holes in SCAN (.ply, .pcd, .csv, .txt, .xyz, .e57, .las or .laz; - reads it from
    stdin, with --input-format).

    Prints center, diameter and normal of every hole as JSON (units those of the file, or
    --output-units). With tolerance options or --spec, every checked hole also gets its deviations
    and "in_tolerance", and the record a "verdict".

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format csv --output result.csv
      holecli detect scan.ply --format csv --fields file,hole,diameter,u_diameter
      holecli detect scan.pcd --view-dir 0,0,-1 --full-only --format table
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0 --decision-rule guarded
      holecli detect scan.ply --nominal-center 3.65,5.14,5.53 --position-tolerance 0.1 \\
          --nominal-normal 0.18,-0.5,0.85 --max-tilt 1
      holecli detect scan.ply --countersink-angle 100 --countersink-angle-tolerance 1 \\
          --countersink-diameter 7 --countersink-diameter-tolerance +0.1/-0 --max-perpendicularity 0.5
      holecli detect scan.ply --gauge-depth 0.5
      holecli detect scan.ply --spec part.toml --format table
      holecli detect R1.ply --spec part.toml --registration registration.json
      holecli detect left.ply --spec part.toml --name R1
      holecli detect scan.ply --explain --format table
      holecli detect scan.ply --plot fit.png
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0 --plot plots/
      cat scan.ply | holecli detect - --input-format ply -o -
      holecli detect scan.asc --input-format xyz
      holecli detect scan.csv --columns x_mm,y_mm,z_mm
      holecli detect site.e57 --scan 1 --output-units mm
      holecli detect scan.ply --units m --output-units mm --nominal-diameter 3 --tolerance 0.02
      holecli detect scan.ply -v
      holecli detect scan.ply --fail-on-warning rim_gap,points_inside,near_border

    A hole's warnings (a result that may be wrong: rim_gap, points_inside, ...) are also said on
    stderr, one line each (not with --quiet); its notes (why a value is null: bore_not_seen, ...) are
    in the record's notes, and on stderr with --verbose.
    """
    check_verbosity(quiet, verbose)
    check_fields(fields, fmt)
    check_stdin_format(scan, input_format)
    if explain and fmt == "csv":
        raise click.UsageError("--explain needs --format json or table (CSV has one row per hole)")
    choice = unit_choice(units, output_units, [scan])
    # lengths on the command line are in the output unit: the pipeline wants the file's
    options = detection_options(method, view_dir, choice.to_file_units(min_diameter), max_holes, full_only,
                                choice.to_file_units(gauge_depth))
    if input_format is not None:
        options["input_format"] = input_format
    if columns is not None:
        options["columns"] = columns
    # the tolerance options (--nominal-diameter, ..., --max-perpendicularity) by their parameter names
    nominal = nominal_from_options(spec_file, **nominal_options)
    decision = decision_from_options(decision_rule, coverage_factor, nominal is not None or spec_file is not None)
    require_gauge_depth(nominal, gauge_depth)

    refused = []  # the checks that refused candidates, for "no hole found"
    far = []  # (distance, name) when no measured hole lies near any spec hole
    scaled = []  # (factor, scan unit, spec unit) when they would, in other units

    def body():
        from holecli.cli.progress import DetectStatus
        plot_path = None
        if plot_file is not None:
            from holecli.cli.plot import plot_path_of

            plot_path = plot_path_of(plot_file, scan)
        # before anything is read or made: no output may replace an input or another output
        refuse_same_files([("SCAN", scan), ("--spec", spec_file), ("--registration", registration_file)],
                          [("-o/--output", output), ("--plot", plot_path)])
        spec = with_decision(read_spec(spec_file) if spec_file is not None else nominal, decision)
        require_gauge_depth(spec, gauge_depth, spec_file)
        inspection = inspection_from_options(spec, spec_file, registration_file, name_pairs, [scan])
        if plot_file is not None:
            from holecli.cli.plot import plot_destination, require_matplotlib

            require_matplotlib()  # before the detection: a missing extra is said at once
            plot_path = plot_destination(plot_file, scan)  # and a folder that cannot be made
        with DetectStatus(scan, quiet=quiet) as status:
            run_options = {**options, "progress": status.stage} if status.shown else options
            measurement = measure(scan, run_options, scan_index, units=choice, spec=inspection, explain=explain,
                                  plot=plot_file is not None)
        record = measurement.record
        refused.extend(rejection.check for rejection in measurement.detection.rejected)
        if spec is not None:
            from holecli.tolerance import far_from_spec, unit_scale_match

            far.append(far_from_spec(record, measurement.spec))
            scaled.append(unit_scale_match(record, measurement.spec))
        outputs = [(output, render([record], fmt, fields), "output")]
        if plot_file is not None:
            from holecli.cli.plot import PLOT_WHAT, plot_png

            outputs.append((plot_path, plot_png(measurement), PLOT_WHAT))
        # the record and the picture together: when either cannot be written, neither is
        write_outputs(outputs)
        return record

    record = run_guarded(body)
    if verbose:
        from holecli.cli.progress import verbose_text

        click.echo(verbose_text(record), err=True, nl=False)
    if not quiet:
        for line in warning_lines(record):
            click.echo(line, err=True)
        assumed = spec_units_line(record)
        if assumed:
            click.echo(assumed, err=True)
        if not verbose:  # (--verbose says every note)
            for line in zone_note_lines(record):
                click.echo(line, err=True)
    if not quiet and not record["holes"]:
        why = refused_summary(refused, explain) if method == "robust" else ""  # (the paper's has no candidates)
        click.echo(f"holecli: no hole found in {record['file']}{why}{min_diameter_hint(record, min_diameter)}",
                   err=True)
    from holecli.batch import Tally

    code = exit_code(Tally.of([record]), fail_on_warning)
    verdict = record.get("verdict")
    if code == EXIT_OUT_OF_TOLERANCE and not quiet:
        missing = f", missing: {', '.join(str(name) for name in verdict['missing'])}" if verdict["missing"] else ""
        not_measured = sum(any(check.endswith("_not_measured") for check in hole.get("failed_checks") or ())
                           for hole in record["holes"])
        unmeasured = f" ({not_measured} with a check not measured)" if not_measured else ""
        undecided = f", {verdict['undecided']} undecided" if verdict["undecided"] else ""
        hint = ""
        if far and far[0] is not None:
            distance, name = far[0]
            hint = (f" (no measured hole lies near a spec hole: the nearest is {distance:.4g} from {name}; are the "
                    f"scan and the spec in the same frame and unit? holecli register gives the frame, --units "
                    f"the unit)")
            if scaled and scaled[0] is not None:
                hint = hint[:-1] + "; " + scale_hint(*scaled[0]) + ")"
        click.echo(f"holecli: out of tolerance: {verdict['out_of_tolerance']} of {verdict['checked']} checked "
                   f"holes{unmeasured}{undecided}{missing} in {record['file']}{hint}{unit_mismatch_hint(record)}",
                   err=True)
    if code == EXIT_UNDECIDED and not quiet:
        click.echo(undecided_line(record), err=True)
    sys.exit(code)
