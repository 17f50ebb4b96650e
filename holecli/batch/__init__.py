"""Measure many scans: find the files, measure them in worker processes, stream and resume the records.

The command line's ``holecli batch`` is a thin layer over this module:

* :func:`find_scans` turns files and folders into a sorted list of point-cloud files;
* :func:`measure_record` is the record of one file (the ``detect`` record, with the tolerance
  verdicts of a spec, or ``{"file", "error"}``);
* :func:`measure_all` runs it in a pool of worker processes and yields each record as its file
  finishes;
* :class:`RecordWriter` writes each record as JSON Lines or CSV with one write and a flush, so that an
  interrupted run leaves only whole lines;
* :class:`BatchOutput` holds the output file locked for the run and, to resume, reads what an
  interrupted run wrote (cutting off a partial last line); :func:`files_to_do` leaves out the files
  already there, and :class:`Tally` (:mod:`holecli.tally`) counts records for the summary and the exit
  code.

One module per idea: :mod:`~holecli.batch.discover` (finding the files), :mod:`~holecli.batch.record`
(one file's record), :mod:`~holecli.batch.pool` (the worker processes) and :mod:`~holecli.batch.output`
(writing and resuming); the counts are :mod:`holecli.tally`'s, which every command's exit code uses.
Nothing here prints or exits, and nothing imports click.
"""

from holecli.batch.discover import default_jobs, find_scans, unlistable_message
from holecli.batch.output import (FORMATS, RESUMED_OPTIONS, BatchOutput, OutputBusyError, OutputNotEmptyError,
                                  RecordWriter, ResumeError, ResumeOptionsError, differing_options, files_to_do,
                                  provenance_cells, resume_options_message)
from holecli.batch.pool import DEFAULT_FILE_TIMEOUT, PARENT_ONLY_DESCRIPTORS, measure_all, timeout_message
from holecli.batch.record import FileTimeout, error_record, internal_error_message, measure_record, plot_files
from holecli.inspection import scan_stem
from holecli.measure import failure_message, resolved_path
from holecli.tally import FileSummary, Tally

__all__ = ["DEFAULT_FILE_TIMEOUT", "FORMATS", "BatchOutput", "FileSummary", "FileTimeout", "OutputBusyError",
           "RecordWriter", "ResumeError", "ResumeOptionsError", "Tally", "default_jobs", "error_record",
           "failure_message", "files_to_do", "find_scans", "internal_error_message", "measure_all", "measure_record",
           "plot_files", "resolved_path", "scan_stem", "timeout_message", "unlistable_message"]
