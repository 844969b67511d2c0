"""The import graph of src/predgait keeps one direction of layers (docs/DEVELOPING.md).

Every ``import`` and ``from ... import`` of a predgait module, at module level or inside
a function (``if TYPE_CHECKING:`` blocks excepted: they are never run), is an edge
from the importing module's package to the imported one's. A package may import only
itself, the packages before it in :data:`LAYERS` and the shared top-level modules
(:data:`SHARED`); the shared modules import only each other. The order is written here
once; the "Architecture as built" table of docs/DEVELOPING.md lists the same packages in
the same order (checked below).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "predgait"
DEVELOPING = Path(__file__).resolve().parents[1] / "docs" / "DEVELOPING.md"

#: Packages of predgait, lowest first: each imports only from those before it.
LAYERS = ("numerics", "models", "data", "kinematics", "dynamics", "analysis", "problems",
          "simulations", "scenarios", "report", "workflows", "cli")
#: Top-level modules every layer may import (``predgait`` itself: ``__version__``).
SHARED = ("predgait", "errors", "textfile", "problemfile", "function_cache", "cache_library",
          "blas_threads", "datasets")
#: Top-level modules that sit above every layer.
TOP = ("__main__",)


def _module_name(path: Path, root: Path) -> tuple[str, bool]:
    """(dotted module name, is a package __init__) of ``path`` under ``root``'s parent."""
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        return ".".join(parts[:-1]), True
    return ".".join(parts), False


def _runtime_nodes(tree: ast.AST):
    """Every node of ``tree`` outside ``if TYPE_CHECKING:`` blocks."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                stack.extend(child.orelse)
                continue
            stack.append(child)


def imports_of(source: str, module: str, is_package: bool) -> list[tuple[str, int]]:
    """(imported predgait module, line) of every runtime import in ``source``."""
    found = []
    for node in _runtime_nodes(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            # target.name is a module or a name in target: import_graph resolves which
            found += [(f"{target}.{alias.name}", node.lineno) for alias in node.names]
    return sorted((name, line) for name, line in found if name.split(".")[0] == "predgait")


def import_graph(root: Path = SRC) -> dict[str, list[tuple[str, int]]]:
    """module -> [(imported predgait module, line)] over every .py file under ``root``."""
    graph = {}
    for path in sorted(root.rglob("*.py")):
        module, is_package = _module_name(path, root)
        graph[module] = imports_of(path.read_text(encoding="utf-8"), module, is_package)
    return {module: sorted(set((_resolve(name, graph), line) for name, line in edges),
                           key=lambda edge: edge[1]) for module, edges in graph.items()}


def _resolve(name: str, modules) -> str:
    """The longest prefix of ``name`` that is a module (``from a import b``: a.b or a)."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        if ".".join(parts[:end]) in modules:
            return ".".join(parts[:end])
    return name


def layer_of(module: str) -> str:
    """The package (or shared top-level module) that ``module`` belongs to."""
    parts = module.split(".")
    return "predgait" if len(parts) == 1 else parts[1]


def rank(layer: str, layers=LAYERS) -> int:
    """Position of ``layer``: shared modules -1, the packages 0.., the top modules last."""
    if layer in SHARED:
        return -1
    if layer in TOP:
        return len(layers)
    return layers.index(layer)


def violations(graph: dict[str, list[tuple[str, int]]], layers=LAYERS) -> list[str]:
    """Imports of a later layer (and of packages missing from ``layers``), one line each."""
    out = []
    known = set(layers) | set(SHARED) | set(TOP)
    for module, edges in sorted(graph.items()):
        here = layer_of(module)
        if here not in known:
            out.append(f"{module}: package {here!r} is not in LAYERS (add it to the order)")
            continue
        for target, line in edges:
            there = layer_of(target)
            if there not in known:
                out.append(f"{module}:{line} imports {target}: {there!r} is not in LAYERS")
            elif rank(there, layers) > rank(here, layers) and there != here:
                out.append(f"{module}:{line} imports {target} ({there} is above {here})")
    return out


