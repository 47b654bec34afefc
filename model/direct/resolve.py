"""Cheap re-solves: change a parameter of a built model and warm-start Ipopt.

The Pyomo model keeps the final time (energy objective), the boundary values and
the obstacles as mutable Params, and the CasADi functions take them as inputs, so a
change needs no rebuild; Ipopt restarts from the previous primal and dual point::

    first = ocp.solve(intervals=100)
    again = Resolver(first).solve(final_time=4.4)     # warm, no rebuild
"""

from __future__ import annotations

import copy
import time

from model.direct.moving import fill_moving, note_settling, solve_moving
from model.direct.solution import Solution
from model.direct.solve import finish
from model.direct.transcription import set_pass_direction
from model.nlp.ipopt import WARM_OPTIONS
from model.scene.obstacles import Circle


class Resolver:
    """Re-solve a solved problem after changing its parameters, without rebuilding.

    Parameters
    ----------
    solution : Solution
        A solution returned by ``OCP.solve`` (it carries its built model and NLP).

    Examples
    --------
    >>> first = ocp.solve(intervals=100)                          # doctest: +SKIP
    >>> r = Resolver(first)                                       # doctest: +SKIP
    >>> longer = r.solve(final_time=5.0)                          # warm, no rebuild  # doctest: +SKIP
    >>> moved = r.solve(final={"y": 0.05}, obstacles={0: Circle((0.5, 0.0), 0.2)})  # doctest: +SKIP
    """

    def __init__(self, solution: Solution):
        self.ocp = copy.copy(solution.ocp)
        self.passing = solution.passing
        self.model, self.nlp = solution.model, solution.nlp
        self.last = solution

    def solve(
        self,
        final_time: float | None = None,
        initial: dict[str, float] | None = None,
        final: dict[str, float] | None = None,
        obstacles: dict[int, Circle] | None = None,
        warm: bool = True,
        options: dict | None = None,
    ) -> Solution:
        """Apply the changes and re-solve from the last valid solution.

        Parameters
        ----------
        final_time : float, optional
            New fixed final time (energy objective only).
        initial, final : dict, optional
            New values of boundary conditions already fixed in the model.
        obstacles : dict, optional
            Obstacle index -> new ``Circle``.
        warm : bool
            Start from the previous primal-dual point (``WARM_OPTIONS``); False starts cold
            from the previous primal point only.
        options : dict, optional
            Further Ipopt options.

        Returns
        -------
        Solution
            Validated and certified like any solve; it becomes the next start if ``ok``.
        """
        t0 = time.perf_counter()
        self._apply(final_time, initial or {}, final or {}, obstacles or {})
        if hasattr(self.model, "pass_direction"):  # the search's model serves both directions: set this one's
            set_pass_direction(self.model, self.passing)
        fill_moving(self.model, self.ocp)  # the moving obstacles at the (new) node times
        self.nlp.refresh_parameters()
        prev = self.last.ipopt
        opts = {**(WARM_OPTIONS if warm else {}), **(options or {})}
        duals = (prev.mult_g, prev.mult_x_L, prev.mult_x_U) if warm else None
        res, settling = solve_moving(self.model, self.ocp, self.nlp, opts, x0=prev.x, duals=duals)
        sol = finish(
            self.ocp, self.model, self.nlp, res, self.passing, {"update": time.perf_counter() - t0 - res.seconds}
        )
        note_settling(sol, settling)
        if sol.ok:
            self.last = sol
        return sol

    def _apply(self, final_time, initial, final, obstacles) -> None:
        m, ocp = self.model, self.ocp
        if final_time is not None:
            if ocp.cost.free_final_time:
                raise ValueError("final_time is a variable of the time objective, not a parameter")
            m.tf.set_value(float(final_time))
            ocp.final_time = float(final_time)
        for where, changes in (("initial", initial), ("final", final)):
            values = dict(getattr(ocp, where))
            for name, val in changes.items():
                param = m.find_component(f"{where}_{name}_value")
                if param is None:
                    raise KeyError(f"{where}.{name} is not fixed in this model; rebuild to add it")
                param.set_value(float(val))
                values[name] = float(val)
            setattr(ocp, where, values)
        obs = list(ocp.obstacles)
        for i, circle in obstacles.items():
            m.obstacle_cx[i] = circle.center[0]
            m.obstacle_cy[i] = circle.center[1]
            m.obstacle_R[i] = circle.keep_out
            obs[i] = circle
        ocp.obstacles = obs


__all__ = ["Resolver", "WARM_OPTIONS"]
