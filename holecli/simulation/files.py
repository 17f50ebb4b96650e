"""Writing simulated scans to files: a scan and its truth, a registration cell's folder, a lot's folder
(``holecli simulate``).

Each function takes what :mod:`holecli.simulation` made (points and truth dicts, a
:class:`holecli.simulation.cell.Cell`, the parts of :func:`holecli.simulation.lot.lot_parts`) and paths,
and writes the files; a file that cannot be written raises :class:`OSError` (:class:`CannotWrite` for a
lot, naming the path to report).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from holecli.io import save_points
from holecli.io.outfile import write_text
from holecli.io.targets import INPUT_COLUMNS, format_targets
from holecli.simulation.part import panel_part
from holecli.simulation.scan_part import scan_part

__all__ = ["CannotWrite", "LotPartError", "cell_part_toml", "cell_targets_csv", "write_cell", "write_lot",
           "write_scan"]

# Tolerances written into a cell's part.toml (mm, degrees): a reference hole's drawing.
_CELL_DIAMETER_TOLERANCE = 0.05
_CELL_POSITION_TOLERANCE = 0.1
_CELL_COUNTERSINK_DIAMETER_TOLERANCE = 0.1
_CELL_COUNTERSINK_ANGLE_TOLERANCE = 1.0


class CannotWrite(Exception):
    """A file or folder of a lot that cannot be written: ``path`` (as to be reported) and the ``error``."""

    def __init__(self, path, error):
        super().__init__(f"{path}: cannot write: {error.strerror or error}")
        self.path, self.error = path, error


class LotPartError(Exception):
    """A part of a lot that cannot be built or scanned: its ``truth`` (of :func:`lot_parts`) and the ``error``."""

    def __init__(self, truth, error):
        super().__init__(str(error))
        self.truth, self.error = truth, error


def write_scan(output, points, truth, truth_path=None, float32=True) -> str:
    """Write a simulated cloud to ``output`` and its truth as JSON to ``truth_path`` (None: ``output`` with
    ``.truth.json``); return the truth's path.

    Raises
    ------
    OSError
        When a file cannot be written.
    """
    target = truth_path or str(Path(output).with_suffix(".truth.json"))
    save_points(output, points, float32=float32)
    write_text(target, json.dumps(truth, indent=2) + "\n")
    return target


def _toml_vector(values):
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def _toml_string(text):
    return json.dumps(text)  # a JSON string is a TOML basic string for the names used here


def cell_part_toml(cell) -> str:
    """The nominal reference holes of ``cell`` as a :func:`holecli.tolerance.parse_spec` file (part frame)."""
    lines = ["# The reference holes of a simulated cell as drawn, in the part frame (mm); the scans are in",
             "# the measuring frame (see cell.truth.json).", ""]
    for hole in cell.nominal:
        lines += ["[[hole]]", f"name = {_toml_string(hole.name)}", f"center = {_toml_vector(hole.center)}",
                  f"normal = {_toml_vector(hole.normal)}", f"diameter = {float(hole.diameter)!r}",
                  f"tolerance = {_CELL_DIAMETER_TOLERANCE!r}", f"position_tolerance = {_CELL_POSITION_TOLERANCE!r}"]
        if hole.countersink_diameter is not None:
            lines += [f"countersink_diameter = {float(hole.countersink_diameter)!r}",
                      f"countersink_diameter_tolerance = {_CELL_COUNTERSINK_DIAMETER_TOLERANCE!r}",
                      "countersink_angle = 100.0",
                      f"countersink_angle_tolerance = {_CELL_COUNTERSINK_ANGLE_TOLERANCE!r}"]
        lines.append("")
    return "\n".join(lines)


def cell_targets_csv(cell) -> str:
    """``name,x,y,z,nx,ny,nz`` rows of ``cell``'s targets, part frame, unit normals, full precision."""
    rows = []
    for target in cell.targets:
        normal = np.asarray(target.normal, dtype=np.float64)
        normal = normal / np.linalg.norm(normal)
        rows.append(dict(zip(INPUT_COLUMNS, (target.name, *target.point, *normal))))
    return format_targets(rows, columns=INPUT_COLUMNS)


