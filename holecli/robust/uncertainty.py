"""The standard uncertainty of a hole's center, diameter and normal, from the scan's own points.

Pure: the measurement's pieces in, an :class:`holecli.results.Uncertainty`'s values out.

Edge (center in the plane, diameter)
    The error of an edge estimate comes from where the sampling put the points near the edge and
    from the noise, neither of which the rim points' residuals describe (on a grid or on stripes
    they are not independent, and the residual scatter is mostly the depth of the rim, not noise).
    So the uncertainty is measured the way the sampling bias is (:mod:`holecli.robust.estimators.rim_fit`):
    synthetic holes of known center and radius are cut into the points around the real hole and
    measured by the same estimator as the hole (the rim fit, the lattice's separating circle, the
    largest empty circle); their errors are a sample of the errors the real measurement makes.

    * in-plane center: the root mean square of the synthetic holes' center errors, per coordinate;
    * radius, for an estimator whose bias is corrected by the synthetic holes' mean error (the rim
      fit, the empty circle): the sample standard deviation ``s`` of their radial errors, times
      ``sqrt(1 + 1/k)`` for ``k`` synthetic holes (the hole's own error less the mean of ``k``
      others); for the lattice's separating circle, which is not corrected, their root mean square;
    * for the rim fit, each is at least the least-squares covariance of the rim's circle fit
      (``sigma^2 (J^T J)^-1``, ``sigma`` the rms radial residual): a burr or debris on the real rim
      that the synthetic holes do not have widens it;
    * a countersunk hole's edge is where the cone meets the surface: its center and radius come
      from the least-squares covariance of that cone fit;
    * the real hole's reflections near its edge are given to the synthetic holes too
      (:func:`synthetic_reflections`).

    What the synthetic holes cannot show (the edge of a real hole is not a clean cut through the
    points: range noise seen off the ray, the wall's top, the profiler's lattice) is a *method term*
    added in quadrature, ``a h`` and ``b sigma_h`` per estimator (its ``method_terms``,
    :data:`holecli.robust.estimators.METHOD_TERMS`; ``h`` the point spacing, ``sigma_h`` the
    surface's height noise), as ISO 15530-3 adds the bias seen on
    calibrated workpieces: the scenes of ``benchmarks/uncertainty.py`` with seeds 0-199 are those
    workpieces (the terms that bring each simulator's pooled coverage nearest 95 %), and the
    benchmark's default seeds (1000 on) validate them. The real-scan simulator's range noise lies
    along the ray, partly in the plane, and the rim fit sees it (``b`` of ``rim_fit``); the synthetic
    simulator's noise is along the normal only, so there the same term is wider than needed.

    The empty circle's bias correction is given a Type B term of its own (its ``correction_share``).

    With few synthetic holes the spread is itself uncertain: a ``k``-sample standard deviation is
    widened by the ratio of Student's t to the normal quantile at 95 %, so that ``value +- 2u``
    keeps its coverage.

Surface (center along the normal, normal)
    The local plane's least-squares covariance: the height at the center ``sigma^2 / n`` and the
    slopes ``sigma^2 / sum s^2`` along the ring's principal axes (``sigma`` the plane's rms).

Resolution
    No uncertainty is below the data's own resolution ``q`` (:func:`resolution_uncertainty`): the
    step between the levels a quantised range or float32 storage puts the heights on, the float32
    spacing of stored coordinates, else the round-off floor of the plane fit. On exact data every
    covariance above is 0 (the height at the center of a noise-free scan came out 1.6e-17 mm), and
    the rounding of noise-free data is not random: every point of a face at one true height is
    rounded the same way, so averaging ``n`` of them does not divide its effect by ``sqrt(n)``. Each
    length is given at least ``q / sqrt(12)`` (the standard uncertainty of a value known to a
    resolution ``q``, GUM F.2.2.1), a diameter twice that (two edges), and the normal that height over
    the ring's rms reach along its narrower axis.
"""

from __future__ import annotations

import math

import numpy as np

from holecli.geometry import lsq


def resolution_uncertainty(resolution) -> float:
    """The standard uncertainty of a length known to the data's resolution: ``resolution / sqrt(12)``
    (a rectangular distribution one step wide, GUM F.2.2.1).

    Parameters
    ----------
    resolution : float
        The data's resolution (>= 0).

    Returns
    -------
    float
    """
    return max(float(resolution), 0.0) / math.sqrt(12.0)


#: How many times the surface's noise (along its normal) a fit's residual rms on a sloped face (a
#: countersink's cone, a bore's wall) may be and still be noise: see :func:`with_model_error`.
NOISE_ON_SLOPES = 2.0


