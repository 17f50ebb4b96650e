"""Scene suite of the robust method: known-answer synthetic scans and the accuracy contract.

Tolerances are in units of the scene's point spacing h (``SceneSpec.spacing``; for stripes, the
spacing along a scan line). Every true hole is matched to the nearest reported center, and

* the hole count is exact, and a hole is partial exactly when it is cut by the border;
* center (3D distance) within 0.25 h, diameter within 0.35 h;
* sparse scans (fewer than the ten scan lines across the hole that the paper asks for), points inside
  the hole, gross outliers: center and diameter within 1 h;
* normal within 0.05 degrees without noise, 0.1 degrees with noise or outliers.

Scenes on which the method is known to fail are ``xfail(strict=True)`` with the measured numbers in
the reason: when the method improves they XPASS, and the marker must go. Tests over several seeds
report every failing seed in their message.
"""

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.settings import DEFAULT_SETTINGS
from holecli.simulation import synth
from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan, rotation_matrix

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

H = 0.1  # point spacing of most scenes, mm
FAR = (769.0, -83.6, 218.8)  # a robot base frame: the cloud ~1000 mm from the origin

# The contract's tolerances (units of h; degrees).
CENTER = 0.25
DIAMETER = 0.35
LOOSE = 1.0
NORMAL = 0.05
NORMAL_NOISY = 0.1
# Fewer scan lines than this across a hole make a sparse scan (the paper's stated limit).
DENSE_LINES = 10


def xfail(reason):
    return pytest.mark.xfail(strict=True, reason=reason)


# --- helpers ---------------------------------------------------------------------------------------


def finite(points):
    return points[np.all(np.isfinite(points), axis=1)]


def angle_deg(a, b):
    cosine = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def panel(pattern="grid", *, hole=None, holes=None, noise=0.0, **changes):
    """A 9 x 9 mm patch (3 hole diameters) with a 3 mm hole off the lattice, in the Table I pose.

    Stripes are 3 h apart at 17 degrees unless changed; ``noise`` is the world-z sigma in units of h.
    """
    if holes is None:
        holes = (hole or HoleSpec(center=(0.37, -0.21), diameter=3.0),)
    scene = SceneSpec(holes=holes, extent=(-4.5, 4.5, -4.5, 4.5), spacing=H, pattern=pattern,
                      rotation_deg=(32.0, 0.0, 20.0), translation=(3.0, 4.0, 5.0), noise_world_z=noise * H)
    if pattern == "stripes":
        scene = replace(scene, line_pitch=3 * H, scan_angle_deg=17.0)
    return replace(scene, **changes)


def lines_crossing(scene, hole):
    """Scan lines of a striped ``scene`` that cross the hole's disk, from the generator's geometry."""
    xmin, _, ymin, _ = scene.extent
    angle = math.radians(scene.scan_angle_deg)
    origin = (xmin + scene.grid_offset[0], ymin + scene.grid_offset[1])
    across = -(hole.center[0] - origin[0]) * math.sin(angle) + (hole.center[1] - origin[1]) * math.cos(angle)
    radius, pitch = hole.surface_radius, scene.line_pitch
    first, last = math.floor((across - radius) / pitch), math.ceil((across + radius) / pitch)
    return sum(1 for j in range(first, last + 1) if abs(j * pitch - across) < radius)


def is_sparse(scene, hole):
    return scene.pattern == "stripes" and lines_crossing(scene, hole) < DENSE_LINES


@dataclass
class Measured:
    """A detection and, per true hole, the nearest reported hole and its errors (units of h, degrees)."""

    detection: object
    truth: dict
    matched: list = field(default_factory=list)
    center: list = field(default_factory=list)
    diameter: list = field(default_factory=list)
    normal: list = field(default_factory=list)

    def summary(self):
        rows = [f"c={c:.3f}h d={d:+.3f}h n={n:.4f}deg{' partial' if hole.partial else ''}"
                for hole, c, d, n in zip(self.matched, self.center, self.diameter, self.normal)]
        return f"{len(self.detection.holes)} holes reported; " + "; ".join(rows)


