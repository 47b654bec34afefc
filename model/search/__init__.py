"""Search: first guesses (geometric paths: Reeds-Shepp, Dubins), and the multi-start that keeps the best answer.

Imports the direct method and the problem definition.
"""

from model.search.guess import guess_final_time, initial_guess
from model.search.multistart import passes_to_try, solve_ocp, solve_pass
from model.search.paths import dubins, min_turning_radius, path_guess, reeds_shepp, reeds_shepp_time

__all__ = ["dubins", "guess_final_time", "initial_guess", "min_turning_radius", "passes_to_try", "path_guess",
           "reeds_shepp", "reeds_shepp_time", "solve_ocp", "solve_pass"]
