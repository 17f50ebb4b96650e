"""Shared fixtures: the paper's Table I scene, its detection, and the scan written in each file format."""

from pathlib import Path

import numpy as np
import pytest

from holecli.simulation import synth

REPO_ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def rng():
    """A fixed random source, fresh for every test."""
    return np.random.default_rng(20240611)


@pytest.fixture(scope="session")
def repo_root():
    """The repository root (for subprocesses that must import holecli from this checkout)."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def table1_scan():
    """The paper's Table I scene without noise: 7,062 points on a 0.0908 mm grid with a 3 mm hole."""
    return synth.make_scan(synth.table1_scene(), 0)


@pytest.fixture(scope="session")
def table1_truth(table1_scan):
    """Ground truth of the Table I hole: center, diameter and normal in the world frame."""
    return table1_scan.truth["holes"][0]


@pytest.fixture(scope="session")
def table1_paper(table1_scan):
    """``detect(..., method="paper")`` on the Table I scene (frozen result, safe to share)."""
    from holecli.pipeline import detect

    return detect(table1_scan.points, method="paper")


@pytest.fixture(scope="session")
def table1_files(table1_scan, tmp_path_factory):
    """The Table I scan written by ``save_points`` as PLY, PCD and CSV: {extension: path}."""
    from holecli.io import save_points

    folder = tmp_path_factory.mktemp("table1")
    files = {}
    for extension in (".ply", ".pcd", ".csv"):
        path = folder / f"table1{extension}"
        save_points(path, table1_scan.points)
        files[extension] = path
    return files


@pytest.fixture
def run():
    """Invoke the CLI in-process; stdout and stderr come back separately (click >= 8.2)."""
    from click.testing import CliRunner

    from holecli import cli

    runner = CliRunner()

    def invoke(*args):
        return runner.invoke(cli.main, [str(arg) for arg in args])

    return invoke


@pytest.fixture
def holecli_process(repo_root):
    """Run the real ``holecli`` program (``python -m holecli``) in a process of its own.

    ``holecli_process(*args, **popen_options)`` returns the finished :class:`subprocess.CompletedProcess`
    (text output, a 120 s timeout); with ``start=True`` the running :class:`subprocess.Popen`.
    """
    import os
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=str(repo_root))
    env.pop("PYTHONWARNINGS", None)

    def start_or_run(*args, start=False, **options):
        command = [sys.executable, "-m", "holecli", *map(str, args)]
        options = {"env": env, "text": True, **options}
        if start:
            options.setdefault("stdout", subprocess.PIPE)
            options.setdefault("stderr", subprocess.PIPE)
            return subprocess.Popen(command, **options)
        options.setdefault("capture_output", "stdout" not in options and "stderr" not in options)
        return subprocess.run(command, timeout=options.pop("timeout", 120), **options)

    return start_or_run


@pytest.fixture
def modules_imported_by(repo_root):
    """``modules_imported_by(commands, names)``: which of the modules ``names`` (and their submodules)
    a fresh interpreter has imported after running each of ``commands`` (argument lists of
    ``holecli``, in-process, their exits caught). For the tests that keep heavy imports out of a
    command."""
    import os
    import subprocess
    import sys

    def imported(commands, names):
        code = (
            "import sys\n"
            "import holecli.cli\n"
            f"for args in {[list(map(str, command)) for command in commands]!r}:\n"
            "    try:\n"
            "        holecli.cli.main(args)\n"
            "    except SystemExit:\n"
            "        pass\n"
            f"names = {tuple(names)!r}\n"
            "print(sorted(m for m in sys.modules if m in names or m.startswith(tuple(n + '.' for n in names))),"
            " file=sys.stderr)\n"
        )
        env = dict(os.environ, PYTHONPATH=str(repo_root))
        result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                                cwd=repo_root, timeout=120)
        assert result.returncode == 0, result.stderr
        return result.stderr.strip().splitlines()[-1]

    return imported


@pytest.fixture
def fifo_reader():
    """``fifo_reader(path)`` starts a reader of the FIFO ``path``: its read end opened at once (without
    waiting for a writer: a FIFO without a reader is refused, issue 23), read in a thread until the
    writer closes it; it returns ``finish()``, which returns the bytes read."""
    import os
    import select
    import threading

    def start(path):
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        chunks = []

        def read():
            # select reports nothing on a FIFO no writer has opened yet; then data, then the writer's close
            while select.select([descriptor], [], [], 60)[0]:
                try:
                    chunk = os.read(descriptor, 1 << 16)
                except BlockingIOError:
                    continue
                if not chunk:
                    return
                chunks.append(chunk)

        thread = threading.Thread(target=read, daemon=True)
        thread.start()

        def finish():
            thread.join(30)
            os.close(descriptor)
            return b"".join(chunks)

        return finish

    return start


@pytest.fixture(scope="session")
def postgres_url():
    """The URL of a throwaway PostgreSQL server for the session (:mod:`tests.pgserver`, fsync on);
    skipped only when this machine has no PostgreSQL (no ``initdb``): any other failure to start it
    is an error."""
    from tests.pgserver import NoPostgres, postgres_bindir, postgres_server

    try:
        postgres_bindir()
    except NoPostgres as reason:
        pytest.skip(str(reason))
    with postgres_server() as url:
        yield url


@pytest.fixture
def postgres_store_url(postgres_url):
    """The URL of a new, empty database of the session's PostgreSQL server, for one test."""
    from tests.pgserver import fresh_database

    with fresh_database(postgres_url) as url:
        yield url


@pytest.fixture(scope="session")
def shift_lot(tmp_path_factory, repo_root):
    """A shift of 4 simulated panels (sample_clouds/panel.toml, 0.2 mm profiler) measured by ``holecli
    batch --spec sample_clouds/panel_tolerances.toml``: part_002's C1 drilled 0.1 mm large, part_003's
    L1 not drilled. Returns ``{"folder", "scans", "jsonl"}``: the JSON Lines' records in file order
    (batch writes them in the order the files finish)."""
    import json
    import os
    import subprocess
    import sys

    folder = tmp_path_factory.mktemp("shift")
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    holecli = [sys.executable, "-m", "holecli"]
    subprocess.run(holecli + ["simulate", "lot", str(folder / "lot"), "--parts", "4", "--panel",
                              str(repo_root / "sample_clouds" / "panel.toml"), "--spacing", "0.2",
                              "--defect", "2/C1=diameter:+0.1", "--defect", "3/L1=missing", "-q"],
                   check=True, env=env, timeout=300)
    jsonl = folder / "shift.jsonl"
    batch = subprocess.run(holecli + ["batch", str(folder / "lot"), "--spec",
                                      str(repo_root / "sample_clouds" / "panel_tolerances.toml"), "-o", str(jsonl),
                                      "-q"], env=env, timeout=300)
    assert batch.returncode == 5  # a part out of tolerance
    records = sorted((json.loads(line) for line in jsonl.read_text().splitlines()), key=lambda r: r["file"])
    jsonl.write_text("".join(json.dumps(record) + "\n" for record in records))
    return {"folder": folder, "scans": folder / "lot", "jsonl": jsonl}