def with_model_error(covariance, rms, noise, points):
    """A least-squares covariance widened for the part of the residuals that is not the data's noise.

    :func:`holecli.geometry.revolution.fit_cone` (and ``fit_cylinder``) give ``s^2 (J^T J)^-1``, ``s``
    the fit's residual rms: right when the residuals are independent noise, which averages down as
    ``1 / sqrt(n)``. On a noise-free or very low-noise cloud (a CAD export, a render, a simulated scan)
    the residuals are the surface's departure from the model instead: a tessellated cone's facets (up
    to a sagitta inside the circle through its vertices, 2/3 of it on average), a sampling grid beating
    with them, round-off. That error is one systematic shape shared by all the points, so it does not
    average down with their number, and ``s^2 (J^T J)^-1`` made the countersink's u hundreds of times
    smaller than its error (issue 25).

    The residual variance is split into noise and the excess ``m^2 = max(0, rms^2 - (c noise)^2)``,
    taken as model error, ``noise`` being the surface's own (measured on the flat surface around the
    hole, independent of the fit) and ``c`` = :data:`NOISE_ON_SLOPES` = 2: a scanner's range noise
    lies along its view, so the flat surface sees it times the cosine of the view's tilt and a cone's
    face up to all of it; c = 2 = 1 / cos(60 deg) lets views up to 60 deg off the normal leave their
    noise as noise, while the noise-free clouds this is for leave rms tens to thousands of times
    their surface's noise. The noise keeps its ``(J^T J)^-1`` share; the model error gets that of one
    independent sample, ``n m^2 (J^T J)^-1``: a systematic departure of rms ``m`` moves each parameter
    by as much as one point of that error would on its own (the radius by about ``m``, the angle by
    about ``m`` over the spread of the points along the cone). So::

        covariance * (1 + (n - 1) m^2 / rms^2)

    With noisy data the rms is at most ``c noise`` and the covariance is unchanged.

    Parameters
    ----------
    covariance : (k, k) ndarray or None
        The fit's least-squares covariance.
    rms : float
        The fit's residual rms over its kept points.
    noise : float
        Standard deviation of the surface's points (>= 0), along its normal.
    points : int
        The number of points the fit kept.

    Returns
    -------
    (k, k) ndarray or None
    """
    if covariance is None or not rms or rms <= 0.0:
        return covariance
    excess = (model_error_rms(rms, noise) / float(rms)) ** 2
    return np.asarray(covariance) * (1.0 + (max(int(points), 1) - 1) * excess)


def model_error_rms(rms, noise) -> float:
    """The part ``m = sqrt(max(0, rms^2 - (c noise)^2))`` of a fit's residual rms that the surface's
    noise does not explain (``c`` = :data:`NOISE_ON_SLOPES`; see :func:`with_model_error`).

    Parameters
    ----------
    rms : float
        The fit's residual rms.
    noise : float
        Standard deviation of the surface's points along its normal.

    Returns
    -------
    float
    """
    if not rms or rms <= 0.0:
        return 0.0
    return math.sqrt(max(0.0, float(rms) ** 2 - (NOISE_ON_SLOPES * max(float(noise), 0.0)) ** 2))


def small_sample_factor(degrees_of_freedom) -> float:
    """Student's t over the normal quantile at 97.5 % for ``degrees_of_freedom``.

    Parameters
    ----------
    degrees_of_freedom : int

    Returns
    -------
    float
        ``t_0.975(dof) / z_0.975`` (``scipy.special.stdtrit`` and ``ndtri``): 1.62 at 3 degrees of
        freedom, 1.04 at 30, toward 1.
    """
    from scipy.special import ndtri, stdtrit

    dof = int(degrees_of_freedom)
    if dof < 1:
        raise ValueError(f"degrees_of_freedom must be >= 1, got {degrees_of_freedom}")
    return float(stdtrit(dof, 0.975) / ndtri(0.975))


def circle_fit_covariance(rim_xy, center, radius):
    """Least-squares covariance of a geometric circle fit's ``(cx, cy, r)``.

    Parameters
    ----------
    rim_xy : (m, 2) float
        The points the circle was fitted to, m > 3.
    center : (2,) float
    radius : float

    Returns
    -------
    (3, 3) float or None
        ``sigma^2 (J^T J)^-1`` with ``sigma^2`` the residuals' variance on ``m - 3`` degrees of
        freedom; None for three points or fewer or a singular fit.
    """
    rim_xy = np.asarray(rim_xy, dtype=np.float64)
    if len(rim_xy) <= 3:
        return None
    d = rim_xy - np.asarray(center, dtype=np.float64)
    distance = np.hypot(d[:, 0], d[:, 1])
    distance[distance == 0] = 1e-300
    jacobian = np.column_stack([-d[:, 0] / distance, -d[:, 1] / distance, -np.ones(len(d))])
    return lsq.covariance(jacobian, distance - radius)


