"""The optimal control problem: vehicle, cost, bounds, obstacles, boundary conditions."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from model.errors import InputError
from model.problem.costs import Cost, Energy
from model.problem.methods import DEFAULT_PMP, Method, default_solve, load_method
from model.scene.lanelet_map import MapRoute
from model.scene.moving import MovingVehicle
from model.scene.obstacles import Circle
from model.scene.road import Road
from model.vehicles import Body, Vehicle

if TYPE_CHECKING:
    from derivations.pmp import PMPSystem
    from model.direct.solution import Solution

PASSES = ("auto", "ccw", "cw")
LATERAL = "lateral_acceleration"  # the [bounds] key of the vehicle's lateral acceleration, m/s^2


@dataclass
class OCP:
    """One optimal control problem, posed once and solved or analysed from here.

    Parameters
    ----------
    vehicle : Vehicle
        The model (``Truck``, ``Unicycle``, ...): states, controls, SymPy dynamics.
    cost : Cost
        ``Energy()`` (fixed final time) or ``Time()`` (free final time).
    bounds : dict
        State or control name -> inclusive (lower, upper); every control needs bounds.
    initial : dict
        Every state's value at t = 0 but the longitudinal dynamics' (``Vehicle.pose_states``: v and a are
        free unless given).
    final : dict
        Any subset of the states at t = Tf (the rest are free; ``end_pose`` completes an end for a pose check).
    obstacles : list of Circle
        Discs to keep out of (radius + safety).
    moving_obstacles : tuple of MovingVehicle
        Other vehicles on known paths (``model.scene.moving``): the reference point, or with
        ``bodies`` every body, stays ``safety`` from each one's rectangle at every node.
    final_time : float, optional
        Fixed for the energy cost; a first guess for the time cost.
    passing : {"auto", "ccw", "cw"}
        The side to pass the first obstacle on ("auto" tries both).
    bodies : dict
        Body name ("vehicle", "trailer") -> ``Body``, a rectangle on that body's reference
        axle; without one the vehicle is a point.
    road : Road, optional
        A roundabout and a route through it (instead of ``obstacles``): every body stays in the
        route's corridor.
    map_route : MapRoute, optional
        A route through a CommonRoad lanelet map (docs/map-format.md; instead of ``obstacles`` and
        ``road``). ``solve`` uses ``model.search.maps`` by default; ``pmp`` raises InputError.
    name, title : str
        Used in results files.

    Raises
    ------
    InputError
        Naming the first inconsistent item (as the scenario key it comes from).

    Examples
    --------
    >>> ocp = OCP(vehicle=Truck(wheelbase=0.1), cost=Energy(), final_time=4.5,
    ...           bounds={"u1": (-1, 1), "u2": (-0.35, 0.35), "phi": (-0.6, 0.6)},
    ...           obstacles=[Circle(center=(0.5, 0.03), radius=0.2, safety=0.05)],
    ...           initial=dict(x=0, y=0, theta=0, phi=0), final=dict(x=1, y=0, theta=0))
    >>> ocp.solve(intervals=100).ok                               # doctest: +SKIP
    True
    """

    vehicle: Vehicle
    cost: Cost = field(default_factory=Energy)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    final: dict[str, float] = field(default_factory=dict)
    obstacles: list[Circle] = field(default_factory=list)
    final_time: float | None = None
    passing: str = "auto"
    bodies: dict[str, Body] = field(default_factory=dict)
    road: Road | None = None
    map_route: MapRoute | None = None
    name: str = "problem"
    title: str = ""
    moving_obstacles: tuple[MovingVehicle, ...] = ()

    def __post_init__(self) -> None:
        self.bounds = {k: (float(v[0]), float(v[1])) for k, v in self.bounds.items()}
        self.moving_obstacles = tuple(self.moving_obstacles)
        self.validate()

    # -- checks that make bad input one clear error --------------------------
    def validate(self) -> None:
        """Raise InputError naming the first inconsistent item."""
        v = self.vehicle
        names = set(v.states) | set(v.controls) | set(v.outputs()) | set(v.path_outputs())
        positive = v.positive_parameters if v.positive_parameters is not None else tuple(v.parameters())
        for key, val in v.parameters().items():
            if not math.isfinite(val):
                raise InputError(f"vehicle.{v.parameter_keys.get(key, key)}", f"must be a finite number, got {val}")
            if val <= 0 and key in positive:
                raise InputError(f"vehicle.{v.parameter_keys.get(key, key)}", f"must be > 0, got {val}")
        self._check_lateral_acceleration()
        for key, (lo, hi) in self.bounds.items():
            if key not in names:
                raise InputError(f"bounds.{key}", f"unknown variable (model has {sorted(names)})")
            if not (lo <= hi):
                raise InputError(f"bounds.{key}", f"lower bound {lo} exceeds upper bound {hi}")
        for c in v.controls:
            if c not in self.bounds:
                raise InputError(f"bounds.{c}", "required: every control needs bounds")
        self._check_boundary("initial", self.initial, require_all=True)
        self._check_boundary("final", self.final, require_all=False)
        self._check_obstacles()
        self._check_moving()
        self._check_bodies()
        self._check_time()
        if self.passing not in PASSES:
            raise InputError("problem.pass", f"must be one of {PASSES}, got {self.passing!r}")

    def _check_lateral_acceleration(self) -> None:
        """``bounds.lateral_acceleration``: a model that defines it, finite lo < hi, and lo <= 0 <= hi."""
        if LATERAL not in self.bounds:
            return
        if self.vehicle.lateral_acceleration is None:
            raise InputError(
                f"bounds.{LATERAL}",
                f"the {self.vehicle.model or type(self.vehicle).__name__} model defines no "
                "lateral-acceleration expression (Vehicle.lateral_acceleration)",
            )
        lo, hi = self.bounds[LATERAL]
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise InputError(f"bounds.{LATERAL}", f"must be two finite numbers in m/s^2, got [{lo}, {hi}]")
        if not lo < hi:
            raise InputError(f"bounds.{LATERAL}", f"lower bound {lo} must be below the upper bound {hi}")
        if not lo <= 0 <= hi:
            raise InputError(
                f"bounds.{LATERAL}", f"[{lo}, {hi}] must contain 0 (driving straight has no lateral acceleration)"
            )

    def _check_boundary(self, where: str, values: dict[str, float], require_all: bool) -> None:
        for key, val in values.items():
            if key not in self.vehicle.states:
                raise InputError(f"{where}.{key}", f"not a state of the {self.vehicle.model} model")
            if not math.isfinite(val):
                raise InputError(f"{where}.{key}", "must be a finite number")
            lo, hi = self.bounds.get(key, (-math.inf, math.inf))
            if not lo <= val <= hi:
                raise InputError(f"{where}.{key}", f"{val} lies outside bounds [{lo}, {hi}]")
        if require_all:
            for key in self.vehicle.pose_states:  # the integrated states (v, a) are free unless stated
                if key not in values:
                    raise InputError(f"{where}.{key}", "missing: every state must be fixed at t = 0")

    def _check_obstacles(self) -> None:
        px, py = self.vehicle.position
        for i, ob in enumerate(self.obstacles):
            if not all(map(math.isfinite, ob.center)):
                raise InputError(f"obstacles[{i}].center", f"must be two finite numbers, got {list(ob.center)}")
            if not (math.isfinite(ob.radius) and ob.radius > 0):
                raise InputError(f"obstacles[{i}].radius", f"must be a finite number > 0, got {ob.radius}")
            if not (math.isfinite(ob.safety) and ob.safety >= 0):
                raise InputError(f"obstacles[{i}].safety", f"must be a finite number >= 0, got {ob.safety}")
            for where, pt in (("initial", self.initial), ("final", self.final)):
                # math, not numpy: huge coordinates must not print a RuntimeWarning beside the one error line
                if px in pt and py in pt and math.hypot(pt[px] - ob.center[0], pt[py] - ob.center[1]) < ob.keep_out:
                    raise InputError(
                        f"{where}.{px}",
                        f"({pt[px]}, {pt[py]}) lies inside obstacles[{i}] (radius + safety = {ob.keep_out})",
                    )

    def _check_moving(self) -> None:
        """Each moving obstacle is a ``MovingVehicle``; the start point is clear of it at t = 0."""
        px, py = self.vehicle.position
        for i, ob in enumerate(self.moving_obstacles):
            if not isinstance(ob, MovingVehicle):
                raise InputError(f"moving_obstacles[{i}]", f"must be a MovingVehicle, got {type(ob).__name__}")
            if px in self.initial and py in self.initial:
                gap = float(ob.clearance_at(self.initial[px], self.initial[py], 0.0))
                if gap < 0:
                    raise InputError(
                        f"initial.{px}",
                        f"({self.initial[px]}, {self.initial[py]}) lies within moving_obstacles[{i}] "
                        f"(rectangle + safety) at t = 0",
                    )

    def _check_bodies(self) -> None:
        poses = self.vehicle.body_poses()
        for name in self.bodies:
            if name not in poses:
                key = "vehicle.trailer_body" if name == "trailer" else f"vehicle.{name}"
                raise InputError(key, f"the {self.vehicle.model} model has no {name} (bodies: {sorted(poses)})")

    def _check_time(self) -> None:
        tf = self.final_time
        if tf is None:
            if not self.cost.free_final_time:
                raise InputError("problem.final_time", "required for the energy objective")
            return
        if not math.isfinite(tf) or tf <= 0:
            raise InputError("problem.final_time", f"must be a finite number > 0, got {tf}")
        if self.cost.free_final_time:
            return
        gap = self.straight_distance()
        speed = self.max_speed()
        if gap is not None and speed is not None and gap > speed * tf * (1 + 1e-9):
            raise InputError(
                "problem.final_time",
                f"infeasible: the goal is {gap:.4g} m away but |{self.vehicle.roles.speed}| <= {speed:g} "
                f"covers at most {speed * tf:.4g} m in {tf:g} s",
            )

    def straight_distance(self) -> float | None:
        """Straight-line distance start to goal, or None if the goal position is free."""
        px, py = self.vehicle.position
        if px in self.final and py in self.final:
            return math.hypot(self.final[px] - self.initial[px], self.final[py] - self.initial[py])
        return None

    def max_speed(self) -> float | None:
        """max |u1|, u1 the vehicle's speed (``roles.speed``, a control or the state v); None without one or its
        bounds."""
        speed = self.vehicle.roles.speed
        if speed not in self.bounds:
            return None
        lo, hi = self.bounds[speed]
        return max(abs(lo), abs(hi))

    # -- the two things one does with a problem ------------------------------
    def solve(self, intervals: int = 100, method: str | Method | None = None, **options: Any) -> Solution:
        """Transcribe with the trapezoid rule and solve with Ipopt (multi-start by default).

        Parameters
        ----------
        intervals : int
            N, the number of trapezoid steps.
        method : callable or "module:function", optional
            What solves the problem, called as ``method(ocp, intervals=N, **options)``;
            default ``model.search.multistart:solve_ocp`` (every pass direction, several
            cold starts, the best validated answer).
        **options
            Passed to the method: ``verbose`` (Ipopt log), ``options`` (Ipopt options),
            ``guess`` (a trajectory DataFrame to start from), ``starts``, ``progress``,
            ``formulation`` (the bodies' NLP formulation on a road), ``time_limit`` (seconds), ``clock``
            (what the time limit counts: "wall" or "cpu" seconds).

        Returns
        -------
        Solution
            ``ok`` is True when Ipopt converged and the independent validation passed.

        Examples
        --------
        >>> sol = ocp.solve(intervals=100)                       # doctest: +SKIP
        >>> sol.ok, sol.objective, sol.trajectory[["t", "x", "y"]]  # doctest: +SKIP
        """
        return load_method(method or default_solve(self))(self, intervals=intervals, **options)

    def pmp(self, **options: Any) -> PMPSystem:
        """The Pontryagin system derived symbolically from this definition (``derivations.pmp.derive``)."""
        self.check_solvable()
        return load_method(DEFAULT_PMP)(self, **options)

    def check_solvable(self) -> None:
        """Raise InputError (key ``map``) for what no method handles yet: the Pontryagin system of a
        route through a lanelet map (its solve is ``model.search.maps``)."""
        if self.map_route is not None:
            raise InputError("map", "simulating map scenarios or deriving their Pontryagin system is not implemented "
                             "yet (docs/map-corridor.md); roundabout solve solves them")  # fmt: skip


def end_pose(
    vehicle: Vehicle, values: Mapping[str, float], rest: Mapping[str, float] | None = None
) -> dict[str, float]:
    """Every state at one end of a problem as a check of the pose there needs it (the bodies' rectangles).

    An end fixes what it states; what it leaves free takes, for the check: the steering angle 0, each trailer in
    line with the reference heading, the longitudinal dynamics' states (``Vehicle.integrated_states``, free at
    either end unless stated and part of no pose) 0, and any other state its value in ``rest``. The one place
    that says so for the road bounds (``model.analysis.bounds``), the map pose check (``model.problem.maps``)
    and what builds on them.

    Parameters
    ----------
    vehicle : Vehicle
        The model whose states are completed.
    values : mapping
        The end's stated values (``[initial]`` or ``[final]`` after a route set its pose): they win.
    rest : mapping, optional
        Values of the states no rule fills (the goal's: the start's); without it such a state is left out.

    Returns
    -------
    dict
        State name -> value, every state of ``vehicle`` that ``values``, the rules or ``rest`` give.
    """
    r = vehicle.roles
    full = {k: val for k, val in (rest or {}).items() if k in vehicle.states}
    full |= dict.fromkeys(vehicle.integrated_states, 0.0)
    if r.steering is not None:
        full[r.steering] = 0.0
    if r.heading is not None and r.heading in values:
        full |= dict.fromkeys(r.trailers, values[r.heading])
    return full | dict(values)
