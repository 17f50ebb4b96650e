"""Tolerance verdicts: a detection record checked against a :class:`holecli.tolerance.spec.Spec` (matching
of measured and nominal holes, each check, the decision rules, the unit checks). See
:mod:`holecli.tolerance` for the checks and the decision rules."""

from __future__ import annotations

import math
from dataclasses import replace

from holecli.tolerance.spec import (_FEATURE_CHECKS, _ROUND_OFF, _UNCERTAINTY_PATHS, DEFAULT_COVERAGE_FACTOR, Band,
                                    NominalHole, _shown, spec_number)
from holecli.units import UNIT_MISMATCH, label_record, scale_factor, unit_factors, unit_mistake
from holecli.vocabulary import NOT_IN_SPEC_FRAME, UNCERTAINTY_NOTE

__all__ = ["check", "describe", "far_from_spec", "spec_in_units", "uncertainty_exceeds_zone",
           "uncertainty_zone_message", "uncertainty_zone_notes", "unit_scale_match"]


def describe(spec) -> dict:
    """What a record's ``options.tolerances`` says of ``spec``: enough to check the record again.

    Parameters
    ----------
    spec : Spec

    Returns
    -------
    dict
        ``spec_file`` and ``spec_sha256`` for a spec file (the file and the SHA-256 of its bytes; the
        nominal holes are in the file), ``nominal`` None; for the command line's tolerance options,
        ``spec_file`` and ``spec_sha256`` None and ``nominal`` the one nominal hole: every
        :class:`NominalHole` value by name (bands as ``{"lower", "upper"}``, None where not given).
        Either way ``decision_rule`` and ``coverage_factor``, how the checks were decided, and
        ``registration`` when the nominal holes were mapped by one (:attr:`Spec.registration`).
    """
    decision = {"decision_rule": spec.decision_rule, "coverage_factor": spec.coverage_factor}
    if spec.registration is not None:
        decision["registration"] = spec.registration
    if spec.named:
        return {"spec_file": spec.source, "spec_sha256": spec.sha256, "nominal": None, **decision}
    hole = spec.holes[0]
    nominal = {}
    for name, value in hole.__dict__.items():
        if name in ("name", "match_radius", "center_covariance", "normal_uncertainty_deg"):
            continue
        if isinstance(value, Band):
            value = {"lower": value.lower, "upper": value.upper}
        elif isinstance(value, tuple):
            value = list(value)
        nominal[name] = value
    return {"spec_file": None, "spec_sha256": None, "nominal": nominal, **decision}


