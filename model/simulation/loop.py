"""Run a controller against the disturbed plant (docs/closed-loop-format.md).

The loop runs from t = 0 to the scenario's final time: the fixed Tf of an energy problem, the
optimum's Tf of a time problem. Samples are t_k = k h; the last one ends at Tf and is shorter
than h when Tf is not a multiple of h. At each sample the plant's state is measured (seeded
Gaussian noise), the controller is called (timed with ``time.perf_counter``) and its control
joins the actuator queue; the control applied over [t_k, t_k+1) is the one sent ``delay / h``
samples earlier. Before t = 0 the vehicle stands still: the queue starts with zero controls.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from model.direct.solution import Solution, csv_text, json_text
from model.outputs import run_folder, write_files
from model.problem.closed_loop import ControlSettings, Disturbance
from model.problem.costs import Energy
from model.problem.scenario import Scenario
from model.simulation.base import Controller
from model.simulation.controllers import wrap
from model.simulation.single_track import make_plant, plan_mismatch, worst_mismatch

POSITION_SHARE = 0.02  # goal tolerance on the position: this share of the start-goal distance
ANGLE_TOL = 0.05  # rad: goal tolerance on every angle the scenario fixes at Tf
SUMMARY_KEYS = (
    "controller", "steps", "final_position_error", "final_heading_error", "energy", "final_time",
    "min_clearance", "solve_seconds_mean", "solve_seconds_max", "realtime_factor", "failed_steps",
    "reached_goal", "goal_tolerance",
)  # fmt: skip
MOVING_KEYS = ("min_distance_moving", "min_clearance_moving")  # extensions, at their worst over several runs


@dataclass
class ClosedLoop:
    """One closed-loop run: the CSV columns (one row per sample, then the final state) and the summary."""

    columns: dict[str, np.ndarray]
    summary: dict
    runs: list[dict] = field(default_factory=list)

    @property
    def reached_goal(self) -> bool:
        return bool(self.summary["reached_goal"])

    def write(self, out: str | Path) -> None:
        """DIR/closed_loop.csv and DIR/summary.json (and DIR/runs.csv for several runs), together.

        An ``optimum`` folder beside them (the open-loop solve, written by ``Solution.write``) is kept.
        """
        with run_folder(out, keep=("optimum",)) as stage:
            write_files(stage, self.files())

    def files(self) -> dict[str, str]:
        """The run's files by name: closed_loop.csv, runs.csv (several runs), summary.json."""
        files = {"closed_loop.csv": csv_text(self.columns)}
        if self.runs:
            files["runs.csv"] = runs_csv(self.runs)
        files["summary.json"] = json_text(self.summary)
        return files


LATEST = 1.5  # a run ends by 1.5 x the optimum's final time whatever the controller plans


def make_controller(
    name: str, solution: Solution, control: ControlSettings, disturbance: Disturbance
) -> Callable[[], Controller]:
    """A factory of fresh controllers named as on the command line: open-loop, tracking or mpc.

    ``mpc`` imports ``model.simulation.mpc`` on first use (an ImportError if it is absent); its steps
    are real-time iterations with ``control.realtime`` true, warm-started Ipopt with false, and without
    the key (None) the real-time iteration wherever it applies (``MPCSettings.realtime``; the summary's
    ``mpc_step`` says which, and why not).
    """
    from model.simulation.controllers import OpenLoop, Tracking

    if name == "open-loop":
        return lambda: OpenLoop(solution, control)
    if name == "tracking":
        return lambda: Tracking(solution, control, disturbance)
    if name == "mpc":
        from model.simulation.mpc import MPC, MPCSettings

        return lambda: MPC(solution, control, disturbance, MPCSettings(realtime=control.realtime))
    raise ValueError(f"unknown controller {name!r} (open-loop, tracking, mpc)")


