"""holecli.quality.wording: one wording for the HTML report and the Form 3 rows."""

import pytest

from holecli.quality.lot import Characteristic
from holecli.quality.wording import REASON_WORDS, decimals, reason_words, warning_phrase, warning_sentence
from holecli.vocabulary import WARNING_CODES


def test_every_reason_a_decision_can_give_has_its_words():
    from holecli.schema import record_schema

    reasons = record_schema()["$defs"]["conformance_entry"]["properties"]["reason"]["enum"]
    assert set(reasons) | {"missing"} == set(REASON_WORDS)
    assert reason_words("something_new") == "something new"


def test_every_warning_has_a_phrase_and_a_sentence():
    for code in WARNING_CODES:
        assert warning_phrase(code) and warning_sentence(code) == WARNING_CODES[code]
    assert "chips" in warning_phrase("points_inside")


@pytest.mark.parametrize("lower, upper, expected", [(-0.05, 0.05, 4), (-1.0, 1.0, 3), (-0.005, 0.005, 5),
                                                    (None, 0.5, 4), (None, None, 4)])
def test_decimals_show_a_thousandth_of_the_zone(lower, upper, expected):
    name = "diameter" if lower is not None else "position"
    c = Characteristic(0, 0, "T1", name, "mm", 4.0, 4.0, 0.0, lower, upper, None, None, None, "pass", "inside")
    assert decimals(c) == expected
