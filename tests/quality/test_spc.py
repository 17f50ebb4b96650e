"""holecli.quality.spc: control charts, run rules and capability against published worked examples
(tests/data/spc/, README.md there names each source) and constructed series."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, stats

from holecli.quality.spc import (CONSTANTS, Capability, ControlChart, RuleViolation, capability,
                                 individuals_charts, western_electric, xbar_r_charts)

DATA = Path(__file__).resolve().parents[1] / "data" / "spc"
EXPECTED = json.loads((DATA / "expected.json").read_text(encoding="utf-8"))


def _rows(name):
    with open(DATA / name, newline="", encoding="utf-8") as stream:
        return list(csv.DictReader(stream))


@pytest.fixture(scope="module")
def pistonrings():
    """The 25 phase-I samples of 5 piston ring diameters (qcc's data(pistonrings)), as a 25 x 5 array."""
    rows = [row for row in _rows("pistonrings.csv") if row["trial"] == "true"]
    assert [int(row["sample"]) for row in rows] == [s for s in range(1, 26) for _ in range(5)]
    return np.array([float(row["diameter"]) for row in rows]).reshape(25, 5)


@pytest.fixture(scope="module")
def viscosity():
    """The 20 phase-I viscosities (qcc's data(viscosity)), in batch order."""
    return np.array([float(row["viscosity"]) for row in _rows("viscosity.csv") if row["trial"] == "true"])


# ---- the constants table ---------------------------------------------------------------------------

@pytest.mark.parametrize("n, name, value", [(2, "d2", 1.128), (5, "d2", 2.326), (5, "D4", 2.114), (5, "A2", 0.577),
                                            (7, "D3", 0.076), (2, "D4", 3.267), (2, "D3", 0.0), (25, "d2", 3.931)])
def test_constants_have_their_textbook_values(n, name, value):
    assert CONSTANTS[n][name] == pytest.approx(value, abs=5e-4)


def test_constants_agree_with_the_printed_table_for_every_subgroup_size():
    # constants.csv: the three-decimal table (four for c4) as two textbooks print it; printed tables
    # differ among themselves by a unit in the third decimal at a few large n
    rows = _rows("constants.csv")
    assert [int(row["n"]) for row in rows] == list(range(2, 26)) == sorted(CONSTANTS)
    for row in rows:
        for name in ("d2", "d3", "A2", "D3", "D4", "c4"):
            if row[name]:
                tolerance = 5e-5 if name == "c4" else 1.5e-3
                assert CONSTANTS[int(row["n"])][name] == pytest.approx(float(row[name]), abs=tolerance), (row["n"], name)


def test_d2_is_the_expected_range_of_normal_samples():
    # d2(n) = integral of 1 - Phi(x)^n - (1 - Phi(x))^n: the table's three decimals
    for n, constants in CONSTANTS.items():
        exact = integrate.quad(lambda x: 1 - stats.norm.cdf(x) ** n - stats.norm.sf(x) ** n, -np.inf, np.inf)[0]
        assert constants["d2"] == pytest.approx(exact, abs=5e-4), n


@pytest.mark.parametrize("n", [2, 7, 25])
def test_d3_is_the_standard_deviation_of_the_range(n):
    # E[R^2] = 2 double-integral over x < y of 1 - Phi(y)^n - (1 - Phi(x))^n + (Phi(y) - Phi(x))^n
    cdf = stats.norm.cdf
    second = 2 * integrate.dblquad(lambda y, x: 1 - cdf(y) ** n - (1 - cdf(x)) ** n + (cdf(y) - cdf(x)) ** n,
                                   -9, 9, lambda x: x, lambda x: 9, epsabs=1e-10)[0]
    exact_d2 = integrate.quad(lambda x: 1 - cdf(x) ** n - stats.norm.sf(x) ** n, -np.inf, np.inf)[0]
    assert CONSTANTS[n]["d3"] == pytest.approx(math.sqrt(second - exact_d2 ** 2), abs=5e-5)


def test_derived_constants_follow_from_d2_and_d3():
    for n, c in CONSTANTS.items():
        assert c["A2"] == pytest.approx(3 / (c["d2"] * math.sqrt(n)))
        assert c["D4"] == pytest.approx(1 + 3 * c["d3"] / c["d2"])
        assert c["D3"] == pytest.approx(max(0.0, 1 - 3 * c["d3"] / c["d2"]))
        assert (c["D3"] == 0) == (n <= 6)
        assert c["c4"] == pytest.approx(math.sqrt(2 / (n - 1)) * math.gamma(n / 2) / math.gamma((n - 1) / 2))


# ---- individuals and moving-range charts ------------------------------------------------------------

def test_individuals_chart_reproduces_the_nist_flow_rate_example():
    case = EXPECTED["nist_individuals"]
    i_chart, mr_chart = individuals_charts(case["values"])
    tol = case["tolerance"]
    assert (i_chart.kind, mr_chart.kind) == ("individuals", "moving_range")
    assert i_chart.center == pytest.approx(case["center"], abs=tol)
    assert i_chart.lower == pytest.approx(case["lower"], abs=tol)
    assert i_chart.upper == pytest.approx(case["upper"], abs=tol)
    assert mr_chart.center == pytest.approx(case["mr_bar"], abs=tol)
    np.testing.assert_allclose(mr_chart.points, case["moving_ranges"], atol=1e-12)
    np.testing.assert_array_equal(i_chart.points, case["values"])
    # MR limits: 0 and D4(2) MRbar; sigma MRbar / 1.128 on both charts
    assert mr_chart.lower == 0.0
    assert mr_chart.upper == pytest.approx(CONSTANTS[2]["D4"] * case["mr_bar"], abs=1e-4)
    assert i_chart.sigma == mr_chart.sigma == pytest.approx(case["mr_bar"] / 1.128, abs=1e-4)
    # "On both charts the process is in control"
    assert case["in_control"] and i_chart.violations == () and mr_chart.violations == ()


def test_individuals_chart_reproduces_qcc_on_the_viscosity_data(viscosity):
    case = EXPECTED["qcc_viscosity_individuals"]
    tol = case["tolerance"]
    for values, expected in ((viscosity, case["all_batches"]), (np.delete(viscosity, 3), case["without_batch_4"])):
        i_chart, _ = individuals_charts(values)
        assert i_chart.center == pytest.approx(expected["center"], abs=tol)
        assert i_chart.sigma == pytest.approx(expected["std_dev"], abs=5e-8)
        assert i_chart.lower == pytest.approx(expected["lower"], abs=tol)
        assert i_chart.upper == pytest.approx(expected["upper"], abs=tol)
    # batch 4, the one the vignette removes as out of control, is the one beyond the upper limit
    i_chart, _ = individuals_charts(viscosity)
    rule_1 = [v for v in i_chart.violations if v.rule == 1]
    assert rule_1 == [RuleViolation(case["all_batches"]["out_of_control_batch"] - 1, 1, "beyond the upper control limit")]


def test_moving_range_chart_judges_rule_1_only():
    # moving ranges 0.5, 0.2 x 9: nine in a row below their center line (rule 4 on an I chart), none
    # beyond the limits; then a jump of 5 beyond D4 MRbar
    values = np.cumsum([0.0, 0.5] + [0.2] * 9)
    _, mr_chart = individuals_charts(values)
    assert np.all(mr_chart.points[1:] < mr_chart.center) and mr_chart.violations == ()
    _, mr_chart = individuals_charts(np.append(values, values[-1] + 5.0))
    assert mr_chart.violations == (RuleViolation(10, 1, "beyond the upper control limit"),)


def test_the_individuals_chart_judges_the_rules_in_sigmas_of_the_values():
    values = [0.0, 0.3, -0.2, 0.1, 0.0, -0.1, 0.2, 5.0]
    i_chart, _ = individuals_charts(values)
    assert i_chart.violations == western_electric(values, i_chart.center, i_chart.sigma)
    assert RuleViolation(7, 1, "beyond the upper control limit") in i_chart.violations


def test_equal_values_give_a_zero_sigma_and_no_signal():
    i_chart, mr_chart = individuals_charts([2.5] * 6)
    assert i_chart.sigma == 0 and i_chart.lower == i_chart.upper == i_chart.center == 2.5
    assert mr_chart.upper == 0 and i_chart.violations == mr_chart.violations == ()


@pytest.mark.parametrize("values, match", [([1.0], "at least 2 values, got 1"), ([], "at least 2 values, got 0"),
                                           ([1.0, float("nan"), 2.0], "finite, got nan at index 1"),
                                           ([1.0, float("inf")], "finite, got inf at index 1"),
                                           ([[1.0, 2.0], [3.0, 4.0]], "1-D array, got 2")])
def test_individuals_charts_refuse_bad_values(values, match):
    with pytest.raises(ValueError, match=match):
        individuals_charts(values)


# ---- X-bar and R charts -----------------------------------------------------------------------------

def test_xbar_r_charts_reproduce_qcc_on_the_piston_rings(pistonrings):
    case = EXPECTED["qcc_pistonrings_xbar_r"]
    tol = case["tolerance"]
    xbar, r_chart = xbar_r_charts(pistonrings)
    assert (xbar.kind, r_chart.kind) == ("xbar", "range")
    assert xbar.center == pytest.approx(case["xbar"]["center"], abs=tol)
    assert xbar.sigma == r_chart.sigma == pytest.approx(case["xbar"]["std_dev"], abs=5e-10)
    assert xbar.lower == pytest.approx(case["xbar"]["lower"], abs=tol)
    assert xbar.upper == pytest.approx(case["xbar"]["upper"], abs=5e-5)  # printed 74.0143
    assert r_chart.center == pytest.approx(case["range"]["center"], abs=tol)
    assert r_chart.lower == case["range"]["lower"]
    assert r_chart.upper == pytest.approx(case["range"]["upper"], abs=5e-9)
    # the textbook forms: grand mean +- A2 Rbar, D4 Rbar
    assert xbar.upper - xbar.center == pytest.approx(CONSTANTS[5]["A2"] * r_chart.center)
    assert r_chart.upper == pytest.approx(2.114 * r_chart.center, rel=5e-4)
    np.testing.assert_allclose(xbar.points, pistonrings.mean(axis=1))
    np.testing.assert_allclose(r_chart.points, pistonrings.max(axis=1) - pistonrings.min(axis=1))
    # phase I of the piston rings is in control (Montgomery's conclusion)
    assert xbar.violations == () and r_chart.violations == ()


def test_the_xbar_chart_judges_the_rules_in_sigmas_of_the_means():
    # means 0.05 apart with ranges of 0.1 (sigma 0.1/2.059, of a mean of 4 half that): the last two means
    # lie beyond 2 sigma/sqrt(4) though within 2 sigma
    rng = np.random.default_rng(5)
    base = np.array([-0.05, 0.05, 0.0, 0.02])
    subgroups = np.array([base + shift for shift in [0.0, 0.01, -0.01, 0.0, 0.01, -0.01, 0.0, 0.075, 0.08]])
    subgroups = subgroups[:, rng.permutation(4)]
    xbar, r_chart = xbar_r_charts(subgroups)
    sigma_mean = xbar.sigma / 2
    assert xbar.violations == western_electric(xbar.points, xbar.center, sigma_mean)
    assert any(v.rule == 2 and v.index == 8 for v in xbar.violations)
    assert np.all(np.abs(xbar.points - xbar.center) < 2 * xbar.sigma)
    assert r_chart.violations == ()


def test_range_chart_of_large_subgroups_has_a_lower_limit_and_flags_below_it():
    rng = np.random.default_rng(7)
    subgroups = rng.normal(size=(20, 7))
    subgroups[12] = subgroups[12].mean() + np.linspace(-0.01, 0.01, 7)  # a range near 0
    _, r_chart = xbar_r_charts(subgroups)
    assert r_chart.lower == pytest.approx(CONSTANTS[7]["D3"] * r_chart.center) and r_chart.lower > 0
    assert RuleViolation(12, 1, "beyond the lower control limit") in r_chart.violations
    assert {v.rule for v in r_chart.violations} == {1}


@pytest.mark.parametrize("subgroups, match", [([1.0, 2.0, 3.0], "2-D array"), (np.ones((5, 1)), "size must be 2 to 25, got 1"),
                                              (np.ones((5, 26)), "size must be 2 to 25, got 26"),
                                              (np.ones((1, 5)), "at least 2 subgroups, got 1"),
                                              ([[1.0, np.nan], [2.0, 3.0]], "finite, got nan at index 1")])
def test_xbar_r_charts_refuse_bad_subgroups(subgroups, match):
    with pytest.raises(ValueError, match=match):
        xbar_r_charts(subgroups)


# ---- Western Electric rules -------------------------------------------------------------------------

@pytest.mark.parametrize("case", EXPECTED["qcc_rules"]["cases"], ids=lambda case: f"rule{case['rule']}")
def test_western_electric_flags_what_qcc_flags(case):
    rules = EXPECTED["qcc_rules"]
    found = western_electric(case["points"], rules["center"], rules["sigma"])
    assert [v.index + 1 for v in found if v.rule == case["rule"]] == case["indices"]


def test_overlapping_patterns_are_each_reported_once_per_rule():
    overlap = EXPECTED["qcc_rules"]["overlap"]
    found = western_electric(overlap["points"], 0.0, 1.0)
    by_rule = {rule: [v.index + 1 for v in found if v.rule == rule] for rule in (1, 2, 3, 4)}
    # as qcc, except that rules 2 and 3 cut their window at the series' start (README: holecli_differs)
    assert by_rule[1] == overlap["indices"]["1"] and by_rule[4] == overlap["indices"]["4"]
    assert by_rule[2] == [2] + overlap["indices"]["2"]
    assert by_rule[3] == [4] + overlap["indices"]["3"]
    assert len({(v.index, v.rule) for v in found}) == len(found)
    assert [(v.index, v.rule) for v in found] == sorted((v.index, v.rule) for v in found)


@pytest.mark.parametrize("points, expected", [
    # rule 1: beyond 3 sigma, strictly
    ([0.0, 3.01], [(1, 1, "beyond the upper control limit")]),
    ([0.0, -3.01], [(1, 1, "beyond the lower control limit")]),
    ([0.0, 3.0, -3.0], []),
    # rule 2: 2 of 3 beyond 2 sigma on one side, the last of them completing it
    ([0.0, 2.1, 0.0, 2.1], [(3, 2, "2 of 3 points in a row more than 2 sigma above the center line")]),
    ([0.0, -2.1, -2.1], [(2, 2, "2 of 3 points in a row more than 2 sigma below the center line")]),
    ([2.1, 0.0, 0.0, 2.1], []),
    ([0.0, 2.1, -2.1], []),
    ([0.0, 2.1, 2.0], []),
    # rule 3: 4 of 5 beyond 1 sigma on one side
    ([0.0, 1.1, 1.1, 0.0, 1.1, 1.1], [(5, 3, "4 of 5 points in a row more than 1 sigma above the center line")]),
    ([1.1, 1.1, 0.0, 0.0, 1.1, 1.1], []),
    ([0.0, 1.1, 1.1, 1.0, 1.1], []),
    ([0.0, -1.1, -1.1, 1.1, -1.1, -1.1], [(5, 3, "4 of 5 points in a row more than 1 sigma below the center line")]),
    # rule 4: 8 in a row on one side; a point on the center line breaks the run
    ([0.1] * 8, [(7, 4, "8 points in a row above the center line")]),
    ([-0.1] * 8, [(7, 4, "8 points in a row below the center line")]),
    ([0.1] * 7, []),
    ([0.1] * 4 + [0.0] + [0.1] * 4, []),
    ([0.1] * 7 + [-0.1] + [0.1] * 7, []),
])
def test_each_rule_triggers_exactly_and_just_misses(points, expected):
    found = western_electric(points, center=0.0, sigma=1.0)
    assert [(v.index, v.rule, v.message) for v in found] == expected


def test_a_long_run_flags_every_point_from_its_eighth():
    found = western_electric([0.1] * 11, center=0.0, sigma=1.0)
    assert [(v.index, v.rule) for v in found] == [(7, 4), (8, 4), (9, 4), (10, 4)]


def test_rules_scale_with_center_and_sigma():
    points = np.array([0.0, 2.5, 1.1, 2.6, 3.2, -0.5])
    plain = western_electric(points, 0.0, 1.0)
    assert western_electric(74.0 + 0.01 * points, 74.0, 0.01) == plain
    assert western_electric(-points, 0.0, 1.0) == tuple(
        RuleViolation(v.index, v.rule, v.message.replace("above", "below").replace("upper", "lower")) for v in plain)


def test_a_zero_sigma_flags_every_point_off_the_center():
    found = western_electric([1.0, 1.0, 1.5], center=1.0, sigma=0.0)
    assert [(v.index, v.rule) for v in found] == [(2, 1)]


@pytest.mark.parametrize("points, center, sigma, match", [([0.0, 1.0], 0.0, -1.0, "sigma must be finite and >= 0"),
                                                          ([0.0, 1.0], 0.0, float("nan"), "sigma must be finite"),
                                                          ([0.0, 1.0], float("inf"), 1.0, "center must be finite"),
                                                          ([0.0, np.nan], 0.0, 1.0, "points must be finite"),
                                                          ([[0.0]], 0.0, 1.0, "1-D array")])
def test_western_electric_refuses_bad_input(points, center, sigma, match):
    with pytest.raises(ValueError, match=match):
        western_electric(points, center, sigma)


def test_no_points_no_violations():
    assert western_electric([], 0.0, 1.0) == ()


# ---- capability -------------------------------------------------------------------------------------

def _assert_index(value, interval, expected, tolerance):
    assert [value, *interval] == pytest.approx(expected, abs=tolerance)


@pytest.mark.parametrize("case", EXPECTED["qcc_pistonrings_capability"]["cases"],
                         ids=lambda case: f"{case['lower']}-{case['upper']}")
def test_capability_reproduces_qcc_on_the_piston_rings(pistonrings, case):
    published = EXPECTED["qcc_pistonrings_capability"]
    xbar, _ = xbar_r_charts(pistonrings)
    result = capability(pistonrings.ravel(), case["lower"], case["upper"], sigma_within=xbar.sigma)
    assert result.n == published["n"]
    assert result.mean == pytest.approx(published["center"], abs=5e-6)
    assert result.sigma_within == pytest.approx(published["std_dev"], abs=5e-10)
    _assert_index(result.cp, result.cp_interval, case["cp"], case["tolerance"])
    _assert_index(result.cpk, result.cpk_interval, case["cpk"], case["tolerance"])


@pytest.mark.parametrize("case", EXPECTED["qcc_capability_tests"]["cases"],
                         ids=["two-sided", "upper-only", "lower-only"])
def test_capability_reproduces_qccs_own_tests(case):
    published = EXPECTED["qcc_capability_tests"]
    subgroups = np.array(published["subgroups"])
    xbar, _ = xbar_r_charts(subgroups)
    result = capability(subgroups.ravel(), case["lower"], case["upper"], sigma_within=xbar.sigma)
    for name in ("cp", "cpk", "pp", "ppk"):
        value, interval = getattr(result, name), getattr(result, f"{name}_interval")
        if case[name] is None:
            assert value is None and interval is None, name
        else:
            _assert_index(value, interval, case[name], published["tolerance"])


def _sample(mean, sigma, n=30):
    """n values with exactly this mean and sample standard deviation (ddof=1)."""
    z = np.linspace(-1.0, 1.0, n) ** 3
    return mean + sigma * (z - z.mean()) / z.std(ddof=1)


def test_capability_reproduces_the_nist_example():
    case = EXPECTED["nist_capability"]
    values = _sample(case["mean"], case["sigma"])
    tol = case["tolerance"]
    both = capability(values, case["lower"], case["upper"], sigma_within=case["sigma"])
    assert both.cp == pytest.approx(case["cp"], abs=tol) and both.cpk == pytest.approx(case["cpk"], abs=tol)
    assert both.pp == pytest.approx(case["cp"], abs=tol) and both.ppk == pytest.approx(case["cpk"], abs=tol)
    upper_only = capability(values, None, case["upper"], sigma_within=case["sigma"])
    assert upper_only.cp is None and upper_only.pp is None
    assert upper_only.cpk == pytest.approx(case["cpu"], abs=tol) and upper_only.ppk == pytest.approx(case["cpu"], abs=tol)
    lower_only = capability(values, case["lower"], None, sigma_within=case["sigma"])
    assert lower_only.cpk == pytest.approx(case["cpl"], abs=tol)


def test_capability_intervals_are_the_chi_square_and_normal_formulas():
    values = _sample(10.0, 0.5, n=40)
    result = capability(values, 8.0, 13.0, sigma_within=0.45, confidence=0.9)
    n, alpha = 40, 0.1
    cp = 5.0 / (6 * 0.45)
    assert result.cp == pytest.approx(cp)
    assert result.cp_interval == pytest.approx(tuple(cp * np.sqrt(stats.chi2.ppf([alpha / 2, 1 - alpha / 2], n - 1) / (n - 1))))
    cpk = 2.0 / (3 * 0.45)
    z = stats.norm.ppf(1 - alpha / 2)
    half = cpk * z * np.sqrt(1 / (9 * n * cpk ** 2) + 1 / (2 * (n - 1)))
    assert result.cpk_interval == pytest.approx((cpk - half, cpk + half))
    assert result.confidence == 0.9
    wider = capability(values, 8.0, 13.0, sigma_within=0.45, confidence=0.99)
    assert wider.cp_interval[0] < result.cp_interval[0] < result.cp < result.cp_interval[1] < wider.cp_interval[1]


def test_default_within_sigma_is_the_moving_range_of_the_values_in_order():
    values = _sample(5.0, 1.0, n=20)
    result = capability(values, 0.0, 10.0)
    assert result.sigma_within == pytest.approx(np.abs(np.diff(values)).mean() / 1.128)
    assert result.sigma_within == pytest.approx(individuals_charts(values)[0].sigma)
    shuffled = capability(values[np.random.default_rng(3).permutation(20)], 0.0, 10.0)
    assert shuffled.sigma_overall == pytest.approx(result.sigma_overall)
    assert shuffled.sigma_within != pytest.approx(result.sigma_within)


def test_a_mean_beyond_a_limit_gives_a_negative_cpk_with_an_ordered_interval():
    result = capability(_sample(11.0, 0.5), 8.0, 10.0)
    assert result.cpk < 0 and result.ppk < 0
    for value, (low, high) in ((result.cpk, result.cpk_interval), (result.ppk, result.ppk_interval)):
        assert low < value < high
    on_limit = capability(_sample(10.0, 0.5), 8.0, 10.0)
    assert on_limit.cpk == pytest.approx(0.0, abs=1e-12) and on_limit.cpk_interval[0] < 0 < on_limit.cpk_interval[1]


def test_a_zero_sigma_gives_no_indices():
    flat = capability([3.0] * 5, 2.0, 4.0)
    assert flat.sigma_within == 0 and flat.sigma_overall == 0
    assert (flat.cp, flat.cpk, flat.pp, flat.ppk) == (None, None, None, None)
    assert (flat.cp_interval, flat.cpk_interval, flat.pp_interval, flat.ppk_interval) == (None, None, None, None)
    within_zero = capability([1.0, 2.0, 3.0], 0.0, 4.0, sigma_within=0.0)
    assert within_zero.cp is None and within_zero.cpk is None and within_zero.cp_interval is None
    assert within_zero.pp == pytest.approx(4.0 / 6) and within_zero.ppk_interval is not None


def test_capability_result_is_a_frozen_record():
    result = capability([1.0, 2.0, 3.0], 0.0, 4.0)
    assert isinstance(result, Capability) and isinstance(result.n, int) and isinstance(result.cp, float)
    assert all(isinstance(bound, float) for bound in result.cp_interval + result.cpk_interval)
    with pytest.raises(AttributeError):
        result.cp = 2.0


@pytest.mark.parametrize("values, lower, upper, kwargs, match", [
    ([1.0], 0.0, 2.0, {}, "at least 2 values, got 1"),
    ([1.0, float("nan")], 0.0, 2.0, {}, "values must be finite"),
    ([1.0, 2.0], 2.0, 2.0, {}, "lower must be below upper, got lower 2.0 and upper 2.0"),
    ([1.0, 2.0], 3.0, 2.0, {}, "lower must be below upper"),
    ([1.0, 2.0], None, None, {}, "lower and upper are both None"),
    ([1.0, 2.0], float("-inf"), 2.0, {}, "lower must be finite or None"),
    ([1.0, 2.0], 0.0, float("nan"), {}, "upper must be finite or None"),
    ([1.0, 2.0], 0.0, 3.0, {"sigma_within": -1.0}, "sigma_within must be finite and >= 0"),
    ([1.0, 2.0], 0.0, 3.0, {"sigma_within": float("inf")}, "sigma_within must be finite"),
    ([1.0, 2.0], 0.0, 3.0, {"confidence": 1.0}, r"confidence must be in \(0, 1\)"),
])
def test_capability_refuses_bad_input(values, lower, upper, kwargs, match):
    with pytest.raises(ValueError, match=match):
        capability(values, lower, upper, **kwargs)


def test_charts_are_frozen_records():
    values = np.array([1.0, 2.0, 1.5])
    i_chart, _ = individuals_charts(values)
    assert isinstance(i_chart, ControlChart)
    values[0] = 99.0  # the chart keeps its own copy of the values
    assert i_chart.points[0] == 1.0
    with pytest.raises(AttributeError):
        i_chart.center = 0.0
