"""holecli.quality.tables: the Form 3 wording of undecided results and of the test uncertainty ratio."""

from holecli.quality.lot import Characteristic
from holecli.quality.tables import _result_text, ratio_text, reason_text


def characteristic(name="diameter", decision="undecided", reason="straddles_upper", u=0.04, upper=0.05):
    lower = None if name == "position" else -0.05
    nominal = 0.0 if name == "position" else 4.0
    return Characteristic(0, 0, "T1", name, "mm", nominal, nominal + 0.03, 0.03, lower, upper,
                          None if lower is None else nominal + lower, nominal + upper, u, decision, reason)


def test_undecided_says_why():
    assert _result_text(characteristic(), 2.0) == "4.0300 mm (U = 0.0400, k = 2): UNDECIDED (within U of a limit)"
    unknown = characteristic(reason="uncertainty_unknown", u=None)
    assert _result_text(unknown, 2.0) == ("4.0300 mm: UNDECIDED (its uncertainty is not known, so conformance "
                                          "cannot be proved (guarded rule))")
    assert reason_text(unknown) == "its uncertainty is not known, so conformance cannot be proved (guarded rule)"


def test_a_one_sided_zone_can_decide_down_to_half_the_ratio_of_a_band():
    # position <= 0.1 with U = 0.07: TUR 0.71; a value of 0.02 + U is inside, so it can be proved in
    # tolerance (holecli.tolerance.uncertainty_exceeds_zone: only U > T cannot)
    zone = characteristic("position", u=0.07, upper=0.1)
    assert zone.test_uncertainty_ratio < 1
    assert ratio_text(zone.test_uncertainty_ratio, one_sided=True).endswith("(below 4:1); values near a limit "
                                                                            "cannot be told in from out.")
    assert "cannot decide conformance" in ratio_text(0.71)
    assert "cannot decide conformance" in ratio_text(0.45, one_sided=True)
    assert ratio_text(5.0) == ratio_text(None) == ""
