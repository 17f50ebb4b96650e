"""The words a record, the command line and the readers share, defined once.

Only the standard library is imported here: the command line builds its options (click choices,
help texts) from these without importing numpy or the readers, and the core checks its arguments
against the very same tuples, so no copy has to be kept equal by a test.
"""

from __future__ import annotations

from holecli.io.formats import INPUT_EXTENSIONS, INPUT_FORMATS

__all__ = ["DECISION_RULES", "INPUT_EXTENSIONS", "INPUT_FORMATS"]

# INPUT_EXTENSIONS (what holecli.io.read_cloud reads, by extension) and INPUT_FORMATS (the formats by
# name: ``input_format``, ``--input-format``) are derived from the table of formats,
# holecli.io.formats.FORMATS, which imports only the standard library too.
# How a tolerance check is decided (ISO 14253-1): by the value alone, or by the value +- its
# expanded uncertainty (holecli.tolerance, ``--decision-rule``).
DECISION_RULES = ("simple", "guarded")
