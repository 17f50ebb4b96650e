"""holecli: measure drilled holes (center, diameter, surface normal) in 3D laser scans.

Public API::

    from holecli import detect_file
    detection = detect_file("scan.ply")  # or detect(load_points("scan.ply"))
    for hole in detection.holes:
        print(hole.center, hole.diameter, hole.normal)

    from holecli import measure_scan  # the record holecli detect prints, checked against a spec
    record = measure_scan("scan.ply", spec=spec, units=units).record
"""

from holecli.errors import HoleCliError, LoadError, PointsError, SpecError

__version__ = "0.1.0"

__all__ = [
    "Detection",
    "Hole",
    "HoleCliError",
    "LoadError",
    "MeasureError",
    "Measurement",
    "Plane",
    "PointsError",
    "SpecError",
    "__version__",
    "detect",
    "detect_file",
    "load_points",
    "measure_scan",
    "read_cloud",
]


def __getattr__(name):
    # Deferred so that ``import holecli`` stays cheap (the ``holecli`` program handles signals only
    # once it has been imported): io pulls in the readers (and open3d lazily), pipeline pulls in
    # scipy, results pulls in dataclasses.
    if name in ("load_points", "read_cloud"):
        from holecli import io

        return getattr(io, name)
    if name in ("Detection", "Hole", "Plane"):
        from holecli import results

        return getattr(results, name)
    if name in ("detect", "detect_file"):
        from holecli import pipeline

        return getattr(pipeline, name)
    if name in ("measure_scan", "Measurement", "MeasureError"):
        from holecli import measure

        return getattr(measure, name)
    raise AttributeError(f"module 'holecli' has no attribute {name!r}")