def write_cell(directory, cell, seed, float32=True) -> dict:
    """Write ``cell`` (of :func:`holecli.simulation.cell.simulate_cell` with ``seed``) into the folder
    ``directory``, made if missing: ``<name>.ply`` for each reference hole's scan, part.toml, targets.csv
    and cell.truth.json (files of those names are replaced); return the truth written.

    Raises
    ------
    OSError
        When a file or the folder cannot be written.
    """
    folder = Path(directory)
    truth = dict(cell.truth, seed=seed, units="mm",
                 files={"scans": {scan.name: f"{scan.name}.ply" for scan in cell.scans}, "spec": "part.toml",
                        "targets": "targets.csv"})
    folder.mkdir(parents=True, exist_ok=True)
    for scan in cell.scans:
        save_points(folder / f"{scan.name}.ply", scan.points, float32=float32)
    write_text(folder / "part.toml", cell_part_toml(cell))
    write_text(folder / "targets.csv", cell_targets_csv(cell))
    write_text(folder / "cell.truth.json", json.dumps(truth, indent=2) + "\n")
    return truth


def write_lot(directory, drilled, aim, manifest, *, units="mm", float32=True, progress=None) -> list:
    """Build, scan and write the parts of a lot into ``directory`` (a new or an empty folder), all or
    none: everything goes into a temporary folder beside it, renamed to ``directory`` at the end;
    nothing of a failed run is left.

    Parameters
    ----------
    directory : str
        The lot's folder.
    drilled : iterable of (PanelSpec, dict)
        Each part's panel spec and truth (:func:`holecli.simulation.lot.lot_parts`).
    aim : callable
        ``aim(vertices)``: the :class:`holecli.simulation.profiler.ProfilerSpec` scanning a part.
    manifest : dict
        The manifest's entries before ``units``, ``defective`` and ``lot``.
    units : str
        The units of the points, in each truth and the manifest.
    float32 : bool
        Write single precision points.
    progress : callable, optional
        ``progress(name, points, truth)`` after each part is written.

    Returns
    -------
    list of dict
        The manifest's ``lot``: each part's file name and truth.

    Raises
    ------
    CannotWrite
        When the temporary folder, a part's file or the rename cannot be written.
    LotPartError
        When a part cannot be built or scanned (a :class:`ValueError`).
    OSError
        When manifest.json cannot be written.
    """
    target = Path(directory)
    try:
        staging = tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".partial", dir=target.resolve().parent)
    except OSError as error:
        raise CannotWrite(directory, error) from None
    try:
        parts = []
        for spec, truth in drilled:
            name = f"part_{truth['part']:03d}.ply"
            try:
                part = panel_part(spec)
                scanned = scan_part(part.vertices, part.triangles, part.features, aim(part.vertices),
                                    rng=truth["scan_seed"])
            except ValueError as error:
                raise LotPartError(truth, error) from None
            scan_truth = dict(scanned.truth, part=truth["part"], seed=truth["scan_seed"], file=name, units=units)
            path = os.path.join(staging, name)
            try:
                write_scan(path, scanned.scan.points, scan_truth, None, float32)
            except OSError as error:
                raise CannotWrite(path, error) from None
            parts.append({"file": name, **truth})
            if progress is not None:
                progress(name, len(scanned.scan.points), truth)
        manifest = {**manifest, "units": units, "defective": [part["file"] for part in parts if part["defective"]],
                    "lot": parts}
        write_text(os.path.join(staging, "manifest.json"), json.dumps(manifest, indent=2) + "\n")
        os.chmod(staging, 0o777 & ~_umask())
        try:
            os.rename(staging, target)  # onto a new or an empty folder: all at once
        except OSError as error:
            raise CannotWrite(directory, error) from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return parts


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask
