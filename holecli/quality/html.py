"""The inspection report of a lot: one self-contained HTML page (``holecli report``'s ``--format html``).

A :class:`holecli.quality.lot.Lot` goes in, the text of one HTML5 page comes out
(:func:`html_report`); nothing is read or written here. The page is what the quality office signs and
what an inspector reads on the shop floor's PC or on paper:

- a header (title, when and by which holecli it was made, the inputs, the decision rule and coverage
  factor of the records' verdicts) and a summary (counts, verdicts, the parts rejected, linked);
- a table per measurement: per hole and characteristic the nominal, the tolerance, the measured value,
  the deviation, the expanded uncertainty U, the decision (coloured and said in a word), the amount out
  of tolerance of a fail, the reason in plain words and the hole's warnings beside it, so that a fail
  caused by chips or lubricant in the hole can be told from a bad hole; optionally a *fit picture* per
  hole, drawn from the record alone (nominal and measured circle, the deviations magnified), and where
  the caller gives one (``holecli report`` does for the doubtful holes) a picture of the scan around
  the hole (:mod:`holecli.quality.scan_views`);
- per characteristic over the lot: the individuals and moving-range charts in measurement order
  (:func:`holecli.quality.spc.individuals_charts`, the Western Electric run rules marked and listed),
  X-bar/R charts where holes of a part share a nominal and tolerance, a histogram against the
  tolerance, the capability indices with their confidence intervals and the test-uncertainty ratio
  said plainly.

The page holds no script and loads nothing: inline CSS, inline SVG and ``data:`` PNGs only, under a
Content-Security-Policy that forbids everything else (:data:`CONTENT_SECURITY_POLICY`). Every string
taken from a record is escaped.
"""

from __future__ import annotations

import base64
import datetime as _datetime
import html
import math
import re
from collections import Counter

import numpy as np

from holecli import __version__
from holecli.quality import spc
from holecli.quality.lot import ZONE_CHECKS, warning_codes
from holecli.quality.wording import (REASON_WORDS, WARNING_WORDS, decimals, reason_words, tur_level, tur_words,
                                     warning_phrase, warning_sentence)

__all__ = ["CONTENT_SECURITY_POLICY", "REASON_WORDS", "WARNING_WORDS", "html_report", "tur_words"]

#: The page's Content-Security-Policy: nothing may load or run; only its own inline CSS (and data: images).
CONTENT_SECURITY_POLICY = "default-src 'none'; style-src 'unsafe-inline'; img-src data:"

_FIT_LEGEND = ('<p class="note">Fit pictures: the nominal circle dashed grey, the diameter\'s tolerance band the '
               'green ring, the position zone the blue disc about the nominal centre, the measured circle in its '
               'decision\'s colour with its centre dot. Deviations are magnified (&times; each picture\'s '
               'factor); the centre offset is drawn to the right: the record keeps its size, not its '
               'direction.</p>')
#: The Western Electric rules (holecli.quality.spc.western_electric), as the list of a chart's violations says them.
_RULE_WORDS = {1: "a point beyond 3 sigma", 2: "2 of 3 beyond 2 sigma on one side",
               3: "4 of 5 beyond 1 sigma on one side", 4: "8 in a row on one side of the centre line"}
_SCAN_LEGEND = ('<p class="note">Scan pictures: the points around the hole seen along its axis, coloured by their '
                'height: the surface white, what stands above it (a burr, a chip, lubricant) red, what lies below '
                'it (the countersink, the bore) blue, no point (the open hole) grey. A fail with red on the rim '
                'or grey gaps may be debris or a bad scan rather than a bad hole.</p>')
_UNCHECKED_WORDS = {True: "not checked: no nominal hole of the spec matches it",
                    False: "not checked: no tolerances were given for this scan"}
_DECISION_WORDS = {"pass": "PASS", "fail": "FAIL", "undecided": "UNDECIDED", "missing": "MISSING",
                   "unchecked": "UNCHECKED", "error": "ERROR"}
_VERDICTS = ("pass", "fail", "undecided", "unchecked", "error")
_MAX_LISTED = 10           # violations listed in words per chart; the rest counted
_MAX_INPUTS = 12           # input files named in the header; the rest counted
_MARKED_POINTS = 150       # a chart of at most this many points draws each with its tooltip
_FIT_RADIUS = 34.0         # the nominal circle's radius in a fit picture, px
_UP, _DOWN, _LEFT, _RIGHT = "\u2191", "\u2193", "\u2190", "\u2192"   # arrows to a limit off the chart
_FIT_SHARE = 0.3           # the largest deviation is drawn at most this share of the radius

