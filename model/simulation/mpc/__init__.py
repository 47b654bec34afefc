"""Nonlinear MPC, split by role: the horizon problem, the disturbance estimator, the controller.

- ``horizon``: ``HorizonModel``, the scenario's OCP built once as the transcription's
  receding-horizon model (``model.direct.options``), its Params set per step, its vectors'
  places in time (``TimeLayout``) and the solved plans (``Plan``);
- ``estimator``: ``DisturbanceEstimator``, the prediction model f + d_hat and the offset-free
  estimate of d_hat;
- ``rti``: ``RealTimeIteration``, one condensed SQP step per sample on the built NLP's CasADi
  functions (``MPCSettings(realtime=True)``; warm-started Ipopt the fallback);
- ``controller``: ``MPC`` and its ``MPCSettings``, the ``Controller`` of the closed loop.
"""

from model.simulation.mpc.controller import MPC, MPCSettings
from model.simulation.mpc.estimator import DisturbanceEstimator
from model.simulation.mpc.horizon import HorizonModel, Plan, TimeLayout
from model.simulation.mpc.rti import RealTimeIteration

__all__ = ["MPC", "DisturbanceEstimator", "HorizonModel", "MPCSettings", "Plan", "RealTimeIteration", "TimeLayout"]
