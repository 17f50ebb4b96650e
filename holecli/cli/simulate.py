"""``holecli simulate``: write a synthetic scan (the paper's scene, or a laser profiler's scan of a
panel or a mesh) and its ground truth, a registration cell, or a lot of parts.

One subcommand per kind (``simulate scene|panel|cell|lot``), each with only its own options; today's
spellings (``simulate FILE ...``, ``simulate FILE --panel SPEC ...``, ``simulate --cell DIR ...``,
``simulate --lot DIR ...``) go, unchanged, to the one command they always went to, whose checks of
which options go together remain as they were."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click
from click.core import ParameterSource

from holecli.cli.exits import EXIT_INPUT, EXIT_OK, EXIT_USAGE, Failure, run_guarded
from holecli.cli.options import Decimal, FloatTuple, check_verbosity, read_small_text, verbosity_option_decorators
from holecli.errors import LoadError, SpecError

# The implementations (holecli.simulation, numpy) are imported by the functions that call them, so that
# `holecli --help` and the other commands start without them.


# --- the options, each defined once -----------------------------------------------------------------
# The legacy command takes them all; each subcommand takes those that apply to it, some with a help text
# of its own (see _option).

_OPTIONS = {
    "diameter": (("--diameter",), dict(
        type=Decimal(min=0, min_open=True), default=3.0, show_default=True,
        help="Hole diameter (ignored when --hole is given).")),
    "center": (("--center",), dict(
        type=FloatTuple(2, "X,Y"), default="1,1", show_default=True,
        help="Hole center in the surface frame (ignored when --hole is given).")),
    "holes": (("--hole", "holes"), dict(
        type=FloatTuple(3, "X,Y,DIAMETER"), multiple=True,
        help="A hole X,Y,DIAMETER in the surface frame; repeat for several holes.")),
    "no_hole": (("--no-hole",), dict(is_flag=True, help="Scan a plain surface without any hole.")),
    "spacing": (("--spacing",), dict(
        type=Decimal(min=0, min_open=True), default=0.0908, show_default=True,
        help="Point spacing h (along a scan line).")),
    "extent": (("--extent",), dict(
        type=FloatTuple(4, "XMIN,XMAX,YMIN,YMAX"), default="-3,5,-3,5", show_default=True,
        help="Scanned patch in the surface frame.")),
    "pattern": (("--pattern",), dict(
        type=click.Choice(["grid", "stripes", "jittered", "random"]), default="grid", show_default=True,
        help="Sampling pattern.")),
    "line_pitch": (("--line-pitch",), dict(
        type=Decimal(min=0, min_open=True), default=None,
        help="Distance between scan lines for --pattern stripes [default: 3 x spacing].")),
    "scan_angle": (("--scan-angle",), dict(
        type=Decimal(), default=0.0, show_default=True,
        help="Direction of the scan lines in the surface frame, degrees.")),
    "rotation": (("--rotation",), dict(
        type=FloatTuple(3, "AX,AY,AZ"), default=None,
        help="Rotation in degrees about x, then y, then z (world axes) [default: 32,0,20; with --panel "
             "or --mesh: none, the part's frame].")),
    "translation": (("--translation",), dict(
        type=FloatTuple(3, "X,Y,Z"), default=None,
        help="Translation after the rotation [default: 3,4,5; with --panel or --mesh: none] (with "
             "--panel/--mesh: into a robot base frame, e.g. 1200,-300,800).")),
    "noise_z": (("--noise-z",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Gaussian noise sigma on the world z coordinate (the paper's noise).")),
    "noise_normal": (("--noise-normal",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Gaussian noise sigma along the surface normal.")),
    "inside_points": (("--inside-points",), dict(
        type=click.IntRange(min=0), default=0, show_default=True,
        help="Random points inside each hole (reflections; the paper's Fig. 5 uses 10 and 100).")),
    "countersink": (("--countersink",), dict(
        type=Decimal(min=0, min_open=True), default=None,
        help="Countersink diameter at the surface for every hole (a cone of --countersink-angle).")),
    "countersink_angle": (("--countersink-angle",), dict(
        type=Decimal(min=0, max=180, min_open=True, max_open=True), default=100.0, show_default=True,
        metavar="DEG", help="Included angle of the countersinks, degrees (82, 90, 100 and 110 are standard).")),
    "bore_depth": (("--bore-depth",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Depth of bore-wall points below the surface (0: none).")),
    "bottom_depth": (("--bottom-depth",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Blind holes: the flat floor at this depth below the surface is scanned (0: a through "
             "hole); at least --bore-depth.")),
    "outliers": (("--outliers",), dict(
        type=Decimal(min=0, max=1), default=0.0, show_default=True, help="Fraction of gross outliers.")),
    "ragged": (("--ragged",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Amplitude of a ragged outer border (0: straight).")),
    "nan_points": (("--nan-points",), dict(
        type=click.IntRange(min=0), default=0, show_default=True,
        help="NaN rows to append, as a profiler writes for missed points.")),
    "panel_file": (("--panel", "panel_file"), dict(
        type=click.Path(dir_okay=False, path_type=str), default=None, metavar="SPEC",
        help="Scan a panel built from the TOML spec SPEC (sheets with holes, see docs/guide/simulate.md; "
             "lengths in mm, or the units = \"in\"|\"m\" at its top) with the laser profiler.")),
    "mesh_file": (("--mesh", "mesh_file"), dict(
        type=click.Path(dir_okay=False, path_type=str), default=None, metavar="PART",
        help="Scan the triangle mesh PART (.stl, .ply, .obj, .off) with the laser profiler.")),
    "cloud": (("--cloud",), dict(
        type=click.Choice(["profiler", "vertices", "surface", "lattice"]), default="profiler", show_default=True,
        help="With --panel or --mesh: how the cloud is made: the laser profiler, or as engineers make one from "
             "a mesh: the mesh's own vertices (a CAD export's: points only along edges), even (area-weighted) "
             "surface sampling at a mean --spacing, or an exact square lattice of parallel rays along --view at "
             "pitch --spacing. --range-noise adds Gaussian noise along --view; the truth is written in the "
             "validation suite's format.")),
    "faces": (("--faces",), dict(
        type=click.Choice(["all", "no-walls", "seen"]), default="all", show_default=True,
        help="--cloud vertices/surface: the faces used: all, all but the walls (bores, sides: faces within 10 deg "
             "of parallel to --view), or only those turned toward the sensor.")),
    "target": (("--target",), dict(
        type=FloatTuple(3, "X,Y,Z"), default=None,
        help="Profiler: the point the sensor aims at [default: the middle of the part, on its side "
             "facing the sensor].")),
    "standoff": (("--standoff",), dict(
        type=Decimal(min=0, min_open=True), default=100.0, show_default=True,
        help="Profiler: distance from the sensor to --target along --view.")),
    "view": (("--view",), dict(
        type=FloatTuple(3, "X,Y,Z"), default="0,0,-1", show_default=True,
        help="Profiler: viewing direction, from the sensor toward the part.")),
    "line": (("--line",), dict(
        type=FloatTuple(3, "X,Y,Z"), default="1,0,0", show_default=True,
        help="Profiler: direction of the laser line (perpendicular to --view); the robot moves along "
             "line x view.")),
    "line_length": (("--line-length",), dict(
        type=Decimal(min=0, min_open=True), default=None,
        help="Profiler: field of view along the line [default: the part's extent].")),
    "scan_length": (("--scan-length",), dict(
        type=Decimal(min=0, min_open=True), default=None,
        help="Profiler: length of the robot's travel [default: the part's extent].")),
    "parallel_rays": (("--parallel-rays",), dict(
        is_flag=True,
        help="Profiler: parallel rays (a profiler's uniform-X output) instead of a fan from the laser.")),
    "triangulation_deg": (("--triangulation-deg",), dict(
        type=Decimal(min=0, max=80), default=25.0, show_default=True,
        help="Profiler: angle between the laser and the camera; points the camera cannot see are lost.")),
    "max_incidence_deg": (("--max-incidence-deg",), dict(
        type=Decimal(min=0, max=90), default=75.0, show_default=True,
        help="Profiler: points on faces steeper than this to the ray are lost.")),
    "range_noise": (("--range-noise",), dict(
        type=Decimal(min=0), default=0.0, show_default=True, help="Profiler: Gaussian noise sigma along each ray.")),
    "range_quantum": (("--range-quantum",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Profiler: ranges rounded to multiples of this (0: none), e.g. 0.001.")),
    "dropout": (("--dropout",), dict(
        type=Decimal(min=0, max=1, max_open=True), default=0.0, show_default=True,
        help="Profiler: fraction of points lost at random.")),
    "jitter": (("--jitter",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Profiler: sigma of the robot's position error, per profile.")),
    "line_width": (("--line-width",), dict(
        type=Decimal(min=0), default=0.0, show_default=True,
        help="Profiler: thickness of the laser line along the travel (e.g. 0.04); each point is the centroid "
             "of the light across it, so points whose line straddles an edge are mixed (0: an ideal line).")),
    "keep_nan": (("--keep-nan",), dict(is_flag=True, help="Profiler: a NaN row for every lost point, as profilers write.")),
    "metres": (("--metres",), dict(is_flag=True, help="Profiler: write the points in metres (the part is in mm).")),
    "float64": (("--float64",), dict(is_flag=True, help="Profiler: write double precision [default: float32, as sensors write].")),
    "cell_dir": (("--cell", "cell_dir"), dict(
        type=click.Path(file_okay=False, path_type=str), default=None, metavar="DIR",
        help="Write a registration scene into DIR (no OUTPUT): a panel with reference holes placed under "
             "a random rigid transform, a profiler scan of each hole (<name>.ply), part.toml, targets.csv "
             "and cell.truth.json; existing files of those names are replaced. Uses --holes, --displace, "
             "--seed and the profiler options --range-noise [default: 0.005 here], --spacing [default: "
             "0.05 here], --line-pitch, --standoff, --triangulation-deg, --float64.")),
    "cell_holes": (("--holes", "cell_holes"), dict(
        type=click.IntRange(3, 8), default=4, show_default=True, help="--cell: number of reference holes (R1, R2, ...).")),
    "displace": (("--displace", "displace"), dict(
        multiple=True, metavar="NAME=DX,DY",
        help="--cell: drill reference hole NAME off its nominal centre by DX,DY (part frame, mm); repeatable.")),
    "lot_dir": (("--lot", "lot_dir"), dict(
        type=click.Path(file_okay=False, path_type=str), default=None, metavar="DIR",
        help="Write a lot of --parts simulated scans of the --panel (no OUTPUT) into DIR, which must not exist "
             "or be empty: part_001.ply, ... (each drilled with a cell's scatter and scanned with its own "
             "seed, with the profiler options), their truths and manifest.json; all or none is written.")),
    "parts": (("--parts",), dict(
        type=click.IntRange(1, 1000), default=None, metavar="N", help="--lot: number of parts.")),
    "defects": (("--defect", "defects"), dict(
        multiple=True, metavar="[PART/]HOLE=KIND[:SIZE]",
        help="--lot: a defect of the panel's hole HOLE in part PART (from 1; without it, every part): "
             "diameter:SIZE (the edge's diameter off by SIZE mm, signed), position:SIZE (drilled SIZE mm off), "
             "countersink:SIZE (cut SIZE mm deeper, signed) or missing; repeatable.")),
    "seed": (("--seed",), dict(type=int, default=0, show_default=True, help="Random seed.")),
    "truth_path": (("--truth", "truth_path"), dict(
        type=click.Path(dir_okay=False, path_type=str), default=None,
        help="Where to write the ground truth [default: OUTPUT with .truth.json].")),
}


def _option(name, **changes):
    """The click option ``name`` of :data:`_OPTIONS`, its settings (a help text, a default) changed by ``changes``."""
    declarations, settings = _OPTIONS[name]
    settings = {**settings, **changes}
    if settings.get("required"):  # no default at all, else click takes the default None for a value
        settings.pop("default", None)
    return click.option(*declarations, **settings)


def _options(*options):
    """A decorator applying ``options`` (names of :data:`_OPTIONS`, or click decorators) in the order given."""
    decorators = [_option(option) if isinstance(option, str) else option for option in options]

    def decorate(function):
        for decorator in reversed(decorators):
            function = decorator(function)
        return function

    return decorate


# The options of each kind of scan, in the order --help lists them.
_SCENE_NAMES = ("diameter", "center", "holes", "no_hole", "spacing", "extent", "pattern", "line_pitch", "scan_angle",
                "rotation", "translation", "noise_z", "noise_normal", "inside_points", "countersink",
                "countersink_angle", "bore_depth", "bottom_depth", "outliers", "ragged", "nan_points")
_SENSOR_NAMES = ("target", "standoff", "view", "line", "line_length", "scan_length", "parallel_rays",
                 "triangulation_deg", "max_incidence_deg", "range_noise", "range_quantum", "dropout", "jitter",
                 "line_width", "keep_nan", "metres", "float64")
# Today's single command's options, in its order (the old spellings keep every one of them).
_LEGACY_NAMES = (*_SCENE_NAMES, "panel_file", "mesh_file", "cloud", "faces", *_SENSOR_NAMES, "cell_dir", "cell_holes",
                 "displace", "lot_dir", "parts", "defects", "seed", "truth_path")

# Help texts of a part's scan (simulate panel, simulate lot), where no synthetic scene competes.
_PART_HELP = dict(
    spacing=dict(help="Profiler: point pitch along the laser line (with --cloud surface: the mean spacing, lattice: "
                      "the pitch).", default=0.0908, show_default=True),
    line_pitch=dict(help="Profiler: distance between profiles [default: --spacing]."),
    rotation=dict(help="Rotation in degrees about x, then y, then z (world axes) of the part into the scan's frame "
                       "[default: none, the part's frame]."),
    translation=dict(help="Translation after the rotation, e.g. into a robot base frame 1200,-300,800 "
                          "[default: none]."),
)


# Help texts of the synthetic scene (simulate scene), where no part competes.
_SCENE_HELP = dict(
    rotation=dict(help="Rotation in degrees about x, then y, then z (world axes) [default: 32,0,20]."),
    translation=dict(help="Translation after the rotation [default: 3,4,5]."),
)


def _part_options(*names):
    return [_option(name, **_PART_HELP.get(name, {})) for name in names]


_SCENE_EPILOG = "\b\nExit codes: 0 written, 2 usage error, 3 the scene or the output is invalid."


# --- the old spellings: one command for every kind of scan -------------------------------------------


@click.command("simulate", epilog=_SCENE_EPILOG)
@click.argument("output", type=click.Path(dir_okay=False, path_type=str), required=False)
@_options(*_LEGACY_NAMES)
@verbosity_option_decorators
@click.pass_context
def _simulate_any(ctx, output, quiet, verbose, **_):
    """Write a synthetic scan to OUTPUT (.ply, .pcd, .csv, .txt or .xyz) and its ground truth.

    The defaults reproduce the paper's Table I scene: a 3 mm hole at (1, 1) on a 0.0908 mm grid
    over [-3, 5]^2, rotated (32, 0, 20) degrees and translated by (3, 4, 5). With --panel or
    --mesh, a laser line profiler on a robot scans a CAD part instead (ray-cast, with occlusion):
    --spacing is then its point pitch and --line-pitch its profile pitch.

    \b
    Examples:
      holecli simulate table1.ply
      holecli simulate noisy.csv --noise-z 0.0272 --seed 3
      holecli simulate stripes.pcd --pattern stripes --spacing 0.05 --line-pitch 0.15 \\
          --hole 0,0,3 --hole 5,0,4 --extent -3,8,-3,3
      holecli simulate panel.ply --panel sample_clouds/panel.toml --spacing 0.1 --range-noise 0.005
      holecli simulate part.ply --mesh part.stl --view 0,-0.42,-0.91 --translation 1200,-300,800
      holecli simulate plate.ply --mesh plate_holes.STL --cloud lattice --spacing 0.25 --float64
      holecli simulate verts.ply --panel sample_clouds/panel.toml --cloud vertices
      holecli simulate table1.ply -q
      holecli simulate --cell cell --holes 4 --displace R2=0.2,0 --seed 1
      holecli simulate --lot lot --parts 5 --panel sample_clouds/panel.toml --spacing 0.2 \\
          --range-noise 0.002 --defect 2/C1=diameter:+0.1 --defect 4/L1=missing
    """
    check_verbosity(quiet, verbose)
    p = ctx.params
    if p["lot_dir"] is not None:
        sys.exit(run_guarded(_simulate_lot, ctx, p["lot_dir"], quiet, verbose))
    lot_only = [name for name in _LOT_OPTIONS if _given(ctx, name)]
    if lot_only:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in lot_only)} need --lot")
    if p["cell_dir"] is not None:
        sys.exit(run_guarded(_simulate_cell, ctx, p["cell_dir"], quiet, verbose))
    cell_only = [name for name in _CELL_OPTIONS if _given(ctx, name)]
    if cell_only:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in cell_only)} need --cell")
    if output is None:
        raise click.UsageError("Missing argument 'OUTPUT'.")
    if p["cloud"] != "profiler" and p["panel_file"] is None and p["mesh_file"] is None:
        raise click.UsageError("--cloud needs --panel or --mesh")
    if _given(ctx, "faces") and p["cloud"] not in ("vertices", "surface"):
        raise click.UsageError("--faces needs --cloud vertices or surface")
    if p["panel_file"] is not None or p["mesh_file"] is not None:
        sys.exit(run_guarded(_simulate_part, ctx, output, p["panel_file"], p["mesh_file"], p["truth_path"], p["seed"],
                             quiet, verbose))
    profiler_only = [name for name in _PROFILER_OPTIONS if _given(ctx, name)]
    if profiler_only:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in profiler_only)} need --panel or --mesh")
    sys.exit(run_guarded(_simulate_scene, ctx, output, quiet, verbose))


# --- the subcommands -----------------------------------------------------------------------------------


@click.command("scene", epilog=_SCENE_EPILOG,
               short_help="The paper's synthetic scan of a surface with holes (was: simulate FILE).")
@click.argument("output", type=click.Path(dir_okay=False, path_type=str))
@_options(*[_option(name, **_SCENE_HELP.get(name, {})) for name in _SCENE_NAMES], "seed", "truth_path")
@verbosity_option_decorators
@click.pass_context
def scene(ctx, output, quiet, verbose, **_):
    """Write the paper's synthetic scan of a flat surface with holes to OUTPUT (.ply, .pcd, .csv, .txt or
    .xyz), and its ground truth.

    The defaults reproduce the paper's Table I scene: a 3 mm hole at (1, 1) on a 0.0908 mm grid
    over [-3, 5]^2, rotated (32, 0, 20) degrees and translated by (3, 4, 5).

    \b
    Examples:
      holecli simulate scene table1.ply
      holecli simulate scene noisy.csv --noise-z 0.0272 --seed 3
      holecli simulate scene stripes.pcd --pattern stripes --spacing 0.05 --line-pitch 0.15 \\
          --hole 0,0,3 --hole 5,0,4 --extent -3,8,-3,3
      holecli simulate scene blind.ply --bore-depth 0.5 --bottom-depth 0.5
      holecli simulate scene table1.ply -q
    """
    check_verbosity(quiet, verbose)
    sys.exit(run_guarded(_simulate_scene, ctx, output, quiet, verbose))


@click.command("panel", short_help="A laser profiler's scan of a --panel spec or a --mesh (was: simulate FILE --panel).",
               epilog="\b\nExit codes: 0 written, 2 usage error, 3 the part, the scan or the output is "
                               "invalid.")
@click.argument("output", type=click.Path(dir_okay=False, path_type=str))
@_options(*_part_options("panel_file", "mesh_file", "cloud", "faces", "spacing", "line_pitch", "rotation",
                         "translation", *_SENSOR_NAMES), "seed", "truth_path")
@verbosity_option_decorators
@click.pass_context
def panel(ctx, output, quiet, verbose, **_):
    """Scan a CAD part (a --panel spec or a --mesh) into OUTPUT (.ply, .pcd, .csv, .txt or .xyz), and
    write its ground truth.

    A laser line profiler on a robot scans the part (ray-cast, with occlusion): --spacing is its point
    pitch and --line-pitch its profile pitch. With --cloud vertices, surface or lattice the cloud is
    made from the mesh as engineers make one instead.

    \b
    Examples:
      holecli simulate panel panel.ply --panel sample_clouds/panel.toml --spacing 0.1 --range-noise 0.005
      holecli simulate panel part.ply --mesh part.stl --view 0,-0.42,-0.91 --translation 1200,-300,800
      holecli simulate panel plate.ply --mesh plate_holes.STL --cloud lattice --spacing 0.25 --float64
      holecli simulate panel verts.ply --panel sample_clouds/panel.toml --cloud vertices
    """
    check_verbosity(quiet, verbose)
    p = ctx.params
    if p["panel_file"] is None and p["mesh_file"] is None:
        raise click.UsageError("give the part: --panel SPEC or --mesh PART")
    if _given(ctx, "faces") and p["cloud"] not in ("vertices", "surface"):
        raise click.UsageError("--faces needs --cloud vertices or surface")
    sys.exit(run_guarded(_simulate_part, ctx, output, p["panel_file"], p["mesh_file"], p["truth_path"], p["seed"],
                         quiet, verbose))


@click.command("cell", short_help="A registration scene: reference-hole scans, part.toml, targets (was: --cell DIR).",
               epilog="\b\nExit codes: 0 written, 2 usage error, 3 the cell or the output is invalid.")
@click.argument("cell_dir", metavar="DIR", type=click.Path(file_okay=False, path_type=str))
@_options(_option("cell_holes", help="Number of reference holes (R1, R2, ...)."),
          _option("displace", help="Drill reference hole NAME off its nominal centre by DX,DY (part frame, mm); "
                                   "repeatable."),
          "seed",
          _option("range_noise", help="Profiler: Gaussian noise sigma along each ray.", default=0.005),
          _option("spacing", help="Profiler: point pitch along the laser line.", default=0.05),
          _option("line_pitch", help="Profiler: distance between profiles [default: --spacing]."),
          "standoff", "triangulation_deg", "float64")
@verbosity_option_decorators
@click.pass_context
def cell(ctx, cell_dir, quiet, verbose, **_):
    """Write a registration scene into DIR: a panel with reference holes placed under a random rigid
    transform, a profiler scan of each hole (<name>.ply), part.toml, targets.csv and cell.truth.json.

    Existing files of those names in DIR are replaced.

    \b
    Examples:
      holecli simulate cell cell --holes 4 --displace R2=0.2,0 --seed 1
      holecli simulate cell cell --holes 3 --range-noise 0.002 --float64
    """
    check_verbosity(quiet, verbose)
    sys.exit(run_guarded(_simulate_cell, ctx, cell_dir, quiet, verbose))


@click.command("lot", short_help="N scans of a --panel with chosen defects and a manifest (was: --lot DIR).",
               epilog="\b\nExit codes: 0 written, 2 usage error (also: DIR is not a new or empty folder), "
                             "3 the panel, a part or the output is invalid.")
@click.argument("lot_dir", metavar="DIR", type=click.Path(file_okay=False, path_type=str))
@_options(_option("panel_file", required=True, help="The panel's TOML spec SPEC (the drawing every part is made "
                                                    "from; see docs/guide/simulate.md)."),
          _option("parts", required=True, help="Number of parts."),
          _option("defects", help="A defect of the panel's hole HOLE in part PART (from 1; without it, every part): "
                                  "diameter:SIZE (the edge's diameter off by SIZE mm, signed), position:SIZE "
                                  "(drilled SIZE mm off), countersink:SIZE (cut SIZE mm deeper, signed) or missing; "
                                  "repeatable."),
          "seed", _option("spacing", help="Profiler: point pitch along the laser line."),
          *_part_options("line_pitch", "rotation", "translation", *_SENSOR_NAMES))
@verbosity_option_decorators
@click.pass_context
def lot(ctx, lot_dir, quiet, verbose, **_):
    """Write a lot of --parts simulated scans of the --panel into DIR, which must not exist or be empty:
    part_001.ply, ... (each drilled with a cell's scatter and scanned with its own seed, with the
    profiler options), their truths and manifest.json; all or none is written.

    \b
    Examples:
      holecli simulate lot lot --parts 5 --panel sample_clouds/panel.toml --spacing 0.2 \\
          --range-noise 0.002 --defect 2/C1=diameter:+0.1 --defect 4/L1=missing
    """
    check_verbosity(quiet, verbose)
    sys.exit(run_guarded(_simulate_lot, ctx, lot_dir, quiet, verbose))


# --- the group -------------------------------------------------------------------------------------------


class _SimulateGroup(click.Group):
    """The subcommands, and today's spellings (``simulate FILE ...``, ``simulate --cell DIR ...``): arguments
    that do not start with a subcommand's name go to :func:`_simulate_any`, as before the subcommands."""

    def list_commands(self, ctx):
        return list(self.commands)  # scene, panel, cell, lot: from the simplest scan to a lot of parts

    def make_context(self, info_name, args, parent=None, **extra):
        if _old_spelling(args, self.commands):
            return _simulate_any.make_context(info_name, args, parent=parent, **extra)
        return super().make_context(info_name, args, parent=parent, **extra)

    def invoke(self, ctx):
        if ctx.command is not self:  # simulate invoked on its own (simulate.main([...])) with an old spelling
            return ctx.command.invoke(ctx)
        return super().invoke(ctx)


