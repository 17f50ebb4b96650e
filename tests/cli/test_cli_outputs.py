"""How ``detect``, ``plot`` and ``batch`` write their outputs (issue 23, items 3, 4 and 7).

* a run's outputs are written all or none: a ``--plot`` that cannot be written leaves ``-o``'s
  earlier file as it was and prints nothing on stdout (item 3);
* no output may be the same file as an input or as another output: same path, a symbolic link or a
  hard link to it (item 4, a usage error, exit 2);
* a FIFO that no process reads is refused at once, exit 3, never waited for (item 7).

``register``'s outputs are tested in test_cli_register.py.
"""

import os
import shutil
import stat

import pytest

from holecli import cli
from test_cli_register import _assert_one_line_error

OLD = '{"earlier": "result"}\n'


def _assert_process_one_line_error(result, *texts, code=cli.EXIT_INPUT):
    assert result.returncode == code, result.stderr
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    for text in texts:
        assert str(text) in lines[0], lines[0]


@pytest.fixture
def scan(table1_files, tmp_path):
    """A copy of the Table I scan (PLY) in the test's folder: tests may try to write over it."""
    path = tmp_path / "scan.ply"
    shutil.copyfile(table1_files[".ply"], path)
    return path


@pytest.fixture
def spec(tmp_path):
    path = tmp_path / "part.toml"
    path.write_text('[[hole]]\nname = "A1"\ndiameter = 3.0\ntolerance = 0.05\n')
    return path


def _unwritable_png(tmp_path):
    # a PNG in a folder that does not exist (not a --plot folder: no trailing /): its write fails
    return tmp_path / "missing" / "fit.png"


# --- item 3: all or none --------------------------------------------------------------------------


def test_detect_plot_that_cannot_be_written_leaves_the_earlier_output(run, scan, tmp_path):
    pytest.importorskip("matplotlib")
    previous = tmp_path / "prev.json"
    previous.write_text(OLD)
    png = _unwritable_png(tmp_path)
    result = run("detect", scan, "-o", previous, "--plot", png)
    _assert_one_line_error(result, png, "cannot write the plot")
    assert previous.read_text() == OLD
    assert sorted(os.listdir(tmp_path)) == ["prev.json", "scan.ply"]  # no temporary left either


def test_detect_plot_that_cannot_be_written_prints_no_record(run, scan, tmp_path):
    pytest.importorskip("matplotlib")
    result = run("detect", scan, "--plot", _unwritable_png(tmp_path))
    _assert_one_line_error(result, "fit.png", "cannot write the plot")  # stdout "" checked there


