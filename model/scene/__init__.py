"""The scene: what the vehicle must keep clear of (static discs, moving vehicles, roads).

Imports nothing of the project but ``model.errors``: shapes know no vehicle, problem or solver.
"""

from model.scene.moving import MovingVehicle
from model.scene.obstacles import Circle, Obstacle

__all__ = ["Circle", "MovingVehicle", "Obstacle"]