_CSS = """
:root { --pass:#1a7f37; --pass-bg:#dafbe1; --fail:#b42318; --fail-bg:#fde2e1; --undecided:#8a5a00;
  --undecided-bg:#fff0c2; --unchecked:#555; --unchecked-bg:#ececec; --error:#6b21a8; --error-bg:#f1e4ff;
  --ink:#1f2328; --line:#d0d7de; }
* { box-sizing: border-box; }
body { font: 14px/1.4 system-ui, "Segoe UI", "DejaVu Sans", Arial, sans-serif; color: var(--ink);
  margin: 0 auto; max-width: 1200px; padding: 16px 24px; background: #fff; }
h1 { font-size: 24px; margin: 0 0 8px; }
h2 { font-size: 20px; border-bottom: 2px solid var(--ink); margin: 28px 0 10px; padding-bottom: 3px; }
h3 { font-size: 16px; margin: 22px 0 6px; }
h4 { font-size: 14px; margin: 12px 0 4px; }
nav a { margin-right: 14px; }
dl.meta { display: grid; grid-template-columns: max-content 1fr; gap: 2px 14px; margin: 6px 0; }
dl.meta dt { font-weight: 600; }
dl.meta dd { margin: 0; overflow-wrap: anywhere; }
table { border-collapse: collapse; margin: 6px 0 10px; }
table.holes { font-size: 13px; }
th, td { border: 1px solid var(--line); padding: 3px 6px; vertical-align: top; }
th { background: #f3f4f6; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.badge, td.decision { font-weight: 700; }
.badge { display: inline-block; padding: 1px 8px; border-radius: 10px; }
.pass { color: var(--pass); background: var(--pass-bg); }
.fail, .missing { color: var(--fail); background: var(--fail-bg); }
.undecided { color: var(--undecided); background: var(--undecided-bg); }
.unchecked { color: var(--unchecked); background: var(--unchecked-bg); }
.error { color: var(--error); background: var(--error-bg); }
tr.row-fail td.reason, tr.row-missing td.reason { color: var(--fail); }
td.reason { min-width: 11em; }
td.warnings { color: var(--undecided); min-width: 15em; max-width: 20em; font-size: 12px; }
td.warnings span { display: block; margin-bottom: 3px; }
td.warnings .hint { color: var(--fail); font-weight: 600; }
p.error-message { padding: 6px 10px; border-left: 4px solid var(--error); }
.note { color: #57606a; }
.caution { padding: 4px 10px; border-left: 4px solid var(--undecided); background: var(--undecided-bg); }
.danger { padding: 4px 10px; border-left: 4px solid var(--fail); background: var(--fail-bg); }
.ok { padding: 4px 10px; border-left: 4px solid var(--pass); background: var(--pass-bg); }
.fits { display: flex; flex-wrap: wrap; gap: 8px; }
figure { margin: 0; }
figure.fit { width: 150px; font-size: 11px; border: 1px solid var(--line); padding: 3px; }
figure.fit figcaption { overflow-wrap: anywhere; }
svg { display: block; }
img.scan { display: block; image-rendering: pixelated; }
svg text { font: 10px "DejaVu Sans", Arial, sans-serif; fill: var(--ink); }
svg .frame { fill: #fff; stroke: #8c959f; }
svg .grid { stroke: #eaeef2; }
svg .series { fill: none; stroke: #0b5cad; stroke-width: 1.2; }
svg .point { fill: #0b5cad; }
svg .center { stroke: #2da44e; stroke-width: 1.2; }
svg .control { stroke: #cf222e; stroke-dasharray: 6 3; }
svg .tolerance { stroke: #8250df; stroke-width: 1.6; }
svg .violation { fill: none; stroke: #cf222e; stroke-width: 2; }
svg .bar { fill: #9ec5f0; stroke: #0b5cad; }
svg .nominal { fill: none; stroke: #57606a; stroke-dasharray: 3 2; }
svg .zone { fill: none; stroke: #b7ebc3; }
svg .poszone { fill: #eef6ff; stroke: #0b5cad; stroke-dasharray: 2 2; }
svg .measured { fill: none; stroke-width: 1.5; }
svg .measured.pass { stroke: var(--pass); }
svg .measured.fail { stroke: var(--fail); }
svg .measured.undecided { stroke: var(--undecided); }
svg .measured.unchecked { stroke: var(--unchecked); }
svg .unseen { fill: none; stroke: #8c959f; stroke-dasharray: 1 3; }
svg .dot { fill: var(--ink); }
.charts { display: flex; flex-wrap: wrap; gap: 8px 18px; align-items: flex-start; }
ul.violations { margin: 2px 0 8px; }
ul.weak { list-style: none; padding: 0; }
ul.weak li { margin: 2px 0; }
/* A lot of 1,000 parts is a long page: the browser lays out only the sections near the view (8 s -> 1 s). */
section.measurement, section.key { content-visibility: auto; contain-intrinsic-size: auto 1200px; }
@page { size: A4; margin: 12mm; }
@media print {
  body { max-width: none; padding: 0; font-size: 9pt; }
  nav { display: none; }
  * { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
  section.measurement, section.key { content-visibility: visible; }
  section.measurement, section.key, section#trends, section#subgroups { break-before: page; }
  tr, figure.fit, svg { break-inside: avoid; }
  a { color: inherit; text-decoration: none; }
}
"""


def html_report(lot, *, title=None, pictures=True, generated=None, inputs=None, scan_views=None) -> str:
    """The inspection report of ``lot`` as one self-contained HTML5 page.

    Parameters
    ----------
    lot : holecli.quality.lot.Lot
        The measurements, in measurement order.
    title : str, optional
        The page's title; default "Inspection report".
    pictures : bool
        Draw a fit picture per hole (the cost of the page's size and most of its time).
    generated : datetime.datetime or str, optional
        When the report was made, as the header says it; default now (UTC).
    inputs : sequence of str, optional
        What was read, as the header names it (the RESULTS files, the store and its filters); default
        the files of the measurements' sources.
    scan_views : dict, optional
        Pictures of the scan around some holes, ``{(measurement order, hole index): view}`` with
        ``view`` :func:`holecli.quality.scan_views.hole_view`'s dict (``png``, ``half_width``,
        ``limit``) or ``{"unavailable": why}``: each shown beside its hole, the PNG inline (a ``data:``
        image, which the page's policy allows).

    Returns
    -------
    str
        The page: inline CSS and SVG only, no script, nothing loaded (:data:`CONTENT_SECURITY_POLICY`).
    """
    title = "Inspection report" if title is None else str(title)
    if generated is None:
        generated = _datetime.datetime.now(_datetime.timezone.utc)
    if isinstance(generated, _datetime.datetime):
        generated = generated.isoformat(timespec="seconds")
    out = ['<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
           f'<meta http-equiv="Content-Security-Policy" content="{_e(CONTENT_SECURITY_POLICY)}">\n'
           '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
           f'<title>{_e(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n']
    by_key = {}  # Lot.series of every key in one pass (a call each scans the whole lot)
    for characteristic in lot.characteristics:
        by_key.setdefault(characteristic.key, []).append(characteristic)
    keys = [key for key in lot.keys if key[1] != "presence"]
    out.append(_header(lot, title, str(generated), inputs))
    out.append(_summary(lot, keys, by_key))
    out.append('<section id="measurements">\n<h2>Measurements</h2>\n')
    if not lot.measurements:
        out.append('<p class="note">No measurements.</p>\n')
    for measurement in lot.measurements:
        out.append(_measurement_section(measurement, pictures, scan_views or {}))
    out.append('</section>\n')
    out.append(_trends(lot, keys, by_key))
    out.append(_subgroups(lot, by_key))
    out.append(f'<footer class="note"><p>Made by holecli {_e(__version__)}. Decisions follow ISO 14253-1 as the '
               'records\' decision rule says; the control charts use the Western Electric run rules.</p>'
               '</footer>\n</body>\n</html>\n')
    return "".join(out)