def test_no_module_imports_a_layer_above_its_own():
    graph = import_graph()
    assert len(graph) > 100  # the whole package was read
    assert violations(graph) == []


def test_the_checker_catches_an_upward_import_at_module_and_function_level(tmp_path):
    """A synthetic tree: data importing problems (module level) and dynamics importing
    workflows (inside a function) are both reported; a type-only import is not."""
    pkg = tmp_path / "predgait"
    for sub in ("data", "dynamics", "problems", "workflows"):
        (pkg / sub).mkdir(parents=True)
        (pkg / sub / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("__version__ = '0'\n")
    (pkg / "errors.py").write_text("")
    (pkg / "data" / "reader.py").write_text(
        "from predgait.errors import InputError\nfrom predgait.problems import fit\n")
    (pkg / "dynamics" / "engine.py").write_text(
        "from typing import TYPE_CHECKING\nfrom ..data import reader\n"
        "if TYPE_CHECKING:\n    from predgait.problems.fit import Fit\n"
        "def run():\n    import predgait.workflows.glue as glue\n    return glue\n")
    (pkg / "problems" / "fit.py").write_text("from . import other\nfrom predgait import data\n")
    (pkg / "problems" / "other.py").write_text("from predgait import __version__\n")
    (pkg / "workflows" / "glue.py").write_text("from predgait.dynamics.engine import run\n")
    graph = import_graph(pkg)
    assert graph["predgait.problems.fit"] == [("predgait.problems.other", 1),
                                              ("predgait.data", 2)]
    assert graph["predgait.dynamics.engine"] == [("predgait.data.reader", 2),
                                                 ("predgait.workflows.glue", 6)]
    assert graph["predgait.problems.other"] == [("predgait", 1)]
    found = violations(graph)
    assert found == [
        "predgait.data.reader:2 imports predgait.problems.fit (problems is above data)",
        "predgait.dynamics.engine:6 imports predgait.workflows.glue "
        "(workflows is above dynamics)"]
    # the same graph under another order: a package missing from it is reported
    assert violations(graph, ("data", "dynamics", "workflows"))[0] == (
        "predgait.data.reader:2 imports predgait.problems.fit: 'problems' is not in LAYERS")


def test_a_planted_upward_import_in_the_real_graph_fails():
    graph = import_graph()
    graph["predgait.data.filters"] = [*graph["predgait.data.filters"],
                                      ("predgait.simulations.rod", 999)]
    assert violations(graph) == ["predgait.data.filters:999 imports predgait.simulations.rod "
                                 "(simulations is above data)"]


def test_no_import_circle_between_modules():
    """No module reaches itself through imports (runtime ones, function level included)."""
    edges_of = import_graph()
    graph = {m: {t for t, _ in edges if t in edges_of and t != m} for m, edges in edges_of.items()}
    state, circles = {}, []

    def visit(module, path):
        state[module] = 1
        for target in sorted(graph.get(module, ())):
            if state.get(target) == 1:
                circles.append(" -> ".join([*path[path.index(target):], target]))
            elif target not in state:
                visit(target, [*path, target])
        state[module] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    assert circles == []


def test_developing_names_the_same_order():
    """The "Architecture as built" table of docs/DEVELOPING.md lists LAYERS in order."""
    text = DEVELOPING.read_text(encoding="utf-8")
    section = text.split("### Architecture as built", 1)[1]
    table = [line for line in section.splitlines() if line.startswith("| `")]
    names = tuple(re.match(r"\| `(\w+)`", line).group(1) for line in table)
    assert names == LAYERS
    assert "tests/test_layers.py" in section


@pytest.mark.parametrize("layer", LAYERS)
def test_every_layer_is_a_package(layer):
    assert (SRC / layer / "__init__.py").is_file()
