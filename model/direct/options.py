"""Options of the transcription: what a receding-horizon controller asks of ``build_model``.

The scenario's own OCP is ``build_model(ocp, N)`` with no options. A model predictive controller
re-solves a horizon problem built from the same rows, with (``TranscriptionOptions``):

- ``soft_penalty``: the keep-out discs and the road's body rows soft, each with a slack in metres
  (``0 <= s <= R`` on a keep-out disc, ``s >= 0`` on a body row) and the summed slack priced at
  this weight per metre in the objective (an exact L1 penalty: a step that can keep clear does,
  one that cannot is no infeasibility);
- ``rate_disturbance``: the dynamics ``dX/dtau = Tf (f(X, U) + d)`` with a mutable Param ``d_hat``
  per state (zero: the nominal model), the offset-free MPC's estimate of a constant disturbance;
- ``horizon`` (``Horizon``): a receding horizon: the final conditions replaced by a soft terminal
  target (mutable Params ``target`` and ``target_weight`` per state, an exact L1 plus a small
  quadratic penalty on the scaled terminal error), and the objective
  ``time_weight Tf / time_scale + energy_weight E / energy_scale + terminal penalty + soft penalty``
  (``time_weight``, ``energy_weight`` mutable Params; ``E`` the energy, ``transcription.energy``).
  The duration is the model's ``tf``: a mutable Param for a fixed final time, a Var whose bounds the
  caller sets (equal bounds: a fixed duration) for a free one. The model also gets the node-time
  hook for time-varying data (``node_time``, ``node_parameters``: see ``transcription.build_model``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Horizon:
    """A receding horizon with a soft terminal target (see the module docstring).

    Attributes
    ----------
    scales : Mapping[str, float]
        Scale of each state's terminal error (m for positions, rad for angles).
    time_scale, energy_scale : float
        The final time and the energy that normalise the cost to about 1.
    terminal_l1, terminal_quadratic : float
        Weights of the L1 and quadratic penalties on the scaled terminal error.
    """

    scales: Mapping[str, float] = field(default_factory=dict)
    time_scale: float = 1.0
    energy_scale: float = 1.0
    terminal_l1: float = 100.0
    terminal_quadratic: float = 10.0


@dataclass(frozen=True)
class TranscriptionOptions:
    """What ``build_model`` adds to or changes in the scenario's model (the defaults: nothing).

    Attributes
    ----------
    soft_penalty : float or None
        Weight per metre of summed keep-out and body-row slack; None keeps those rows hard.
    rate_disturbance : bool
        Add a mutable Param ``d_hat[state]`` to every state's rate.
    horizon : Horizon or None
        Build the receding-horizon problem (soft terminal target, the horizon's objective).
    free_grid : bool
        Time free per interval (a free final time only, no horizon): a Var ``step[k]`` (s, k = 1..N) per
        interval, the trapezoid rows ``X_k - X_{k-1} = step_k / 2 (f_{k-1} + f_k)`` with dX = f(X, U)
        (no time scale), ``tf`` the Expression sum_k step_k and every time integral the trapezoid rule on
        these steps (docs/map-corridor.md, nodes fixed to arclength).
    """

    soft_penalty: float | None = None
    rate_disturbance: bool = False
    horizon: Horizon | None = None
    free_grid: bool = False
