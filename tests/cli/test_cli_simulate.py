"""holecli simulate's subcommands (scene, panel, cell, lot), each with only its own options, and today's
spellings (simulate FILE, simulate FILE --panel, simulate --cell DIR, simulate --lot DIR) routed to them
unchanged: both spellings write byte-identical files for the same seed (issue 26)."""

import hashlib

import pytest

from holecli import cli
from holecli.cli.simulate import simulate
from tests.conftest import REPO_ROOT

PANEL = str(REPO_ROOT / "sample_clouds" / "panel.toml")
COARSE = ("--spacing", "0.4", "--range-noise", "0.002")  # a quick scan of the sample panel

# (subcommand, old spelling, new spelling) with OUT the file or folder written.
SPELLINGS = [
    ("scene", ["OUT.ply", "--seed", "3", "--noise-z", "0.01"], ["scene", "OUT.ply", "--seed", "3", "--noise-z", "0.01"]),
    ("scene", ["OUT.csv", "--hole", "0,0,2", "--hole", "3,3,1.5", "--countersink", "2.5", "--pattern", "stripes",
               "--line-pitch", "0.2"],
     ["scene", "OUT.csv", "--hole", "0,0,2", "--hole", "3,3,1.5", "--countersink", "2.5", "--pattern", "stripes",
      "--line-pitch", "0.2"]),
    ("panel", ["OUT.ply", "--panel", PANEL, *COARSE, "--seed", "1"], ["panel", "OUT.ply", "--panel", PANEL, *COARSE,
                                                                       "--seed", "1"]),
    ("panel", ["OUT.pcd", "--panel", PANEL, "--cloud", "surface", "--spacing", "0.5", "--faces", "seen"],
     ["panel", "OUT.pcd", "--panel", PANEL, "--cloud", "surface", "--spacing", "0.5", "--faces", "seen"]),
    ("cell", ["--cell", "OUT", "--holes", "3", "--displace", "R2=0.2,0", "--seed", "1", "--spacing", "0.1"],
     ["cell", "OUT", "--holes", "3", "--displace", "R2=0.2,0", "--seed", "1", "--spacing", "0.1"]),
    ("lot", ["--lot", "OUT", "--parts", "2", "--panel", PANEL, *COARSE, "--defect", "2/C1=diameter:+0.1"],
     ["lot", "OUT", "--parts", "2", "--panel", PANEL, *COARSE, "--defect", "2/C1=diameter:+0.1"]),
]


def _written(folder):
    """{relative path: sha256} of every file under ``folder``."""
    return {str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(folder.rglob("*")) if path.is_file()}


def _spelled(args, out):
    return [arg.replace("OUT", str(out)) if arg.startswith("OUT") else arg for arg in args]


@pytest.mark.parametrize("kind, old, new", SPELLINGS, ids=[f"{s[0]}-{s[1][0]}" for s in SPELLINGS])
def test_the_old_spelling_and_the_subcommand_write_the_same_bytes(run, tmp_path, kind, old, new):
    written = {}
    for spelling, args in (("old", old), ("new", new)):
        folder = tmp_path / spelling
        folder.mkdir()
        result = run("simulate", *_spelled(args, folder / "out"), "-q")
        assert result.exit_code == cli.EXIT_OK, result.stderr
        assert result.stderr == ""
        written[spelling] = _written(folder)
    assert written["old"] and written["old"] == written["new"]


def test_the_group_help_lists_the_subcommands_and_the_old_spellings(run):
    text = run("simulate", "--help").stdout
    for name in ("scene", "panel", "cell", "lot"):
        assert f"\n  {name} " in text
    assert "Today's spellings still work" in text and "simulate --cell DIR" in text


@pytest.mark.parametrize("name", sorted(simulate.commands))
def test_each_subcommand_has_its_help_with_examples_and_exit_codes(run, name):
    result = run("simulate", name, "--help")
    assert result.exit_code == 0 and result.stderr == ""
    assert f"holecli simulate {name} " in result.stdout
    assert "Examples" in result.stdout and "Exit codes" in result.stdout


@pytest.mark.parametrize("name, own, foreign", [
    ("scene", ("--hole", "--pattern", "--noise-z", "--truth"), ("--panel", "--cell", "--lot", "--standoff", "--holes")),
    ("panel", ("--panel", "--mesh", "--cloud", "--standoff", "--truth"), ("--hole ", "--pattern", "--cell", "--parts")),
    ("cell", ("--holes", "--displace", "--standoff", "--range-noise"), ("--hole ", "--panel", "--parts", "--truth")),
    ("lot", ("--panel", "--parts", "--defect", "--standoff"), ("--hole", "--mesh", "--cell", "--truth", "--cloud")),
])
def test_each_subcommand_takes_only_its_own_options(run, name, own, foreign):
    text = run("simulate", name, "--help").stdout
    assert all(option in text for option in own)
    assert not any(option in text for option in foreign)


@pytest.mark.parametrize("args, message", [
    (("scene", "x.ply", "--panel", PANEL), "No such option '--panel'"),
    (("panel", "x.ply"), "give the part: --panel SPEC or --mesh PART"),
    (("panel", "x.ply", "--panel", PANEL, "--faces", "seen"), "--faces needs --cloud vertices or surface"),
    (("cell", "c", "--panel", PANEL), "No such option '--panel'"),
    (("lot", "l", "--parts", "2"), "Missing option '--panel'"),
    (("lot", "l", "--panel", PANEL), "Missing option '--parts'"),
    (("scene",), "Missing argument 'OUTPUT'"),
])
def test_subcommand_usage_errors(run, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = run("simulate", *args)
    assert result.exit_code == cli.EXIT_USAGE
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_the_old_spellings_keep_their_messages(run, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert "Missing argument 'OUTPUT'" in run("simulate").stderr
    assert "--parts need --lot" in run("simulate", "--parts", "3").stderr
    assert " simulate [OPTIONS] [OUTPUT]\n" in run("simulate", "x.ply", "--standoff", "3").stderr


@pytest.mark.parametrize("args", [("-q", "simulate", "scene"), ("simulate", "-q", "scene"), ("simulate", "scene", "-q")])
def test_quiet_reaches_the_subcommand_from_the_group_and_from_holecli(run, tmp_path, args):
    result = run(*args, tmp_path / "x.ply")
    assert result.exit_code == cli.EXIT_OK
    assert result.stderr == "" and (tmp_path / "x.ply").exists()


def test_verbose_reaches_the_subcommand(run, tmp_path):
    result = run("simulate", "-v", "scene", tmp_path / "x.ply")
    assert result.exit_code == cli.EXIT_OK
    assert "holecli: scene: pattern grid" in result.stderr


@pytest.mark.parametrize("spelling", [[], ["scene"]])
def test_simulate_invoked_on_its_own_takes_both_spellings(tmp_path, spelling):
    from click.testing import CliRunner

    out = tmp_path / "x.ply"
    result = CliRunner().invoke(simulate, [*spelling, str(out), "-q"])
    assert result.exit_code == cli.EXIT_OK, result.output
    assert out.exists() and out.with_suffix(".truth.json").exists()
