"""A plant that is not the planning model: CommonRoad's dynamic single-track model (docs/closed-loop-format.md).

The controllers plan on the kinematic model (truck, tricycle) and send its controls; this plant
integrates the dynamic single-track model of the CommonRoad vehicle models (M. Althoff and
G. Würsching, "CommonRoad: Vehicle Models (Version 2020a)", TU München, 2020, section 5;
``vehicle_dynamics_st`` of the package ``commonroad-vehicle-models`` 3.0.2, which
``tests/test_single_track.py`` matches to 1e-9): linear tyres whose lateral force is
``mu C_S F_z alpha`` per axle, the axle loads ``F_z`` shifted by the longitudinal acceleration
(load transfer through the centre of gravity's height), the centre of gravity as the reference
point. Below ``LOW_SPEED`` (0.1 m/s) the model is singular; as CommonRoad does, it then switches
to the kinematic single-track model about the centre of gravity and integrates the yaw rate and
side slip angle from their kinematic rates. One departure: CommonRoad switches for |v| < 0.1 m/s
and keeps the dynamic model in reverse (v <= -0.1 m/s), where its linear tyre terms change sign and
the yaw and slip dynamics diverge (rates of order mu C_S g / |v|, hundreds per second: a tracking
controller that backs the truck up briefly drove the side slip to 1e6 rad in one sample); this
plant uses the kinematic branch for every v < 0.1 m/s. CommonRoad's input constraints (steering and
acceleration limits) are not applied: the controllers already keep the controls within the OCP's
bounds.

States of the plant: ``[sx, sy, delta, v, psi, psi_dot, beta]`` (CommonRoad's order: centre of
gravity, steering angle, speed of the centre of gravity, yaw angle, yaw rate, side slip angle),
then ``a`` when the planning model's control is the jerk.

Inputs (the planning model's controls, ``vehicle.roles``): the steering rate is the steering
velocity; the longitudinal acceleration is the control ``a`` (``roles.acceleration`` a control),
the integrated state ``a`` (with a jerk control), or, when the speed is the control (the seed
paper's model), the speed-tracking law ``a = clip(k (u1 s(delta) - v cos(beta)), lo, hi)``: the
rear axle's speed along the heading, ``v cos(beta)``, follows the speed the kinematic model gives
it, ``u1 s(delta)`` (s = 1 for the truck, cos(delta) for the tricycle), with gain ``k`` (1/s).

Measurement (the kinematic state the controllers know): x, y of the rear axle, ``sx - lr cos(psi)``,
``sy - lr sin(psi)``; theta = psi; phi = delta; the speed state v (with longitudinal dynamics)
``v cos(beta) / s(delta)``; the acceleration state a (with a jerk control) the integrated a.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import sympy as sp

from model.problem.closed_loop import Disturbance, PlantSettings
from model.simulation.plant import Plant, held_step
from model.vehicles import Vehicle, expression, sym

GRAVITY = 9.81  # m/s^2, CommonRoad's value in vehicle_dynamics_st
LOW_SPEED = 0.1  # m/s: below it CommonRoad's vehicle_dynamics_st switches to the kinematic model
RTOL = ATOL = 1e-9
METHOD = "DOP853"
ST_STATES = ("sx", "sy", "delta", "v", "psi", "psi_dot", "beta")

# Defaults of the single-track plant, a laden two-axle rigid truck scaled to the vehicle's wheelbase L.
DEFAULT_MASS = 18000.0  # kg: the gross weight limit of a two-axle motor vehicle, Directive 96/53/EC Annex I 2.2.1(a)
# lr / L = the front axle's share of the weight: 6.5 t of 18 t with the driving axle at its 11.5 t limit
# (Directive 96/53/EC Annex I 3.2); assumed that a laden truck loads the axles so.
DEFAULT_LR_SHARE = 6.5 / 18.0
# Yaw inertia m lf lr: a dynamic index k^2 / (lf lr) of 1 (W. F. Milliken and D. L. Milliken, Race Car Vehicle
# Dynamics, SAE 1995, ch. 5: about 1 for road vehicles); assumed for a truck.
DEFAULT_DYNAMIC_INDEX = 1.0
# Cornering stiffness per unit vertical load, 1/rad (CommonRoad's mu C_S): 0.12 / deg on the single steer tyres,
# 0.14 / deg on the lighter-loaded rear duals (so the truck understeers). Assumed within the range 0.1-0.2 / deg of
# truck tyres in P. S. Fancher et al., A Factbook of the Mechanical Properties of the Components for Single-Unit
# and Articulated Heavy Trucks, UMTRI / NHTSA DOT HS 807 125, 1986.
DEFAULT_CF = math.degrees(0.12)
DEFAULT_CR = math.degrees(0.14)
DEFAULT_HEIGHT_SHARE = 0.3  # h_cg / L: about 1.8 m on a 6 m wheelbase for a laden truck; assumed
DEFAULT_MU = 0.8  # tyre-road friction coefficient, dry asphalt; assumed (it scales C_S only: mu C_S is given)
DEFAULT_SPEED_GAIN = 2.0  # 1/s: the speed-tracking law's gain (a 0.5 s time constant); assumed
DEFAULT_ACCELERATION = (-4.0, 1.3)  # m/s^2: SUMO's vClass "truck" defaults decel 4.0, accel 1.3 (SUMO docs, vClass)


@dataclass(frozen=True)
class SingleTrackParameters:
    """The plant's numbers (SI units).

    Parameters
    ----------
    mass : float
        m, kg.
    yaw_inertia : float
        I_z about the centre of gravity, kg m^2.
    lf, lr : float
        Centre of gravity to the front and the rear axle, m (lf + lr is the wheelbase).
    cf, cr : float
        Cornering stiffness of the front and the rear axle per unit vertical load, 1/rad: the axle's
        lateral force is ``cf F_zf alpha_f`` (CommonRoad's ``mu C_Sf``).
    h_cg : float
        Height of the centre of gravity, m (load transfer under acceleration).
    mu : float
        Friction coefficient: CommonRoad's ``C_S = cf / mu`` and the summary's friction use.
    speed_gain : float
        k of the speed-tracking law, 1/s (when the planning model's speed is a control).
    acceleration_limits : tuple of float
        (lo, hi) of the speed-tracking law's acceleration, m/s^2.
    """

    mass: float
    yaw_inertia: float
    lf: float
    lr: float
    cf: float
    cr: float
    h_cg: float
    mu: float
    speed_gain: float = DEFAULT_SPEED_GAIN
    acceleration_limits: tuple[float, float] = DEFAULT_ACCELERATION

    @property
    def wheelbase(self) -> float:
        return self.lf + self.lr


def single_track_parameters(vehicle: Vehicle, disturbance: Disturbance, values: dict) -> SingleTrackParameters:
    """The plant's parameters: the scenario's ``[plant]`` values, the defaults above for the rest.

    The wheelbase is the plant's (``disturbance.wheelbase`` if given, else the vehicle's); one given
    axle distance fixes the other.
    """
    wheelbase = disturbance.wheelbase.get("wheelbase", vehicle.parameter_values()["wheelbase"])
    lr = values.get("lr", wheelbase - values["lf"] if "lf" in values else DEFAULT_LR_SHARE * wheelbase)
    lf = values.get("lf", wheelbase - lr)
    mass = values.get("mass", DEFAULT_MASS)
    return SingleTrackParameters(
        mass=mass,
        yaw_inertia=values.get("yaw_inertia", DEFAULT_DYNAMIC_INDEX * mass * lf * lr),
        lf=lf,
        lr=lr,
        cf=values.get("cf", DEFAULT_CF),
        cr=values.get("cr", DEFAULT_CR),
        h_cg=values.get("h_cg", DEFAULT_HEIGHT_SHARE * wheelbase),
        mu=values.get("mu", DEFAULT_MU),
        speed_gain=values.get("speed_gain", DEFAULT_SPEED_GAIN),
        acceleration_limits=tuple(values.get("acceleration_limits", DEFAULT_ACCELERATION)),
    )


def single_track_rhs(x, steering_rate: float, acceleration: float, p: SingleTrackParameters) -> list[float]:
    """CommonRoad's ``vehicle_dynamics_st`` (3.0.2) without its input constraints.

    Parameters
    ----------
    x : sequence of 7 floats
        ``[sx, sy, delta, v, psi, psi_dot, beta]``.
    steering_rate, acceleration : float
        The steering velocity (rad/s) and the longitudinal acceleration (m/s^2).
    p : SingleTrackParameters

    Returns
    -------
    list of 7 floats
        The state derivative; below ``LOW_SPEED`` CommonRoad's kinematic branch (in reverse too, where
        CommonRoad keeps the dynamic one).
    """
    if x[3] < LOW_SPEED:  # CommonRoad: abs(x[3]) < 0.1; its linear tyres diverge in reverse (see the module)
        return _kinematic_branch(x, steering_rate, acceleration, p)
    g, mu, m, inertia, lf, lr, h = GRAVITY, p.mu, p.mass, p.yaw_inertia, p.lf, p.lr, p.h_cg
    c_sf, c_sr = p.cf / mu, p.cr / mu
    delta, v, psi, dpsi, beta = x[2], x[3], x[4], x[5], x[6]
    front = g * lr - acceleration * h  # the front axle's load per unit mass times L
    rear = g * lf + acceleration * h
    yaw = (
        -mu * m / (v * inertia * (lr + lf)) * (lf**2 * c_sf * front + lr**2 * c_sr * rear) * dpsi
        + mu * m / (inertia * (lr + lf)) * (lr * c_sr * rear - lf * c_sf * front) * beta
        + mu * m / (inertia * (lr + lf)) * lf * c_sf * front * delta
    )
    slip = (
        (mu / (v**2 * (lr + lf)) * (c_sr * rear * lr - c_sf * front * lf) - 1) * dpsi
        - mu / (v * (lr + lf)) * (c_sr * rear + c_sf * front) * beta
        + mu / (v * (lr + lf)) * (c_sf * front) * delta
    )
    return [v * math.cos(beta + psi), v * math.sin(beta + psi), steering_rate, acceleration, dpsi, yaw, slip]


def _kinematic_branch(x, steering_rate: float, acceleration: float, p: SingleTrackParameters) -> list[float]:
    """CommonRoad's low-speed branch: ``vehicle_dynamics_ks_cog`` and the kinematic yaw and slip rates.

    The slip rate's denominator ``1 + (tan(delta)^2 lr / L)^2`` is written as CommonRoad 3.0.2 writes it.
    """
    wheelbase = p.lf + p.lr
    delta, v, psi, beta = x[2], x[3], x[4], x[6]
    beta_ks = math.atan(math.tan(delta) * p.lr / wheelbase)
    d_beta = (p.lr * steering_rate) / (
        wheelbase * math.cos(delta) ** 2 * (1 + (math.tan(delta) ** 2 * p.lr / wheelbase) ** 2)
    )
    dd_psi = (
        acceleration * math.cos(beta) * math.tan(delta)
        - v * math.sin(beta) * d_beta * math.tan(delta)
        + v * math.cos(beta) * steering_rate / math.cos(delta) ** 2
    ) / wheelbase
    return [
        v * math.cos(beta_ks + psi),
        v * math.sin(beta_ks + psi),
        steering_rate,
        acceleration,
        v * math.cos(beta_ks) * math.tan(delta) / wheelbase,
        dd_psi,
        d_beta,
    ]


def speed_factor(vehicle: Vehicle) -> sp.Expr:
    """s(phi): the rear axle's speed along the heading per unit of the model's speed (1 truck, cos(phi) tricycle).

    Raises
    ------
    ValueError
        If it depends on more than the steering angle (the model is not a rigid car-like one).
    """
    r = vehicle.roles
    f = vehicle.dynamics()
    theta = sym(r.heading)
    along = expression(f[r.x]) * sp.cos(theta) + expression(f[r.y]) * sp.sin(theta)
    factor = sp.simplify(along / sym(r.speed))
    if not factor.free_symbols <= {sym(r.steering)}:
        raise ValueError(f"the {vehicle.model} model's speed along the heading is not u1 s(phi): {factor}")
    return factor


class SingleTrackPlant:
    """CommonRoad's dynamic single-track model driven by a kinematic model's controls, one sample at a time.

    Parameters
    ----------
    vehicle : Vehicle
        The planning model (truck or tricycle, with or without longitudinal dynamics).
    disturbance : Disturbance
        Its true wheelbase, delay and noise (the speed gain, steering bias and drift are the
        kinematic plant's; ``check_plant`` refuses them here).
    sample_time : float
        The zero-order hold's sample time h, s.
    values : dict
        The scenario's ``[plant]`` numbers (``PlantSettings.values``).

    Examples
    --------
    >>> plant = SingleTrackPlant(Truck(wheelbase=5.0), Disturbance(), 0.1, {})      # doctest: +SKIP
    >>> z = plant.start(np.zeros(4)); plant.state(plant.step(z, np.array([2.0, 0.0])))  # doctest: +SKIP
    """

    def __init__(self, vehicle: Vehicle, disturbance: Disturbance, sample_time: float, values: dict):
        self.vehicle = vehicle
        self.sample_time = float(sample_time)
        self.parameters = single_track_parameters(vehicle, disturbance, values)
        self.kinematic = Plant(vehicle, disturbance, sample_time)  # its measurement noise
        r = vehicle.roles
        self._factor = sp.lambdify(sym(r.steering), speed_factor(vehicle), "math")
        index = {name: i for i, name in enumerate(vehicle.states)}
        self._pose = [index[r.x], index[r.y], index[r.heading], index[r.steering]]
        self._speed_state = index.get(r.speed)
        self._acceleration_state = index.get(r.acceleration)
        ctrl = {name: j for j, name in enumerate(vehicle.controls)}
        self._steer = ctrl[r.steering_rate]
        self._speed_control = ctrl.get(r.speed)
        self._acceleration_control = ctrl.get(r.acceleration)
        self._jerk = ctrl.get(r.jerk) if r.jerk is not None else None

    def start(self, x: np.ndarray, speed: float = 0.0) -> np.ndarray:
        """The plant's state at the kinematic state ``x``, in the kinematic model's steady motion.

        The speed is the speed state's (with longitudinal dynamics), else ``speed`` (the model's speed
        control's value; default 0: before t = 0 the vehicle stands still, docs/closed-loop-format.md).
        Side slip and yaw rate are the kinematic ones.
        """
        p = self.parameters
        px, py, psi, delta = (float(x[i]) for i in self._pose)
        model_speed = float(x[self._speed_state]) if self._speed_state is not None else float(speed)
        rear = model_speed * self._factor(delta)
        beta = math.atan(math.tan(delta) * p.lr / p.wheelbase)
        v = rear / math.cos(beta)
        z = [px + p.lr * math.cos(psi), py + p.lr * math.sin(psi), delta, v, psi, rear * math.tan(delta) / p.wheelbase,
             beta]  # fmt: skip
        if self._jerk is not None:
            z.append(float(x[self._acceleration_state]))
        return np.array(z, dtype=float)

    def state(self, z: np.ndarray) -> np.ndarray:
        """The kinematic state the controllers measure (rear axle position, heading, steering, speed)."""
        p = self.parameters
        x = np.zeros(len(self.vehicle.states))
        sx, sy, delta, v, psi, _, beta = z[:7]
        x[self._pose] = [sx - p.lr * math.cos(psi), sy - p.lr * math.sin(psi), psi, delta]
        if self._speed_state is not None:
            x[self._speed_state] = v * math.cos(beta) / self._factor(delta)
        if self._acceleration_state is not None:
            x[self._acceleration_state] = z[7] if self._jerk is not None else 0.0
        return x

    def acceleration(self, z: np.ndarray, u: np.ndarray) -> float:
        """The longitudinal acceleration the controls ask for (the speed-tracking law for a speed control)."""
        if self._acceleration_control is not None:
            return float(u[self._acceleration_control])
        if self._jerk is not None:
            return float(z[7])
        p = self.parameters
        lo, hi = p.acceleration_limits
        target = float(u[self._speed_control]) * self._factor(z[2])
        return min(max(p.speed_gain * (target - z[3] * math.cos(z[6])), lo), hi)

    def rhs(self, z: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The plant's state derivative at ``z`` under the kinematic model's controls ``u``."""
        f = single_track_rhs(z, float(u[self._steer]), self.acceleration(z, u), self.parameters)
        if self._jerk is not None:
            f.append(float(u[self._jerk]))
        return np.array(f, dtype=float)

    def step(self, z: np.ndarray, u: np.ndarray, duration: float | None = None) -> np.ndarray:
        """The plant's state after one sample (``duration``, default the sample time) with ``u`` held."""
        return held_step(self.rhs, z, u, self.sample_time if duration is None else float(duration), RTOL)

    def measure(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The measured kinematic state, with the noise of the kinematic plant (``Plant.measure``)."""
        return self.kinematic.measure(x, rng)

    def extras(self, z: np.ndarray, u: np.ndarray) -> dict[str, float]:
        """Side slip angle (rad), yaw rate (rad/s), speed of the centre of gravity (m/s) and its lateral
        acceleration ``v (psi_dot + beta_dot)`` (m/s^2) under ``u``: closed_loop.csv's ``plant_*`` columns."""
        f = self.rhs(z, u)
        return {"beta": float(z[6]), "yaw_rate": float(z[5]), "speed": float(z[3]),
                "lateral_acceleration": float(z[3] * (z[5] + f[6]))}  # fmt: skip


def make_plant(vehicle: Vehicle, disturbance: Disturbance, sample_time: float, settings: PlantSettings):
    """The plant ``settings.model`` names: ``Plant`` (kinematic), ``SingleTrackPlant``, or for a model with a
    trailer ``TractorSemitrailerPlant`` (``model.simulation.tractor_semitrailer``)."""
    if settings.model == "single-track" and vehicle.roles.trailers:
        from model.simulation.tractor_semitrailer import TractorSemitrailerPlant

        return TractorSemitrailerPlant(vehicle, disturbance, sample_time, settings.values)
    if settings.model == "single-track":
        return SingleTrackPlant(vehicle, disturbance, sample_time, settings.values)
    if settings.model != "kinematic":
        raise ValueError(f"unknown plant model {settings.model!r}")
    return Plant(vehicle, disturbance, sample_time)


def plan_mismatch(plant: SingleTrackPlant, columns: dict[str, np.ndarray], plan: dict[str, np.ndarray]) -> dict:
    """What the model mismatch costs: the summary's ``plant`` table.

    ``max_lateral_deviation``: the largest distance (m) over the samples from the plant's rear axle
    point to the plan's path (the optimum's node positions joined by segments); ``max_side_slip``
    the largest |beta| (rad); ``max_lateral_acceleration`` (m/s^2) and ``max_friction_use``, that
    over mu g (linear tyres are a fair model well below 1); and the parameters used.
    """
    px, py = plant.vehicle.position
    points = np.column_stack([columns[px], columns[py]])
    path = np.column_stack([plan[px], plan[py]])
    lateral = float(np.max(np.abs(columns["plant_lateral_acceleration"])))
    p = plant.parameters
    return {
        "model": "single-track",
        "max_lateral_deviation": float(np.max(path_distance(points, path))),
        "max_side_slip": float(np.max(np.abs(columns["plant_beta"]))),
        "max_lateral_acceleration": lateral,
        "max_friction_use": lateral / (p.mu * GRAVITY),
        "parameters": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(p).items()},
        "low_speed_switch": LOW_SPEED,
    }


def worst_mismatch(tables: list[dict]) -> dict:
    """The ``plant`` tables of several runs at their worst: the largest ``max_*``, the smallest clearance."""
    out = dict(tables[0])
    for key in out:
        vals = [t[key] for t in tables if t[key] is not None]
        if key.startswith("max_") and vals:
            out[key] = max(vals)
        elif key == "min_clearance" and vals:
            out[key] = min(vals)
    return out


def path_distance(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Each point's distance (m) to the polyline ``path`` (shape (n, 2), n >= 1)."""
    a, b = path[:-1], path[1:]
    if len(path) == 1:
        return np.hypot(*(points - path[0]).T)
    ab = b - a
    length2 = np.maximum(np.sum(ab**2, axis=1), 1e-300)
    rel = points[:, None, :] - a[None, :, :]
    s = np.clip(np.sum(rel * ab[None], axis=2) / length2[None], 0.0, 1.0)
    nearest = a[None] + s[..., None] * ab[None]
    return np.min(np.linalg.norm(points[:, None, :] - nearest, axis=2), axis=1)


__all__ = [
    "SingleTrackParameters", "SingleTrackPlant", "make_plant", "path_distance", "plan_mismatch",
    "single_track_parameters", "single_track_rhs", "speed_factor", "worst_mismatch",
]  # fmt: skip
