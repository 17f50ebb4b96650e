"""The pipeline's entry points.

* :func:`detect` checks the points and options and runs the chosen method (:mod:`holecli.paper`,
  :mod:`holecli.robust`); it does no IO.
* :func:`detect_file` reads a point-cloud file (:func:`holecli.io.read_cloud`, which drops the
  non-finite rows) and runs :func:`detect` on its points: what ``holecli detect`` and every worker of
  ``holecli batch`` do with one file; :func:`detect_cloud` does the same with a cloud already read
  (``holecli detect -``: standard input, :func:`holecli.io.read_stream`).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from holecli.errors import PointsError
from holecli.io import read_cloud
from holecli.paper.method import detect_paper
from holecli.results import Detection, Options, Timing
from holecli.stages import StageClock
from holecli.threads import single_blas_thread

METHODS = ("paper", "robust")
# Fewer points than this cannot hold a plane with a hole and a rim around it.
MIN_POINTS = 20
# Beyond this magnitude squared distances overflow long before any scan is that large (1e12 mm is a
# million kilometres).
MAX_COORDINATE = 1e12


def validate_points(points):
    """``points`` as a C-contiguous (n, 3) float64 array the pipeline can use.

    Parameters
    ----------
    points : array_like
        Any (n, 3) numeric array.

    Returns
    -------
    (n, 3) float64 ndarray
        C-contiguous; ``points`` itself when it already is.

    Raises
    ------
    PointsError
        Not (n, 3), not numeric, not finite, beyond ``MAX_COORDINATE`` or fewer than ``MIN_POINTS``
        rows.
    """
    array = np.asarray(points)
    if array.ndim != 2 or array.shape[1] != 3:
        raise PointsError(f"points must be an (n, 3) array, got shape {array.shape}")
    try:
        array = np.ascontiguousarray(array, dtype=np.float64)
    except (TypeError, ValueError):
        raise PointsError(f"points must be numeric, got dtype {np.asarray(points).dtype}") from None
    # One pass each for the minimum and the maximum: NaN propagates into both, inf into one.
    low, high = (float(array.min()), float(array.max())) if array.size else (0.0, 0.0)
    if not (np.isfinite(low) and np.isfinite(high)):
        raise PointsError("points must be finite (drop NaN and inf rows first)")
    if max(-low, high) > MAX_COORDINATE:
        raise PointsError(f"coordinates up to {max(-low, high):.3g} are beyond the supported "
                          f"range (|x| <= {MAX_COORDINATE:.0e} file units)")
    if len(array) < MIN_POINTS:
        raise PointsError(f"too few points: {len(array)} (the pipeline needs at least {MIN_POINTS})")
    return array


def _check_options(view_dir, min_diameter, max_holes, gauge_depth=None):
    if view_dir is not None:
        direction = np.asarray(view_dir, dtype=np.float64).reshape(-1)
        if direction.shape != (3,) or not np.all(np.isfinite(direction)) or not np.any(direction):
            raise PointsError(f"view_dir must be a finite, non-zero 3-vector, got {view_dir!r}")
        view_dir = direction
    if min_diameter is not None and not (np.isfinite(min_diameter) and min_diameter >= 0):
        raise PointsError(f"min_diameter must be a finite length >= 0, got {min_diameter!r}")
    if max_holes is not None and (int(max_holes) != max_holes or max_holes < 1):
        raise PointsError(f"max_holes must be a whole number >= 1, got {max_holes!r}")
    if gauge_depth is not None and not (np.isfinite(gauge_depth) and gauge_depth >= 0):
        raise PointsError(f"gauge_depth must be a finite depth >= 0, got {gauge_depth!r}")
    return view_dir


def _settings_changed(settings, defaults):
    """The (name, value) pairs of ``settings`` that differ from ``defaults``, by their flat names in the
    order of :meth:`holecli.settings.RobustSettings.flat_items`."""
    return tuple((name, value) for name, value in settings.flat_items() if value != getattr(defaults, name))


def _plain(value):
    """A number or a tuple of numbers as plain Python floats (for the record's ``options``)."""
    if value is None:
        return None
    if np.ndim(value):
        return tuple(float(v) for v in np.asarray(value, dtype=np.float64).reshape(-1))
    return float(value)


def detect(points, *, method="robust", view_dir=None, min_diameter=None, max_holes=None, full_only=False,
           gauge_depth=None, settings=None, rng=0, progress=None):
    """Find the holes in a scan of a nearly flat surface.

    Parameters
    ----------
    points : (n, 3) float
        Finite points in file units (at least ``MIN_POINTS``).
    method : {"robust", "paper"}
        ``"robust"`` (default) finds every hole, robust to noise, outliers, bore-wall and
        countersink points and ragged borders, with the sampling bias removed. ``"paper"`` reproduces
        the published method (one hole, clean data) and takes none of the options below.
    view_dir : (3,) float, optional
        The sensor's viewing direction, from the sensor toward the part (``(0, 0, -1)``: a sensor
        above). It tells which side of the surface the sensor saw, which face of a cloud holding
        several is the surface, and which faces lie hidden behind it (left out). When the sensor sees
        nothing behind the surface, the surface's points slide along it onto the plane instead of
        being projected orthogonally, which keeps range noise out of the in-plane coordinates.
    min_diameter : float, optional
        Smallest diameter reported, file units; by default six times the sampling's gap scale.
    max_holes : int, optional
        Report at most this many holes (the largest).
    full_only : bool
        Leave out holes cut by the border of the scan.
    gauge_depth : float, optional
        Depth below the surface at which each countersink's diameter is given
        (``countersink.diameter_at_depth``), file units.
    settings : holecli.settings.RobustSettings, optional
        Tunables of the robust method.
    rng : int or numpy.random.Generator
        Seed of the plane's RANSAC hypotheses (results do not depend on it beyond round-off).
    progress : callable, optional
        Called with the name of each stage as it starts (``validate``, ``imports``, then ``plane``, ``frame``,
        ``sampling``, ``grid``, ``candidates``, ``shape`` or ``paper``): what the command line's
        status line shows. It must be cheap and must not raise.

    Returns
    -------
    Detection
        The holes found (possibly none), the fitted plane and the point count, the measured
        ``scales``, the ``options`` it ran with, the number of ``candidates`` examined and the
        ``timing`` of every stage. ``file``, ``dropped_points`` and ``timing.read_ms`` are left for
        the caller that read the file to fill in; tolerances are not the pipeline's
        (:func:`holecli.tolerance.check` adds them to the record).

    Raises
    ------
    PointsError
        When ``points`` is not a usable (n, 3) array, ``method`` is unknown or an option is invalid.

    See Also
    --------
    detect_file : Read a point-cloud file and run ``detect`` on its points.

    Examples
    --------
    The paper's Table I scene, a 3 mm hole (run from the repository's root):

    >>> from holecli import detect, load_points
    >>> detection = detect(load_points("sample_clouds/table1.ply"))
    >>> len(detection.holes), detection.points, detection.method
    (1, 7062, 'robust')
    >>> print(f"{detection.holes[0].diameter:.2f}")
    3.00
    >>> print(detection.file)
    None

    The published method, on the same points:

    >>> print(f"{detect(load_points('sample_clouds/table1.ply'), method='paper').holes[0].diameter:.1f}")
    3.0
    """
    if method not in METHODS:
        raise PointsError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    started = time.perf_counter()
    clock = StageClock(progress)
    clock.start("validate")
    points = validate_points(points)
    view_dir = _check_options(view_dir, min_diameter, max_holes, gauge_depth)
    clock.start("imports")  # the method's modules: paid by the first detection of a process only
    if method == "robust":
        # Before the limit: importing it loads scipy's own BLAS, which the limit must see.
        from holecli.robust.method import detect_robust
        from holecli.settings import DEFAULT_SETTINGS
    with single_blas_thread():
        if method == "paper":
            if (view_dir is not None or min_diameter is not None or max_holes is not None or full_only
                    or gauge_depth is not None):
                raise PointsError("the paper method takes no options (view_dir, min_diameter, max_holes, full_only, "
                                  "gauge_depth)")
            clock.start("paper")
            plane, holes, scales = detect_paper(points)
            rejected, candidates, stages = (), 1, clock.stop()
            used = Options(method="paper", rng=None, settings=None)
        else:
            settings = settings or DEFAULT_SETTINGS
            validated = clock.stop()
            result = detect_robust(points, view_dir=view_dir, min_diameter=min_diameter, max_holes=max_holes,
                                   full_only=full_only, gauge_depth=gauge_depth, settings=settings, rng=rng,
                                   progress=progress)
            plane, holes, rejected, scales = result.plane, result.holes, result.rejected, result.scales
            candidates, stages = result.candidates, validated + result.stages
            used = Options(method="robust", view_dir=_plain(view_dir), min_diameter=_plain(min_diameter),
                           max_holes=None if max_holes is None else int(max_holes), full_only=bool(full_only),
                           gauge_depth=_plain(gauge_depth),
                           rng=int(rng) if isinstance(rng, (int, np.integer)) else None,
                           settings=_settings_changed(settings, DEFAULT_SETTINGS))
    elapsed_ms = (time.perf_counter() - started) * 1000.0
    return Detection(holes=holes, plane=plane, points=len(points), method=method,
                     timing=Timing(elapsed_ms=elapsed_ms, stages=stages), rejected=rejected, scales=scales,
                     options=used, candidates=candidates)


def detect_file(path, scan=None, *, input_format=None, columns=None, **options) -> Detection:
    """Read a point-cloud file and find the holes in it.

    The one sequence of ``holecli detect`` and of every file of ``holecli batch``: read the file with
    :func:`holecli.io.read_cloud` (which drops the rows with a NaN or infinite coordinate), run
    :func:`detect` on its finite points, and fill in what only the file knows.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply``, ``.pcd``, ``.csv``, ``.txt``, ``.xyz``, ``.e57``, ``.las`` or ``.laz`` file; its
        extension (any case) selects the format, unless ``input_format`` is given.
    scan : int, optional
        The scan of an E57 file to measure, from 0; by default every scan, merged (see
        :func:`holecli.io.read_cloud`).
    input_format : {"ply", "pcd", "csv", "txt", "xyz", "e57", "las", "laz"}, optional
        Read the file in this format, whatever its extension (``scan.asc`` as ``"xyz"``).
    columns : sequence of 3 (str or int), optional
        The x, y, z columns of a text table, header names or 0-based indices (``--columns``, see
        :func:`holecli.io.read_cloud`).
    **options
        Keyword arguments of :func:`detect`: ``method``, ``view_dir``, ``min_diameter``,
        ``max_holes``, ``full_only``, ``gauge_depth``, ``settings``, ``rng``, ``progress``.

    Returns
    -------
    Detection
        What :func:`detect` returns, with ``file`` (``str(path)``), ``dropped_points`` (the rows
        dropped as non-finite or flagged invalid), ``units`` (what the format declares) and
        ``timing.read_ms`` (the time to read it) filled in. ``timing.elapsed_ms`` is the time of the
        detection, as :func:`detect` measures it (reading the file is not counted).

    Raises
    ------
    LoadError
        When the file cannot be read (missing, unsupported extension, malformed, no finite point,
        no scan ``scan``, the optional extra of its format not installed).
    PointsError
        When its points are too few for the pipeline, an option is invalid or ``method`` is unknown
        (see :func:`detect`).
    TypeError
        When an option is not a keyword argument of :func:`detect`.

    See Also
    --------
    detect : The same on points already in memory.

    Examples
    --------
    The paper's Table I scene, a 3 mm hole (run from the repository's root):

    >>> from holecli import detect_file
    >>> detection = detect_file("sample_clouds/table1.ply")
    >>> detection.file, detection.points, detection.dropped_points
    ('sample_clouds/table1.ply', 7062, 0)
    >>> hole = detection.holes[0]
    >>> print(f"{hole.diameter:.2f}", hole.partial)
    3.00 False
    >>> detect_file("sample_clouds/table1.ply", method="paper").method
    'paper'

    A file that cannot be read raises :class:`holecli.LoadError`:

    >>> detect_file("sample_clouds/missing.ply")
    Traceback (most recent call last):
        ...
    holecli.errors.LoadError: sample_clouds/missing.ply: file not found
    """
    detection, _ = read_and_detect(lambda: read_cloud(path, scan=scan, input_format=input_format, columns=columns),
                                   scan=scan, input_format=input_format, columns=columns, **options)
    return detection


def read_and_detect(read, *, scan=None, input_format=None, columns=None, **options):
    """Read a cloud with ``read()``, timed, and find its holes (:func:`detect_cloud`).

    The sequence :func:`detect_file` runs on a file, for a caller that reads the cloud otherwise
    (standard input) or needs its points too (a picture of the fit).

    Parameters
    ----------
    read : callable
        Returns the :class:`holecli.io.Cloud` (raising :class:`holecli.errors.LoadError`).
    scan, input_format, columns : optional
        How it is read, for the record's ``options`` (see :func:`detect_cloud`).
    **options
        Keyword arguments of :func:`detect`.

    Returns
    -------
    detection : Detection
        :func:`detect_cloud`'s, with ``timing.read_ms`` (the time ``read`` took).
    cloud : holecli.io.Cloud
        What ``read`` returned.
    """
    started = time.perf_counter()
    cloud = read()
    read_ms = (time.perf_counter() - started) * 1000.0
    detection = detect_cloud(cloud, scan=scan, input_format=input_format, columns=columns, **options)
    return replace(detection, timing=replace(detection.timing, read_ms=read_ms)), cloud


def detect_cloud(cloud, *, scan=None, input_format=None, columns=None, **options) -> Detection:
    """Find the holes in a cloud already read (:func:`holecli.io.read_cloud`,
    :func:`holecli.io.read_stream`).

    Parameters
    ----------
    cloud : holecli.io.Cloud
        Its points, dropped rows, file name and declared unit.
    scan, input_format, columns : optional
        How it was read (``scan`` of an E57 file, the format asked for, the columns asked for), for
        the record's ``options``.
    **options
        Keyword arguments of :func:`detect`.

    Returns
    -------
    Detection
        What :func:`detect` returns, with ``file`` (``cloud.path``), ``dropped_points``
        (``cloud.dropped``), ``units`` (``cloud.units``) and ``input_columns`` (``cloud.columns``)
        filled in.

    Raises
    ------
    PointsError, TypeError
        As :func:`detect_file`.
    """
    detection = detect(cloud.points, **options)
    return replace(detection, file=str(cloud.path), dropped_points=cloud.dropped, units=cloud.units,
                   input_columns=cloud.columns,
                   options=replace(detection.options, scan=scan, input_format=input_format,
                                   columns=None if columns is None else tuple(columns)))
