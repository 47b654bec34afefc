"""The scene: what the vehicle must keep clear of (circular obstacles; road geometry next).

Imports nothing of the project: shapes know no vehicle, problem or solver.
"""

from model.scene.obstacles import Circle

__all__ = ["Circle"]
