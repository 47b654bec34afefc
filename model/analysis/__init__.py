"""Analysis of a node trajectory, independent of the solver that made it.

Validation (re-integration, bounds, boundary values, clearance), the PMP certificate and
the arc structure. Imports the problem definition and the Pontryagin engine; knows no solver,
so a trajectory.csv from anywhere can be checked.
"""

from model.analysis.certificate import certify, certify_trajectory
from model.analysis.validation import validate

__all__ = ["certify", "certify_trajectory", "validate"]
