"""The project's import graph, read from the source (stdlib only): layers and code closures.

Used by the Snakemake rules (a rule's outputs depend on exactly the code its script can
import), by ``tests/test_layers.py`` (no module imports a layer above its own) and by
``tests/test_architecture_claims.py`` (docs/architecture.md states what each layer imports).
Imports under ``if TYPE_CHECKING:`` are annotations only and are left out.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("model", "derivations")


def module_file(module: str, root: Path = ROOT) -> Path | None:
    """The file of a project module (``model.direct.solve`` -> model/direct/solve.py), or None."""
    base = root.joinpath(*module.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


@cache
def imports_of(path: Path) -> tuple[str, ...]:
    """Project modules imported anywhere in ``path`` (functions included, TYPE_CHECKING excluded)."""
    tree = ast.parse(path.read_text(), str(path))
    found: set[str] = set()
    for node in _walk_runtime(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
    return tuple(sorted(m for m in found if m.split(".")[0] in PACKAGES and module_file(m)))


def _walk_runtime(tree: ast.AST):
    """ast.walk without the bodies of ``if TYPE_CHECKING:`` blocks."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            stack.extend(node.orelse)
            continue
        stack.extend(ast.iter_child_nodes(node))


def module_name(path: Path, root: Path = ROOT) -> str:
    """``model/direct/solve.py`` -> ``model.direct.solve`` (a package's __init__ -> the package)."""
    parts = list(path.resolve().relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def closure(*roots: str | Path) -> list[str]:
    """Every project file the given modules or script files can import, transitively (with parents)."""
    todo = [Path(r) if str(r).endswith(".py") else module_file(str(r)) for r in roots]
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path is None or path in seen:
            continue
        seen.add(path)
        todo.extend(module_file(m) for m in imports_of(path))
        todo.extend(_parents(path))
    return sorted(str(p) for p in seen)


def _parents(path: Path) -> list[Path]:
    """The __init__.py files Python runs before a module of a package."""
    out = []
    for parent in path.resolve().parents:
        if parent == ROOT:
            break
        init = parent / "__init__.py"
        if init.is_file() and init != path:
            out.append(init)
    return out


def project_modules() -> list[Path]:
    """Every .py file of the project's packages."""
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def layer_of(module: str, layers: Iterable[str]) -> str | None:
    """The longest of ``layers`` that is ``module`` or a package above it (``model.direct.solve`` -> ``model.direct``).

    Parameters
    ----------
    module : str
        A dotted module name.
    layers : iterable of str
        Dotted package or module names.

    Returns
    -------
    str or None
        The layer, or None when no layer holds the module.
    """
    held = [name for name in layers if module == name or module.startswith(name + ".")]
    return max(held, key=len) if held else None


def layer_imports(layers: Iterable[str]) -> dict[str, set[str]]:
    """The other layers each layer's modules import at run time (functions included, TYPE_CHECKING excluded).

    Parameters
    ----------
    layers : iterable of str
        Dotted package names; every project module must belong to one of them.

    Returns
    -------
    dict of str to set of str
        For each layer, the layers (not itself) that any of its modules imports.

    Raises
    ------
    ValueError
        If a project module, or a project module one imports, belongs to no layer.
    """
    layers = tuple(layers)
    found: dict[str, set[str]] = {name: set() for name in layers}
    for path in project_modules():
        modules = [module_name(path), *imports_of(path)]
        owners = [layer_of(m, layers) for m in modules]
        if None in owners:
            raise ValueError(f"{modules[owners.index(None)]} belongs to no layer of {layers}")
        found[owners[0]].update(owners[1:])
    for name, imported in found.items():
        imported.discard(name)
    return found
