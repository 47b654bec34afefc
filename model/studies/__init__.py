"""Studies: Pareto fronts, grid convergence, wheelbase sweeps, built on the solve and re-solve layers."""

from model.studies.sweeps import convergence, pareto_front

__all__ = ["convergence", "pareto_front"]
