"""Costs: the running cost L(u) of J = integral of L dt, and whether Tf is free.

The energy 1/2 integral of sum_i w_i u_i^2 dt is written once, in ``Energy``: its weighted squares
(``Energy.squares``) make both the symbolic running cost (``Energy.lagrangian``, which the transcription, the
Pontryagin engine and the certificate read) and the numeric energy of a trajectory's columns
(``Energy.integral``, ``Energy.cumulative``: the solution's, the closed loop's, the MPC's cost scale, the figures').
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import sympy as sp

from model.errors import InputError
from model.vehicles import Vehicle, sym


class Cost:
    """Base class of a Lagrange cost."""

    objective: str = ""
    free_final_time: bool = False

    def lagrangian(self, vehicle: Vehicle) -> sp.Expr:
        raise NotImplementedError

    @property
    def energy(self) -> Energy:
        """The energy this cost weighs: an ``Energy`` cost itself (its weights), any other cost unit weights."""
        return Energy()


RULES = ("trapezoid", "zoh")
"""How ``Energy.integral`` integrates over the nodes: "trapezoid" (the transcription's rule, the paper's eq. 32)
or "zoh" (the zero-order hold: each node's controls held over the step that follows, as a plant applies them)."""

Rule = Literal["trapezoid", "zoh"]


@dataclass
class Energy(Cost):
    """J = 1/2 integral of sum_i w_i u_i^2 dt (the paper's (16) with unit weights).

    Parameters
    ----------
    weights : dict
        {control: w > 0}; a control not named weighs 1.

    The symbolic running cost and the numeric energy come from the same ``squares`` (module docstring).
    """

    weights: dict[str, float] = field(default_factory=dict)
    objective = "energy"
    free_final_time = False

    @property
    def energy(self) -> Energy:
        """This cost itself: the energy it weighs (``Cost.energy``)."""
        return self

    def squares(self, controls: Mapping[str, Any]) -> list[Any]:
        """w_i u_i^2 for each control u_i of ``controls`` (name: SymPy symbol or NumPy array), in their order."""
        return [self.weights.get(c, 1.0) * u**2 for c, u in controls.items()]

    def lagrangian(self, vehicle: Vehicle) -> sp.Expr:
        """L(u) = 1/2 sum_i w_i u_i^2 over the vehicle's controls."""
        return sp.Rational(1, 2) * sp.Add(*self.squares({c: sym(c) for c in vehicle.controls}))

    def rate(self, columns: Mapping[str, Any], controls: Sequence[str]) -> np.ndarray:
        """L(u) = 1/2 sum_i w_i u_i^2 at every node of ``columns`` (``controls``: the vehicle's control names)."""
        return 0.5 * sum(self.squares({c: np.asarray(columns[c], dtype=float) for c in controls}))

    def integral(self, columns: Mapping[str, Any], controls: Sequence[str], rule: Rule = "trapezoid") -> float:
        """The energy of a trajectory: the integral of ``rate`` over ``columns["t"]`` by ``rule`` (``RULES``).

        Parameters
        ----------
        columns : mapping
            Node arrays (a ``Columns`` dict or a DataFrame): ``t`` and the controls.
        controls : sequence of str
            The control names (``vehicle.controls``).
        rule : str
            "trapezoid" (the default) or "zoh" (``RULES``); ValueError otherwise.

        Returns
        -------
        float
            The energy (with unit weights m^2/s + rad^2/s for the truck).
        """
        t, rate = np.asarray(columns["t"], dtype=float), self.rate(columns, controls)
        if rule == "trapezoid":
            return float(np.trapezoid(rate, t))
        if rule == "zoh":
            return float(np.sum(np.diff(t) * rate[:-1]))
        raise ValueError(f"rule must be one of {', '.join(RULES)}, got {rule!r}")

    def cumulative(self, columns: Mapping[str, Any], controls: Sequence[str]) -> np.ndarray:
        """E(t_k), the trapezoid ``integral`` up to each node (0 at the first): for the figures' energy panel."""
        t, rate = np.asarray(columns["t"], dtype=float), self.rate(columns, controls)
        return np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (rate[1:] + rate[:-1]))])


@dataclass
class Time(Cost):
    """J = Tf = integral of 1 dt, with a free final time.

    ``steering_weight`` w > 0 makes it J = integral of (1 + w u2^2) dt = Tf + w integral of u2^2 dt
    (scenario key ``[problem] steering_weight``), u2 the vehicle's ``roles.turning`` control (the
    steering rate; the unicycle's turn rate): part of the Lagrangian, so the transcription, the
    Pontryagin engine and the certificate read the same cost, and the maximum condition for u2 is a
    projection (u2 = clip(p_phi / (2 w))) instead of bang-bang; 0 is the plain problem.

    ``rate_penalty`` eps > 0 adds eps * sum_k (u_{k+1} - u_k)^2 / h to the discrete
    objective (a small regularisation against chattering, not part of the Lagrangian); 0 is
    the plain problem.
    """

    rate_penalty: float = 0.0
    steering_weight: float = 0.0
    objective = "time"
    free_final_time = True

    def lagrangian(self, vehicle: Vehicle) -> sp.Expr:
        if not self.steering_weight:
            return sp.Integer(1)
        return sp.Integer(1) + self.steering_weight * sym(vehicle.roles.turning) ** 2

    def __post_init__(self) -> None:
        w = self.steering_weight
        if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) or w < 0:
            raise InputError("problem.steering_weight", f"must be a finite number >= 0 (s/rad^2), got {w!r}")
        self.steering_weight = float(w)
