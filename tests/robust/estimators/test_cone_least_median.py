"""The least-median hinge's slope search (:func:`holecli.robust.estimators.cone._least_median_slope`) skips
the medians that cannot be the smallest: it must give what the argmin of every median gives, to the last
bit, on the cones, bore walls, floors, ties and quantised depths it meets."""

import numpy as np
import pytest

from holecli.robust.estimators.cone import _least_median_slope, _median_errors


def _every_median(depth, ramp, slopes):
    errors = _median_errors(depth, ramp, slopes)
    index = int(np.argmin(errors))
    return index, float(errors[index])


@pytest.mark.parametrize("seed", range(6))
def test_same_as_every_median(seed):
    rng = np.random.default_rng(seed)
    for trial in range(150):
        count = int(rng.integers(1, 3000))  # above ALL_MEDIANS_UP_TO / 41 the fine search skips too
        rho = rng.uniform(0.0, 2.0, count)
        if trial % 4 == 1:
            rho = np.round(rho, 1)  # many points at one radius: ties
        edge = float(rng.uniform(0.0, 2.5))  # at 0 no point is inside the edge
        slope = float(rng.uniform(0.0, 2.0))
        depth = slope * np.maximum(edge - rho, 0.0) + rng.normal(0.0, float(rng.choice([0.0, 1e-3, 0.1])), count)
        if trial % 4 == 2:
            depth = np.round(depth, 2)  # quantised
        if trial % 4 == 3:
            depth[: count // 2] = rng.uniform(0.0, 5.0, count // 2)  # a bore wall's and a floor's points
        ramp = np.maximum(edge - rho, 0.0)
        best = 0.0
        for slopes in (np.linspace(0.0, 3.0, 201), np.linspace(best - 0.015, best + 0.015, 41),
                       np.linspace(slope - 0.015, slope + 0.015, 41)):
            assert _least_median_slope(depth, ramp, slopes) == _every_median(depth, ramp, slopes)


def test_not_finite_as_argmin():
    depth = np.array([0.1, np.nan, 0.3, 0.2])
    ramp = np.array([0.5, 0.2, 0.0, 0.1])
    slopes = np.linspace(0.0, 1.0, 11)
    index, error = _least_median_slope(depth, ramp, slopes)
    assert index == 0 and np.isnan(error)
