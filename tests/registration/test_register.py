"""Tests of holecli.registration.register: matching, fit, outlier left out, verdict, targets (pure, no files)."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli.io.targets import Targets
from holecli.registration import RegistrationError, RigidTransform, register
from holecli.results import Uncertainty
from holecli.tolerance import NominalHole

TRUTH = RigidTransform(Rotation.from_euler("xyz", [4.0, -3.0, 27.0], degrees=True).as_matrix(),
                       np.array([812.5, -140.25, 33.0]))
CENTERS = np.array([[0.0, 0.0, 0.0], [120.0, 0.0, 0.0], [120.0, 80.0, 5.0], [0.0, 80.0, 0.0], [60.0, 40.0, -10.0]])
NORMALS = np.array([[0, 0, 1.0], [0, 0, 1.0], [0.2, 0, 1.0], [0, 0, 1.0], [0, 0.3, 1.0]])
NAMES = ["A", "B", "C", "D", "E"]


def _nominals(count=5):
    return [NominalHole(name=NAMES[i], diameter=3.0, center=tuple(CENTERS[i]), normal=tuple(NORMALS[i]))
            for i in range(count)]


def _measured(count=5, noise=0.0, sigma=0.002, displace=None, rng=None, flip=()):
    rng = np.random.default_rng(1) if rng is None else rng
    centers = TRUTH.apply_points(CENTERS[:count]) + noise * rng.standard_normal((count, 3))
    normals = TRUTH.apply_directions(NORMALS[:count] / np.linalg.norm(NORMALS[:count], axis=1, keepdims=True))
    if displace is not None:
        index, vector = displace
        centers[index] += vector
    holes = []
    for i in range(count):
        normal = -normals[i] if i in flip else normals[i]
        u = None if sigma is None else Uncertainty(center_in_plane=sigma, center_along_normal=sigma, diameter=sigma,
                                                   normal_deg=0.05)
        holes.append(SimpleNamespace(center=tuple(centers[i]), normal=tuple(normal), uncertainty=u))
    return holes


def _rotation_error_deg(a, b):
    return np.degrees(Rotation.from_matrix(a.rotation @ b.rotation.T).magnitude())


@pytest.mark.parametrize("names", [None, NAMES])
def test_exact_recovery_by_names_and_by_distances(names):
    result = register(_measured(), _nominals(), measured_names=names, max_residual=0.01)
    assert result.match_method == ("names" if names else "distances")
    assert [hole.name for hole in result.holes] == NAMES
    assert np.allclose(result.transform.translation, TRUTH.translation, atol=1e-9)
    assert _rotation_error_deg(result.transform, TRUTH) < 1e-9
    assert result.verdict == "pass" and result.outliers == () and result.free_dofs == ()
    assert result.sigmas and result.fit.covariance_source == "sigmas"
    record = result.to_dict()
    json.dumps(record, allow_nan=False)
    assert record["transform"]["quaternion_wxyz"] == pytest.approx(TRUTH.quaternion.tolist(), abs=1e-12)
    assert all(u > 0 for u in record["uncertainty"]["translation"])


def test_shuffled_unnamed_holes_pair_by_distances():
    holes = _measured()
    order = [3, 0, 4, 1, 2]
    result = register([holes[i] for i in order], _nominals())
    assert [hole.name for hole in result.holes] == [NAMES[i] for i in order]


def test_flipped_measured_normal_is_turned():
    result = register(_measured(flip=(1,)), _nominals(), measured_names=NAMES)
    assert [hole.normal_flipped for hole in result.holes] == [False, True, False, False, False]
    assert _rotation_error_deg(result.transform, TRUTH) < 1e-9


def test_displaced_hole_is_named_and_left_out():
    rng = np.random.default_rng(7)
    result = register(_measured(noise=0.001, displace=(2, [0.2, 0.0, 0.0]), rng=rng), _nominals(),
                      measured_names=NAMES, max_residual=0.05)
    assert result.outliers == ("C",)
    by_name = {hole.name: hole for hole in result.holes}
    assert not by_name["C"].used and by_name["C"].outlier
    assert by_name["C"].in_plane == pytest.approx(0.2, abs=0.02)  # where the others place it
    assert np.allclose(result.transform.translation, TRUTH.translation, atol=0.01)
    assert result.verdict == "fail" and result.failed == ("C: outlier",)
    assert result.warnings[0][0] == "outlier"


def test_verdict_fails_on_a_large_residual_without_outlier_check():
    # three holes: no leave-one-out check; the residual itself fails the verdict
    result = register(_measured(3, displace=(2, [0.0, 0.0, 0.05])), _nominals(3), measured_names=NAMES[:3],
                      max_residual=0.001)
    assert not result.outlier_check.checked
    assert result.verdict == "fail" and result.failed


def test_two_holes_use_the_normals():
    result = register(_measured(2), _nominals(2), measured_names=NAMES[:2])
    assert result.free_dofs == ()
    assert _rotation_error_deg(result.transform, TRUTH) < 1e-7


def test_one_hole_leaves_the_rotation_about_its_normal_free():
    result = register(_measured(1), _nominals(1), measured_names=["A"])
    assert result.free_dofs == ("rotation about the normal",)
    assert np.allclose(result.transform.apply_points(CENTERS[0]), TRUTH.apply_points(CENTERS[0]))
    rows = result.corrected_targets(Targets(("on", "off"), np.array([CENTERS[0], [10.0, 0, 0]]),
                                            np.array([[0, 0, 1.0], [0, 0, 1.0]])))
    assert np.isfinite([rows[0][k] for k in ("u_x", "u_y", "u_z")]).all()
    assert np.isinf([rows[1][k] for k in ("u_x", "u_y")]).any()
    record = result.to_dict()
    json.dumps(record, allow_nan=False)
    assert record["free_dofs"] == ["rotation about the normal"]
    assert any(code == "free_dofs" for code, _ in result.warnings)


def test_corrected_targets_match_the_truth():
    result = register(_measured(), _nominals(), measured_names=NAMES)
    points = np.array([[10.0, 20.0, 0.0], [100.0, 5.0, 2.0]])
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]])
    rows = result.corrected_targets(Targets(("t1", "t2"), points, normals))
    assert [row["name"] for row in rows] == ["t1", "t2"]
    got = np.array([[row[k] for k in ("x", "y", "z")] for row in rows])
    assert np.allclose(got, TRUTH.apply_points(points), atol=1e-9)
    got_n = np.array([[row[k] for k in ("nx", "ny", "nz")] for row in rows])
    assert np.allclose(got_n, TRUTH.apply_directions(normals), atol=1e-12)
    assert all(0 < row["u_x"] < 0.01 and row["u_normal_deg"] > 0 for row in rows)


def test_without_uncertainties_the_covariance_comes_from_residuals():
    result = register(_measured(noise=0.001, sigma=None), _nominals(), measured_names=NAMES)
    assert not result.sigmas and result.fit.covariance_source == "residuals"
    # a fact of the input, not a doubt: a note (issue 24)
    assert any(code == "no_uncertainty" for code, _ in result.notes) and result.warnings == ()
    assert [note["code"] for note in result.to_dict()["notes"]] == ["no_uncertainty"]


def test_mixed_names_pair_the_rest_by_nearness():
    holes = _measured()
    result = register(holes, _nominals(), measured_names=["A", "B", "C", None, None])
    assert result.match_method == "names+nearest"
    assert [hole.name for hole in result.holes] == NAMES


def test_unmatched_spec_holes_are_reported():
    result = register(_measured(4), _nominals(5), measured_names=NAMES[:4])
    assert result.unmatched_nominal == ("E",)


@pytest.mark.parametrize("kwargs, match", [
    ({"measured_names": ["A", "Z"]}, "no hole 'Z' in the spec"),
    ({"measured_names": ["A", "A"]}, "named by 2"),
    ({}, "cannot be matched"),
    ({"measured_names": ["A", "B"], "max_residual": -1.0}, "max_residual"),
])
def test_bad_inputs(kwargs, match):
    with pytest.raises(RegistrationError, match=match):
        register(_measured(2), _nominals(2), **kwargs)


def test_spec_hole_without_normal():
    nominals = [NominalHole(name="A", diameter=3.0, center=(0.0, 0.0, 0.0))]
    with pytest.raises(RegistrationError, match="has no normal"):
        register(_measured(1), nominals, measured_names=["A"])


def test_a_measured_hole_without_a_spec_hole_is_a_note():
    # a scan that shows a hole the spec does not list: the fit is that of the others, nothing doubtful
    result = register(_measured(5), _nominals(4), measured_names=NAMES[:4] + [None])
    assert result.unmatched_measured == (4,)
    assert [code for code, _ in result.notes] == ["unmatched_hole"] and result.warnings == ()
