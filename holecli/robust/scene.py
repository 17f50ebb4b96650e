"""The scene: what the whole scan knows, built once (:func:`build_scene`), and the spatial questions every
candidate asks of it (:class:`Scene`'s ``box``, ``within``, ``count_in_disk``, ``disk_allowance``,
``scanned_fraction``, ``material_arc``, ``in_material_interior``).

Steps 1-4 of :mod:`holecli.robust.method`: the plane of the dominant surface, the rotation into its
frame (a slide of the surface's points along the view where nothing is seen behind it), the sensor's
side, the sampling's scales and the occupancy grid of the surface whose voids are the candidates.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import NamedTuple, Optional

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from holecli.geometry.frame import canonical_rotation, check_view_angle
from holecli.geometry.kernels import CellIndex, box_indices, robust_sigma
from holecli.geometry.plane import ASSUMED_VIEW, PlaneFit, fit_plane_robust, fit_plane_scatter, hidden_points
from holecli.robust.candidates import Grid, distance_to_outside, occupancy_grid, scanned_hull
from holecli.robust.edge_loops import faces_empty, looks_like_vertices, top_face
from holecli.robust.facing import Facing, decide, fan_side, fan_spacing, MIN_POINTS as SEEN_MIN_POINTS, seen_through
from holecli.robust.sampling import Sampling, estimate_sampling
from holecli.robust.uncertainty import resolution_uncertainty
from holecli.settings import DEFAULT_SETTINGS
from holecli.stages import StageClock

__all__ = ["Scene", "build_scene"]


@dataclass(frozen=True, eq=False)
class Scene:
    """What every candidate's measurement needs to know of the whole scan (plane frame: the rows of
    ``rotation`` are the in-plane axes and the normal, ``origin`` the plane's point).

    The cell indices (``xy_cells``, ``surface_cells``, ``material_cells``) are built once, when the
    scan has many candidates (:meth:`with_cell_indices`); the scanned hull and the border distance
    are computed when first asked and kept.
    """

    xy: np.ndarray           # (n, 2) all points in the plane frame (projected, or the surface's slid)
    surface_xy: np.ndarray   # (m, 2) the plane inliers' rows of xy
    material_xy: np.ndarray  # surface_xy in material cells of the grid (specks inside holes removed)
    above_xy: np.ndarray     # (k, 2) points standing above the surface band (a boss, outliers)
    surface_density: float   # surface points per unit area of scanned material
    height_noise: float      # robust sd of the surface points' heights, at least resolution / sqrt(12)
    band: float              # largest |height| of a surface point: above it stand a boss or outliers
    points: np.ndarray       # (n, 3) the cloud, world coordinates (a face hidden along the view removed)
    surface_index: np.ndarray  # (m,) rows of the plane inliers in points
    heights: np.ndarray      # (n,) signed distance from the plane
    origin: np.ndarray       # (3,) the plane's point
    rotation: np.ndarray     # (3, 3) world -> plane frame
    direction: np.ndarray    # projection direction (unit, world)
    plane: PlaneFit          # the surface's plane, its normal toward the sensor
    sampling: Sampling
    alpha: float
    cell: float
    min_radius: float
    gap_scatter: float       # rim scatter the sampling alone produces
    envelope: float          # depth below its sector's outermost rim point at which a rim point is dropped
    grid: Grid               # the occupancy grid of the surface (its voids are the candidates)
    resolution: float        # of the heights: the plane's (PlaneFit.resolution: a level step, else round-off)
    facing: Facing           # the sensor's side of the surface
    vertices: bool = False   # the scan looks like a CAD export's vertices (holecli.robust.edge_loops)
    xy_cells: Optional[CellIndex] = None        # of xy (many candidates)
    surface_cells: Optional[CellIndex] = None   # of surface_xy
    material_cells: Optional[CellIndex] = None  # of material_xy

    def with_cell_indices(self):
        """The scene with a :class:`holecli.geometry.kernels.CellIndex` of ``xy``, ``surface_xy`` and
        ``material_xy``: every narrow neighbourhood query then reads only its own cells instead of
        every point (many candidates: the natural gaps of random sampling). Each index sorts its
        points at its first narrow query; when making ``material_xy`` removed no point (no speck: the
        usual case), it is ``surface_xy`` and the two share one index."""
        surface_cells = CellIndex(self.surface_xy, self.cell)
        same = len(self.material_xy) == len(self.surface_xy) and np.array_equal(self.material_xy, self.surface_xy)
        return replace(self, xy_cells=CellIndex(self.xy, self.cell), surface_cells=surface_cells,
                       material_cells=surface_cells if same else CellIndex(self.material_xy, self.cell))

    def _cells_of(self, xy):
        for array, index in ((self.xy, self.xy_cells), (self.surface_xy, self.surface_cells),
                             (self.material_xy, self.material_cells)):
            if xy is array:
                return index
        return None

    def box(self, xy, low, high):
        """Indices of the points of ``xy`` (one of the scene's arrays) in the box ``[low, high]``: from
        its cell index when the scene has one for it, else by a pass over the points."""
        index = self._cells_of(xy)
        return box_indices(xy, low, high) if index is None else index.box(low, high)

    def within(self, xy, center, inner, outer):
        """Indices of the points of ``xy`` (one of the scene's arrays) at a distance in [inner, outer)
        from ``center``.

        A box test first: on a million points it is several times cheaper than the distances.
        """
        index = self.box(xy, center - outer, center + outer)
        return index[in_ring(xy[index], center, inner, outer)]

    def count_in_disk(self, xy, center, radius):
        """How many points of ``xy`` (one of the scene's arrays) lie within ``radius`` of ``center``."""
        return len(self.within(xy, center, 0.0, radius))

    def disk_allowance(self, radius, fraction):
        """``fraction`` of the surface points a disk of ``radius`` holds at the scan's density."""
        return float(fraction * self.surface_density * np.pi * max(radius, 0.0) ** 2)

    @cached_property
    def scanned_hull(self):
        """The convex hull of the scanned material on the grid
        (:func:`holecli.robust.candidates.scanned_hull`), computed when first asked."""
        return scanned_hull(self.grid)

    @cached_property
    def border_distance(self):
        """Per grid cell, the distance to the scan's outside
        (:func:`holecli.robust.candidates.distance_to_outside`), computed when first asked."""
        return distance_to_outside(self.grid)

    @property
    def void_reach(self):
        """The distance from a void's cells up to which its nearest material is looked for: the
        smallest reported radius and a cell (:func:`holecli.robust.acceptance.void_below_min_diameter`)."""
        return self.min_radius + self.cell

    @cached_property
    def empty_cell_clearance(self):
        """Per cell of the grid, the distance from its center to the nearest material point where the
        cell is empty and that distance less than :attr:`void_reach`, else inf; computed when first
        asked.

        A scan with many candidates (the natural gaps of random sampling: hundreds of voids at a
        million points) asks each void for the nearest material of its cells
        (:func:`holecli.robust.acceptance.void_below_min_diameter`). Here one tree of the material
        near the empty cells answers every empty cell at once, where a box query and a tree per void
        cost twice as much. A material point within ``reach`` of a cell's center lies in a cell whose
        nearest side is within ``reach`` of that center (with a margin for the round-off of the cell
        a point falls in): the tree holds every material point such a query can find, so that each
        distance is the one the void's own points give, bit for bit.

        Returns
        -------
        (nx, ny) float ndarray
        """
        grid, reach = self.grid, self.void_reach
        empty = ~grid.material
        clearance = np.full(empty.shape, np.inf)
        cells = np.argwhere(empty)
        # Offsets (in cells) of the cells whose nearest side lies within reach of a cell's center.
        span = reach / grid.cell * (1.0 + 1e-9)
        offsets = np.maximum(np.abs(np.arange(-int(np.ceil(span + 0.5)), int(np.ceil(span + 0.5)) + 1)) - 0.5, 0.0)
        footprint = offsets[:, None] ** 2 + offsets[None, :] ** 2 <= span * span
        near = ndimage.binary_dilation(empty, structure=footprint)
        material = self.material_xy[grid.lookup(near, self.material_xy)]
        if len(cells) and len(material):
            # (the tree's shape does not change a distance: an unbalanced tree is built in half the time)
            tree = cKDTree(material, balanced_tree=False, compact_nodes=False)
            distance, _ = tree.query(grid.center_of(cells), distance_upper_bound=reach)
            clearance[cells[:, 0], cells[:, 1]] = distance
        return clearance

    def scanned_fraction(self, center, radius, rings=48, spokes=96):
        """The fraction of the disk's area inside the scan: in the convex hull of the scanned material
        (:attr:`scanned_hull`), on points spread evenly over the disk. 1 for a void surrounded by
        material, less where the scan's border cuts the disk."""
        r = radius * np.sqrt((np.arange(rings) + 0.5) / rings)  # equal areas
        t = 2.0 * np.pi * (np.arange(spokes) + 0.5) / spokes
        disk = center + np.column_stack([np.outer(r, np.cos(t)).ravel(), np.outer(r, np.sin(t)).ravel()])
        return float(np.mean(self.grid.lookup(self.scanned_hull, disk)))

    def material_arc(self, center, radius, samples=720):
        """Degrees of the circle with scanned material just outside it (a cell beyond the edge).

        Counted on the occupancy grid rather than from the rim points, whose spacing along a sparse rim
        (or near the scan's edge) would understate the coverage.
        """
        grid = self.grid
        angles = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
        ring = center + (radius + grid.cell) * np.column_stack([np.cos(angles), np.sin(angles)])
        return 360.0 * float(np.mean(grid.lookup(grid.solid, ring)))

    def in_material_interior(self, xy):
        """Whether each point lies in a cell of the grid's material whose eight neighbours are material too.

        The surface's own points do (away from its edges); reflections inside a hole do not, even where
        a cluster of them joins the material at the rim: 100 reflections in the paper's 3 mm hole occupy
        about a fifth of its cells, and eight occupied neighbours around one of them are rare (~0.2^8).
        """
        grid = self.grid
        ij = grid.cell_of(xy)
        inside = np.all((ij >= 1) & (ij < np.array(grid.material.shape) - 1), axis=1)
        out = inside.copy()
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                out[inside] &= grid.material[ij[inside, 0] + di, ij[inside, 1] + dj]
        return out


def build_scene(points, *, view_dir=None, min_diameter=None, settings=DEFAULT_SETTINGS, rng=0, clock=None,
                flattened=False):
    """The :class:`Scene` of a scan: steps 1-4 of :mod:`holecli.robust.method` up to the grid.

    Parameters
    ----------
    points : (n, 3) float64
        Checked points (:func:`holecli.pipeline.validate_points`).
    view_dir, min_diameter, settings, rng
        See :func:`holecli.detect`.
    clock : holecli.stages.StageClock, optional
        Times the stages ``plane``, ``frame``, ``sampling`` and ``grid``.
    flattened : bool
        The points are the flattened neighbourhood of one hole of a curved surface
        (:mod:`holecli.robust.curved`): their frame has the sensor on +z, and they are no CAD
        export's vertices.

    Returns
    -------
    Scene
    """
    clock = StageClock() if clock is None else clock
    clock.start("plane")
    plane = fit_plane_robust(points, rng=rng, sample=settings.ransac_sample,
                             hypotheses=settings.ransac_hypotheses, quantile=settings.ransac_quantile,
                             clip=settings.plane_clip, max_rounds=settings.plane_refine_rounds,
                             refine_sample=settings.plane_refine_sample, max_faces=settings.plane_max_faces,
                             view=view_dir)
    frame = _frame_and_grid(points, plane, view_dir, min_diameter, settings, clock)
    if plane.hidden and not faces_empty(float(frame.sampling.spacing), float(frame.sampling.gap)):
        # A face hidden behind the surface along the view (a whole mesh sampled, its bottom under its
        # top): a sensor never recorded it, and seen through a countersink it reads as a counterbore's
        # floor. (Not in a CAD export's vertices, whose faces are empty: there the loops at one depth,
        # a countersink's inner loops, make such a face, and they are what types the holes.)
        seen = ~hidden_points(points, plane, ASSUMED_VIEW if view_dir is None else view_dir)
        points, plane = points[seen], replace(plane, inliers=plane.inliers[seen], hidden=())
        frame = _frame_and_grid(points, plane, view_dir, min_diameter, settings, clock)
    # The heights are read along the normal toward the sensor (holecli.robust.facing): from
    # --view-dir, else from the points seen through the surface, else the z-positive normal. A
    # flattened crop's frame has the sensor on +z (holecli.robust.curved).
    below, above = seen_through(frame.heights, frame.xy, plane.inliers, frame.grid, frame.band,
                                frame.sampling.spacing)
    fan = None
    if view_dir is None and not flattened and max(below, above) < SEEN_MIN_POINTS:
        # Not seen through: the second cue, a fan's spacing growing with the range.
        fan = fan_side(fan_spacing(frame.xy, frame.heights, plane.inliers, frame.band, frame.sampling.spacing,
                                   frame.grid.cell))
    facing = decide(plane.normal, (0.0, 0.0, -1.0) if flattened else view_dir, below, above, fan=fan)
    if facing.sign < 0:
        # The frame again about the flipped normal (not a mirror of the first one), so that a scan
        # and its rigid motions are measured in the same frame of the part.
        plane = replace(plane, normal=-plane.normal)
        frame = _frame_and_grid(points, plane, view_dir, min_diameter, settings, clock)
    vertices = not flattened and looks_like_vertices(float(frame.sampling.spacing), float(frame.sampling.gap),
                                                     int(np.count_nonzero(plane.inliers)))
    if vertices and faces_empty(float(frame.sampling.spacing), float(frame.sampling.gap)):
        # A CAD export's vertices: its faces hold their edges' vertices, not points in proportion to
        # their area; the surface is the widest face nearest the sensor (edge_loops.top_face). Only
        # when the faces are empty: a small surface sampling's walls join its faces' levels.
        noise = max(robust_sigma(frame.heights[plane.inliers]), float(plane.resolution))
        top = top_face(frame.xy, frame.heights, noise)
        if top is not None and np.count_nonzero(top & plane.inliers) < 0.5 * np.count_nonzero(top):
            fit = fit_plane_scatter(points[top])
            plane = replace(plane, point=fit.point, normal=fit.normal if fit.normal @ plane.normal > 0 else -fit.normal,
                            rms=fit.rms, inliers=top, major=fit.major)
            frame = _frame_and_grid(points, plane, view_dir, min_diameter, settings, clock)
    surface, grid, heights, gap = plane.inliers, frame.grid, frame.heights, frame.sampling.gap
    cell = settings.cell_gaps * gap
    surface_xy = frame.surface_xy
    material_xy = np.asfortranarray(surface_xy[grid.lookup(grid.material, surface_xy)])
    above_xy = np.asfortranarray(frame.xy[(heights > frame.band) & ~surface])
    surface_density = len(surface_xy) / max(float(np.count_nonzero(grid.material)) * cell * cell, 1e-300)
    # Never 0: noise-free data still holds its heights only to its resolution.
    resolution = float(plane.resolution)
    height_noise = max(robust_sigma(heights[surface]), resolution_uncertainty(resolution))
    return Scene(xy=frame.xy, surface_xy=surface_xy, material_xy=material_xy, above_xy=above_xy,
                 surface_density=surface_density, height_noise=height_noise, band=frame.band, heights=heights,
                 points=points, surface_index=np.flatnonzero(surface), origin=plane.point, rotation=frame.rotation,
                 direction=frame.direction, plane=plane, sampling=frame.sampling, alpha=settings.alpha_gaps * gap,
                 cell=cell, min_radius=frame.min_radius, gap_scatter=0.5 * gap, envelope=settings.envelope_gaps * gap,
                 grid=grid, resolution=resolution, facing=facing, vertices=vertices)


class _Frame(NamedTuple):
    """The scan in the frame of its plane, with the sampling and the occupancy grid of its surface."""

    rotation: np.ndarray
    xy: np.ndarray
    heights: np.ndarray
    band: float
    direction: np.ndarray
    sampling: Sampling
    min_radius: float
    surface_xy: np.ndarray
    grid: Grid


def _frame_and_grid(points, plane, view_dir, min_diameter, settings, clock):
    """Steps 2-4 of the module docstring up to the grid, about ``plane`` with its normal's sign as
    given: the rotation into its frame, the plane-frame xy (surface points slid along ``view_dir``
    when given and nothing stands behind the surface, :func:`_nothing_behind`) and heights, the band,
    the sampling and the occupancy grid of the surface (a ``view_dir`` grazing the plane is refused)."""
    normal, origin = plane.normal, plane.point
    # In-plane axes from the surface points themselves (centroid, principal axes), so that the grid
    # and the windows below move with the cloud under any rigid motion.
    clock.start("frame")
    rotation = canonical_rotation(points, plane)
    # One (n, 3) @ (3, 3) product with a C-ordered right factor (BLAS); the rows of the rotation are
    # the in-plane axes and the normal, so the third coordinate is the height above the plane.
    local = (points - origin) @ np.ascontiguousarray(rotation.T)
    heights = np.ascontiguousarray(local[:, 2])
    surface = plane.inliers
    band = float(np.max(np.abs(heights[surface])))  # (a slide moves xy only)
    direction = normal
    if view_dir is not None:
        view = rotation @ (np.asarray(view_dir, dtype=np.float64) / np.linalg.norm(view_dir))
        check_view_angle(view, min_sine=settings.view_min_sine)
        if _nothing_behind(heights, surface, band, view):
            # The surface's points slide along the view onto the plane: a triangulation sensor's range
            # noise lies along its ray, and slid back along it a point lands where the ray met the
            # surface (the paper's Table I protocol: the center's error a tenth of the orthogonal
            # projection's). The center then moves onto its local plane along the view (assemble.to_hole).
            direction = view @ rotation
            surface_local = local[surface]
            surface_local[:, 0] -= surface_local[:, 2] * (view[0] / view[2])
            surface_local[:, 1] -= surface_local[:, 2] * (view[1] / view[2])
            local[surface] = surface_local
    # Column-major: the box tests below read x and y as contiguous columns.
    xy = np.asfortranarray(local[:, :2])
    del local
    clock.start("sampling")
    surface_xy = np.asfortranarray(xy[surface])  # (one copy for the sampling and the grid)
    sampling = estimate_sampling(surface_xy, windows=settings.sampling_windows,
                                 window_points=settings.sampling_window_points, settings=settings)
    gap = sampling.gap
    min_radius = 0.5 * (min_diameter if min_diameter is not None else settings.min_diameter_gaps * gap)
    clock.start("grid")
    grid = occupancy_grid(surface_xy, settings.cell_gaps * gap, max_speck_cells=settings.max_speck_cells)
    return _Frame(rotation=rotation, xy=xy, heights=heights, band=band, direction=direction, sampling=sampling,
                  min_radius=min_radius, surface_xy=surface_xy, grid=grid)


def _nothing_behind(heights, surface, band, view):
    """Whether no more than ``facing.MIN_POINTS`` points stand behind the surface band (``band``, the
    largest surface height) as the sensor sees it: then the band holds the surface alone and its points
    may slide along the view.

    Where the sensor sees behind the surface (a bore's far wall on a tilted scan, a floor, a cone),
    the band also holds the top of what it sees there: slid, the far wall's top lands where its rays
    crossed the hole's opening, up to ``band x tan(tilt)`` inside the hole, and pulls the far edge in
    (on tilted profiler scans with 10 um of noise the centers came out 30 % worse than projected
    orthogonally, and the validation suite's centers were covered in 87 % of cases against 100 %:
    tests/robust/test_robust_view_dir.py). Every point is then projected orthogonally.
    """
    behind = np.count_nonzero(~surface & (heights * np.sign(view[2]) > band))
    return behind <= SEEN_MIN_POINTS


def in_ring(points, center, inner, outer):
    """Whether each of ``points`` (m, 2) lies at a distance in [inner, outer) from ``center``: the
    distance test of :meth:`Scene.within` and :meth:`Neighbourhood.within` (one expression, so that
    both give the same answer to the last bit)."""
    distance = np.hypot(points[:, 0] - center[0], points[:, 1] - center[1])
    return (distance >= inner) & (distance < outer)


class Neighbourhood:
    """The scene as one hole sees it: every attribute and question of its :class:`Scene`, the
    neighbourhood questions (``box``, ``within``, ``count_in_disk``) answered from the points
    gathered once around the hole.

    A hole's measurement asks a dozen questions of the points around it (the surface ring of its
    tangent plane and of the height of a countersink's top, the fringe of its edge, the reflections
    inside it, a boss, the points of its shape, the crop of a curved panel), each of them a pass over
    the whole scan when asked of the scene. Here each of the scene's point arrays (``xy``,
    ``surface_xy``, ``material_xy``, ``above_xy``) is gathered once, when first asked: its points in
    the box of its reach about ``center`` (or farther, when the first question needs it), with their
    squared distances from ``center``. A question whose box lies inside what was gathered is
    answered from those points alone: the points clearly inside or outside its ring by their
    distance from ``center`` (the triangle inequality, with a margin a million times the round-off),
    the few near its circles by the scene's own box test and distance, so that the answer is the
    scene's, the same indices in the same order. Any other question goes to the scene.

    Parameters
    ----------
    scene : Scene
    center : (2,) float
        Plane frame.
    reaches : dict
        Per array's name (``"xy"``, ``"surface_xy"``, ``"material_xy"``, ``"above_xy"``), the
        half side of the box its points are gathered in when first asked (an array not named: as
        far as its first question needs).
    """

    ARRAYS = ("xy", "surface_xy", "material_xy", "above_xy")

    def __init__(self, scene, center, reaches):
        self.scene = scene
        self.center = np.array(center, dtype=np.float64)
        self.reaches = dict(reaches)
        self._gathered = {}  # name -> (indices, their squared distances from center, low, high)

    def __getattr__(self, name):
        if name.startswith("_"):  # (copy and pickle ask before __init__ has run)
            raise AttributeError(name)
        return getattr(self.scene, name)

    def _name_of(self, xy):
        for name in self.ARRAYS:
            if xy is getattr(self.scene, name):
                return name
        return None

    def _gather(self, name, need):
        """The points of the array ``name`` in the box of its reach (at least ``need``) about the
        center, their squared distances from it, and the box's corners ``(low x, low y, high x,
        high y)``."""
        gathered = self._gathered.get(name)
        if gathered is None:
            reach = max(float(self.reaches.get(name, 0.0)), need)
            xy, center = getattr(self.scene, name), self.center
            low, high = center - reach, center + reach
            index = self.scene.box(xy, low, high)
            dx, dy = xy[index, 0] - center[0], xy[index, 1] - center[1]
            corners = (float(low[0]), float(low[1]), float(high[0]), float(high[1]))
            gathered = self._gathered[name] = (index, dx * dx + dy * dy, corners)
        return gathered

    def box(self, xy, low, high):
        """:meth:`Scene.box`, from the gathered points when the box lies inside theirs."""
        name = self._name_of(xy)
        gathered = None if name is None else self._gathered.get(name)
        if gathered is not None:
            index, _, (low_x, low_y, high_x, high_y) = gathered
            if low[0] >= low_x and low[1] >= low_y and high[0] <= high_x and high[1] <= high_y:
                points = xy[index]
                return index[(points[:, 0] >= low[0]) & (points[:, 0] <= high[0])
                             & (points[:, 1] >= low[1]) & (points[:, 1] <= high[1])]
        return self.scene.box(xy, low, high)

    def within(self, xy, center, inner, outer):
        """:meth:`Scene.within`: the same indices, from the gathered points when the box of the disk
        of ``outer`` lies inside theirs."""
        name = self._name_of(xy)
        x, y = float(center[0]), float(center[1])
        at_x, at_y = float(self.center[0]), float(self.center[1])
        shift = ((x - at_x) ** 2 + (y - at_y) ** 2) ** 0.5
        if name is None or not 0.0 < outer < np.inf or not shift < np.inf:
            return self.scene.within(xy, center, inner, outer)
        # The distances carry a few units of round-off of the coordinates' magnitude: far below this.
        margin = 1e-9 * (max(abs(at_x), abs(at_y)) + max(abs(x), abs(y)) + shift + outer)
        index, squared, (low_x, low_y, high_x, high_y) = self._gather(name, shift + outer + 2.0 * margin)
        if not (x - outer >= low_x and y - outer >= low_y and x + outer <= high_x and y + outer <= high_y):
            return self.scene.within(xy, center, inner, outer)
        # A point's distance from ``center`` differs from its distance from self.center by at most
        # ``shift``: certainly out beyond outer + shift or within inner - shift, certainly in between
        # inner + shift and outer - shift; the rest is tested as the scene tests it.
        maybe = squared < (outer + shift + margin) ** 2
        if inner - shift - margin > 0:
            maybe &= squared >= (inner - shift - margin) ** 2
        if outer - shift - margin > 0:
            sure = maybe & (squared < (outer - shift - margin) ** 2)
            if inner > 0:
                sure &= squared >= (inner + shift + margin) ** 2
        else:
            sure = np.zeros(len(index), dtype=bool)
        doubt = np.flatnonzero(maybe ^ sure)  # (sure lies inside maybe)
        if len(doubt):
            # Scene.within's own tests: the box, then the distance.
            points = xy[index[doubt]]
            low, high = center - outer, center + outer
            boxed = ((points[:, 0] >= low[0]) & (points[:, 0] <= high[0])
                     & (points[:, 1] >= low[1]) & (points[:, 1] <= high[1]))
            sure[doubt] = boxed & in_ring(points, center, inner, outer)
        return index[sure]

    def count_in_disk(self, xy, center, radius):
        """:meth:`Scene.count_in_disk`, from the gathered points."""
        return len(self.within(xy, center, 0.0, radius))


def seen_from(scene, measured):
    """The scene as the hole ``measured`` sees it: the :class:`Neighbourhood` its measurement
    gathered (``measured.around``), else ``scene``."""
    around = getattr(measured, "around", None)
    return scene if around is None else around
