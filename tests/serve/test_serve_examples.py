"""The service's client examples: the README shows the very client the docs' examples run
(docs/examples/serve_client.py, run against a real service by tests/test_readme_examples.py)."""

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_the_readme_client_is_the_example_the_docs_run():
    example = (REPO / "docs" / "examples" / "serve_client.py").read_text()
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("## Serving a cell"):readme.index("## Documentation")]
    shown = re.search(r"```python\n(.*?)```", section, re.DOTALL).group(1)
    assert shown == example[example.index("import sys"):]
    assert len([line for line in shown.splitlines() if line and not line.startswith(("import", "from"))]) <= 15


def test_the_guide_includes_each_example_file_that_a_block_runs():
    guide = (REPO / "docs" / "guide" / "serve.md").read_text()
    for name in ("serve_client.py", "line_client.py", "opcua_client.py"):
        assert f'--8<-- "{name}"' in guide and f"python docs/examples/{name}" in guide
