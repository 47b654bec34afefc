"""The indirect method: single shooting on the Pontryagin boundary-value problem.

Imports the problem definition and the Pontryagin engine.
"""

from model.indirect.shooting import ShootingResult, example_problem, richardson, shoot

__all__ = ["ShootingResult", "example_problem", "richardson", "shoot"]
