"""Plane fits: the paper's SVD fit of all points, and a robust fit of the dominant surface."""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from holecli.errors import PointsError
from holecli.geometry.kernels import orient_normal, robust_sigma
from holecli.settings import DEFAULT_SETTINGS

__all__ = ["PlaneFit", "fit_plane_robust", "fit_plane_scatter", "fit_plane_svd", "orient_normal"]

# Relative round-off floor of a plane's noise (a multiple of the magnitude of the surface's own
# coordinates): far below any real noise, far above float error, so that exact data keeps a band.
ROUND_OFF = 1e-9
# Smallest sine of the angle between the two edges of a point triple that still defines a plane.
COLLINEAR_SINE = 1e-12
# Discrete height levels (see :func:`level_step`): a level holds at least LEVEL_SHARE of the heights
# looked at, is at most LEVEL_WIDTH of the step wide, the levels hold at least LEVEL_HELD of the
# heights between the outermost ones, and the step is at most LEVEL_LIMIT of the face's extent (a
# float32 coordinate resolves 6e-8 of its magnitude, a profiler's range quantum is ~1e-5 of its
# range; a face a thousandth of the field above another is a step of the part, not a quantum).
LEVEL_SHARE = 0.05
LEVEL_WIDTH = 0.5
LEVEL_HELD = 0.9
LEVEL_LIMIT = 1e-3
LEVEL_MIN_HEIGHTS = 50


@dataclass(frozen=True, eq=False)
class PlaneFit:
    """A fitted plane.

    Attributes
    ----------
    point : (3,) float
        Centroid of the points fitted (a point on the plane).
    normal : (3,) float
        Unit normal, oriented by :func:`orient_normal`.
    rms : float
        Root mean square of the fitted points' distances to the plane.
    inliers : (n,) bool or None
        Which points the plane was fitted to (None: all of them).
    major : (3,) float or None
        Unit in-plane direction along which the fitted points spread most (its sign arbitrary), when
        the fit computed it.
    resolution : float
        The smallest height difference the data resolve about the plane (:func:`fit_plane_robust`):
        the step between the discrete levels its inliers' heights sit on (a quantised range, float32
        storage), else the round-off floor; 0 when the fit did not compute it.
    hidden : tuple of (normal, offset, half_width)
        The faces :func:`fit_plane_robust` found hidden behind this one along its view (``n . x =
        offset``, points within ``half_width`` of it); empty without a view.
    """

    point: np.ndarray
    normal: np.ndarray
    rms: float
    inliers: np.ndarray | None = None
    major: np.ndarray | None = None  # (3,) in-plane direction of largest spread of the fitted points
    resolution: float = 0.0
    # (normal, offset, half-width) of each face hidden behind the plane along the view (fit_plane_robust)
    hidden: tuple = ()

    @property
    def inlier_count(self) -> int:
        """Number of inliers, -1 when ``inliers`` is None."""
        return -1 if self.inliers is None else int(self.inliers.sum())


def _centred(points):
    """The points as an (n >= 3, 3) float64 array, their centroid and the centred points."""
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 3:
        raise PointsError(f"a plane needs an (n >= 3, 3) array, got shape {points.shape}")
    centroid = points.mean(axis=0)
    return points, centroid, points - centroid


def fit_plane_svd(points):
    """Least-squares plane through ``points`` by the SVD of the centred coordinates (paper, sec. 2.2).

    Parameters
    ----------
    points : (n, 3) float
        At least three points, not all on one line.

    Returns
    -------
    PlaneFit
        Centroid, unit normal (right-singular vector of the smallest singular value, oriented by
        :func:`orient_normal`) and rms distance.
    """
    points, centroid, centred = _centred(points)
    # Never form the n x n U of the paper's Eq. (5): the 3 x 3 right factor is all that is needed.
    _, singular, vt = np.linalg.svd(centred, full_matrices=False)
    if singular[1] <= 1e-12 * max(singular[0], 1e-300):
        raise PointsError("the points are collinear (or coincide): no plane is defined")
    normal = orient_normal(vt[2])
    rms = float(singular[2] / np.sqrt(len(points)))
    return PlaneFit(point=centroid, normal=normal, rms=rms)


