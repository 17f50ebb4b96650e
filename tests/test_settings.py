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


def test_function_defaults_are_the_settings():
    """One value per tunable: the steps' own defaults are RobustSettings' (unit tests exercise the
    values production uses)."""
    import inspect

    from holecli.geometry import circle, frame, plane
    from holecli.robust import candidates, sampling
    from holecli.robust.estimators import cone, lattice, rim_fit

    def defaults(function):
        return {name: p.default for name, p in inspect.signature(function).parameters.items()
                if p.default is not inspect.Parameter.empty}

    s = DEFAULT_SETTINGS
    robust = defaults(plane.fit_plane_robust)
    assert (robust["sample"], robust["hypotheses"], robust["quantile"], robust["clip"]) == (
        s.ransac_sample, s.ransac_hypotheses, s.ransac_quantile, s.plane_clip)
    assert (robust["max_rounds"], robust["refine_sample"], robust["max_faces"]) == (
        s.plane_refine_rounds, s.plane_refine_sample, s.plane_max_faces)
    assert defaults(frame.check_view_angle)["min_sine"] == s.view_min_sine
    from holecli.robust import edge_loops
    assert edge_loops.POCKET_MAX_DEPTH_RATIO == s.pocket_max_depth_ratio
    windows = defaults(sampling.estimate_sampling)
    assert (windows["windows"], windows["window_points"]) == (s.sampling_windows, s.sampling_window_points)
    assert defaults(circle.fit_circle_robust)["clip"] == circle.CLIP_SIGMAS == s.clip_sigmas
    assert defaults(candidates.occupancy_grid)["max_speck_cells"] == candidates.MAX_SPECK_CELLS == s.max_speck_cells
    assert defaults(cone.fit_cone_edge)["depth_slope_ratio"] == s.cone_depth_slope_ratio
    assert (cone.MIN_SLOPE, cone.MAX_SLOPE, cone.MIN_POINTS_BELOW, cone.DEPTH_BINS,
            cone.MIN_BIN_POINTS) == (s.cone_min_slope, s.cone_max_slope, s.cone_min_points_below,
                                            s.cone_depth_bins, s.cone_min_bin_points)
    for function in (sampling.estimate_sampling, cone.fit_cone_edge, lattice.lattice_steps,
                     lattice.separating_circle, rim_fit.sampling_bias, rim_fit.synthetic_rim_fit):
        assert defaults(function)["settings"] is DEFAULT_SETTINGS


def test_the_new_tunables_keep_their_values():
    """Moving a literal into RobustSettings changed no value."""
    s = DEFAULT_SETTINGS
    assert (s.plane_refine_rounds, s.plane_refine_sample, s.plane_max_faces, s.view_min_sine) == (20, 50_000, 3, 0.05)
    assert s.sampling_window_offset_sd == 0.7
    assert (s.sampling_gap_percentile, s.sampling_inner_fraction, s.sampling_line_coherence,
            s.sampling_min_pitch_spacings, s.sampling_lattice_coherence, s.sampling_pitch_neighbours) == (
        90.0, 0.6, 0.6, 1.3, 0.6, 16)
    assert s.max_speck_cells == 8
    assert (s.cut_alphas, s.bias_min_rim_points, s.bias_max_excess_alphas) == (2.0, 5, 1.0)
    assert (s.lattice_present_steps, s.lattice_missing_steps, s.lattice_min_present_fraction,
            s.lattice_min_brackets, s.lattice_max_gap_deg, s.lattice_others_steps) == (0.15, 0.5, 0.5, 8, 90.0, 2.0)
    assert (s.cone_min_slope, s.cone_max_slope, s.cone_min_points_below, s.cone_below_sigmas, s.cone_inner_widths,
            s.cone_trim_sigmas, s.cone_trim_rounds, s.cone_edge_steps, s.cone_depth_bins,
            s.cone_min_bin_points) == (0.2, 3.0, 12, 3.0, 2.0, 3.0, 3, 64, 8, 3)
