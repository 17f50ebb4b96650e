"""--quiet and --verbose of every command, detect's status line on a terminal, shell completion (issue 13)."""

import io
import json
import os
import shutil
import subprocess
import sys
import time

import pytest

from holecli import cli

SAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "sample_clouds")
TABLE1 = os.path.join(SAMPLES, "table1.ply")
NO_HOLE = os.path.join(SAMPLES, "no_hole.csv")


def _without_timing(text):
    record = json.loads(text)
    record.pop("timing")
    return record


# --- --quiet -----------------------------------------------------------------------------------------


def test_detect_quiet_says_nothing_but_errors(run, tmp_path):
    result = run("detect", NO_HOLE, "-q")
    assert result.exit_code == cli.EXIT_NO_HOLE
    assert result.stderr == ""
    assert json.loads(result.stdout)["holes"] == []
    assert "no hole found" in run("detect", NO_HOLE).stderr
    result = run("detect", TABLE1, "--quiet", "--nominal-diameter", "2", "--tolerance", "0.01")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert result.stderr == ""
    result = run("detect", tmp_path / "missing.ply", "-q")
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith("Error: ") and "file not found" in result.stderr


def test_batch_quiet_gives_only_the_failures(run, tmp_path):
    shutil.copy(TABLE1, tmp_path / "a.ply")
    (tmp_path / "b.csv").write_text("1,2\n")
    result = run("batch", tmp_path, "-j", "1", "-q")
    assert result.exit_code == cli.EXIT_FILE_FAILED
    assert result.stderr.splitlines() == [line for line in result.stderr.splitlines() if "failed: " in line]
    assert len(result.stderr.splitlines()) == 1
    assert "holecli batch: " in run("batch", tmp_path, "-j", "1").stderr  # the summary, without -q
    assert len(result.stdout.splitlines()) == 2


def test_simulate_quiet_and_verbose(run, tmp_path):
    result = run("simulate", tmp_path / "scene.ply", "-q")
    assert result.exit_code == cli.EXIT_OK
    assert result.stderr == "" and result.stdout == ""
    result = run("simulate", tmp_path / "scene.ply", "--verbose", "--pattern", "stripes", "--line-pitch", "0.2")
    assert result.exit_code == cli.EXIT_OK
    assert "scene: pattern stripes, spacing 0.0908, line pitch 0.2, 1 hole, seed 0" in result.stderr
    assert "time: generate" in result.stderr and result.stdout == ""


@pytest.mark.parametrize("command", [["detect", TABLE1], ["batch", TABLE1], ["simulate", "out.ply"]])
def test_quiet_and_verbose_together_are_a_usage_error(run, command):
    result = run(*command, "-q", "-v")
    assert result.exit_code == cli.EXIT_USAGE
    assert "--quiet and --verbose cannot be combined" in result.stderr


@pytest.mark.parametrize("command", ["detect", "batch", "simulate"])
def test_every_command_documents_quiet_and_verbose(run, command):
    text = run(command, "--help").stdout
    assert "-q, --quiet" in text and "-v, --verbose" in text


# --- --verbose ---------------------------------------------------------------------------------------


def test_detect_verbose_gives_the_scales_candidates_and_stage_times_on_stderr_only(run):
    plain = run("detect", TABLE1)
    result = run("detect", TABLE1, "-v")
    assert result.exit_code == cli.EXIT_OK
    assert _without_timing(result.stdout) == _without_timing(plain.stdout)  # stdout: the data only
    text = result.stderr
    assert all(line.startswith("holecli: ") for line in text.splitlines())
    record = json.loads(result.stdout)
    scales = record["scales"]
    assert f"point spacing {scales['point_spacing']:.4g}, gap scale {scales['gap_scale']:.4g}" in text
    assert "no stripes, a square grid" in text
    assert f"minimum diameter {scales['min_diameter']:.4g} (default: 6 gap scales)" in text
    assert "1 candidate tried: 1 hole, 0 rejected" in text
    for stage in record["timing"]["stages"]:
        assert f" {stage} " in text
    assert "reading the file" in text


def test_detect_verbose_of_a_striped_scan_and_of_the_paper_method(run):
    text = run("detect", os.path.join(SAMPLES, "stripes_three_holes.ply"), "-v", "--min-diameter", "1").stderr
    assert "(stripes)" in text and "line pitch" in text
    assert "minimum diameter 1 (given)" in text
    assert "3 candidates tried: 3 holes" in text
    text = run("detect", TABLE1, "-v", "--method", "paper").stderr
    assert "triangle area bound" in text and "paper" in text


def test_batch_verbose_gives_each_files_scales(run, tmp_path):
    for name in ("a.ply", "b.ply"):
        shutil.copy(TABLE1, tmp_path / name)
    result = run("batch", tmp_path, "-j", "1", "-v")
    assert result.exit_code == cli.EXIT_OK
    assert result.stderr.count("point spacing") == 2
    assert result.stderr.count("candidate tried") == 2
    assert "holecli batch: 2 files" in result.stderr


# --- detect's status line ----------------------------------------------------------------------------


def test_the_status_line_is_drawn_on_a_terminal_and_is_gone_after():
    from rich.console import Console

    from holecli.cli.progress import DetectStatus

    screen = io.StringIO()
    with DetectStatus("scan.ply", console=Console(file=screen, force_terminal=True, width=80)) as status:
        assert status.shown
        status.stage("plane")
        time.sleep(0.15)  # the status's own refresh draws it
    text = screen.getvalue()
    assert "measuring scan.ply: plane" in text
    assert text.endswith("\x1b[2K")  # transient: the line is erased at the end


