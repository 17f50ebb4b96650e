"""What ``holecli detect`` prints, and the other commands reuse: the record in a format (:func:`render`:
JSON, JSON Lines, CSV or the tables of :func:`render_table`, fitted to :func:`table_width`), and the lines
said on stderr about a record (its warnings, its notes, the spec's assumed unit, the verdict and why: the
``*_line``, ``*_lines``, ``*_hint`` and ``*_summary`` functions). Pure text: nothing is printed here.

rich (heavy) and the record's helpers are imported inside the functions that draw a table, so that
``holecli --help`` and the JSON formats do not import them.
"""

from __future__ import annotations

import io as _stringio

from holecli.vocabulary import UNCERTAINTY_NOTE


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

    from holecli.vocabulary import DEFAULT_COVERAGE_FACTOR
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
