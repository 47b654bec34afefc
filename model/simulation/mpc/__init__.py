"""Nonlinear MPC, split by role: the horizon problem, the disturbance estimator, the controller.

- ``horizon``: ``HorizonModel``, the scenario's OCP built once as the transcription's
  receding-horizon model (``model.direct.options``), its Params set per step, its vectors'
  places in time (``TimeLayout``) and the solved plans (``Plan``);
- ``estimator``: ``DisturbanceEstimator``, the prediction model f + d_hat and the offset-free
  estimate of d_hat;
- ``controller``: ``MPC`` and its ``MPCSettings``, the ``Controller`` of the closed loop.
"""

from model.simulation.mpc.controller import MPC, MPCSettings
from model.simulation.mpc.estimator import DisturbanceEstimator
from model.simulation.mpc.horizon import HorizonModel, Plan, TimeLayout

__all__ = ["MPC", "DisturbanceEstimator", "HorizonModel", "MPCSettings", "Plan", "TimeLayout"]