def simulate(
    scenario: Scenario,
    solution: Solution,
    controller: Controller,
    disturbance: Disturbance,
    control: ControlSettings,
) -> ClosedLoop:
    """Run ``controller`` against the plant from t = 0 to the final time.

    Parameters
    ----------
    scenario : Scenario
        The problem (vehicle, start, goal, obstacles or road).
    solution : Solution
        The open-loop optimum: its final time ends the run (fixed Tf, or the optimum's for a time
        problem), its states are the reference columns of the CSV.
    controller : Controller
        Called once per sample with the measured state and the pending controls.
    disturbance : Disturbance
        The plant's disturbances, the delay, the noise and its seed.
    control : ControlSettings
        The sample time.

    Returns
    -------
    ClosedLoop
    """
    ocp = scenario.ocp
    v = ocp.vehicle
    h = control.sample_time
    tf = float(solution.columns["t"][-1])
    plant = make_plant(v, disturbance, h, scenario.plant)
    rng = np.random.default_rng(disturbance.seed)
    zero = np.zeros(len(v.controls))
    queue = deque([zero] * control.delay_samples(disturbance))
    start = [ocp.initial.get(s, solution.columns[s][0]) for s in v.states]  # a free start: the optimum's
    z = plant.start(np.array(start, dtype=float))
    rows: dict[str, list] = {k: [] for k in ("state", "applied", "measured", "sent", "seconds", "cpu", "plant")}
    failed, grid = 0, [0.0]
    while grid[-1] < _end(controller, tf) - 1e-9:
        t, x = grid[-1], plant.state(z)
        y = plant.measure(x, rng)
        pending = np.array(queue, dtype=float).reshape(len(queue), len(v.controls))
        t0, c0 = time.perf_counter(), time.process_time()
        sent = np.asarray(controller.make_step(float(t), y, pending), dtype=float).reshape(len(v.controls))
        rows["seconds"].append(time.perf_counter() - t0)
        rows["cpu"].append(time.process_time() - c0)
        if controller.failed or not np.all(np.isfinite(sent)):
            failed += 1
            sent = np.where(np.isfinite(sent), sent, 0.0)
        queue.append(sent)
        applied = queue.popleft()
        for key, val in (("state", x), ("applied", applied), ("measured", y), ("sent", sent)):
            rows[key].append(val)
        rows["plant"].append(plant.extras(z, applied))
        grid.append(min(len(grid) * h, _end(controller, tf)))
        z = plant.step(z, applied, grid[-1] - t)
    rows["state"].append(plant.state(z))
    rows["plant"].append(plant.extras(z, rows["applied"][-1]))
    columns = _columns(v, solution, np.array(grid), rows)
    summary = _summary(scenario, solution, controller, columns, (rows["seconds"], rows["cpu"]), failed, h)
    if scenario.plant.model != "kinematic":  # the summary of the kinematic plant is as before
        summary["plant"] = plan_mismatch(plant, columns, solution.columns) | {"min_clearance": summary["min_clearance"]}
    return ClosedLoop(columns=columns, summary=summary)


def _end(controller: Controller, tf: float) -> float:
    """The run's end: the optimum's Tf, or later if the controller moved its arrival (MPC on a
    time problem under a slower plant), at most ``LATEST`` x Tf."""
    return min(max(tf, float(getattr(controller, "final_time", tf))), LATEST * tf)


def _columns(v, solution: Solution, grid: np.ndarray, rows: dict) -> dict[str, np.ndarray]:
    """t, states, u1, u2 (applied), then measured states, sent controls and the optimum's states at t."""
    X = np.array(rows["state"])
    last = lambda a: np.vstack([np.array(a), np.array(a)[-1:]])  # noqa: E731 - the final row repeats the previous
    U, Y, S = last(rows["applied"]), last(rows["measured"]), last(rows["sent"])
    cols = {"t": grid}
    cols |= {s: X[:, i] for i, s in enumerate(v.states)}
    cols |= {c: U[:, j] for j, c in enumerate(v.controls)}
    cols |= {f"measured_{s}": Y[:, i] for i, s in enumerate(v.states)}
    cols |= {f"sent_{c}": S[:, j] for j, c in enumerate(v.controls)}
    t = np.asarray(solution.columns["t"], dtype=float)
    cols |= {f"ref_{s}": np.interp(grid, t, solution.columns[s]) for s in v.states}
    cols |= {f"plant_{k}": np.array([row[k] for row in rows["plant"]]) for k in rows["plant"][0]}
    return cols


