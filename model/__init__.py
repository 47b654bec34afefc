"""roundabout-ocp: optimal trajectories of truck-type vehicles (the modelling DSL)."""

from model.costs import Energy, Time
from model.errors import InputError
from model.obstacles import Circle
from model.ocp import OCP
from model.vehicles import VEHICLES, Truck, Unicycle, Vehicle

__all__ = ["OCP", "Circle", "Energy", "InputError", "Time", "Truck", "Unicycle", "VEHICLES", "Vehicle"]
