"""How the surface was sampled: point spacing, gap scale and scan-line structure.

Measured in a few local windows of the projected surface points, each triangulated on its own (a
global triangulation of 10^6 points would cost seconds). The windows sit at fixed quantiles of the
coordinates, so the result does not depend on the order of the points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import QhullError, cKDTree

from holecli.errors import PointsError
from holecli.geometry.kernels import box_indices, circumradii, triangulate
from holecli.settings import DEFAULT_SETTINGS


@dataclass(frozen=True, eq=False)
class Sampling:
    """Sampling statistics of the surface points.

    Attributes
    ----------
    spacing : float
        Median nearest-neighbour distance (h), file units.
    gap : float
        90th percentile of the empty-circle (Delaunay circumcircle) radii in the material (g).
    line_direction : (2,) float or None
        Unit in-plane direction of the scan lines, when the points lie on stripes.
    line_pitch : float or None
        Distance between neighbouring scan lines, when striped.
    lattice : bool
        True when the points sit on a regular square lattice of pitch ``spacing`` (a grid).
    lattice_axes : tuple of (2,) float
        Unit directions along which points follow each other at ``spacing`` (the scan-line direction
        of stripes, the two axes of a grid; empty for irregular sampling).
    """

    spacing: float
    gap: float
    line_direction: np.ndarray | None = None
    line_pitch: float | None = None
    lattice: bool = False
    lattice_axes: tuple = ()

    @property
    def period(self):
        """Across-line period of a regular pattern (line pitch, or grid spacing), None if irregular.

        Returns
        -------
        float or None
        """
        if self.line_pitch is not None:
            return self.line_pitch
        return self.spacing if self.lattice else None


def _line_pitch(window, direction, spacing, neighbours):
    """Pitch of the scan lines across ``direction``: the median, over the points, of the across-line
    offset of the nearest neighbour on another line (offset above half a spacing).

    Unlike clustering the across-line coordinates of a whole window, this holds when the estimated
    direction is a few degrees off (noise), since only offsets to near neighbours are used.
    """
    if len(window) <= neighbours:
        return None
    distance, index = cKDTree(window).query(window, k=neighbours + 1)
    vectors = window[index[:, 1:]] - window[:, None, :]
    across = np.abs(vectors @ np.array([-direction[1], direction[0]]))
    # The nearest neighbour (by distance) that is not on the point's own line.
    distance = np.where(across > 0.5 * spacing, distance[:, 1:], np.inf)
    nearest = np.argmin(distance, axis=1)
    found = np.isfinite(distance[np.arange(len(window)), nearest])
    if found.sum() < 0.5 * len(window):
        return None
    return float(np.median(across[np.arange(len(window)), nearest][found]))


def estimate_sampling(xy, windows=None, window_points=None, *, settings=DEFAULT_SETTINGS.sampling):
    """Measure spacing, gap scale and scan-line structure of 2D surface points.

    Parameters
    ----------
    xy : (n, 2) float
        Surface points projected onto their plane.
    windows : int, optional
        Number of local windows (placed at coordinate quantiles); default ``settings.sampling_windows``.
    window_points : int, optional
        Target number of points per window; default ``settings.sampling_window_points``.
    settings : holecli.settings.SamplingSettings or RobustSettings
        Source of the thresholds ``sampling_gap_percentile``, ``sampling_inner_fraction``,
        ``sampling_line_coherence``, ``sampling_min_pitch_spacings``, ``sampling_lattice_coherence``,
        ``sampling_pitch_neighbours`` and ``sampling_window_offset_sd``, and of the defaults above.

    Returns
    -------
    Sampling
    """
    n = len(xy)
    if n < 10:
        raise PointsError(f"too few surface points to measure the sampling: {n}")
    windows = settings.sampling_windows if windows is None else windows
    window_points = settings.sampling_window_points if window_points is None else window_points
    # Column-major: the window box tests read x and y as contiguous columns, a few times each.
    columns = np.asfortranarray(xy)
    x, y = columns[:, 0], columns[:, 1]
    # Window positions from the mean and standard deviation of the coordinates (two cheap passes,
    # where quantiles would partition a million points): on a uniformly covered patch, mean -+ 0.7 sd
    # (sampling_window_offset_sd) are about its 30th and 70th percentiles and mean -+ 1.56 sd its 5th
    # and 95th.
    mean = np.array([x.mean(), y.mean()])
    spread = np.array([x.std(), y.std()])
    area = max(float(np.prod(3.12 * spread)) / 0.81, 1e-300)
    density = n / area  # about a lower bound: the scan need not fill its bounding box
    half = 0.5 * np.sqrt(window_points / density)
    # Windows in pairs placed symmetrically about the mean (the same set after a half turn of the
    # frame), off-centre first: a scan is often centred on its hole.
    pairs = [((-1, -1), (1, 1)), ((-1, 1), (1, -1)), ((0, -1), (0, 1)), ((-1, 0), (1, 0)), ((0, 0),)]
    spacings, gaps, angles = [], [], []
    windows_used = []
    enough = max(10, min(window_points // 2, n // 2))
    chosen, largest = [], None
    for pair in pairs:
        centers = [mean + settings.sampling_window_offset_sd * spread * np.array(offset) for offset in pair]
        indices = [box_indices(columns, center - half, center + half) for center in centers]
        for index in indices:
            if largest is None or len(index) > len(largest):
                largest = index
        if all(len(index) >= enough for index in indices):
            chosen.extend(indices)
            if len(chosen) >= max(1, windows):
                break
    if not chosen:
        chosen = [largest]
    for index in chosen:
        if len(index) < 10:
            continue
        window = xy[index]
        tree = cKDTree(window)
        distance, neighbour = tree.query(window, k=2)
        nn = distance[:, 1]
        positive = nn > 0
        if positive.sum() < 5:
            continue
        spacings.append(float(np.median(nn[positive])))
        vectors = window[neighbour[:, 1]] - window
        angles.append(np.arctan2(vectors[positive, 1], vectors[positive, 0]))
        try:
            triangulation = triangulate(window)
        except QhullError:
            continue
        radius, center_xy = circumradii(window, triangulation.simplices)
        inner = np.all(np.abs(center_xy - window.mean(axis=0)) <= settings.sampling_inner_fraction
                       * np.ptp(window, axis=0), axis=1)
        inner &= np.isfinite(radius)
        if inner.sum() >= 5:
            gaps.append(float(np.percentile(radius[inner], settings.sampling_gap_percentile)))
        windows_used.append(window)
    if not spacings or not gaps:
        raise PointsError("cannot measure the point spacing: the surface points are degenerate")
    spacing = float(np.median(spacings))
    gap = float(np.median(gaps))
    # Scan lines: nearest neighbours mostly along one direction (doubled angles average to |m| ~ 1).
    doubled = np.exp(2j * np.concatenate(angles))
    mean = doubled.mean()
    direction = pitch = None
    lattice = False
    if abs(mean) > settings.sampling_line_coherence:
        theta = np.angle(mean) / 2.0
        candidate = np.array([np.cos(theta), np.sin(theta)])
        pitches = [p for p in (_line_pitch(w, candidate, spacing, settings.sampling_pitch_neighbours)
                               for w in windows_used) if p]
        if pitches and np.median(pitches) > settings.sampling_min_pitch_spacings * spacing:
            direction, pitch = candidate, float(np.median(pitches))
    axes = () if direction is None else (direction,)
    quadrupled = np.mean(doubled**2)
    if direction is None and abs(quadrupled) > settings.sampling_lattice_coherence:
        # Nearest neighbours along two perpendicular directions: a square grid.
        lattice = True
        theta = np.angle(quadrupled) / 4.0
        axes = (np.array([np.cos(theta), np.sin(theta)]), np.array([-np.sin(theta), np.cos(theta)]))
    return Sampling(spacing=spacing, gap=gap, line_direction=direction, line_pitch=pitch, lattice=lattice,
                    lattice_axes=axes)
