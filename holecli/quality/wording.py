"""How the quality records say things: a decision's reason, a hole's warning, the test uncertainty ratio,
and how many decimals a characteristic's values get. One wording for the HTML report
(:mod:`holecli.quality.html`) and the first-article rows (:mod:`holecli.quality.tables`).
"""

from __future__ import annotations

import math

from holecli.vocabulary import DOUBT_CODES, WARNING_CODES

TUR_GOOD = 4.0
"""The test uncertainty ratio from which a measurement is fit to decide conformance (4:1)."""

#: A conformance reason (holecli.tolerance's ``reason`` codes, and ``missing``) in plain words.
REASON_WORDS = {
    "inside": "inside the tolerance",
    "outside": "outside the tolerance",
    "inside_with_uncertainty": "inside the tolerance by more than its uncertainty U: conformance proved",
    "outside_with_uncertainty": "outside the tolerance by more than its uncertainty U: non-conformance proved",
    "straddles_lower": "within its uncertainty U of the lower limit: the measurement cannot decide",
    "straddles_upper": "within its uncertainty U of the upper limit: the measurement cannot decide",
    "straddles_both": "its uncertainty U is wider than the tolerance: the measurement cannot decide",
    "uncertainty_unknown": "its uncertainty is not known, so conformance cannot be proved (guarded rule)",
    "not_measured": "not measured: the scan does not show this value, so it cannot be accepted",
    "missing": "no hole found where the drawing puts one",
}

#: The hole warnings an inspector should weigh before rejecting a part, in shop-floor words (the
#: others are said in holecli.vocabulary's words). A fail beside one of these may be debris, not a bad hole.
WARNING_WORDS = {
    "points_inside": "points inside the hole: possible chips, burr or lubricant (or reflections) in the hole",
    "rim_gap": "part of the hole's edge not seen: chips, lubricant or a shadow may hide it",
    "few_rim_points": "few points on the edge: centre and diameter loosely held",
    "high_fit_rms": "ragged edge: the edge points scatter (burr or chips on the edge?)",
    "surface_not_flat": "the surface around the hole is not flat (burr, sealant or chips?)",
    "near_border": "at the border of the scan: its surroundings are not all scanned",
    "edge_bore_mismatch": "edge and bore disagree: an edge break (chamfer, burr) the scan does not resolve",
    "blurred_edge": "blurred edge: the edge lies somewhere in a wide band",
    "large_bias_correction": "a large correction of the diameter for the scan's sampling",
    "bias_not_measured": "the diameter's sampling correction could not be measured",
}


def tur_level(ratio, one_sided=False) -> str:
    """How well a measurement of this test-uncertainty ratio (tolerance zone / 2U) decides conformance.

    Parameters
    ----------
    ratio : float or None
    one_sided : bool
        A zone with an upper limit only (position, tilt, perpendicularity: the value is a deviation,
        never below 0), whose zone is [0, T].

    Returns
    -------
    {"danger", "caution", "ok", "note"}
        ``danger`` when no value can be proved in tolerance with this U (ISO 14253-1's guarded rule):
        2U wider than the zone (ratio below 1), or, one-sided, U above T (below 0.5; the rule of
        :func:`holecli.tolerance.uncertainty_exceeds_zone`); ``caution`` below 4:1; ``ok`` from 4:1;
        ``note`` when U is not known.

    Examples
    --------
    >>> tur_level(0.7), tur_level(0.7, one_sided=True), tur_level(0.4, one_sided=True), tur_level(None)
    ('danger', 'caution', 'danger', 'note')
    """
    if ratio is None or not math.isfinite(ratio):
        return "note"
    if ratio < (0.5 if one_sided else 1.0):
        return "danger"
    return "caution" if ratio < TUR_GOOD else "ok"


def tur_words(ratio, one_sided=False) -> tuple[str, str]:
    """The test-uncertainty ratio (tolerance zone / 2U) said plainly, with its level (:func:`tur_level`,
    the page's CSS class).

    Examples
    --------
    >>> tur_words(0.5)[1], tur_words(2.0)[1], tur_words(10.0)[1], tur_words(None)[1]
    ('danger', 'caution', 'ok', 'note')
    >>> tur_words(0.99999)[0]
    'Test-uncertainty ratio (tolerance zone / 2U) 0.99999: the uncertainty is larger than the tolerance: this measurement cannot decide conformance.'
    """
    level = tur_level(ratio, one_sided)
    if level == "note":
        return "The uncertainty U is not known: no test-uncertainty ratio.", "note"
    said = f"Test-uncertainty ratio (tolerance zone / 2U) {_ratio(ratio)}: "
    if level == "danger":
        return said + ("the uncertainty is larger than the tolerance: this measurement cannot decide "
                       "conformance."), level
    if level == "caution":
        return said + ("caution: the uncertainty takes a large share of the tolerance (below 4:1); values near a "
                       "limit cannot be told in from out."), level
    return said + "the measurement is fit to decide (4:1 or better).", level


def _ratio(ratio) -> str:
    """A ratio to 3 significant digits, but never rounded across a threshold (0.99999 is not 1)."""
    shown = f"{ratio:.3g}"
    for threshold in (0.5, 1.0, TUR_GOOD):
        if (ratio < threshold) != (float(shown) < threshold):
            return f"{ratio:.6g}"
    return shown


def reason_words(code) -> str:
    """A conformance reason in plain words (:data:`REASON_WORDS`; an unknown code as its words)."""
    return REASON_WORDS.get(code, str(code).replace("_", " "))


def warning_phrase(code) -> str:
    """A hole warning in a few words (:data:`WARNING_WORDS`, else the first clause of its sentence)."""
    if code in WARNING_WORDS:
        return WARNING_WORDS[code]
    return warning_sentence(code).split(":")[0]


def warning_sentence(code) -> str:
    """A hole warning (or doubt) code's full sentence, holecli.vocabulary's."""
    return DOUBT_CODES.get(code) or WARNING_CODES.get(code) or str(code).replace("_", " ")


def decimals(characteristic) -> int:
    """Decimals that show a characteristic's values to about a thousandth of its tolerance zone."""
    try:
        zone = characteristic.tolerance_zone
    except (TypeError, AttributeError):
        zone = None
    if zone is None or not math.isfinite(zone) or zone <= 0:
        return 4
    return int(min(9, max(1, math.ceil(-math.log10(zone)) + 3)))
