"""The problem definition: the OCP (vehicle, cost, bounds, obstacles, boundary values), costs, scenario files.

Imports the vehicles and the scene only; solvers are reached through ``methods`` (named, not imported).
"""

from model.problem.costs import Cost, Energy, Time
from model.problem.ocp import OCP, PASSES
from model.problem.scenario import Scenario, load_scenario, parse_scenario

__all__ = ["OCP", "PASSES", "Cost", "Energy", "Scenario", "Time", "load_scenario", "parse_scenario"]
