"""The import layering (docs/ARCHITECTURE.md, "Layers"), checked on the source text of every module.

Every ``import`` and ``from ... import`` of the packages, at module level and inside functions alike, is an
edge of one graph. The test fails on

- a cycle (a function-local import does not make a circle acceptable),
- a layer violation: the foundation imports nothing above it; ``methods`` and ``references`` stand on the
  foundation and never import each other; ``harness`` and ``reports`` stand on all three,
- a private name (leading underscore) used outside its module, imported (``from m import _x``) or read
  through an imported module (``m._x``),
- an absolute import of a package of the tree under a name that is not its installed name (once the tree
  is installed as ``ldbench.*``, ``import harness`` finds nothing).

The packages and their installed names come from the tree itself: every top-level folder with an
``__init__.py`` is a package; ``pyproject.toml``'s ``[tool.setuptools.package-dir]`` maps them under one
import name (``ldbench.harness`` <- ``harness/``) when it says so. Before the foundation has a folder of its
own, :data:`MOVING` names the files that form it (the same list the move uses).
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from layout import PACKAGE, ROOT, import_prefix, packages

#: The layer of each top-level folder (its modules may import their own layer, without cycles, or lower ones).
FOLDER_LAYER = {"core": "foundation", "methods": "methods", "references": "references", "harness": "harness",
                "reports": "reports"}
#: Files and folders of the layer they will move to while they still lie elsewhere (a path ending in "/"
#: is a folder); once moved, their folder says it.
MOVING = {
    "foundation": ("core/errors.py", "core/params.py", "core/conventions.py", "core/bindings.py",
                   "core/gpu.py",
                   "core/egl.py", "core/device.py", "core/scene.py", "core/meshio.py",
                   "core/scenes/", "core/scene_registry.py", "core/mitsuba_xml.py",
                   "core/metrics.py", "core/imageio.py", "core/plugins.py", "core/effects/",
                   "core/exr.py"),
    "reports": ("reports/report.py", "reports/figures/", "reports/reproduce.py", "reports/history_plots.py",
                "reports/reproductions/"),
}

#: Names that will move out of a module into the foundation ({file: names}): the validated-parameter
#: declaration of ldbench/methods/base.py (param, group, ParamsBase), which the effects declare their parameters
#: with. An import of only these names counts as an import of the foundation.
MOVING_NAMES = {"methods/base.py": ("param", "group", "ParamsBase")}

#: Import circles another change is dissolving (the layered structures merging into ldbench/methods/structures/):
#: a circle among these modules only is tolerated; delete the entry once they are gone.
PENDING_CYCLES: tuple = ()

#: layer rank: a module may import its own layer (without cycles) or lower ones, never a higher one.
RANK = {"foundation": 0, "methods": 1, "references": 1, "harness": 2, "reports": 2}
#: layers of one rank that must not import each other.
APART = {frozenset({"methods", "references"})}


def modules() -> dict[str, Path]:
    """{folder-dotted name: path} of every module of the packages (a package is its __init__)."""
    out = {}
    for pkg in packages():
        for f in (PACKAGE / pkg).rglob("*.py"):
            if "__pycache__" in f.parts:
                continue
            parts = list(f.relative_to(PACKAGE).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = f
    return out


def layer(path: Path) -> str:
    rel = path.relative_to(PACKAGE).as_posix()
    for name, group in MOVING.items():
        if any(rel == m or (m.endswith("/") and rel.startswith(m)) for m in group):
            return name
    return FOLDER_LAYER.get(rel.split("/")[0], rel.split("/")[0])


class Graph:
    """Import edges between the modules of the tree, the private names crossing modules, bad names."""

    def __init__(self):
        self.mods = modules()
        self.prefix = import_prefix()
        self.pkgs = set(packages())
        self.edges: dict[str, dict[str, int]] = {}
        self.private: list[str] = []
        self.misnamed: list[str] = []
        self.unresolved: list[str] = []
        for mod, path in self.mods.items():
            self._scan(mod, path)

    def _local(self, name: str, where: str) -> str | None:
        """The tree's module an absolute import name refers to (None: outside the tree)."""
        if self.prefix and name.startswith(self.prefix):
            name = name[len(self.prefix):]
        elif name.split(".")[0] in self.pkgs:
            if self.prefix:
                self.misnamed.append(f"{where}: import {name} (installed as {self.prefix}{name})")
        elif self.prefix and name == self.prefix[:-1]:
            return None
        else:
            return None
        if name not in self.mods:
            self.unresolved.append(f"{where}: import {name}: no such module")
        while name and name not in self.mods:
            name = name.rpartition(".")[0]
        return name or None

    def _scan(self, mod: str, path: Path):
        tree = ast.parse(path.read_text(), str(path))
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        aliases = {}  # local name -> module of the tree bound to it
        for node in ast.walk(tree):
            where = f"{path.relative_to(ROOT)}:{getattr(node, 'lineno', 0)}"
            if isinstance(node, ast.Import):
                for a in node.names:
                    target = self._local(a.name, where)
                    if target:
                        self._edge(mod, target, node.lineno)
                        if a.asname:
                            aliases[a.asname] = target
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                    absolute = ".".join(base + ([node.module] if node.module else []))
                    source = self._relative(absolute)
                else:
                    source = self._local(node.module, where)
                if not source:
                    continue
                moving = MOVING_NAMES.get(self.mods[source].relative_to(PACKAGE).as_posix(), ())
                for a in node.names:
                    sub = f"{source}.{a.name}"
                    if sub in self.mods:  # from pkg import module
                        self._edge(mod, sub, node.lineno)
                        aliases[a.asname or a.name] = sub
                        continue
                    if a.name in moving:  # counted as the foundation module it will be
                        self._edge(mod, f"{source}:{a.name}", node.lineno)
                        continue
                    self._edge(mod, source, node.lineno)
                    if _private(a.name) and source != mod:
                        self.private.append(f"{where}: from {source} import {a.name}")
            elif (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
                  and isinstance(node.args[0].value, str) and _dynamic_import(node.func)):
                target = self._local(node.args[0].value, where)  # importlib.import_module("pkg.mod")
                if target:
                    self._edge(mod, target, node.lineno)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in aliases and _private(node.attr) and aliases[node.value.id] != mod):
                self.private.append(f"{path.relative_to(ROOT)}:{node.lineno}: "
                                    f"{aliases[node.value.id]}.{node.attr}")

    def _relative(self, name: str) -> str | None:
        while name and name not in self.mods:
            name = name.rpartition(".")[0]
        return name or None

    def _edge(self, a: str, b: str, line: int):
        if a != b:
            self.edges.setdefault(a, {}).setdefault(b, line)

    def cycles(self) -> list[list[str]]:
        """Strongly connected components of more than one module (Tarjan, iterative)."""
        index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
        for root in sorted(self.mods):
            if root in index:
                continue
            work = [(root, iter(sorted(self.edges.get(root, {}))))]
            index[root] = low[root] = counter[0]
            counter[0] += 1
            stack.append(root)
            on.add(root)
            while work:
                v, it = work[-1]
                for w in it:
                    if w not in index:
                        index[w] = low[w] = counter[0]
                        counter[0] += 1
                        stack.append(w)
                        on.add(w)
                        work.append((w, iter(sorted(self.edges.get(w, {})))))
                        break
                    if w in on:
                        low[v] = min(low[v], index[w])
                else:
                    work.pop()
                    if work:
                        low[work[-1][0]] = min(low[work[-1][0]], low[v])
                    if low[v] == index[v]:
                        comp = []
                        while True:
                            w = stack.pop()
                            on.discard(w)
                            comp.append(w)
                            if w == v:
                                break
                        if len(comp) > 1:
                            out.append(sorted(comp))
        return out

    def describe(self, comp: list[str]) -> str:
        inside = set(comp)
        return "; ".join(f"{a} -> {b} (line {line})" for a in comp
                         for b, line in sorted(self.edges.get(a, {}).items()) if b in inside)

    def layer_of(self, mod: str) -> str:
        return "foundation" if ":" in mod else layer(self.mods[mod])

    def violations(self) -> list[str]:
        out = []
        for a, targets in sorted(self.edges.items()):
            la = self.layer_of(a)
            for b, line in sorted(targets.items()):
                lb = self.layer_of(b)
                if la == lb:
                    continue
                if RANK[la] < RANK[lb] or frozenset({la, lb}) in APART:
                    out.append(f"{a} ({la}) imports {b} ({lb}), line {line}")
        return out


