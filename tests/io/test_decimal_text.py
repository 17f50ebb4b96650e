"""Tests of holecli.io.decimal_text: plain ASCII decimals only (issue 8, item 16)."""

import pytest

from holecli.io.decimal_text import is_decimal, parse_decimal


@pytest.mark.parametrize("text, value", [
    ("3", 3.0), ("-0", 0.0), ("+0.036", 0.036), (".5", 0.5), ("5.", 5.0), ("1e-3", 0.001), ("2.5E+2", 250.0),
])
def test_plain_decimals(text, value):
    assert is_decimal(text)
    assert parse_decimal(text) == value


@pytest.mark.parametrize("text", [
    "1_0", "٣", "３", " 3", "3 ", "", "+", ".", "e5", "1e", "0x10", "inf", "-inf", "nan", "NaN", "Infinity",
    "1,5", "1.2.3", "--1", "1e999",
])
def test_everything_else_is_refused(text):
    with pytest.raises(ValueError):
        parse_decimal(text)


def test_python_float_would_take_some_of_them():
    # the reason the module exists: each of these is a number to float()
    for text in ("1_0", "٣", " 3", "inf", "nan"):
        float(text)
        assert not is_decimal(text)
