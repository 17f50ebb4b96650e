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
