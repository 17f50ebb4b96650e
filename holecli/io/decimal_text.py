"""Numbers written as text (spec files, command-line options): plain ASCII decimals only.

Python's ``float`` also reads ``"1_0"`` as 10, ``"٣"`` (an Arabic-Indic digit) as 3, ``" 3 "``,
``"inf"`` and ``"nan"``: leniency that turns a typo on a drawing into a wrong tolerance. A quality
record needs the number the operator meant, or a refusal.
"""

from __future__ import annotations

import re

__all__ = ["DECIMAL", "is_decimal", "parse_decimal"]

# An optional sign, ASCII digits with at most one decimal point, an optional exponent.
DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def is_decimal(text) -> bool:
    """Whether ``text`` is a plain ASCII decimal number (no surrounding space).

    Parameters
    ----------
    text : object
        Anything; only a ``str`` can be a decimal.

    Returns
    -------
    bool
    """
    return isinstance(text, str) and DECIMAL.fullmatch(text) is not None


def parse_decimal(text) -> float:
    """The value of the plain ASCII decimal ``text``.

    Parameters
    ----------
    text : str

    Returns
    -------
    float
        Finite.

    Raises
    ------
    ValueError
        When ``text`` is anything else (underscores, non-ASCII digits, spaces, ``inf``, ``nan``,
        hexadecimal) or overflows to infinity (``1e999``).
    """
    if not is_decimal(text):
        raise ValueError(f"{text!r} is not a plain decimal number")
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise ValueError(f"{text!r} is too large")
    return value
