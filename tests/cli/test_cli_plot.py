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