def check(record, spec, tied=None) -> dict:
    """A copy of ``record`` with the tolerance verdicts of ``spec`` added.

    Parameters
    ----------
    record : dict
        A detection record (:meth:`holecli.results.Detection.to_dict`): ``holes`` with ``center``,
        ``diameter`` and ``normal``, and ``countersink``, ``bore`` and ``perpendicularity_deg`` for the
        checks of those (missing counts as null); optionally each hole's ``uncertainty``, the
        standard uncertainties (k = 1) of its values (missing or null: not known).
    spec : Spec
        From :func:`nominal_spec` or :func:`parse_spec`; its ``decision_rule`` and
        ``coverage_factor`` say how a value and its uncertainty decide a check.
    tied : dict, optional
        ``{measured hole index: nominal name}``: holes tied to spec holes by name (``--name``, a
        one-hole scan named after a hole). Each is checked against its nominal wherever it lies; no
        other hole is matched and only the tied nominals are expected (a scan of one hole does not
        miss the spec's other holes). A tied hole farther from its nominal's center than the
        nominal's ``match_radius``, with a spec that no registration mapped into the scan's frame
        (:attr:`Spec.registration` None), is in another frame: its position and tilt are not checked
        (null, and the note ``not_in_spec_frame`` says so).

    Returns
    -------
    dict
        The record, every hole with ``diameter_deviation``, ``position_deviation``
        (``{"in_plane", "along_normal"}``), ``tilt_deg``, ``countersink_diameter_deviation``,
        ``countersink_angle_deviation``, ``countersink_depth_deviation``, ``bore_diameter_deviation``,
        ``in_tolerance``, ``failed_checks``, ``undecided_checks`` and ``conformance`` (None where the
        check does not apply or its value is not measured, all None for a hole no nominal applies
        to; a check not measured is in ``failed_checks`` as ``<check>_not_measured``; ``conformance``
        the decision of every check, see the module's docstring; ``in_tolerance`` true only when
        every check passes), and with ``name`` when ``spec.named``; and ``verdict``: ``{"checked",
        "out_of_tolerance", "undecided", "missing", "in_tolerance", "decision_rule",
        "coverage_factor"}`` after ``holes`` (``out_of_tolerance`` the holes with a failed check,
        ``undecided`` those with an undecided check and none failed). A record with ``options`` gets
        its ``tolerances`` (:func:`describe`). A spec that declares its unit (:attr:`Spec.units`) is
        converted into the record's ``units``; a record without ``units`` takes the spec's (its
        lengths are assumed to be in it); the verdict then also says ``spec_units`` and
        ``spec_units_assumed``. A hole whose measured diameter is a unit's factor of its nominal
        (1000, 25.4, ... within 1 %) gets the warning ``unit_mismatch`` in its ``warnings``.

    Raises
    ------
    ValueError
        When a hole's ``uncertainty`` holds a value that is not a finite number >= 0, or ``tied``
        names a hole or a nominal that is not there.
    """
    declared = spec.units
    spec, record, assumed = _spec_in_record_units(spec, record)
    holes = record["holes"]
    expected = spec.holes
    if tied is None:
        assigned = _match(holes, spec.holes)
    else:
        assigned = _tie(holes, spec.holes, tied)
        expected = tuple(assigned.values())
    checked_holes = []
    checked = failed = undecided = 0
    for index, hole in enumerate(holes):
        nominal = assigned.get(index)
        result = dict(hole)
        if spec.named:
            result["name"] = nominal.name if nominal else None
        in_frame = (tied is None or nominal is None or spec.registration is not None or nominal.center is None
                    or math.dist(hole["center"], nominal.center) <= nominal.match_radius)
        result.update(_verdict(hole, nominal, spec.decision_rule, spec.coverage_factor, in_frame))
        mistake = _unit_mismatch_warning(hole, nominal, record.get("units"), declared)
        if mistake is not None:
            result["warnings"] = [*hole.get("warnings", ()), mistake]
        if not in_frame:
            distance = math.dist(hole["center"], nominal.center)
            result["notes"] = [*hole.get("notes", ()), {"code": NOT_IN_SPEC_FRAME, "message": (
                f"tied to spec hole {nominal.name} but {distance:.4g} from its center (match radius "
                f"{nominal.match_radius:g}): the scan is in another frame, position and tilt not checked "
                f"(--registration maps the spec into the scan's frame)")}]
        if spec.decision_rule == "guarded" and result.get("conformance"):
            zone_notes = uncertainty_zone_notes(result["conformance"])
            if zone_notes:
                result["notes"] = [*(result.get("notes") or ()), *zone_notes]
        if nominal is not None:
            checked += 1
            failed += bool(result["failed_checks"])
            undecided += not result["failed_checks"] and bool(result["undecided_checks"])
        checked_holes.append(result)
    matched = {id(nominal) for nominal in assigned.values()}
    missing = [nominal.name for nominal in expected if id(nominal) not in matched]
    verdict = {"checked": checked, "out_of_tolerance": failed, "undecided": undecided, "missing": missing,
               "in_tolerance": failed == 0 and undecided == 0 and not missing,
               "decision_rule": spec.decision_rule, "coverage_factor": spec.coverage_factor}
    if declared is not None:  # (a spec without units: the verdict as before)
        verdict["spec_units"] = declared
        verdict["spec_units_assumed"] = assumed
    out = {}
    for key, value in record.items():
        out[key] = checked_holes if key == "holes" else value
        if key == "holes":
            out["verdict"] = verdict
        elif key == "options" and isinstance(value, dict):
            out[key] = {**value, "tolerances": describe(spec)}
    return out


