"""Ipopt through cyipopt: run a CasadiNLP, map Ipopt's status to the contract's words."""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from pyomo.contrib.pynumero.interfaces.cyipopt_interface import CyIpoptNLP, cyipopt_available

from model.nlp.casadi_nlp import CasadiNLP

STATUS_WORDS = {
    0: "optimal",
    1: "acceptable",
    2: "infeasible",
    3: "search_direction_too_small",
    4: "diverging",
    5: "user_stop",
    6: "feasible_point_found",
    -1: "iteration_limit",
    -2: "restoration_failed",
    -3: "step_computation_error",
    -4: "time_limit",
    -5: "wall_time_limit",
    -10: "too_few_degrees_of_freedom",
    -11: "invalid_problem",
    -12: "invalid_option",
    -13: "invalid_number",
}

# mumps_pivot_order 6 (QAMD): the fastest MUMPS ordering measured (benchmarks/bench_ipopt.py;
# N = 1600: 1.82 s against 2.52 s for Ipopt's automatic choice, same iterations).
DEFAULT_OPTIONS = {"tol": 1e-8, "max_iter": 3000, "sb": "yes", "print_level": 0, "mumps_pivot_order": 6}

# A warm start from a previous primal-dual point (a re-solve, an MPC step): Ipopt's bound pushes made
# negligible so that the point is not moved off its active bounds, and a small initial barrier parameter.
WARM_OPTIONS = {
    "warm_start_init_point": "yes",
    "warm_start_bound_push": 1e-9,
    "warm_start_bound_frac": 1e-9,
    "warm_start_slack_bound_push": 1e-9,
    "warm_start_slack_bound_frac": 1e-9,
    "warm_start_mult_bound_push": 1e-9,
    "mu_init": 1e-6,
}

# A long Ipopt run logs where it is (INFO on "roundabout.ipopt") at most this often; the
# command line shows these lines on stderr (library users see them if they configure logging).
LOG = logging.getLogger("roundabout.ipopt")
PROGRESS_SECONDS = 5.0


class IpoptOptionError(ValueError):
    """An option Ipopt does not have, or a value it does not accept."""


def set_option(problem, key: str, value) -> None:
    """``problem.add_option``; an integer is retried as a number (tol=1); IpoptOptionError if rejected."""
    try:
        problem.add_option(key, value)
        return
    except TypeError:
        pass
    try:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError
        problem.add_option(key, float(value))
    except TypeError:
        raise IpoptOptionError(f"Ipopt rejected option {key} = {value!r}") from None


def check_options(options: dict) -> None:
    """Raise IpoptOptionError for the first option Ipopt rejects, without solving anything
    (Ipopt's own explanation on stdout is silenced)."""
    import cyipopt

    class _Empty:
        def objective(self, x):
            return 0.0

        def gradient(self, x):
            return x * 0

    probe = cyipopt.Problem(n=1, m=0, problem_obj=_Empty(), lb=[0.0], ub=[1.0])
    with quiet_stdout():
        for key, val in options.items():
            set_option(probe, key, val)


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence file descriptor 1 (Ipopt, qpOASES write there from C); what C buffered goes to /dev/null too."""
    sys.stdout.flush()
    saved, null = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        _flush_c_stdout()  # what C buffered goes to /dev/null, not after the restore
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def _flush_c_stdout() -> None:
    """fflush(NULL): C's buffered output written out now."""
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).fflush(None)


@dataclass
class IpoptResult:
    """What one Ipopt run returned: status word, iterate, multipliers, counts."""

    status: str
    code: int
    message: str
    x: np.ndarray
    mult_g: np.ndarray
    mult_x_L: np.ndarray
    mult_x_U: np.ndarray
    objective: float
    iterations: int
    seconds: float
    log: list[tuple[int, float, float, float]] = field(default_factory=list)


def run_ipopt(
    nlp: CasadiNLP,
    options: dict | None = None,
    x0: np.ndarray | None = None,
    duals: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> IpoptResult:
    """Solve ``nlp`` from ``x0`` (default: the model's values); ``duals`` warm-start (g, zL, zU)."""
    if not cyipopt_available:
        raise RuntimeError("cyipopt is not installed: run `python tools/install_solver.py`")
    log: list[tuple[int, float, float, float]] = []
    said = [time.perf_counter()]

    def intermediate(_nlp, _problem, alg_mod, iter_count, obj, inf_pr, inf_du, mu, d_norm, reg, a_du, a_pr, ls):
        log.append((int(iter_count), float(obj), float(inf_pr), float(inf_du)))
        now = time.perf_counter()
        if now - said[0] >= PROGRESS_SECONDS:
            said[0] = now
            LOG.info(
                "Ipopt iteration %d: objective %.8g, constraint violation %.2e, dual infeasibility %.2e, %.0f s",
                iter_count, obj, inf_pr, inf_du, now - start,
            )  # fmt: skip
        return True

    # pynumero's wrapper takes the NLP's objective factor for 1 and sets it only when Ipopt asks for
    # another: a run that ended in the restoration phase (factor 0) would leave the next run's
    # Hessian without its objective
    nlp.set_obj_factor(1.0)
    problem = CyIpoptNLP(nlp, intermediate_callback=intermediate)
    opts = {**DEFAULT_OPTIONS, **(options or {})}
    if duals is not None:
        opts.setdefault("warm_start_init_point", "yes")
    for key, val in opts.items():
        set_option(problem, key, val)
    x0 = nlp.init_primals() if x0 is None else x0
    start = said[0] = time.perf_counter()
    if duals is None:
        x, info = problem.solve(x0)
    else:
        x, info = problem.solve(x0, lagrange=duals[0], zl=duals[1], zu=duals[2])
    seconds = time.perf_counter() - start
    code = int(info["status"])
    msg = info["status_msg"]
    return IpoptResult(
        status=STATUS_WORDS.get(code, "solver_error"),
        code=code,
        message=msg.decode() if isinstance(msg, bytes) else str(msg),
        x=np.asarray(x),
        mult_g=np.asarray(info["mult_g"]),
        mult_x_L=np.asarray(info["mult_x_L"]),
        mult_x_U=np.asarray(info["mult_x_U"]),
        objective=float(info["obj_val"]),
        iterations=log[-1][0] if log else 0,
        seconds=seconds,
        log=log,
    )
