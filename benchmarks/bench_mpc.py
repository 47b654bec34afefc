"""Benchmark: NMPC per-step solve times in a nominal closed loop, against a plain CasADi Opti peer.

Usage: python benchmarks/bench_mpc.py [--cases real-s1 real-s2 paper paper-fine road road-truck road-semitrailer]
       [--no-peer]

The road cases with bodies ``road-truck`` and ``road-semitrailer`` (the roundabout at 10 Hz, a 4 s
horizon, the real-time iteration and warm-started Ipopt, each beside a plain CasADi Opti peer of the
same horizon problem) are benchmarks/bench_mpc_road.py's (its docstring; a table of their own).

For each case (scenario, sample time, horizon 40, a disturbance or none) the truck is integrated
accurately (scipy, rtol 1e-10) under a zero-order hold; ``model.simulation.mpc.MPC`` is called
once per sample and timed (wall seconds of ``make_step``, the loop's own measure). The open-loop
replay of the optimum's controls runs through the same disturbed integrator.

The peer shadows the controller in the same run: at every step it is handed the same problem
(start state, horizon length, terminal target and weights, and the MPC's disturbance estimate on
the state rates: offset-free MPC) and solves the same horizon OCP written
in plain CasADi Opti (trapezoid defects, soft terminal target, soft keep-out slacks, the same cost
and Ipopt options), warm-started the same way: its own previous primal and dual point moved onto
the new grid in time (model.simulation.mpc.TimeLayout). Ratio = our mean (max) step seconds over
the peer's; ``du`` is the difference of the first planned controls, median and largest over the
steps (the same OCP gives the same answer up to the tolerance; a step stopped by the iteration cap
or an acceptable-level stop on a singular arc may differ). The road case (a body in a roundabout
corridor) has no peer.

Prints the machine, then one Markdown table row per case.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: the RTI's small dense algebra, no thread contention
os.environ.setdefault("OMP_NUM_THREADS", "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.problem.closed_loop import ControlSettings  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402
from model.simulation.mpc import MPC, TimeLayout  # noqa: E402

SCENARIOS = ROOT / "workflows" / "scenarios"
CASES = {  # name: (scenario, sample time, speed gain, steering bias)
    "real-s1": ("time-real-s1", 0.1, 0.95, 0.02),
    "real-s2": ("time-real-s2", 0.1, 0.95, 0.02),
    "paper": ("s2-case1", 0.1, 0.97, 0.005),
    "paper-fine": ("s2-case1", 0.05, 0.97, 0.005),
    "road": ("../roads/truck-straight-on", 0.1, 0.95, 0.02),  # 8 m body in the corridor: no peer
}
ROAD_CASES = {"road-truck": "truck", "road-semitrailer": "semitrailer"}  # benchmarks/bench_mpc_road.py


def plant(d: float, gain: float, bias: float):
    def f(_t, s, u):
        v = gain * u[0]
        return [v * math.cos(s[2]), v * math.sin(s[2]), v * math.tan(s[3] + bias) / d, u[1]]

    return f


def simulate(controller, x0, end, dt, f) -> tuple[np.ndarray, float, list[float]]:
    """Zero-order hold until ``end()``; final state, energy, per-step controller seconds."""
    t, x, energy, seconds = 0.0, np.array(x0, float), 0.0, []
    while t < end() - 1e-9:
        t0 = time.perf_counter()
        u = np.asarray(controller(t, x, np.zeros((0, 2))), float)
        seconds.append(time.perf_counter() - t0)
        h = min(dt, end() - t)
        x = solve_ivp(f, (t, t + h), x, args=(u,), rtol=1e-10, atol=1e-10).y[:, -1]
        energy += 0.5 * h * float(u @ u)
        t += h
    return x, energy, seconds


class OptiPeer:
    """The MPC's horizon OCP in plain CasADi Opti (truck only), warm-started like the MPC."""

    def __init__(self, mpc: MPC):
        hm, s, ocp = mpc.horizon, mpc.settings, mpc.ocp
        self.mpc, self.n, n = mpc, hm.n, hm.n
        self.free = ocp.cost.free_final_time
        opti = self.opti = ca.Opti()
        X = [opti.variable(1, n + 1) for _ in range(4)]  # one row per state: consecutive nodes
        U = [opti.variable(1, n + 1) for _ in range(2)]
        self.T = opti.variable() if self.free else opti.parameter()
        obstacles = ocp.obstacles
        S = [opti.variable(1, n + 1) for _ in obstacles]
        above, below = opti.variable(4), opti.variable(4)
        self.x0, self.target, self.weight = opti.parameter(4), opti.parameter(4), opti.parameter(4)
        self.dist = opti.parameter(4)  # the MPC's disturbance estimate on the state rates
        self.w_time, self.w_energy = opti.parameter(), opti.parameter()
        d, h = ocp.vehicle.wheelbase, self.T / n
        x, y, th, ph = X
        u1, u2 = U
        rhs = [u1 * ca.cos(th), u1 * ca.sin(th), u1 * ca.tan(ph) / d, u2]
        g_frac = []  # each constraint entry's place in the horizon (TimeLayout)
        nodes, steps = np.arange(n + 1) / n, np.arange(1, n + 1) / n
        for k in range(4):
            opti.subject_to(X[k][1:] - X[k][:-1] == h / 2 * (rhs[k][:-1] + rhs[k][1:]) + h * self.dist[k])
            g_frac.append(steps)
        for k in range(4):
            opti.subject_to(X[k][0] == self.x0[k])
            g_frac.append([np.nan])
        for name, var in (("phi", ph), ("u1", u1), ("u2", u2)):
            lo, hi = ocp.bounds[name]
            opti.subject_to(opti.bounded(lo, var, hi))
            g_frac.append(nodes)
        scales = hm.scales
        for k in range(4):
            opti.subject_to((X[k][n] - self.target[k]) / scales[k] == above[k] - below[k])
            g_frac.append([np.nan])
        opti.subject_to(above >= 0)
        opti.subject_to(below >= 0)
        g_frac += [[np.nan] * 4] * 2
        for ob, slack in zip(obstacles, S, strict=True):
            R = ob.keep_out
            opti.subject_to((x - ob.center[0]) ** 2 + (y - ob.center[1]) ** 2 >= (R - slack) ** 2)
            opti.subject_to(opti.bounded(0, slack, R))
            g_frac += [nodes, nodes]
        if self.free:  # fixed (lower = upper) while the horizon recedes, as the MPC's bounds on tf
            self.T_lo, self.T_hi = opti.parameter(), opti.parameter()
            opti.subject_to(self.T >= self.T_lo)
            opti.subject_to(self.T <= self.T_hi)
            g_frac += [[np.nan], [np.nan]]
        L = (u1**2 + u2**2) / 2
        energy = h * (ca.sum2(L) - (L[0] + L[n]) / 2)
        t_s, e_s = mpc._cost_scales()
        terms = [self.weight[k] * (s.terminal_l1 * (above[k] + below[k])
                                   + s.terminal_quadratic * (above[k] - below[k]) ** 2) for k in range(4)]  # fmt: skip
        slack_sum = sum(ca.sum2(v) for v in S) if S else 0
        opti.minimize(self.w_time * self.T / t_s + self.w_energy * energy / e_s + sum(terms)
                      + s.obstacle_l1 / mpc._path_length() * slack_sum)  # fmt: skip
        self.X, self.U = X, U
        x_frac = [nodes] * 6 + [[np.nan]] * (1 if self.free else 0) + [nodes] * len(S) + [[np.nan] * 8]
        self.x_layout = TimeLayout(np.concatenate([np.ravel(f) for f in x_frac]), n)
        self.g_layout = TimeLayout(np.concatenate([np.ravel(f) for f in g_frac]), n)
        self.prev = None
        self.seconds: list[float] = []
        self.iterations: list[int] = []
        self.du: list[float] = []

    def configure(self, options: dict) -> None:
        self.opti.solver("ipopt", {"expand": True, "print_time": False, "detect_simple_bounds": True}, options)

    def solve(self, start: float, state: dict, length: float, free: bool, target: dict, weights: dict,
              disturbance: np.ndarray | None = None) -> None:  # fmt: skip
        """Solve the step's problem (same data as the MPC's) from the shifted previous solution."""
        opti, n = self.opti, self.n
        t0 = time.perf_counter()
        states = ("x", "y", "theta", "phi")
        opti.set_value(self.x0, [state[k] for k in states])
        opti.set_value(self.dist, np.zeros(4) if disturbance is None else disturbance)
        opti.set_value(self.target, [target[k] for k in states])
        opti.set_value(self.weight, [weights[k] for k in states])
        opti.set_value(self.w_time, 1.0 if free else 0.0)
        opti.set_value(self.w_energy, self.mpc.settings.time_energy if free else 1.0)
        if not self.free:
            opti.set_value(self.T, length)
        else:
            opti.set_value(self.T_lo, 1e-3 if free else length)
            opti.set_value(self.T_hi, 1e6 if free else length)
        times = start + np.linspace(0.0, length, n + 1)
        if self.prev is None:  # the MPC's own start: the reference on the grid
            ref = self.mpc.reference
            for var, name in zip(self.X + self.U, states + ("u1", "u2"), strict=True):
                opti.set_initial(var, np.interp(times, ref["t"], ref[name]))
            if self.free:
                opti.set_initial(self.T, length)
        else:
            old_times, x_prev, lam_prev = self.prev
            opti.set_initial(opti.x, self.x_layout.move(x_prev, old_times, times))
            opti.set_initial(opti.lam_g, self.g_layout.move(lam_prev, old_times, times))
            for k, name in enumerate(states):
                opti.set_initial(self.X[k][0], state[name])
        try:
            sol = opti.solve()
            x, lam = sol.value(opti.x), sol.value(opti.lam_g)
            u_first = [sol.value(u[0]) for u in self.U]
            length = float(sol.value(self.T)) if self.free else length
        except RuntimeError:
            x, lam = opti.debug.value(opti.x), opti.debug.value(opti.lam_g)
            u_first = [opti.debug.value(u[0]) for u in self.U]
        self.seconds.append(time.perf_counter() - t0)
        self.iterations.append(int(opti.stats().get("iter_count", -1)))
        self.prev = (start + np.linspace(0.0, length, n + 1), np.asarray(x).ravel(), np.asarray(lam).ravel())
        ours = self.mpc.warm.values
        self.du.append(max(abs(u_first[0] - ours["u1"][0]), abs(u_first[1] - ours["u2"][0])))