def goal_tolerance(scenario: Scenario) -> dict:
    """Position (2 % of the start-goal distance) and angle (0.05 rad) tolerances on the states fixed at Tf."""
    ocp = scenario.ocp
    v = ocp.vehicle
    distance = ocp.straight_distance()
    angles = [s for s in v.states if s in ocp.final and s not in v.position]
    return {
        "position": POSITION_SHARE * distance if distance is not None else None,
        "position_rule": f"{POSITION_SHARE:g} x the start-goal distance ({distance} m)" if distance else None,
        "angle": ANGLE_TOL,
        "states": [s for s in v.states if s in ocp.final],
        "angle_states": angles,
    }


def final_errors(scenario: Scenario, columns: dict[str, np.ndarray]) -> dict[str, float]:
    """Final error of each state fixed at Tf (angles wrapped), and the position error."""
    ocp = scenario.ocp
    px, py = ocp.vehicle.position
    out = {}
    for s, goal in ocp.final.items():
        err = columns[s][-1] - goal
        out[s] = float(abs(wrap(err)) if s in ocp.vehicle.roles.headings else abs(err))
    if px in ocp.final and py in ocp.final:
        out["position"] = float(math.hypot(columns[px][-1] - ocp.final[px], columns[py][-1] - ocp.final[py]))
    return out


def min_clearance(scenario: Scenario, columns: dict[str, np.ndarray]) -> float | None:
    """Smallest clearance over the samples: exact body rectangles to the road's edges, else the point to obstacles."""
    ocp = scenario.ocp
    v = ocp.vehicle
    px, py = v.position
    if ocp.road is not None and ocp.bodies:
        from model.analysis.bodies import clearances

        return float(min(np.min(c) for c in clearances(ocp, {s: columns[s] for s in v.states}).values()))
    if ocp.road is not None:
        xy = np.column_stack([columns[px], columns[py]])
        return float(np.min(ocp.road.corridor("vehicle").signed_distance(xy)))
    if ocp.obstacles:
        return float(min(np.min(ob.clearance(columns[px], columns[py])) for ob in ocp.obstacles))
    return None


def moving_distances(scenario: Scenario, columns: dict[str, np.ndarray]) -> dict:
    """Least distance (m) over the samples from the vehicle (its bodies' exact rectangles, else its
    reference point) to every moving obstacle's exact rectangle (negative: the overlap's depth),
    ``min_distance_moving``, and that minus the obstacle's safety, ``min_clearance_moving``; None
    without moving obstacles. A distance <= 0 is a collision (``collided``)."""
    ocp = scenario.ocp
    if not ocp.moving_obstacles:
        return {"min_distance_moving": None, "min_clearance_moving": None, "collided": False}
    from model.analysis.bodies import moving_clearances

    clear = moving_clearances(ocp, {k: columns[k] for k in ("t", *ocp.vehicle.states)})
    safety = np.array([ob.safety for ob in ocp.moving_obstacles])[:, None]
    distance = float(np.min(clear + safety))
    return {"min_distance_moving": distance, "min_clearance_moving": float(np.min(clear)), "collided": distance <= 0.0}


def reached(errors: dict[str, float], tol: dict) -> bool:
    """Every state fixed at Tf within its tolerance (position by distance, angles by ``angle``)."""
    ok = [errors["position"] <= tol["position"]] if "position" in errors and tol["position"] is not None else []
    ok += [errors[s] <= tol["angle"] for s in tol["angle_states"]]
    return all(ok)


def _summary(scenario, solution, controller, columns, clocks: tuple, failed: int, h: float) -> dict:
    """The run's summary; ``clocks`` the steps' wall and CPU (this process's) seconds."""
    v = scenario.ocp.vehicle
    tol = goal_tolerance(scenario)
    errors = final_errors(scenario, columns)
    seconds, cpu = (np.asarray(c, dtype=float) for c in clocks)
    moving = moving_distances(scenario, columns)
    step = {"mpc_step": controller.mpc_step} if hasattr(controller, "mpc_step") else {}
    return {
        "controller": controller.name,
        **step,
        "steps": len(seconds),
        "final_position_error": errors.get("position"),
        "final_heading_error": errors.get(v.roles.heading),
        "energy": Energy().integral(columns, v.controls, rule="zoh"),  # the applied controls, unit weights
        "final_time": float(columns["t"][-1]),
        "min_clearance": min_clearance(scenario, columns),
        **moving,
        "solve_seconds_mean": float(np.mean(seconds)),
        "solve_seconds_max": float(np.max(seconds)),
        "step_cpu_seconds_mean": float(np.mean(cpu)),
        "step_cpu_seconds_max": float(np.max(cpu)),
        "realtime_factor": float(np.max(seconds) / h),
        "failed_steps": int(failed),
        "truncated_steps": sum(bool(step.get("truncated")) for step in getattr(controller, "steps", [])),
        "reached_goal": failed == 0 and not moving["collided"] and reached(errors, tol),
        "goal_tolerance": tol,
        "final_errors": errors,
        "sample_time": h,
        "optimum_energy": solution.energy,
        "optimum_objective": solution.objective,
        "optimum_final_time": solution.final_time,
    }