# Options of the group itself: the leading ones an old spelling may start with, too.
_GROUP_FLAGS = ("-q", "--quiet", "-v", "--verbose")


def _old_spelling(args, commands):
    """Whether ``args`` (after ``simulate``) are one of today's spellings rather than a subcommand's: their
    first word (after the group's own -q/-v) is neither a subcommand nor a request for the group's help."""
    words = [arg for arg in args if arg not in _GROUP_FLAGS]
    if not words:  # a bare `simulate` is, as before, an old spelling without its OUTPUT
        return True
    return words[0] not in commands and words[0] not in ("-h", "--help")


@click.group(cls=_SimulateGroup,
             epilog="\b\nExit codes: 0 written, 2 usage error, 3 the scene, the part, the cell or the output is invalid.")
@verbosity_option_decorators
@click.pass_context
def simulate(ctx, quiet, verbose):
    """Write a synthetic scan and its ground truth: the paper's scene, a profiler's scan of a CAD part, a
    registration cell, or a lot of parts.

    Each subcommand has its own --help. Today's spellings still work as before:
    simulate FILE ... is simulate scene FILE ..., simulate FILE --panel SPEC ... (or --mesh) is
    simulate panel FILE --panel SPEC ..., simulate --cell DIR ... is simulate cell DIR ..., and
    simulate --lot DIR ... is simulate lot DIR ...; the old spellings write the same files.

    \b
    Examples:
      holecli simulate scene table1.ply
      holecli simulate panel panel.ply --panel sample_clouds/panel.toml --spacing 0.1 --range-noise 0.005
      holecli simulate cell cell --holes 4 --displace R2=0.2,0 --seed 1
      holecli simulate lot lot --parts 5 --panel sample_clouds/panel.toml --spacing 0.2
      holecli simulate table1.ply                 (the old spelling of simulate scene)
    """
    check_verbosity(quiet, verbose)
    chosen = {name: True for name, value in (("quiet", quiet), ("verbose", verbose)) if value}
    if chosen:  # simulate -q scene ...: the subcommand's own -q, as holecli -q simulate scene ... is
        ctx.default_map = {**(ctx.default_map or {}),
                           **{name: {**(ctx.default_map or {}).get(name, {}), **chosen} for name in ctx.command.commands}}