def uncertainty_exceeds_zone(entry):
    """Whether a check's expanded uncertainty ``U`` is too wide for its tolerance zone: no measured value
    could pass it under the guarded rule (``2U`` wider than a band ``upper - lower``; ``U`` above a
    largest value's ``upper``).

    Parameters
    ----------
    entry : dict
        A conformance entry (``lower``, ``upper``, ``expanded_uncertainty``).

    Returns
    -------
    bool
        False when ``U`` is not known.

    Examples
    --------
    >>> uncertainty_exceeds_zone({"lower": -0.02, "upper": 0.02, "expanded_uncertainty": 0.046})
    True
    >>> uncertainty_exceeds_zone({"lower": None, "upper": 0.1, "expanded_uncertainty": 0.004})
    False
    """
    expanded = entry.get("expanded_uncertainty")
    if expanded is None:
        return False
    if entry.get("lower") is None:
        return expanded > entry["upper"]
    return 2.0 * expanded > entry["upper"] - entry["lower"]


def uncertainty_zone_message(check, entry):
    """Why ``check`` can never pass under the guarded rule (:func:`uncertainty_exceeds_zone`), in words.

    Examples
    --------
    >>> uncertainty_zone_message("diameter", {"lower": -0.02, "upper": 0.02, "expanded_uncertainty": 0.046})
    'diameter: 2U = 0.092 is wider than its tolerance zone 0.04: a guarded decision can never pass it'
    """
    expanded = entry["expanded_uncertainty"]
    if entry.get("lower") is None:
        what = f"U = {expanded:.2g} exceeds its largest value {entry['upper']:.4g}"
    else:
        what = f"2U = {2.0 * expanded:.2g} is wider than its tolerance zone {entry['upper'] - entry['lower']:.4g}"
    return f"{check}: {what}: a guarded decision can never pass it"


def uncertainty_zone_notes(conformance):
    """The notes (:data:`holecli.vocabulary.UNCERTAINTY_NOTE`) of a hole's checks whose U exceeds their tolerance zone.

    Parameters
    ----------
    conformance : dict
        A checked hole's ``conformance``.

    Returns
    -------
    list of dict
        ``{"code", "message"}``, one per such check.
    """
    return [{"code": UNCERTAINTY_NOTE, "message": uncertainty_zone_message(check, entry)}
            for check, entry in conformance.items() if uncertainty_exceeds_zone(entry)]


def far_from_spec(record, spec):
    """``(distance, name)``: how far the nearest measured hole lies from the nearest spec hole, when holes
    were measured, every spec hole has a center and none of them was matched (all beyond their match
    radii: a scan in another frame or unit than the spec); else None.

    Parameters
    ----------
    record : dict
        A detect record, checked against ``spec`` (:func:`check`).
    spec : Spec

    Returns
    -------
    (float, str) or None
    """
    holes, verdict = record.get("holes") or [], record.get("verdict") or {}
    nominals = spec.holes
    if not holes or not nominals or verdict.get("checked") or any(n.center is None for n in nominals):
        return None
    distance, name = min((math.dist(hole["center"], nominal.center), nominal.name)
                         for hole in holes for nominal in nominals)
    return distance, name


def _tie(holes, nominals, tied) -> dict:
    """{measured index: nominal} of ``tied`` ({measured index: nominal name})."""
    by_name = {nominal.name: nominal for nominal in nominals}
    assigned = {}
    for index, name in tied.items():
        if not 0 <= index < len(holes):
            raise ValueError(f"tied hole {index} is not a measured hole (there are {len(holes)})")
        if name not in by_name:
            raise ValueError(f"tied to {name!r}, which is not a hole of the spec")
        assigned[index] = by_name[name]
    return assigned