def fit_plane_scatter(points):
    """Least-squares plane from the eigenvectors of the 3 x 3 scatter matrix of the centred points.

    The same plane as :func:`fit_plane_svd`, in one pass over the points instead of an SVD of the
    whole (n, 3) array: the fast path for large clouds. ``rms`` is computed from the residuals.

    Parameters
    ----------
    points : (n, 3) float
        At least three points, not all on one line.

    Returns
    -------
    PlaneFit
        Centroid, unit normal (eigenvector of the smallest eigenvalue, oriented by
        :func:`orient_normal`), rms distance and ``major`` (eigenvector of the largest).
    """
    points, centroid, centred = _centred(points)
    scatter = centred.T @ centred
    values, vectors = np.linalg.eigh(scatter)
    if values[1] <= 1e-24 * max(values[2], 1e-300):
        raise PointsError("the points are collinear (or coincide): no plane is defined")
    normal = orient_normal(vectors[:, 0])
    # From the residuals, not from the smallest eigenvalue: that carries the round-off of the largest.
    rms = float(np.sqrt(np.mean((centred @ normal) ** 2)))
    return PlaneFit(point=centroid, normal=normal, rms=rms, major=vectors[:, 2])


def _round_off_floor(points, origin):
    """Noise floor for a plane through ``points`` (given relative to ``origin``): ROUND_OFF times the
    magnitude of their world coordinates and of their spread.

    From the points' median and the 90th percentile of their offsets from it, so that a few points
    far away (a stray point at 1e8) do not raise it: a floor from the extent of the whole cloud
    widens the band until bore-wall and countersink points count as surface.
    """
    center = np.median(points, axis=0)
    reach = np.percentile(np.abs(points - center), 90, axis=0)
    return ROUND_OFF * (float(np.max(np.abs(center + origin))) + 2.0 * float(np.max(reach)))


def _extent(points):
    """Extent of ``points`` in the plane: twice the 90th percentile of their offsets from their median
    (the largest over the axes), so that a few far points do not set it."""
    center = np.median(points, axis=0)
    return 2.0 * float(np.max(np.percentile(np.abs(points - center), 90, axis=0)))


def level_step(heights, tolerance, largest):
    """The step between the discrete levels that ``heights`` sit on near zero, or 0 when they do not.

    A noise-free range quantised by the sensor, or written in float32, puts a face's heights about its
    plane on a few levels a quantum apart (a noise-free parallel-ray scan at 100 mm: 7.6e-6 mm, with
    half the points on one level): their quantile, and their median absolute value, is then 0 and
    says nothing of where the face's points lie. The heights within ``2 largest`` of zero are cut into
    runs wherever two consecutive ones (sorted) are more than ``tolerance`` apart; they sit on levels
    when the runs holding at least :data:`LEVEL_SHARE` of them are at least two, each at most
    :data:`LEVEL_WIDTH` of the smallest step between their centers wide, hold at least
    :data:`LEVEL_HELD` of the heights between the outermost, and that step is at most ``largest``.
    Smooth heights (noise, the round-off of fan rays) make one run, or many small ones: 0.

    Parameters
    ----------
    heights : (n,) float
        Signed distances to a plane.
    tolerance : float
        Spread of one level (the round-off floor).
    largest : float
        Largest step taken for a quantum.

    Returns
    -------
    float
    """
    heights = np.asarray(heights, dtype=np.float64)
    values = np.sort(heights[np.abs(heights) <= 2.0 * largest])
    if len(values) < LEVEL_MIN_HEIGHTS:
        return 0.0
    cuts = np.flatnonzero(np.diff(values) > tolerance) + 1
    starts, ends = np.r_[0, cuts], np.r_[cuts, len(values)]
    big = (ends - starts) >= LEVEL_SHARE * len(values)
    if np.count_nonzero(big) < 2:
        return 0.0
    low, high = values[starts[big]], values[ends[big] - 1]
    step = float(np.min(np.diff(0.5 * (low + high))))
    if not 0.0 < step <= largest or float(np.max(high - low)) > LEVEL_WIDTH * step:
        return 0.0
    between = ends[big][-1] - starts[big][0]
    return step if int(np.sum(ends[big] - starts[big])) >= LEVEL_HELD * between else 0.0