# ---------------------------------------------------------------------------------------------------
# The page's parts


def _header(lot, title, generated, inputs) -> str:
    if inputs is None:
        files = list(dict.fromkeys(_input_of(m.source) for m in lot.measurements))
    else:
        files = [str(name) for name in inputs]
    shown = ", ".join(_e(f) for f in files[:_MAX_INPUTS])
    if len(files) > _MAX_INPUTS:
        shown += f" and {len(files) - _MAX_INPUTS} more"
    rules = Counter()
    versions = Counter()
    for measurement in lot.measurements:
        verdict = _mapping(measurement.record.get("verdict"))
        if verdict:
            rules[(verdict.get("decision_rule"), verdict.get("coverage_factor"))] += 1
        version = measurement.record.get("holecli_version")
        if version is not None:
            versions[str(version)] += 1
    rule_text = "; ".join(f"{_e(rule if rule is not None else 'not given')}, coverage factor k = "
                          f"{_e(_plain(k))}" + (f" ({count} records)" if len(rules) > 1 else "")
                          for (rule, k), count in rules.items()) or "no tolerances checked"
    version_text = _e(__version__)
    if versions:
        version_text += " (records by holecli " + ", ".join(_e(v) for v in versions) + ")"
    return (f'<header>\n<h1>{_e(title)}</h1>\n<dl class="meta">'
            f'<dt>Generated</dt><dd>{_e(generated)}</dd>'
            f'<dt>holecli version</dt><dd>{version_text}</dd>'
            f'<dt>Inputs</dt><dd>{shown or "none"}</dd>'
            f'<dt>Decision rule</dt><dd>{rule_text}</dd></dl>\n'
            '<nav><a href="#summary">Summary</a><a href="#measurements">Measurements</a>'
            '<a href="#trends">Characteristics over the lot</a><a href="#subgroups">Subgroup charts</a></nav>\n'
            '</header>\n')


def _summary(lot, keys, by_key) -> str:
    summary = lot.summary()
    verdicts = summary.get("verdicts", {})
    cells = "".join(f'<td class="num {word}">{int(verdicts.get(word, 0))}</td>' for word in _VERDICTS)
    heads = "".join(f'<th class="{word}">{word}</th>' for word in _VERDICTS)
    out = ['<section id="summary">\n<h2>Summary</h2>\n<table class="summary"><tr><th>measurements</th>'
           f'<th>parts</th><th>holes</th><th>characteristics</th>{heads}</tr><tr>'
           f'<td class="num">{int(summary["measurements"])}</td><td class="num">{int(summary["parts"])}</td>'
           f'<td class="num">{int(summary["holes"])}</td><td class="num">{int(summary["characteristics"])}</td>'
           f'{cells}</tr></table>\n']
    # a part (a label) once, at its last measurement that was rejected (lot.summary's list)
    last = {m.label: m for m in lot.measurements if m.verdict in ("fail", "error")}
    rejected = [last[label] for label in summary["rejected"]]
    if rejected:
        out.append(f'<h3>Parts rejected ({len(rejected)})</h3>\n<ul class="rejected">')
        for measurement in rejected:
            out.append(f'<li><a href="#m-{measurement.order}">{_e(measurement.label)}</a> '
                       f'<span class="badge {measurement.verdict}">{_DECISION_WORDS[measurement.verdict]}</span>'
                       f' {_e(_rejection_cause(measurement))}</li>')
        out.append('</ul>\n')
    else:
        out.append('<p>No part rejected.</p>\n')
    weak = [(number, key, ratio, level) for number, key in enumerate(keys)
            for ratio in [_median_tur(by_key[key])]
            for level in [tur_level(ratio, by_key[key][0].is_zone)] if level in ("danger", "caution")]
    if weak:
        out.append('<h3>Characteristics the measurement decides poorly</h3>\n<ul class="weak">')
        for number, (hole, name), ratio, css in weak:
            words = "cannot decide conformance" if css == "danger" else "below 4:1, caution near the limits"
            out.append(f'<li class="{css}"><a href="#k-{number}">{_e(hole)} {_e(_name(name))}</a>: test-uncertainty '
                       f'ratio {ratio:.3g}, {words}</li>')
        out.append('</ul>\n')
    return "".join(out) + '</section>\n'


def _rejection_cause(measurement) -> str:
    if measurement.verdict == "error":
        return str(measurement.record.get("error", ""))
    failed = [c for c in measurement.characteristics if c.decision in ("fail", "missing")]
    return ", ".join(f"{c.hole} {'missing' if c.decision == 'missing' else _name(c.name)}" for c in failed)


