"""``holecli plot`` and ``holecli detect --plot``: the PNG, the missing extra, matplotlib never imported without them."""

import json
import os
import sys

import numpy as np
import pytest

from holecli import cli

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "sample_clouds")


def sample(name):
    return os.path.normpath(os.path.join(SAMPLES, name))


def png_pixels(path):
    from PIL import Image

    with Image.open(path) as image:
        return np.asarray(image.convert("L"), dtype=float)


def test_detect_without_plot_does_not_import_matplotlib(modules_imported_by):
    commands = (["--help"], ["plot", "--help"], ["detect", sample("table1.ply"), "--format", "csv"])
    assert modules_imported_by(commands, ("matplotlib", "holecli.plot")) == "[]"


def test_missing_matplotlib_is_one_error_line_and_exit_3(run, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    for args in (["plot", sample("table1.ply"), "-o", str(tmp_path / "fit.png")],
                 ["detect", sample("table1.ply"), "--plot", str(tmp_path / "fit.png")]):
        result = run(*args)
        assert result.exit_code == cli.EXIT_INPUT
        assert result.stderr == "Error: holecli plot needs the optional extra: pip install 'holecli[plot]'\n"
        assert result.stdout == ""
        assert not (tmp_path / "fit.png").exists()


pytest.importorskip("matplotlib")


@pytest.mark.parametrize("name, holes", [("panel.ply", 4), ("table1.ply", 1)])
def test_plot_writes_a_png_of_the_holes(run, tmp_path, name, holes):
    out = tmp_path / "fit.png"
    result = run("plot", sample(name), "-o", str(out), "--dpi", "40")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert result.stdout == ""
    assert f"{holes} hole" in result.stderr and str(out) in result.stderr
    assert out.read_bytes().startswith(PNG_MAGIC)
    pixels = png_pixels(out)
    assert pixels.shape[1] == 14 * 40
    assert pixels.shape[0] == pytest.approx(4.6 * 40 * holes, rel=0.03)
    assert pixels.std() > 10
    assert [p.name for p in tmp_path.iterdir()] == ["fit.png"]  # no temporary left


def test_plot_max_panels_and_quiet(run, tmp_path):
    out = tmp_path / "fit.png"
    result = run("plot", sample("panel.ply"), "-o", str(out), "--max-panels", "1", "--dpi", "30", "-q")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert result.stderr == ""
    assert png_pixels(out).shape[0] == pytest.approx(4.6 * 30, rel=0.05)


def test_detect_plot_writes_the_record_and_the_png(run, tmp_path):
    out = tmp_path / "fit.png"
    result = run("detect", sample("table1.ply"), "--plot", str(out))
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert len(json.loads(result.stdout)["holes"]) == 1
    assert out.read_bytes().startswith(PNG_MAGIC)
    assert png_pixels(out).std() > 10


def test_plot_errors_are_one_line(run, tmp_path):
    result = run("plot", str(tmp_path / "missing.ply"), "-o", str(tmp_path / "fit.png"))
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith("Error: ") and result.stderr.count("\n") == 1
    result = run("plot", sample("table1.ply"), "-o", str(tmp_path / "no" / "such" / "fit.png"))
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith("Error: ") and "cannot write the plot" in result.stderr
    assert result.stderr.count("\n") == 1


def test_plot_needs_output(run):
    result = run("plot", sample("table1.ply"))
    assert result.exit_code == cli.EXIT_USAGE


def test_plot_without_a_hole_draws_the_scan_and_exits_4(run, tmp_path):
    out = tmp_path / "fit.png"
    result = run("plot", sample("no_hole.csv"), "-o", str(out), "--dpi", "30")
    assert result.exit_code == cli.EXIT_NO_HOLE
    assert out.read_bytes().startswith(PNG_MAGIC)


# --- detect --plot DIR/ -------------------------------------------------------------------------


def test_detect_plot_into_an_existing_folder_writes_the_scan_stem(run, tmp_path):
    result = run("detect", sample("table1.ply"), "--plot", str(tmp_path), "--format", "csv")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["table1.png"]
    assert png_pixels(tmp_path / "table1.png").std() > 10


def test_detect_plot_into_a_new_folder_ending_with_a_slash_creates_it(run, tmp_path):
    folder = tmp_path / "plots" / "shift1"
    result = run("detect", sample("table1.ply"), "--plot", str(folder) + "/")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert json.loads(result.stdout)["holes"]
    assert [p.name for p in folder.iterdir()] == ["table1.png"]


def test_detect_plot_file_without_a_slash_is_a_file(run, tmp_path):
    out = tmp_path / "fit"  # not a folder, no slash: the PNG itself
    result = run("detect", sample("table1.ply"), "--plot", str(out))
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert out.is_file() and out.read_bytes().startswith(PNG_MAGIC)


def test_detect_plot_folder_that_cannot_be_made_is_one_error_line_and_exit_3(run, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    for target, why in ((str(blocker) + "/", "not a folder"), (str(blocker / "sub") + "/", "cannot create")):
        result = run("detect", sample("table1.ply"), "--plot", target)
        assert result.exit_code == cli.EXIT_INPUT
        assert result.stderr.startswith(f"Error: {blocker}") and why in result.stderr
        assert result.stderr.count("\n") == 1
        assert result.stdout == ""  # nothing measured


def test_detect_plot_draws_the_verdict_of_the_tolerances(run, tmp_path, monkeypatch):
    from holecli import plot

    drawn = {}
    figure = plot.figure

    def spy(*args, **kwargs):
        drawn.update(kwargs)
        return figure(*args, **kwargs)

    monkeypatch.setattr(plot, "figure", spy)
    result = run("detect", sample("table1.ply"), "--nominal-diameter", "3", "--tolerance", "+0.036/-0",
                 "--plot", str(tmp_path) + "/")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert drawn["checked"][0]["failed_checks"] == ["diameter"]
    assert plot.verdict_lines(drawn["checked"][0])[-1] == "verdict: fail: diameter"
    assert (tmp_path / "table1.png").is_file()
    drawn.clear()
    assert run("detect", sample("table1.ply"), "--plot", str(tmp_path) + "/").exit_code == cli.EXIT_OK
    assert drawn["checked"] is None


def test_plot_names_of_scans():
    from holecli.cli.plot import is_plot_folder, plot_name

    assert plot_name("scans/part.7.ply") == "part.7.png"
    assert plot_name("-") == "stdin.png"
    assert is_plot_folder("new/") and not is_plot_folder("new.png")


# --- batch --plot PLOTDIR ------------------------------------------------------------------------


def _small_scan(seed):
    """About 3,000 points on a 0.1 mm grid with one 2.5 mm hole: quick to measure and to draw."""
    from holecli.simulation import synth

    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=2.5),), extent=(-2.8, 2.8, -2.8, 2.8),
                            spacing=0.1, rotation_deg=(10.0, 5.0, 7.0 * seed), translation=(seed, 2.0, 3.0))
    return synth.make_scan(scene, seed)


