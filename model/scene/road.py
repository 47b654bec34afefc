"""A road scene: a roundabout and the route a vehicle takes through it (roundabout-format.md)."""

from __future__ import annotations

from dataclasses import dataclass

from model.scene.roundabout import Roundabout, Route, apron_allowed, corridor, exit_leg, goal_pose, start_pose


@dataclass(frozen=True)
class Road:
    """The roundabout, the route, and what follows from them: poses, exit leg, corridors.

    Parameters
    ----------
    roundabout : Roundabout
    route : Route
    """

    roundabout: Roundabout
    route: Route

    @property
    def exit_leg(self) -> int:
        """Index of the leg the route leaves by."""
        return exit_leg(self.roundabout, self.route)

    def start(self) -> tuple[float, float, float]:
        """(x, y, theta) at t = 0."""
        return start_pose(self.roundabout, self.route)

    def goal(self) -> tuple[float, float, float]:
        """(x, y, theta) at Tf."""
        return goal_pose(self.roundabout, self.route)

    def corridor(self, body: str):
        """The exact region (``model.scene.geometry.Region``) body ``"vehicle"`` or ``"trailer"`` may occupy."""
        return corridor(self.roundabout, self.route, apron=apron_allowed(self.roundabout, body))
