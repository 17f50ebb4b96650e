"""The click parameter types of the command line: strict numbers (:class:`FloatTuple`, :class:`Decimal`,
:class:`ToleranceBand`), ``--columns`` (:class:`Columns`), warning codes (:class:`WarningCodes`),
``--name`` ties (:class:`HoleTie`) and CSV fields (:class:`CsvFields`).

Nothing heavy is imported at module level: ``holecli --help`` builds the options that use them.
"""

from __future__ import annotations

import math

import click

from holecli.vocabulary import DOUBT_CODES, NOTE_CODES, UNIT_MISMATCH, WARNING_CODES


class FloatTuple(click.ParamType):
    """Comma-separated numbers, e.g. ``0,0,1`` (spaces allowed)."""

    def __init__(self, count, names):
        self.count = count
        self.name = names

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        from holecli.io.decimal_text import parse_decimal

        parts = [part.strip() for part in str(value).split(",")]
        try:
            numbers = tuple(parse_decimal(part) for part in parts)
        except ValueError:
            self.fail(f"expected {self.count} comma-separated numbers ({self.name}), got {value!r}", param, ctx)
        if len(numbers) != self.count:  # (parse_decimal refuses infinities)
            self.fail(f"expected {self.count} comma-separated finite numbers ({self.name}), got {value!r}",
                      param, ctx)
        return numbers


class Decimal(click.FloatRange):
    """A plain ASCII decimal number, optionally within a range (click's FloatRange, without the
    leniency of ``float``: no ``1_0``, no non-ASCII digits, no ``inf`` or ``nan``).

    ``hint``, when given, is added to the message for text that is not a number (``"give its
    tolerance with --countersink-angle-tolerance"`` for ``--countersink-angle "100 +/- 1"``)."""

    name = "decimal"

    def __init__(self, *args, hint=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.hint = hint

    def convert(self, value, param, ctx):
        from holecli.io.decimal_text import is_decimal

        if isinstance(value, str) and not is_decimal(value.strip()):
            self.fail(f"{value!r} is not a plain decimal number" + (f" ({self.hint})" if self.hint else ""),
                      param, ctx)
        number = super().convert(value.strip() if isinstance(value, str) else value, param, ctx)
        if isinstance(number, float) and not math.isfinite(number):  # "1e400": a decimal, but no float holds it
            self.fail(f"{value!r} is too large", param, ctx)
        return number


class ToleranceBand(click.ParamType):
    """A tolerance: ``T`` (symmetric) or ``+U/-L`` (signed upper/lower deviation), see
    :func:`holecli.tolerance.parse_band`."""

    name = "T|+U/-L"

    def convert(self, value, param, ctx):
        from holecli.errors import SpecError
        from holecli.tolerance import Band, parse_band

        if isinstance(value, Band):
            return value
        try:
            return parse_band(value)
        except SpecError as error:
            self.fail(str(error), param, ctx)


class Columns(click.ParamType):
    """``--columns X,Y,Z``: three header names or 0-based indices (:func:`holecli.io.text.parse_columns`)."""

    name = "X,Y,Z"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        from holecli.io.text import parse_columns

        try:
            return parse_columns(value)
        except ValueError as error:
            self.fail(str(error), param, ctx)


class WarningCodes(click.ParamType):
    """``--fail-on-warning``'s value: ``any`` (every warning), or comma-separated warning codes
    (docs/reference/warnings.md), ``doubts`` standing for every warning code
    (:data:`holecli.vocabulary.DOUBT_CODES` and :data:`holecli.vocabulary.WARNING_CODES`: since schema 2.2
    every warning is a doubt).

    A note code (:data:`holecli.vocabulary.NOTE_CODES`: why a value is null) is refused: notes
    never fail a run, and a code that would silently select nothing must not pass for a check. A value
    that must be measured is checked with a tolerance instead (a value not measured fails it)."""

    name = "CODE[,CODE...]|doubts|any"

    def convert(self, value, param, ctx):
        if isinstance(value, frozenset) or value is None:
            return value
        known = [*WARNING_CODES, *DOUBT_CODES, UNIT_MISMATCH]
        codes = frozenset(part.strip() for part in str(value).split(",") if part.strip())
        if codes == {"any"}:
            return codes
        if "doubts" in codes:
            codes = (codes - {"doubts"}) | frozenset(known)
        notes = sorted(codes & set(NOTE_CODES))
        if notes:
            self.fail(f"{', '.join(notes)}: a note (why a value is null), not a warning: --fail-on-warning acts "
                      f"on warnings only (a result that may be wrong). To require the value, check it with a "
                      f"tolerance option or --spec: a check of a value not measured fails (exit 5)", param, ctx)
        unknown = sorted(codes - set(known))
        if not codes or unknown:
            self.fail(f"{', '.join(unknown) or repr(value)}: not a warning code (known: any, doubts, "
                      f"{', '.join(known)})", param, ctx)
        return codes


class HoleTie(click.ParamType):
    """``--name SCAN=HOLE`` of ``detect`` and ``batch`` (``(SCAN, HOLE)``); a plain ``HOLE`` (``(None,
    HOLE)``: detect's one scan) when ``plain`` is allowed."""

    name = "SCAN=HOLE"

    def __init__(self, plain=False):
        self.plain = plain

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        scan, sep, hole = str(value).rpartition("=")
        if sep and scan and hole:
            return scan, hole
        if not sep and hole and self.plain:
            return None, hole
        expected = "SCAN=HOLE or HOLE" if self.plain else "SCAN=HOLE"
        self.fail(f"{value!r}: expected {expected} (a scan as given, its file name or stem; a hole name of "
                  "the spec)", param, ctx)


class CsvFields(click.ParamType):
    """``--fields``'s value: comma-separated CSV column names (:func:`holecli.report.csv_fields`), kept in
    the order given. A name that is not a column is refused with the list of the valid ones.

    Parameters
    ----------
    batch : bool
        Whether the columns are ``holecli batch``'s (:data:`holecli.report.BATCH_CSV_COLUMNS`, with
        ``error`` and ``path``) rather than ``detect``'s.
    """

    name = "FIELD[,FIELD...]"

    def __init__(self, batch=False):
        self.batch = batch

    def convert(self, value, param, ctx):
        if isinstance(value, tuple) or value is None:
            return value
        from holecli.report import BATCH_CSV_COLUMNS, CSV_COLUMNS, csv_fields

        try:
            return csv_fields(str(value), BATCH_CSV_COLUMNS if self.batch else CSV_COLUMNS)
        except ValueError as error:
            self.fail(str(error), param, ctx)
