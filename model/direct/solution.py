"""A solved (or failed) problem: the node trajectory, the summary, writing to disk."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from model.outputs import run_folder, write_files
from model.problem.ocp import OCP

if TYPE_CHECKING:
    import pandas as pd


SUMMARY_MEASURES = ("lateral_acceleration", "longitudinal", "integration_error", "min_clearance_integrated")
"""The validation's measures that summary.json carries under their own keys."""

@dataclass
class Solution:
    """The result of ``OCP.solve``; ``ok`` is True only if Ipopt converged and validation passed.

    ``columns`` holds the node values (t, states, controls, p_<state>, mu, the path constraints'
    mu_<family> on a road or with a bounded output, H, psi_<control>) as arrays; ``trajectory`` is
    the same as a pandas DataFrame, made on first use so that a solve that only writes its files
    never imports pandas. A solve also attaches ``adjoined`` (the families' gradients for the
    certificate, ``model.direct.costates.path_multipliers``), ``model``, ``nlp`` and ``ipopt``.
    """

    ocp: OCP
    intervals: int
    status: str
    objective: float | None
    final_time: float
    energy: float | None
    iterations: int
    solve_seconds: float
    columns: dict[str, np.ndarray]
    passing: str
    validation: dict = field(default_factory=dict)
    solver_message: str = ""
    attempts: list[dict] = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    certificate: dict = field(default_factory=dict)
    diagnosis: dict | None = None
    accuracy: dict = field(default_factory=dict)
    search: dict = field(default_factory=dict)  # how the search ended (its time limit: model.search.context)

    @property
    def trajectory(self) -> pd.DataFrame:
        """The node values as a DataFrame (one column per name of ``columns``)."""
        cached = self.__dict__.get("_frame")
        if cached is None:
            import pandas as pd

            cached = self.__dict__["_frame"] = pd.DataFrame(self.columns)
        return cached

    @property
    def ok(self) -> bool:
        return self.status == "optimal" and bool(self.validation.get("passed"))

    def summary(self) -> dict:
        """The contract's summary.json content (plus extra keys)."""
        measures = self.validation.get("measures", {})
        return {
            "name": self.ocp.name,
            "title": self.ocp.title,
            "status": self.status,
            "objective_name": self.ocp.cost.objective,
            "objective": self.objective,
            "final_time": self.final_time,
            "energy": self.energy,
            "intervals": self.intervals,
            "iterations": self.iterations,
            "solve_seconds": self.solve_seconds,
            "min_clearance": measures.get("min_clearance"),
            "min_clearance_dense": measures.get("min_clearance_dense"),
            **({k: v for k, v in measures.items() if k.startswith("min_clearance_moving")}),
            "pass": self.passing,
            **({"exit_taken": measures.get("exit_taken")} if self.ocp.road is not None else {}),
            "swept_angle": measures.get("swept_angle"),
            "valid": bool(self.validation.get("passed")),
            "validation": self.validation.get("checks", {}),
            "reintegration": measures.get("reintegration"),
            **{k: measures[k] for k in SUMMARY_MEASURES if k in measures},
            **self._steering_cost(),
            **({"accuracy": self.accuracy} if self.accuracy else {}),
            "solver_message": self.solver_message,
            **({"search": self.search} if self.search else {}),
            "attempts": self.attempts,
            "timings": self.timings,
            "certificate": self.certificate,
            **({"diagnosis": self.diagnosis} if self.diagnosis is not None else {}),
            **({k: measures.get(k) for k in ("route_lanelets", "lanelets_used")} if self.ocp.map_route else {}),
            **({"route_loops": self.ocp.map_route.loops} if self.ocp.map_route else {}),
        }

    def _steering_cost(self) -> dict:
        """``steering_weight`` w and ``steering_integral`` (integral of u2^2 dt, trapezoid, u2 the
        vehicle's ``roles.turning`` control) of a weighted time cost."""
        w = float(getattr(self.ocp.cost, "steering_weight", 0.0) or 0.0)
        u2 = self.ocp.vehicle.roles.turning
        if not w or u2 not in self.columns:
            return {}
        integral = float(np.trapezoid(np.asarray(self.columns[u2]) ** 2, self.columns["t"]))
        return {"steering_weight": w, "steering_integral": integral}

    def write(self, out: str | Path) -> None:
        """Write summary.json, trajectory.csv (and, on a road, swept_path.geojson) into ``out``.

        The files appear together when all are written (``model.outputs.run_folder``), with
        the umask's permissions; an earlier run's files in ``out`` are replaced or removed.
        """
        with run_folder(out) as stage:
            write_files(stage, self.files())

    def files(self) -> dict[str, str]:
        """The run's files by name: trajectory.csv, swept_path.geojson (roads), summary.json."""
        files = {"trajectory.csv": csv_text(self.columns)}
        if (self.ocp.road is not None or self.ocp.map_route is not None) and self.ocp.bodies:
            files["swept_path.geojson"] = json.dumps(self.swept_path()) + "\n"
        if self.ocp.map_route is not None:
            files["commonroad.xml"] = self.commonroad_xml()
        files["summary.json"] = json_text(self.summary())
        return files

    def swept_path(self) -> dict:
        """GeoJSON FeatureCollection: the area each body sweeps, in the scenario's metric coordinates."""
        import shapely

        from model.analysis.bodies import swept_polygons

        polygons = swept_polygons(self.ocp, self.columns)
        features = [{"type": "Feature", "properties": {"body": name}, "geometry": shapely.geometry.mapping(poly)}
                    for name, poly in polygons.items()]  # fmt: skip
        return {"type": "FeatureCollection", "features": features}


    def commonroad_xml(self) -> bytes:
        """The map's CommonRoad scenario with each body as a DynamicObstacle along the trajectory."""
        from model.scene.commonroad_out import MovingRectangle, scenario_with_rectangles

        v, poses = self.ocp.vehicle, self.ocp.vehicle.body_poses()
        states = {k: np.asarray(self.columns[k], float) for k in v.states}
        rectangles = []
        for name, body in self.ocp.bodies.items():
            x, y, h = v.state_function(list(poses[name]))(states)
            middle = (body.front - body.rear_overhang) / 2  # the rectangle's centre ahead of its reference point
            cx, cy = x + middle * np.cos(h), y + middle * np.sin(h)
            rectangles.append(MovingRectangle(body.length, body.width, np.asarray(self.columns["t"], float), cx, cy, h))
        return scenario_with_rectangles(self.ocp.map_route.map, rectangles)


def csv_text(columns: dict[str, np.ndarray]) -> str:
    """The columns as CSV, 17 significant digits, NaN as an empty field (as pandas writes it)."""
    names = list(columns)
    table = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    rows = [",".join("" if v != v else f"{v:.17g}" for v in row) for row in table.tolist()]
    return "\n".join([",".join(names), *rows]) + "\n"


def json_text(data: dict) -> str:
    """``data`` as full-precision JSON text (NaN and infinities as null), indented."""
    return json.dumps(jsonable(data), indent=2) + "\n"


def jsonable(obj):
    """Full-precision JSON: floats as repr (17 digits), NaN/inf as null."""
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj
