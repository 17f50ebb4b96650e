"""The words a record, the command line and the readers share, defined once.

Only the standard library is imported here: the command line builds its options (click choices,
help texts) from these without importing numpy or the readers, and the core checks its arguments
against the very same tuples, so no copy has to be kept equal by a test.
"""

from __future__ import annotations

from holecli.io.formats import INPUT_EXTENSIONS, INPUT_FORMATS

__all__ = ["DECISION_RULES", "DEFAULT_COVERAGE_FACTOR", "DOUBT_CODES", "ESTIMATORS", "ESTIMATOR_CONE",
           "ESTIMATOR_EMPTY_CIRCLE", "ESTIMATOR_LATTICE", "ESTIMATOR_RIM_FIT", "INPUT_EXTENSIONS", "INPUT_FORMATS",
           "LOOP_CHECKS", "NOTE_CODES", "NOT_IN_SPEC_FRAME", "REJECTION_REASONS", "UNCERTAINTY_NOTE", "UNIT_MISMATCH",
           "WARNING_CODES"]

# INPUT_EXTENSIONS (what holecli.io.read_cloud reads, by extension) and INPUT_FORMATS (the formats by
# name: ``input_format``, ``--input-format``) are derived from the table of formats,
# holecli.io.formats.FORMATS, which imports only the standard library too.
# How a tolerance check is decided (ISO 14253-1): by the value alone, or by the value +- its
# expanded uncertainty (holecli.tolerance, ``--decision-rule``).
DECISION_RULES = ("simple", "guarded")
# The default coverage factor of the expanded uncertainty (k = 2: about 95 % coverage for a normal
# distribution, the usual choice of a calibration certificate; ``--coverage-factor``).
DEFAULT_COVERAGE_FACTOR = 2.0

#: How a hole's edge was measured (``uncertainty.estimator`` of a hole), each estimator's name: a
#: countersink's cone, the brackets of a lattice, the largest empty circle of irregular sampling, and the
#: rim fit corrected by synthetic holes, which always applies. (A CAD export's edge loop says ``edge_loops``.)
ESTIMATOR_CONE = "cone"
ESTIMATOR_LATTICE = "lattice"
ESTIMATOR_EMPTY_CIRCLE = "empty_circle"
ESTIMATOR_RIM_FIT = "rim_fit"
#: The estimators' names in the order the robust method tries them (the one statement of their precedence:
#: holecli.robust.estimators.ESTIMATORS follows it).
ESTIMATORS = (ESTIMATOR_CONE, ESTIMATOR_LATTICE, ESTIMATOR_EMPTY_CIRCLE, ESTIMATOR_RIM_FIT)

#: Why a loop of a CAD export's vertices is not a hole's edge (holecli.robust.edge_loops), by check name.
LOOP_CHECKS = {
    "loop_not_round": "the vertices do not lie on one circle within the noise (a slot, a cut-out, the border)",
    "loop_not_isolated": "other surface points lie near its circle: sampled points near an edge, not the edge's vertices",
    "loop_no_face_outside": "no other point of the face lies outside its circle: nothing shows the face around it "
                            "(a round part's outline)",
    "loop_material_inside": "surface points lie inside its circle (the outline of a face around other loops)",
    "loop_boss": "points stand above the surface inside it (the foot of a boss)",
    "loop_wider_below": "a wider loop lies below it on its axis (the island of a ring groove: a hole's walls "
                        "never widen below its edge as the vertices show them)",
    "loop_pocket": "a loop of its own size lies below it on a floor of its own (no other vertex at that depth: not "
                   "the part's bottom face), shallower than any drilled hole's: a pocket or spot face",
}

#: Why a candidate void is not a hole, by the name of the check that refused it: for the record and for
#: people (holecli detect --explain; the checks are holecli.robust.acceptance's, the method's and the loops').
REJECTION_REASONS = {
    "no_rim": "no hole boundary around the void (a gap of the sampling)",
    "too_few_rim_points": "too few rim points for a circle fit",
    "no_circle_fit": "the rim points do not give a circle",
    "below_min_diameter": "smaller than the minimum diameter",
    "material_inside": "surface material fills the inside of the fitted circle (the island of a groove, not a hole)",
    "not_round": "the rim is not round (robust scatter of the radial residuals above the limit)",
    "material_in_first_circle": "surface material lies deep inside the circle first fitted to its rim "
                                "(the long sides of a slot or cut-out, not reflections inside a hole)",
    "partial_rim_arc": "a partial hole whose rim covers too little of its circle",
    "boss": "material stands above the surface inside it (a pin or boss, not a hole)",
    "pocket": "a flat floor shallower than any drilled hole's (a pocket or spot face, not a hole)",
    "duplicate": "the same hole as another candidate with more rim points",
    "partial_left_out": "a partial hole, left out by --full-only",
    "beyond_max_holes": "smaller than the holes kept by --max-holes",
    **LOOP_CHECKS,  # the loops of a CAD export's vertices (holecli.robust.edge_loops)
}

