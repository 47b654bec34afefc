"""The seed paper's three problems as OCP definitions (the claims are checked on these)."""

from __future__ import annotations

from model.problem.costs import Energy, Time
from model.problem.ocp import OCP
from model.scene.obstacles import Circle
from model.vehicles import Truck

U1MAX = 1.0
U2MAX = 0.35
WHEELBASE = 0.1
BOUNDS = {"u1": (-U1MAX, U1MAX), "u2": (-U2MAX, U2MAX)}
START = {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0}
GOAL = {"x": 1.0, "y": 0.0, "theta": 0.0}
OBSTACLE = Circle(center=(0.5, 0.03), radius=0.2, safety=0.05)
"""The project's obstacle: the paper's centre, R = r_obs + d_s = 0.25 (scenario-format.md)."""


def toctaco() -> OCP:
    """Time-optimal, no obstacle (Section 3.3)."""
    return OCP(vehicle=Truck(WHEELBASE), cost=Time(), bounds=dict(BOUNDS), initial=dict(START),
               final=dict(GOAL), final_time=2.0, name="TOCTACO")


def toctpco() -> OCP:
    """Time-optimal with one circular obstacle, problem (4)."""
    return OCP(vehicle=Truck(WHEELBASE), cost=Time(), bounds=dict(BOUNDS), initial=dict(START),
               final=dict(GOAL), obstacles=[OBSTACLE], final_time=2.0, name="TOCTPCO")


def eetppco() -> OCP:
    """Energy-optimal with one circular obstacle and fixed final time, problem (17)."""
    return OCP(vehicle=Truck(WHEELBASE), cost=Energy(), bounds=dict(BOUNDS), initial=dict(START),
               final=dict(GOAL), obstacles=[OBSTACLE], final_time=4.5, name="EETPPCO")