simulate.add_command(scene)
simulate.add_command(panel)
simulate.add_command(cell)
simulate.add_command(lot)


def _simulate_scene(ctx, output, quiet=False, verbose=False):
    """``holecli simulate scene``: the paper's synthetic scan of a flat surface with holes, and its truth."""
    from holecli.simulation import synth

    p = ctx.params
    pattern, line_pitch, spacing, seed = p["pattern"], p["line_pitch"], p["spacing"], p["seed"]
    rotation = p["rotation"] if p["rotation"] is not None else (32.0, 0.0, 20.0)
    translation = p["translation"] if p["translation"] is not None else (3.0, 4.0, 5.0)
    _check_extension(output)
    specs = () if p["no_hole"] else p["holes"] or ((p["center"][0], p["center"][1], p["diameter"]),)
    started = time.perf_counter()
    try:
        scene = synth.SceneSpec(
            holes=tuple(synth.HoleSpec(center=(x, y), diameter=d, countersink_diameter=p["countersink"],
                                       countersink_angle_deg=p["countersink_angle"], bore_depth=p["bore_depth"],
                                       bottom_depth=p["bottom_depth"], inside_points=p["inside_points"])
                        for x, y, d in specs),
            extent=p["extent"], spacing=spacing, pattern=pattern, line_pitch=line_pitch,
            scan_angle_deg=p["scan_angle"], rotation_deg=rotation, translation=translation,
            noise_world_z=p["noise_z"], noise_normal=p["noise_normal"], outlier_fraction=p["outliers"],
            ragged_border=p["ragged"], nan_points=p["nan_points"])
        scan = synth.make_scan(scene, seed)
    except ValueError as error:
        raise Failure(f"{output}: invalid scene: {error}", EXIT_INPUT) from None
    truth = dict(scan.truth, seed=seed, file=Path(output).name)
    generated = time.perf_counter()
    target = _write_scan(output, scan.points, truth, p["truth_path"], float32=False)
    if verbose:
        pitch = f"line pitch {line_pitch:g}" if pattern == "stripes" and line_pitch else "no line pitch"
        click.echo(f"holecli: scene: pattern {pattern}, spacing {spacing:g}, {pitch}, {len(specs)} "
                   f"hole{'' if len(specs) == 1 else 's'}, seed {seed}\nholecli: time: generate "
                   f"{(generated - started) * 1e3:.1f} ms, write {(time.perf_counter() - generated) * 1e3:.1f} ms",
                   err=True)
    if not quiet:
        click.echo(f"wrote {len(scan.points)} points to {output} and the ground truth to {target}", err=True)
    return EXIT_OK


