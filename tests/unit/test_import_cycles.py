"""No import cycles in ``src/parolkit``: the import graph is built statically and every cycle
found is listed, each import with its file, line and kind.

The rules of the graph:

* Nodes are the modules of the package (a package is its ``__init__``).
* Every import statement counts, wherever it is: at module level, inside a function (a lazy
  import is still a dependency) and under ``if TYPE_CHECKING:`` (a type-only import still
  ties the two modules together).  ``importlib.import_module("parolkit....")`` with a literal
  name counts too; a name computed at run time cannot be seen.
* ``import a.b`` and ``from a.b import c`` are an edge to ``a.b``, or to ``a.b.c`` when ``c``
  is a submodule.  The parent packages that Python initialises on the way (``a``) are NOT
  edges: so a package ``__init__`` that imports its own submodules (``motion/__init__`` ->
  ``motion.planner``) is not a cycle with every submodule of that package.  A submodule that
  imports a NAME from its own package's ``__init__`` while that ``__init__`` imports it is an
  edge both ways and therefore a cycle (it works only by import order).

Known cycles are listed in :data:`KNOWN_CYCLES` with the reason they are still there; the test
fails on any other cycle, and on a known one that is gone (then delete its entry).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import parolkit

SRC = Path(parolkit.__file__).resolve().parent.parent

#: Cycles that exist today, as the set of their modules, with the reason.
KNOWN_CYCLES: dict[frozenset[str], str] = {}


@dataclass(frozen=True)
class Edge:
    source: str
    target: str
    file: str  # relative to src/
    line: int
    kind: str  # "module", "function" or "TYPE_CHECKING"

    def __str__(self) -> str:
        return f"{self.source} -> {self.target}  ({self.file}:{self.line}, {self.kind}-level import)"


def modules() -> dict[str, Path]:
    out = {}
    for path in sorted((SRC / "parolkit").rglob("*.py")):
        rel = path.relative_to(SRC).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        out[".".join(parts)] = path
    return out


class _Imports(ast.NodeVisitor):
    """Collects (target, line, kind) of every import in one module."""

    def __init__(self, module: str, is_package: bool, known: set[str]) -> None:
        self.module = module
        self.package = module if is_package else module.rpartition(".")[0]
        self.known = known
        self.found: list[tuple[str, int, str]] = []
        self._functions = 0
        self._type_checking = 0

    def _kind(self) -> str:
        if self._type_checking:
            return "TYPE_CHECKING"
        return "function" if self._functions else "module"

    def _add(self, target: str, line: int) -> None:
        if target in self.known and target != self.module:
            self.found.append((target, line, self._kind()))

    def visit_FunctionDef(self, node: ast.FunctionDef | ast.AsyncFunctionDef) -> None:
        self._functions += 1
        self.generic_visit(node)
        self._functions -= 1

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_If(self, node: ast.If) -> None:
        test = ast.unparse(node.test)
        if test in ("TYPE_CHECKING", "typing.TYPE_CHECKING"):
            self._type_checking += 1
            for child in node.body:
                self.visit(child)
            self._type_checking -= 1
            for child in node.orelse:
                self.visit(child)
        else:
            self.generic_visit(node)

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self._add(alias.name, node.lineno)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.level:
            base = self.package.split(".")
            if node.level > 1:
                base = base[: len(base) - (node.level - 1)]
            origin = ".".join(base + ([node.module] if node.module else []))
        else:
            origin = node.module or ""
        for alias in node.names:
            sub = f"{origin}.{alias.name}"
            self._add(sub if sub in self.known else origin, node.lineno)

    def visit_Call(self, node: ast.Call) -> None:
        name = ast.unparse(node.func)
        if name in ("importlib.import_module", "import_module") and node.args:
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                self._add(arg.value, node.lineno)
        self.generic_visit(node)


def import_graph() -> dict[str, list[Edge]]:
    mods = modules()
    known = set(mods)
    graph: dict[str, list[Edge]] = {m: [] for m in mods}
    for module, path in mods.items():
        visitor = _Imports(module, path.name == "__init__.py", known)
        visitor.visit(ast.parse(path.read_text(encoding="utf-8"), str(path)))
        unique = dict.fromkeys(visitor.found)  # `from m import a, b` is one import of m
        file = path.relative_to(SRC).as_posix()
        graph[module] = [Edge(module, t, file, line, kind) for t, line, kind in unique]
    return graph


def strongly_connected(graph: dict[str, list[Edge]]) -> list[frozenset[str]]:
    """Tarjan's algorithm (iterative); the components with more than one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[frozenset[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            advanced = False
            for edge in edges:
                nxt = edge.target
                if nxt not in index:
                    index[nxt] = low[nxt] = counter
                    counter += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(graph[nxt])))
                    advanced = True
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = set()
                while True:
                    m = stack.pop()
                    on_stack.discard(m)
                    comp.add(m)
                    if m == node:
                        break
                if len(comp) > 1:
                    out.append(frozenset(comp))
    return out


