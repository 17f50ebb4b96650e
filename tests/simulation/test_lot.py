"""holecli.simulation.lot: the defect grammar, the cell's scatter and the defects of a lot's parts."""

import math

import pytest

from holecli.simulation.lot import DIAMETER_SIGMA, POSITION_SIGMA, Defect, lot_parts, parse_defect
from holecli.simulation.panel import parse_panel_toml
from tests.conftest import REPO_ROOT

PANEL = parse_panel_toml((REPO_ROOT / "sample_clouds" / "panel.toml").read_text())


@pytest.mark.parametrize("text, expected", [
    ("C1=diameter:+0.1", Defect("C1", "diameter", 0.1, None, "C1=diameter:+0.1")),
    ("2/C1=diameter:-0.05", Defect("C1", "diameter", -0.05, 2, "2/C1=diameter:-0.05")),
    ("T1=position:0.3", Defect("T1", "position", 0.3, None, "T1=position:0.3")),
    ("3/C1=countersink:0.1", Defect("C1", "countersink", 0.1, 3, "3/C1=countersink:0.1")),
    ("L1=missing", Defect("L1", "missing", None, None, "L1=missing")),
])
def test_parse_defect(text, expected):
    assert parse_defect(text) == expected


@pytest.mark.parametrize("text, message", [
    ("C1", "is not \\[PART/\\]HOLE=KIND\\[:SIZE\\]"),
    ("C1=bigger:0.1", "unknown defect 'bigger'"),
    ("C1=diameter", "diameter needs a size"),
    ("C1=diameter:abc", "must be a signed number"),
    ("C1=diameter:nan", "must be a signed number"),
    ("C1=position:-0.3", "must be a number >= 0"),
    ("L1=missing:1", "missing takes no size"),
    ("0/L1=missing", "counted from 1"),
])
def test_parse_defect_refuses(text, message):
    with pytest.raises(ValueError, match=message):
        parse_defect(text)


def _holes(truth):
    return {hole["name"]: hole for hole in truth["holes"]}


def test_every_part_is_drilled_with_a_small_scatter_and_its_own_seed():
    parts = lot_parts(PANEL, 20, seed=5)
    assert [truth["part"] for _, truth in parts] == list(range(1, 21))
    assert len({truth["scan_seed"] for _, truth in parts}) == 20
    drawing = {f.name: f for f in PANEL.features}
    for spec, truth in parts:
        assert not truth["defective"] and len(spec.features) == len(PANEL.features)
        for name, hole in _holes(truth).items():
            assert math.dist(hole["center"], drawing[name].center) < 6 * POSITION_SIGMA
            assert abs(hole["diameter"] - drawing[name].diameter) < 6 * DIAMETER_SIGMA
    offsets = [_holes(truth)["T1"]["center"][0] + 20.0 for _, truth in parts]
    assert max(offsets) - min(offsets) > 0  # scattered, not all alike
    assert lot_parts(PANEL, 3, seed=5)[2][1] == parts[2][1]  # reproducible


def test_defects_go_to_their_part_and_change_nothing_else():
    defects = [parse_defect(text) for text in ("2/C1=diameter:+0.1", "3/L1=missing", "4/T1=position:0.3",
                                               "5/C1=countersink:0.1")]
    clean = lot_parts(PANEL, 5, seed=1)
    parts = lot_parts(PANEL, 5, defects, seed=1)
    assert [truth["defective"] for _, truth in parts] == [False, True, True, True, True]
    assert parts[0][1] == clean[0][1]
    two, three, four, five = (_holes(parts[i][1]) for i in range(1, 5))
    assert two["C1"]["countersink_diameter"] == pytest.approx(_holes(clean[1][1])["C1"]["countersink_diameter"] + 0.1)
    assert three["L1"] == {"name": "L1", "drilled": False}
    assert "L1" not in {f.name for f in parts[2][0].features}
    assert math.dist(four["T1"]["center"], _holes(clean[3][1])["T1"]["center"]) == pytest.approx(0.3)
    grown = 2 * 0.1 * math.tan(math.radians(50.0))
    assert five["C1"]["countersink_diameter"] == pytest.approx(_holes(clean[4][1])["C1"]["countersink_diameter"] + grown)
    for index in (1, 2, 3, 4):  # the other holes of a defective part as in the clean lot
        for name in ("B1",):
            assert _holes(parts[index][1])[name] == _holes(clean[index][1])[name]
    assert parts[1][1]["defects"] == [{"defect": "2/C1=diameter:+0.1", "hole": "C1", "kind": "diameter", "size": 0.1}]


@pytest.mark.parametrize("text, message", [
    ("X9=missing", "the panel has no hole named 'X9'"),
    ("S1=missing", "the panel has no hole named 'S1'"),  # a slot is no hole
    ("T1=countersink:0.1", "T1 is through, not countersunk"),
    ("7/T1=missing", "there are only 5 parts"),
    ("T1=diameter:-5", "leaves T1's diameter at"),
])
def test_lot_refuses_defects_the_panel_cannot_take(text, message):
    with pytest.raises(ValueError, match=message):
        lot_parts(PANEL, 5, [parse_defect(text)])