# The options of simulate that only a profiler scan of a part uses, and those only a synthetic scene uses.
_PROFILER_OPTIONS = ("target", "standoff", "view", "line", "line_length", "scan_length", "parallel_rays",
                     "triangulation_deg", "max_incidence_deg", "range_noise", "range_quantum", "dropout", "jitter", "line_width",
                     "keep_nan", "metres", "float64")
_SYNTHETIC_OPTIONS = ("diameter", "center", "holes", "no_hole", "extent", "pattern", "scan_angle", "noise_z",
                      "noise_normal", "inside_points", "countersink", "countersink_angle", "bore_depth", "bottom_depth", "outliers",
                      "ragged", "nan_points")
# The options that aim the profiler at a part (the parameters of holecli.simulation.part.aimed_profiler).
_AIM_OPTIONS = ("view", "line", "target", "line_length", "scan_length", "rotation", "translation", "spacing",
                "line_pitch", "standoff", "parallel_rays", "triangulation_deg", "max_incidence_deg", "range_noise",
                "range_quantum", "dropout", "jitter", "line_width", "keep_nan", "metres", "float64")


# The options of simulate that only --cell uses, and the others it accepts.
_CELL_OPTIONS = ("cell_holes", "displace")
_CELL_ACCEPTS = _CELL_OPTIONS + ("cell_dir", "seed", "range_noise", "spacing", "line_pitch", "standoff",
                                 "triangulation_deg", "float64", "quiet", "verbose")