def measure(points, truth, **options):
    """Run the robust method on the finite rows of ``points`` and match every true hole."""
    detection = detect(finite(points), method="robust", **options)
    result = Measured(detection=detection, truth=truth)
    h = truth["spacing"]
    for true in truth["holes"]:
        if not true["is_hole"] or not detection.holes:
            continue
        distances = [float(np.linalg.norm(np.subtract(hole.center, true["center"]))) for hole in detection.holes]
        hole = detection.holes[int(np.argmin(distances))]
        result.matched.append(hole)
        result.center.append(min(distances) / h)
        result.diameter.append((hole.diameter - true["diameter"]) / h)
        result.normal.append(angle_deg(hole.normal, true["normal"]))
    return result


def measure_scene(scene, seed=0, **options):
    scan = make_scan(scene, seed)
    return measure(scan.points, scan.truth, **options)


def violations(result, scene=None, *, center=CENTER, diameter=DIAMETER, normal=NORMAL):
    """What breaks the contract in ``result`` (empty when nothing does).

    With ``scene``, holes with fewer than ten scan lines across get the loose tolerance.
    """
    true_holes = [t for t in result.truth["holes"] if t["is_hole"]]
    if len(result.detection.holes) != len(true_holes):
        return [f"count {len(result.detection.holes)} != {len(true_holes)}"]
    if len({id(hole) for hole in result.matched}) != len(true_holes):
        return ["two true holes matched to the same reported hole"]
    specs = [spec for spec in scene.holes if spec.boss_height == 0] if scene is not None else [None] * len(true_holes)
    found = []
    for k, (hole, true, spec) in enumerate(zip(result.matched, true_holes, specs)):
        sparse = spec is not None and is_sparse(scene, spec)
        if hole.partial != true["partial"]:
            found.append(f"hole {k}: partial={hole.partial}, arc {hole.arc_deg:.0f} deg")
        if result.center[k] >= max(center, LOOSE if sparse else 0.0):
            found.append(f"hole {k}: center {result.center[k]:.3f} h")
        if abs(result.diameter[k]) >= max(diameter, LOOSE if sparse else 0.0):
            found.append(f"hole {k}: diameter {result.diameter[k]:+.3f} h")
        if result.normal[k] >= normal:
            found.append(f"hole {k}: normal {result.normal[k]:.4f} deg")
    return found


def check(result, scene=None, **tolerances):
    """Assert the contract on one detection."""
    found = violations(result, scene, **tolerances)
    assert not found, f"{found}: {result.summary()}"


def check_seeds(scene, seeds, **tolerances):
    """Assert the contract on the scans of ``scene`` for every seed; the message lists every failure."""
    failures = {}
    for seed in seeds:
        result = measure_scene(scene, seed)
        found = violations(result, scene, **tolerances)
        if found:
            failures[seed] = f"{found}: {result.summary()}"
    assert not failures, failures


# --- sampling patterns, poses and scales -----------------------------------------------------------

BASIC = [
    pytest.param(panel("grid"), [0], NORMAL, id="grid"),
    pytest.param(panel("stripes", line_pitch=2 * H), [0], NORMAL, id="stripes-pitch-2h"),
    pytest.param(panel("stripes", line_pitch=3 * H), [0], NORMAL, id="stripes-pitch-3h"),
    pytest.param(panel("stripes", line_pitch=4 * H), [0], NORMAL, id="stripes-pitch-4h"),
    pytest.param(panel("random"), range(4), NORMAL, id="random"),
    pytest.param(panel("jittered"), range(4), NORMAL, id="jittered"),
    pytest.param(panel("grid", noise=0.1), range(3), NORMAL_NOISY, id="grid-noise-10pct"),
    pytest.param(panel("stripes", noise=0.1), range(3), NORMAL_NOISY, id="stripes-noise-10pct"),
    pytest.param(panel("random", noise=0.1), range(3), NORMAL_NOISY, id="random-noise-10pct"),
    pytest.param(panel("jittered", noise=0.1), range(3), NORMAL_NOISY, id="jittered-noise-10pct"),
    pytest.param(panel("grid", translation=FAR, noise=0.1), range(2), NORMAL_NOISY, id="far-grid"),
    pytest.param(panel("stripes", translation=FAR, noise=0.1), range(2), NORMAL_NOISY, id="far-stripes"),
    pytest.param(panel("random", translation=FAR, noise=0.1), range(2), NORMAL_NOISY, id="far-random"),
]
for _tilt in (0, 30, 50, 70):
    # Without noise a tilt changes nothing in the plane frame; with world-z noise it moves points in plane.
    BASIC += [
        pytest.param(panel("grid", rotation_deg=(_tilt, 0.0, 0.0)), [0], NORMAL, id=f"tilt-{_tilt}"),
        pytest.param(panel("stripes", rotation_deg=(_tilt, 0.0, 0.0)), [0], NORMAL, id=f"tilt-{_tilt}-stripes"),
        pytest.param(panel("grid", rotation_deg=(_tilt, 0.0, 0.0), noise=0.1), range(6), NORMAL_NOISY,
                     id=f"tilt-{_tilt}-noise-10pct"),
        pytest.param(panel("stripes", rotation_deg=(_tilt, 0.0, 0.0), noise=0.1), range(6), NORMAL_NOISY,
                     id=f"tilt-{_tilt}-stripes-noise-10pct"),
    ]


