"""Benchmark: real-time MPC on the roundabout road with bodies, against a plain CasADi Opti peer.

Usage: python benchmarks/bench_mpc_road.py [--cases truck semitrailer] [--controllers rti ipopt]
       [--reference-intervals 100] [--no-peer] [--compiled] [--qp-max-changes K]
       [--qp-solver qpoases|hpipm] [--hpipm-mode MODE] [--hpipm-iter-max K] [--interval-samples K]

Cases: the rigid truck (examples/roundabout-truck.toml), the EU semitrailer
(examples/roundabout-semitrailer.toml) and the truck with a crossing car (examples/crossing-car.toml)
through the roundabout, sampled at 10 Hz with a 4 s horizon (40 samples; since the fifth round in 20
prediction intervals of 2 samples, ``--interval-samples``). The open-loop optimum (``ocp.solve``,
``--reference-intervals``) is the reference; the closed loop is ``model.simulation.loop.simulate`` with
the nominal plant (the vehicle's own dynamics, no disturbance). Controllers: ``rti`` is
``MPC(settings=MPCSettings(realtime=True))`` (one condensed SQP step per sample, warm-started Ipopt the
fallback), ``ipopt`` the warm-started Ipopt MPC (the default controller).

The peer shadows the controller in the same run: after each of the MPC's steps it is handed the same
horizon problem (every active row and the objective of the horizon's Pyomo model: the body discs,
the soft constraints with their slacks, the same cost; the Params' values and the variables' bounds
of the step) written in plain CasADi Opti: the rows translated to SX by a direct walk of each
expression (``model.nlp.pyomo_sx.PyomoToSX``: no templates, no presolve; CasADi's own derivatives,
its own Ipopt interface, ``detect_simple_bounds``), and started from the same warm start (the MPC's
primal start, ``CasadiNLP.full_primals``; at the first step the multipliers the MPC starts from,
``CasadiNLP.full_duals``, then its own previous multipliers moved in time like the MPC's).
Its Ipopt options are the MPC's Ipopt options without a wall-time budget. ``du`` is the largest
difference of the first planned controls (the real-time iteration is one step, not a converged
solve: it differs by what one step leaves).

Per case and controller: the MPC's steps (real-time iterations, Ipopt fallbacks, failed), mean and
worst step seconds (wall, and CPU: ``time.process_time``, less sensitive to a shared machine), the
peer's, the ratio, whether the goal was reached (the loop's tolerance), the final errors, and the
exact-rectangle corridor check at every sample (``model.analysis.bodies.clearances``: the smallest
clearance of the bodies' exact rectangles to the exact corridor, and how many samples are below 0).
Timings on a shared machine are noisy: the load average is printed before and after each case.

Measured at 2a08fc4 (x86_64, 2 cores shared, load average 5-8: wall seconds are 3-4 times the CPU
seconds; reference N = 100):

| case | controller | steps (RTI/fallback/failed) | wall mean/max s | CPU mean/max s | Opti mean/max s | goal |
|---|---|---|---|---|---|---|
| truck | rti | 105 (105/0/0) | 0.081 / 0.183 | 0.018 / 0.044 | 0.52 / 12.7 | yes (1.4 mm) |
| truck | ipopt | 105 (0/0/100) | 0.154 / 0.385 | 0.040 / 0.080 | 1.97 / 6.37 | no (60 m) |
| semitrailer | rti | 132 (132/0/0) | 0.191 / 0.372 | 0.043 / 0.086 | 1.24 / 32.5 | yes (2.0 mm) |
| semitrailer | ipopt | 132 (0/0/131) | 0.153 / 0.222 | 0.071 / 0.108 | 2.58 / 14.8 | no (61 m) |

Exact corridor at every sample: no sample outside in any run (smallest clearance of the exact
rectangles 0.122 / 0.126 / 0.052 / 0.145 m).

Crossing car (examples/crossing-car.toml: the truck straight on while a car circulates ahead of it;
the horizon refills the car at its node times every step), measured at d13d3e0, reference N = 60
(refined to 120), load average 5:

| case | controller | steps (RTI/fallback/failed) | wall mean/max s | CPU mean/max s | Opti mean/max s | goal | car |
|---|---|---|---|---|---|---|---|
| crossing-car | rti | 115 (115/0/0) | 0.075 / 0.334 | 0.038 / 0.164 | 0.33 / 5.12 | yes (0.19 mm) | 0.824 m |
| crossing-car | ipopt | 115 (0/0/85) | 0.130 / 0.216 | 0.070 / 0.112 | 1.09 / 4.23 | no (44 m) | 1.122 m |

(car: the least distance to its exact rectangle over the samples; its safety is 0.5 m: both keep
it at every sample; exact corridor: no sample outside, smallest clearance 0.065 / 0.100 m.)

(ipopt: at this load nearly every warm-started Ipopt step hits its wall-time budget, 0.8 x the
sample, without a usable iterate, so the controller follows old plans; at load ~3 the same truck
run had 17 failed steps, mean 0.078 s. The peer has no budget: its "unsolved" counts iteration-cap
stops. The 10 ms mean / 30 ms worst target is not met here: the RTI's CPU time is 18 / 44 ms on the
truck, 43 / 86 ms on the semitrailer; the dense QP (qpOASES) is about half of it.)

The RTI's step after the profile of issue 19 (the QP through persistent buffers instead of a
numpy-to-DM conversion of the dense A per call, qpOASES's MPC preset, the objective's Hessian
blocks formed once, constant row bounds read once, one gc collection after the build), against its
parent 6f5b615 in the same conditions (``--controllers rti --no-peer``, one after the other, load
average 5-6 on 2 shared cores; ms):

| case | 6f5b615 CPU mean / max | now CPU mean / max | 6f5b615 wall mean / max | now wall mean / max |
|---|---|---|---|---|
| truck | 14.0 / 36.8 | 7.9 / 20.0 | 33 / 164 | 20 / 51 |
| semitrailer | 35.4 / 79.5 | 19.6 / 54.7 | 85 / 160 | 38 / 83 |
| crossing-car | 34.8 / 115 | 17.6 / 65.3 | 82 / 286 | 32 / 127 |

Same closed loops to the printed digits (all steps real-time iterations, goal errors 1.4 / 2.0 /
0.22 mm, exact-corridor clearances 0.122 / 0.052 / 0.068 m, the car 0.821 m away at least).
The 10 ms mean / 30 ms worst target is met by the truck's CPU time only; on the semitrailer and the
crossing car a step's CPU is still about 2x the target (CPU profile of the semitrailer loop: the
QP ~35 %, about 20 hot-started qpOASES iterations of ~0.1-0.2 ms on ~1500 rows; the function
evaluations ~20 %; the condensing's LU and solves ~10 %).

Second round (``--controllers rti --no-peer [--compiled]``, load 5-9, CPU mean / max ms): the
worst steps are those with many hot-started qpOASES iterations (100-173; correlation of a step's CPU
time with the QP's iteration count 0.95-0.99), not a cold QP, a collection, the check or a fallback.
At 5c53a87 7.5 / 18.9 (truck), 19.5 / 55.6 (semitrailer), 15.1 / 64.8 (crossing car); g, gradient
and Jacobian in one CasADi call: 7.0 / 19.2 and 7.2 / 19.5, 17.6 / 51.7 and 17.0 / 50.2, 16.0 / 65.6
and 15.6 / 65.3 (two runs); with ``--compiled`` (gcc -O1, cached under ~/.cache/roundabout-ocp; the
first run compiles in the MPC's constructor): 8.0 / 21.6 and 6.6 / 17.7, 17.1 / 52.0 and 17.4 / 51.8,
15.2 / 63.0 and 13.6 / 60.2. Same closed loops in every run.

Third round (semitrailer, ``--no-peer``, load 0.4-2.0, CPU mean / max ms): baseline 23.2 / 69.5;
``--qp-max-changes 40`` 26.1 / 146.9 (7 fallbacks, 4 failed, goal missed), ``70`` 21.2 / 152.1 (1 / 1,
goal missed): qpOASES' early stop (its intermediate iterate) does not keep the loop; benchmarks/mpc-road.md
has the profile of a step.
With the Opti peer (``--controllers rti``, load 1.7 -> 3.2): CPU mean / max ms 10.5 / 26.5 (truck,
Opti ratio 0.124), 24.0 / 63.5 (semitrailer, 0.100), 21.0 / 71.2 (crossing car, 0.131); all checks held.

Fourth round (ced764a): ``--qp-solver hpipm`` (the uncondensed QP in hpipm's stage layout,
``model.simulation.mpc.stagewise``; robust mode, cap 40, ``--no-peer``): truck 6 RTI / 99 fallbacks,
CPU 40 / 61 ms (load 11), semitrailer 5 / 127, 102 / 131 ms (load 6), crossing car 0 / 115, 65 / 87
ms; goals missed: the interior point takes 14-29 iterations when it converges (truck RTI steps
9-10 ms, semitrailer 17-19 ms) and reaches its cap from some sample on. qpOASES stays the default.
With the Opti peer (``--controllers rti``, N = 40, x86_64 2 shared cores, load 12 -> 7): CPU mean / max
ms 11.8 / 25.4 (truck, ratio 0.107), 26.6 / 64.1 (semitrailer, 0.108), 23.3 / 78.4 (crossing car,
0.130); same closed loops, all checks held; the 10 / 30 ms target is not met (benchmarks/mpc-road.md).

Fifth round (20c7296, idle, load 0.5-0.8): 20 prediction intervals of 2 samples (``--interval-samples 2``,
the default here), ``MPCSettings.rti_regularization`` 0.1, the slack repair sign-aware. With the Opti peer,
CPU mean / worst ms: truck 3.6 / 8.6 (ratio to Opti's wall mean 0.137), semitrailer 8.2 / 21.0 (0.125),
crossing car 6.9 / 16.6 (0.162; another run of it 7.7 / 30.5); every step RTI, goals reached, 0 samples
outside the exact corridor, the car >= 0.825 m away. The 10 / 30 ms target is met (benchmarks/mpc-road.md).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the condensing's small dense algebra: no thread contention
os.environ.setdefault("OMP_NUM_THREADS", "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
import pyomo.environ as pyo  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.analysis.bodies import clearances  # noqa: E402
from model.direct.resolve import WARM_OPTIONS  # noqa: E402
from model.nlp.ipopt import DEFAULT_OPTIONS  # noqa: E402
from model.nlp.pyomo_sx import PyomoToSX  # noqa: E402
from model.problem.closed_loop import ControlSettings, Disturbance  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402
from model.simulation.loop import simulate  # noqa: E402
from model.simulation.mpc import MPC, MPCSettings, TimeLayout  # noqa: E402
from model.simulation.mpc.horizon import node_fraction  # noqa: E402

CASES = {"truck": "examples/roundabout-truck.toml", "semitrailer": "examples/roundabout-semitrailer.toml",
         "crossing-car": "examples/crossing-car.toml"}  # fmt: skip
SAMPLE, HORIZON = 0.1, 40  # 10 Hz, 4 s
INTERVAL_SAMPLES = 2  # samples per prediction interval: 20 intervals of 0.2 s
BIG = 1e20  # Ipopt reads |bound| >= 1e19 as none


class OptiPeer:
    """The MPC's horizon problem in plain CasADi Opti, warm-started like the MPC (see the module docstring)."""

    def __init__(self, mpc: MPC):
        hm = mpc.horizon
        self.mpc, self.model, self.nlp, self.n = mpc, hm.model, hm.nlp, hm.n
        self.variables, self.params = hm.nlp.variables, hm.nlp.params
        self.rows = list(self.model.component_data_objects(pyo.Constraint, active=True, descend_into=True))
        xs, ps = ca.SX.sym("x", len(self.variables)), ca.SX.sym("p", len(self.params))
        walk = PyomoToSX({id(v): i for i, v in enumerate(self.variables)}, xs,
                         {id(q): i for i, q in enumerate(self.params)}, ps)  # fmt: skip
        body, lower, upper = [], [], []
        for c in self.rows:  # constant bounds (a Param bound: an equality row, written body - bound == 0)
            lo, expr, hi = c.to_bounded_expression(evaluate_bounds=False)
            if c.equality and not _number(lo):
                body.append(walk(expr) - walk(lo))
                lo = hi = 0.0
            else:
                body.append(walk(expr))
                if not (_number(lo) and _number(hi)):
                    raise ValueError(f"{c.name}: a Param bound on an inequality row")
            lower.append(-BIG if lo is None else float(lo))
            upper.append(BIG if hi is None else float(hi))
        objective = walk(self.model.component_data_objects(pyo.Objective, active=True).__next__().expr)
        fn = ca.Function("horizon", [xs, ps], [ca.vertcat(*body), objective])
        opti = self.opti = ca.Opti()
        self.X, self.P = opti.variable(len(self.variables)), opti.parameter(len(self.params))
        self.LBX, self.UBX = opti.parameter(len(self.variables)), opti.parameter(len(self.variables))
        g, f = fn(self.X, self.P)
        opti.subject_to(opti.bounded(ca.DM(lower), g, ca.DM(upper)))
        opti.subject_to(opti.bounded(self.LBX, self.X, self.UBX))
        opti.minimize(f)
        s = mpc.settings
        self.options = {**DEFAULT_OPTIONS, **WARM_OPTIONS, **s.ipopt, "max_wall_time": 10.0}
        opti.solver("ipopt", {"expand": True, "print_time": False, "detect_simple_bounds": True}, self.options)
        fractions = [node_fraction(c, self.n) for c in (*self.rows, *self.variables)]  # Opti's g: rows, then bounds
        self.layout = TimeLayout(np.array(fractions), self.n)
        index = {id(v): i for i, v in enumerate(self.variables)}
        self.first = {c: index[id(self.model.component(c)[0])] for c in mpc.ocp.vehicle.controls}
        plan = mpc.plan  # the MPC's first step starts from this plan's multipliers: the peer's too
        self.prev = None
        if len(plan.mult_g):  # the rows' multipliers (the bounds' start at zero)
            rows = hm.nlp.full_duals(plan.x, plan.mult_g)
            self.prev = (plan.times, np.concatenate([rows, np.zeros(len(self.variables))]))
        self.seconds, self.cpu, self.iterations, self.du, self.status = [], [], [], [], []

    def solve(self, times: np.ndarray, x0: np.ndarray) -> None:
        """The step's problem (the model's Params and bounds as the MPC left them) from the MPC's start."""
        opti = self.opti
        opti.set_value(self.P, [float(pyo.value(q)) for q in self.params])
        bounds = np.array([v.bounds for v in self.variables], dtype=float).reshape(-1, 2)
        opti.set_value(self.LBX, np.nan_to_num(bounds[:, 0], nan=-BIG))
        opti.set_value(self.UBX, np.nan_to_num(bounds[:, 1], nan=BIG))
        opti.set_initial(self.X, self.nlp.full_primals(x0))
        if self.prev is not None:
            old, lam = self.prev
            opti.set_initial(opti.lam_g, self.layout.move(lam, old, times))
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            sol = opti.solve()
        except RuntimeError:  # not converged (iteration cap): its last iterate, counted as unsolved
            sol = opti.debug
        self.seconds.append(time.perf_counter() - t0)
        self.cpu.append(time.process_time() - c0)
        stats = opti.stats()
        self.iterations.append(int(stats.get("iter_count", -1)))
        self.status.append(str(stats.get("return_status", "")))
        x = np.asarray(sol.value(self.X)).ravel()
        lam = np.asarray(sol.value(opti.lam_g)).ravel()
        if lam.size == opti.ng:  # (Opti's debug value after a failed solve may not be the full vector)
            self.prev = (times, lam)
        plan = self.mpc.warm.values
        self.du.append(max(abs(x[i] - plan[c][0]) for c, i in self.first.items()))


