"""The robust method's tunables (holecli.settings): every field checked when the object is made."""

from dataclasses import fields, replace

import pytest

from holecli.settings import DEFAULT_SETTINGS, RobustSettings


def test_the_defaults_are_valid_and_every_field_is_checked():
    assert RobustSettings() == DEFAULT_SETTINGS
    for field in fields(RobustSettings):
        with pytest.raises(ValueError, match=f"RobustSettings.{field.name} must be"):
            replace(DEFAULT_SETTINGS, **{field.name: float("nan")})


@pytest.mark.parametrize("name, value", [
    ("alpha_gaps", 0.0), ("alpha_gaps", -1.0), ("alpha_gaps", float("inf")), ("alpha_gaps", "2.5"),
    ("alpha_gaps", True), ("ransac_quantile", 1.0), ("full_arc_deg", 361.0), ("boss_fraction", 0.0),
    ("threads", 0), ("threads", 2.0), ("min_rim_points", 2), ("cone_depth_slope_ratio", 1.0),
    ("bias_offsets", ()), ("bias_offsets", (1, -2)), ("bias_offsets", [1, 2]),
])
def test_a_value_out_of_range_names_the_field(name, value):
    with pytest.raises(ValueError, match=f"RobustSettings.{name} must be"):
        replace(DEFAULT_SETTINGS, **{name: value})


@pytest.mark.parametrize("name, value", [
    ("full_arc_deg", 360.0), ("boss_fraction", 1.0), ("cone_window_moves", 0),
    ("cone_depth_slope_ratio", float("-inf")), ("bias_offsets", (0.5,)),
])
def test_limits_that_are_allowed(name, value):
    assert getattr(replace(DEFAULT_SETTINGS, **{name: value}), name) == value
