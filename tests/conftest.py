import math
from pathlib import Path

import pytest

from model import OCP, Circle, Energy, Time, Truck

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "workflows" / "scenarios").glob("*.toml"))
EXAMPLE = ROOT / "examples" / "format-example.toml"

TRUCK_BOUNDS = {"u1": (-1.0, 1.0), "u2": (-0.35, 0.35), "phi": (-0.6, 0.6)}
START = {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0}


def straight(cost, length: float = 1.0, tf: float = 2.0) -> OCP:
    """Obstacle-free drive along the x axis (energy: u1 = L / Tf; time: Tf = L / u1max)."""
    return OCP(
        vehicle=Truck(0.1),
        cost=cost,
        bounds=TRUCK_BOUNDS,
        initial=START,
        final={"x": length, "y": 0.0, "theta": 0.0, "phi": 0.0},
        final_time=tf,
    )


def straight_energy(length: float = 1.0, tf: float = 2.0) -> OCP:
    return straight(Energy(), length, tf)


def straight_time(length: float = 1.0) -> OCP:
    return straight(Time(), length, 3.0)  # final_time: the first guess


def paper_energy_problem(tf: float = 4.5) -> OCP:
    """The scenario format's example, posed in Python."""
    return OCP(
        vehicle=Truck(wheelbase=0.1),
        cost=Energy(),
        final_time=tf,
        bounds=TRUCK_BOUNDS,
        obstacles=[Circle(center=(0.5, 0.03), radius=0.2, safety=0.05)],
        initial=START,
        final={"x": 1.0, "y": 0.0, "theta": 0.0},
        passing="ccw",
    )


@pytest.fixture(scope="session")
def example_solution():
    return paper_energy_problem().solve(intervals=100)


__all__ = ["math"]