def unit_scale_match(record, spec):
    """``(factor, scan_unit, spec_unit)`` when no measured hole lies near a spec hole (:func:`far_from_spec`)
    but every one of them would, the measured centers multiplied by a factor of units (1000, 25.4, ...,
    and their inverses): the scan and the spec in different units; else None.

    "Every one": as many pairs as the fewer of the measured and the spec holes (a scan may show part of
    the part) match within the spec holes' match radii, and at least one.

    Parameters
    ----------
    record : dict
        A detect record, checked against ``spec`` (:func:`check`).
    spec : Spec

    Returns
    -------
    (float, str, str) or None
        The factor the measured centers were multiplied by, the unit the scan would then be in and the
        spec's (e.g. ``(1000.0, "m", "mm")``).
    """
    if far_from_spec(record, spec) is None:
        return None
    holes = record["holes"]
    spec, _, _ = _spec_in_record_units(spec, record)
    wanted = min(len(holes), len(spec.holes))
    for factor, scan_unit, spec_unit in unit_factors():
        scaled = [{**hole, "center": [c * factor for c in hole["center"]]} for hole in holes]
        if len(_match(scaled, spec.holes)) == wanted:
            return factor, scan_unit, spec_unit
    return None


def spec_in_units(spec, units):
    """``spec`` with its lengths in ``units``, when it declares its own (:attr:`Spec.units`) and ``units``
    is known; else ``spec`` itself (a spec without units is in the scan's unit, whatever it is; a known
    spec unit against an unknown scan unit is taken as the scan's).

    Parameters
    ----------
    spec : Spec
    units : {"mm", "m", "in"} or None
        The scan's unit.

    Returns
    -------
    Spec
        Its ``units`` still the declared one (what the file said); angles, normals and names unchanged.
    """
    if spec.units is None or units is None:
        return spec
    factor = scale_factor(spec.units, units)
    if factor == 1.0:
        return spec
    return replace(spec, holes=tuple(_scaled_nominal(hole, factor) for hole in spec.holes))


def _spec_in_record_units(spec, record):
    """``(spec, record, assumed)``: ``spec`` with its lengths in the record's unit when it declares its own
    and the record says one; the record labelled with the spec's unit when it says none (``assumed``
    True: the spec's lengths are taken in the scan's unit, which is then said to be the spec's)."""
    if spec.units is None:
        return spec, record, False
    if record.get("units") is None:
        return spec, label_record(record, spec.units), True
    return spec_in_units(spec, record["units"]), record, False


# The lengths of a nominal hole (the others are angles, a direction and the name).
_NOMINAL_LENGTHS = ("diameter", "position_tolerance", "countersink_diameter", "countersink_depth", "bore_diameter",
                    "match_radius")
_NOMINAL_BANDS = ("band", "countersink_diameter_band", "countersink_depth_band", "bore_diameter_band")


def _scaled_nominal(hole, factor) -> NominalHole:
    """``hole`` with every length multiplied by ``factor`` (angles, the normal and the name as they are)."""
    values = {key: getattr(hole, key) * factor for key in _NOMINAL_LENGTHS if getattr(hole, key) is not None}
    values.update({key: Band(lower=getattr(hole, key).lower * factor, upper=getattr(hole, key).upper * factor)
                   for key in _NOMINAL_BANDS if getattr(hole, key) is not None})
    if hole.center is not None:
        values["center"] = tuple(c * factor for c in hole.center)
    return replace(hole, **values)


def _unit_mismatch_warning(hole, nominal, units=None, declared=None):
    """The ``unit_mismatch`` warning of a hole whose measured diameter is a unit's factor of its nominal
    (:func:`holecli.units.unit_mistake`), or None. ``units``: the record's unit (the tolerances are
    taken in it, unless the spec declared its own, ``declared``), which the advice then names."""
    if nominal is None or nominal.diameter is None:
        return None
    mistake = unit_mistake(hole.get("diameter"), nominal.diameter)
    if mistake is None:
        return None
    ratio, scan_unit, spec_unit = mistake
    if units is None:
        advice = (f"give --units {scan_unit} --output-units {spec_unit} (tolerances are in the output unit), or "
                  f"units = \"{spec_unit}\" in the spec file with --units {scan_unit}")
    elif declared is None:
        advice = (f"the record is in {units} and the tolerances are taken in it: give them in {units}, or "
                  f"--output-units {spec_unit} with --units {scan_unit} when the scan is in {scan_unit} "
                  f"(or units = \"{spec_unit}\" in the spec file)")
    else:
        advice = f"the spec says {declared} and the record is in {units}: check --units"
    return {"code": UNIT_MISMATCH,
            "message": f"measured diameter {hole['diameter']:.4g} is {ratio} of the nominal {nominal.diameter:.4g}: "
                       f"the scan may be in {scan_unit} and the tolerances in {spec_unit}; {advice}"}


