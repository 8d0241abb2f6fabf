"""The import graph of the ``odsuite`` package, read from the source (AST): no import circles among
its modules, and no import of the built-in plugins (``odsuite_plugins``).

Imports inside functions count: they run on every call, and a circle through one is still a
circle. ``from odsuite import __version__`` is an edge to ``odsuite/__init__.py``; the implicit
import of a module's parent packages is not.
"""

from __future__ import annotations

import ast
from pathlib import Path

ODSUITE = Path(__file__).resolve().parents[2] / "odsuite"

def _module(path: Path, root: Path) -> str:
    """The dotted name of ``path`` in the package directory ``root``."""
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported(path: Path, root: Path, modules: set[str]) -> set[str]:
    """Every module name ``path`` (in the package directory ``root``) imports; ``from pkg import
    mod`` names ``pkg.mod`` when that is one of ``modules``."""
    name = _module(path, root)
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: resolved against this module's package
                package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
                package = package[: len(package) - node.level + 1]
                base = ".".join(package + ([base] if base else []))
            found |= {f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names}
    return found


def _graph() -> dict[str, set[str]]:
    files = {_module(p, ODSUITE): p for p in sorted(ODSUITE.rglob("*.py"))}
    return {name: _imported(path, ODSUITE, set(files)) for name, path in files.items()}


def _circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(out)


def test_the_circle_finder_finds_circles():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"f"}, "f": {"e"}}
    assert _circles(edges) == [["a", "b", "c"], ["e", "f"]]
    assert _circles({"a": {"b"}, "b": set()}) == []


def test_the_graph_sees_function_level_and_relative_imports(tmp_path):
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    source = package / "a.py"
    source.write_text("from . import b\n\ndef f():\n    from pkg.c import thing\n    import pkg.d\n")
    modules = {"pkg", "pkg.a", "pkg.b", "pkg.c", "pkg.d"}
    assert _imported(source, package, modules) == {"pkg.b", "pkg.c", "pkg.d"}


def test_no_import_circles_in_odsuite():
    graph = _graph()
    edges = {a: {b for b in targets if b in graph and b != a} for a, targets in graph.items()}
    assert "odsuite.store.project" in edges and edges["odsuite.store.project"]  # the graph was read
    assert _circles(edges) == []


def test_odsuite_never_imports_the_builtin_plugins():
    offenders = {name: sorted(t for t in targets if t.split(".")[0] == "odsuite_plugins")
                 for name, targets in _graph().items()}
    assert {name: t for name, t in offenders.items() if t} == {}
