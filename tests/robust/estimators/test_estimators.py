"""The edge estimators behind one protocol (holecli.robust.estimators): their precedence, their method
terms, which holes each applies to, and the one synthetic-error harness they share."""

from types import SimpleNamespace

import numpy as np
import pytest

from holecli.robust.estimators import (CONE, EMPTY_CIRCLE, ESTIMATOR_NAMED, ESTIMATORS, LATTICE, METHOD_TERMS,
                                       RIM_FIT, synthetic_errors)
from holecli.robust.uncertainty import edge_uncertainty
from holecli.settings import DEFAULT_SETTINGS


def test_the_estimators_are_tried_cone_lattice_empty_circle_then_rim_fit():
    assert [estimator.name for estimator in ESTIMATORS] == ["cone", "lattice", "empty_circle", "rim_fit"]
    assert ESTIMATORS[-1] is RIM_FIT and all(ESTIMATOR_NAMED[e.name] is e for e in ESTIMATORS)


@pytest.mark.parametrize("estimator", ESTIMATORS, ids=lambda e: e.name)
def test_each_estimators_u_grows_as_its_sampling_coarsens_or_gets_noisier(estimator):
    """Its method terms widen its uncertainty with the spacing h or the height noise sigma_h: never
    smaller on a coarser or noisier scan, and the center's larger on one both coarser and noisier."""
    rim = np.column_stack([np.cos(np.linspace(0, 6, 50)), np.sin(np.linspace(0, 6, 50))])
    errors = synthetic_errors(lambda radius, inside: ((0.01, 0.0), radius + 0.01), np.zeros(2), [1.0, 1.1, 1.2])

    def u(spacing, noise):
        return edge_uncertainty(estimator, errors, rim, (0.0, 0.0), 1.0, spacing=spacing, height_noise=noise,
                                density=100.0)

    fine = u(0.1, 0.01)
    for coarser in (u(0.2, 0.01), u(0.1, 0.02), u(0.2, 0.02)):
        assert coarser[0] >= fine[0] and coarser[1] >= fine[1]
    assert u(0.2, 0.02)[0] > fine[0]
    assert METHOD_TERMS[estimator.name] is estimator.method_terms


def _scene(lattice_axes=(), period=None, height_noise=0.0, surface_density=100.0):
    return SimpleNamespace(sampling=SimpleNamespace(lattice_axes=lattice_axes, period=period),
                           height_noise=height_noise, surface_density=surface_density)


def test_which_holes_each_estimator_is_tried_on():
    grid, random, noisy = _scene(lattice_axes=((1.0, 0.0),), period=0.1), _scene(), _scene(height_noise=1.0)
    for scene in (grid, random, noisy):
        for partial in (False, True):
            assert CONE.applies(scene, partial, DEFAULT_SETTINGS) and RIM_FIT.applies(scene, partial, DEFAULT_SETTINGS)
    assert LATTICE.applies(grid, False, DEFAULT_SETTINGS) and not LATTICE.applies(grid, True, DEFAULT_SETTINGS)
    assert not LATTICE.applies(random, False, DEFAULT_SETTINGS)
    assert EMPTY_CIRCLE.applies(random, False, DEFAULT_SETTINGS)
    assert not EMPTY_CIRCLE.applies(random, True, DEFAULT_SETTINGS)  # partial
    assert not EMPTY_CIRCLE.applies(grid, False, DEFAULT_SETTINGS)  # periodic sampling
    assert not EMPTY_CIRCLE.applies(noisy, False, DEFAULT_SETTINGS)  # noise carries points into the hole


def test_the_harness_collects_the_errors_of_the_synthetic_holes_measured():
    center = np.array([1.0, -2.0])
    given = []

    def measure(radius, inside):
        given.append((radius, inside))
        if radius > 3.5:
            return None  # no edge: left out
        return center + [0.01 * radius, 0.0], radius + 0.1 * radius

    errors = synthetic_errors(measure, center, [2.0, 3.0, 4.0], reflections=["a", "b", "c"])
    assert given == [(2.0, "a"), (3.0, "b"), (4.0, "c")]
    np.testing.assert_allclose(errors.radial, [0.2, 0.3])
    np.testing.assert_allclose(errors.center, [[0.02, 0.0], [0.03, 0.0]])
    assert errors.bias == pytest.approx(0.25)
    assert synthetic_errors(measure, center, [2.0], reflections=None).center.shape == (1, 2)
    assert given[-1] == (2.0, None)
    assert synthetic_errors(lambda radius, inside: None, center, [2.0, 3.0]) is None