@pytest.mark.parametrize("scene, seeds, normal", BASIC)
def test_one_hole_within_the_contract(scene, seeds, normal):
    check_seeds(scene, seeds, normal=normal)


def sized(diameter, spacing, pattern, pitch=None):
    """A hole of ``diameter`` on a square patch 3 diameters wide, tilted and off the lattice."""
    half = 1.5 * diameter
    return SceneSpec(holes=(HoleSpec(center=(0.041 * diameter, 0.026 * diameter), diameter=diameter),),
                     extent=(-half, half, -half, half), spacing=spacing, pattern=pattern, line_pitch=pitch,
                     scan_angle_deg=10.0, rotation_deg=(20.0, 10.0, 5.0), translation=(3.0, 4.0, 5.0))


@pytest.mark.parametrize("scene", [
    pytest.param(sized(1.0, 0.02, "grid"), id="1mm-grid"),
    pytest.param(sized(1.0, 0.02, "stripes", 0.04), id="1mm-stripes"),
    pytest.param(sized(20.0, 0.25, "grid"), id="20mm-grid"),
    pytest.param(sized(20.0, 0.25, "stripes", 0.5), id="20mm-stripes"),
])
def test_small_and_large_holes(scene):
    check(measure_scene(scene), scene)


@pytest.mark.parametrize("pattern", [
    "grid",
    "stripes",
    "random",
    "jittered",
])
def test_metres_give_the_millimetre_result_scaled(pattern):
    """The same scan in metres (unit_scale 0.001): every length scales by 0.001, to round-off."""
    scene = panel(pattern, translation=FAR, noise=0.1)
    millimetres = measure_scene(scene)
    metres = measure_scene(replace(scene, unit_scale=0.001))
    check(metres, normal=NORMAL_NOISY)
    assert len(metres.detection.holes) == len(millimetres.detection.holes)
    for mm, m in zip(millimetres.detection.holes, metres.detection.holes):
        difference = (abs(1000.0 * m.diameter - mm.diameter) / H,
                      np.linalg.norm(1000.0 * np.asarray(m.center) - mm.center) / H)
        assert max(difference) < 1e-6, difference
        assert angle_deg(m.normal, mm.normal) < 1e-6


# --- several holes ---------------------------------------------------------------------------------