def _match(holes, nominals) -> dict:
    """{measured index: nominal}: one-to-one by increasing distance for nominals with a center; a
    nominal without a center takes every hole."""
    assigned = {}
    pairs = []
    for n, nominal in enumerate(nominals):
        if nominal.center is None:
            return {index: nominal for index in range(len(holes))}
        for index, hole in enumerate(holes):
            distance = math.dist(hole["center"], nominal.center)
            if distance <= nominal.match_radius:
                pairs.append((distance, n, index))
    taken = set()
    for _, n, index in sorted(pairs):
        if n not in taken and index not in assigned:
            assigned[index] = nominals[n]
            taken.add(n)
    return assigned


def _verdict(hole, nominal, rule="simple", coverage_factor=DEFAULT_COVERAGE_FACTOR, in_frame=True) -> dict:
    """The verdict fields of ``hole`` against ``nominal``; without ``in_frame`` (a tied hole of a scan
    in another frame than the nominal's) no position and no tilt."""
    out = {"diameter_deviation": None, "position_deviation": None, "tilt_deg": None,
           **{f"{feature.name}_deviation": None for feature in _FEATURE_CHECKS}, "countersink_gauge_deviation": None,
           "in_tolerance": None, "failed_checks": None, "undecided_checks": None, "conformance": None}
    if nominal is None:
        return out
    uncertainty = hole.get("uncertainty") or {}
    conformance = {}

    def decide(name, value, lower, upper, size, nominal_u=None):
        expanded = _expanded_uncertainty(uncertainty, name, coverage_factor, hole.get("index"))
        if nominal_u is not None:  # the nominal's own (a registration's), in quadrature with the measurement's
            known = expanded is not None and math.isfinite(nominal_u)
            expanded = math.hypot(expanded, coverage_factor * nominal_u) if known else None
        conformance[name] = _decision(value, lower, upper, expanded, size, rule)
        if nominal_u is not None:
            conformance[name]["nominal_uncertainty"] = nominal_u if math.isfinite(nominal_u) else None

    if nominal.diameter is not None:
        deviation = hole["diameter"] - nominal.diameter
        out["diameter_deviation"] = deviation
        decide("diameter", deviation, nominal.band.lower, nominal.band.upper, nominal.diameter)
    normal = _unit(hole["normal"])
    if nominal.center is not None and in_frame:
        offset = [m - c for m, c in zip(hole["center"], nominal.center)]
        along = sum(o * n for o, n in zip(offset, normal))
        in_plane = math.hypot(*(o - along * n for o, n in zip(offset, normal)))
        out["position_deviation"] = {"in_plane": in_plane, "along_normal": along}
        if nominal.position_tolerance is not None:
            decide("position", in_plane, None, nominal.position_tolerance, nominal.position_tolerance,
                   _in_plane_uncertainty(nominal.center_covariance, normal))
    if nominal.normal is not None and in_frame:
        tilt = _line_angle_deg(normal, _unit(nominal.normal))
        out["tilt_deg"] = tilt
        if nominal.max_tilt is not None:
            decide("tilt", tilt, None, nominal.max_tilt, nominal.max_tilt, nominal.normal_uncertainty_deg)
    for feature in _FEATURE_CHECKS:
        nominal_value = getattr(nominal, feature.name)
        if nominal_value is None:
            continue
        part, key = feature.path
        measured = (hole.get(part) or {}).get(key)
        deviation = None if measured is None else measured - nominal_value
        out[f"{feature.name}_deviation"] = deviation
        band = getattr(nominal, f"{feature.name}_band")
        decide(feature.name, deviation, band.lower, band.upper, nominal_value)
    if nominal.countersink_gauge_diameter is not None:
        measured = (hole.get("countersink") or {}).get("diameter_at_depth")
        deviation = None if measured is None else measured - nominal.countersink_gauge_diameter
        out["countersink_gauge_deviation"] = deviation
        band = nominal.countersink_gauge_band
        decide("countersink_gauge", deviation, band.lower, band.upper, nominal.countersink_gauge_diameter)
    if nominal.max_perpendicularity is not None:
        decide("perpendicularity", hole.get("perpendicularity_deg"), None, nominal.max_perpendicularity,
               nominal.max_perpendicularity)
    out["failed_checks"] = [name + ("_not_measured" if entry["value"] is None else "")
                            for name, entry in conformance.items() if entry["decision"] == "fail"]
    out["undecided_checks"] = [name for name, entry in conformance.items() if entry["decision"] == "undecided"]
    out["in_tolerance"] = not out["failed_checks"] and not out["undecided_checks"]
    out["conformance"] = conformance
    return out


