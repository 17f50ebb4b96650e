"""The robust method's tunables (holecli.settings): grouped per step, each field checked against the range
beside it when the object is made, read by its own (flat) name as well as through its group."""

import math
import pickle
from dataclasses import fields, replace

import pytest

from holecli.settings import (
    DEFAULT_SETTINGS,
    GROUP_OF,
    GROUPS,
    CandidateSettings,
    CountersinkSettings,
    PlaneSettings,
    Range,
    RobustSettings,
)


@pytest.mark.parametrize("group, kind", GROUPS, ids=[group for group, _ in GROUPS])
def test_every_field_of_every_group_has_a_range_and_a_valid_default(group, kind):
    assert isinstance(getattr(DEFAULT_SETTINGS, group), kind)
    for item in fields(kind):
        allowed = item.metadata["range"]
        assert allowed.admits(item.default), item.name
        assert not allowed.admits(float("nan")), item.name
        with pytest.raises(ValueError, match=rf"^RobustSettings\.{item.name} must be "):
            kind(**{item.name: float("nan")})


def test_the_defaults_are_valid_and_every_field_is_checked():
    assert RobustSettings() == DEFAULT_SETTINGS
    for item in RobustSettings.flat_fields():
        with pytest.raises(ValueError, match=f"RobustSettings.{item.name} must be"):
            replace(DEFAULT_SETTINGS, **{item.name: float("nan")})


def test_a_flat_name_is_its_groups_field():
    assert len(GROUP_OF) == len(RobustSettings.flat_fields())  # no name in two groups
    for name, group in GROUP_OF.items():
        assert getattr(DEFAULT_SETTINGS, name) == getattr(getattr(DEFAULT_SETTINGS, group), name)
    assert [name for name, _ in DEFAULT_SETTINGS.flat_items()] == list(GROUP_OF)


def test_flat_and_grouped_construction_agree():
    flat = RobustSettings(cell_gaps=3.0, cone_min_slope=0.3)
    grouped = RobustSettings(candidates=CandidateSettings(cell_gaps=3.0),
                             countersink=CountersinkSettings(cone_min_slope=0.3))
    assert flat == grouped and hash(flat) == hash(grouped)
    assert flat.cell_gaps == flat.candidates.cell_gaps == 3.0
    assert flat.plane is not None and flat.plane == DEFAULT_SETTINGS.plane
    # dataclasses.replace passes the groups and the flat change together: the flat name wins.
    assert replace(DEFAULT_SETTINGS, cell_gaps=3.0) == RobustSettings(cell_gaps=3.0)
    assert replace(grouped, cell_gaps=2.0).candidates == CandidateSettings()
    assert pickle.loads(pickle.dumps(flat)) == flat


def test_settings_are_frozen():
    with pytest.raises(AttributeError):
        DEFAULT_SETTINGS.cell_gaps = 3.0
    with pytest.raises(AttributeError):
        DEFAULT_SETTINGS.plane = PlaneSettings()


def test_unknown_names_and_wrong_groups_are_refused():
    with pytest.raises(TypeError, match="unexpected keyword argument 'cell_gap'"):
        RobustSettings(cell_gap=3.0)
    with pytest.raises(TypeError, match="RobustSettings.plane must be a PlaneSettings"):
        RobustSettings(plane=CandidateSettings())


@pytest.mark.parametrize("name, value, message", [
    ("alpha_gaps", -1.0, "RobustSettings.alpha_gaps must be a number in (0.0, inf), got -1.0"),
    ("threads", 0, "RobustSettings.threads must be an integer in [1, 1024], got 0"),
    ("full_arc_deg", 361.0, "RobustSettings.full_arc_deg must be a number in (0.0, 360.0], got 361.0"),
    ("cone_depth_slope_ratio", 1.0, "RobustSettings.cone_depth_slope_ratio must be a number in (-inf, 1.0), got 1.0"),
    ("bias_offsets", (1, -2), "RobustSettings.bias_offsets must be a non-empty tuple of positive numbers, got (1, -2)"),
])
def test_a_refusal_names_the_field_and_its_range(name, value, message):
    with pytest.raises(ValueError) as flat:
        RobustSettings(**{name: value})
    assert str(flat.value) == message
    group = GROUP_OF[name]
    with pytest.raises(ValueError) as grouped:
        replace(getattr(DEFAULT_SETTINGS, group), **{name: value})
    assert str(grouped.value) == message


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


def test_ranges_open_closed_and_counts():
    open_ = Range(0.0, 1.0)
    assert not open_.admits(0.0) and open_.admits(0.5) and not open_.admits(1.0)
    assert Range(0.0, 1.0, closed=True).admits(1.0)
    assert Range(-math.inf, 1.0).admits(-math.inf)
    counts = Range(1, 3, integer=True)
    assert counts.admits(1) and counts.admits(3) and not counts.admits(4) and not counts.admits(2.0)
    assert not counts.admits(True)


def test_the_steps_take_the_settings_they_are_given():
    """A step given settings reads them (no module copy of a default stands in their way)."""
    import numpy as np

    from holecli.geometry.circle import fit_circle_robust
    from holecli.robust.candidates import occupancy_grid

    angles = np.linspace(0.0, 2.0 * np.pi, 40, endpoint=False)
    radii = 1.0 + 0.01 * np.random.default_rng(0).standard_normal(len(angles))
    radii[0] = 1.3  # one point 30 sigmas off the circle: clipped at 4 sigmas, kept at 1e6
    xy = radii[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
    assert not fit_circle_robust(xy).kept[0]
    assert fit_circle_robust(xy, settings=RobustSettings(clip_sigmas=1e6)).kept.all()
    # Two occupied cells far from everything: a speck at max_speck_cells 8, material at 0.
    grid = np.stack(np.meshgrid(np.arange(30.0), np.arange(30.0)), axis=-1).reshape(-1, 2)
    ring = grid[np.hypot(grid[:, 0] - 15, grid[:, 1] - 15) > 8]
    specks = np.array([[15.0, 15.0], [16.0, 15.0]])
    points = np.vstack([ring, specks])
    default = occupancy_grid(points, 1.0)
    kept = occupancy_grid(points, 1.0, settings=RobustSettings(max_speck_cells=0))
    cells = default.cell_of(specks)
    assert not default.material[cells[:, 0], cells[:, 1]].any()
    assert kept.material[cells[:, 0], cells[:, 1]].all()
