"""Search: first guesses and the multi-start that keeps the best validated answer.

Imports the direct method and the problem definition.
"""

from model.search.guess import guess_final_time, initial_guess
from model.search.multistart import passes_to_try, solve_ocp, solve_pass

__all__ = ["guess_final_time", "initial_guess", "passes_to_try", "solve_ocp", "solve_pass"]
