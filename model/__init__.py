"""roundabout-ocp: optimal trajectories of truck-type vehicles around roundabouts.

The public API, re-exported from the layers (see docs/architecture.md)::

    from model import OCP, Truck, Energy, Circle, MovingVehicle, Resolver, load_scenario, solve_many

Names are imported on first use (PEP 562), so ``import model`` stays cheap and a
command that only reads a scenario file never loads the solver.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_PUBLIC = {
    "InputError": "model.errors",
    "Vehicle": "model.vehicles",
    "Roles": "model.vehicles",
    "Truck": "model.vehicles",
    "Unicycle": "model.vehicles",
    "VEHICLES": "model.vehicles",
    "Circle": "model.scene",
    "MovingVehicle": "model.scene",
    "OCP": "model.problem",
    "Cost": "model.problem",
    "Energy": "model.problem",
    "Time": "model.problem",
    "Scenario": "model.problem",
    "load_scenario": "model.problem",
    "validate": "model.analysis",
    "certify_trajectory": "model.analysis",
    "Solution": "model.direct",
    "Resolver": "model.direct",
    "solve_ocp": "model.search",
    "solve_many": "model.search.batch",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str) -> Any:
    if name not in _PUBLIC:
        raise AttributeError(f"module 'model' has no attribute {name!r}")
    value = getattr(import_module(_PUBLIC[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
