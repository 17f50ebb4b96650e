"""Statistical process control of a characteristic over a lot: Shewhart control charts, Western Electric
run rules and process capability.

- :func:`individuals_charts`: the individuals (I) and moving-range (MR, span 2) charts of values in
  measurement order, the charts of drilling order, where drill wear shows. Within sigma = MRbar / d2(2)
  (d2(2) = 1.128); I limits mean +- 3 sigma; MR limits 0 and D4(2) MRbar (D4(2) = 3.267).
- :func:`xbar_r_charts`: the X-bar and range charts of subgroups of 2 to 25 values (the holes of one
  part, say). Within sigma = Rbar / d2(n); X-bar limits grand mean +- 3 sigma / sqrt(n) (= A2 Rbar);
  R limits D3 Rbar and D4 Rbar.
- :func:`western_electric`: the four Western Electric rules on a plotted statistic; the I and X-bar
  charts carry all four, the MR and R charts rule 1 only (points beyond their limits).
- :func:`capability`: Cp, Cpk (within sigma), Pp, Ppk (overall sample standard deviation) with the
  confidence intervals R's qcc (``processCapability``) gives.

:data:`CONSTANTS` holds the control chart constants for n = 2..25: d2 (the mean range of n standard
normal values) as the tables print it to three decimals, d3 (the standard deviation of that range) to
seven, as qcc tabulates both; D3 = max(0, 1 - 3 d3/d2), D4 = 1 + 3 d3/d2, A2 = 3 / (d2 sqrt(n)) and
c4 = sqrt(2/(n-1)) Gamma(n/2) / Gamma((n-1)/2) are derived from them, unrounded, so that every chart
here reproduces qcc's limits; they agree with the printed three-decimal tables to their last decimal
(d2(2) = 1.128, D4(2) = 3.267, A2(5) = 0.577, D3(7) = 0.076). The published worked examples the tests
check against are listed in ``tests/data/spc/README.md``.

Pure numpy/scipy: arrays in, frozen results out; every public function validates its input once and
raises :class:`ValueError` with the expected and the received value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy import stats

__all__ = ["CONSTANTS", "Capability", "ControlChart", "RuleViolation", "capability", "individuals_charts",
           "western_electric", "xbar_r_charts"]

# d2(n), the expected range of n independent standard normal values, n = 2..25, to the three decimals
# of the printed tables (as qcc's .qcc.options$exp.R.unscaled has them).
_D2 = (1.128, 1.693, 2.059, 2.326, 2.534, 2.704, 2.847, 2.970, 3.078, 3.173, 3.258, 3.336, 3.407, 3.472,
       3.532, 3.588, 3.640, 3.689, 3.735, 3.778, 3.819, 3.858, 3.895, 3.931)
# d3(n), the standard deviation of that range (qcc's .qcc.options$se.R.unscaled).
_D3_SPREAD = (0.8525033, 0.8883697, 0.8798108, 0.8640855, 0.8480442, 0.8332108, 0.8198378, 0.8078413,
              0.7970584, 0.7873230, 0.7784873, 0.7704257, 0.7630330, 0.7562217, 0.7499188, 0.7440627,
              0.7386021, 0.7334929, 0.7286980, 0.7241851, 0.7199267, 0.7158987, 0.7120802, 0.7084528)

SIGMAS = 3.0  # the control limits' half width in sigmas of the plotted statistic (Shewhart's 3-sigma limits)
MOVING_RANGE_SPAN = 2
SUBGROUP_SIZES = range(2, 26)


def _constants_row(n, d2, d3):
    ratio = SIGMAS * d3 / d2
    return {"d2": d2, "d3": d3, "D3": max(0.0, 1.0 - ratio), "D4": 1.0 + ratio, "A2": SIGMAS / (d2 * math.sqrt(n)),
            "c4": math.sqrt(2.0 / (n - 1)) * math.exp(math.lgamma(n / 2) - math.lgamma((n - 1) / 2))}


CONSTANTS = {n: _constants_row(n, d2, d3) for n, d2, d3 in zip(SUBGROUP_SIZES, _D2, _D3_SPREAD)}


@dataclass(frozen=True)
class RuleViolation:
    """A run-rule signal on a control chart.

    Attributes
    ----------
    index : int
        Index into the chart's ``points`` of the point that completes the pattern.
    rule : int
        The Western Electric rule, 1 to 4: 1 one point beyond 3 sigma; 2 two of three points in a row
        beyond 2 sigma on one side; 3 four of five points in a row beyond 1 sigma on one side; 4 eight
        points in a row on one side of the center line.
    message : str
        The pattern in plain words, e.g. ``"beyond the upper control limit"``.
    """

    index: int
    rule: int
    message: str


@dataclass(frozen=True, eq=False)
class ControlChart:
    """A Shewhart control chart: the plotted statistic, its center line and limits, and its signals.

    Attributes
    ----------
    kind : str
        ``"individuals"``, ``"moving_range"``, ``"xbar"`` or ``"range"``.
    points : (m,) float ndarray
        The plotted statistic in order. A moving-range chart has one point fewer than the values: its
        first point is the range of the first two values, plotted at the second value.
    center : float
        The center line.
    lower : float or None
        The lower control limit; 0.0 on a moving-range chart and on a range chart of subgroups of 6 or
        fewer (D3 = 0).
    upper : float
        The upper control limit.
    sigma : float
        The within sigma the limits come from, in the values' unit: MRbar / d2(2) or Rbar / d2(n) (on
        the X-bar chart the plotted means scatter by sigma / sqrt(n)).
    violations : tuple of RuleViolation
        The individuals and X-bar charts: Western Electric rules 1 to 4; moving-range and range charts:
        rule 1 only. Sorted by index, then rule.
    """

    kind: str
    points: np.ndarray
    center: float
    lower: Optional[float]
    upper: float
    sigma: float
    violations: tuple


@dataclass(frozen=True)
class Capability:
    """Process capability and performance indices of a sample against its specification limits.

    Attributes
    ----------
    n : int
        Number of values.
    mean : float
        Their mean.
    sigma_within : float or None
        The within (short-term) sigma Cp and Cpk use: MRbar / d2(2) of the values in order, or the one
        given.
    sigma_overall : float
        The sample standard deviation (ddof=1) Pp and Ppk use.
    cp, cpk, pp, ppk : float or None
        None where undefined: Cp and Pp with one limit only; every index whose sigma is 0.
    cp_interval, cpk_interval, pp_interval, ppk_interval : (float, float) or None
        The two-sided confidence intervals of the indices at ``confidence``, as qcc computes them; None
        where the index is None.
    confidence : float
        The intervals' confidence level.
    """

    n: int
    mean: float
    sigma_within: Optional[float]
    sigma_overall: float
    cp: Optional[float]
    cpk: Optional[float]
    pp: Optional[float]
    ppk: Optional[float]
    cp_interval: Optional[tuple]
    cpk_interval: Optional[tuple]
    pp_interval: Optional[tuple]
    ppk_interval: Optional[tuple]
    confidence: float = 0.95


def individuals_charts(values):
    """The individuals and moving-range charts of values in measurement order.

    Parameters
    ----------
    values : (n,) array_like of float
        At least 2 finite values, in the order they were made.

    Returns
    -------
    individuals, moving_range : ControlChart
        The I chart (points: the values; center: their mean; limits: mean +- 3 sigma) and the MR chart
        (points: the n - 1 ranges of consecutive values; center: MRbar; limits 0 and D4(2) MRbar), both
        with sigma = MRbar / d2(2). The I chart carries Western Electric rules 1 to 4, the MR chart rule
        1. When all values are equal, sigma is 0 and the limits lie on the center line.

    Raises
    ------
    ValueError
        Fewer than 2 values, not one-dimensional, or a value not finite.

    Examples
    --------
    The flow rates of the NIST/SEMATECH e-Handbook's individuals chart example (6.3.2.2):

    >>> i_chart, mr_chart = individuals_charts([49.6, 47.6, 49.9, 51.3, 47.8, 51.2, 52.6, 52.4, 53.6, 52.1])
    >>> print(f"{i_chart.center:.2f} {i_chart.lower:.4f} {i_chart.upper:.4f}")
    50.81 45.8159 55.8041
    >>> print(f"{mr_chart.center:.4f} {mr_chart.upper:.3f} {len(mr_chart.points)}")
    1.8778 6.135 9
    >>> i_chart.violations + mr_chart.violations
    ()
    """
    values = _values(values, "values")
    constants = CONSTANTS[MOVING_RANGE_SPAN]
    ranges = np.abs(np.diff(values))
    mr_bar = float(ranges.mean())
    sigma = mr_bar / constants["d2"]
    center = float(values.mean())
    individuals = ControlChart(kind="individuals", points=values, center=center, lower=center - SIGMAS * sigma,
                               upper=center + SIGMAS * sigma, sigma=sigma,
                               violations=western_electric(values, center, sigma))
    upper = constants["D4"] * mr_bar
    moving_range = ControlChart(kind="moving_range", points=ranges, center=mr_bar, lower=0.0, upper=upper,
                                sigma=sigma, violations=_beyond_limits(ranges, 0.0, upper))
    return individuals, moving_range


def xbar_r_charts(subgroups):
    """The X-bar and range charts of equal subgroups in order.

    Parameters
    ----------
    subgroups : (m, n) array_like of float
        m >= 2 subgroups (rows) of n values each, 2 <= n <= 25, all finite.

    Returns
    -------
    xbar, range : ControlChart
        The X-bar chart (points: the subgroup means; center: the grand mean; limits: center +- 3 sigma /
        sqrt(n), which is A2 Rbar) with Western Electric rules 1 to 4 judged in zones of sigma / sqrt(n),
        and the range chart (points: the subgroup ranges; center: Rbar; limits D3 Rbar and D4 Rbar) with
        rule 1; both with sigma = Rbar / d2(n).

    Raises
    ------
    ValueError
        Not two-dimensional, fewer than 2 subgroups, a subgroup size outside 2..25, or a value not
        finite.

    Examples
    --------
    Three subgroups of four (the data of qcc's capability tests):

    >>> xbar, r = xbar_r_charts([[10.00, 10.02, 9.98, 10.01], [10.03, 9.99, 10.01, 10.00],
    ...                          [9.97, 10.04, 10.02, 9.99]])
    >>> print(f"{xbar.center:.4f} {xbar.lower:.4f} {xbar.upper:.4f} sigma {xbar.sigma:.5f}")
    10.0050 9.9686 10.0414 sigma 0.02428
    >>> print(f"{r.center:.4f} {r.lower:.1f} {r.upper:.4f}")
    0.0500 0.0 0.1141
    """
    data = np.asarray(subgroups, dtype=float)
    if data.ndim != 2:
        raise ValueError(f"subgroups must be a 2-D array (subgroups x values), got {data.ndim} dimension(s)")
    m, n = data.shape
    if m < 2:
        raise ValueError(f"subgroups must hold at least 2 subgroups, got {m}")
    if n not in CONSTANTS:
        raise ValueError(f"the subgroup size must be 2 to 25, got {n}")
    if not np.all(np.isfinite(data)):
        raise ValueError(f"subgroups must be finite, got {_first_bad(data.ravel())}")
    constants = CONSTANTS[n]
    means = data.mean(axis=1)
    ranges = np.ptp(data, axis=1)
    r_bar = float(ranges.mean())
    sigma = r_bar / constants["d2"]
    sigma_mean = sigma / math.sqrt(n)
    center = float(means.mean())
    xbar = ControlChart(kind="xbar", points=means, center=center, lower=center - SIGMAS * sigma_mean,
                        upper=center + SIGMAS * sigma_mean, sigma=sigma,
                        violations=western_electric(means, center, sigma_mean))
    lower, upper = constants["D3"] * r_bar, constants["D4"] * r_bar
    range_chart = ControlChart(kind="range", points=ranges, center=r_bar, lower=lower, upper=upper, sigma=sigma,
                               violations=_beyond_limits(ranges, lower, upper))
    return xbar, range_chart


def western_electric(points, center, sigma):
    """The Western Electric rules 1 to 4 on a plotted statistic.

    Zones are center +- k sigma, sigma being the plotted statistic's (on an X-bar chart the within
    sigma / sqrt(n)); "beyond" is strict, so a point on a zone's edge is inside it. The rules:

    1. one point beyond 3 sigma;
    2. two of three points in a row beyond 2 sigma, on one side;
    3. four of five points in a row beyond 1 sigma, on one side;
    4. eight points in a row on one side of the center line (a point on it breaks the run).

    A violation names the point that completes its pattern, and that point is always one of the
    pattern's points (beyond the zone, or on the run's side): a point inside the zone that ends a window
    is never flagged. Overlapping patterns: each point is flagged at most once per rule, so a long run
    flags its 8th point and every point after it under rule 4, and one point may carry several rules
    (a point beyond 3 sigma that also ends a 2-of-3 pattern is reported under rules 1 and 2). The
    windows of rules 2 and 3 end at the point and are cut at the start of the series: two points beyond
    2 sigma at the very start already complete rule 2 (R's qcc needs a full window of three).

    Parameters
    ----------
    points : (m,) array_like of float
        The plotted statistic, in order; finite.
    center : float
        The center line.
    sigma : float
        The standard deviation of the plotted statistic, >= 0. With 0, every point off the center line
        is beyond the limits.

    Returns
    -------
    tuple of RuleViolation
        Sorted by index, then rule.

    Raises
    ------
    ValueError
        ``points`` not one-dimensional or not finite, ``center`` not finite, ``sigma`` negative or not
        finite.

    Examples
    --------
    >>> for v in western_electric([0.0, 2.5, 1.1, 2.6, 3.2], center=0.0, sigma=1.0):
    ...     print(v.index, v.rule, v.message)
    3 2 2 of 3 points in a row more than 2 sigma above the center line
    4 1 beyond the upper control limit
    4 2 2 of 3 points in a row more than 2 sigma above the center line
    4 3 4 of 5 points in a row more than 1 sigma above the center line
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 1:
        raise ValueError(f"points must be a 1-D array, got {points.ndim} dimension(s)")
    if not np.all(np.isfinite(points)):
        raise ValueError(f"points must be finite, got {_first_bad(points)}")
    if not math.isfinite(center):
        raise ValueError(f"center must be finite, got {center}")
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma must be finite and >= 0, got {sigma}")
    violations = list(_beyond_limits(points, center - SIGMAS * sigma, center + SIGMAS * sigma))
    deviation = points - center
    for side, word in ((1.0, "above"), (-1.0, "below")):
        signed = side * deviation
        for rule, count, window, zone in ((2, 2, 3, 2.0), (3, 4, 5, 1.0)):
            beyond = signed > zone * sigma
            message = f"{count} of {window} points in a row more than {zone:g} sigma {word} the center line"
            violations += [RuleViolation(int(i), rule, message) for i in np.flatnonzero(beyond)
                           if np.count_nonzero(beyond[max(0, i - window + 1):i + 1]) >= count]
        run = 0
        for i, on_side in enumerate(signed > 0):
            run = run + 1 if on_side else 0
            if run >= 8:
                violations.append(RuleViolation(i, 4, f"8 points in a row {word} the center line"))
    return tuple(sorted(violations, key=lambda v: (v.index, v.rule)))


def capability(values, lower, upper, sigma_within=None, confidence=0.95):
    """Process capability (Cp, Cpk) and performance (Pp, Ppk) with confidence intervals.

    Cp = (upper - lower) / (6 sigma_within) and Cpk = min(upper - mean, mean - lower) / (3 sigma_within);
    Pp and Ppk the same with the overall sample standard deviation (ddof=1). With one limit only, Cp and
    Pp are None and Cpk, Ppk the one-sided index ((upper - mean) / (3 sigma) with ``lower`` None). An
    index whose sigma is 0 (all values equal) is None, as is its interval.

    The intervals are qcc's (``processCapability``), with alpha = 1 - confidence and n the number of
    values: Cp sqrt(chi2(alpha/2; n-1) / (n-1)) to Cp sqrt(chi2(1 - alpha/2; n-1) / (n-1)) (Chou et al.
    1990) and Cpk -+ z sqrt(1/(9n) + Cpk^2 / (2(n-1))), z = Phi^-1(1 - alpha/2) (Bissell 1990; qcc
    writes it Cpk (1 -+ z sqrt(1/(9 n Cpk^2) + 1/(2(n-1)))), the same for Cpk > 0, which this form keeps
    ordered for Cpk <= 0); Pp and Ppk alike.

    Parameters
    ----------
    values : (n,) array_like of float
        At least 2 finite values, in measurement order (the default within sigma depends on the order).
    lower, upper : float or None
        The specification limits on the values; one may be None (a one-sided limit), not both;
        ``lower < upper``.
    sigma_within : float, optional
        The within sigma (e.g. ``xbar_r_charts(...)[0].sigma`` for subgrouped data); by default MRbar /
        d2(2) of the values in order. Finite, >= 0.
    confidence : float
        The confidence level of the intervals, in (0, 1).

    Returns
    -------
    Capability

    Raises
    ------
    ValueError
        Fewer than 2 values, a value or limit not finite, no limit, ``lower >= upper``, a negative or
        non-finite ``sigma_within``, a confidence outside (0, 1).

    Examples
    --------
    The NIST/SEMATECH e-Handbook's example (6.1.6): USL 20, LSL 8, mean 16, sigma 2:

    >>> import numpy as np
    >>> z = np.array([-1.5, -0.5, 0.0, 0.5, 1.5])
    >>> values = 16 + 2 * (z - z.mean()) / z.std(ddof=1)
    >>> c = capability(values, lower=8, upper=20, sigma_within=2.0)
    >>> print(f"Cp {c.cp:.4f} Cpk {c.cpk:.4f} Pp {c.pp:.4f} Ppk {c.ppk:.4f}")
    Cp 1.0000 Cpk 0.6667 Pp 1.0000 Ppk 0.6667
    >>> print(f"{c.cp_interval[0]:.3f} {c.cp_interval[1]:.3f}")
    0.348 1.669
    >>> capability(values, lower=None, upper=20).cp is None
    True
    """
    values = _values(values, "values")
    for name, limit in (("lower", lower), ("upper", upper)):
        if limit is not None and not math.isfinite(limit):
            raise ValueError(f"{name} must be finite or None, got {limit}")
    if lower is None and upper is None:
        raise ValueError("capability needs a specification limit: lower and upper are both None")
    if lower is not None and upper is not None and not lower < upper:
        raise ValueError(f"lower must be below upper, got lower {lower} and upper {upper}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    if sigma_within is None:
        sigma_within = float(np.abs(np.diff(values)).mean()) / CONSTANTS[MOVING_RANGE_SPAN]["d2"]
    elif not (math.isfinite(sigma_within) and sigma_within >= 0):
        raise ValueError(f"sigma_within must be finite and >= 0, got {sigma_within}")
    n = values.size
    mean = float(values.mean())
    sigma_overall = float(values.std(ddof=1))
    alpha = 1.0 - confidence
    cp, cpk, cp_interval, cpk_interval = _indices(mean, sigma_within, lower, upper, n, alpha)
    pp, ppk, pp_interval, ppk_interval = _indices(mean, sigma_overall, lower, upper, n, alpha)
    return Capability(n=n, mean=mean, sigma_within=float(sigma_within), sigma_overall=sigma_overall, cp=cp,
                      cpk=cpk, pp=pp, ppk=ppk, cp_interval=cp_interval, cpk_interval=cpk_interval,
                      pp_interval=pp_interval, ppk_interval=ppk_interval, confidence=confidence)


def _indices(mean, sigma, lower, upper, n, alpha):
    """(Cp, Cpk, Cp interval, Cpk interval) for one sigma; Nones where undefined."""
    if sigma == 0:
        return None, None, None, None
    sides = [(upper - mean) / (SIGMAS * sigma)] if upper is not None else []
    sides += [(mean - lower) / (SIGMAS * sigma)] if lower is not None else []
    cpk = float(min(sides))
    z = float(stats.norm.ppf(1.0 - alpha / 2))
    half = z * math.sqrt(1.0 / (9.0 * n) + cpk ** 2 / (2.0 * (n - 1)))
    cpk_interval = (cpk - half, cpk + half)
    if lower is None or upper is None:
        return None, cpk, None, cpk_interval
    cp = float((upper - lower) / (2 * SIGMAS * sigma))
    chi2 = stats.chi2.ppf([alpha / 2, 1.0 - alpha / 2], n - 1)
    cp_interval = tuple(float(cp * math.sqrt(q / (n - 1))) for q in chi2)
    return cp, cpk, cp_interval, cpk_interval


def _beyond_limits(points, lower, upper):
    """Rule 1: the points strictly beyond the control limits."""
    return tuple(RuleViolation(int(i), 1, "beyond the upper control limit" if points[i] > upper
                               else "beyond the lower control limit")
                 for i in np.flatnonzero((points > upper) | (points < lower)))


def _values(values, name):
    """``values`` as a new 1-D float array (a chart keeps it) of at least 2 finite values, else ValueError."""
    array = np.array(values, dtype=float)
    if array.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array, got {array.ndim} dimension(s)")
    if array.size < 2:
        raise ValueError(f"{name} must hold at least 2 values, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {_first_bad(array)}")
    return array


def _first_bad(array):
    """The first non-finite value of a 1-D array and its index, for a message."""
    index = int(np.flatnonzero(~np.isfinite(array))[0])
    return f"{array[index]} at index {index}"