# The options of simulate that only --lot uses, and those --lot refuses.
_LOT_OPTIONS = ("parts", "defects")
_LOT_REFUSES = ("output", "mesh_file", "cell_dir", "truth_path", "cloud", "faces", *_CELL_OPTIONS, *_SYNTHETIC_OPTIONS)


def _simulate_lot(ctx, directory, quiet=False, verbose=False):
    """``holecli simulate --lot DIR``: N profiler scans of a panel, each part drilled with the cell's scatter
    and its defects (:mod:`holecli.simulation.lot`), their truths and a manifest, written whole or not at
    all (:func:`holecli.simulation.files.write_lot`)."""
    from holecli.simulation.files import CannotWrite, LotPartError, write_lot
    from holecli.simulation.lot import DIAMETER_SIGMA, POSITION_SIGMA, lot_parts, parse_defect
    from holecli.simulation.panel import parse_panel_toml

    p = ctx.params
    refused = [name for name in _LOT_REFUSES if _given(ctx, name) or (name == "output" and p.get("output") is not None)]
    if refused:
        names = ", ".join("OUTPUT" if name == "output" else _option_name(name) for name in refused)
        raise click.UsageError(f"--lot cannot be used with {names}")
    if p["panel_file"] is None or p["parts"] is None:
        raise click.UsageError("--lot needs --panel (the drawing) and --parts (how many)")
    try:
        defects = [parse_defect(text) for text in p["defects"]]
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--defect'") from None
    target = Path(directory)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise Failure(f"{directory}: exists and is not an empty folder: give a new or empty folder (a lot is "
                      f"written whole or not at all)", EXIT_USAGE)
    panel_file = p["panel_file"]
    try:
        panel = parse_panel_toml(read_small_text(panel_file, "a panel spec"))
        drilled = lot_parts(panel, p["parts"], defects, p["seed"])
    except (SpecError, ValueError) as error:
        raise Failure(f"{panel_file}: {error}", EXIT_INPUT) from None

    def progress(name, points, truth):
        if verbose:
            given = ", ".join(defect["defect"] for defect in truth["defects"])
            click.echo(f"holecli: {name}: {points} points, " + (f"defects {given}" if given else "no defect"), err=True)

    manifest = {"panel": panel_file, "parts": p["parts"], "seed": p["seed"], "defects": list(p["defects"]),
                "scatter": {"position_sigma": POSITION_SIGMA, "diameter_sigma": DIAMETER_SIGMA}}
    started = time.perf_counter()
    try:
        parts = write_lot(directory, drilled, lambda vertices: _aimed_profiler(p, vertices), manifest,
                          units="m" if p["metres"] else "mm", float32=not p["float64"], progress=progress)
    except CannotWrite as error:
        raise Failure(str(error), EXIT_INPUT) from None
    except LotPartError as error:
        given = ", ".join(defect["defect"] for defect in error.truth["defects"]) or "no defect"
        raise Failure(f"{panel_file}: part {error.truth['part']} ({given}): {error.error}", EXIT_INPUT) from None
    if not quiet:
        defective = sum(part["defective"] for part in parts)
        click.echo(f"wrote {p['parts']} scan{'' if p['parts'] == 1 else 's'} of {panel_file} ({defective} with "
                   f"defects) and manifest.json to "
                   f"{directory} in {time.perf_counter() - started:.1f} s", err=True)
    return EXIT_OK