def _dynamic_import(func) -> bool:
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    return name in ("import_module", "__import__")


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


@pytest.fixture(scope="module")
def graph():
    return Graph()


def test_the_tree_is_found(graph):
    assert {"harness", "methods", "references"} <= graph.pkgs
    assert len(graph.mods) > 50 and graph.edges
    layers = {layer(p) for p in graph.mods.values()}
    assert layers <= set(RANK), sorted(layers - set(RANK))


def test_no_import_cycles(graph):
    rel = lambda c: {graph.mods[m].relative_to(PACKAGE).as_posix() for m in c}  # noqa: E731
    cycles = [c for c in graph.cycles() if not any(rel(c) <= p for p in PENDING_CYCLES)]
    assert not cycles, "import cycles:\n" + "\n".join(graph.describe(c) for c in cycles)


def test_layers_import_downwards(graph):
    bad = graph.violations()
    assert not bad, "layer violations:\n" + "\n".join(bad)


def test_no_private_name_crosses_modules(graph):
    assert not graph.private, "private names used outside their module:\n" + "\n".join(graph.private)


def test_imports_use_the_installed_name(graph):
    assert not graph.misnamed, "\n".join(graph.misnamed)


def test_imports_name_modules_that_exist(graph):
    assert not graph.unresolved, "\n".join(graph.unresolved)


if __name__ == "__main__":  # python tests/test_imports.py: the whole list at once
    g = Graph()
    for c in g.cycles():
        print("CYCLE", g.describe(c))
    for v in g.violations():
        print("LAYER", v)
    for p in g.private:
        print("PRIVATE", p)
    for m in g.misnamed:
        print("NAME", m)
    for m in g.unresolved:
        print("MISSING", m)
