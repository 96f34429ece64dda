"""Import architecture of the ``bootnav`` package, read from the source with ``ast`` (nothing is imported).

* no import cycle between modules anywhere in the package;
* acquisition (``bootnav.logger``) and the low-level primitives (``bootnav.core``) never import processing
  (``bootnav.postproc``), and ``bootnav.core`` imports neither ``bootnav.logger`` nor ``bootnav.postproc``.

Every import statement counts, also one inside a function: a deferred import hides a cycle from the
interpreter, not from the design.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import REPO

# installed package name -> source folder (pyproject.toml package-dir)
ROOTS = {"bootnav": REPO / "bootnav", "bootnav.logger": REPO / "logger", "bootnav.postproc": REPO / "postproc",
         "bootnav.simulator": REPO / "simulator"}


def _modules() -> dict[str, Path]:
    """Dotted module name -> file, for every .py file of the package."""
    mods = {}
    for pkg, folder in ROOTS.items():
        for f in folder.rglob("*.py"):
            parts = list(f.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join([pkg, *parts])] = f
    return mods


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the package modules it imports (``from a import b`` counts as ``a.b`` when that is a module)."""

    def owner(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for mod, path in mods.items():
        deps = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
                    base = base[:len(base) - (node.level - 1)]
                    src = ".".join(base + ([node.module] if node.module else []))
                else:
                    src = node.module or ""
                targets = [f"{src}.{a.name}" if f"{src}.{a.name}" in mods else src for a in node.names]
            else:
                continue
            deps.update(t for t in map(owner, targets) if t and t != mod)
        graph[mod] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


@pytest.fixture(scope="module")
def graph():
    return import_graph(_modules())


def test_the_checker_sees_a_cycle_and_a_deferred_import(tmp_path):
    """The graph builder and the cycle finder on a made-up package: a -> b at module level, b -> a inside a
    function (a deferred import), c -> a only."""
    (tmp_path / "a.py").write_text("from pkg import b\n")
    (tmp_path / "b.py").write_text("def f():\n    from .a import x\n")
    (tmp_path / "c.py").write_text("import pkg.a\n")
    mods = {f"pkg.{n}": tmp_path / f"{n}.py" for n in "abc"}
    g = import_graph(mods)
    assert g == {"pkg.a": {"pkg.b"}, "pkg.b": {"pkg.a"}, "pkg.c": {"pkg.a"}}
    assert cycles(g) == [["pkg.a", "pkg.b"]]


def test_graph_covers_the_package(graph):
    assert {"bootnav.cli", "bootnav.postproc.ins.fast", "bootnav.logger.recording"} <= set(graph)
    assert "bootnav.postproc.ins.measurements" in graph["bootnav.postproc.ins.fast"]


def test_no_import_cycle(graph):
    assert cycles(graph) == []


@pytest.mark.parametrize("layer, forbidden", [
    ("bootnav.logger", ("bootnav.postproc",)),
    ("bootnav.core", ("bootnav.postproc", "bootnav.logger")),
])
def test_layers_import_downwards_only(graph, layer, forbidden):
    bad = sorted((m, d) for m, deps in graph.items() if m == layer or m.startswith(layer + ".")
                 for d in deps if d.startswith(forbidden))
    assert bad == []
