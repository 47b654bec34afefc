"""What every controller offers the closed loop (do-mpc's ``make_step`` style)."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Controller(Protocol):
    """A feedback law called once per sample.

    Attributes
    ----------
    name : str
        What the summary calls it, e.g. ``"tracking (time-varying LQR)"``.
    failed : bool
        True if the last step's own computation failed and a fallback control was returned.
    final_time : float, optional
        A controller may move the arrival (MPC on a time problem under a slower plant); the
        loop then runs until it (``loop.LATEST`` x the optimum's Tf at most).
    steps : list of dict, optional
        Per-step records; a ``truncated`` key counts into the summary's ``truncated_steps``.
    """

    name: str
    failed: bool

    def make_step(self, t: float, y: np.ndarray, pending: np.ndarray) -> np.ndarray:
        """The controls to send at time ``t``.

        Parameters
        ----------
        t : float
            Sample time instant (s).
        y : ndarray
            Measured state, in the vehicle model's state order (noise included).
        pending : ndarray, shape (k, n_controls)
            Controls already sent and not yet applied (k = delay in samples; oldest first):
            they act on the plant over [t, t + k h). The control returned now acts over
            [t + k h, t + (k + 1) h). A controller that knows the delay predicts through them.

        Returns
        -------
        ndarray, shape (n_controls,)
        """
        ...


__all__ = ["Controller"]
