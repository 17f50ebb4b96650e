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
...     "index": 0, "name": "T1", "center": [0, 0, 0], "normal": [0, 0, 1], "diameter": 4.0712, "warnings": [],
...     "conformance": {"diameter": {
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

from holecli.quality.lot import PRESENCE, warning_codes
from holecli.quality.wording import decimals, reason_words, tur_words

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


def format_value(value, digits) -> str:
    """A value with ``digits`` decimals (:func:`holecli.quality.wording.decimals` of its characteristic:
    about a thousandth of its tolerance zone); ``-`` for None.

    Examples
    --------
    >>> format_value(7.09966, 4), format_value(100.12345, 3), format_value(None, 4)
    ('7.0997', '100.123', '-')
    """
    return "-" if value is None else f"{value:.{digits}f}"


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
    digits = decimals(c)
    if c.is_zone:
        return f"{words} \N{LESS-THAN OR EQUAL TO} {format_value(c.upper_tolerance, digits)}{unit_suffix(c.unit)}"
    tolerance = _band_text(c.lower_tolerance, c.upper_tolerance, digits)
    nominal = format_value(c.nominal, digits) if c.nominal is not None else "(nominal not known: not measured)"
    return f"{words} {nominal} {tolerance}{unit_suffix(c.unit)}"


def reason_text(c) -> str:
    """Why a characteristic is not a pass, in words (empty for a pass): the reason's words
    (:data:`holecli.quality.wording.REASON_WORDS`), with the value and U where they say more.

    Examples
    --------
    >>> from holecli.quality.lot import Characteristic
    >>> c = Characteristic(0, 0, "T1", "diameter", "mm", 4.0, 4.03, 0.03, -0.05, 0.05, 3.95, 4.05, 0.04,
    ...                    "undecided", "straddles_upper")
    >>> reason_text(c)
    'undecided: 4.0300 mm +- U = 0.0400: within its uncertainty U of the upper limit: the measurement cannot decide'
    """
    if c.decision == "pass":
        return ""
    words = reason_words(c.reason)
    if c.reason.startswith("straddles"):
        digits = decimals(c)
        return (f"undecided: {format_value(c.measured, digits)}{unit_suffix(c.unit)} +- U = "
                f"{format_value(c.expanded_uncertainty, digits)}: {words}")
    if c.reason.startswith("outside"):
        return f"{_beyond(c)} ({words})"
    return words


def characteristic_table(lot) -> list:
    """Every characteristic of the lot, a row each, in measurement order.

    Parameters
    ----------
    lot : holecli.quality.lot.Lot

    Returns
    -------
    list of list of str
        :data:`CHARACTERISTIC_COLUMNS` first; numbers in full precision (``repr``), empty where None. A
        hole no tolerance applies to is a row of its diameter, decision ``unchecked``; a scan that could
        not be measured one row, decision ``error``, its error the reason.
    """
    rows = [list(CHARACTERISTIC_COLUMNS)]
    for m in lot.measurements:
        head = [str(m.order + 1), m.label, m.part or "", m.serial or "", m.received or "", m.record.get("file", ""),
                m.id or ""]
        if "error" in m.record:  # a scan that could not be measured: one row, its error the reason
            rows.append(head + ["", "", "", *[""] * 8, "error", str(m.record["error"]), "", "", "", m.source])
            continue
        checked = {c.hole_index for c in m.characteristics}
        for c in m.characteristics:
            rows.append(head + [
                c.hole, c.name, c.unit, _number(c.nominal), _number(c.lower_tolerance),
                _number(c.upper_tolerance), _number(c.lower), _number(c.upper), _number(c.measured),
                _number(c.deviation), _number(c.expanded_uncertainty), c.decision, c.reason,
                _number(c.exceedance), _number(c.test_uncertainty_ratio), " ".join(c.warnings), m.source])
        for position, hole in enumerate(m.record.get("holes") or ()):
            index = hole.get("index", position)
            if index not in checked:  # a hole no tolerance applies to: its diameter, unchecked
                rows.append(head + [
                    hole.get("name") or f"#{index}", "diameter", m.units, "", "", "", "", "", _number(hole["diameter"]),
                    "", "", "unchecked", "no tolerance applies to this hole", "", "", " ".join(warning_codes(hole)),
                    m.source])
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
        :data:`FAI_COLUMNS` first, then per measurement a row per characteristic (an error record, or a
        record measured without tolerances: one row saying so).
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
        if m.verdict == "unchecked":
            rows.append(head + ["", "", "", "the drawing's characteristics", "not checked: the scan was measured "
                                "without tolerances", tooling, "", "measure it again with the part's spec (--spec)"])
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
    digits = decimals(c)
    text = f"{format_value(c.measured, digits)}{unit_suffix(c.unit)}"
    if c.expanded_uncertainty is not None:
        k = f", k = {coverage:g}" if isinstance(coverage, (int, float)) else ""
        text += f" (U = {format_value(c.expanded_uncertainty, digits)}{k})"
    if c.decision == "fail":
        text += f": NONCONFORMING, {_beyond(c, values=False)}"
    elif c.decision == "undecided":
        text += (": UNDECIDED (within U of a limit)" if c.reason.startswith("straddles")
                 else f": UNDECIDED ({reason_words(c.reason)})")
    return text


def _comment(c) -> str:
    """Form 3's field 14: what else the quality office needs to know (the hole's warnings, a TUR below 4)."""
    notes = []
    if c.decision not in ("pass",) and c.reason not in ("outside", "missing", "not_measured"):
        notes.append(reason_text(c))
    if c.warnings:
        notes.append("the scan warns: " + ", ".join(c.warnings) + " (check the hole for chips, burrs or lubricant "
                     "before rejecting it)")
    notes.append(ratio_text(c.test_uncertainty_ratio, c.is_zone))
    return "; ".join(note for note in notes if note)


def ratio_text(ratio, one_sided=False) -> str:
    """What a test uncertainty ratio (tolerance zone / 2U) says (:func:`holecli.quality.wording.tur_words`;
    ``one_sided`` for a zone with an upper limit only); empty from 4:1 up or when unknown.

    Examples
    --------
    >>> ratio_text(0.7)
    'Test-uncertainty ratio (tolerance zone / 2U) 0.7: the uncertainty is larger than the tolerance: this measurement cannot decide conformance.'
    >>> ratio_text(5.0)
    ''
    """
    sentence, level = tur_words(ratio, one_sided)
    return sentence if level in ("danger", "caution") else ""


def _beyond(c, values=True) -> str:
    """``0.0212 above the upper limit`` (with ``values``, prefixed by the measured value and the limit)."""
    excess = c.exceedance
    if excess is None:
        return "outside the tolerance"
    side = "above the upper limit" if c.upper is not None and c.measured is not None and c.measured > c.upper \
        else "below the lower limit"
    digits = decimals(c)
    text = f"{format_value(excess, digits)} {side}"
    if values:
        limit = c.upper if side.startswith("above") else c.lower
        text = (f"outside: {format_value(c.measured, digits)}{unit_suffix(c.unit)} is {text} "
                f"{format_value(limit, digits)}")
    return text


def _band_text(lower, upper, digits) -> str:
    """``+0.0500/-0.0500``; ``+/-0.0500`` when symmetric."""
    if lower is None or upper is None:
        return ""
    if math.isclose(-lower, upper, rel_tol=1e-12, abs_tol=0.0):
        return f"\N{PLUS-MINUS SIGN}{format_value(upper, digits)}"
    return f"{'+' if upper >= 0 else '-'}{format_value(abs(upper), digits)}/{'+' if lower >= 0 else '-'}" \
           f"{format_value(abs(lower), digits)}"


def _number(value) -> str:
    """A number in full precision, empty for None."""
    return "" if value is None else repr(float(value))
