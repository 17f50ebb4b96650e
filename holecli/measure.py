"""One road from a scan to its record: read, detect, express in units, check against a spec, draw.

:func:`measure_scan` is what ``holecli detect``, ``holecli batch`` (each file), ``holecli plot`` and
``holecli register`` (each scan) do with a scan before they print, write or fit anything: read the
cloud (any format, columns, unit), find its holes (:func:`holecli.pipeline.detect_file`), make the
record (:meth:`holecli.Detection.to_dict`) in the unit asked for (:class:`holecli.units.UnitChoice`),
and check it against tolerances (a :class:`holecli.tolerance.Spec`, or an
:class:`holecli.inspection.Inspection` with a registration and name ties). It returns a
:class:`Measurement`, which also draws the picture (:meth:`Measurement.png`) when asked to keep the
points. Nothing here prints, exits or imports click.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Optional

from holecli.errors import HoleCliError, LoadError

__all__ = ["MeasureError", "Measurement", "failure_message", "measure_scan", "resolved_path"]


class MeasureError(HoleCliError):
    """A scan that cannot be measured into a record; the message is one line and names the scan.

    Attributes
    ----------
    stage : {"read", "units", "check"}
        Where it failed: reading or measuring the cloud (the cause is a :class:`holecli.LoadError`
        or :class:`holecli.PointsError`), expressing the record in the output unit (an output unit
        without the file's), or checking it (:class:`holecli.inspection.InspectionError`: a scan tied
        to a hole by name holds several holes). The original exception is the ``__cause__``.
    """

    def __init__(self, message, stage):
        super().__init__(message)
        self.stage = stage


def failure_message(path, error) -> str:
    """The one-line message of ``error`` raised while measuring ``path`` (what ``detect`` prints after
    ``Error: ``).

    Parameters
    ----------
    path : str or os.PathLike
    error : Exception
        A :class:`holecli.errors.LoadError` already names its file; any other is prefixed with it.

    Returns
    -------
    str
        One line.
    """
    message = str(error) if isinstance(error, LoadError) else f"{path}: {error}"
    return " ".join(message.splitlines())


def resolved_path(path) -> str:
    """The absolute path of ``path`` with every symbolic link resolved: what ``--resume`` matches
    files on, wherever the batch is run from.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
    """
    return os.path.realpath(os.fspath(path))


@dataclass(frozen=True, eq=False)
class Measurement:
    """What :func:`measure_scan` made of a scan.

    Attributes
    ----------
    detection : holecli.Detection
        The holes found, in the file's unit.
    record : dict
        The record the command line prints: ``detection.to_dict()`` in the output unit, checked
        (``verdict``, each hole's ``in_tolerance``, ...) when a spec was given.
    points : (n, 3) float ndarray or None
        The cloud's points, kept when ``plot`` was asked for (:meth:`png` needs them).
    spec : holecli.tolerance.Spec or None
        The spec the record was checked against, in the measuring frame (an inspection's mapped by its
        registration); None without a spec.
    file_units : {"mm", "m", "in"} or None
        The unit the file's coordinates were taken in (``units.file``), what the picture is drawn in.
    """

    detection: Any
    record: dict
    points: Optional[Any] = None
    spec: Optional[Any] = None
    file_units: Optional[str] = None

    def png(self, max_panels=None, dpi=None, unit=None, *, checked=True):
        """The picture of the holes as PNG bytes (:func:`holecli.plot.figure`, matplotlib).

        Parameters
        ----------
        max_panels : int, optional
            Draw the first holes only.
        dpi : int, optional
            As for :func:`holecli.plot.png_bytes`.
        unit : {"mm", "m", "in"}, optional
            The unit of the file's coordinates (default :attr:`file_units`).
        checked : bool
            Draw the verdict, each check's nominal and zone, when the record was checked.

        Returns
        -------
        bytes

        Raises
        ------
        ValueError
            When the points were not kept (``measure_scan(..., plot=False)``).
        ImportError
            When matplotlib (the extra ``plot``) is not installed.
        """
        if self.points is None:
            raise ValueError("the points were not kept: measure the scan with plot=True to draw it")
        from holecli import plot

        verdicts = self.record["holes"] if checked and self.spec is not None else None
        fig = plot.figure(self.detection, self.points, max_panels=max_panels,
                          unit=self.file_units if unit is None else unit, checked=verdicts,
                          checked_unit=self.record.get("units"))
        return plot.png_bytes(fig, dpi=dpi)


def measure_scan(source, *, read=None, scan=None, input_format=None, columns=None, units=None, spec=None,
                 explain=False, plot=False, resolve_path=False, name=None, **options) -> Measurement:
    """Measure one scan into its record: read, detect, express in units, check, keep what a picture needs.

    Parameters
    ----------
    source : str or os.PathLike
        The point-cloud file (.ply, .pcd, .csv, .txt, .xyz, .e57, .las, .laz); with ``read``, the
        name a spec's name ties match (``-`` for standard input).
    read : callable, optional
        Returns the :class:`holecli.io.Cloud` instead of reading ``source`` (a stream, standard input).
    scan : int, optional
        The scan of an E57 file (default: every scan, merged).
    input_format : str, optional
        Read the file in this format, whatever its extension.
    columns : sequence of 3 (str or int), optional
        The x, y, z columns of a text table.
    units : holecli.units.UnitChoice, optional
        The file's unit and the record's (default: the file's as its format declares it); tolerances
        are in the record's unit.
    spec : holecli.tolerance.Spec or holecli.inspection.Inspection, optional
        Check the record's holes against it (:func:`holecli.inspection.check_record`).
    explain : bool
        Also give the record ``rejected``: the candidates that are not holes.
    plot : bool
        Keep the points, so that :meth:`Measurement.png` can draw them.
    resolve_path : bool
        Also give the record ``path``, the file's :func:`resolved_path` (as ``holecli batch`` does).
    name : str, optional
        What messages call the scan (default: ``source``, a path).
    **options
        Keyword arguments of :func:`holecli.detect`: ``method``, ``view_dir``, ``min_diameter``,
        ``max_holes``, ``full_only``, ``gauge_depth``, ``settings``, ``rng``, ``progress``.

    Returns
    -------
    Measurement

    Raises
    ------
    MeasureError
        When the scan cannot be read or measured, its record not expressed in the output unit, or
        not checked (see :attr:`MeasureError.stage`).

    See Also
    --------
    holecli.detect_file : The detection alone.

    Examples
    --------
    The paper's Table I scene, a 3 mm hole, checked against +0.036/-0 (run from the repository's root):

    >>> from holecli import measure_scan
    >>> from holecli.tolerance import nominal_spec
    >>> spec = nominal_spec(diameter=3.0, tolerance="+0.036/-0")
    >>> measurement = measure_scan("sample_clouds/table1.ply", spec=spec)
    >>> record = measurement.record
    >>> record["file"], len(record["holes"]), f"{record['holes'][0]['diameter']:.2f}"
    ('sample_clouds/table1.ply', 1, '3.00')
    >>> sorted(key for key in record["verdict"] if key.endswith("tolerance"))
    ['in_tolerance', 'out_of_tolerance']
    >>> measure_scan("sample_clouds/missing.ply")
    Traceback (most recent call last):
        ...
    holecli.measure.MeasureError: sample_clouds/missing.ply: file not found
    """
    from holecli import pipeline
    from holecli.units import UnitChoice

    shown = name if name is not None else source
    reading = {key: value for key, value in (("input_format", input_format), ("columns", columns))
               if value is not None}
    try:
        if read is not None or plot:
            if read is None:
                def read():
                    return pipeline.read_cloud(source, scan=scan, input_format=input_format, columns=columns)
            detection, cloud = pipeline.read_and_detect(read, scan=scan, input_format=input_format, columns=columns,
                                                        **options)
        else:  # (detect_file: the one sequence of a file, as the library's users call it)
            detection, cloud = pipeline.detect_file(source, **({} if scan is None else {"scan": scan}), **reading,
                                                    **options), None
    except HoleCliError as error:
        raise MeasureError(failure_message(shown, error), "read") from error
    choice = units or UnitChoice()
    try:
        record = choice.express(detection.to_dict(explain=explain), detection.units)
    except ValueError as error:  # an output unit without the file's
        raise MeasureError(f"{shown}: {error}", "units") from error
    if resolve_path:
        record["path"] = resolved_path(source)
    mapped = None
    if spec is not None:
        from holecli.inspection import Inspection, check_record

        try:
            record = check_record(record, spec, source)
        except HoleCliError as error:  # a scan tied to a hole (--name) that holds several
            raise MeasureError(str(error), "check") from error
        mapped = spec.spec_for(record.get("units")) if isinstance(spec, Inspection) else spec
    return Measurement(detection=detection, record=record, points=cloud.points if plot else None, spec=mapped,
                       file_units=choice.file)
