"""A registration scene: a panel with reference holes, placed in a robot cell under a known rigid transform.

A cell is a flat panel (its part frame: the top face is z = 0 with normal +z, the material on z <= 0,
see :mod:`holecli.simulation.panel`) with 3-5 reference holes, set on a table under a rigid
transform ``T`` from the part frame to the measuring frame (a robot base, say). A laser profiler
(:mod:`holecli.simulation.profiler`) scans each reference hole in its own pass, aimed at the hole's
*nominal* centre, and writes its points in the measuring frame. A hole may be drilled off its
nominal position (``displaced``): the panel is built with it there, so the scan shows it there,
while the nominal holes (the drawing) keep it where it should be; a registration then has to name it
as the outlier. Drilling targets are points with normals in the part frame; the truth gives them
in the measuring frame too, so that a registration's corrected targets can be scored.

Everything here is pure: :func:`simulate_cell` returns arrays and JSON-ready dicts, writes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Optional

import numpy as np

from holecli.errors import SpecError

__all__ = ["Cell", "CellSpec", "HoleScan", "NominalHole", "ReferenceHole", "Target", "random_cell", "simulate_cell"]

# A rotation is accepted when R @ R.T is the identity and det R = 1 to this tolerance.
_ROTATION_TOL = 1e-9
# Each pass scans a square of this many outer diameters about the hole's nominal centre.
_SCAN_DIAMETERS = 2.5
# random_cell: smallest distance between two reference holes' centres, and from a centre to the
# panel's border, as fractions of the panel's smaller side.
_HOLE_SPACING = 0.3
_BORDER_MARGIN = 0.06
# random_cell: draws of a hole position before giving up on the spacing.
_PLACEMENT_TRIES = 1000


@dataclass(frozen=True)
class ReferenceHole:
    """A reference hole as drawn (nominal), in the part frame.

    Attributes
    ----------
    name : str
        Its label, unique in the cell.
    center : (2,) tuple of float
        ``(x, y)`` on the top face (z = 0), mm.
    diameter : float
        Bore diameter, mm.
    countersink_diameter : float or None
        A countersink's diameter at the top face (100 degrees included), mm; None: a plain through hole.
    """

    name: str
    center: tuple[float, float]
    diameter: float
    countersink_diameter: Optional[float] = None

    @property
    def edge_diameter(self) -> float:
        """Diameter of the hole's visible edge on the top face (the countersink's, if any), mm."""
        return self.countersink_diameter if self.countersink_diameter is not None else self.diameter


@dataclass(frozen=True)
class Target:
    """A drilling target in the part frame.

    Attributes
    ----------
    name : str
        Its label.
    point : (3,) tuple of float
        Where to drill, mm.
    normal : (3,) tuple of float
        Drilling direction out of the material, unit.
    """

    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]


@dataclass(frozen=True)
class CellSpec:
    """A panel with reference holes, its pose in the cell and the profiler that scans it.

    Attributes
    ----------
    holes : tuple of ReferenceHole
        The reference holes (nominal), at least one; through holes, optionally countersunk.
    width, height, thickness : float
        The flat panel, mm, centred on the part frame's origin.
    rotation : (3, 3) tuple of float
        Rotation of the true transform from the part frame to the measuring frame.
    translation : (3,) tuple of float
        Its translation, mm: a part point ``p`` is at ``rotation @ p + translation``.
    displaced : mapping of str to (2,) tuple of float
        Holes drilled off their nominal centre: name -> ``(dx, dy)`` in the part frame, mm.
    targets : tuple of Target
        Drilling targets, part frame.
    range_noise : float
        Profiler: Gaussian sigma of the range, mm.
    point_pitch : float
        Profiler: spacing of the points along the line, mm.
    line_pitch : float or None
        Profiler: travel between profiles, mm; None: ``point_pitch``.
    standoff : float
        Profiler: distance from the sensor to the aimed-at hole, mm.
    view_tilt_deg : float
        Angle between the sensor's view and the panel's inward normal (-z of the part frame), degrees, in [0, 45).
    view_azimuth_deg : float
        Direction the view leans toward, degrees from the part's +x toward +y.
    triangulation_deg : float
        Profiler: angle between the laser and the camera (camera occlusion), degrees.
    chord_error : float
        Largest sagitta of the mesh's hole polygons, mm.
    grid_spacing : float
        Spacing of the panel mesh's background grid, mm (the panel is flat: it does not limit accuracy).
    """

    holes: tuple[ReferenceHole, ...]
    width: float = 300.0
    height: float = 200.0
    thickness: float = 3.0
    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    displaced: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    targets: tuple[Target, ...] = ()
    range_noise: float = 0.005
    point_pitch: float = 0.05
    line_pitch: Optional[float] = None
    standoff: float = 100.0
    view_tilt_deg: float = 0.0
    view_azimuth_deg: float = 0.0
    triangulation_deg: float = 25.0
    chord_error: float = 1e-4
    grid_spacing: float = 10.0

    @property
    def transform(self) -> np.ndarray:
        """(4, 4) float64: the true rigid transform from the part frame to the measuring frame."""
        matrix = np.eye(4)
        matrix[:3, :3] = np.asarray(self.rotation, dtype=np.float64)
        matrix[:3, 3] = np.asarray(self.translation, dtype=np.float64)
        return matrix


@dataclass(frozen=True)
class NominalHole:
    """A reference hole as a spec file gives it (part frame).

    Attributes
    ----------
    name : str
    center : (3,) tuple of float
        On the top face (z = 0), mm.
    normal : (3,) tuple of float
        (0, 0, 1).
    diameter : float
        The visible edge's diameter (the countersink's, if any), mm.
    bore_diameter : float
    countersink_diameter : float or None
    """

    name: str
    center: tuple[float, float, float]
    normal: tuple[float, float, float]
    diameter: float
    bore_diameter: float
    countersink_diameter: Optional[float] = None


@dataclass(frozen=True, eq=False)
class HoleScan:
    """One profiler pass over one reference hole.

    Attributes
    ----------
    name : str
        The hole scanned.
    points : (n, 3) float64
        Finite points in the measuring frame, mm.
    view : (3,) float64
        The sensor's viewing direction in the measuring frame (for ``detect(view_dir=...)``).
    info : dict
        The profiler's counts (see :class:`holecli.simulation.profiler.ProfilerScan`).
    """

    name: str
    points: np.ndarray
    view: np.ndarray
    info: dict


@dataclass(frozen=True, eq=False)
class Cell:
    """A simulated cell: the scans, what the drawing says, and the truth.

    Attributes
    ----------
    scans : tuple of HoleScan
        One per reference hole, in the spec's order.
    nominal : tuple of NominalHole
        The reference holes as drawn, part frame (undisplaced).
    targets : tuple of Target
        The drilling targets, part frame.
    transform : (4, 4) float64
        The true transform from the part frame to the measuring frame.
    truth : dict
        JSON-ready: ``transform`` (4x4), ``rotation`` (3x3), ``translation``, ``holes`` (per reference
        hole: ``name``, ``center`` and ``normal`` in the measuring frame where it was actually
        drilled, ``nominal_center`` (part frame), ``offset`` ([dx, dy], part frame), ``displaced``,
        ``diameter``, ``bore_diameter``, ``countersink_diameter``), ``targets`` (``name``,
        ``point``, ``normal`` in the measuring frame), ``displaced`` (names), ``panel`` and
        ``profiler`` (the settings).
    spec : CellSpec
    """

    scans: tuple
    nominal: tuple
    targets: tuple
    transform: np.ndarray
    truth: dict
    spec: CellSpec = field(repr=False)


# --------------------------------------------------------------------------------------------------
# Validation


def _finite(value, count=None):
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return bool(np.all(np.isfinite(array))) and (count is None or array.shape == (count,))


def _validate(spec: CellSpec):
    if not isinstance(spec, CellSpec):
        raise SpecError(f"spec must be a CellSpec, got {type(spec).__name__}")
    if len(spec.holes) < 1:
        raise SpecError("holes must hold at least one ReferenceHole, got none")
    names = [hole.name for hole in spec.holes]
    for hole in spec.holes:
        if not isinstance(hole.name, str) or not hole.name:
            raise SpecError(f"a hole's name must be a non-empty string, got {hole.name!r}")
        if not _finite(hole.center, 2):
            raise SpecError(f"hole {hole.name}: center must be 2 finite numbers (x, y), got {hole.center!r}")
        if not (_finite(hole.diameter) and hole.diameter > 0):
            raise SpecError(f"hole {hole.name}: diameter must be > 0, got {hole.diameter!r}")
    if len(set(names)) != len(names):
        repeated = sorted({name for name in names if names.count(name) > 1})
        raise SpecError(f"hole names must be unique, got {repeated[0]!r} more than once")
    rotation = np.asarray(spec.rotation, dtype=np.float64) if _finite(spec.rotation) else None
    if rotation is None or rotation.shape != (3, 3) or \
            np.abs(rotation @ rotation.T - np.eye(3)).max() > _ROTATION_TOL or np.linalg.det(rotation) < 0:
        raise SpecError(f"rotation must be a proper 3x3 rotation matrix, got {spec.rotation!r}")
    if not _finite(spec.translation, 3):
        raise SpecError(f"translation must be 3 finite numbers, got {spec.translation!r}")
    for name, offset in spec.displaced.items():
        if name not in names:
            raise SpecError(f"displaced hole {name!r} is not a reference hole (expected one of {', '.join(names)})")
        if not _finite(offset, 2):
            raise SpecError(f"displaced hole {name}: offset must be 2 finite numbers (dx, dy), got {offset!r}")
    for target in spec.targets:
        if not (_finite(target.point, 3) and _finite(target.normal, 3) and np.linalg.norm(target.normal) > 0):
            raise SpecError(f"target {target.name}: point and normal must be 3 finite numbers (normal not zero), "
                            f"got {target.point!r}, {target.normal!r}")
    if not (_finite(spec.range_noise) and spec.range_noise >= 0):
        raise SpecError(f"range_noise must be >= 0, got {spec.range_noise!r}")
    for key in ("point_pitch", "standoff", "width", "height", "thickness", "chord_error", "grid_spacing"):
        value = getattr(spec, key)
        if not (_finite(value) and value > 0):
            raise SpecError(f"{key} must be > 0, got {value!r}")
    if spec.line_pitch is not None and not (_finite(spec.line_pitch) and spec.line_pitch > 0):
        raise SpecError(f"line_pitch must be > 0 or None, got {spec.line_pitch!r}")
    if not (_finite(spec.view_tilt_deg) and 0 <= spec.view_tilt_deg < 45):
        raise SpecError(f"view_tilt_deg must be in [0, 45), got {spec.view_tilt_deg!r}")
    if not _finite(spec.view_azimuth_deg):
        raise SpecError(f"view_azimuth_deg must be a finite number, got {spec.view_azimuth_deg!r}")


# --------------------------------------------------------------------------------------------------
# Drawing a cell


def random_cell(rng=0, holes=4, *, width=300.0, height=200.0, thickness=3.0, diameters=(4.0, 8.0),
                max_rotation_deg=5.0, targets=5, target_reach=300.0, countersunk=False, displaced=None,
                **profiler) -> CellSpec:
    """A plausible cell: reference holes spread over a panel, a part set on a robot cell's table.

    Parameters
    ----------
    rng : int or numpy.random.Generator
        Random source.
    holes : int
        Number of reference holes, 1-8 (3-5 is typical); named ``R1``, ``R2``, ...
    width, height, thickness : float
        The panel, mm.
    diameters : (2,) tuple of float
        Range the bore diameters are drawn from (uniform, rounded to 0.01 mm), mm.
    max_rotation_deg : float
        Each of the rotations about x, y and z (applied in that order) is uniform in +- this, degrees.
    targets : int
        Number of drilling targets (``P1``, ...): on the panel's top plane, up to ``target_reach`` from
        the centroid of the reference holes (so many lie beyond the panel), normals within 5 degrees of +z.
    target_reach : float
        Largest distance of a target from the reference holes' centroid, mm.
    countersunk : bool
        Make the last reference hole countersunk (1.75 x its diameter at the surface, 100 degrees).
    displaced : mapping of str to (2,) tuple of float, optional
        Passed on to :attr:`CellSpec.displaced`.
    **profiler
        Other :class:`CellSpec` fields (``range_noise``, ``point_pitch``, ``view_tilt_deg``, ...).

    Returns
    -------
    CellSpec
        Translation uniform in x [300, 900], y [-400, 400], z [0, 400] mm; holes at least 0.3 x the
        panel's smaller side apart.

    Raises
    ------
    SpecError
        ``holes`` out of range, or the holes cannot be spread over the panel.
    """
    from holecli.simulation.synth import rotation_matrix

    if isinstance(holes, bool) or not isinstance(holes, (int, np.integer)) or not 1 <= holes <= 8:
        raise SpecError(f"holes must be an integer in 1-8, got {holes!r}")
    if isinstance(targets, bool) or not isinstance(targets, (int, np.integer)) or targets < 0:
        raise SpecError(f"targets must be an integer >= 0, got {targets!r}")
    rng = np.random.default_rng(rng)
    side = min(width, height)
    margin = _BORDER_MARGIN * side + 0.5 * 1.75 * max(diameters)
    spacing = _HOLE_SPACING * side
    centers = []
    for _ in range(_PLACEMENT_TRIES):
        if len(centers) == holes:
            break
        candidate = rng.uniform([-width / 2 + margin, -height / 2 + margin], [width / 2 - margin, height / 2 - margin])
        if all(np.hypot(*(candidate - other)) >= spacing for other in centers):
            centers.append(candidate)
    if len(centers) < holes:
        raise SpecError(f"cannot spread {holes} holes {spacing:g} mm apart over a {width:g} x {height:g} mm panel")
    reference = []
    for k, center in enumerate(centers):
        diameter = round(float(rng.uniform(*diameters)), 2)
        sink = round(1.75 * diameter, 2) if countersunk and k == holes - 1 else None
        reference.append(ReferenceHole(name=f"R{k + 1}", center=(round(float(center[0]), 3), round(float(center[1]), 3)),
                                       diameter=diameter, countersink_diameter=sink))
    rotation = rotation_matrix(rng.uniform(-max_rotation_deg, max_rotation_deg, size=3))
    translation = rng.uniform([300.0, -400.0, 0.0], [900.0, 400.0, 400.0])
    centroid = np.mean(centers, axis=0)
    drawn = []
    for k in range(targets):
        reach = target_reach * math.sqrt(rng.uniform(0.05, 1.0))
        angle = rng.uniform(0.0, 2 * math.pi)
        tilt, lean = math.radians(rng.uniform(0.0, 5.0)), rng.uniform(0.0, 2 * math.pi)
        point = centroid + reach * np.array([math.cos(angle), math.sin(angle)])
        normal = (math.sin(tilt) * math.cos(lean), math.sin(tilt) * math.sin(lean), math.cos(tilt))
        drawn.append(Target(name=f"P{k + 1}", point=(float(point[0]), float(point[1]), 0.0), normal=normal))
    return CellSpec(holes=tuple(reference), width=width, height=height, thickness=thickness,
                    rotation=tuple(map(tuple, rotation.tolist())), translation=tuple(translation.tolist()),
                    displaced=dict(displaced or {}), targets=tuple(drawn), **profiler)


# --------------------------------------------------------------------------------------------------
# Simulation


def _unit(vector):
    vector = np.asarray(vector, dtype=np.float64)
    return vector / np.linalg.norm(vector)


def _view(spec):
    """The view and the laser line in the part frame."""
    tilt, lean = math.radians(spec.view_tilt_deg), math.radians(spec.view_azimuth_deg)
    view = -np.array([math.sin(tilt) * math.cos(lean), math.sin(tilt) * math.sin(lean), math.cos(tilt)])
    # The line runs along the part's x as far as the view allows (made perpendicular to the view).
    line = np.array([1.0, 0.0, 0.0]) - view[0] * view
    return view, _unit(line)


def simulate_cell(spec: CellSpec, rng=0) -> Cell:
    """Build the cell's panel, scan each reference hole in its own profiler pass, and give the truth.

    Parameters
    ----------
    spec : CellSpec
        The cell; validated here.
    rng : int or numpy.random.Generator
        Random source of the profiler's noise (the passes draw from it in the holes' order).

    Returns
    -------
    Cell
        The scans (measuring frame), the nominal holes and targets (part frame) and the truth.

    Raises
    ------
    SpecError
        An invalid spec, or a panel that cannot be built (a hole off the panel or too near another).
    """
    from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
    from holecli.simulation.profiler import ProfilerSpec
    from holecli.simulation.scan_part import scan_part

    _validate(spec)
    rng = np.random.default_rng(rng)
    offsets = {hole.name: np.asarray(spec.displaced.get(hole.name, (0.0, 0.0)), dtype=np.float64) for hole in spec.holes}
    features = []
    for hole in spec.holes:
        drilled = tuple((np.asarray(hole.center, dtype=np.float64) + offsets[hole.name]).tolist())
        if hole.countersink_diameter is None:
            features.append(FeatureSpec(kind="through", center=drilled, diameter=hole.diameter, name=hole.name))
        else:
            features.append(FeatureSpec(kind="countersunk", center=drilled, diameter=hole.diameter,
                                        countersink_diameter=hole.countersink_diameter, name=hole.name))
    panel = build_panel(PanelSpec(width=spec.width, height=spec.height, thickness=spec.thickness,
                                  features=tuple(features), chord_error=spec.chord_error,
                                  grid_spacing=spec.grid_spacing))
    part_truth = panel_truth(panel)
    transform = spec.transform
    rotation, translation = transform[:3, :3], transform[:3, 3]
    frame = tuple(map(tuple, transform.tolist()))
    view, line = _view(spec)

    scans, holes = [], []
    for hole, feature in zip(spec.holes, part_truth["features"]):
        size = _SCAN_DIAMETERS * hole.edge_diameter
        # The robot aims at the nominal centre: it does not know the hole was drilled elsewhere.
        profiler = ProfilerSpec(target=(float(hole.center[0]), float(hole.center[1]), 0.0), standoff=spec.standoff,
                                view=tuple(view), line=tuple(line), line_length=size, scan_length=size,
                                point_pitch=spec.point_pitch, line_pitch=spec.line_pitch or spec.point_pitch,
                                triangulation_deg=spec.triangulation_deg, range_noise=spec.range_noise,
                                frame=frame)
        # Only this hole's truth: the pass's window reaches no other reference hole.
        scanned = scan_part(panel.vertices, panel.triangles, [feature], profiler, rng=rng)
        points = scanned.scan.points
        scans.append(HoleScan(name=hole.name, points=points, view=rotation @ view, info=dict(scanned.scan.info)))
        (moved,) = scanned.truth["holes"]
        holes.append({"name": hole.name, "center": moved["center"], "normal": moved["normal"],
                      "nominal_center": [float(hole.center[0]), float(hole.center[1]), 0.0],
                      "offset": offsets[hole.name].tolist(), "displaced": hole.name in spec.displaced,
                      "diameter": moved["diameter"], "bore_diameter": float(hole.diameter),
                      "countersink_diameter": hole.countersink_diameter, "inside_scan": moved["inside_scan"],
                      "points": int(len(points))})

    nominal = tuple(NominalHole(name=hole.name, center=(float(hole.center[0]), float(hole.center[1]), 0.0),
                                normal=(0.0, 0.0, 1.0), diameter=float(hole.edge_diameter),
                                bore_diameter=float(hole.diameter), countersink_diameter=hole.countersink_diameter)
                    for hole in spec.holes)
    targets = [{"name": target.name,
                "point": (rotation @ np.asarray(target.point, dtype=np.float64) + translation).tolist(),
                "normal": (rotation @ _unit(target.normal)).tolist()} for target in spec.targets]
    truth = {
        "frames": "transform maps the part frame (the drawing's: nominal holes, targets) to the measuring "
                  "frame (the scans'): p_measuring = rotation @ p_part + translation",
        "transform": transform.tolist(), "rotation": rotation.tolist(), "translation": translation.tolist(),
        "holes": holes, "targets": targets, "displaced": sorted(spec.displaced),
        "panel": dict(part_truth["panel"], vertices=part_truth["vertices"], triangles=part_truth["triangles"]),
        "profiler": {"range_noise": float(spec.range_noise), "point_pitch": float(spec.point_pitch),
                     "line_pitch": float(spec.line_pitch or spec.point_pitch), "standoff": float(spec.standoff),
                     "view_tilt_deg": float(spec.view_tilt_deg), "view_azimuth_deg": float(spec.view_azimuth_deg),
                     "triangulation_deg": float(spec.triangulation_deg), "fan": True,
                     "view_part": view.tolist(), "view": (rotation @ view).tolist()},
    }
    return Cell(scans=tuple(scans), nominal=nominal, targets=tuple(spec.targets), transform=transform,
                truth=truth, spec=spec)