def edge_uncertainty(estimator, synthetic, rim_xy, center, radius, spacing, height_noise, cone_covariance=None,
                     diameter_correction=0.0, edge_fringe=0.0, resolution=0.0, radius_range=None, density=None):
    """Standard uncertainties of an edge's in-plane center (per coordinate) and of its diameter.

    Parameters
    ----------
    estimator : holecli.robust.estimators.EdgeEstimator
        What measured the edge: rim fit or empty circle (bias corrected by the synthetic holes' mean
        error), lattice (not corrected) or cone (a countersink's edge from its cone fit); its
        ``method_terms``, ``correction_share``, ``center_floor``, ``bias_corrected``, ``at_least_fit``
        and ``from_cone_covariance`` decide the terms below.
    synthetic : holecli.robust.estimators.SyntheticErrors or None
        The estimator's errors on synthetic holes (None: none could be measured).
    rim_xy : (m, 2) float
        The rim points the hole's circle was fitted to (plane frame).
    center : (2,) float
        The rim circle's center.
    radius : float
        The rim circle's radius (before any correction).
    spacing : float
        The point spacing ``h``.
    height_noise : float
        The surface's height noise ``sigma_h``.
    cone_covariance : (3, 3) float, optional
        For the cone: the covariance of the cone edge's ``(cx, cy, R)``.
    diameter_correction : float, optional
        The sampling-bias correction applied to the diameter (for the estimator's ``correction_share``).
    edge_fringe : float, optional
        Mean radial width ``F`` of the fringe of mixed points along the edge (a laser line of finite
        width; :func:`holecli.robust.measure._edge_fringe`), whose middle was taken as the edge: the
        model of that fringe is uncertain over its width, a Type B term ``F / sqrt(12)`` on the
        diameter (a rectangular distribution, GUM 4.3.7).
    resolution : float, optional
        The data's resolution: the center's uncertainty is at least
        :func:`resolution_uncertainty` of it, the diameter's twice that.
    radius_range : (low, high), optional
        For the lattice: the smallest and largest radius of a circle that separates every bracket
        (:func:`holecli.robust.estimators.lattice.separating_circle`). The points do not say where in
        that range the edge lies: rectangular over it (GUM 4.3.7), ``(high - low) / sqrt(12)`` on the radius,
        which replaces the synthetic holes' spread when it is the larger. The synthetic holes sample
        the ranges of other radii at the same center; this is the hole's own, the wider one on a
        lattice aligned with the hole when a lattice position lies on the edge (a round radius on a
        round pitch): the truth is then at the range's outer end, ``sqrt(3) u`` from the estimate.
    density : float, optional
        The surface's points per unit area ``rho``, for the estimator's ``center_floor`` (the empty
        circle's: the center's uncertainty is at least
        :data:`holecli.robust.estimators.empty_circle.EMPTY_CIRCLE_CENTER` ``/ (rho R)``, that of a
        largest empty circle on random sampling, whose heavy tails the synthetic holes rarely sample).

    Returns
    -------
    center : float
        Of each in-plane coordinate of the center.
    diameter : float
    """
    u_center, u_radius = _sampled_uncertainty(estimator, synthetic, rim_xy, center, radius, cone_covariance)
    (ca, cb), (da, db) = estimator.method_terms["center"], estimator.method_terms["diameter"]
    correction = estimator.correction_share * abs(float(diameter_correction))
    if radius_range is not None:
        u_radius = max(u_radius, abs(float(radius_range[1]) - float(radius_range[0])) / math.sqrt(12.0))
    floor = estimator.center_floor(density, radius)
    if floor:
        u_center = max(u_center, floor)
    least = resolution_uncertainty(resolution)
    return (max(math.hypot(u_center, ca * spacing, cb * height_noise), least),
            max(math.hypot(2.0 * u_radius, da * spacing, db * height_noise, correction,
                           float(edge_fringe) / math.sqrt(12.0)), 2.0 * least))


