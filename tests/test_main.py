"""The ``holecli`` program's exit (:func:`holecli.__main__.prepare_exit`): cheap, and nothing lost."""

import json
import os
import subprocess
import sys


def run_python(code, *args, repo_root):
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, env=env,
                          cwd=repo_root, timeout=120)


def test_the_exit_still_finalizes_what_the_command_left_in_a_cycle(tmp_path, repo_root):
    # prepare_exit collects before it freezes: an object the command left in a reference cycle is still
    # finalized, as by the interpreter's own last collection (frozen first, it never would be)
    path = tmp_path / "finalized.txt"
    code = ("import sys\n"
            "from holecli.__main__ import prepare_exit\n"
            "class Holder:\n"
            "    def __del__(self):\n"
            "        with open(sys.argv[1], 'w') as file:\n"
            "            file.write('finalized')\n"
            "holder = Holder()\n"
            "holder.itself = holder\n"
            "del holder\n"
            "prepare_exit()\n")
    result = run_python(code, path, repo_root=repo_root)
    assert result.returncode == 0, result.stderr
    assert path.read_text() == "finalized"


def test_the_program_writes_its_whole_record_and_exits_with_its_code(tmp_path, repo_root):
    # through __main__ (and its prepare_exit), the record on stdout and in -o FILE is complete
    scan = repo_root / "sample_clouds" / "table1.ply"
    output = tmp_path / "record.json"
    code = "import sys\nfrom holecli.__main__ import main\nsys.exit(main())\n"
    shown = run_python(code, "detect", scan, "-q", repo_root=repo_root)
    written = run_python(code, "detect", scan, "-q", "-o", output, repo_root=repo_root)
    assert shown.returncode == written.returncode == 0, shown.stderr + written.stderr
    shown, written = json.loads(shown.stdout), json.loads(output.read_text())
    shown.pop("timing"), written.pop("timing")
    assert shown["holes"] and written == shown


def test_the_exit_freezes_nothing_after_a_command_that_used_processes(repo_root):
    # batch and serve start process pools: the exit's finalizers of their semaphores and pipes must see
    # every object, so prepare_exit leaves the collector alone once multiprocessing is imported
    code = ("import gc, sys\n"
            "from holecli.__main__ import prepare_exit\n"
            "if sys.argv[1] == 'pool':\n"
            "    import multiprocessing\n"
            "prepare_exit()\n"
            "print(gc.get_freeze_count() > 0)\n")
    assert run_python(code, "pool", repo_root=repo_root).stdout.strip() == "False"
    assert run_python(code, "plain", repo_root=repo_root).stdout.strip() == "True"
