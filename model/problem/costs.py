"""Costs: the running cost L(u) of J = integral of L dt, and whether Tf is free."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import sympy as sp

from model.errors import InputError
from model.vehicles import Vehicle, sym


class Cost:
    """Base class of a Lagrange cost."""

    objective: str = ""
    free_final_time: bool = False

    def lagrangian(self, vehicle: Vehicle) -> sp.Expr:
        raise NotImplementedError


@dataclass
class Energy(Cost):
    """J = 1/2 integral of sum_i w_i u_i^2 dt (the paper's (16) with unit weights)."""

    weights: dict[str, float] = field(default_factory=dict)
    objective = "energy"
    free_final_time = False

    def lagrangian(self, vehicle: Vehicle) -> sp.Expr:
        terms = [self.weights.get(c, 1.0) * sym(c) ** 2 for c in vehicle.controls]
        return sp.Rational(1, 2) * sp.Add(*terms)


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