def _measurement_section(measurement, pictures, scan_views) -> str:
    record = measurement.record
    verdict = measurement.verdict
    out = [f'<section class="measurement" id="m-{measurement.order}">\n'
           f'<h3>{_e(measurement.label)} <span class="badge {verdict}">{_DECISION_WORDS[verdict]}</span></h3>\n'
           '<dl class="meta">']
    for name, value in (("Part", measurement.part), ("Serial", measurement.serial),
                        ("Received", measurement.received), ("File", record.get("file")),
                        ("Source", measurement.source)):
        if value is not None:
            out.append(f'<dt>{name}</dt><dd>{_e(value)}</dd>')
    out.append(f'<dt>Verdict</dt><dd>{verdict}</dd></dl>\n')
    if verdict == "error":
        out.append(f'<p class="error-message">This scan was not measured: {_e(record.get("error", ""))}</p>\n')
        return "".join(out) + '</section>\n'
    holes = record.get("holes") or []
    by_hole = {}
    missing = []
    for characteristic in measurement.characteristics:
        if characteristic.hole_index is None:
            missing.append(characteristic)
        else:
            by_hole.setdefault(characteristic.hole_index, []).append(characteristic)
    out.append('<table class="holes"><thead><tr><th>Hole</th><th>Characteristic</th><th>Nominal</th>'
               '<th>Tolerance (&minus; / +)</th><th>Measured</th><th>Deviation</th><th>U</th><th>Decision</th>'
               '<th>Out of tolerance</th><th>Reason</th><th>Hole warnings</th></tr></thead>\n<tbody>\n')
    for position, hole in enumerate(holes):
        index = hole.get("index", position)
        out.append(_hole_rows(hole, index, by_hole.get(index, ()), measurement.units, "verdict" in record))
    for characteristic in missing:
        out.append(f'<tr class="row-missing"><td>{_e(characteristic.hole)}</td><td>presence</td>'
                   + '<td class="num">&ndash;</td>' * 5 + '<td class="decision missing">MISSING</td><td></td>'
                   f'<td class="reason">{_e(reason_words(characteristic.reason))}</td><td></td></tr>\n')
    if not holes and not missing:
        out.append('<tr><td colspan="11" class="note">No hole found in this scan.</td></tr>\n')
    out.append('</tbody></table>\n')
    views = {index: scan_views[(measurement.order, index)] for index in
             (hole.get("index", position) for position, hole in enumerate(holes))
             if (measurement.order, index) in scan_views}
    if (pictures or views) and holes:
        out.append((_FIT_LEGEND if pictures else "") + (_SCAN_LEGEND if views else "") + '<div class="fits">')
        for position, hole in enumerate(holes):
            index = hole.get("index", position)
            if pictures:
                out.append(_fit_figure(hole, position))
            if index in views:
                out.append(_scan_figure(hole, index, views[index], measurement.units))
        out.append('</div>\n')
    return "".join(out) + '</section>\n'


def _hole_rows(hole, index, characteristics, units, checked) -> str:
    name = hole.get("name") or f"#{index}"
    codes = warning_codes(hole)
    rows = max(1, len(characteristics))
    words = "".join(f'<span title="{_e(warning_sentence(code))}">{_e(warning_phrase(code))}</span>'
                        for code in codes)
    if codes and any(c.decision in ("fail", "undecided") for c in characteristics):
        words += ('<span class="hint">A warning may explain this result: look at the hole before '
                  'rejecting it.</span>')
    hole_cell = f'<td rowspan="{rows}">{_e(name)}</td>'
    warning_cell = f'<td rowspan="{rows}" class="warnings">{words}</td>'
    if not characteristics:
        diameter = hole.get("diameter")
        unit = f" {_e(units)}" if units else ""
        return (f'<tr class="row-unchecked">{hole_cell}<td>diameter</td><td class="num"></td><td></td>'
                f'<td class="num">{_number(diameter, 4)}{unit}</td><td class="num"></td><td class="num"></td>'
                '<td class="decision unchecked">UNCHECKED</td><td></td>'
                f'<td class="reason">{_UNCHECKED_WORDS[checked]}</td>'
                f'{warning_cell}</tr>\n')
    out = []
    for row, c in enumerate(characteristics):
        digits = decimals(c)
        unit = f" {_e(c.unit)}" if c.unit else ""
        zone = c.name in ZONE_CHECKS
        if zone:
            nominal = "0"
            tolerance = f"zone &le; {_number(c.upper_tolerance, digits)}"
        else:
            nominal = _number(c.nominal, digits)
            tolerance = _band(c.lower_tolerance, c.upper_tolerance, digits)
        exceed = ""
        if c.decision == "fail":
            amount = c.exceedance
            exceed = "not measured" if amount is None else _number(amount, digits) + unit
        decision = c.decision if c.decision in _DECISION_WORDS else "undecided"
        out.append(f'<tr class="row-{decision}">{hole_cell if row == 0 else ""}<td>{_e(_name(c.name))}</td>'
                   f'<td class="num">{nominal}{unit}</td><td class="num">{tolerance}</td>'
                   f'<td class="num">{_number(c.measured, digits)}</td>'
                   f'<td class="num">{_signed(c.deviation, digits)}</td>'
                   f'<td class="num">{_number(c.expanded_uncertainty, digits)}</td>'
                   f'<td class="decision {decision}">{_DECISION_WORDS[decision]}</td>'
                   f'<td class="num exceedance">{exceed}</td><td class="reason">{_e(reason_words(c.reason))}</td>'
                   f'{warning_cell if row == 0 else ""}</tr>\n')
    return "".join(out)


def _trends(lot, keys, by_key) -> str:
    out = ['<section id="trends">\n<h2>Characteristics over the lot</h2>\n']
    if not keys:
        out.append('<p class="note">No characteristic checked.</p>\n')
    for number, key in enumerate(keys):
        out.append(_key_section(lot, key, by_key[key], number))
    return "".join(out) + '</section>\n'


def _key_section(lot, key, every, number) -> str:
    hole, name = key
    series = [c for c in every if c.measured is not None and math.isfinite(c.measured)]
    unit = next((c.unit for c in every if c.unit), "")
    digits = decimals(every[0]) if every else 4
    decisions = Counter(c.decision for c in every)
    out = [f'<section class="key" id="k-{number}">\n<h3>{_e(hole)} &middot; {_e(_name(name))}'
           f'{" (" + _e(unit) + ")" if unit else ""}</h3>\n<p>{len(every)} checked, {len(series)} measured: '
           + ", ".join(f'<span class="badge {_e(word)}">{count} {_e(word)}</span>'
                       for word, count in sorted(decisions.items()))
           + '</p>\n']
    lower, upper = _limits(series)
    sentence, css = tur_words(_median_tur(every), every[0].is_zone if every else False)
    out.append(f'<p class="tur {css}">{_e(sentence)}</p>\n')
    if len(series) < 2:
        out.append('<p class="note">Not enough measurements for a chart (fewer than 2 values).</p>\n')
        return "".join(out) + '</section>\n'
    values = np.array([c.measured for c in series], dtype=float)
    labels = [lot.measurements[c.measurement].label if c.measurement < len(lot.measurements) else str(c.measurement)
              for c in series]
    individuals, moving_range = spc.individuals_charts(values)
    positions = np.array([c.measurement + 1 for c in series], dtype=float)  # "measurement No.": 1-based order
    out.append('<div class="charts">')
    out.append(_chart_figure(individuals, "Individuals", positions, labels, (lower, upper), unit, digits))
    out.append(_chart_figure(moving_range, "Moving range", positions[1:], labels[1:], (None, None), unit, digits))
    out.append(f'<figure><figcaption>Histogram against the tolerance</figcaption>'
               f'{_histogram_svg(values, lower, upper, digits)}</figure>')
    out.append('</div>\n')
    out.append(_capability_table(values, lower, upper, individuals.sigma, digits))
    return "".join(out) + '</section>\n'