def test_the_status_line_is_never_drawn_with_quiet_or_without_a_terminal(monkeypatch):
    from rich.console import Console

    from holecli.cli.progress import DetectStatus

    screen = io.StringIO()
    with DetectStatus("scan.ply", quiet=True, console=Console(file=screen, force_terminal=True)) as status:
        status.stage("plane")
    assert not status.shown and screen.getvalue() == ""
    stderr = io.StringIO()
    monkeypatch.setattr(sys, "stderr", stderr)
    with DetectStatus("scan.ply") as status:
        status.stage("plane")
    assert not status.shown and stderr.getvalue() == ""


def test_the_status_line_follows_a_fake_terminal_on_stderr(monkeypatch):
    from holecli.cli.progress import DetectStatus

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    monkeypatch.setenv("TERM", "xterm")
    monkeypatch.delenv("NO_COLOR", raising=False)
    with DetectStatus("scan.ply") as status:
        status.stage("sampling")
        time.sleep(0.15)
    assert status.shown
    assert "measuring scan.ply: sampling" in stderr.getvalue()
    with DetectStatus("scan.ply", quiet=True) as status:
        pass
    assert not status.shown


def test_detect_shows_the_stages_of_the_pipeline_on_the_status_line(monkeypatch):
    # The command line hands the status's stage() to the pipeline as its progress callback.
    from click.testing import CliRunner

    from holecli.cli import progress

    stages = []
    original = progress.DetectStatus.stage
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda stream=None: True)
    monkeypatch.setattr(progress.DetectStatus, "stage", lambda self, name: (stages.append(name), original(self, name)))
    result = CliRunner().invoke(cli.main, ["detect", TABLE1])
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert stages == ["validate", "imports", "plane", "frame", "sampling", "grid", "candidates", "shape"]
    assert json.loads(result.stdout)["holes"]


def test_no_status_line_when_stderr_is_a_pipe(holecli_process):
    result = holecli_process("detect", TABLE1)
    assert result.returncode == cli.EXIT_OK
    assert result.stderr == ""
    json.loads(result.stdout)


# --- shell completion ---------------------------------------------------------------------------------


def test_click_completion_source_and_completions(monkeypatch):
    from click.testing import CliRunner

    runner = CliRunner()
    source = runner.invoke(cli.main, [], prog_name="holecli", env={"_HOLECLI_COMPLETE": "bash_source"})
    assert source.exit_code == 0
    assert "_holecli_completion" in source.stdout and "complete -o nosort -F _holecli_completion holecli" in source.stdout
    completed = runner.invoke(cli.main, [], prog_name="holecli",
                              env={"_HOLECLI_COMPLETE": "bash_complete", "COMP_WORDS": "holecli detect scan.ply --verb",
                                   "COMP_CWORD": "3"})
    assert completed.stdout.splitlines() == ["plain,--verbose"]


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_bash_completion_of_the_installed_program_works(tmp_path, repo_root):
    # The docs' line (docs/guide/info.md, Shell completion), run by bash against a `holecli` program of
    # this checkout (what the console script of an install is: a script named holecli that calls
    # holecli.__main__.main).
    program = tmp_path / "holecli"
    program.write_text(f"#!{sys.executable}\nimport sys\nfrom holecli.__main__ import main\nsys.exit(main())\n")
    program.chmod(0o755)
    env = dict(os.environ, PATH=f"{tmp_path}{os.pathsep}{os.environ.get('PATH', '')}", PYTHONPATH=str(repo_root))
    # bash calls a completion function with the command's name as its first argument
    script = ('eval "$(_HOLECLI_COMPLETE=bash_source holecli)"\n'
              'complete -p holecli\n'
              'COMP_WORDS=(holecli de); COMP_CWORD=1; _holecli_completion holecli; echo "${COMPREPLY[*]}"\n'
              'COMPREPLY=(); COMP_WORDS=(holecli batch --qu); COMP_CWORD=2; _holecli_completion holecli; '
              'echo "${COMPREPLY[*]}"\n')
    result = subprocess.run(["bash", "--norc", "--noprofile", "-c", script], capture_output=True, text=True, env=env,
                            timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["complete -o nosort -F _holecli_completion holecli", "detect", "--quiet"]


# --- before the command (issue 25) -------------------------------------------------------------------


def test_verbose_before_the_command_is_the_commands_verbose(run):
    before, after = run("-v", "detect", TABLE1), run("detect", "-v", TABLE1)
    assert before.exit_code == after.exit_code == cli.EXIT_OK
    strip = lambda text: [line for line in text.splitlines() if "time " not in line]  # noqa: E731
    assert strip(before.stderr) == strip(after.stderr) and "point spacing" in before.stderr
    assert _without_timing(before.stdout) == _without_timing(after.stdout)


def test_quiet_before_the_command_silences_it(run):
    result = run("-q", "detect", NO_HOLE)
    assert result.exit_code == cli.EXIT_NO_HOLE and result.stderr == ""
    assert "no hole found" in run("detect", NO_HOLE).stderr


@pytest.mark.parametrize("args", [["-q", "-v", "detect", TABLE1], ["-q", "detect", "-v", TABLE1],
                                  ["-v", "batch", "-q", TABLE1]])
def test_quiet_and_verbose_before_and_after_the_command_are_a_usage_error(run, args):
    result = run(*args)
    assert result.exit_code == cli.EXIT_USAGE
    assert "--quiet and --verbose cannot be combined" in result.stderr


def test_the_global_options_are_in_the_help(run):
    text = run("--help").stdout
    assert "-q, --quiet" in text and "-v, --verbose" in text