@pytest.fixture
def scans_folder(tmp_path):
    """scans/{a.ply, b.ply, sub/a.csv}: two scans share the stem a."""
    from holecli.io import save_points

    folder = tmp_path / "scans"
    (folder / "sub").mkdir(parents=True)
    for seed, name in enumerate(("a.ply", "b.ply", "sub/a.csv")):
        save_points(folder / name, _small_scan(seed).points)
    return folder


def _records(text):
    return [json.loads(line) for line in text.splitlines()]


def test_batch_plot_one_png_per_scan_unique_names_plotdir_inside_never_measured(run, scans_folder):
    plots = scans_folder / "plots"
    result = run("batch", scans_folder, "-r", "--plot", plots, "--jobs", "2")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert len(_records(result.stdout)) == 3
    assert sorted(p.name for p in plots.iterdir()) == ["a-2.png", "a.png", "b.png"]
    for png in plots.iterdir():
        assert png.read_bytes().startswith(PNG_MAGIC) and png_pixels(png).std() > 10
    # again, every file read as PLY: the PNGs in PLOTDIR (inside the folder) are still not measured
    again = run("batch", scans_folder, "-r", "--input-format", "ply", "--pattern", "*", "--plot", plots, "-j", "1")
    assert {os.path.basename(r["file"]) for r in _records(again.stdout)} == {"a.ply", "b.ply", "a.csv"}


