"""A lot of measurements as the quality records see it: each record's checked characteristics, in order.

A detect/batch record says, per checked hole, a ``conformance`` entry for each characteristic it
was checked on: the value compared (a deviation from the nominal, or the deviation itself for a
geometric tolerance), the zone's limits, the expanded uncertainty and the decision. The reports,
control charts, QIF and first-article tables all need the same thing from it: the nominal, the
limits, the measured value and the decision of every characteristic, and the characteristic's
identity across the lot (the spec's hole name and the check) to trend it. :func:`lot_from_records`
builds that once: a :class:`Lot` of :class:`Measurement` objects, each with its
:class:`Characteristic` objects.

Two kinds of check (``holecli.tolerance``'s):

- a *size* (:data:`SIZE_CHECKS`: diameters, the countersink's angle and depth): the record's value
  is ``measured - nominal`` against a band ``[lower, upper]`` of deviations, so the nominal is the
  measured value minus the deviation;
- a *zone* (:data:`ZONE_CHECKS`: position, tilt, perpendicularity): the value is the measured
  deviation itself (an in-plane distance, an angle), ideally 0, with an upper limit only.

A nominal hole the scan does not show (``verdict.missing``) gives one characteristic, ``presence``,
decided ``missing``.

Examples
--------
>>> record = {"file": "scans/part_001.ply", "units": "mm", "holes": [{
...     "index": 0, "name": "T1", "center": [0, 0, 0], "normal": [0, 0, 1], "diameter": 4.02, "warnings": [],
...     "conformance": {"diameter": {
...         "value": 0.02, "lower": -0.05, "upper": 0.05, "expanded_uncertainty": 0.01,
...         "decision": "pass", "reason": "inside"}}}],
...     "verdict": {"in_tolerance": True, "missing": []}}
>>> lot = lot_from_records([{"record": record, "source": "shift.jsonl:1"}])
>>> c = lot.characteristics[0]
>>> c.key, round(c.nominal, 6), c.measured, c.upper, c.decision
(('T1', 'diameter'), 4.0, 4.02, 4.05, 'pass')
>>> lot.measurements[0].label, round(c.test_uncertainty_ratio, 6)
('part_001', 5.0)
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from holecli.store.schema import verdict_word
from holecli.units import UNITS

SIZE_CHECKS = ("diameter", "countersink_diameter", "countersink_angle", "countersink_depth",
               "bore_diameter", "countersink_gauge")
"""The checks whose value is ``measured - nominal`` against a band of deviations."""

ZONE_CHECKS = ("position", "tilt", "perpendicularity")
"""The checks whose value is the measured deviation itself (>= 0, ideally 0) with an upper limit only."""

ANGLE_CHECKS = ("countersink_angle", "tilt", "perpendicularity")
"""The checks measured in degrees (the others in the record's length unit)."""

PRESENCE = "presence"
"""The characteristic of a nominal hole the scan does not show (decision ``missing``)."""


@dataclass(frozen=True)
class Characteristic:
    """One checked characteristic of one hole in one measurement.

    Attributes
    ----------
    measurement : int
        The :attr:`Measurement.order` of the record it belongs to.
    hole_index : int or None
        The hole's index in the record's ``holes``; None for a missing nominal hole.
    hole : str
        The spec's name of the hole, else ``#<index>``.
    name : str
        The check: a conformance key (``diameter``, ``position``, ...) or :data:`PRESENCE`.
    unit : str
        ``deg`` for :data:`ANGLE_CHECKS`, else the record's length unit (``""``: not declared).
    nominal : float or None
        A size's nominal (the measured value minus its deviation; None when not measured); 0.0 for
        a zone.
    measured : float or None
        A size's measured value; a zone's measured deviation (in-plane distance, angle).
    deviation : float or None
        ``measured - nominal``.
    lower_tolerance, upper_tolerance : float or None
        The band's deviation limits (a zone: ``lower_tolerance`` None, ``upper_tolerance`` its limit).
    lower, upper : float or None
        The limits on ``measured`` (``nominal`` plus the tolerances; None where unknown or none).
    expanded_uncertainty : float or None
        U = k u of the value (None: not known).
    decision : {"pass", "fail", "undecided", "missing"}
    reason : str
        The record's reason (``inside``, ``outside``, ``straddles_upper``, ``not_measured``, ...) or
        ``missing``.
    warnings : tuple of str
        The hole's warning codes (``rim_gap``, ``points_inside``, ...).
    named : bool
        Whether the hole has the spec's name. A hole checked against a nominal without a name (``detect
        --nominal-diameter ...``) is ``#<index>/<measurement number>``: the detection's index says
        nothing of which hole it is in another scan, so it is a characteristic of its measurement only,
        never trended across the lot.
    """

    measurement: int
    hole_index: int | None
    hole: str
    name: str
    unit: str
    nominal: float | None
    measured: float | None
    deviation: float | None
    lower_tolerance: float | None
    upper_tolerance: float | None
    lower: float | None
    upper: float | None
    expanded_uncertainty: float | None
    decision: str
    reason: str
    warnings: tuple = ()
    named: bool = True

    @property
    def key(self) -> tuple:
        """``(hole, name)``: the identity of the characteristic across a lot."""
        return (self.hole, self.name)

    @property
    def is_zone(self) -> bool:
        """Whether the check is a zone (:data:`ZONE_CHECKS`) rather than a size."""
        return self.name in ZONE_CHECKS

    @property
    def exceedance(self) -> float | None:
        """How far ``measured`` lies beyond the nearer limit (0.0 inside the limits; None when the
        value or the limits are not known)."""
        if self.measured is None or (self.lower is None and self.upper is None):
            return None
        below = self.lower - self.measured if self.lower is not None else -math.inf
        above = self.measured - self.upper if self.upper is not None else -math.inf
        return max(below, above, 0.0)

    @property
    def tolerance_zone(self) -> float | None:
        """The width of the tolerance zone: ``upper_tolerance - lower_tolerance`` (a size) or
        ``upper_tolerance`` (a zone); None for a missing hole."""
        if self.upper_tolerance is None:
            return None
        if self.is_zone or self.lower_tolerance is None:
            return self.upper_tolerance
        return self.upper_tolerance - self.lower_tolerance

    @property
    def test_uncertainty_ratio(self) -> float | None:
        """The test uncertainty ratio, tolerance zone / (2 U): below 1 the measurement's uncertainty
        interval is wider than the zone, and no value can be decided in tolerance with it; None when U
        is unknown or 0."""
        zone = self.tolerance_zone
        if zone is None or not self.expanded_uncertainty:
            return None
        return zone / (2.0 * self.expanded_uncertainty)


@dataclass(frozen=True)
class Measurement:
    """One record of a lot: one scan of one part.

    Attributes
    ----------
    order : int
        Its place in measurement order, from 0.
    record : dict
        The detect/batch record (a batch error record has ``error``).
    label : str
        How the reports name it: the metadata's serial, else the scan file's stem.
    part, serial : str or None
        The metadata's (a store's measurements), else None.
    id : str or None
        The store's id, else None.
    received : str or None
        When the store received it (ISO-8601 UTC), else None.
    source : str
        Where it was read: ``FILE:LINE`` or the store's id.
    verdict : {"pass", "fail", "undecided", "unchecked", "error"}
        :func:`holecli.store.schema.verdict_word` of the record.
    units : str
        The record's length unit, ``""`` when not declared.
    characteristics : tuple of Characteristic
        Its checked characteristics, in hole order then check order; then the missing holes'.
    """

    order: int
    record: dict
    label: str
    part: str | None
    serial: str | None
    id: str | None
    received: str | None
    source: str
    verdict: str
    units: str
    characteristics: tuple


@dataclass(frozen=True)
class Lot:
    """Measurements in order, with their characteristics.

    Attributes
    ----------
    measurements : tuple of Measurement
    """

    measurements: tuple

    @property
    def characteristics(self) -> tuple:
        """Every characteristic, in measurement order."""
        return tuple(c for m in self.measurements for c in m.characteristics)

    @property
    def keys(self) -> tuple:
        """The distinct :attr:`Characteristic.key` of the named holes, in the order first seen: the
        characteristics trended across the lot (a missing hole's ``presence`` has no value to trend, an
        unnamed hole is its measurement's only)."""
        seen = {}
        for c in self.characteristics:
            if c.name != PRESENCE and c.named:
                seen.setdefault(c.key, None)
        return tuple(seen)

    def series(self, key) -> list:
        """The characteristics of ``key`` in measurement order (at most one per measurement)."""
        return [c for c in self.characteristics if c.key == tuple(key)]

    def summary(self) -> dict:
        """What the lot holds, in counts.

        Returns
        -------
        dict
            ``measurements``; ``parts`` (distinct labels); ``holes`` (holes found); ``characteristics``
            (checked, missing holes included); ``verdicts`` (a count for each verdict word, every word
            present); ``rejected`` (the labels of the measurements whose verdict is ``fail`` or
            ``error``, in order, each once).
        """
        verdicts = dict.fromkeys(("pass", "fail", "undecided", "unchecked", "error"), 0)
        rejected = {}
        for m in self.measurements:
            verdicts[m.verdict] += 1
            if m.verdict in ("fail", "error"):
                rejected.setdefault(m.label, None)
        return {"measurements": len(self.measurements),
                "parts": len({m.label for m in self.measurements}),
                "holes": sum(len(m.record.get("holes") or ()) for m in self.measurements),
                "characteristics": sum(len(m.characteristics) for m in self.measurements),
                "verdicts": verdicts, "rejected": list(rejected)}


def measurement_from_record(record, *, order, source, meta=None, id=None, received=None) -> Measurement:
    """A :class:`Measurement` of one record.

    Parameters
    ----------
    record : dict
        A detect/batch record or a batch error record.
    order : int
        Its place in measurement order.
    source : str
        Where it was read (``FILE:LINE``, a store's id).
    meta : Mapping, optional
        The store's metadata (``part``, ``serial``, ...).
    id, received : str, optional
        The store's id and time of the measurement.

    Returns
    -------
    Measurement

    Raises
    ------
    ValueError
        When ``record`` is not a record: not an object, or without ``file`` or without ``holes``
        (``error`` aside), or its holes or conformance entries are not what a record holds.
    """
    if not isinstance(record, dict):
        raise ValueError(f"a record is a JSON object, got {type(record).__name__}")
    if "error" not in record and not isinstance(record.get("holes"), list):
        raise ValueError("not a holecli record: no \"holes\" list and no \"error\"")
    file = record.get("file")
    if not isinstance(file, str):
        raise ValueError("not a holecli record: no \"file\"")
    units = record.get("units") or ""
    if units not in ("", *UNITS):
        raise ValueError(f"units must be one of {', '.join(UNITS)} or null, got {_shown(units)}")
    options, verdict = _object(record, "options"), _object(record, "verdict")
    _object(options, "tolerances", "options.tolerances")
    for key in ("coverage_factor",):
        if verdict.get(key) is not None and _number(verdict[key]) is None:
            raise ValueError(f"verdict.{key} must be a number, got {_shown(verdict[key])}")
    missing = verdict.get("missing") or []
    if not isinstance(missing, list) or not all(isinstance(name, str) for name in missing):
        raise ValueError(f"verdict.missing must be a list of hole names, got {_shown(missing)}")
    meta = dict(meta or {})
    part, serial = _text(meta.get("part")), _text(meta.get("serial"))
    label = serial or _stem(file)
    characteristics = []
    for position, hole in enumerate(record.get("holes") or ()):
        if not isinstance(hole, dict):
            raise ValueError(f"hole {position} is not a JSON object")
        characteristics.extend(_hole_characteristics(hole, position, order, units))
    for name in missing:
        characteristics.append(Characteristic(
            measurement=order, hole_index=None, hole=name, name=PRESENCE, unit="", nominal=None, measured=None,
            deviation=None, lower_tolerance=None, upper_tolerance=None, lower=None, upper=None,
            expanded_uncertainty=None, decision="missing", reason="missing"))
    return Measurement(order=order, record=record, label=label, part=part, serial=serial,
                       id=id, received=received, source=source, verdict=verdict_word(record), units=units,
                       characteristics=tuple(characteristics))


def lot_from_records(entries) -> Lot:
    """A :class:`Lot` of records in measurement order.

    Parameters
    ----------
    entries : iterable of dict
        Each ``{"record": ..., "source": ...}`` with optionally ``meta``, ``id``, ``received``
        (the keyword arguments of :func:`measurement_from_record`), in measurement order.

    Returns
    -------
    Lot

    Raises
    ------
    ValueError
        When an entry's record is not a record; the message starts with its source.
    """
    measurements = []
    for order, entry in enumerate(entries):
        try:
            measurements.append(measurement_from_record(
                entry["record"], order=order, source=entry["source"], meta=entry.get("meta"), id=entry.get("id"),
                received=entry.get("received")))
        except ValueError as error:
            raise ValueError(f"{entry['source']}: {error}") from None
    return Lot(tuple(measurements))


def _hole_characteristics(hole, position, order, units) -> list:
    """The characteristics of one hole of a record (none when it was not checked), the hole's shape
    checked (checked or not)."""
    index = hole.get("index", position)
    if isinstance(index, bool) or not isinstance(index, int):
        raise ValueError(f"hole {position}: index must be an integer, got {_shown(index)}")
    name = hole.get("name")
    if name is not None and (not isinstance(name, str) or not name):
        raise ValueError(f"hole {position}: name must be a non-empty string or null, got {_shown(name)}")
    for key in ("center", "normal"):
        vector = hole.get(key)
        if not (isinstance(vector, list) and len(vector) == 3 and all(_number(v) is not None for v in vector)):
            raise ValueError(f"hole {position}: {key} must be 3 finite numbers, got {_shown(vector)}")
    if _number(hole.get("diameter")) is None or hole["diameter"] <= 0:
        raise ValueError(f"hole {position}: diameter must be a positive number, got {_shown(hole.get('diameter'))}")
    warnings = warning_codes(hole, position)
    conformance = hole.get("conformance")
    if not conformance:
        return []
    if not isinstance(conformance, dict):
        raise ValueError(f"hole {position}: conformance is not a JSON object")
    out = []
    for check, entry in conformance.items():
        if not isinstance(entry, dict) or entry.get("decision") not in DECISIONS:
            raise ValueError(f"hole {position}: conformance.{check} is not a conformance entry (a decision "
                             f"{', '.join(DECISIONS)})")
        upper_tol = _limited(entry, "upper", position, check)
        if upper_tol is None:
            raise ValueError(f"hole {position}: conformance.{check}.upper must be a number")
        value, lower_tol = _limited(entry, "value", position, check), _limited(entry, "lower", position, check)
        expanded = _limited(entry, "expanded_uncertainty", position, check)
        if expanded is not None and expanded < 0:
            raise ValueError(f"hole {position}: conformance.{check}.expanded_uncertainty must be >= 0")
        reason = entry.get("reason") or ""
        if not isinstance(reason, str):
            raise ValueError(f"hole {position}: conformance.{check}.reason must be a string")
        if check in ZONE_CHECKS:
            nominal, measured, deviation = 0.0, value, value
            lower, upper = None, upper_tol
            lower_tol = None
        else:
            measured = _measured_value(hole, check)
            deviation = value
            nominal = measured - deviation if measured is not None and deviation is not None else None
            lower = nominal + lower_tol if nominal is not None and lower_tol is not None else None
            upper = nominal + upper_tol if nominal is not None and upper_tol is not None else None
        out.append(Characteristic(
            measurement=order, hole_index=index, hole=name or f"#{index}/{order + 1}", name=check,
            unit="deg" if check in ANGLE_CHECKS else units, nominal=nominal, measured=measured, deviation=deviation,
            lower_tolerance=lower_tol, upper_tolerance=upper_tol, lower=lower, upper=upper,
            expanded_uncertainty=expanded, decision=entry["decision"], reason=reason, warnings=warnings,
            named=name is not None))
    return out


def warning_codes(hole, position=0) -> tuple:
    """The warning codes of a record's hole (its ``warnings``: objects with a ``code``, or codes).

    Raises
    ------
    ValueError
        When ``warnings`` is not a list of them.
    """
    listed = hole.get("warnings") or []
    if not isinstance(listed, list):
        raise ValueError(f"hole {position}: warnings is not a list")
    codes = tuple(w.get("code") if isinstance(w, dict) else w for w in listed)
    if not all(isinstance(code, str) and code for code in codes):
        raise ValueError(f"hole {position}: a warning has no code")
    return codes


# Where a size check's measured value is in a hole (holecli.tolerance's _FEATURE_CHECKS and gauge).
_MEASURED_PATHS = {"diameter": ("diameter",), "countersink_diameter": ("countersink", "diameter"),
                   "countersink_angle": ("countersink", "angle_deg"), "countersink_depth": ("countersink", "depth"),
                   "bore_diameter": ("bore", "diameter"), "countersink_gauge": ("countersink", "diameter_at_depth")}


def _measured_value(hole, check):
    """The measured value of a size check in ``hole`` (None when not measured or the check unknown)."""
    value = hole
    for key in _MEASURED_PATHS.get(check, (None,)):
        value = value.get(key) if isinstance(value, dict) else None
    return _number(value)


def _number(value):
    """``value`` as a float when it is a finite number, else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


# The decisions of a conformance entry (holecli.tolerance).
DECISIONS = ("pass", "fail", "undecided")

# The largest magnitude of a value the records are read with: beyond it a record is not a measurement
# (and the statistics of such values overflow).
_LARGEST = 1e12


def _limited(entry, key, position, check):
    """A conformance entry's number ``key`` (None when null), refused when it is not one or is beyond
    :data:`_LARGEST`."""
    value = entry.get(key)
    if value is None:
        return None
    number = _number(value)
    if number is None or abs(number) > _LARGEST:
        raise ValueError(f"hole {position}: conformance.{check}.{key} must be a finite number, got {_shown(value)}")
    return number


def _object(container, key, name=None) -> dict:
    """``container[key]`` when it is an object, {} when absent or null; refused otherwise."""
    value = container.get(key)
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ValueError(f"{name or key} must be a JSON object, got {_shown(value)}")
    return value


def _shown(value) -> str:
    """A value as a message shows it (at most 40 characters)."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _text(value):
    """A metadata value as text, or None when not given or empty."""
    return None if value is None or value == "" else str(value)


def _stem(file) -> str:
    """The stem of a scan's file name (``-`` for stdin stays ``-``)."""
    base = os.path.basename(file.replace("\\", "/")) or file
    stem, _ = os.path.splitext(base)
    return stem or base
