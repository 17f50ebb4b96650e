"""The batch summary's words: parts (files) rejected and holes out of tolerance are counted apart."""

from holecli.batch import FileSummary, Tally
from holecli.cli.progress import batch_summary


def _tally(*summaries):
    tally = Tally()
    for summary in summaries:
        tally.add(summary)
    return tally


def test_summary_counts_rejected_parts_and_holes_out_of_tolerance_apart():
    tally = _tally(FileSummary("a.ply", False, holes=4, out_of_tolerance=2),  # one part, two bad holes
                   FileSummary("b.ply", False, holes=3, missing=1),  # one part, a hole missing
                   FileSummary("c.ply", False, holes=4),  # a good part
                   FileSummary("d.ply", True))  # not measured: failed, not rejected
    text = batch_summary(tally, 1.0, checked=True, earlier=0, output=None)
    assert "4 files: 3 measured, 1 failed; 11 holes found" in text
    assert "parts rejected: 2 of 3; holes out of tolerance: 2, nominal holes missing: 1" in text


def test_summary_counts_undecided_parts_apart_from_rejected_ones():
    tally = _tally(FileSummary("a.ply", False, holes=2, undecided=2),
                   FileSummary("b.ply", False, holes=2, out_of_tolerance=1, undecided=1))
    text = batch_summary(tally, 1.0, checked=True, earlier=0, output=None)
    assert "parts rejected: 1 of 2, undecided: 1; holes out of tolerance: 1, undecided: 3" in text


def test_summary_without_tolerances_counts_no_parts():
    text = batch_summary(_tally(FileSummary("a.ply", False, holes=2)), 1.0, checked=False, earlier=0, output=None)
    assert "tolerances not checked" in text and "parts rejected" not in text
