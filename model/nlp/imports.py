"""Import-time economy for the solve path.

Pyomo defers its scipy import and, once anything imports scipy, finalises it by importing
scipy.stats, scipy.spatial and scipy.integrate (about 0.7 s on these machines), none of
which pynumero or this project's NLP uses: cyipopt imports scipy.optimize, the bridge
scipy.sparse. ``lighten_pyomo_scipy_import`` swaps that finaliser for one that imports
scipy.sparse only. It changes nothing if Pyomo has already resolved scipy or if a Pyomo
release renames the hook; a later ``import scipy.stats`` works as usual. It must run before
scipy is first imported (Pyomo resolves an already-imported scipy at once): the packages of the
solve path import this module first, and ``model.analysis`` imports scipy only when it validates.
"""

from __future__ import annotations


def _finalize_scipy(module, available: bool) -> None:
    if available:
        import scipy.sparse  # noqa: F401  (what pynumero needs)


def lighten_pyomo_scipy_import() -> bool:
    """Make Pyomo's deferred scipy import load scipy.sparse only; True if the hook was set."""
    from pyomo.common import dependencies

    indicator = getattr(dependencies, "scipy_available", None)
    if getattr(indicator, "_available", True) is not None or not hasattr(indicator, "_callback"):
        return False
    indicator._callback = _finalize_scipy
    return True


lighten_pyomo_scipy_import()  # on import: before anything imports scipy after Pyomo