def test_batch_plot_names_are_by_input_order():
    from holecli.batch import plot_files

    files = ["s/a.ply", "s/b.ply", "s/sub/a.csv", "s/sub/A.pcd", "s/a-2.xyz"]
    assert plot_files(files, "p") == {"s/a.ply": "p/a.png", "s/b.ply": "p/b.png", "s/sub/a.csv": "p/a-2.png",
                                      "s/sub/A.pcd": "p/A-3.png", "s/a-2.xyz": "p/a-2-2.png"}


def test_batch_plot_draws_the_verdict_in_the_worker(run, scans_folder, tmp_path, monkeypatch):
    from holecli import plot

    log = tmp_path / "verdicts.txt"
    figure = plot.figure

    def spy(*args, **kwargs):  # the workers are forked: they run this too
        with open(log, "a") as stream:
            stream.write(plot.verdict_lines(kwargs["checked"][0] if kwargs["checked"] else None)[-1] + "\n")
        return figure(*args, **kwargs)

    monkeypatch.setattr(plot, "figure", spy)
    result = run("batch", scans_folder / "b.ply", "--nominal-diameter", "2.5", "--tolerance", "0.05",
                 "--plot", tmp_path / "plots", "-j", "1")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert log.read_text() == "verdict: pass\n"
    assert (tmp_path / "plots" / "b.png").is_file()


def test_batch_plotdir_that_cannot_be_created_is_one_error_line_exit_3_nothing_measured(run, scans_folder, tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("x")
    out = tmp_path / "out.jsonl"
    out.write_text("kept\n")
    result = run("batch", scans_folder, "--plot", blocker / "plots", "-o", out)
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr == f"Error: {blocker / 'plots'}: cannot create the plot folder: Not a directory\n"
    assert result.stdout == "" and out.read_text() == "kept\n"  # the output not even opened
    result = run("batch", scans_folder, "--plot", blocker)
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr == f"Error: {blocker}: cannot draw into it: not a folder\n"


def test_batch_a_png_that_cannot_be_written_makes_an_error_record_and_the_batch_goes_on(run, scans_folder):
    plots = scans_folder.parent / "plots"
    (plots / "a.png").mkdir(parents=True)  # a folder where a.ply's PNG goes
    result = run("batch", scans_folder, "--plot", plots, "-j", "1")
    assert result.exit_code == cli.EXIT_FILE_FAILED, result.stderr
    records = {os.path.basename(r["file"]): r for r in _records(result.stdout)}
    assert set(records) == {"a.ply", "b.ply"}
    error = records["a.ply"]["error"]
    assert error.startswith(f"{plots / 'a.png'}: cannot write the plot: ")
    assert f"({scans_folder / 'a.ply'} was measured: 1 hole, diameter 2." in error
    assert set(records["a.ply"]) == {"schema_version", "holecli_version", "file", "path", "error"}
    assert records["b.ply"]["holes"] and (plots / "b.png").is_file()
    assert "holecli: failed: " in result.stderr


def test_batch_resume_does_not_redraw_the_scans_done(run, scans_folder, tmp_path):
    plots, out = tmp_path / "plots", tmp_path / "out.jsonl"
    first = run("batch", scans_folder / "a.ply", "--plot", plots, "-o", out, "-j", "1")
    assert first.exit_code == cli.EXIT_OK, first.stderr
    (plots / "a.png").unlink()
    result = run("batch", scans_folder, "-r", "--plot", plots, "-o", out, "--resume", "-j", "1")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert len(_records(out.read_text())) == 3
    assert sorted(p.name for p in plots.iterdir()) == ["a-2.png", "b.png"]  # a.ply not drawn again


def test_batch_without_plot_does_not_import_matplotlib(modules_imported_by, scans_folder):
    assert modules_imported_by([["batch", scans_folder / "b.ply", "-j", "1", "-q"]],
                               ("matplotlib", "holecli.plot", "PIL")) == "[]"
    assert "matplotlib" in modules_imported_by([["batch", scans_folder / "b.ply", "-j", "1", "-q", "--plot",
                                                 scans_folder.parent / "plots"]], ("matplotlib",))


def test_batch_plot_without_matplotlib_is_one_error_line(run, scans_folder, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    result = run("batch", scans_folder, "--plot", tmp_path / "plots")
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr == "Error: holecli plot needs the optional extra: pip install 'holecli[plot]'\n"
    assert result.stdout == "" and not (tmp_path / "plots").exists()
