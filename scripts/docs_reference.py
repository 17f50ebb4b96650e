"""The docs' generated reference: every command's ``--help``, and the record's fields from its JSON Schema.

Used as an MkDocs hook (``hooks:`` in ``mkdocs.yml``): a page line that is exactly one of the markers

    <!-- generated: cli-reference -->
    <!-- generated: record-fields -->

is replaced, when the site is built, by the Markdown that :func:`cli_reference` or :func:`record_fields`
returns. The reference is therefore made from the checkout's code at every build and cannot be stale;
nothing generated is committed. Run as a script, it prints the generated Markdown:

    python scripts/docs_reference.py cli-reference
    python scripts/docs_reference.py record-fields
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))  # this checkout's holecli, whatever the Python running mkdocs has installed

MARKER = re.compile(r"^<!-- generated: ([\w-]+) -->$", re.MULTILINE)
HELP_WIDTH = 100


def _commands(group, path=()):
    """Every command under ``group`` as (its words, the command), the group first, depth first."""
    import click

    yield path, group
    if isinstance(group, click.Group):
        context = click.Context(group, info_name=" ".join(("holecli", *path)))
        for name in group.list_commands(context):
            yield from _commands(group.get_command(context, name), (*path, name))


def help_text(path):
    """What ``holecli PATH... --help`` prints, at :data:`HELP_WIDTH` columns (the command itself is run)."""
    from click.testing import CliRunner

    from holecli.cli import main

    result = CliRunner().invoke(main, [*path, "--help"], prog_name="holecli", terminal_width=HELP_WIDTH)
    if result.exit_code != 0:
        raise RuntimeError(f"holecli {' '.join(path)} --help exited {result.exit_code}: {result.output}")
    return result.stdout


def cli_reference():
    """Markdown: a section per command (``holecli``, ``holecli detect``, ...) holding its ``--help``."""
    from holecli.cli import main

    sections = []
    for path, _ in _commands(main):
        title = " ".join(("holecli", *path))
        sections.append(f"## `{title}`\n\n```text\n{help_text(path).rstrip()}\n```\n")
    return "\n".join(sections)


def _type(schema, defs):
    """A field's type in words, with links to the definitions it refers to."""
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return f"[{name}](#{name})"
    if "anyOf" in schema or "oneOf" in schema:
        return " or ".join(_type(part, defs) for part in schema.get("anyOf", schema.get("oneOf")))
    if "const" in schema:
        return f"`{json.dumps(schema['const'])}`"
    kinds = schema.get("type", "any")
    kinds = kinds if isinstance(kinds, list) else [kinds]
    words = []
    for kind in kinds:
        if kind == "array" and "items" in schema:
            size = schema.get("minItems")
            count = f"{size} " if size is not None and size == schema.get("maxItems") else ""
            words.append(f"array of {count}{_type(schema['items'], defs)}")
        else:
            words.append(kind)
    text = " or ".join(words)
    if "enum" in schema:
        text += ": " + ", ".join(f"`{value}`" if value is not None else "`null`" for value in schema["enum"])
    return text


def _cell(text):
    return str(text).replace("|", "\\|").replace("\n", " ")


def record_fields():
    """Markdown: a table per definition of ``holecli/schema/record.schema.json`` (field, type, required, meaning)."""
    from holecli.results import SCHEMA_VERSION
    from holecli.schema import record_schema

    schema = record_schema()
    defs = schema["$defs"]
    parts = [f"Schema version {SCHEMA_VERSION}. {_cell(schema['description'])}\n",
             "A record is " + " or ".join(_type(part, defs) for part in schema["anyOf"]) + ".\n"]
    for name, definition in defs.items():
        parts.append(f"## {name}\n")
        if "description" in definition:
            parts.append(_cell(definition["description"]) + "\n")
        properties = definition.get("properties")
        if not properties:
            parts.append(f"Type: {_type(definition, defs)}.\n")
            continue
        required = set(definition.get("required", ()))
        rows = ["| field | type | required | meaning |", "|---|---|---|---|"]
        for field, field_schema in properties.items():
            rows.append(f"| `{field}` | {_cell(_type(field_schema, defs))} | {'yes' if field in required else 'no'} "
                        f"| {_cell(field_schema.get('description', ''))} |")
        parts.append("\n".join(rows) + "\n")
        if definition.get("additionalProperties") is False:
            parts.append("No other field.\n")
    return "\n".join(parts)


GENERATORS = {"cli-reference": cli_reference, "record-fields": record_fields}


def expand(markdown):
    """``markdown`` with each generated-content marker replaced by what it stands for."""
    def generated(match):
        if match[1] not in GENERATORS:
            raise ValueError(f"unknown generated block {match[1]!r} (known: {', '.join(GENERATORS)})")
        return GENERATORS[match[1]]()
    return MARKER.sub(generated, markdown)


def on_page_markdown(markdown, page, config, files):
    """The MkDocs hook: a page's Markdown with its generated blocks filled in."""
    return expand(markdown)


if __name__ == "__main__":
    if len(sys.argv) != 2 or sys.argv[1] not in GENERATORS:
        sys.exit(f"usage: python scripts/docs_reference.py {{{'|'.join(GENERATORS)}}}")
    sys.stdout.write(GENERATORS[sys.argv[1]]())