def _in_plane_uncertainty(covariance, normal):
    """The standard uncertainty of each coordinate, in the plane of unit ``normal``, of a point of 3x3
    ``covariance`` (as a hole's ``uncertainty.center_in_plane``): ``sqrt(trace(P C P) / 2)`` with
    ``P = I - n n^T``; None without a covariance, ``inf`` when it is not finite."""
    if covariance is None:
        return None
    values = [float(value) for row in covariance for value in row]
    if not all(math.isfinite(value) for value in values):
        return math.inf
    trace = values[0] + values[4] + values[8]
    along = sum(normal[i] * values[3 * i + j] * normal[j] for i in range(3) for j in range(3))
    return math.sqrt(max(trace - along, 0.0) / 2.0)


def _decision(value, lower, upper, expanded, size, rule) -> dict:
    """The conformance entry of one check: ``value`` against the zone ``[lower, upper]`` (``lower``
    None: no lower limit) by ``rule``, with the expanded uncertainty ``expanded`` (None: not known) and
    the round-off of a quantity of ``size``."""
    entry = {"value": value, "lower": lower, "upper": upper, "expanded_uncertainty": expanded}
    slack = _ROUND_OFF * size
    low = -math.inf if lower is None else lower - slack
    high = upper + slack
    if value is None:
        decision, reason = "fail", "not_measured"
    elif rule == "simple":
        decision, reason = ("pass", "inside") if low <= value <= high else ("fail", "outside")
    elif expanded is None:
        decision, reason = "undecided", "uncertainty_unknown"
    elif value - expanded > high or value + expanded < low:
        decision, reason = "fail", "outside_with_uncertainty"
    elif low <= value - expanded and value + expanded <= high:
        decision, reason = "pass", "inside_with_uncertainty"
    else:
        below, above = value - expanded < low, value + expanded > high
        decision = "undecided"
        reason = "straddles_both" if below and above else ("straddles_lower" if below else "straddles_upper")
    return {**entry, "decision": decision, "reason": reason}


def _expanded_uncertainty(uncertainty, check_name, coverage_factor, index):
    """``k * u`` of a check from a hole's ``uncertainty`` (a dict), or None when ``u`` is not known."""
    value = uncertainty
    path = _UNCERTAINTY_PATHS[check_name]
    for key in path:
        value = value.get(key) if isinstance(value, dict) else None
    if value is None:
        return None
    if spec_number(value) is None or value < 0:
        raise ValueError(f"hole {index}: uncertainty.{'.'.join(path)} must be a finite number >= 0, "
                         f"got {_shown(value)}")
    return coverage_factor * spec_number(value)


def _unit(vector):
    # Scaled first: the length of (1e308, 1e308, 0) overflows, and v / inf made it (0, 0, 0).
    largest = max(abs(v) for v in vector)
    scaled = [v / largest for v in vector]
    length = math.hypot(*scaled)
    return tuple(v / length for v in scaled)


def _line_angle_deg(a, b) -> float:
    """Angle between the lines of unit vectors ``a`` and ``b`` in [0, 90] degrees."""
    # atan2 of |cross| and |dot| stays accurate near 0 and 90 degrees, where acos and asin do not.
    cross = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    return math.degrees(math.atan2(math.hypot(*cross), abs(sum(x * y for x, y in zip(a, b)))))
