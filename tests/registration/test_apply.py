"""holecli.registration.apply: a register record read back and a spec mapped with it; and
holecli.tolerance.check's use of a mapped nominal's uncertainty and of tied holes."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli.registration import RegistrationError, RigidTransform
from holecli.registration.apply import map_spec, parse_registration
from holecli.tolerance import NOT_IN_SPEC_FRAME, check, parse_spec

SPEC = """
[[hole]]
name = "A"
center = [10.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
diameter = 3.0
tolerance = 0.05
position_tolerance = 0.1
max_tilt = 1
"""


def _record(transform, covariance):
    return {"schema": "holecli.register", "units": "file units of the scans and the spec",
            "transform": {"matrix": transform.matrix.tolist()},
            "uncertainty": {"covariance": covariance}}


def _hole(center, normal=(0.0, 0.0, 1.0), u_center=0.003):
    return {"index": 0, "center": list(center), "normal": list(normal), "diameter": 3.0, "notes": [],
            "uncertainty": {"center_in_plane": u_center, "diameter": 0.001, "normal_deg": 0.01}}


def test_map_spec_moves_the_nominal_and_carries_the_registration_u():
    transform = RigidTransform(Rotation.from_euler("z", 90, degrees=True).as_matrix(), [100.0, 0.0, 0.0])
    covariance = np.diag([0.0, 0.0, 0.0, 0.004 ** 2, 0.004 ** 2, 0.0]).tolist()
    spec = map_spec(parse_spec(SPEC, source="part.toml"), parse_registration(_record(transform, covariance)))
    (hole,) = spec.holes
    assert hole.center == pytest.approx((100.0, 10.0, 0.0))
    assert spec.registration == {}
    checked = check({"holes": [_hole((100.001, 10.0, 0.0))]}, spec)
    position = checked["holes"][0]["conformance"]["position"]
    assert position["nominal_uncertainty"] == pytest.approx(0.004)
    assert position["expanded_uncertainty"] == pytest.approx(2 * math.hypot(0.003, 0.004))
    # without the registration's covariance, U is the measurement's alone
    exact = check({"holes": [_hole((100.001, 10.0, 0.0))]},
                  map_spec(parse_spec(SPEC), parse_registration(_record(transform, np.zeros((6, 6)).tolist()))))
    assert exact["holes"][0]["conformance"]["position"]["expanded_uncertainty"] == pytest.approx(0.006)


def test_a_covariance_not_known_leaves_u_not_known():
    covariance = [[None] * 6 for _ in range(6)]
    spec = map_spec(parse_spec(SPEC), parse_registration(_record(RigidTransform.identity(), covariance)))
    position = check({"holes": [_hole((10.0, 0.0, 0.0))]}, spec)["holes"][0]["conformance"]["position"]
    assert position["nominal_uncertainty"] is None and position["expanded_uncertainty"] is None


@pytest.mark.parametrize("data, text", [
    ([], "JSON object"),
    ({"schema": "holecli.detect"}, "not a holecli register record"),
    ({"schema": "holecli.register", "transform": {"matrix": np.eye(4).tolist()}}, "uncertainty.covariance"),
    ({"schema": "holecli.register", "transform": {"matrix": (2 * np.eye(4)).tolist()},
      "uncertainty": {"covariance": np.zeros((6, 6)).tolist()}}, "last row"),
])
def test_parse_registration_refuses_what_is_not_one(data, text):
    with pytest.raises(RegistrationError, match=text):
        parse_registration(data)


def test_a_tied_hole_is_checked_wherever_it_lies_and_others_are_not_missing():
    spec = parse_spec(SPEC + SPEC.replace('"A"', '"B"').replace("10.0, 0.0", "-10.0, 0.0"))
    far = {"holes": [_hole((500.0, 0.0, 0.0))]}
    untied = check(far, spec)
    assert untied["verdict"]["missing"] == ["A", "B"] and untied["verdict"]["checked"] == 0
    tied = check(far, spec, {0: "B"})
    hole = tied["holes"][0]
    assert hole["name"] == "B" and tied["verdict"]["missing"] == [] and tied["verdict"]["checked"] == 1
    # another frame: the diameter is checked, position and tilt are not
    assert list(hole["conformance"]) == ["diameter"] and hole["position_deviation"] is None
    assert hole["notes"][-1]["code"] == NOT_IN_SPEC_FRAME
    near = check({"holes": [_hole((-10.2, 0.0, 0.0))]}, spec, {0: "B"})["holes"][0]
    assert near["conformance"]["position"]["decision"] == "fail"  # in the spec's frame: checked
    with pytest.raises(ValueError, match="C"):
        check(far, spec, {0: "C"})