def _hypothesis_normals(sample, rng, count):
    triples = rng.integers(0, len(sample), size=(count, 3))
    a, b, c = sample[triples[:, 0]], sample[triples[:, 1]], sample[triples[:, 2]]
    normals = np.cross(b - a, c - a)
    lengths = np.linalg.norm(normals, axis=1)
    # Each triple against its own edges (the sine of its angle), not against the largest triple: one
    # triple through a far point would otherwise discard every well-shaped triple of the surface.
    edges = np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - a, axis=1)
    good = (lengths > COLLINEAR_SINE * edges) & (lengths > 0.0)
    return a[good], normals[good] / lengths[good, None]


def _faces(sample, rng, hypotheses, quantile, clip, origin, max_faces):
    """Planar faces in a sample, one after the other: (count, normal, offset, sigma, step) each.

    Each round takes the RANSAC hypothesis with the smallest ``quantile`` of absolute residuals
    (least quantile of squares) over the points not yet assigned, sets its noise from that quantile
    (never below the round-off floor of the points within it), and removes its points (within
    ``clip`` sigma). Taking faces one by one lets a noisy main surface win over a flatter but smaller
    side face, which a single threshold would favour. Where the heights about the face sit on discrete
    levels (:func:`level_step`), the noise is at least the step between them: the quantile of a
    noise-free quantised face is 0, and a band of a fraction of a step would cut the face into strips.
    """
    # |r| at quantile q of a normal distribution is sigma * z((1 + q) / 2): 0.385 sigma for q = 0.3.
    z = NormalDist().inv_cdf((1.0 + quantile) / 2.0)
    faces = []
    remaining = sample
    for _ in range(max_faces):
        if len(remaining) < max(10, len(sample) // 10):
            break
        anchors, normals = _hypothesis_normals(remaining, rng, hypotheses)
        if len(normals) == 0:
            break
        offsets = np.sum(normals * anchors, axis=1)
        residuals = np.abs(normals @ remaining.T - offsets[:, None])
        k = max(2, int(quantile * len(remaining)))
        quantiles = np.partition(residuals, k, axis=1)[:, k]
        best = int(np.argmin(quantiles))
        floor = _round_off_floor(remaining[residuals[best] <= quantiles[best]], origin)
        sigma = max(float(quantiles[best]) / z, floor)
        step = level_step(remaining @ normals[best] - offsets[best], floor, LEVEL_LIMIT * _extent(remaining))
        sigma = max(sigma, step)
        members = residuals[best] <= clip * sigma
        faces.append((int(members.sum()), normals[best], float(offsets[best]), sigma, step, remaining[members]))
        remaining = remaining[~members]
    return faces


# seen_face: a face is turned toward the sensor when its normal is within this angle (degrees) of the
# view's line (the validation suite views faces up to 40 deg off their normal; a part's sides and a bore
# wall are at ~90 deg).
SEEN_FACE_MAX_DEG = 60.0
# seen_face: of the faces turned toward the sensor, those holding at least this share of the largest
# one's points may be the surface; the one nearest the sensor is taken (a sampled sheet's top and bottom
# hold about the same number of points; a boss's top or a counterbore's floor holds far fewer).
SEEN_FACE_SHARE = 0.8
# seen_face: a face is hidden behind a nearer one when at least this share of its points lie under that
# face's points along the view (within HIDDEN_SPACINGS of the nearer face's own median spacing, across
# the view). A sensor never records a face it cannot see, so only clouds sampled from a whole mesh hold
# one (a sheet's bottom under its top); a floor seen around or through a part lies mostly clear of it.
HIDDEN_SHARE = 0.5
HIDDEN_SPACINGS = 2.0
# hidden_faces: a hidden face's band (clip sigma) is at most this share of its distance behind the
# surface; a wider one is the sample's leftovers (walls, cones), not a face, and its points are kept.
HIDDEN_BAND_SHARE = 0.5


def _turned(faces, view):
    """The unit ``view`` and the faces turned toward a sensor looking along it (normal within
    ``SEEN_FACE_MAX_DEG`` of the view's line)."""
    view = np.asarray(view, dtype=np.float64) / np.linalg.norm(view)
    cos_limit = math.cos(math.radians(SEEN_FACE_MAX_DEG))
    return view, [face for face in faces if abs(float(face[1] @ view)) >= cos_limit]


def _hidden(face, nearer, view):
    """Whether ``face``'s member points lie mostly under ``nearer``'s along ``view`` (nearer the sensor)."""
    from scipy.spatial import cKDTree

    behind, front = face[5], nearer[5]
    if len(behind) == 0 or len(front) < 3:
        return False
    across = np.linalg.svd(view[None, :])[2][1:]  # two unit vectors across the view
    front_xy, behind_xy = front @ across.T, behind @ across.T
    tree = cKDTree(front_xy)
    spacing = float(np.median(tree.query(front_xy, k=2)[0][:, 1]))
    distance, index = tree.query(behind_xy, distance_upper_bound=HIDDEN_SPACINGS * spacing)
    under = np.isfinite(distance)
    under[under] = (front[index[under]] - behind[under]) @ view < 0  # the front point is met first
    return float(np.mean(under)) >= HIDDEN_SHARE


def _hidden_faces(faces, chosen, view, clip, origin):
    """(normal, offset, half_width) of the faces turned toward the sensor hidden behind ``chosen``
    (:func:`_hidden`), the offsets from the coordinates' own origin."""
    view, turned = _turned(faces, view)

    def thin(face):
        # A face, not the leftovers of the sample (walls and cones, whose quantile makes a band of
        # millimetres): its band lies behind the surface's, clear of everything between.
        behind = np.median((face[5] - np.mean(chosen[5], axis=0)) @ view) if len(face[5]) else 0.0
        return clip * face[3] < HIDDEN_BAND_SHARE * behind

    return tuple((face[1], face[2] + float(face[1] @ origin), clip * face[3]) for face in turned
                 if face is not chosen and len(face) > 5 and len(chosen) > 5
                 and _hidden(face, chosen, view) and thin(face))


def hidden_points(points, plane, view):
    """Which ``points`` lie on a face hidden behind ``plane`` along ``view`` (``plane.hidden``) and behind
    the plane: points a sensor looking along ``view`` cannot have recorded (a sampled sheet's bottom
    under its top), which only a cloud sampled from a whole mesh holds."""
    points = np.asarray(points, dtype=np.float64)
    hidden = np.zeros(len(points), dtype=bool)
    if not plane.hidden:
        return hidden
    view = np.asarray(view, dtype=np.float64) / np.linalg.norm(view)
    behind = (points - plane.point) @ view > 0  # farther along the view than the plane
    for normal, offset, half_width in plane.hidden:
        hidden |= np.abs(points @ normal - offset) <= half_width
    return hidden & behind if plane.inliers is None else hidden & behind & ~plane.inliers


def _seen_face(faces, view):
    """The face of ``faces`` ((count, normal, offset, sigma, step[, members]), offsets from a common origin)
    that a sensor looking along ``view`` sees: among the faces turned toward it (normal within
    ``SEEN_FACE_MAX_DEG`` of the view's line) and, where the faces carry their member points, not hidden
    behind another turned face (:func:`_hidden`: a sampled sheet's bottom under its top, whose share of
    the points is no guide when the top has large holes), of those holding at least ``SEEN_FACE_SHARE``
    of the largest one's points, the one nearest the sensor (where the view's line through the origin
    meets it first). No face turned toward it: the largest face."""
    view, turned = _turned(faces, view)
    if not turned:
        return max(faces, key=lambda face: face[0])
    if all(len(face) > 5 for face in turned):
        seen = [face for face in turned
                if not any(other is not face and _hidden(face, other, view) for other in turned)]
        turned = seen or turned
    most = max(face[0] for face in turned)
    contenders = [face for face in turned if face[0] >= SEEN_FACE_SHARE * most]
    # The view's line through the origin, origin + t view, meets the face n . x = offset at t = offset / (n . view).
    return min(contenders, key=lambda face: face[2] / float(face[1] @ view))


# Without a view, the side a sensor is assumed on when the data do not tell (the file's +z, as the sign
# convention of normals: holecli.geometry.frame.orient_normal).
ASSUMED_VIEW = (0.0, 0.0, -1.0)
# _dominant_face: faces within this angle of the largest are the sides of one sheet; a face across it
# (the other flange of an angle, a wall) is another surface, and the larger one stays the scan's.
SHEET_SIDES_MAX_DEG = 10.0


def _dominant_face(faces):
    """The face of ``faces`` a scan is of when no view is given: the one holding the most points, unless
    other faces parallel to it (within :data:`SHEET_SIDES_MAX_DEG`) hold nearly as many
    (``SEEN_FACE_SHARE`` of it: the top and bottom of a sheet sampled whole, from CAD), when the
    sensor is taken to be above the file's +z (:data:`ASSUMED_VIEW`, :func:`_seen_face` among those
    faces). A scan's own surface holds far more points than any other
    face it shows (a floor, a boss's top, a bore wall), so only clouds sampled from every side meet the
    tie; those whose faces all stand across +z keep the largest."""
    contenders = _sheet_sides(faces)
    if len(contenders) == 1:
        return contenders[0]
    return _seen_face(contenders, ASSUMED_VIEW)


def _sheet_sides(faces):
    """The largest face of ``faces`` and those parallel to it (within :data:`SHEET_SIDES_MAX_DEG`) holding
    nearly as many points (``SEEN_FACE_SHARE`` of it), the largest first."""
    largest = max(faces, key=lambda face: face[0])
    cos_limit = math.cos(math.radians(SHEET_SIDES_MAX_DEG))
    return [largest] + [face for face in faces if face is not largest and face[0] >= SEEN_FACE_SHARE * largest[0]
                        and abs(float(face[1] @ largest[1])) >= cos_limit]


def fit_plane_robust(points, *, rng=0, sample=None, hypotheses=None, quantile=None, clip=None, max_rounds=None,
                     refine_sample=None, max_faces=None, view=None, settings=DEFAULT_SETTINGS.plane):
    """Plane of the dominant surface, ignoring bore-wall, countersink, inside-hole and outlier points.

    RANSAC hypotheses from point triples are scored by the ``quantile`` of their absolute residuals
    (least quantile of squares: no threshold to choose); faces are taken one after the other from a
    sample, each with its own noise, and the face holding the most points wins (the dominant face
    when the scan holds several). The plane is then refined by least squares (:func:`fit_plane_scatter`)
    on the points within ``clip`` robust standard deviations (1.4826 * MAD) until the inlier set
    stops changing: on a subsample of ``refine_sample`` points first, then on all points.

    Noise-free data leaves the noise at a floor: the round-off floor (a multiple of the magnitude of
    the coordinates, far below any real noise), or, where the heights about the plane sit on discrete
    levels (a quantised range, float32 storage: :func:`level_step`), the step between the levels. The
    step itself, not its standard deviation ``step / sqrt(12)``: a face's true height is one value,
    not one spread uniformly over a step, and the roundings of a chain (range, then coordinates) put
    its points a level or two either side of the nearest; ``clip`` steps keep them with room, a band of
    ``clip / sqrt(12)`` steps (1.15 at clip 4) would keep the next level by a hair, whatever the
    plane's offset between levels.

    Every tunable not given is the field of ``settings`` named in brackets.

    Parameters
    ----------
    points : (n, 3) float
    rng : numpy.random.Generator or int
        Random source for the hypotheses (results do not depend on it beyond round-off).
    sample : int
        Points drawn for the RANSAC faces (``ransac_sample``).
    hypotheses : int
        Point triples tried per face (``ransac_hypotheses``).
    quantile : float
        Quantile of the absolute residuals that scores a hypothesis, in (0, 1) (``ransac_quantile``).
    clip : float
        Inlier band, in robust standard deviations of the residuals (``plane_clip``).
    max_rounds : int
        Most refits on the subsample (``plane_refine_rounds``).
    refine_sample : int
        Size of the subsample refitted (``plane_refine_sample``).
    max_faces : int
        Most faces taken from the RANSAC sample (``plane_max_faces``).
    view : (3,) float, optional
        The sensor's viewing direction (into the part). Given, the face is the one the sensor sees
        rather than the one holding the most points (see :func:`_seen_face`): a cloud sampled from a
        whole CAD mesh holds the bottom face, the sides and the bore walls as well as the top.
        Without it, faces holding alike many points are told apart as if the sensor were above the
        file's +z (:func:`_dominant_face`).
    settings : holecli.settings.PlaneSettings or RobustSettings
        Source of the tunables not given (default: :data:`holecli.settings.DEFAULT_SETTINGS`'s).

    Returns
    -------
    PlaneFit
        With ``inliers`` set, ``rms`` the rms distance of the inliers and ``resolution`` the step
        between the levels of their heights, or the round-off floor where they are not on levels.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 3:
        raise PointsError(f"a plane needs an (n >= 3, 3) array, got shape {points.shape}")
    sample = settings.ransac_sample if sample is None else sample
    hypotheses = settings.ransac_hypotheses if hypotheses is None else hypotheses
    quantile = settings.ransac_quantile if quantile is None else quantile
    clip = settings.plane_clip if clip is None else clip
    max_rounds = settings.plane_refine_rounds if max_rounds is None else max_rounds
    refine_sample = settings.plane_refine_sample if refine_sample is None else refine_sample
    max_faces = settings.plane_max_faces if max_faces is None else max_faces
    rng = np.random.default_rng(rng)
    # Work relative to a point among the cloud's (the median of a thousand of them, so a stray point
    # far away is not it) without a centred copy of all the points; only samples are copied.
    origin = np.median(points[::max(1, len(points) // 1000)], axis=0)

    def sample_of(size):
        chosen = rng.choice(len(points), size=size, replace=False) if len(points) > size else slice(None)
        return points[chosen] - origin

    subset = sample_of(sample)
    faces = _faces(subset, rng, hypotheses, quantile, clip, origin, max_faces)
    if not faces:
        raise PointsError("the points are collinear (or coincide): no plane is defined")
    # The dominant face is the one that holds the most points, whatever its noise; with a view, the
    # one the sensor sees (see _seen_face); without one, of faces holding alike many points, the one a
    # sensor above the file's +z would see (_dominant_face).
    chosen = _dominant_face(faces) if view is None else _seen_face(faces, view)
    _, normal, offset, sigma, face_step = chosen[:5]
    if view is not None:
        hidden = _hidden_faces(faces, chosen, view, clip, origin)
    else:
        # Without a view, only a sheet sampled on both sides (a tie of _dominant_face) has a face hidden
        # behind the one taken, as a sensor above the file's +z would see them.
        sides = _sheet_sides(faces)
        hidden = _hidden_faces(sides, chosen, ASSUMED_VIEW, clip, origin) if len(sides) > 1 else ()
    # Iterate on a subsample (a million points need not be refitted ten times), then settle the
    # inlier set on every point: the result depends on the subsample only through points exactly at
    # the band's edge.
    refine = sample_of(refine_sample)
    inliers = np.abs(refine @ normal - offset) <= clip * sigma
    # The noise floor from the surface's own points, never from the extent of the whole cloud.
    # The step between the levels the face's heights sit on (found about its exact RANSAC plane: the
    # least-squares plane of quantised heights tilts by a fraction of a step over the face and
    # blurs them) is a property of the data: it stays a floor.
    floor = _round_off_floor(refine[inliers], origin) if inliers.sum() >= 3 else 0.0
    floor = max(floor, face_step)
    largest = LEVEL_LIMIT * _extent(refine[inliers]) if inliers.sum() >= 3 else 0.0
    for _ in range(max_rounds):
        if inliers.sum() < 3:
            raise PointsError("no plane holds enough of the points")
        fit = fit_plane_scatter(refine[inliers])
        normal, offset = fit.normal, float(fit.normal @ fit.point)
        distance = refine @ normal - offset
        floor = max(floor, level_step(distance, floor, largest))
        sigma = max(robust_sigma(distance[inliers]), floor)
        new_inliers = np.abs(distance) <= clip * sigma
        if np.array_equal(new_inliers, inliers):
            break
        inliers = new_inliers
    inliers = np.abs(points @ normal - (offset + float(normal @ origin))) <= clip * sigma
    if inliers.sum() < 3:
        raise PointsError("no plane holds enough of the points")
    fit = fit_plane_scatter(points[inliers])
    return PlaneFit(point=fit.point, normal=fit.normal, rms=fit.rms, inliers=inliers, major=fit.major,
                    resolution=floor, hidden=hidden)