def _sampled_uncertainty(estimator, synthetic, rim_xy, center, radius, cone_covariance):
    """The center's and the radius's uncertainty from the synthetic holes (or the cone's fit)."""
    fit = circle_fit_covariance(rim_xy, center, radius)
    fit_center = 0.0 if fit is None else math.sqrt(max(float(np.linalg.eigvalsh(fit[:2, :2])[-1]), 0.0))
    fit_radius = 0.0 if fit is None else math.sqrt(max(float(fit[2, 2]), 0.0))
    if estimator.from_cone_covariance and cone_covariance is not None:
        cone_center = math.sqrt(max(float(np.linalg.eigvalsh(cone_covariance[:2, :2])[-1]), 0.0))
        return cone_center, math.sqrt(max(float(cone_covariance[2, 2]), 0.0))
    if synthetic is None or len(synthetic.radial) == 0:
        return fit_center, fit_radius
    k = len(synthetic.radial)
    radial = np.asarray(synthetic.radial, dtype=np.float64)
    shifts = np.asarray(synthetic.center, dtype=np.float64)
    # the center errors: 2k values about zero (no correction is applied to the center)
    spread_center = math.sqrt(float(np.mean(shifts ** 2))) * small_sample_factor(2 * k)
    if not estimator.bias_corrected:
        spread_radius = math.sqrt(float(np.mean(radial ** 2))) * small_sample_factor(k)
    elif k >= 2:
        spread_radius = float(np.std(radial, ddof=1)) * math.sqrt(1.0 + 1.0 / k) * small_sample_factor(k - 1)
    else:
        spread_radius = 0.0
    if not estimator.at_least_fit:
        return spread_center, spread_radius
    return max(spread_center, fit_center), max(spread_radius, fit_radius)


def plane_uncertainty(points, plane, at, resolution=0.0):
    """Standard uncertainties of a local plane's height at ``at`` and of its normal's direction.

    Parameters
    ----------
    points : (n, 3) float
        The points the plane was fitted to (n > 3).
    plane : holecli.geometry.plane.PlaneFit
        Its fit (point, normal, rms).
    at : (3,) float
        Where the height is wanted (the hole's center).
    resolution : float, optional
        The data's resolution: the height's uncertainty is at least :func:`resolution_uncertainty`
        of it, the normal's that height over the points' rms reach along the narrower in-plane axis.

    Returns
    -------
    height : float
        Along the normal, at ``at``.
    normal_rad : float
        Of the normal's direction (radians), along the worse-determined in-plane axis.
    """
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    if n <= 3:
        return float("nan"), float("nan")
    normal = np.asarray(plane.normal, dtype=np.float64)
    centred = points - np.asarray(plane.point, dtype=np.float64)
    in_plane = centred - np.outer(centred @ normal, normal)
    scatter = in_plane.T @ in_plane
    values, vectors = np.linalg.eigh(scatter)
    # the two in-plane axes: the largest two eigenvalues (the third, along the normal, is ~0)
    axes, spread = vectors[:, 1:], values[1:]
    variance = float(plane.rms) ** 2 * n / (n - 3)
    offset = (np.asarray(at, dtype=np.float64) - np.asarray(plane.point, dtype=np.float64)) @ axes
    slopes = variance / np.maximum(spread, 1e-300)
    height = math.sqrt(variance / n + float(np.sum(offset ** 2 * slopes)))
    least = resolution_uncertainty(resolution)
    tilt = least / max(math.sqrt(float(spread.min()) / n), 1e-300)
    return max(height, least), max(math.sqrt(float(slopes.max())), tilt)


def synthetic_reflections(inside_count, inner_radius, center, radii, band):
    """Reflections for synthetic holes like those the real hole has near its edge.

    A reflection (a speck of surface points inside the hole) deep inside the hole is removed with the
    other specks; one within a cell or two of the edge joins the material and pulls the edge in, by
    up to its depth. The synthetic holes that measure a hole's sampling bias and uncertainty must see
    as many: each gets points uniform in the band ``[r - band, r]`` inside its edge at the density of
    the real hole's surface points deeper inside (``inside_count`` within ``inner_radius``). The
    positions are drawn with fixed seeds (one per synthetic hole): a result does not depend on global
    random state.

    Parameters
    ----------
    inside_count : int
        Surface points of the real hole within ``inner_radius`` of its center.
    inner_radius : float
        > 0.
    center : (2,) float
    radii : sequence of float
        The synthetic holes' radii.
    band : float
        Depth inside the edge within which a reflection joins the material.

    Returns
    -------
    list of (m, 2) float or None
        Per synthetic hole its reflections; None when the real hole has none.
    """
    if inside_count <= 0 or inner_radius <= 0:
        return None
    density = inside_count / (math.pi * inner_radius ** 2)
    center = np.asarray(center, dtype=np.float64)
    out = []
    for i, radius in enumerate(radii):
        rng = np.random.default_rng(i)
        low = max(radius - band, 0.0)
        count = int(rng.poisson(density * math.pi * (radius ** 2 - low ** 2)))
        rho = np.sqrt(rng.uniform(low ** 2, radius ** 2, count))
        phi = rng.uniform(0.0, 2.0 * math.pi, count)
        out.append(center + np.column_stack([rho * np.cos(phi), rho * np.sin(phi)]))
    return out