def _given(ctx, name):
    return ctx.get_parameter_source(name) not in (ParameterSource.DEFAULT, None)


def _option_name(name):
    names = {"holes": "--hole", "cell_holes": "--holes", "cell_dir": "--cell", "panel_file": "--panel",
             "mesh_file": "--mesh", "truth_path": "--truth", "defects": "--defect", "lot_dir": "--lot"}
    return names.get(name, "--" + name.replace("_", "-"))


def _parse_displace(values):
    """{name: (dx, dy)} of the --displace values NAME=DX,DY."""
    from holecli.io.decimal_text import parse_decimal

    displaced = {}
    for value in values:
        name, sep, offset = value.partition("=")
        parts = offset.split(",")
        try:
            numbers = tuple(parse_decimal(part.strip()) for part in parts) if sep else ()
        except ValueError:
            numbers = ()
        if not name.strip() or len(numbers) != 2:
            raise click.BadParameter(f"expected NAME=DX,DY (two numbers, mm), got {value!r}", param_hint="'--displace'")
        if name.strip() in displaced:
            raise click.BadParameter(f"hole {name.strip()!r} given twice", param_hint="'--displace'")
        displaced[name.strip()] = numbers
    return displaced


def _simulate_cell(ctx, directory, quiet=False, verbose=False):
    """``holecli simulate --cell DIR``: a registration scene, its scans and its truth."""
    from holecli.simulation.cell import random_cell, simulate_cell
    from holecli.simulation.files import write_cell

    p = ctx.params
    if p.get("output") is not None:
        raise click.UsageError("--cell writes into its folder DIR: give no OUTPUT")
    other = [name for name in p if name not in _CELL_ACCEPTS and name != "output" and _given(ctx, name)]
    if other:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in other)} cannot be used with --cell")
    displaced = _parse_displace(p["displace"])
    names = [f"R{k + 1}" for k in range(p["cell_holes"])]
    unknown = [name for name in displaced if name not in names]
    if unknown:
        raise click.BadParameter(f"no reference hole {unknown[0]!r} (the cell has {', '.join(names)})",
                                 param_hint="'--displace'")
    seed = p["seed"]
    started = time.perf_counter()
    try:
        spec = random_cell(seed, p["cell_holes"], displaced=displaced,
                           range_noise=p["range_noise"] if _given(ctx, "range_noise") else 0.005,
                           point_pitch=p["spacing"] if _given(ctx, "spacing") else 0.05,
                           line_pitch=p["line_pitch"], standoff=p["standoff"],
                           triangulation_deg=p["triangulation_deg"])
        cell = simulate_cell(spec, seed)
    except SpecError as error:
        raise Failure(f"{directory}: invalid cell: {error}", EXIT_INPUT) from None
    generated = time.perf_counter()
    try:
        truth = write_cell(directory, cell, seed, float32=not p["float64"])
    except OSError as error:
        raise Failure(f"{directory}: cannot write: {error.strerror or error}", EXIT_INPUT) from None
    if verbose:
        click.echo(f"holecli: cell: {len(cell.scans)} reference holes, {len(cell.targets)} targets, "
                   f"displaced {', '.join(truth['displaced']) or 'none'}, seed {seed}\nholecli: time: simulate "
                   f"{(generated - started) * 1e3:.1f} ms, write {(time.perf_counter() - generated) * 1e3:.1f} ms",
                   err=True)
    if not quiet:
        points = sum(len(scan.points) for scan in cell.scans)
        click.echo(f"wrote {len(cell.scans)} scans ({points} points), part.toml, targets.csv and cell.truth.json "
                   f"to {directory}", err=True)
    return EXIT_OK


