"""holecli's modules import each other without a cycle: no module imports one that imports it back
(directly or through others), at module level or inside a function. The graph is read from the source
with ``ast``, so that it holds every import whether or not a test runs it; imports inside functions are
listed apart (they run late and cannot make an import fail, but each is a place where a layer may reach
the wrong way: the cycle between ``cli.detect`` and ``cli.plot`` went through them), and the few that
may close a cycle are named in :data:`LATE_IMPORTS_ALLOWED`, each with its reason.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "holecli"


def module_name(path):
    """``holecli/cli/detect.py`` -> ``holecli.cli.detect``; a package's ``__init__.py`` -> the package."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def resolve(module, node, modules):
    """The holecli modules an import statement of ``module`` names (``from holecli import io`` names the
    submodule ``holecli.io``; ``from holecli.io import read_cloud`` names ``holecli.io``)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        base = node.module or ""
        if node.level:
            package = module.split(".")
            if not (PACKAGE / Path(*package[1:]) / "__init__.py").exists() or module == "holecli":
                package = package[:-1]
            package = package[:len(package) - node.level + 1]
            base = ".".join(package + ([base] if base else []))
        names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
    found = []
    for name in names:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        if name.startswith("holecli") and name != module:
            found.append(name)
    return found


def import_graph():
    """``(module_level, function_level)``: each a dict from a holecli module to the holecli modules it
    imports at module level (including ``if`` and ``try`` blocks at the top), and inside functions."""
    paths = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(path) for path in paths}
    top, inner = {name: set() for name in modules}, {name: set() for name in modules}
    for path in paths:
        module = module_name(path)
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))

        def visit(node, in_function):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.Import, ast.ImportFrom)):
                    (inner if in_function else top)[module].update(resolve(module, child, modules))
                visit(child, in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)))

        visit(tree, False)
    # importing holecli.a.b runs holecli/a/__init__.py first
    for module in modules:
        for imported in list(top[module]):
            parent = imported.rpartition(".")[0]
            while parent:
                if parent != module and not module.startswith(parent + "."):
                    top[module].add(parent)
                parent = parent.rpartition(".")[0]
    return top, inner


def cycles(graph):
    """Every strongly connected set of two or more modules of ``graph`` (Tarjan), sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def connect(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in graph.get(node, ()):
            if other not in index:
                connect(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                other = stack.pop()
                on_stack.discard(other)
                component.append(other)
                if other == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return sorted(found)


def test_the_graph_is_read_from_the_source():
    top, inner = import_graph()
    assert "holecli.pipeline" in top["holecli.measure"] or "holecli.pipeline" in inner["holecli.measure"]
    assert "holecli.cli.exits" in top["holecli.cli.detect"]
    assert "holecli.io" in top["holecli.pipeline"]


def test_the_cycle_finder_finds_a_cycle_through_three_modules():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


# The imports inside functions that may close a cycle, (importer, imported), each with its reason.
LATE_IMPORTS_ALLOWED = {
    # holecli/__init__.py's __getattr__ loads the heavy parts of the library's face (holecli.detect,
    # holecli.measure_scan, ...) on first use, so that ``import holecli`` (and the command line's start)
    # stays cheap; every module that imports from the package at module level (``__version__``, the
    # errors) would otherwise close a cycle with it, and none of them runs that loader.
    ("holecli", "holecli.io"): "the package's lazy attribute loader",
    ("holecli", "holecli.results"): "the package's lazy attribute loader",
    ("holecli", "holecli.pipeline"): "the package's lazy attribute loader",
    ("holecli", "holecli.measure"): "the package's lazy attribute loader",
    # results.py's to_dict() writes holecli's __version__ into each record; the package imports
    # results only in its lazy loader above, so the two never import each other at load time.
    ("holecli.results", "holecli"): "the record's holecli_version",
}


def test_no_module_of_holecli_imports_itself_back():
    top, inner = import_graph()
    late = {module: {imported for imported in inner[module] if (module, imported) not in LATE_IMPORTS_ALLOWED}
            for module in inner}
    assert cycles({module: top[module] | late[module] for module in top}) == []


def test_every_allowed_late_import_is_still_there():
    # an allowance outlives the import it was for: then it would hide the next one
    _, inner = import_graph()
    assert [pair for pair in LATE_IMPORTS_ALLOWED if pair[1] not in inner[pair[0]]] == []


@pytest.mark.parametrize("pair", [("holecli.cli.detect", "holecli.cli.plot")])
def test_detect_and_plot_do_not_import_each_other(pair):
    # they did (detect took plot's drawing, plot took detect's stdin reading), inside functions
    top, inner = import_graph()
    first, second = pair
    assert first not in top[second] | inner[second]


# The modules of the commands other than detect, and the packages behind them.
OTHER_COMMANDS = ("holecli.cli.batch", "holecli.cli.simulate", "holecli.cli.plot", "holecli.cli.register",
                  "holecli.cli.info", "holecli.cli.report", "holecli.cli.serve", "holecli.batch", "holecli.simulation",
                  "holecli.registration", "holecli.serve", "holecli.quality", "holecli.store", "holecli.plot")


def test_detect_imports_no_other_command(modules_imported_by, repo_root):
    # holecli.cli imports a command's module when it runs (a one-shot detect paid for all of them);
    # a global -v looks at the command that runs only
    scan = repo_root / "sample_clouds" / "table1.ply"
    assert modules_imported_by([["detect", scan], ["-v", "detect", scan, "--format", "csv"]], OTHER_COMMANDS) == "[]"
    # the check sees them when they are imported
    assert "holecli.cli.batch" in modules_imported_by([["--help"]], OTHER_COMMANDS)


# What a detect of a PLY without tolerance options or --spec does not need: the tolerance checks (with
# tomllib, which reads a spec), the inspection of --spec, --registration and --name, and the reader of
# text tables and of PCD.
NOT_FOR_A_PLAIN_DETECT = ("holecli.tolerance", "holecli.inspection", "tomllib", "holecli.io.text", "holecli.io.pcd")


def test_a_plain_detect_imports_no_tolerance_module_and_no_other_reader(modules_imported_by, repo_root):
    # a one-shot detect paid about 6 ms for them (the default coverage factor it needs is
    # holecli.vocabulary's); the table's and the CSV's renderers do not import them either
    scan = repo_root / "sample_clouds" / "table1.ply"
    plain = [["detect", scan], ["detect", scan, "--format", "table"], ["detect", scan, "--format", "csv"]]
    assert modules_imported_by(plain, NOT_FOR_A_PLAIN_DETECT) == "[]"
    # the check sees them when a tolerance is given, and when a text table is read
    checked = modules_imported_by([["detect", scan, "--nominal-diameter", "3", "--tolerance", "0.1"]],
                                  NOT_FOR_A_PLAIN_DETECT)
    assert "'holecli.tolerance'" in checked and "'tomllib'" in checked
    table = repo_root / "sample_clouds" / "table1_inside100.csv"
    assert "'holecli.io.text'" in modules_imported_by([["detect", table]], NOT_FOR_A_PLAIN_DETECT)
