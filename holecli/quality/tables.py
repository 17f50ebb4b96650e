"""A lot's characteristics as flat tables: one row per characteristic (CSV), and the AS9102 Form 3 rows.

:func:`characteristic_table` is every characteristic of every measurement with its nominal, limits,
measured value, deviation, U and decision, for a spreadsheet or a script. :func:`fai_table` is the
first article inspection's characteristic accountability (AS9102 Form 3): per part, a row per
characteristic with its number (the same number for the same characteristic on every part), its
location, its requirement as a drawing states it, the result, the tooling that measured it, and a
nonconformance number left for the quality office to fill in where the result does not conform.

Both return rows (lists of str) with a header first; :func:`csv_text` writes them.

Examples
--------
>>> from holecli.quality.lot import lot_from_records
>>> record = {"file": "scans/part_001.ply", "units": "mm", "holecli_version": "0.1.0", "holes": [{
...     "index": 0, "name": "T1", "diameter": 4.0712, "warnings": [], "conformance": {"diameter": {
...         "value": 0.0712, "lower": -0.05, "upper": 0.05, "expanded_uncertainty": 0.004,
...         "decision": "fail", "reason": "outside"}}}],
...     "verdict": {"in_tolerance": False, "missing": [], "coverage_factor": 2.0}}
>>> rows = fai_table(lot_from_records([{"record": record, "source": "shift.jsonl:1"}]))
>>> rows[1][4:8]
['1', 'hole T1', '', 'diameter 4.0000 ±0.0500 mm']
>>> rows[1][8]
'4.0712 mm (U = 0.0040, k = 2): NONCONFORMING, 0.0212 above the upper limit'
"""

from __future__ import annotations

import csv
import io
import math

from holecli.quality.lot import PRESENCE

CHARACTERISTIC_COLUMNS = (
    "measurement", "label", "part", "serial", "received", "file", "id", "hole", "characteristic", "unit",
    "nominal", "lower_tolerance", "upper_tolerance", "lower_limit", "upper_limit", "measured", "deviation",
    "expanded_uncertainty", "decision", "reason", "out_of_tolerance", "test_uncertainty_ratio", "warnings", "source",
)
"""The columns of :func:`characteristic_table` (docs/reference/report.md says what each holds)."""

FAI_COLUMNS = (
    "part_number", "serial_number", "measured_at", "file",
    "char_no", "reference_location", "characteristic_designator", "requirement", "results",
    "designed_tooling", "nonconformance_number", "comments",
)
"""The columns of :func:`fai_table`: AS9102 Form 3's fields 1 (part number), 3 (serial number), 5 to
11 and 14 (comments), with when and from which scan each part was measured."""

# How the characteristics are named for people (the requirement's words).
CHARACTERISTIC_WORDS = {
    "diameter": "diameter", "position": "position", "tilt": "tilt of the axis",
    "countersink_diameter": "countersink diameter", "countersink_angle": "countersink angle",
    "countersink_depth": "countersink depth", "bore_diameter": "bore diameter",
    "countersink_gauge": "countersink gauge diameter", "perpendicularity": "perpendicularity",
    PRESENCE: "hole present",
}


def format_value(value, unit) -> str:
    """A value as the records print it: 4 decimals of a length (0.1 um in mm), 3 of an angle in degrees,
    6 significant digits in an undeclared unit; ``-`` for None.

    Examples
    --------
    >>> format_value(7.09966, "mm"), format_value(100.12345, "deg"), format_value(0.000712, ""), format_value(None, "mm")
    ('7.0997', '100.123', '0.000712', '-')
    """
    if value is None:
        return "-"
    if unit == "deg":
        return f"{value:.3f}"
    if unit in ("mm", "um", "in", "m"):
        decimals = {"mm": 4, "um": 1, "in": 5, "m": 7}[unit]
        return f"{value:.{decimals}f}"
    return f"{value:.6g}"


def unit_suffix(unit) -> str:
    """The unit written after a value: `` mm``, ``°`` for degrees, nothing when not declared."""
    if unit == "deg":
        return "\N{DEGREE SIGN}"
    return f" {unit}" if unit else ""