#: The doubts of a measured hole (holecli.robust.doubts): warnings from numbers the method already knows;
#: the hole is measured, but its result deserves a look.
DOUBT_CODES = {
    "few_rim_points": "few rim points for the edge circle: its center and diameter are loosely held",
    "rim_gap": "the rim points leave an arc of the circle empty (occlusion or missing data)",
    "points_inside": "surface points inside the fitted circle (reflections, debris or a film)",
    "surface_not_flat": "the surface around the hole is not flat: its local plane leaves residuals well above "
                        "the scan's noise",
    "near_border": "the hole is at the scan's border: its surroundings are not all scanned",
    "large_bias_correction": "a large sampling-bias correction of the diameter",
    "high_fit_rms": "the rim points scatter about the circle well beyond what the sampling explains",
    "blurred_edge": "the edge's points are mixed with what lies below it (a wide laser line) and the surface band "
                    "hides most of the mix: the edge lies somewhere within it, the diameter's u does not hold that",
    "bias_not_measured": "the sampling-bias correction of the diameter could not be measured (no synthetic hole "
                         "cut around it gave a rim): the diameter is the rim fit's, uncorrected, and its "
                         "uncertainty includes the correction's possible size",
    "view_dir_contradicted": "the points seen through the surface lie on the sensor's side that --view-dir gives "
                             "(--view-dir is the direction the sensor looks, from the sensor toward the part: "
                             "is its sign reversed?)",
    "edge_bore_mismatch": "the edge's diameter and the bore wall's disagree far beyond their uncertainties: an edge "
                          "break (chamfer, burr) the scan does not resolve, or an edge its sampling does not "
                          "show; the diameter may be off by that difference",
}

#: The warnings of a hole's shape (holecli.robust.hole_shape): the points below the edge contradict the
#: shape the hole was taken for, so its type (and a countersink's edge) may be wrong; the value is None.
WARNING_CODES = {
    "cone_angle_implausible": "the fitted cone's angle is outside the plausible range: no countersink values",
    "cone_not_conical": "the points taken for the countersink do not lie on one cone: no countersink values",
    "bore_not_cylindrical": "the points taken for the bore wall do not lie on one cylinder: no bore diameter",
}

#: Why a value of a hole is None (holecli.robust.hole_shape, and the edge loops'): the scan shows too
#: little for a value (or the value asked for is not on the part). Nothing given is doubtful: a note is
#: not a warning.
NOTE_CODES = {
    "bore_not_seen": "too few points on the bore wall for a cylinder fit: no bore diameter",
    "bore_short_arc": "the bore wall is seen over too little of its circumference for a diameter",
    "cone_few_points": "too few points on the countersink's cone for a fit: no countersink values",
    "cone_short_arc": "the countersink's cone is seen over too little of its circumference",
    "gauge_depth_outside_cone": "--gauge-depth is not within the countersink's depth: no diameter_at_depth",
    "axis_not_measured": "no cone, bore wall or floor shows the hole's axis: no axis or perpendicularity",
    # (given by holecli.robust.assemble to the holes of holecli.robust.edge_loops)
    "edge_loops": "the edge is a loop of a CAD export's vertices, no point inside a face: the diameter is "
                  "the least-squares circle of the polygon's sides",
}

#: The note of a hole tied to a spec hole (holecli.tolerance.check's ``tied``) that lies beyond its match
#: radius in a spec no registration mapped: the scan is in another frame, so its position and tilt are
#: not checked. (A tolerance check's note, given beside NOTE_CODES' measurement notes.)
NOT_IN_SPEC_FRAME = "not_in_spec_frame"

#: The note of a tolerance check whose expanded uncertainty leaves no value a guarded decision could
#: pass (holecli.tolerance.uncertainty_exceeds_zone).
UNCERTAINTY_NOTE = "uncertainty_exceeds_tolerance"

#: The warning of a tolerance check whose values and tolerances look like different units (holecli.units).
UNIT_MISMATCH = "unit_mismatch"