def _simulate_part(ctx, output, panel_file, mesh_file, truth_path, seed, quiet=False, verbose=False):
    """``holecli simulate --panel/--mesh``: the profiler's scan of a part, and its truth."""
    import numpy as np

    from holecli.simulation.scan_part import scan_part

    p = ctx.params
    if panel_file is not None and mesh_file is not None:
        raise click.UsageError("give --panel or --mesh, not both")
    synthetic = [name for name in _SYNTHETIC_OPTIONS if _given(ctx, name)]
    if synthetic:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in synthetic)} cannot be used with "
                               f"{'--panel' if panel_file else '--mesh'} (they describe a synthetic scene)")
    _check_extension(output)
    source = panel_file or mesh_file
    if p["cloud"] != "profiler":
        return _simulate_cad(ctx, output, panel_file, mesh_file, truth_path, seed, quiet, verbose)
    started = time.perf_counter()
    try:
        part = _load_part(panel_file, mesh_file, p["view"])
        spec = _aimed_profiler(p, part.vertices)
        scanned = scan_part(part.vertices, part.triangles, part.features, spec, rng=seed)
    except (SpecError, ValueError) as error:
        raise Failure(f"{source}: {error}", EXIT_INPUT) from None
    truth = dict(scanned.truth, part=part.description, seed=seed, file=Path(output).name,
                 units="m" if p["metres"] else "mm")
    points = scanned.scan.points
    generated = time.perf_counter()
    target = _write_scan(output, points, truth, truth_path, float32=not p["float64"])
    finite = int(np.isfinite(points).all(axis=1).sum())
    if verbose:
        click.echo(f"holecli: profiler: point pitch {spec.point_pitch:g}, line pitch {spec.line_pitch:g}, "
                   f"line length {spec.line_length:.4g}, scan length {spec.scan_length:.4g}, standoff "
                   f"{spec.standoff:g}, seed {seed}\nholecli: time: scan {(generated - started) * 1e3:.1f} ms, "
                   f"write {(time.perf_counter() - generated) * 1e3:.1f} ms", err=True)
    if not quiet:
        click.echo(f"wrote {len(points)} points ({finite} measured) to {output} and the ground truth "
                   f"({len(truth['holes'])} holes) to {target}", err=True)
    return EXIT_OK


