"""Costs: the running cost L(u) of J = integral of L dt, and whether Tf is free."""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

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

    ``rate_penalty`` eps > 0 adds eps * sum_k (u_{k+1} - u_k)^2 / h to the discrete
    objective (a small regularisation against chattering); 0 is the plain problem.
    """

    rate_penalty: float = 0.0
    objective = "time"
    free_final_time = True

    def lagrangian(self, vehicle: Vehicle) -> sp.Expr:
        return sp.Integer(1)
