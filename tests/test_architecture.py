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


def private_imports(mods: dict[str, Path]) -> list[str]:
    """``module: imported thing`` for every import of another module's private name (``from a import _x``) and
    of a private module (``a._m``) from outside the package that holds it. A name with a leading underscore
    is its module's own business: what another module needs is public, under a name that says what it is."""
    bad = []
    for mod, path in mods.items():
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                    src = ".".join(base + ([node.module] if node.module else []))
                else:
                    src = node.module or ""
                targets = [(src, a.name) for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [(a.name, None) for a in node.names]
            else:
                continue
            for src, name in targets:
                full = f"{src}.{name}" if name and f"{src}.{name}" in mods else src
                if name and full == src and name.startswith("_") and not name.startswith("__") and src != mod:
                    bad.append(f"{mod}: {src}.{name}")
                parts = full.split(".")
                for i, part in enumerate(parts):
                    if part.startswith("_") and not part.startswith("__"):
                        owner = ".".join(parts[:i])
                        if package != owner:
                            bad.append(f"{mod}: {full} (a private module of {owner})")
                        break
    return sorted(set(bad))


def test_the_private_import_checker_sees_both_kinds(tmp_path):
    (tmp_path / "a.py").write_text("from pkg.b import _x, y\nfrom pkg.sub._m import z\n")
    (tmp_path / "b.py").write_text("def _x(): pass\ny = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "__init__.py").write_text("")
    (tmp_path / "sub" / "_m.py").write_text("z = 1\n")
    (tmp_path / "sub" / "c.py").write_text("from ._m import z\nfrom . import _m\n")  # siblings may
    mods = {"pkg.a": tmp_path / "a.py", "pkg.b": tmp_path / "b.py", "pkg.sub": tmp_path / "sub" / "__init__.py",
            "pkg.sub._m": tmp_path / "sub" / "_m.py", "pkg.sub.c": tmp_path / "sub" / "c.py"}
    assert private_imports(mods) == ["pkg.a: pkg.b._x", "pkg.a: pkg.sub._m (a private module of pkg.sub)"]


def test_no_module_imports_another_modules_private_names():
    assert private_imports(_modules()) == []


def test_no_cycle_between_subpackages(graph):
    """pdr and evaluate (and every other pair of subpackages) depend one way."""
    def pkg(m: str) -> str:
        parts = m.split(".")
        return ".".join(parts[:3]) if parts[:2] == ["bootnav", "postproc"] and len(parts) > 3 else m

    packages: dict[str, set[str]] = {}
    for m, deps in graph.items():
        packages.setdefault(pkg(m), set()).update(pkg(d) for d in deps if pkg(d) != pkg(m))
    for p in list(packages):
        for d in packages[p]:
            packages.setdefault(d, set())
    assert [c for c in cycles(packages) if any(len(x.split(".")) == 3 for x in c)] == []


def test_core_is_the_ground_floor(graph):
    """``bootnav.core`` (errors, arrays, progress, registry, ...) imports only itself."""
    bad = sorted((m, d) for m, deps in graph.items() if m.startswith("bootnav.core")
                 for d in deps if not d.startswith("bootnav.core"))
    assert bad == []


def private_attribute_uses(mods: dict[str, Path]) -> list[str]:
    """``module: used name`` for every ``m._name`` where ``m`` is another package module bound by an import
    (``from pkg import m``, ``import pkg.m as m``, ``from . import m``): the attribute form of a private import."""
    bad = []
    for mod, path in mods.items():
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        bound = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in mods:
                        bound[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                    src = ".".join(base + ([node.module] if node.module else []))
                else:
                    src = node.module or ""
                bound.update((a.asname or a.name, f"{src}.{a.name}") for a in node.names if f"{src}.{a.name}" in mods)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
                chain, v = [], node.value
                while isinstance(v, ast.Attribute):
                    chain.append(v.attr)
                    v = v.value
                if isinstance(v, ast.Name) and v.id in bound:
                    target = ".".join([bound[v.id], *reversed(chain)])
                    if target != mod:
                        bad.append(f"{mod}: {target}.{node.attr}")
    return sorted(set(bad))


def test_the_private_attribute_checker_sees_module_attributes(tmp_path):
    (tmp_path / "a.py").write_text("from pkg import b\nimport pkg.b as bb\nx = b._y + bb._z + b.w\n")
    (tmp_path / "b.py").write_text("_y = _z = w = 1\nimport pkg.b as me\nq = me._y\n")
    mods = {"pkg.a": tmp_path / "a.py", "pkg.b": tmp_path / "b.py"}
    assert private_attribute_uses(mods) == ["pkg.a: pkg.b._y", "pkg.a: pkg.b._z"]


#: Known exceptions (none left: ``pipeline`` reads ``StreamStance.noise_floor_log10``).
KNOWN_PRIVATE_ATTRIBUTE_USES: set[str] = set()


def test_no_module_reads_another_modules_private_attributes():
    assert sorted(set(private_attribute_uses(_modules())) - KNOWN_PRIVATE_ATTRIBUTE_USES) == []


def private_member_uses(mods: dict[str, Path]) -> list[str]:
    """``module: .name (defined in ...)`` for every ``x._name`` (``x`` not ``self``/``cls``) whose ``_name`` this
    module neither defines nor assigns but another module does (a ``def _name`` or an ``obj._name = ...``): an
    object's private method or attribute used from outside its class's module, e.g. ``det._classify``."""
    trees = {m: ast.parse(p.read_text(encoding="utf-8"), filename=str(p)) for m, p in mods.items()}
    own = {}
    for m, tree in trees.items():
        own[m] = {n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
                  and n.name.startswith("_") and not n.name.startswith("__")}
        own[m] |= {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Store)
                   and n.attr.startswith("_")}
    where: dict[str, set[str]] = {}
    for m, names in own.items():
        for name in names:
            where.setdefault(name, set()).add(m)
    bad = []
    for m, tree in trees.items():
        for n in ast.walk(tree):
            if (isinstance(n, ast.Attribute) and n.attr.startswith("_") and not n.attr.startswith("__")
                    and not (isinstance(n.value, ast.Name) and n.value.id in ("self", "cls"))
                    and n.attr not in own[m] and n.attr in where):
                bad.append(f"{m}: .{n.attr} (defined in {', '.join(sorted(where[n.attr]))})")
    return sorted(set(bad))


def test_the_private_member_checker_sees_a_private_method_used_from_outside(tmp_path):
    (tmp_path / "a.py").write_text("class D:\n    def _f(self):\n        return self._g\n    def h(self):\n"
                                   "        self._g = 1\n")
    (tmp_path / "b.py").write_text("def use(d, e):\n    e._own = 2\n    return d._f() + e._own\n")
    mods = {"pkg.a": tmp_path / "a.py", "pkg.b": tmp_path / "b.py"}
    assert private_member_uses(mods) == ["pkg.b: ._f (defined in pkg.a)"]


#: Known, owned elsewhere: ``ins.fast``'s warm-up reads a ``StreamNavigator``'s private state (helper owning
#: ``ins/fast.py``); ``bootnav.cli`` closes h5py object ids through h5py's own ``_close`` (the name is h5py's,
#: not ``pipeline``'s).
KNOWN_PRIVATE_MEMBER_USES = {*(f"bootnav.postproc.ins.fast: .{a}" for a in ("_P", "_active", "_bufs", "_ric", "_st")),
                             "bootnav.cli: ._close"}


def test_no_module_uses_another_classes_private_members():
    found = private_member_uses(_modules())
    assert [u for u in found if u.split(" (")[0] not in KNOWN_PRIVATE_MEMBER_USES] == []


def test_in_the_logger_only_the_recording_module_opens_recordings():
    """``bootnav.logger.recording`` is the one reader and writer of the HDF5 layout: no other logger module opens
    an HDF5 file (``h5py.File``) or indexes the layout's groups (``["imu"]``, ``"imu/acc"``, ``["meta"]``,
    ``"boots/..."``; ``["events"]`` is also a key of info's own summary, not checked); ``bootnav info`` reads through ``RecordingReader``, the recorder rewrites
    times and scale factors through ``recording.retime_boots`` / ``set_scale_factors``."""
    bad = []
    for mod, path in _modules().items():
        if not mod.startswith("bootnav.logger") or mod == "bootnav.logger.recording":
            continue
        for n in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(n, ast.Attribute) and n.attr == "File" and isinstance(n.value, ast.Name) \
                    and n.value.id == "h5py":
                bad.append(f"{mod}: h5py.File (line {n.lineno})")
            if isinstance(n, ast.Subscript):
                key = n.slice
                parts = [key] if isinstance(key, ast.Constant) else \
                    [v for v in key.values if isinstance(v, ast.Constant)] if isinstance(key, ast.JoinedStr) else []
                for c in parts:
                    text = c.value if isinstance(c.value, str) else ""
                    if text in ("imu", "meta") or text.startswith(("imu/", "boots/")) \
                            or text.endswith(("imu/acc", "imu/gyro", "imu/t_s")):
                        bad.append(f"{mod}: [{text!r}] (line {n.lineno})")
    assert bad == []
