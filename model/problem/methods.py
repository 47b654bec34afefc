"""Where a problem is handed to a method, without the problem layer importing it.

As in rockit's ``ocp.method(...)``, the problem definition does not import its
solvers: ``OCP.solve`` and ``OCP.pmp`` call a *method*, a callable ``(ocp, **options)``,
given directly or named as ``"package.module:function"`` and imported on first use (the
way Pyomo's SolverFactory and Python entry points name plug-ins). The defaults name the
search layer's multi-start and the Pontryagin engine.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module
from typing import Any

DEFAULT_SOLVE = "model.search.multistart:solve_ocp"
DEFAULT_MAP_SOLVE = "model.search.maps:solve_map_route"  # a route through a lanelet map
DEFAULT_PMP = "derivations.pmp:derive"

Method = Callable[..., Any]


def default_solve(ocp: Any) -> str:
    """The default solve method of a problem: the map search for a ``map_route``, else the multi-start."""
    return DEFAULT_MAP_SOLVE if getattr(ocp, "map_route", None) is not None else DEFAULT_SOLVE


def load_method(method: str | Method) -> Method:
    """The callable a method names (``"module:function"``), or ``method`` itself if callable."""
    if callable(method):
        return method
    module, sep, name = str(method).partition(":")
    if not sep or not module or not name:
        raise ValueError(f"a method is a callable or 'module:function', got {method!r}")
    return getattr(import_module(module), name)


__all__ = ["DEFAULT_MAP_SOLVE", "DEFAULT_PMP", "DEFAULT_SOLVE", "Method", "default_solve", "load_method"]
