"""The installed package: what `import holecli` finds, and what a wheel built from the checkout holds."""

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import holecli

PACKAGE = Path(holecli.__file__).resolve().parent


def _run(args, cwd):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, timeout=120)


def test_import_from_the_folder_that_holds_a_clone_named_holecli(tmp_path):
    # From the parent of a clone named holecli/ the current folder (first on sys.path) holds a folder
    # holecli/ without __init__.py. With setuptools' default editable install (a finder consulted after
    # sys.path) that folder was imported as an empty namespace package: holecli.__file__ None, every
    # command broken. The path-based editable install of scripts/setup.sh (or a plain install) wins.
    (tmp_path / "holecli" / "sample_clouds").mkdir(parents=True)
    (tmp_path / "holecli" / "README.md").write_text("a clone, seen from its parent folder\n")
    result = _run(["-c", "import holecli; print(holecli.__file__)"], tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() != "None", "holecli was imported as a namespace package from the current folder"
    assert Path(result.stdout.strip()).resolve() == PACKAGE / "__init__.py"
    result = _run(["-m", "holecli", "--version"], tmp_path)
    assert result.returncode == 0, result.stderr
    assert holecli.__version__ in result.stdout


def test_every_folder_of_the_package_is_a_regular_package():
    # pyproject.toml takes the packages that setuptools finds (`holecli*`): a folder of modules
    # without __init__.py would be left out of the wheel (and of `pip install .`).
    missing = [str(folder.relative_to(PACKAGE.parent)) for folder, _, files in os.walk(PACKAGE)
               for folder in [Path(folder)] if folder.name != "__pycache__"
               and any(name.endswith(".py") for name in files) and "__init__.py" not in files]
    assert missing == []


def test_the_package_s_data_files_are_declared():
    # Modules, and the JSON Schema of the records: a data file added to holecli/ needs
    # [tool.setuptools.package-data] in pyproject.toml to reach the wheel (and then this list).
    data = [str(path.relative_to(PACKAGE.parent)) for path in PACKAGE.rglob("*")
            if path.is_file() and "__pycache__" not in path.parts and path.suffix not in {".py", ".pyi"}
            and path.name != "py.typed"]
    assert data == ["holecli/schema/record.schema.json"]
    assert '"holecli.schema" = ["*.json"]' in (PACKAGE.parent / "pyproject.toml").read_text()


def test_setup_installs_and_checks_every_extra():
    # scripts/setup.sh makes the development environment: every optional-dependency group of
    # pyproject.toml is installed (so that the readers, holecli plot, the docs' build and holecli serve
    # and the cluster batch are tested), and its check that the environment is complete imports the docs' and the service's
    # packages.
    extras = set(tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    setup = (PACKAGE.parent / "scripts" / "setup.sh").read_text()
    installed = re.search(r"pip install --quiet -e '\.\[([\w,]+)\]'", setup)
    assert installed and set(installed.group(1).split(",")) == extras == {"test", "e57", "las", "plot", "docs", "serve",
                                                                                "postgres", "opcua", "cluster"}
    assert re.search(r"^import .*\bmkdocs, material\b", setup, re.MULTILINE)
    assert re.search(r"^import fastapi, uvicorn, prometheus_client, psycopg, asyncua\b", setup, re.MULTILINE)


def test_setup_installs_the_postgresql_the_store_tests_start():
    # tests/pgserver.py starts a throwaway server of Debian's package; setup.sh installs it when absent
    setup = (PACKAGE.parent / "scripts" / "setup.sh").read_text()
    assert "apt_install postgresql" in setup and "/usr/lib/postgresql/*/bin/initdb" in setup
