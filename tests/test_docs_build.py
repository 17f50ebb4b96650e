"""The docs site: ``mkdocs build --strict`` passes without a warning, and its generated reference holds
every command's ``--help`` (scripts/docs_reference.py, an MkDocs hook) and every field of the record's
JSON Schema, made from this checkout at each build."""

import html
import importlib.util
import os
import re
import subprocess
import sys

import click
import pytest

from holecli.cli import main
from holecli.schema import record_schema
from tests.conftest import REPO_ROOT


def _reference_module():
    spec = importlib.util.spec_from_file_location("docs_reference", REPO_ROOT / "scripts" / "docs_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built with ``mkdocs build --strict`` into a temporary folder, and what the build said."""
    folder = tmp_path_factory.mktemp("site")
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT), NO_MKDOCS_2_WARNING="1")
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(folder)],
                          cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=300)
    return folder, done


def _text(page):
    """A built page's text, tags removed and entities decoded."""
    return html.unescape(re.sub(r"<[^>]+>", "", page.read_text(encoding="utf-8")))


def test_the_site_builds_with_warnings_as_errors(site):
    _, done = site
    assert done.returncode == 0, done.stdout + done.stderr
    assert "WARNING" not in done.stderr and "WARNING" not in done.stdout, done.stderr


def test_every_page_of_the_docs_is_in_the_navigation_and_built(site):
    folder, _ = site
    pages = sorted(path.relative_to(REPO_ROOT / "docs").with_suffix("") for path in (REPO_ROOT / "docs").rglob("*.md"))
    built = [folder / ("index.html" if page.name == "index" and page.parent == page.parent.parent else
                       f"{page}/index.html") for page in pages]
    assert len(pages) > 20 and all(path.exists() for path in built), [str(p) for p in built if not p.exists()]
    navigation = (REPO_ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert [str(page) for page in pages if f"{page}.md" not in navigation] == []


def test_the_cli_reference_holds_every_command_and_option(site):
    folder, _ = site
    text = _text(folder / "reference" / "cli" / "index.html")
    reference = _reference_module()
    commands = list(reference._commands(main))
    assert {" ".join(path) for path, _ in commands} >= {"", "detect", "batch", "register", "simulate", "plot", "info"}
    for path, command in commands:
        assert f"Usage: holecli {' '.join(path)}".replace("  ", " ") in text, path
        for parameter in command.params:
            if isinstance(parameter, click.Option) and not parameter.hidden:
                for name in parameter.opts:
                    assert re.search(rf"(^|[\s,]){re.escape(name)}\b", text, re.MULTILINE), (path, name)


def test_the_cli_reference_is_what_each_command_s_help_prints(site):
    folder, _ = site
    text = _text(folder / "reference" / "cli" / "index.html")
    reference = _reference_module()
    for path, _ in reference._commands(main):
        printed = reference.help_text(path)
        assert printed.strip() in text, f"holecli {' '.join(path)} --help is not in the built reference"


def test_the_record_fields_page_holds_every_field_of_the_schema(site):
    folder, _ = site
    text = _text(folder / "reference" / "record" / "index.html")
    schema = record_schema()
    for name, definition in schema["$defs"].items():
        assert re.search(rf"^{re.escape(name)}¶?$", text, re.MULTILINE), name
        for field, field_schema in definition.get("properties", {}).items():
            assert field in text, (name, field)
            for value in field_schema.get("enum", ()):
                assert value is None or str(value) in text, (name, field, value)


def test_an_unknown_generated_block_is_an_error():
    reference = _reference_module()
    assert reference.expand("a\n<!-- generated: record-fields -->\n").startswith("a\nSchema version ")
    with pytest.raises(ValueError, match="unknown generated block 'nothing'"):
        reference.expand("<!-- generated: nothing -->")
