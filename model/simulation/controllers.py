"""Two controllers of the closed loop: the optimum replayed, and a time-varying LQR around it.

Both read the open-loop optimum (a ``Solution``: node times, states, controls) at the sample
times t_k = k h. The control of a sample is the *sample mean* of the optimum's piecewise-linear
node controls over [t_k, min(t_k + h, Tf)] (exact integral of the interpolant divided by the
length): the zero-order hold that moves the vehicle as the optimum does to second order in h.
Bounds hold, since a mean of values within bounds is within them. After Tf the optimum sends zeros.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from model.direct.solution import Solution
from model.problem.closed_loop import ControlSettings, Disturbance
from model.simulation.plant import Plant

JACOBIAN_RTOL = 1e-9
HEADING_TOL = 0.05  # rad: the error scale of headings in the LQR weights (Bryson's rule)
STEERING_SCALE = 0.2  # rad: the error scale of the steering angle
POSITION_SHARE = 0.01  # the error scale of positions: this share of the start-goal distance
TERMINAL_FACTOR = 10.0  # terminal weight = this times the stage weight


def sample_grid(final_time: float, sample_time: float) -> np.ndarray:
    """Sample instants 0, h, 2h, ... below Tf, then Tf: the last sample may be shorter than h."""
    count = max(1, int(np.ceil(final_time / sample_time - 1e-9)))
    return np.append(np.arange(count) * sample_time, final_time)


def interval_means(t: np.ndarray, values: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean over each [a_i, b_i] of the piecewise-linear interpolant of (t, values), zero outside [t0, tN]."""
    cum = np.concatenate([[0.0], np.cumsum(np.diff(t) * (values[1:] + values[:-1]) / 2)])

    def integral(s: np.ndarray) -> np.ndarray:
        s = np.clip(s, t[0], t[-1])
        i = np.clip(np.searchsorted(t, s, side="right") - 1, 0, len(t) - 2)
        ds = s - t[i]
        slope = (values[i + 1] - values[i]) / (t[i + 1] - t[i])
        return cum[i] + ds * (values[i] + 0.5 * slope * ds)

    width = np.maximum(b - a, 1e-300)
    return (integral(b) - integral(a)) / width


class Reference:
    """The optimum at the sample times: node states interpolated, controls as sample means.

    Parameters
    ----------
    solution : Solution
        The open-loop optimum.
    sample_time : float
        h, s.
    """

    def __init__(self, solution: Solution, sample_time: float):
        vehicle = solution.ocp.vehicle
        cols = solution.columns
        self.solution = solution
        self.sample_time = float(sample_time)
        self.final_time = float(cols["t"][-1])
        self.grid = sample_grid(self.final_time, self.sample_time)
        self.durations = np.diff(self.grid)
        t = np.asarray(cols["t"], dtype=float)
        self.states = np.column_stack([np.interp(self.grid, t, cols[s]) for s in vehicle.states])
        a, b = self.grid[:-1], self.grid[1:]
        self.controls = np.column_stack([interval_means(t, np.asarray(cols[c], float), a, b) for c in vehicle.controls])

    @property
    def samples(self) -> int:
        """K, the number of samples from 0 to Tf."""
        return len(self.durations)

    def index(self, t: float) -> int:
        """The sample that starts at (or just before) ``t``."""
        return int(np.searchsorted(self.grid, t + 1e-9 * self.sample_time, side="right") - 1)

    def control(self, k: int) -> np.ndarray:
        """The optimum's control for sample ``k`` (zeros from Tf on)."""
        if 0 <= k < self.samples:
            return self.controls[k].copy()
        return np.zeros(self.controls.shape[1])


class OpenLoop:
    """The optimal controls replayed: at t_k the sample mean of the optimum's controls over [t_k, t_k + h).

    It ignores the measurement and the delay (pure feed-forward); after Tf it sends zeros.

    Parameters
    ----------
    solution : Solution
        The open-loop optimum.
    control : ControlSettings
        The sample time.
    """

    name = "open-loop (optimal controls, sample means under zero-order hold)"

    def __init__(self, solution: Solution, control: ControlSettings):
        self.reference = Reference(solution, control.sample_time)
        self.failed = False

    def make_step(self, t: float, y: np.ndarray, pending: np.ndarray) -> np.ndarray:
        """The optimum's control for the sample starting at ``t``."""
        return self.reference.control(self.reference.index(t))