def cycles_in(component: frozenset[str], graph: dict[str, list[Edge]], limit: int = 50) -> list[list[str]]:
    """The elementary cycles inside one component as module lists (each once, starting at its
    smallest module, the start repeated at the end), at most ``limit`` of them."""
    succ = {m: sorted({e.target for e in graph[m] if e.target in component}) for m in component}
    found: list[list[str]] = []
    def walk(node: str, start: str, path: list[str]) -> None:
        for nxt in succ[node]:
            if len(found) >= limit or nxt < start:
                continue
            if nxt == start:
                found.append([*path, start])
            elif nxt not in path:
                path.append(nxt)
                walk(nxt, start, path)
                path.pop()

    for start in sorted(component):
        walk(start, start, [start])
    return found


def describe(components: list[frozenset[str]], graph: dict[str, list[Edge]]) -> str:
    """Every cycle of every component, with each import statement that makes each hop."""
    lines = []
    for comp in components:
        lines.append(f"cycle among {', '.join(sorted(comp))}:")
        for cycle in cycles_in(comp, graph):
            lines.append("  " + " -> ".join(cycle))
            for a, b in zip(cycle, cycle[1:]):
                lines.extend(f"      {edge}" for edge in graph[a] if edge.target == b)
    return "\n".join(lines)


def test_the_graph_sees_module_function_and_type_checking_imports():
    graph = import_graph()
    kinds = {e.kind for edges in graph.values() for e in edges}
    assert kinds == {"module", "function", "TYPE_CHECKING"}
    targets = {e.target for e in graph["parolkit.motion.planner"]}
    assert "parolkit.motion.cartesian" in targets  # a lazy, function-level import
    assert "parolkit.motion" not in targets  # the parent package is not an edge


def test_the_cycle_finder_finds_a_cycle_through_three_modules():
    graph = {
        "a": [Edge("a", "b", "a.py", 1, "module")],
        "b": [Edge("b", "c", "b.py", 2, "function")],
        "c": [Edge("c", "a", "c.py", 3, "TYPE_CHECKING"), Edge("c", "d", "c.py", 4, "module")],
        "d": [],
    }
    comps = strongly_connected(graph)
    assert comps == [frozenset({"a", "b", "c"})]
    assert cycles_in(comps[0], graph) == [["a", "b", "c", "a"]]
    assert "c -> a  (c.py:3, TYPE_CHECKING-level import)" in describe(comps, graph)


def test_there_are_no_import_cycles_but_the_known_ones():
    graph = import_graph()
    components = strongly_connected(graph)
    new = [c for c in components if c not in KNOWN_CYCLES]
    assert not new, "import cycles in src/parolkit:\n" + describe(new, graph)
    gone = [sorted(c) for c in KNOWN_CYCLES if c not in components]
    assert not gone, f"these known cycles are gone: delete them from KNOWN_CYCLES: {gone}"