def shadow(mpc: MPC, peer: OptiPeer) -> None:
    """Hand the peer every problem the MPC sets up (after the MPC's own step, untimed for it)."""
    queue = []
    original = mpc.horizon.set_problem

    def set_problem(start, length, free, target, weights, disturbance=None, times=None):
        d = None if disturbance is None else np.array(disturbance, dtype=float)
        queue.append((dict(start), length, free, dict(target), dict(weights), d))
        original(start, length, free, target, weights, disturbance, times)

    mpc.horizon.set_problem = set_problem
    original_step = mpc.make_step

    def make_step(t, y, pending):
        u = original_step(t, y, pending)
        if queue and mpc.steps:
            step_start = mpc.steps[-1]["t"]
            peer.solve(step_start, *queue.pop())
        queue.clear()
        return u

    mpc.make_step = make_step


def replay(cols: dict):
    """The open-loop controller: the optimum's controls at the sample times."""

    def control(t, _y, _pending):
        return np.array([np.interp(t, cols["t"], cols[c]) for c in ("u1", "u2")])

    return control


def run_case(name: str, peer: bool) -> list[dict]:
    scenario, dt, gain, bias = CASES[name]
    sc = load_scenario(SCENARIOS / f"{scenario}.toml")
    sol = sc.ocp.solve(intervals=sc.intervals)
    ocp = sol.ocp
    x0 = [ocp.initial[k] for k in ocp.vehicle.states]
    fin = ocp.final
    rows = []
    for disturbed in (False, True):
        f = plant(ocp.vehicle.wheelbase, gain if disturbed else 1.0, bias if disturbed else 0.0)
        mpc = MPC(sol, ControlSettings(dt, 40))
        opti = None
        if peer and ocp.road is None:
            opti = OptiPeer(mpc)
            opti.configure({**_ipopt_defaults(), **_warm(), **mpc.settings.ipopt, "max_wall_time": 10.0})
            length, free = mpc._horizon(0.0)  # the peer's first solve: the MPC's construction-time one
            opti.solve(0.0, dict(ocp.initial), length, free, *mpc._target(length, True))
            opti.seconds, opti.iterations, opti.du = [], [], []
            shadow(mpc, opti)
        x, energy, _ = simulate(mpc.make_step, x0, lambda m=mpc: m.final_time, dt, f)
        xo, _, _ = simulate(replay(sol.columns), x0, lambda: sol.final_time, dt, f)
        secs = np.array([s["seconds"] for s in mpc.steps if "seconds" in s])
        its = np.array([s.get("iterations", 0) for s in mpc.steps])
        row = {
            "case": f"{name} " + (f"g={gain:g} b={bias:g}" if disturbed else "undisturbed"),
            "N": mpc.horizon.n,
            "dt": dt,
            "steps": len(mpc.steps),
            "mean": secs.mean(),
            "max": secs.max(),
            "rt": secs.max() / dt,
            "it": f"{its.mean():.1f}/{its.max()}",
            "failed": sum(1 for s in mpc.steps if not s.get("used", True)),
            "truncated": sum(1 for s in mpc.steps if s.get("truncated")),
            "err": math.hypot(x[0] - fin["x"], x[1] - fin["y"]),
            "heading": abs(x[2] - fin["theta"]),
            "err_open": math.hypot(xo[0] - fin["x"], xo[1] - fin["y"]),
            "energy": energy / sol.energy - 1,
            "time": mpc.final_time / sol.final_time - 1,
        }
        if opti is not None:
            ps = np.array(opti.seconds)
            row |= {"peer_mean": ps.mean(), "peer_max": ps.max(), "peer_it": np.mean(opti.iterations),
                    "du": float(np.median(opti.du)), "du_max": max(opti.du)}  # fmt: skip
        rows.append(row)
    return rows


