"""The direct method: the Pyomo.dae trapezoid transcription, one solve, costates, warm re-solves.

Imports the problem definition, the engine (for H and psi), the NLP layer and the analysis
that checks each answer.
"""

import model.nlp.imports  # noqa: F401  (first: it lightens Pyomo's deferred scipy import)
from model.direct.resolve import WARM_OPTIONS, Resolver
from model.direct.solution import Solution
from model.direct.solve import Start, solve_starts
from model.direct.transcription import build_model

__all__ = ["WARM_OPTIONS", "Resolver", "Solution", "Start", "build_model", "solve_starts"]