def simulate_runs(
    scenario: Scenario,
    solution: Solution,
    make_controller: Callable[[], Controller],
    disturbance: Disturbance,
    control: ControlSettings,
    runs: int = 1,
) -> ClosedLoop:
    """``runs`` closed loops with seeds seed, seed + 1, ...; a fresh controller for each.

    Returns
    -------
    ClosedLoop
        The first run's columns; ``runs`` one row per run; the summary: the contract's keys at
        their worst case over the runs (largest errors, energy and times, smallest clearance, all
        failed steps, ``reached_goal`` only if every run reached it), plus ``mean`` and ``worst``
        of every number and ``reached_goal_rate``.
    """
    results = []
    for i in range(runs):
        seeded = dataclasses.replace(disturbance, seed=disturbance.seed + i)
        results.append(simulate(scenario, solution, make_controller(), seeded, control))
    rows = [{"run": i, "seed": disturbance.seed + i, **_scalars(r.summary)} for i, r in enumerate(results)]
    if runs == 1:
        return results[0]
    summary = _runs_summary([r.summary for r in results], [r["seed"] for r in rows])
    return ClosedLoop(columns=results[0].columns, summary=summary, runs=rows)


WORST_IS_SMALLEST = {"min_clearance", "min_distance_moving", "min_clearance_moving"}


def _scalars(summary: dict) -> dict:
    """The summary's per-run numbers and booleans (for runs.csv)."""
    keys = [k for k, v in summary.items() if isinstance(v, bool | int | float) or v is None]
    return {k: summary[k] for k in keys if k not in ("goal_tolerance",)}


def _runs_summary(summaries: list[dict], seeds: list[int]) -> dict:
    """The first run's summary with the contract's numbers at their worst, plus means, worst cases and rates."""
    numbers = [k for k, v in _scalars(summaries[0]).items() if not isinstance(v, bool) and k != "steps"]
    mean, worst = {}, {}
    for k in numbers:
        vals = [s[k] for s in summaries if s[k] is not None]
        mean[k] = float(np.mean(vals)) if vals else None
        worst[k] = (min(vals) if k in WORST_IS_SMALLEST else max(vals)) if vals else None
    worst["failed_steps"] = int(sum(s["failed_steps"] for s in summaries))
    rate = float(np.mean([s["reached_goal"] for s in summaries]))
    summary = {k: v for k, v in summaries[0].items() if k != "final_errors"}
    summary |= {k: worst[k] for k in (*SUMMARY_KEYS, *MOVING_KEYS) if k in worst}
    summary["collided"] = any(bool(s.get("collided")) for s in summaries)
    if "plant" in summary:
        summary["plant"] = worst_mismatch([s["plant"] for s in summaries])
    return summary | {
        "reached_goal": rate == 1.0,
        "runs": len(summaries),
        "seeds": seeds,
        "reached_goal_rate": rate,
        "mean": mean,
        "worst": worst,
    }


def runs_csv(rows: list[dict]) -> str:
    """One line per run, the header the keys of the first."""
    names = list(rows[0])

    def cell(v) -> str:
        if v is None:
            return ""
        if isinstance(v, bool):
            return str(v).lower()
        return f"{v:.17g}" if isinstance(v, float) else str(v)

    return "\n".join([",".join(names), *(",".join(cell(r[n]) for n in names) for r in rows)]) + "\n"


__all__ = [
    "ClosedLoop", "goal_tolerance", "make_controller", "min_clearance", "moving_distances", "simulate", "simulate_runs",
]  # fmt: skip
