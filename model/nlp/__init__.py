"""The NLP layer: a Pyomo model to CasADi templates (presolve, exact derivatives) and Ipopt.

Knows no vehicle, cost or problem: it reads any Pyomo ConcreteModel.
"""

import model.nlp.imports  # noqa: F401  (first: it lightens Pyomo's deferred scipy import)
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import DEFAULT_OPTIONS, IpoptResult, run_ipopt

__all__ = ["DEFAULT_OPTIONS", "CasadiNLP", "IpoptResult", "run_ipopt"]