class Tracking:
    """Time-varying LQR around the optimal trajectory.

    The nominal model (the scenario's vehicle, no disturbance) is linearised along the optimum
    at every sample from its SymPy Jacobians and discretised exactly under the zero-order hold
    (the variational equations integrated over the sample); a backward Riccati recursion over the
    samples gives the gains. Weights by Bryson's rule: position errors of 1 % of the start-goal
    distance, headings 0.05 rad, steering angle 0.2 rad, controls their bound. The controller knows
    the actuator delay (nothing else of the disturbance): it predicts the state through the pending
    controls with the nominal model and computes the control for the sample it will act on. Heading
    errors are wrapped to (-pi, pi]; controls are clipped to the OCP's bounds, u2 also so that the
    predicted steering angle stays within its bounds.

    Parameters
    ----------
    solution : Solution
        The open-loop optimum.
    control : ControlSettings
        The sample time.
    disturbance : Disturbance
        Only its delay is used.
    """

    name = "tracking (time-varying LQR)"

    def __init__(self, solution: Solution, control: ControlSettings, disturbance: Disturbance):
        ocp = solution.ocp
        self.vehicle = ocp.vehicle
        self.reference = ref = Reference(solution, control.sample_time)
        self.delay_samples = control.delay_samples(disturbance)
        self.model = Plant(self.vehicle, Disturbance(), control.sample_time)
        self.bounds = np.array([ocp.bounds[c] for c in self.vehicle.controls])
        self.angles = np.array([s in self.vehicle.roles.headings for s in self.vehicle.states])
        self.rate_limit = _rate_limit(ocp)
        A, B = discretise(self.vehicle, ref.states[:-1], ref.controls, ref.durations)
        Q, R = weights(ocp)
        self.gains = riccati(A, B, Q, R, TERMINAL_FACTOR * Q)
        self.failed = False

    def make_step(self, t: float, y: np.ndarray, pending: np.ndarray) -> np.ndarray:
        """The control for the sample the delay makes it act on, from the predicted state there."""
        ref = self.reference
        k = ref.index(t)
        x = np.asarray(y, dtype=float)
        for i, u in enumerate(np.reshape(pending, (-1, len(self.vehicle.controls)))):
            if k + i >= ref.samples:
                break
            x = self.model.step(x, u, ref.durations[k + i])
        j = k + self.delay_samples
        if j >= ref.samples:
            return np.zeros(len(self.vehicle.controls))
        error = x - ref.states[j]
        error[self.angles] = wrap(error[self.angles])
        u = np.clip(ref.controls[j] - self.gains[j] @ error, self.bounds[:, 0], self.bounds[:, 1])
        if self.rate_limit is not None:
            i, s, lo, hi = self.rate_limit
            u[i] = np.clip(u[i], (lo - x[s]) / ref.durations[j], (hi - x[s]) / ref.durations[j])
        return u


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return -((-np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi)


def weights(ocp) -> tuple[np.ndarray, np.ndarray]:
    """Stage weights Q (states) and R (controls) by Bryson's rule: 1 / (acceptable error)^2."""
    v = ocp.vehicle
    distance = ocp.straight_distance() or 1.0
    scale = {s: HEADING_TOL if s in v.roles.headings else STEERING_SCALE for s in v.states}
    scale.update(dict.fromkeys(v.position, POSITION_SHARE * max(distance, 1e-6)))
    Q = np.diag([1.0 / scale[s] ** 2 for s in v.states])
    R = np.diag([1.0 / max(abs(lo), abs(hi), 1e-9) ** 2 for lo, hi in (ocp.bounds[c] for c in v.controls)])
    return Q, R


def _rate_limit(ocp) -> tuple[int, int, float, float] | None:
    """(control index, state index, lower, upper) when a bounded state's derivative is a control (phi' = u2)."""
    v = ocp.vehicle
    f = v.dynamics()
    for s, (lo, hi) in ocp.bounds.items():
        if s in v.states and isinstance(f[s], sp.Symbol) and f[s].name in v.controls:
            return v.controls.index(f[s].name), v.states.index(s), lo, hi
    return None


def jacobians(vehicle):
    """NumPy functions df/dx(x, u), df/du(x, u) of the vehicle's SymPy dynamics (derived once)."""
    rhs = sp.Matrix(vehicle.rhs(numeric=True))
    xs, us = vehicle.state_symbols(), vehicle.control_symbols()
    return sp.lambdify(xs + us, rhs.jacobian(xs), "numpy"), sp.lambdify(xs + us, rhs.jacobian(us), "numpy")


def discretise(vehicle, states: np.ndarray, controls: np.ndarray, durations: np.ndarray):
    """Exact zero-order-hold linearisations (A_k, B_k) along the samples: the variational equations.

    From each reference state x_k with u_k held for the sample's duration, integrate
    x' = f(x, u), Phi' = A(x, u) Phi (Phi(0) = I), Gamma' = A(x, u) Gamma + B(x, u) (Gamma(0) = 0).
    """
    from scipy.integrate import solve_ivp

    f, (fx, fu) = vehicle.rhs_function(), jacobians(vehicle)
    n, m = states.shape[1], controls.shape[1]

    def rhs(_t, z, u):
        x, phi, gamma = z[:n], z[n : n + n * n].reshape(n, n), z[n + n * n :].reshape(n, m)
        a = np.array(fx(*x, *u), dtype=float)
        b = np.array(fu(*x, *u), dtype=float)
        return np.concatenate([f(x, u), (a @ phi).ravel(), (a @ gamma + b).ravel()])

    A, B = np.empty((len(durations), n, n)), np.empty((len(durations), n, m))
    for k, (x0, u, h) in enumerate(zip(states, controls, durations, strict=True)):
        z0 = np.concatenate([x0, np.eye(n).ravel(), np.zeros(n * m)])
        z = solve_ivp(rhs, (0.0, h), z0, args=(u,), rtol=JACOBIAN_RTOL, atol=JACOBIAN_RTOL).y[:, -1]
        A[k], B[k] = z[n : n + n * n].reshape(n, n), z[n + n * n :].reshape(n, m)
    return A, B


def riccati(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, Qf: np.ndarray) -> np.ndarray:
    """Gains K_k of the finite-horizon discrete LQR (u_k = -K_k dx_k), by the backward Riccati recursion."""
    P = Qf.copy()
    gains = np.empty((len(A), B.shape[2], A.shape[1]))
    for k in range(len(A) - 1, -1, -1):
        a, b = A[k], B[k]
        gains[k] = np.linalg.solve(R + b.T @ P @ b, b.T @ P @ a)
        P = Q + a.T @ P @ (a - b @ gains[k])
        P = (P + P.T) / 2
    return gains


__all__ = ["OpenLoop", "Reference", "Tracking", "discretise", "interval_means", "riccati", "sample_grid", "wrap"]
