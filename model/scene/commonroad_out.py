"""A lanelet map's CommonRoad scenario with rectangles moving along given paths (for commonroad.xml).

``scenario_with_rectangles`` copies the map's scenario, adds each rectangle as a ``DynamicObstacle``
(its centre and orientation resampled at the scenario's time step ``dt``) and returns the file
written by commonroad-io's ``CommonRoadFileWriter``. No vehicle here: only rectangles and arrays.
"""

from __future__ import annotations

import copy
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from model.scene.lanelet_map import LaneletMap


@dataclass
class MovingRectangle:
    """A rectangle (length, width, m) whose centre (x, y) and orientation (rad) are given at times t (s)."""

    length: float
    width: float
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    orientation: np.ndarray


def resample(rect: MovingRectangle, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Times k dt within [t0, t_end] and the centre and orientation there (linear interpolation)."""
    t = np.arange(0.0, float(rect.t[-1] - rect.t[0]) + 1e-9, dt) + float(rect.t[0])
    return (t, np.interp(t, rect.t, rect.x), np.interp(t, rect.t, rect.y),
            np.interp(t, rect.t, np.unwrap(rect.orientation)))  # fmt: skip


def scenario_with_rectangles(lanelet_map: LaneletMap, rectangles: list[MovingRectangle]) -> bytes:
    """The CommonRoad XML (bytes) of the map's scenario with each rectangle as a car ``DynamicObstacle``."""
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
    from commonroad.geometry.shape import Rectangle
    from commonroad.planning.planning_problem import PlanningProblemSet
    from commonroad.prediction.prediction import TrajectoryPrediction
    from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
    from commonroad.scenario.state import CustomState, InitialState
    from commonroad.scenario.trajectory import Trajectory

    scenario = copy.deepcopy(lanelet_map.scenario)
    dt = float(scenario.dt)
    for rect in rectangles:
        t, x, y, h = resample(rect, dt)
        speed = np.hypot(np.gradient(x, dt), np.gradient(y, dt)) if len(t) > 1 else np.zeros(1)
        shape = Rectangle(length=float(rect.length), width=float(rect.width))
        states = [CustomState(position=np.array([x[k], y[k]]), orientation=float(h[k]), velocity=float(speed[k]),
                              time_step=k) for k in range(1, len(t))]  # fmt: skip
        initial = InitialState(position=np.array([x[0], y[0]]), orientation=float(h[0]), velocity=float(speed[0]),
                               acceleration=0.0, yaw_rate=0.0, slip_angle=0.0, time_step=0)  # fmt: skip
        prediction = TrajectoryPrediction(Trajectory(1, states), shape) if states else None
        scenario.add_objects(DynamicObstacle(scenario.generate_object_id(), ObstacleType.TRUCK, shape, initial,
                                             prediction))  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "commonroad.xml"
        writer = CommonRoadFileWriter(scenario, PlanningProblemSet(), author="roundabout-ocp",
                                      affiliation="", source="roundabout solve", tags=set())  # fmt: skip
        writer.write_to_file(str(path), OverwriteExistingFile.ALWAYS)
        return path.read_bytes()
