"""The counts of a command's records, the input of its exit code: :class:`FileSummary` of one record (or
of its CSV rows of ``holecli batch``) and :class:`Tally` of them all. ``holecli detect``, ``plot``,
``register`` and ``batch`` derive their exit code from a Tally (:func:`holecli.cli.exits.exit_code`);
``batch`` also its progress and summary. Only the standard library and :mod:`holecli.vocabulary` are
imported.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from holecli.vocabulary import NOTE_CODES

__all__ = ["FileSummary", "Tally"]


@dataclass(frozen=True)
class FileSummary:
    """What the summary and the exit code need from the record of one file."""

    file: str
    failed: bool
    holes: int = 0
    out_of_tolerance: int = 0
    undecided: int = 0  # holes with an undecided check and none failed (--decision-rule guarded)
    missing: int = 0
    path: str = ""  # resolved_path of the file; "" in records of holecli 0.1
    warnings: tuple = ()  # per hole, the tuple of its warning codes (never a note's, see _warning_codes)

    @classmethod
    def of_record(cls, record):
        path = record.get("path") if isinstance(record.get("path"), str) else ""
        if "error" in record:
            return cls(file=record["file"], failed=True, path=path)
        verdict = record.get("verdict") or {}
        return cls(file=record["file"], failed=False, holes=len(record.get("holes", ())),
                   out_of_tolerance=verdict.get("out_of_tolerance", 0), undecided=verdict.get("undecided", 0),
                   missing=len(verdict.get("missing", ())),
                   path=path, warnings=tuple(_warning_codes(warning["code"] for warning in hole.get("warnings", ()))
                                             for hole in record.get("holes", ())))

    @classmethod
    def of_csv_rows(cls, file, rows):
        path = rows[0].get("path", "") if rows else ""
        if any(row["error"] for row in rows):
            return cls(file=file, failed=True, path=path)
        holes = [row for row in rows if row["hole"]]
        return cls(file=file, failed=False, holes=len(holes), path=path,
                   # a hole not in tolerance fails a check, or else has an undecided one
                   out_of_tolerance=sum(row["in_tolerance"] == "false" and not _only_undecided(row) for row in holes),
                   undecided=sum(row["in_tolerance"] == "false" and _only_undecided(row) for row in holes),
                   missing=sum(row["in_tolerance"] == "false" for row in rows if not row["hole"]),
                   warnings=tuple(_warning_codes(code for code in (row.get("warnings") or "").split(";") if code)
                                  for row in holes))


def _warning_codes(codes):
    """The warning codes among ``codes``, without the notes' (:data:`holecli.vocabulary.NOTE_CODES`),
    which records before schema 2.2 (a resumed batch's earlier ones) gave as warnings: a note never counts
    as a doubt or fails ``--fail-on-warning``."""
    return tuple(code for code in codes if code not in NOTE_CODES)


def _only_undecided(row):
    """Whether a CSV row's hole has an undecided check and no failed one."""
    return not row.get("failed_checks") and bool(row.get("undecided_checks"))


@dataclass
class Tally:
    """Counts of a batch, for its progress, summary and exit code."""

    files: int = 0
    failed: int = 0
    holes: int = 0
    without_hole: int = 0
    out_of_tolerance: int = 0
    undecided: int = 0
    missing: int = 0
    doubtful_holes: int = 0  # holes with a warning (a doubtful result; notes are not warnings)
    rejected_parts: int = 0  # files (parts) with a hole out of tolerance or a nominal hole missing
    undecided_parts: int = 0  # files with an undecided hole and none out of tolerance or missing
    warning_codes: dict = field(default_factory=dict)  # every warning code -> holes with it

    @classmethod
    def of(cls, records):
        """The counts of ``records`` (each a :class:`FileSummary` or a record), as :meth:`add` counts them."""
        tally = cls()
        for record in records:
            tally.add(record)
        return tally

    def add(self, summary):
        """Count one file (a :class:`FileSummary`, or a record)."""
        if isinstance(summary, dict):
            summary = FileSummary.of_record(summary)
        self.files += 1
        if summary.failed:
            self.failed += 1
            return
        self.holes += summary.holes
        self.without_hole += summary.holes == 0
        self.out_of_tolerance += summary.out_of_tolerance
        self.undecided += summary.undecided
        self.missing += summary.missing
        rejected = bool(summary.out_of_tolerance or summary.missing)
        self.rejected_parts += rejected
        self.undecided_parts += not rejected and bool(summary.undecided)
        for codes in summary.warnings:
            self.doubtful_holes += bool(codes)
            for code in set(codes):
                self.warning_codes[code] = self.warning_codes.get(code, 0) + 1

    @property
    def measured(self) -> int:
        return self.files - self.failed
