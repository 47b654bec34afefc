"""The search's structure, read from the source: no module state changed with ``global``, no import cycle."""

from __future__ import annotations

import ast
from pathlib import Path

from tools.import_graph import ROOT


def global_statements(path: Path) -> list[str]:
    """``global NAME`` statements in ``path`` (each as 'line: names'): a module-level name a function changes."""
    tree = ast.parse(path.read_text(), str(path))
    return [f"{node.lineno}: {', '.join(node.names)}" for node in ast.walk(tree) if isinstance(node, ast.Global)]


def test_no_module_under_model_changes_a_module_level_name():
    found = {str(p.relative_to(ROOT)): global_statements(p) for p in sorted((ROOT / "model").rglob("*.py"))}
    assert not {p: g for p, g in found.items() if g}


def test_the_global_check_catches_one(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("MODE = 'a'\n\n\ndef use(mode):\n    global MODE\n    MODE = mode\n")
    assert global_statements(probe) == ["5: MODE"]


def package_graph(folder: Path, package: str) -> dict[str, set[str]]:
    """Each module of ``package`` (the files in ``folder``, not its __init__) -> the package's modules it imports.

    Imports inside functions count (a cycle that only a lazy import hides is still a cycle).
    """
    modules = {f"{package}.{p.stem}" for p in folder.glob("*.py") if p.stem != "__init__"}
    graph: dict[str, set[str]] = {}
    for name in sorted(modules):
        tree = ast.parse((folder / f"{name.rsplit('.', 1)[1]}.py").read_text())
        found: set[str] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                found |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
            elif isinstance(node, ast.Import):
                found |= {a.name for a in node.names}
        graph[name] = (found & modules) - {name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle (``[a, b, ..., a]``) of ``graph``, or None (depth-first search)."""
    state: dict[str, int] = {}  # 1 on the current path, 2 done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        state[node] = 2
        path.pop()
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_model_search_has_no_import_cycle():
    graph = package_graph(ROOT / "model" / "search", "model.search")
    assert "model.search.road" in graph and "model.search.road" in graph["model.search.multistart"]
    assert find_cycle(graph) is None, find_cycle(graph)


def test_the_cycle_check_catches_a_lazy_import_cycle(tmp_path):
    """The check is not vacuous: a module that imports its importer inside a function is a cycle."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "top.py").write_text("from pkg.helper import help_me\n")
    (pkg / "helper.py").write_text("from pkg import leaf\n\n\ndef help_me():\n    from pkg.top import x\n")
    (pkg / "leaf.py").write_text("import os\n")
    graph = package_graph(pkg, "pkg")
    assert graph == {"pkg.top": {"pkg.helper"}, "pkg.helper": {"pkg.leaf", "pkg.top"}, "pkg.leaf": set()}
    assert find_cycle(graph) == ["pkg.helper", "pkg.top", "pkg.helper"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