# Profiler options that --cloud vertices/surface/lattice use (the others describe the sensor).
_CAD_ACCEPTS = ("target", "view", "line", "line_length", "scan_length", "range_noise", "float64")


def _simulate_cad(ctx, output, panel_file, mesh_file, truth_path, seed, quiet=False, verbose=False):
    """``holecli simulate --panel/--mesh --cloud KIND``: a cloud made from the mesh as engineers make one, and its
    truth in the validation suite's format (:func:`holecli.simulation.part.cad_scan`)."""
    from holecli.simulation.part import cad_scan

    p = ctx.params
    refused = [name for name in _PROFILER_OPTIONS if _given(ctx, name) and name not in _CAD_ACCEPTS]
    if refused:
        raise click.UsageError(f"{', '.join(_option_name(name) for name in refused)} cannot be used with --cloud "
                               f"{p['cloud']} (they describe the profiler)")
    source = panel_file or mesh_file
    started = time.perf_counter()
    try:
        part = _load_part(panel_file, mesh_file, p["view"])
        points, truth, pitch = cad_scan(part, p["cloud"], p["spacing"], faces=p["faces"], noise=p["range_noise"],
                                        seed=seed, rotation=p["rotation"], translation=p["translation"],
                                        view=p["view"], line=p["line"], target=p["target"],
                                        line_length=p["line_length"], scan_length=p["scan_length"],
                                        float64=p["float64"])
    except (SpecError, ValueError) as error:
        raise Failure(f"{source}: {error}", EXIT_INPUT) from None
    truth = dict(truth, part=part.description, seed=seed, file=Path(output).name, noise=float(p["range_noise"]))
    generated = time.perf_counter()
    target = _write_scan(output, points, truth, truth_path, float32=not p["float64"])
    if verbose:
        click.echo(f"holecli: cloud: {p['cloud']}, faces {p['faces']}, pitch {pitch:.4g}, noise {p['range_noise']:g}, "
                   f"seed {seed}\nholecli: time: make {(generated - started) * 1e3:.1f} ms, write "
                   f"{(time.perf_counter() - generated) * 1e3:.1f} ms", err=True)
    if not quiet:
        click.echo(f"wrote {len(points)} points to {output} and the ground truth ({len(truth['holes'])} holes) to "
                   f"{target}", err=True)
    return EXIT_OK


def _load_part(panel_file, mesh_file, view):
    """The :class:`holecli.simulation.part.Part` of --panel or --mesh; a mesh that cannot be read is an
    input failure."""
    from holecli.simulation.part import mesh_part, panel_part

    if panel_file is not None:
        return panel_part(read_small_text(panel_file, "a panel spec"), panel_file)
    try:
        return mesh_part(mesh_file, view)
    except LoadError as error:
        raise Failure(str(error), EXIT_INPUT) from None


def _aimed_profiler(p, vertices):
    """The profiler of simulate's options ``p``, aimed at the part of ``vertices``."""
    from holecli.simulation.part import aimed_profiler

    return aimed_profiler(vertices, **{name: p[name] for name in _AIM_OPTIONS})


def _check_extension(output):
    """Fail on an OUTPUT whose extension no writer knows."""
    from holecli.io import WRITE_EXTENSIONS

    if Path(output).suffix.lower() not in WRITE_EXTENSIONS:
        raise Failure(f"{output}: unsupported extension (expected {', '.join(WRITE_EXTENSIONS)})", EXIT_INPUT)


def _write_scan(output, points, truth, truth_path, float32):
    """:func:`holecli.simulation.files.write_scan`; a file that cannot be written is an input/output failure."""
    from holecli.simulation.files import write_scan

    try:
        return write_scan(output, points, truth, truth_path, float32)
    except OSError as error:
        raise Failure(f"{output}: cannot write: {error.strerror or error}", EXIT_INPUT) from None