def _number(bound) -> bool:
    """None or a plain number (not an expression of Params)."""
    return bound is None or isinstance(bound, int | float)


class Shadowed:
    """The MPC as the loop's controller, with the peer solving each of its steps' problems after it."""

    def __init__(self, mpc: MPC, peer: OptiPeer | None):
        self.mpc, self.peer = mpc, peer
        self.name = mpc.name
        hm, self._last = mpc.horizon, None
        fill = hm.fill_slacks

        def fill_slacks(x):  # the MPC's warm start of the step, complete (a copy: microseconds)
            fill(x)
            self._last = x.copy()

        hm.fill_slacks = fill_slacks

    @property
    def failed(self) -> bool:
        return self.mpc.failed

    @property
    def final_time(self) -> float:
        return self.mpc.final_time

    def make_step(self, t, y, pending):
        self._last = None
        u = self.mpc.make_step(t, y, pending)
        step = self.mpc.steps[-1] if self.mpc.steps else None
        if self.peer is not None and self._last is not None and step is not None and step.get("t") is not None:
            m = self.mpc.horizon.model
            times = np.array([float(m.node_time[t].value) for t in m.nodes])
            self.peer.solve(times, self._last)
        return u


def run(case: str, controller: str, reference_intervals: int, peer: bool, compiled: bool = False,
        qp_changes: int = 0, qp_solver: str = "qpoases", hpipm: dict | None = None,
        interval_samples: int = INTERVAL_SAMPLES) -> dict:  # fmt: skip
    sc = load_scenario(ROOT / CASES[case])
    t0 = time.perf_counter()
    sol = sc.ocp.solve(intervals=reference_intervals)
    solve_seconds = time.perf_counter() - t0
    control, disturbance = ControlSettings(SAMPLE, HORIZON, interval_samples), Disturbance()
    qp_options = {"nWSR": qp_changes} if qp_changes else {}
    if qp_solver == "hpipm":  # the stagewise QP: its options are hpipm's
        qp_options = dict(hpipm or {})
    settings = MPCSettings(realtime=controller == "rti", rti_compiled=compiled, qp_options=qp_options,
                           qp_solver=qp_solver)  # fmt: skip
    mpc = MPC(sol, control, disturbance, settings=settings)
    shadow = Shadowed(mpc, OptiPeer(mpc) if peer else None)
    load_before = os.getloadavg()[0]
    loop = simulate(sc, sol, shadow, disturbance, control)
    load_after = os.getloadavg()[0]
    steps = [s for s in mpc.steps if "seconds" in s]
    wall = np.array([s["seconds"] for s in steps])
    cpu = np.array([s["cpu_seconds"] for s in steps])
    v = sc.ocp.vehicle
    gaps = clearances(sc.ocp, {s: loop.columns[s] for s in v.states})
    worst = np.min(np.vstack(list(gaps.values())), axis=0)
    row = {
        "case": case, "controller": controller, "N": mpc.horizon.n, "reference_ok": bool(sol.ok),
        "reference_seconds": solve_seconds, "columns": mpc.horizon.nlp.n_primals(),
        "rows": mpc.horizon.nlp.n_constraints(), "steps": len(steps),
        "realtime": sum(1 for s in steps if s.get("realtime")),
        "fallback": sum(1 for s in steps if not s.get("realtime")) if controller == "rti" else 0,
        "failed": sum(1 for s in steps if not s.get("used", True)),
        "mean": wall.mean(), "max": wall.max(), "cpu_mean": cpu.mean(), "cpu_max": cpu.max(),
        "reached": bool(loop.summary["reached_goal"]), "position_error": loop.summary["final_position_error"],
        "heading_error": loop.summary["final_heading_error"], "min_clearance": float(worst.min()),
        "samples_outside": int(np.sum(worst < 0)), "samples": int(worst.size),
        "min_distance_moving": loop.summary["min_distance_moving"],
        "load": (load_before, load_after),
    }  # fmt: skip
    if peer:
        p = shadow.peer
        row |= {"peer_mean": float(np.mean(p.seconds)), "peer_max": float(np.max(p.seconds)),
                "peer_cpu_mean": float(np.mean(p.cpu)), "peer_cpu_max": float(np.max(p.cpu)),
                "peer_it": float(np.mean(p.iterations)), "peer_steps": len(p.seconds),
                "peer_unsolved": sum(1 for s in p.status if s not in ("Solve_Succeeded", "Solved_To_Acceptable_Level")),
                "du_median": float(np.median(p.du)), "du_max": float(np.max(p.du))}  # fmt: skip
    return row