def requirement_text(c) -> str:
    """The requirement of a characteristic as a drawing states it: ``diameter 4.0000 +0.0500/-0.0500 mm``,
    ``position <= 0.1000 mm``, ``hole T1 present``."""
    words = CHARACTERISTIC_WORDS.get(c.name, c.name)
    if c.name == PRESENCE:
        return f"hole {c.hole} present"
    if c.is_zone:
        return f"{words} \N{LESS-THAN OR EQUAL TO} {format_value(c.upper_tolerance, c.unit)}{unit_suffix(c.unit)}"
    tolerance = _band_text(c.lower_tolerance, c.upper_tolerance, c.unit)
    nominal = format_value(c.nominal, c.unit) if c.nominal is not None else "(nominal not known: not measured)"
    return f"{words} {nominal} {tolerance}{unit_suffix(c.unit)}"


def reason_text(c) -> str:
    """Why a characteristic is not a pass, in words (empty for a pass).

    Examples
    --------
    >>> from holecli.quality.lot import Characteristic
    >>> c = Characteristic(0, 0, "T1", "diameter", "mm", 4.0, 4.03, 0.03, -0.05, 0.05, 3.95, 4.05, 0.04,
    ...                    "undecided", "straddles_upper")
    >>> reason_text(c)
    'undecided: 4.0300 mm +- U = 0.0400 straddles the upper limit'
    """
    unit = c.unit
    u = format_value(c.expanded_uncertainty, unit)
    value = f"{format_value(c.measured, unit)}{unit_suffix(unit)}"
    texts = {
        "outside": lambda: f"{_beyond(c)}",
        "outside_with_uncertainty": lambda: f"{_beyond(c)}, by more than U = {u}",
        "straddles_lower": lambda: f"undecided: {value} +- U = {u} straddles the lower limit",
        "straddles_upper": lambda: f"undecided: {value} +- U = {u} straddles the upper limit",
        "straddles_both": lambda: f"undecided: U = {u} is wider than the tolerance zone",
        "uncertainty_unknown": lambda: "undecided: the measurement's uncertainty is not known",
        "not_measured": lambda: "not measured: the scan does not show it (a fail until measured)",
        "missing": lambda: "the hole was not found in the scan",
    }
    if c.decision == "pass":
        return ""
    return texts.get(c.reason, lambda: c.reason)()


def characteristic_table(lot) -> list:
    """Every characteristic of the lot, a row each, in measurement order.

    Parameters
    ----------
    lot : holecli.quality.lot.Lot

    Returns
    -------
    list of list of str
        :data:`CHARACTERISTIC_COLUMNS` first; numbers in full precision (``repr``), empty where None.
    """
    rows = [list(CHARACTERISTIC_COLUMNS)]
    for m in lot.measurements:
        for c in m.characteristics:
            rows.append([
                str(m.order + 1), m.label, m.part or "", m.serial or "", m.received or "", m.record.get("file", ""),
                m.id or "", c.hole, c.name, c.unit, _number(c.nominal), _number(c.lower_tolerance),
                _number(c.upper_tolerance), _number(c.lower), _number(c.upper), _number(c.measured),
                _number(c.deviation), _number(c.expanded_uncertainty), c.decision, c.reason,
                _number(c.exceedance), _number(c.test_uncertainty_ratio), " ".join(c.warnings), m.source])
    return rows


def fai_table(lot, *, part_number=None) -> list:
    """The AS9102 Form 3 rows of every measurement of the lot.

    Each characteristic gets its number from its place in the lot (:attr:`Lot.keys`; a missing hole's
    presence after them), so that the same characteristic has the same number on every part's form.

    Parameters
    ----------
    lot : holecli.quality.lot.Lot
    part_number : str, optional
        Form 3's field 1 where the measurements' metadata has no part.

    Returns
    -------
    list of list of str
        :data:`FAI_COLUMNS` first, then per measurement a row per characteristic (an error record: one
        row saying the scan could not be measured).
    """
    numbers = {key: n for n, key in enumerate(lot.keys, 1)}
    for c in lot.characteristics:
        if c.name == PRESENCE:
            numbers.setdefault(c.key, len(numbers) + 1)
    rows = [list(FAI_COLUMNS)]
    for m in lot.measurements:
        version = m.record.get("holecli_version")
        tooling = f"laser profile scan, holecli {version}" if version else "laser profile scan, holecli"
        head = [m.part or part_number or "", m.serial or m.label, m.received or "", m.record.get("file", "")]
        if "error" in m.record:
            rows.append(head + ["", "", "", "the whole part", f"not measured: {m.record['error']}", tooling, "",
                                "the scan could not be measured: measure the part again"])
            continue
        coverage = (m.record.get("verdict") or {}).get("coverage_factor")
        for c in sorted(m.characteristics, key=lambda c: numbers[c.key]):
            rows.append(head + [str(numbers[c.key]), f"hole {c.hole}", "", requirement_text(c),
                                _result_text(c, coverage), tooling, "", _comment(c)])
    return rows