def _ipopt_defaults() -> dict:
    from model.nlp.ipopt import DEFAULT_OPTIONS

    return dict(DEFAULT_OPTIONS)


def _warm() -> dict:
    from model.direct.resolve import WARM_OPTIONS

    return dict(WARM_OPTIONS)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    every = list(CASES) + list(ROAD_CASES)
    ap.add_argument("--cases", nargs="+", default=every, choices=every)
    ap.add_argument("--no-peer", action="store_true")
    args = ap.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, CasADi {ca.__version__}, load average {load:.2f}")  # fmt: skip
    head = ("| case | N | dt s | steps | mean s | max s | max/dt | iters mean/max | failed (truncated) "
            "| end error m / rad | open-loop m | energy | arrival |")  # fmt: skip
    sep = "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    if not args.no_peer:
        head += " Opti mean s | Opti max s | Opti iters | ratio mean (max) | du median (max) |"
        sep += "---|---|---|---|---|"
    print(head)
    print(sep)
    for name in (c for c in args.cases if c in CASES):
        for r in run_case(name, not args.no_peer):
            line = (f"| {r['case']} | {r['N']} | {r['dt']:g} | {r['steps']} | {r['mean']:.4f} | {r['max']:.4f} | "
                    f"{r['rt']:.2f} | {r['it']} | {r['failed']} ({r['truncated']}) | "
                    f"{r['err']:.3g} / {r['heading']:.2g} | "
                    f"{r['err_open']:.3g} | "
                    f"{r['energy']:+.2%} | {r['time']:+.2%} |")  # fmt: skip
            if not args.no_peer and "peer_mean" not in r:
                line += " - | - | - | - | - |"
            if "peer_mean" in r:
                ratio = f"{r['mean'] / r['peer_mean']:.2f} ({r['max'] / r['peer_max']:.2f})"
                du = f"{r['du']:.1e} ({r['du_max']:.1e})"
                line += f" {r['peer_mean']:.4f} | {r['peer_max']:.4f} | {r['peer_it']:.1f} | {ratio} | {du} |"
            print(line, flush=True)
    road = [ROAD_CASES[c] for c in args.cases if c in ROAD_CASES]
    if road:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import bench_mpc_road

        print()
        bench_mpc_road.main(["--cases", *road, *(["--no-peer"] if args.no_peer else [])])
    return 0


if __name__ == "__main__":
    sys.exit(main())