def _capability_table(values, lower, upper, sigma_within, digits) -> str:
    if upper is None and lower is None:
        return '<p class="note">No tolerance limits known: no capability indices.</p>\n'
    if lower is not None and upper is not None and not lower < upper:
        return '<p class="note">The tolerance limits are not in order: no capability indices.</p>\n'
    capability = spc.capability(values, lower, upper, sigma_within=sigma_within)
    rows = []
    for name in ("cp", "cpk", "pp", "ppk"):
        value = getattr(capability, name)
        interval = getattr(capability, f"{name}_interval")
        shown = "&ndash;" if interval is None else f"{_index(interval[0])} &ndash; {_index(interval[1])}"
        rows.append(f'<tr><th>{name.capitalize()}</th>'
                    f'<td class="num">{_index(value)}</td><td class="num">{shown}</td></tr>')
    level = f"{100 * capability.confidence:.0f}%"
    return ('<table class="capability"><tr><th>Index</th><th>Value</th>'
            f'<th>{level} confidence interval</th></tr>' + "".join(rows) + '</table>\n'
            f'<p class="note">n = {capability.n}, mean {_number(capability.mean, digits)}, sigma within '
            f'{_number(capability.sigma_within, digits + 1)}, sigma overall '
            f'{_number(capability.sigma_overall, digits + 1)}. Cp and Cpk use the within (moving-range) '
            'sigma, Pp and Ppk the overall one; 1.33 is the usual least Cpk of a capable process.</p>\n')


def _subgroups(lot, by_key) -> str:
    """X-bar/R charts where holes of a part share a characteristic's nominal and tolerance."""
    groups = {}
    for key in lot.keys:
        if key[1] == "presence":
            continue
        first = next((c for c in by_key[key] if c.upper_tolerance is not None
                      and (c.nominal is not None or c.name in ZONE_CHECKS)), None)
        if first is None:
            continue
        identity = (first.name, _rounded(first.nominal), _rounded(first.lower_tolerance),
                    _rounded(first.upper_tolerance), first.unit)
        groups.setdefault(identity, []).append(key)
    out = ['<section id="subgroups">\n<h2>Subgroup charts (X-bar/R per part)</h2>\n<p class="note">Where holes '
           'of a part share a characteristic\'s nominal and tolerance, each measured part is a subgroup of '
           'those holes.</p>\n']
    shown = 0
    for (name, nominal, low, high, unit), keys in groups.items():
        if len(keys) < 2:
            continue
        holes = [key[0] for key in keys]
        title = f"{_name(name)} of {', '.join(holes)}"
        if nominal is not None and name not in ZONE_CHECKS:
            title += f" (nominal {nominal:.6g})"
        out.append(f'<section class="subgroup"><h3>{_e(title)}</h3>\n')
        shown += 1
        if len(keys) > 25:
            out.append('<p class="note">More than 25 holes per subgroup: no X-bar/R chart.</p></section>\n')
            continue
        values = {key: {c.measurement: c.measured for c in by_key[key]} for key in keys}
        rows, labels, numbers = [], [], []
        for measurement in lot.measurements:
            row = [values[key].get(measurement.order) for key in keys]
            if all(v is not None and math.isfinite(v) for v in row):
                rows.append(row)
                labels.append(measurement.label)
                numbers.append(measurement.order + 1)
        if len(rows) < 2:
            out.append('<p class="note">Not enough measurements for a chart (fewer than 2 complete '
                       'subgroups).</p></section>\n')
            continue
        left_out = sum(1 for m in lot.measurements if m.verdict != "error") - len(rows)
        xbar, ranges = spc.xbar_r_charts(np.array(rows, dtype=float))
        positions = np.array(numbers, dtype=float)
        digits = decimals(by_key[keys[0]][0])
        out.append('<div class="charts">')
        out.append(_chart_figure(xbar, "X-bar (subgroup mean)", positions, labels, (None, None), unit, digits))
        out.append(_chart_figure(ranges, "Range (subgroup)", positions, labels, (None, None), unit, digits))
        out.append('</div>\n')
        if left_out > 0:
            out.append(f'<p class="note">{left_out} measurement(s) without every one of these holes measured '
                       'are left out.</p>\n')
        out.append('</section>\n')
    if not shown:
        out.append('<p class="note">No characteristic shared by several holes of a part.</p>\n')
    return "".join(out) + '</section>\n'


# ---------------------------------------------------------------------------------------------------
# Drawings: pure functions of numbers, returning SVG text


def _chart_figure(chart, name, positions, labels, tolerance, unit, digits) -> str:
    svg = _chart_svg(chart.points, positions, labels, center=chart.center, lower=chart.lower, upper=chart.upper,
                     tolerance=tolerance, violations=chart.violations, digits=digits, title=name)
    out = [f'<figure class="chart {_e(chart.kind)}"><figcaption>{_e(name)} chart'
           f'{" (" + _e(unit) + ")" if unit else ""}</figcaption>{svg}']
    violations = chart.violations
    if violations:
        rules = Counter(int(violation.rule) for violation in violations)
        out.append(f'<p>{len(violations)} run-rule violation(s): '
                   + "; ".join(f"rule {rule} ({_RULE_WORDS.get(rule, 'rule ' + str(rule))}): {count}"
                               for rule, count in sorted(rules.items())) + '</p><ul class="violations">')
        for violation in violations[:_MAX_LISTED]:
            index = int(violation.index)
            where = f"No. {positions[index]:.0f}" if index < len(positions) else f"point {index + 1}"
            label = labels[index] if index < len(labels) else ""
            out.append(f'<li>{where} ({_e(label)}): rule {int(violation.rule)}, {_e(violation.message)}</li>')
        if len(violations) > _MAX_LISTED:
            out.append(f'<li>and {len(violations) - _MAX_LISTED} more</li>')
        out.append('</ul>')
    else:
        out.append('<p class="note">No run-rule violation.</p>')
    return "".join(out) + '</figure>'


