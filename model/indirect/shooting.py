"""Indirect refinement: single shooting on the Pontryagin boundary-value problem.

For an energy problem whose controls stay strictly inside their bounds (no obstacle
contact), the maximum condition gives u = psi(x, p) and the extremals solve
x' = f(x, psi), p' = -dH/dx, all from the derivation engine (``derivations.pmp``).
The unknowns are p(0); the residuals are the fixed final states and p_i(Tf) = 0 for
the free ones. The direct solution's p(0) starts the Newton-type iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from model.problem.ocp import OCP

RTOL, ATOL = 1e-12, 1e-13


@dataclass
class ShootingResult:
    """p(0), the residual norm, J by quadrature along the extremal, and the control range."""

    success: bool
    p0: np.ndarray
    residual: float
    objective: float
    max_control_ratio: float
    nfev: int
    message: str


def extremal_rhs(ocp: OCP):
    """Numpy rhs(t, z) of z = (x, p, J) with u = the unconstrained maximiser of H."""
    from derivations.pmp import derive

    if ocp.obstacles:
        raise ValueError("shooting is implemented for obstacle-free problems only")
    pmp = derive(ocp)
    subs = {law.control: law.stationary for law in pmp.laws}
    if any(v is None for v in subs.values()):
        raise ValueError("shooting needs a strictly concave H (the energy objective)")
    vals = pmp.parameters
    args = [*pmp.states, *pmp.costates]
    exprs = [e.subs(subs).subs(vals) for e in [*pmp.dynamics, *pmp.adjoint, pmp.lagrangian]]
    fn = sp.lambdify(args, exprs, "numpy")
    controls = sp.lambdify(args, [subs[u].subs(vals) for u in pmp.controls], "numpy")
    n = len(pmp.states)

    def rhs(_t: float, z: np.ndarray) -> np.ndarray:
        return np.array(fn(*z[: 2 * n]), dtype=float)

    return rhs, controls, n


def shoot(ocp: OCP, p0_guess: np.ndarray) -> ShootingResult:
    """Solve the shooting equations for p(0) from ``p0_guess`` (scipy least_squares, 'lm')."""
    rhs, controls, n = extremal_rhs(ocp)
    states = list(ocp.vehicle.states)
    x0 = np.array([ocp.initial[s] for s in states])
    tf = float(ocp.final_time)

    def integrate(p0: np.ndarray):
        z0 = np.concatenate([x0, p0, [0.0]])
        return solve_ivp(rhs, (0.0, tf), z0, method="DOP853", rtol=RTOL, atol=ATOL, dense_output=True)

    def residual(p0: np.ndarray) -> np.ndarray:
        end = integrate(p0).y[:, -1]
        return np.array([end[i] - ocp.final[s] if s in ocp.final else end[n + i] for i, s in enumerate(states)])

    fit = least_squares(residual, np.asarray(p0_guess, float), method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    sol = integrate(fit.x)
    t = np.linspace(0.0, tf, 401)
    z = sol.sol(t)
    u = np.array(controls(*z[: 2 * n]), dtype=float)
    ratio = max(
        float(np.max(np.abs(u[i]))) / max(abs(b) for b in ocp.bounds[c]) for i, c in enumerate(ocp.vehicle.controls)
    )
    res = float(np.max(np.abs(residual(fit.x))))
    return ShootingResult(
        bool(fit.success and res < 1e-9), fit.x, res, float(sol.y[-1, -1]), ratio, int(fit.nfev), fit.message
    )


def example_problem() -> OCP:
    """Obstacle-free energy problem with unsaturated controls: (0,0,0,0) -> (1, 0.3, 0.5), phi(Tf) free."""
    from model.problem.costs import Energy
    from model.vehicles import Truck

    truck = Truck(wheelbase=0.1)
    r = truck.roles
    return OCP(
        vehicle=truck,
        cost=Energy(),
        final_time=2.0,
        bounds={r.speed: (-1.0, 1.0), r.steering_rate: (-0.35, 0.35), r.steering: (-0.6, 0.6)},
        initial={r.x: 0.0, r.y: 0.0, r.heading: 0.0, r.steering: 0.0},
        final={r.x: 1.0, r.y: 0.3, r.heading: 0.5},
        name="indirect",
    )


def richardson(values: list[float], order: float = 2.0) -> float:
    """Extrapolate the last two of values on grids halving h, for an error of O(h^order)."""
    a, b = values[-2], values[-1]
    return b + (b - a) / (2**order - 1)