def csv_text(rows) -> str:
    """``rows`` as CSV text (RFC 4180 quoting, ``\\r\\n`` line ends as the csv module writes them)."""
    buffer = io.StringIO()
    csv.writer(buffer).writerows(rows)
    return buffer.getvalue()


def _result_text(c, coverage) -> str:
    """Form 3's field 9: the measured value with its U, and NONCONFORMING / UNDECIDED where it is."""
    if c.name == PRESENCE:
        return "not found: NONCONFORMING"
    if c.measured is None:
        return "not measured: NONCONFORMING"
    text = f"{format_value(c.measured, c.unit)}{unit_suffix(c.unit)}"
    if c.expanded_uncertainty is not None:
        k = f", k = {coverage:g}" if isinstance(coverage, (int, float)) else ""
        text += f" (U = {format_value(c.expanded_uncertainty, c.unit)}{k})"
    if c.decision == "fail":
        text += f": NONCONFORMING, {_beyond(c, values=False)}"
    elif c.decision == "undecided":
        text += ": UNDECIDED (within U of a limit)"
    return text


def _comment(c) -> str:
    """Form 3's field 14: what else the quality office needs to know (the hole's warnings, a TUR below 4)."""
    notes = []
    if c.decision not in ("pass",) and c.reason not in ("outside", "missing", "not_measured"):
        notes.append(reason_text(c))
    if c.warnings:
        notes.append("the scan warns: " + ", ".join(c.warnings) + " (check the hole for chips, burrs or lubricant "
                     "before rejecting it)")
    notes.append(ratio_text(c.test_uncertainty_ratio))
    return "; ".join(note for note in notes if note)


def ratio_text(ratio) -> str:
    """What a test uncertainty ratio (tolerance zone / 2U) says, in words; empty from 4:1 up or unknown.

    Examples
    --------
    >>> ratio_text(0.7)
    'test uncertainty ratio 0.7:1: U is larger than half the tolerance zone, too small for a decision (the measurement cannot tell a good part from a bad one near the limits)'
    >>> ratio_text(2.5), ratio_text(5.0)
    ('test uncertainty ratio 2.5:1 (below 4:1: decisions near the limits are uncertain)', '')
    """
    if ratio is None or ratio >= 4:
        return ""
    if ratio < 1:
        return (f"test uncertainty ratio {ratio:.1f}:1: U is larger than half the tolerance zone, too small for a "
                f"decision (the measurement cannot tell a good part from a bad one near the limits)")
    return f"test uncertainty ratio {ratio:.1f}:1 (below 4:1: decisions near the limits are uncertain)"


def _beyond(c, values=True) -> str:
    """``0.0212 above the upper limit`` (with ``values``, prefixed by the measured value and the limit)."""
    excess = c.exceedance
    if excess is None:
        return "outside the tolerance"
    side = "above the upper limit" if c.upper is not None and c.measured is not None and c.measured > c.upper \
        else "below the lower limit"
    text = f"{format_value(excess, c.unit)} {side}"
    if values:
        limit = c.upper if side.startswith("above") else c.lower
        text = (f"outside: {format_value(c.measured, c.unit)}{unit_suffix(c.unit)} is {text} "
                f"{format_value(limit, c.unit)}")
    return text


def _band_text(lower, upper, unit) -> str:
    """``+0.0500/-0.0500``; ``+/-0.0500`` when symmetric."""
    if lower is None or upper is None:
        return ""
    if math.isclose(-lower, upper, rel_tol=1e-12, abs_tol=0.0):
        return f"\N{PLUS-MINUS SIGN}{format_value(upper, unit)}"
    return f"{'+' if upper >= 0 else '-'}{format_value(abs(upper), unit)}/{'+' if lower >= 0 else '-'}" \
           f"{format_value(abs(lower), unit)}"


def _number(value) -> str:
    """A number in full precision, empty for None."""
    return "" if value is None else repr(float(value))