def _chart_svg(points, positions, labels, *, center, lower, upper, tolerance, violations, digits, title,
               width=560, height=210) -> str:
    """A control chart: the points joined in order, the centre line, the control limits (dashed), the
    tolerance limits (purple; named at the edge when far off the chart) and the violations circled."""
    points = np.asarray(points, dtype=float)
    positions = np.asarray(positions, dtype=float)
    left, right, top, bottom = 72.0, 118.0, 10.0, 26.0
    plot_w, plot_h = width - left - right, height - top - bottom
    finite = points[np.isfinite(points)]
    levels = [v for v in (center, lower, upper) if v is not None and math.isfinite(v)]
    low, high = _span([*finite.tolist(), *levels])
    tol_low, tol_high = tolerance
    reach = 1.5 * (high - low)
    shown_tol = [(v, word) for v, word in ((tol_low, "lower tol."), (tol_high, "upper tol."))
                 if v is not None and math.isfinite(v)]
    inside = [(v, w) for v, w in shown_tol if low - reach <= v <= high + reach]
    low, high = _span([low, high, *(v for v, _ in inside)], pad=0.06)
    x0, x1 = (positions[0] - 0.5, positions[-1] + 0.5) if len(positions) else (0.0, 1.0)

    def sx(v):
        return left + (v - x0) / (x1 - x0) * plot_w

    def sy(v):
        return top + (high - v) / (high - low) * plot_h

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" role="img" aria-label="{_e(title)} chart">'
           f'<rect class="frame" x="{left}" y="{top}" width="{plot_w}" height="{plot_h}"/>']
    for tick in _ticks(low, high):
        y = sy(tick)
        out.append(f'<line class="grid" x1="{left}" x2="{left + plot_w}" y1="{y:.1f}" y2="{y:.1f}"/>'
                   f'<text x="{left - 4}" y="{y + 3:.1f}" text-anchor="end">{_tick_label(tick, low, high)}</text>')
    for tick in _ticks(x0, x1, 8):
        if abs(tick - round(tick)) < 1e-9 and x0 <= tick <= x1:
            out.append(f'<text x="{sx(tick):.1f}" y="{height - 10}" text-anchor="middle">{tick:.0f}</text>')
    out.append(f'<text x="{left + plot_w / 2:.1f}" y="{height - 1}" text-anchor="middle">measurement No.</text>')
    tags = []
    for value, css, word in ((center, "center", "CL"), (upper, "control", "UCL"), (lower, "control", "LCL")):
        if value is not None and math.isfinite(value):
            y = sy(value)
            out.append(f'<line class="{css}" x1="{left}" x2="{left + plot_w}" y1="{y:.1f}" y2="{y:.1f}"/>')
            tags.append((y, f"{word} {_number(value, digits)}"))
    for value, word in inside:
        y = sy(value)
        out.append(f'<line class="tolerance" x1="{left}" x2="{left + plot_w}" y1="{y:.1f}" y2="{y:.1f}"/>')
        tags.append((y, f"{word} {_number(value, digits)}"))
    for value, word in shown_tol:
        if (value, word) not in inside:
            arrow = _UP if value > high else _DOWN
            tags.append((top + 6 if value > high else top + plot_h - 2, f"{arrow} {word} {_number(value, digits)}"))
    for y, text in _spread(tags, top, top + plot_h):
        out.append(f'<text x="{left + plot_w + 4}" y="{y + 3:.1f}">{_e(text)}</text>')
    mask = np.isfinite(points)
    xs, ys = sx(positions[mask]), sy(points[mask])
    out.append('<polyline class="series" points="' + " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(xs, ys)) + '"/>')
    if len(points) <= _MARKED_POINTS:
        for i in np.flatnonzero(mask):
            label = labels[i] if i < len(labels) else ""
            out.append(f'<circle class="point" cx="{sx(positions[i]):.1f}" cy="{sy(points[i]):.1f}" r="2.2">'
                       f'<title>No. {positions[i]:.0f} {_e(label)}: {_number(points[i], digits)}</title></circle>')
    for violation in violations:
        i = int(violation.index)
        if 0 <= i < len(points) and math.isfinite(points[i]):
            out.append(f'<circle class="violation" cx="{sx(positions[i]):.1f}" cy="{sy(points[i]):.1f}" r="5">'
                       f'<title>rule {int(violation.rule)}: {_e(violation.message)}</title></circle>')
    return "".join(out) + '</svg>'


def _histogram_svg(values, lower, upper, digits, width=340, height=210) -> str:
    """A histogram of ``values`` with the tolerance limits (purple) and the mean (green)."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    left, right, top, bottom = 36.0, 12.0, 22.0, 26.0
    plot_w, plot_h = width - left - right, height - top - bottom
    low, high = _span(values.tolist())
    reach = 1.5 * (high - low)
    limits = [(v, w) for v, w in ((lower, "lower tol."), (upper, "upper tol.")) if v is not None and math.isfinite(v)]
    inside = [(v, w) for v, w in limits if low - reach <= v <= high + reach]
    low, high = _span([low, high, *(v for v, _ in inside)], pad=0.04)
    bins = int(min(30, max(5, round(math.sqrt(len(values))))))
    data_low, data_high = _span(values.tolist(), pad=0.0)
    counts, edges = np.histogram(values, bins=bins, range=(data_low, data_high))
    tallest = max(int(counts.max()), 1) if len(counts) else 1

    def sx(v):
        return left + (v - low) / (high - low) * plot_w

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" role="img" aria-label="histogram">'
           f'<rect class="frame" x="{left}" y="{top}" width="{plot_w}" height="{plot_h}"/>'
           f'<text x="{left - 4}" y="{top + 4}" text-anchor="end">{tallest}</text>'
           f'<text x="{left - 4}" y="{top + plot_h}" text-anchor="end">0</text>']
    for count, a, b in zip(counts, edges[:-1], edges[1:]):
        if count:
            h = count / tallest * plot_h
            out.append(f'<rect class="bar" x="{sx(a):.1f}" y="{top + plot_h - h:.1f}" '
                       f'width="{max(sx(b) - sx(a), 0.8):.1f}" height="{h:.1f}"><title>{_number(a, digits)} to '
                       f'{_number(b, digits)}: {int(count)}</title></rect>')
    mean = float(values.mean()) if len(values) else None
    for value, css, word in ([(v, "tolerance", w) for v, w in inside]
                             + ([(mean, "center", "mean")] if mean is not None else [])):
        x = sx(value)
        out.append(f'<line class="{css}" x1="{x:.1f}" x2="{x:.1f}" y1="{top}" y2="{top + plot_h}"/>')
    text_y = top - 6
    for value, word in inside:
        anchor = "end" if value == max(v for v, _ in inside) and len(inside) > 1 else "start"
        out.append(f'<text x="{sx(value):.1f}" y="{text_y}" text-anchor="{anchor}">{_e(word)}</text>')
    for value, word in limits:
        if (value, word) not in inside:
            out.append(f'<text x="{left + (plot_w if value > high else 0):.1f}" y="{text_y}" '
                       f'text-anchor="{"end" if value > high else "start"}">'
                       f'{_RIGHT if value > high else _LEFT} {_e(word)} {_number(value, digits)}</text>')
    for tick in _ticks(low, high, 4):
        out.append(f'<text x="{sx(tick):.1f}" y="{height - 10}" text-anchor="middle">'
                   f'{_tick_label(tick, low, high)}</text>')
    return "".join(out) + '</svg>'


def _fit_figure(hole, position) -> str:
    index = hole.get("index", position)
    name = hole.get("name") or f"#{index}"
    svg, magnification, notes = _fit_picture(hole)
    caption = [f'<b>{_e(name)}</b> &middot; deviations &times;{magnification:g}']
    caption.extend(_e(note) for note in notes)
    caption.extend(_e(warning_phrase(code)) for code in warning_codes(hole))
    return f'<figure class="fit">{svg}<figcaption>{"<br>".join(caption)}</figcaption></figure>'


def _scan_figure(hole, index, view, units) -> str:
    """The picture of the scan around a hole (a PNG made by holecli.quality.scan_views), inline."""
    name = _e(hole.get("name") or f"#{index}")
    png = view.get("png") if isinstance(view, dict) else None
    if not isinstance(png, (bytes, bytearray)) or not png.startswith(b"\x89PNG"):
        why = view.get("unavailable", "no picture") if isinstance(view, dict) else "no picture"
        return (f'<figure class="fit scan"><p class="note">The scan around {name}: {_e(why)}</p>'
                f'<figcaption><b>{name}</b> &middot; the scan</figcaption></figure>')
    unit = f" {_e(units)}" if units else ""
    data = base64.b64encode(bytes(png)).decode("ascii")
    return (f'<figure class="fit scan"><img class="scan" width="140" height="140" alt="the scan around hole {name}" '
            f'src="data:image/png;base64,{data}"><figcaption><b>{name}</b> &middot; the scan, '
            f'&plusmn;{_number(view.get("half_width"), 3)}{unit} about the centre; full colour at a height of '
            f'&plusmn;{_number(view.get("limit"), 3)}{unit}</figcaption></figure>')


def _fit_picture(hole):
    """The fit picture of one record hole: the nominal circle (dashed), the diameter's tolerance band
    (pale green ring), the position zone (pale blue disc about the nominal centre), the measured
    circle (its decision's colour; the arc seen of a partial hole solid) and its centre, the deviations
    magnified so that the largest is about a third of the radius.

    Returns
    -------
    (str, float, list of str)
        The SVG, the magnification and the notes the caption says (the offset's direction is not in
        the record; a partial hole's arc).
    """
    conformance = _mapping(hole.get("conformance"))
    diameter = _finite(hole.get("diameter"))
    dia = _mapping(conformance.get("diameter"))
    deviation = _finite(hole.get("diameter_deviation"))
    if deviation is None:
        deviation = _finite(dia.get("value"))
    offset = _finite(_mapping(hole.get("position_deviation")).get("in_plane"))
    zone = _finite(_mapping(conformance.get("position")).get("upper"))
    band = (_finite(dia.get("lower")), _finite(dia.get("upper")))
    checked = bool(conformance)
    radius = None
    if diameter is not None and diameter > 0:
        radius = (diameter - (deviation or 0.0)) / 2.0
    if radius is None or radius <= 0:
        radius = 1.0
    sizes = [abs(v) / 2.0 for v in (deviation, *band) if v is not None]
    sizes += [v for v in (offset, zone) if v is not None]
    largest = max(sizes, default=0.0)
    magnification = _magnification(_FIT_SHARE * radius / largest) if largest > 0 else 1.0
    scale = _FIT_RADIUS / radius
    cx = cy = 60.0
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="144" height="120" viewBox="0 0 144 120" '
           'role="img" aria-label="fit picture">']
    if checked and band[0] is not None and band[1] is not None:
        inner = scale * (radius + magnification * band[0] / 2.0)
        outer = scale * (radius + magnification * band[1] / 2.0)
        out.append(f'<circle class="zone" cx="{cx}" cy="{cy}" r="{max((inner + outer) / 2, 0):.2f}" '
                   f'stroke-width="{max(outer - inner, 0.5):.2f}"/>')
    if zone is not None:
        out.append(f'<circle class="poszone" cx="{cx}" cy="{cy}" r="{scale * magnification * zone:.2f}"/>')
    if checked:
        out.append(f'<circle class="nominal" cx="{cx}" cy="{cy}" r="{_FIT_RADIUS}"/>')
    decisions = [entry.get("decision") for entry in conformance.values() if isinstance(entry, dict)]
    css = ("fail" if "fail" in decisions else "undecided" if "undecided" in decisions
           else "pass" if checked else "unchecked")
    mx = cx + scale * magnification * (offset or 0.0)
    measured = max(scale * (radius + magnification * (deviation or 0.0) / 2.0), 0.5) if diameter else _FIT_RADIUS
    notes = []
    arc = _finite(hole.get("arc_deg"))
    if hole.get("partial") and arc is not None and 0 < arc < 360:
        sweep = math.radians(arc)
        start = -math.pi / 2 - sweep / 2
        x_a, y_a = mx + measured * math.cos(start), cy + measured * math.sin(start)
        x_b, y_b = mx + measured * math.cos(start + sweep), cy + measured * math.sin(start + sweep)
        out.append(f'<circle class="unseen" cx="{mx:.2f}" cy="{cy}" r="{measured:.2f}"/>'
                   f'<path class="measured {css}" d="M{x_a:.2f},{y_a:.2f} A{measured:.2f},{measured:.2f} 0 '
                   f'{1 if arc > 180 else 0} 1 {x_b:.2f},{y_b:.2f}"/>')
        notes.append(f"partial: {arc:.0f}\u00b0 of the edge seen")
    else:
        out.append(f'<circle class="measured {css}" cx="{mx:.2f}" cy="{cy}" r="{measured:.2f}"/>')
    out.append(f'<circle class="dot" cx="{mx:.2f}" cy="{cy}" r="1.8"/>')
    if checked:
        out.append(f'<line class="nominal" x1="{cx - 4}" x2="{cx + 4}" y1="{cy}" y2="{cy}"/>'
                   f'<line class="nominal" x1="{cx}" x2="{cx}" y1="{cy - 4}" y2="{cy + 4}"/>')
    if not checked:
        notes.append("unchecked: no nominal")
    return "".join(out) + '</svg>', magnification, notes


# ---------------------------------------------------------------------------------------------------
# Small helpers


def _e(value) -> str:
    return html.escape(str(value), quote=True)


def _input_of(source) -> str:
    """The file of a ``FILE:LINE`` source (a store id as it is)."""
    match = re.fullmatch(r"(.*):\d+", str(source))
    return match.group(1) if match else str(source)


def _mapping(value) -> dict:
    """``value`` when it is a dict, else an empty one (a record's part that is not what a record holds)."""
    return value if isinstance(value, dict) else {}


def _finite(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def _plain(value) -> str:
    return "not given" if value is None else f"{value:g}" if isinstance(value, (int, float)) else str(value)


def _name(name) -> str:
    return str(name).replace("_", " ")


def _number(value, digits) -> str:
    value = _finite(value)
    if value is None:
        return "&ndash;"
    return f"{value:.{digits}f}"


def _signed(value, digits) -> str:
    value = _finite(value)
    if value is None:
        return "&ndash;"
    shown = f"{value:+.{digits}f}"
    if float(shown) == 0.0:
        shown = f"{0.0:+.{digits}f}"  # not -0.0000: a deviation that rounds to nothing has no side
    return shown.replace("-", "&minus;")


def _band(lower, upper, digits) -> str:
    """A band of deviations: ``±t`` when symmetric, else ``lower / upper`` signed."""
    if lower is not None and upper is not None and upper > 0 and _number(-lower, digits) == _number(upper, digits):
        return f"&plusmn;{_number(upper, digits)}"
    return f"{_signed(lower, digits)} / {_signed(upper, digits)}"


def _index(value) -> str:
    if value is None:
        return "&ndash;"
    if not math.isfinite(value):
        return "&infin;" if value > 0 else "&minus;&infin;"
    return f"{value:.2f}"


def _rounded(value):
    return None if value is None else float(f"{value:.9g}")


def _median_tur(characteristics):
    """The median test-uncertainty ratio of a characteristic over the lot (None: U never known)."""
    ratios = [c.test_uncertainty_ratio for c in characteristics if c.test_uncertainty_ratio is not None]
    return float(np.median(ratios)) if ratios else None


def _limits(series):
    """The tolerance limits on the measured values of a characteristic over the lot: the most common."""
    lowers = Counter(_rounded(c.lower) for c in series if c.lower is not None)
    uppers = Counter(_rounded(c.upper) for c in series if c.upper is not None)
    lower = lowers.most_common(1)[0][0] if lowers else None
    upper = uppers.most_common(1)[0][0] if uppers else None
    return lower, upper


def _magnification(largest) -> float:
    """The 1-2-5 step at most ``largest``, at least 1."""
    if not largest > 1:
        return 1.0
    power = 10.0 ** math.floor(math.log10(largest))
    return max(step * power for step in (1, 2, 5) if step * power <= largest)


def _span(values, pad=0.0):
    values = [v for v in values if v is not None and math.isfinite(v)]
    if not values:
        return 0.0, 1.0
    low, high = min(values), max(values)
    if high - low <= 1e-12 * max(abs(low), abs(high), 1e-300):
        half = max(abs(low) * 1e-3, 1e-9)
        return low - half, high + half
    extra = pad * (high - low)
    return low - extra, high + extra


def _ticks(low, high, count=5):
    span = high - low
    if not span > 0:
        return [low]
    raw = span / count
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    start = math.ceil(low / step) * step
    return [start + i * step for i in range(int((high - start) / step + 1e-9) + 1)]


def _tick_label(value, low, high) -> str:
    span = high - low
    digits = max(0, int(-math.floor(math.log10(span / 5)))) if span > 0 else 3
    return f"{value:.{min(digits, 9)}f}"


def _spread(tags, top, bottom, gap=11.0):
    """Labels at heights ``y`` moved apart so that none overlaps, kept in ``[top, bottom]``."""
    tags = sorted(tags)
    placed = []
    for y, text in tags:
        y = max(y, top + 4)
        if placed and y - placed[-1][0] < gap:
            y = placed[-1][0] + gap
        placed.append((y, text))
    overflow = placed[-1][0] - bottom if placed else 0
    if overflow > 0:
        placed = [(y - overflow, text) for y, text in placed]
    return placed
