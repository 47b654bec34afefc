"""The MPC's prediction model and its disturbance estimator (kept apart from the controller, as
do-mpc keeps its estimator apart from its optimizer).

Offset-free MPC (Pannocchia & Rawlings 2003; Maeder, Borrelli & Morari 2009): the prediction model
is x' = f(x, u) + d with a constant disturbance d on the rates of the position and heading states.
At each sample d is updated from the prediction error over the last ``window`` samples: x_pred is
the measurement then, carried to now under the controls applied since by f + d_hat (RK4); with h
that time, d_hat <- d_hat + alpha (y - x_pred) / h, each component saturated at ``share`` of the
largest rate of that state along the reference. A window of 1 is the one-step error; the default 3
divides the measurement noise in (y - x_pred) / h by 3 (real truck: 3 cm of noise at 0.1 s is
0.4 m/s in a one-step rate, as large as the crosswind), measured to end closer on both study
geometries (alpha 0.3 / 0.5, window 1 / 3). The same model f + d_hat predicts through the pending
(delayed) controls and continues a plan's tail. Undisturbed, the prediction error is the
integrator's only, and d_hat stays ~0.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from model.vehicles import Vehicle


class DisturbanceEstimator:
    """The prediction model f(x, u) + d_hat and the estimate d_hat of a constant rate disturbance.

    Parameters
    ----------
    vehicle : Vehicle
        The model whose rates ``f`` predict (``Vehicle.rhs_function``).
    reference : dict of str to ndarray
        The open-loop optimum's columns ("t" and each state): the saturation of the estimate.
    enabled : bool
        Update d_hat from the measurements (else it stays zero: the nominal model).
    gain : float
        The filter gain alpha (0 < alpha <= 1).
    share : float
        Saturation of each estimated rate, as a share of that state's largest rate on the reference.
    window : int
        Samples of the prediction error.

    Attributes
    ----------
    d_hat : ndarray
        The current estimate on the state rates (state order; zero where not estimated).
    bound : ndarray
        Per state, the saturation of the estimate (0: not estimated).
    """

    def __init__(self, vehicle: Vehicle, reference: dict[str, np.ndarray], enabled: bool, gain: float,
                 share: float, window: int):  # fmt: skip
        self.vehicle, self.enabled, self.gain = vehicle, enabled, gain
        self.rhs = vehicle.rhs_function()
        self.d_hat = np.zeros(len(vehicle.states))
        self.bound = self._bound(reference, share)
        self.history: deque[tuple[float, np.ndarray, np.ndarray]] = deque(maxlen=window)

    def _bound(self, ref: dict[str, np.ndarray], share: float) -> np.ndarray:
        """Per state: ``share`` x its largest rate on the reference for the position and heading
        states, 0 (not estimated) for the others."""
        v = self.vehicle
        estimated = [s in v.position or s in v.roles.headings for s in v.states]
        rates = [np.max(np.abs(np.gradient(ref[s], ref["t"]))) if ref["t"].size > 1 else 0.0 for s in v.states]
        return np.where(estimated, share * np.asarray(rates, dtype=float), 0.0)

    # -- the prediction model ---------------------------------------------------------------
    def rate(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """f(x, u) + d_hat."""
        return self.rhs(x, u) + self.d_hat

    def rk4(self, x: np.ndarray, u: np.ndarray, h: float) -> np.ndarray:
        """One classical Runge-Kutta step of the prediction model."""
        k1 = self.rate(x, u)
        k2 = self.rate(x + h / 2 * k1, u)
        k3 = self.rate(x + h / 2 * k2, u)
        k4 = self.rate(x + h * k3, u)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def carry(self, x: np.ndarray, u: np.ndarray, duration: float, substeps: int = 10) -> np.ndarray:
        """``x`` after ``duration`` with ``u`` held (RK4, ``substeps`` steps)."""
        for _ in range(substeps):
            x = self.rk4(x, u, duration / substeps)
        return x

    def predict(self, y: np.ndarray, pending: np.ndarray, sample_time: float, substeps: int = 10) -> np.ndarray:
        """The state after the pending controls, each held for one sample."""
        x = y.copy()
        for u in pending:
            x = self.carry(x, u, sample_time, substeps)
        return x

    # -- the estimate ------------------------------------------------------------------------
    def update(self, t: float, y: np.ndarray) -> None:
        """d_hat <- sat(d_hat + alpha (y - x_pred) / h): the prediction error over the window
        (x_pred: the oldest measurement in it, carried by f + d_hat)."""
        if not self.enabled or not self.history or not np.all(np.isfinite(y)):
            return
        x, h = self.history[0][1], t - self.history[0][0]
        if h <= 1e-12:
            return
        ends = [s[0] for s in list(self.history)[1:]] + [t]
        for (t0, _, applied), t1 in zip(self.history, ends, strict=True):
            x = self.carry(x, applied, t1 - t0)
        step = self.gain * (y - x) / h
        self.d_hat = np.clip(self.d_hat + np.where(self.bound > 0, step, 0.0), -self.bound, self.bound)

    def record(self, t: float, y: np.ndarray, applied: np.ndarray) -> None:
        """Remember (t, y, the control applied over the sample from t) if ``y`` is finite."""
        if np.all(np.isfinite(y)):
            self.history.append((float(t), y.copy(), np.asarray(applied, dtype=float).copy()))