def many(count, pattern, noise=0.0):
    """``count`` holes of 1.5 to 6 mm in rows of five, 8 mm apart (never overlapping), h = 0.12 mm."""
    rng = np.random.default_rng(count)
    holes = []
    for k in range(count):
        row, column = divmod(k, 5)
        center = (8.0 * column + rng.uniform(-0.5, 0.5), 8.0 * row + rng.uniform(-0.5, 0.5))
        holes.append(HoleSpec(center=center, diameter=float(rng.uniform(1.5, 6.0))))
    extent = (-4.5, 8.0 * min(count, 5) - 3.5, -4.5, 8.0 * -(-count // 5) - 3.5)
    scene = SceneSpec(holes=tuple(holes), extent=extent, spacing=0.12, pattern=pattern,
                      rotation_deg=(25.0, -10.0, 40.0), translation=(3.0, 4.0, 5.0), noise_world_z=noise * 0.12)
    if pattern == "stripes":
        scene = replace(scene, line_pitch=0.36, scan_angle_deg=8.0)
    return scene


@pytest.mark.parametrize("scene", [
    pytest.param(many(count, pattern, noise), id=f"{count}-holes-{pattern}" + ("-noise-10pct" if noise else ""))
    for count in (2, 5, 10) for pattern in ("grid", "stripes") for noise in (0.0, 0.1)
])
def test_several_holes_in_one_cloud(scene):
    """Holes with fewer than ten scan lines across (the 2.1 mm hole on stripes: 6) are sparse."""
    check(measure_scene(scene), scene, normal=NORMAL_NOISY if scene.noise_world_z else NORMAL)


# --- what else a scan holds: inside points, bore wall, countersink, outliers, a boss, a wall -------


@pytest.mark.parametrize("inside", [10, 100])
def test_points_inside_the_hole(inside):
    """The paper's Table I scene with reflections inside the hole (its Fig. 5), noise 10 % of h.

    100 reflections in the 3 mm hole (one grid position in nine) join the material next to the edge
    and shield its true rim; with rim points dropped only an alpha (2.5 gaps) inside their direction's
    outermost, over seeds 0-15 the diameter came out 0.28 to 1.55 h too small. With a gap (setting
    ``envelope_gaps``), within 0.3 h on every seed.
    """
    check_seeds(synth.table1_scene(0.1, inside), range(16), center=CENTER, diameter=DIAMETER, normal=NORMAL_NOISY)


BORE = HoleSpec(center=(0.37, -0.21), diameter=3.0, bore_depth=2.0)
COUNTERSINK = HoleSpec(center=(0.37, -0.21), diameter=3.0, countersink_diameter=4.5, countersink_angle_deg=100.0)


@pytest.mark.parametrize("scene, normal", [
    pytest.param(panel("grid", hole=BORE), NORMAL, id="bore-grid"),
    pytest.param(panel("stripes", hole=BORE), NORMAL, id="bore-stripes"),
    pytest.param(panel("random", hole=BORE), NORMAL, id="bore-random"),
    pytest.param(panel("grid", hole=BORE, noise=0.1), NORMAL_NOISY, id="bore-grid-noise-10pct"),
    pytest.param(panel("stripes", hole=BORE, noise=0.1), NORMAL_NOISY, id="bore-stripes-noise-10pct"),
    pytest.param(panel("random", hole=BORE, noise=0.1), NORMAL_NOISY, id="bore-random-noise-10pct"),
    pytest.param(panel("grid", hole=COUNTERSINK), NORMAL, id="countersink-grid"),
    pytest.param(panel("stripes", hole=COUNTERSINK), NORMAL, id="countersink-stripes"),
    pytest.param(panel("random", hole=COUNTERSINK), NORMAL, id="countersink-random"),
    pytest.param(panel("grid", hole=COUNTERSINK, noise=0.1), NORMAL_NOISY, id="countersink-grid-noise-10pct"),
    pytest.param(panel("stripes", hole=COUNTERSINK, noise=0.1), NORMAL_NOISY, id="countersink-stripes-noise-10pct"),
    pytest.param(panel("random", hole=COUNTERSINK, noise=0.1), NORMAL_NOISY, id="countersink-random-noise-10pct"),
])
def test_bore_wall_and_countersink(scene, normal):
    """Bore-wall points are not the edge; a countersunk hole's diameter is the cone's at the surface."""
    if scene.holes[0].countersink_diameter is not None:
        assert make_scan(scene, 0).truth["holes"][0]["diameter"] == 4.5
    check_seeds(scene, range(4), normal=normal)


@pytest.mark.parametrize("pattern", ["grid", "stripes", "random", "jittered"])
def test_gross_outliers(pattern):
    """1 % gross outliers over the scan, 5 % of h noise (measured within 0.15 h; the contract allows 1 h)."""
    check_seeds(panel(pattern, outlier_fraction=0.01, noise=0.05), range(3), center=LOOSE, diameter=LOOSE,
                normal=NORMAL_NOISY)


@pytest.mark.parametrize("pattern", ["grid", "stripes", "random"])
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_a_boss_is_not_a_hole(pattern, noise):
    """A hole and, beside it, a pin 1 mm high: only the hole is reported."""
    holes = (HoleSpec(center=(-2.0, 0.1), diameter=2.5), HoleSpec(center=(2.2, -0.3), diameter=2.5, boss_height=1.0))
    scene = panel(pattern, holes=holes, extent=(-4.5, 5.0, -3.5, 3.5), noise=noise)
    check_seeds(scene, range(2), normal=NORMAL_NOISY if noise else NORMAL)


def with_wall(noise, side, seed=0):
    """The Table I scene plus half as many points on a wall perpendicular to it, then world-z noise.

    ``side="y"``: the wall y = 5.5 (local), which the Table I pose tilts, so the noise reaches it.
    ``side="x"``: the wall x = 5.5 (local), which the pose keeps vertical in the world: world-z noise
    moves its points within the wall, and it stays exactly flat while the panel is noisy.
    """
    scene = synth.table1_scene()
    scan = make_scan(scene, seed)
    rng = np.random.default_rng(1000 + seed)
    count = len(scan.points) // 2
    along, up = rng.uniform(-3.0, 5.0, count), rng.uniform(0.0, 6.0, count)
    wall = np.full(count, 5.5)
    local = np.column_stack([wall, along, up] if side == "x" else [along, wall, up])
    points = np.concatenate([scan.points, local @ rotation_matrix(scene.rotation_deg).T + scene.translation])
    points[:, 2] += rng.normal(0.0, noise * synth.TABLE1_SPACING, len(points))
    return points, scan.truth


@pytest.mark.parametrize("noise, side", [
    pytest.param(0.0, "y", id="wall"),
    pytest.param(0.0, "x", id="vertical-wall"),
    pytest.param(0.1, "y", id="wall-noise-10pct"),
    pytest.param(0.2, "y", id="wall-noise-20pct"),
    pytest.param(0.1, "x", id="vertical-wall-noise-10pct"),
])
def test_a_second_face_does_not_take_the_plane(noise, side):
    points, truth = with_wall(noise, side)
    result = measure(points, truth)
    plane = result.detection.plane
    tolerance = NORMAL_NOISY if noise else NORMAL
    assert angle_deg(plane.normal, truth["holes"][0]["normal"]) < tolerance, result.summary()
    # The panel's points hold the plane, not the wall's (of which there are half as many).
    assert truth["points"] <= plane.inliers < 1.02 * truth["points"]
    check(result, normal=tolerance)


# --- borders ---------------------------------------------------------------------------------------


def cut(pattern, **changes):
    """A full hole and one whose center lies on the top border (half of it scanned)."""
    holes = (HoleSpec(center=(-1.6, 0.3), diameter=2.5), HoleSpec(center=(2.4, 5.0), diameter=2.5))
    return panel(pattern, holes=holes, extent=(-4.5, 5.5, -3.0, 5.0), rotation_deg=(20.0, 10.0, 30.0), **changes)


@pytest.mark.parametrize("scene", [
    pytest.param(cut("grid"), id="grid"),
    pytest.param(cut("stripes", scan_angle_deg=45.0), id="stripes"),
    pytest.param(cut("random"), id="random"),
    pytest.param(cut("jittered"), id="jittered"),
    pytest.param(cut("grid", noise=0.1), id="grid-noise-10pct"),
])
def test_a_hole_cut_by_the_border(scene):
    """The cut hole is partial with about half its rim, never a full hole; full_only leaves it out."""
    result = measure_scene(scene)
    full, half = result.truth["holes"]
    assert half["partial"] and not full["partial"] and half["arc_deg"] == pytest.approx(180.0, abs=0.5)
    assert len(result.detection.holes) == 2, result.summary()
    assert len({id(hole) for hole in result.matched}) == 2, result.summary()
    full_hole, cut_hole = result.matched
    assert not full_hole.partial and full_hole.arc_deg == 360.0
    assert result.center[0] < CENTER and abs(result.diameter[0]) < DIAMETER, result.summary()
    assert cut_hole.partial, result.summary()
    assert abs(cut_hole.arc_deg - 180.0) < 20.0, cut_hole.arc_deg
    # Half a rim pins the circle less well (measured up to 1.0 h center and 1.5 h diameter on stripes
    # and jittered sampling): twice the loose tolerance, a check that the half hole is measured at all.
    assert result.center[1] < 2 * LOOSE and abs(result.diameter[1]) < 2 * LOOSE, result.summary()
    assert max(result.normal) < NORMAL_NOISY
    # Full holes come first.
    assert [hole.partial for hole in result.detection.holes] == [False, True]

    only_full = measure_scene(scene, full_only=True)
    assert len(only_full.detection.holes) == 1
    assert not only_full.detection.holes[0].partial
    assert only_full.center[0] < CENTER


def test_a_cut_hole_is_found_whatever_the_point_order():
    for scan_angle in (17.0, 60.0):
        points = make_scan(cut("stripes", scan_angle_deg=scan_angle), 0).points
        counts = []
        for seed in range(20):
            order = np.random.default_rng(seed).permutation(len(points))
            counts.append(len(detect(points[order], method="robust").holes))
        assert counts == [2] * len(counts), (scan_angle, counts)


@pytest.mark.parametrize("pattern", ["grid", "stripes", "random", "jittered"])
def test_a_ragged_border_makes_no_hole(pattern):
    """A 1 mm ragged border around a 10 x 10 mm patch with one hole: exactly that hole, 12 seeds."""
    check_seeds(panel(pattern, extent=(-5.0, 5.0, -5.0, 5.0), ragged_border=1.0), range(12))


@pytest.mark.parametrize("pattern", ["grid", "stripes", "random", "jittered"])
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_no_hole_no_report(pattern, noise):
    scene = panel(pattern, holes=(), noise=noise)
    for seed in range(3):
        detection = measure_scene(scene, seed).detection
        assert detection.holes == (), (seed, [hole.diameter for hole in detection.holes])


# --- single seeds that fail, found by surveying more seeds than the tests above run ----------------


@pytest.mark.parametrize("scene, seed, normal", [
    pytest.param(panel("grid", extent=(-5.0, 5.0, -5.0, 5.0), ragged_border=1.0), 28, NORMAL,
                 id="ragged-grid-seed-28"),
    pytest.param(panel("stripes", rotation_deg=(70.0, 0.0, 0.0), noise=0.1), 13, NORMAL_NOISY,
                 id="tilt-70-stripes-noise-seed-13", marks=xfail(
                     "1 of seeds 6-17: center 0.302 h off (diameter -0.160 h); seed 14 at tilt 50 gives 0.257 h")),
    pytest.param(panel("stripes", hole=COUNTERSINK, noise=0.1), 8, NORMAL_NOISY,
                 id="countersink-stripes-noise-seed-8"),
])
def test_surveyed_failures(scene, seed, normal):
    check(measure_scene(scene, seed), scene, normal=normal)


# --- sparse scans: five scan lines across a 1 mm hole ----------------------------------------------


def five_lines(scan_angle, offset, noise=0.0):
    """A 1 mm hole, h = 0.05 along the lines, 0.2 between them: five lines cross the hole."""
    hole = HoleSpec(center=(0.137, 0.0), diameter=1.0)
    return SceneSpec(holes=(hole,), extent=(-1.5, 1.5, -1.5, 1.5), spacing=0.05, pattern="stripes", line_pitch=0.2,
                     scan_angle_deg=scan_angle, grid_offset=(0.0, offset), rotation_deg=(20.0, -15.0, 40.0),
                     translation=(3.0, 4.0, 5.0), noise_world_z=noise * 0.05)


@pytest.mark.parametrize("scene, seeds", [
    pytest.param(five_lines(0.0, 0.03), [0], id="along-x"),
    pytest.param(five_lines(25.0, 0.03), [0, 1], id="at-25-deg"),
    pytest.param(five_lines(60.0, 0.11), [0], id="at-60-deg"),
    pytest.param(five_lines(145.0, 0.162), [0], id="at-145-deg"),
    pytest.param(five_lines(0.0, 0.03, noise=0.1), [0], id="along-x-noise-10pct"),
    pytest.param(five_lines(60.0, 0.0, noise=0.1), [0, 1], id="at-60-deg-noise-10pct"),
    pytest.param(five_lines(27.0, 0.14, noise=0.1), [0, 1], id="at-27-deg-noise-10pct"),
])
def test_five_scan_lines_across_a_1mm_hole(scene, seeds):
    """Found, within the sparse tolerance, and ``scan_lines`` counts the lines across (within one)."""
    crossing = lines_crossing(scene, scene.holes[0])
    assert crossing == 5
    check_seeds(scene, seeds, normal=NORMAL_NOISY if scene.noise_world_z else NORMAL)
    for seed in seeds:
        assert abs(measure_scene(scene, seed).matched[0].scan_lines - crossing) <= 1


def test_scan_lines_counts_the_lines_across_larger_holes():
    for scene in (panel("stripes"), panel("stripes", line_pitch=2 * H), sized(20.0, 0.25, "stripes", 0.5)):
        result = measure_scene(scene)
        assert abs(result.matched[0].scan_lines - lines_crossing(scene, scene.holes[0])) <= 1, scene.line_pitch


def test_scan_lines_is_none_without_stripes():
    for pattern in ("grid", "random", "jittered"):
        assert measure_scene(panel(pattern)).matched[0].scan_lines is None


# --- the sampling-bias correction, statistically ----------------------------------------------------


def bias_scenes(pattern, pitch, seed=0, count=12):
    """``count`` scenes of one pattern at zero noise: random diameter (2 to 4 mm), center, scan angle,
    lattice offset and pose; the patch is three diameters wide."""
    rng = np.random.default_rng(seed)
    scenes = []
    for _ in range(count):
        diameter = rng.uniform(20.0, 40.0) * H
        half = 1.5 * diameter
        center = tuple(rng.uniform(-0.15, 0.15, 2) * diameter)
        scenes.append(SceneSpec(
            holes=(HoleSpec(center=center, diameter=diameter),), extent=(-half, half, -half, half), spacing=H,
            pattern=pattern, line_pitch=pitch, scan_angle_deg=float(rng.uniform(0.0, 180.0)),
            grid_offset=(float(rng.uniform(0.0, H)), float(rng.uniform(0.0, pitch or H))),
            rotation_deg=tuple(rng.uniform(-40.0, 40.0, 3)), translation=tuple(rng.uniform(-50.0, 50.0, 3)),
        ))
    return scenes


@pytest.mark.parametrize("pattern, pitch", [
    pytest.param("grid", None, id="grid"),
    pytest.param("stripes", 2 * H, id="stripes-2h"),
    pytest.param("stripes", 3 * H, id="stripes-3h"),
    pytest.param("stripes", 4 * H, id="stripes-4h"),
    pytest.param("jittered", None, id="jittered"),
    pytest.param("random", None, id="random"),
])
def test_sampling_bias_is_removed_on_average(pattern, pitch):
    """Over 12 random full holes at zero noise, the mean diameter error is below 0.1 h in magnitude.

    Uncorrected, a rim fit is biased high by 0.2 to 0.6 h in radius depending on the pattern.
    """
    errors = []
    for index, scene in enumerate(bias_scenes(pattern, pitch)):
        result = measure_scene(scene, index)
        assert len(result.detection.holes) == 1, (index, result.summary())
        assert not result.matched[0].partial, (index, result.summary())
        errors.append(result.diameter[0])
    assert abs(np.mean(errors)) < 0.1, np.round(errors, 3)


def test_random_sampling_is_measured_by_its_largest_empty_circle():
    """On random sampling the largest circle empty of the points, less its overshoot on synthetic holes,
    is the edge: over 24 random full holes at zero noise the rms diameter error is below 0.06 h and
    none is beyond 0.15 h (measured: 0.049 and 0.14; a rim fit with the sampling-bias correction: rms 0.134 h,
    worst 0.30 h)."""
    errors = []
    for index, scene in enumerate(bias_scenes("random", None, seed=1, count=24)):
        result = measure_scene(scene, index)
        assert len(result.detection.holes) == 1, (index, result.summary())
        errors.append(result.diameter[0])
    errors = np.asarray(errors)
    assert np.sqrt(np.mean(errors ** 2)) < 0.06, np.round(errors, 3)
    assert np.max(np.abs(errors)) < 0.15, np.round(errors, 3)


@pytest.mark.parametrize("noise_gate, bound", [(None, 0.12), (1e9, None)], ids=["gated", "gate-off"])
def test_noisy_random_sampling_keeps_the_rim_fit(noise_gate, bound):
    """With 30 % of h noise on the world z of a tilted scan the in-plane scatter carries points into
    the hole and the empty circle shrinks with it: over 16 random holes its mean diameter error is
    about -0.17 h. Above ``empty_circle_max_noise`` the rim fit is kept: mean about -0.08 h."""
    settings = DEFAULT_SETTINGS if noise_gate is None else replace(DEFAULT_SETTINGS, empty_circle_max_noise=noise_gate)
    errors = []
    for index, scene in enumerate(bias_scenes("random", None, seed=2, count=16)):
        scene = replace(scene, noise_world_z=0.3 * H, rotation_deg=(32.0, 0.0, 20.0))
        result = measure_scene(scene, index, settings=settings)
        assert len(result.detection.holes) == 1, (index, result.summary())
        errors.append(result.diameter[0])
    if bound is None:
        assert np.mean(errors) < -0.12, np.round(errors, 3)
    else:
        assert abs(np.mean(errors)) < bound, np.round(errors, 3)
