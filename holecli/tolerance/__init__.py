"""Tolerance verdicts: nominal holes, tolerance bands, matching of measured holes, pass or fail.

Pure functions over plain values: a :class:`Spec` (built and validated once by :func:`parse_band`,
:func:`nominal_spec` or :func:`parse_spec`) and a detection record (the dict of
:meth:`holecli.results.Detection.to_dict`) go in, a new record with the verdicts comes out
(:func:`check`). No file is opened here and nothing is printed.

Checks
------
diameter
    measured - nominal diameter within the band ``[lower, upper]`` of signed deviations
    (``+0.036/-0`` is ``lower = 0, upper = 0.036``).
position
    the distance of the measured center from the nominal center in the plane of the hole (that is,
    perpendicular to the measured hole normal) at most ``position_tolerance``. The distance along the
    normal is reported, not checked.
tilt
    the angle between the lines of the measured and the nominal normal (the sign of a normal does not
    matter) at most ``max_tilt`` degrees.
countersink_diameter, countersink_angle, countersink_depth, bore_diameter
    measured - nominal value within its band, like the diameter: the hole's ``countersink.diameter``,
    ``countersink.angle_deg`` (degrees), ``countersink.depth`` and ``bore.diameter`` against the
    nominal's ``countersink_diameter`` and ``countersink_diameter_band`` and so on (spec keys
    ``countersink_diameter`` and ``countersink_diameter_tolerance``, ...).
perpendicularity
    the hole's ``perpendicularity_deg`` (the angle between its axis and its surface normal) at most
    ``max_perpendicularity`` degrees.
countersink_gauge
    the countersink gauge reading: the countersink's diameter at the run's gauge depth
    (``countersink.diameter_at_depth``, at ``--gauge-depth`` below the surface, what a gauge whose
    stop is set to that depth reads) minus the nominal ``countersink_gauge_diameter``, within the band
    ``countersink_gauge_tolerance`` (spec keys of those names). Not measured without a gauge depth, or
    when the depth is not within the countersink.

A check whose measured value is null (a hole without a countersink, a bore wall not seen, no axis) is
*not measured*: it fails, with ``<check>_not_measured`` in ``failed_checks`` (``"bore_diameter_not_measured"``)
and a null deviation, so that a value the scan does not show is never taken for one in tolerance.

Decision rules (ISO 14253-1)
----------------------------
Every check of a checked hole gets an entry in the hole's ``conformance``, by check name::

    {"value": v, "lower": L or None, "upper": T, "expanded_uncertainty": U or None,
     "decision": "pass" | "fail" | "undecided", "reason": code}

``value`` is what is compared (the deviation for a band check, the in-plane distance for position,
the angle for tilt and perpendicularity; None when not measured), ``lower`` and ``upper`` the limits
of the zone (``lower`` None for the checks of a largest value), ``expanded_uncertainty`` is
``U = k * u`` with ``u`` the standard uncertainty of the measured value in the hole's ``uncertainty``
(:data:`_UNCERTAINTY_PATHS`) and ``k`` the spec's ``coverage_factor`` (None when ``u`` is not known).

simple (the default)
    the value alone decides: ``pass`` inside the zone, ``fail`` outside it; U is reported, not used.
guarded
    ``pass`` when ``[value - U, value + U]`` lies inside the zone (conformance proved), ``fail`` when
    it lies wholly outside (non-conformance proved), ``undecided`` when it straddles a limit. A check
    whose ``u`` is not known is ``undecided`` (reason ``uncertainty_unknown``): a conformance that
    cannot be proved is not proved.

A check not measured fails under either rule (reason ``not_measured``). The ``reason`` codes:
``inside``, ``outside`` (simple), ``inside_with_uncertainty``, ``outside_with_uncertainty``,
``straddles_lower``, ``straddles_upper``, ``uncertainty_unknown`` (guarded), ``not_measured``.
Every comparison allows :data:`_ROUND_OFF`, as without a decision rule.

Matching
--------
A nominal hole with a center is matched to one measured hole: every pair closer than the nominal's
``match_radius`` is a candidate, and pairs are taken greedily by increasing distance, each hole on
either side at most once. Nominal holes of a spec file have ``match_radius = diameter``; the nominal
of the command line has an unlimited one (it takes the nearest hole). A nominal without a center (the
command line's ``--nominal-diameter`` alone) applies to every measured hole. A nominal hole left
without a measured one is *missing* and fails the verdict; a measured hole left without a nominal one
is reported unchecked and does not fail it.

Where each thing happens: :mod:`holecli.tolerance.spec` (the spec's model and its validation:
:class:`Spec`, :func:`parse_spec`, :func:`nominal_spec`, :func:`parse_band`) and
:mod:`holecli.tolerance.verdicts` (the checks: :func:`check`, :func:`describe`, the unit checks).
Every name is importable from here.
"""

from __future__ import annotations

from holecli.tolerance.spec import (DECISION_RULES, DEFAULT_COVERAGE_FACTOR, Band, NominalHole, Spec, gauge_checked,
                                    load_toml, nominal_spec, parse_band, parse_spec, spec_number)
from holecli.tolerance.verdicts import (check, describe, far_from_spec, spec_in_units, uncertainty_exceeds_zone,
                                        uncertainty_zone_message, uncertainty_zone_notes, unit_scale_match)
# the notes check() gives: defined with the other record codes in holecli.vocabulary, importable here too
from holecli.vocabulary import NOT_IN_SPEC_FRAME, UNCERTAINTY_NOTE  # noqa: F401

__all__ = ["DECISION_RULES", "DEFAULT_COVERAGE_FACTOR", "Band", "NominalHole", "Spec", "check", "describe",
           "load_toml", "nominal_spec", "parse_band", "parse_spec", "spec_in_units", "spec_number", "unit_scale_match"]
