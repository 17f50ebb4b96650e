"""Holes among slots, cut-outs and bosses (issue 24): fresh panels of ``benchmarks/cutouts.py``, built by
holecli.simulation.panel and scanned by its profiler (pitch 0.05-0.25 mm, tilt 0-25 deg, noise 0-10 um,
fan or parallel rays), six real holes each among a long slot (aspect >= 3, longer than twice the hole
spacing), a rectangular cut-out with rounded corners and a boss or a second slot, the latter often cut
by the scan's border.

Measured over seeds 0-39 (``python benchmarks/cutouts.py --seeds 40``): 239 of 240 holes within the
validation tolerances; nothing on a slot or a cut-out (117 features, 73 cut by the border); 2 reports on
bosses cut by the border (seeds 26 and 32, see the CHANGELOG). Without ``material_in_first_circle``
(``--set max_material_dropped=1``) 5 cut-outs of the 40 scenes are reported as holes of 10-24 mm
(seeds 0, 4, 16, 29, 31). The test runs the first twelve seeds, two of which (0, 4) need the check.
"""

import importlib.util
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "cutouts.py"
_SPEC = importlib.util.spec_from_file_location("cutouts", _PATH)
cutouts = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(cutouts)


def test_holes_among_slots_cutouts_and_bosses():
    results = [cutouts.measure(seed) for seed in range(12)]
    expected = sum(r["expected"] for r in results)
    within = sum(r["within"] for r in results)
    assert expected == 72
    assert within == expected, [r["misses"] for r in results if r["misses"]]
    # nothing reported on a slot, a cut-out or a boss, nor anywhere else that is not a hole
    assert sum(r["extra"] for r in results) == 0, [(r["seed"], r["extras"]) for r in results if r["extras"]]
    # the scenes do cut features by the scan's border
    assert sum(r["cut"] for r in results) >= 12