HEAD = ("| case | controller | columns x rows | steps (RTI / fallback / failed) | mean s | max s | CPU mean s | "
        "CPU max s | Opti mean s | Opti max s | Opti iters | ratio mean (max) | du median (max) | goal | "
        "end error m / rad | exact corridor: min clearance m, samples outside | car: min distance m | "
        "load |")  # fmt: skip


def line(r: dict) -> str:
    peer = " - | - | - | - | - |"
    car = "-" if r["min_distance_moving"] is None else f"{r['min_distance_moving']:.3f}"
    if "peer_mean" in r:
        ratio = f"{r['mean'] / r['peer_mean']:.3f} ({r['max'] / r['peer_max']:.3f})"
        peer = (f" {r['peer_mean']:.4f} | {r['peer_max']:.4f} | {r['peer_it']:.1f} "
                f"({r['peer_unsolved']} unsolved) | {ratio} | {r['du_median']:.1e} ({r['du_max']:.1e}) |")  # fmt: skip
    return (f"| {r['case']} | {r['controller']} | {r['columns']} x {r['rows']} | {r['steps']} ({r['realtime']} / "
            f"{r['fallback']} / {r['failed']}) | {r['mean']:.4f} | {r['max']:.4f} | {r['cpu_mean']:.4f} | "
            f"{r['cpu_max']:.4f} |{peer} {'yes' if r['reached'] else 'no'} | "
            f"{r['position_error']:.2g} / {r['heading_error']:.2g} | {r['min_clearance']:.3f}, "
            f"{r['samples_outside']} of {r['samples']} | {car} | "
            f"{r['load'][0]:.1f} -> {r['load'][1]:.1f} |")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--controllers", nargs="+", default=["rti", "ipopt"], choices=["rti", "ipopt"])
    ap.add_argument("--reference-intervals", type=int, default=100)
    ap.add_argument("--no-peer", action="store_true")
    ap.add_argument("--compiled", action="store_true", help="the RTI's first-order functions as compiled C")
    ap.add_argument("--qp-max-changes", type=int, default=0,
                    help="cap on qpOASES' working-set changes per step (nWSR; 0: its default)")  # fmt: skip
    ap.add_argument("--qp-solver", default="qpoases", choices=["qpoases", "hpipm"],
                    help="the RTI's QP: condensed and dense (qpoases) or stagewise (hpipm)")
    ap.add_argument("--hpipm-mode", default=None, help="hpipm's mode (speed_abs, speed, balance, robust)")
    ap.add_argument("--hpipm-iter-max", type=int, default=0, help="hpipm's iteration cap (0: the default)")
    ap.add_argument("--interval-samples", type=int, default=INTERVAL_SAMPLES,
                    help="samples per prediction interval (control.interval_samples; must divide the horizon)")
    args = ap.parse_args(argv)
    if args.interval_samples < 1 or HORIZON % args.interval_samples or HORIZON // args.interval_samples < 2:
        ap.error(f"--interval-samples must divide the horizon of {HORIZON} samples into at least 2 intervals")
    hpipm = {k: v for k, v in (("mode", args.hpipm_mode), ("iter_max", args.hpipm_iter_max)) if v}
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, CasADi {ca.__version__}, load average {os.getloadavg()[0]:.2f}; "
          f"{SAMPLE:g} s samples, horizon {HORIZON} samples ({SAMPLE * HORIZON:g} s) in "
          f"{HORIZON // args.interval_samples} intervals of {args.interval_samples}")  # fmt: skip
    print(HEAD)
    print("|" + "---|" * (HEAD.count("|") - 1))
    for case in args.cases:
        for controller in args.controllers:
            row = run(case, controller, args.reference_intervals, not args.no_peer, args.compiled, args.qp_max_changes,
                      args.qp_solver, hpipm, interval_samples=args.interval_samples)  # fmt: skip
            print(line(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