def test_detect_output_that_cannot_be_written_leaves_the_earlier_plot(run, scan, tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "fit.png"
    png.write_bytes(b"earlier picture")
    output = tmp_path / "missing" / "result.json"
    result = run("detect", scan, "-o", output, "--plot", png)
    _assert_one_line_error(result, output, "cannot write output")
    assert png.read_bytes() == b"earlier picture"


def test_detect_writes_both_outputs_when_both_can_be_written(run, scan, tmp_path):
    pytest.importorskip("matplotlib")
    previous, png = tmp_path / "prev.json", tmp_path / "fit.png"
    previous.write_text(OLD)
    result = run("detect", scan, "-o", previous, "--plot", png)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert previous.read_text() != OLD and png.read_bytes().startswith(b"\x89PNG")
    assert sorted(os.listdir(tmp_path)) == ["fit.png", "prev.json", "scan.ply"]


# --- item 4: an output over an input, or over another output ---------------------------------------


def _same_file_cases(tmp_path, scan, spec):
    """(arguments, the two names the error must give, files that must not change)"""
    link = tmp_path / "latest.ply"
    link.symlink_to(scan.name)
    hard = tmp_path / "hard.toml"
    os.link(spec, hard)
    both = tmp_path / "both.json"
    return {
        "detect -o SCAN": (["detect", scan, "-o", scan], ["-o/--output", "SCAN"]),
        "detect --plot SCAN": (["detect", scan, "--plot", scan], ["--plot", "SCAN"]),
        "detect -o --spec": (["detect", scan, "--spec", spec, "-o", spec], ["-o/--output", "--spec"]),
        "detect -o X --plot X": (["detect", scan, "-o", both, "--plot", both], ["-o/--output", "--plot"]),
        "detect -o symlink to SCAN": (["detect", scan, "-o", link], ["latest.ply", "scan.ply"]),
        "detect -o hard link of --spec": (["detect", scan, "--spec", spec, "-o", hard], ["hard.toml", "part.toml"]),
        "detect --plot folder/ holding SCAN's png name": (["detect", tmp_path / "scan.png", "--plot", f"{tmp_path}/"],
                                                          ["--plot", "SCAN"]),
        "plot -o SCAN": (["plot", scan, "-o", scan], ["-o/--output", "SCAN"]),
        "plot -o symlink to SCAN": (["plot", scan, "-o", link], ["latest.ply", "scan.ply"]),
        "batch -o --spec": (["batch", scan, "--spec", spec, "-o", spec], ["-o/--output", "--spec"]),
        "batch -o a named PATH": (["batch", scan, "-o", scan], ["-o/--output", "PATH"]),
    }


CASES = ["detect -o SCAN", "detect --plot SCAN", "detect -o --spec", "detect -o X --plot X",
         "detect -o symlink to SCAN", "detect -o hard link of --spec", "detect --plot folder/ holding SCAN's png name",
         "plot -o SCAN", "plot -o symlink to SCAN", "batch -o --spec", "batch -o a named PATH"]


@pytest.mark.parametrize("case", CASES)
def test_an_output_that_is_an_input_or_another_output_is_a_usage_error(run, scan, spec, tmp_path, case):
    (tmp_path / "scan.png").write_bytes(b"not a scan, but named like one's plot")
    arguments, names = _same_file_cases(tmp_path, scan, spec)[case]
    before = {name: (tmp_path / name).read_bytes() for name in os.listdir(tmp_path)
              if not os.path.islink(tmp_path / name)}
    result = run(*arguments)
    _assert_one_line_error(result, *names, code=cli.EXIT_USAGE)
    after = {name: (tmp_path / name).read_bytes() for name in os.listdir(tmp_path)
             if not os.path.islink(tmp_path / name)}
    assert after == before  # nothing written, nothing made (both.json neither)


def test_dev_null_may_take_several_outputs(run, scan):
    pytest.importorskip("matplotlib")
    result = run("detect", scan, "-o", os.devnull, "--plot", os.devnull)
    assert result.exit_code == cli.EXIT_OK, result.stderr


# --- item 7: a FIFO without a reader ----------------------------------------------------------------


@pytest.mark.parametrize("option", ["-o", "--plot"])
def test_detect_into_a_fifo_without_a_reader_is_refused_not_waited_for(holecli_process, scan, tmp_path, option):
    if option == "--plot":
        pytest.importorskip("matplotlib")
    fifo = tmp_path / "nobody.reads"
    os.mkfifo(fifo)
    previous = tmp_path / "prev.json"
    previous.write_text(OLD)
    other = ["-o", previous] if option == "--plot" else []
    # without the check this never ends: the timeout fails the test
    result = holecli_process("detect", scan, option, fifo, *other, timeout=90)
    _assert_process_one_line_error(result, fifo, "no process reads")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert previous.read_text() == OLD


def test_detect_plot_into_a_fifo_with_a_reader_writes_through_it(run, scan, tmp_path, fifo_reader):
    pytest.importorskip("matplotlib")
    fifo = tmp_path / "viewer"
    os.mkfifo(fifo)
    finish = fifo_reader(fifo)
    result = run("detect", scan, "--plot", fifo)
    received = finish()
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert received.startswith(b"\x89PNG") and received.endswith(b"IEND\xaeB`\x82")
