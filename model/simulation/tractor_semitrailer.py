"""A dynamic plant for the tractor-semitrailer: a yaw-plane single-track model with linear tyres.

The yaw-plane model of an articulated vehicle of J. R. Ellis (Vehicle Dynamics, London Business
Books, 1969) and M. F. J. Luijten (Lateral dynamic behaviour of articulated commercial vehicles,
MSc thesis, Eindhoven University of Technology, 2010): two rigid bodies, the tractor and the
semitrailer, joined by the kingpin (a pin joint), each axle one lumped tyre whose lateral force is
linear in its slip, ``F = C alpha``, ``C`` = the axle's cornering coefficient x its static load
(1/rad x N). The structure is theirs; the equations are derived here (Newton-Euler of both bodies)
with the planar kinematics (articulation and steering angles) kept exact and the slip angle's
tangent the ratio of the axle's lateral to longitudinal speed; no load transfer, no roll. They are
checked against the single-track model with a vanishing trailer, the kinematic tractor-trailer at
low speed and a steady turn (tests/test_single_track.py), not against the sources' numbers.

Equations (written per evaluation as a 6 x 6 linear system): the tractor's rear-axle longitudinal
speed u follows the longitudinal acceleration input (``u' = a``, the drive force the unknown that
achieves it, as CommonRoad's single-track model sets ``v' = a``); the unknowns are the rear axle's
lateral acceleration ``w'``, the yaw accelerations ``r1'``, ``r2'``, the drive force and the kingpin
force (2). Below ``LOW_SPEED`` (and in reverse) the slip is singular; as the single-track plant
does, the plant then moves as the kinematic tractor-trailer (no lateral slip at any axle) and
integrates its velocity states by the kinematic rates.

States: ``[X, Y, psi1, psi2, delta, u, w, r1, r2]`` (+ ``a`` under a jerk control): the tractor's rear
axle centre (the kinematic model's reference point, so the measurement needs no conversion), the
headings of tractor and trailer, the steering angle, the rear axle's longitudinal and lateral speed
in the tractor's frame, the two yaw rates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from model.problem.closed_loop import Disturbance
from model.simulation.single_track import (
    DEFAULT_ACCELERATION,
    DEFAULT_CF,
    DEFAULT_CR,
    DEFAULT_DYNAMIC_INDEX,
    DEFAULT_MU,
    DEFAULT_SPEED_GAIN,
    GRAVITY,
    LOW_SPEED,
    SingleTrackPlant,
)
from model.vehicles import Vehicle

# Defaults of the tractor-semitrailer plant (scaled to the model's d, h, L):
DEFAULT_TRACTOR_MASS = 8000.0  # kg: a 4x2 road tractor in running order; assumed (7-8 t is typical)
DEFAULT_TRAILER_MASS = 30000.0  # kg: laden, so that the combination stays within the 40 t of Directive 96/53/EC
# Annex I 2.2.2 (a 5-axle tractor-semitrailer); assumed
DEFAULT_TRACTOR_CG_SHARE = 0.6  # tractor CoG ahead of the rear axle, share of d (an unladen tractor is nose-heavy);
# assumed
DEFAULT_TRAILER_CG_SHARE = 0.6  # trailer CoG behind the kingpin, share of L (a laden trailer loads its axles more
# than the kingpin); assumed
DEFAULT_CT = DEFAULT_CR  # the trailer axle group's cornering coefficient: as the tractor's rear duals; assumed


@dataclass(frozen=True)
class ArticulatedParameters:
    """The tractor-semitrailer plant's numbers (SI units).

    Parameters
    ----------
    mass, yaw_inertia : float
        The tractor's, kg and kg m^2 (about its centre of gravity).
    lf, lr : float
        The tractor's centre of gravity to its front and rear axle, m (lf + lr = d).
    hitch : float
        h, the kingpin ahead of the tractor's rear axle, m (the kinematic model's ``hitch_offset``).
    trailer_wheelbase : float
        L, kingpin to the trailer axle, m.
    trailer_mass, trailer_yaw_inertia : float
        The trailer's, kg and kg m^2.
    trailer_cg : float
        Kingpin to the trailer's centre of gravity, m (0 < trailer_cg < L).
    cf, cr, ct : float
        Cornering coefficients (cornering stiffness per unit static vertical load, 1/rad) of the
        tractor's front and rear axle and the trailer axle.
    mu, speed_gain, acceleration_limits
        As for the single-track plant.
    """

    mass: float
    yaw_inertia: float
    lf: float
    lr: float
    hitch: float
    trailer_wheelbase: float
    trailer_mass: float
    trailer_yaw_inertia: float
    trailer_cg: float
    cf: float
    cr: float
    ct: float
    mu: float = DEFAULT_MU
    speed_gain: float = DEFAULT_SPEED_GAIN
    acceleration_limits: tuple[float, float] = DEFAULT_ACCELERATION

    @property
    def wheelbase(self) -> float:
        return self.lf + self.lr

    def axle_stiffness(self) -> tuple[float, float, float]:
        """(C_f, C_r, C_t), N/rad: each axle's coefficient times its static load (the kingpin's load on the tractor)."""
        g, d, L = GRAVITY, self.wheelbase, self.trailer_wheelbase
        kingpin = self.trailer_mass * g * (L - self.trailer_cg) / L
        trailer_axle = self.trailer_mass * g - kingpin
        front = (self.mass * g * self.lr + kingpin * self.hitch) / d
        rear = self.mass * g + kingpin - front
        return self.cf * front, self.cr * rear, self.ct * trailer_axle


def articulated_parameters(vehicle: Vehicle, disturbance: Disturbance, values: dict) -> ArticulatedParameters:
    """The scenario's ``[plant]`` values, the defaults above for the rest (lengths the plant's: the model's,
    or ``disturbance.wheelbase``)."""
    lengths = {**vehicle.parameter_values(), **disturbance.wheelbase}
    d, h, L = lengths["wheelbase"], lengths["hitch_offset"], lengths["trailer_wheelbase"]
    lr = values.get("lr", d - values["lf"] if "lf" in values else DEFAULT_TRACTOR_CG_SHARE * d)
    lf = values.get("lf", d - lr)
    mass, trailer_mass = values.get("mass", DEFAULT_TRACTOR_MASS), values.get("trailer_mass", DEFAULT_TRAILER_MASS)
    cg = values.get("trailer_cg", DEFAULT_TRAILER_CG_SHARE * L)
    return ArticulatedParameters(
        mass=mass,
        yaw_inertia=values.get("yaw_inertia", DEFAULT_DYNAMIC_INDEX * mass * lf * lr),
        lf=lf,
        lr=lr,
        hitch=h,
        trailer_wheelbase=L,
        trailer_mass=trailer_mass,
        trailer_yaw_inertia=values.get("trailer_yaw_inertia", DEFAULT_DYNAMIC_INDEX * trailer_mass * cg * (L - cg)),
        trailer_cg=cg,
        cf=values.get("cf", DEFAULT_CF),
        cr=values.get("cr", DEFAULT_CR),
        ct=values.get("ct", DEFAULT_CT),
        mu=values.get("mu", DEFAULT_MU),
        speed_gain=values.get("speed_gain", DEFAULT_SPEED_GAIN),
        acceleration_limits=tuple(values.get("acceleration_limits", DEFAULT_ACCELERATION)),
    )


def articulated_rhs(z, steering_rate: float, acceleration: float, p: ArticulatedParameters) -> list[float]:
    """The state derivative of ``[X, Y, psi1, psi2, delta, u, w, r1, r2]`` (kinematic below ``LOW_SPEED``)."""
    _, _, psi1, psi2, delta, u, w, r1, r2 = z[:9]
    if u < LOW_SPEED:
        return _kinematic(z, steering_rate, acceleration, p)
    w_dot, r1_dot, r2_dot = _accelerations(z, acceleration, p)
    c, s = math.cos(psi1), math.sin(psi1)
    return [u * c - w * s, u * s + w * c, r1, r2, steering_rate, acceleration, w_dot, r1_dot, r2_dot]


def _accelerations(z, acceleration: float, p: ArticulatedParameters) -> tuple[float, float, float]:
    """w', r1', r2' from Newton-Euler of both bodies (tractor frame), the drive and kingpin forces eliminated."""
    _, _, psi1, psi2, delta, u, w, r1, r2 = z[:9]
    d, h, L, b1, c2 = p.wheelbase, p.hitch, p.trailer_wheelbase, p.lr, p.trailer_cg
    cf, cr, ct = p.axle_stiffness()
    e2 = np.array([math.cos(psi2 - psi1), math.sin(psi2 - psi1)])  # the trailer's axis in the tractor's frame
    n2 = np.array([-e2[1], e2[0]])
    # tyre forces along each axle's lateral direction, linear in the slip angle's tangent
    vf = np.array([u, w + d * r1])
    front = (
        cf * -(-vf[0] * math.sin(delta) + vf[1] * math.cos(delta)) / (vf[0] * math.cos(delta) + vf[1] * math.sin(delta))
    )
    rear = cr * -w / u
    vt = np.array([u, w + h * r1]) - L * r2 * n2
    trailer = ct * -(vt @ n2) / (vt @ e2)
    # unknowns: [w', r1', r2', F_drive, Hx, Hy] (H: the kingpin's force on the trailer, tractor frame)
    a_hitch_known = np.array([acceleration - r1 * w - r1**2 * h, r1 * u])  # + (0, w' + h r1')
    a_g1_known = np.array([acceleration - r1 * w - r1**2 * b1, r1 * u])  # + (0, w' + b1 r1')
    m1, m2, i1, i2 = p.mass, p.trailer_mass, p.yaw_inertia, p.trailer_yaw_inertia
    A = np.zeros((6, 6))
    rhs = np.zeros(6)
    # tractor, x: m1 a_g1x = F - front sin(delta) - Hx
    A[0] = [0, 0, 0, -1, 1, 0]
    rhs[0] = -front * math.sin(delta) - m1 * a_g1_known[0]
    # tractor, y: m1 (a_g1y + w' + b1 r1') = rear + front cos(delta) - Hy
    A[1] = [m1, m1 * b1, 0, 0, 0, 1]
    rhs[1] = rear + front * math.cos(delta) - m1 * a_g1_known[1]
    # tractor, yaw about its CoG: i1 r1' = (d - b1) front cos(delta) - b1 rear - (h - b1) Hy
    A[2] = [0, i1, 0, 0, 0, h - b1]
    rhs[2] = (d - b1) * front * math.cos(delta) - b1 * rear
    # trailer: m2 (a_hitch + c2 r2^2 e2 - c2 r2' n2) = H + trailer n2
    known = a_hitch_known + c2 * r2**2 * e2
    for k in (0, 1):
        A[3 + k] = [m2 * (k == 1), m2 * h * (k == 1), -m2 * c2 * n2[k], 0, -(k == 0), -(k == 1)]
        rhs[3 + k] = trailer * n2[k] - m2 * known[k]
    # trailer, yaw about its CoG: i2 r2' = c2 (e2 x H) - (L - c2) trailer
    A[5] = [0, 0, i2, 0, c2 * e2[1], -c2 * e2[0]]
    rhs[5] = -(L - c2) * trailer
    sol = np.linalg.solve(A, rhs)
    return float(sol[0]), float(sol[1]), float(sol[2])


def _kinematic(z, steering_rate: float, acceleration: float, p: ArticulatedParameters) -> list[float]:
    """The kinematic tractor-trailer's motion; the velocity states follow its rates (w' = 0)."""
    _, _, psi1, psi2, delta, u, _, _, _ = z[:9]
    d, h, L = p.wheelbase, p.hitch, p.trailer_wheelbase
    art = psi1 - psi2
    tan = math.tan(delta)
    r1 = u * tan / d
    r2 = (u / L) * (math.sin(art) + (h / d) * tan * math.cos(art))
    sec2 = steering_rate / math.cos(delta) ** 2
    r1_dot = (acceleration * tan + u * sec2) / d
    art_dot = r1 - r2
    r2_dot = (acceleration / L) * (math.sin(art) + (h / d) * tan * math.cos(art)) + (u / L) * (
        math.cos(art) * art_dot + (h / d) * (sec2 * math.cos(art) - tan * math.sin(art) * art_dot)
    )
    return [u * math.cos(psi1), u * math.sin(psi1), r1, r2, steering_rate, acceleration, 0.0, r1_dot, r2_dot]


class TractorSemitrailerPlant(SingleTrackPlant):
    """The articulated plant driven by the kinematic tractor-trailer's controls, one sample at a time.

    As ``SingleTrackPlant`` (inputs, speed-tracking law, zero-order hold, noise); the plant's state is
    ``[X, Y, psi1, psi2, delta, u, w, r1, r2]`` (+ ``a``), and the kinematic state it gives the
    controllers is x = X, y = Y, theta = psi1, phi = delta, theta1 = psi2 (and v = u, a).
    """

    def __init__(self, vehicle: Vehicle, disturbance: Disturbance, sample_time: float, values: dict):
        super().__init__(vehicle, disturbance, sample_time, values)
        self.parameters = articulated_parameters(vehicle, disturbance, values)
        self._pose.append(vehicle.states.index(vehicle.roles.trailers[0]))

    def start(self, x: np.ndarray, speed: float = 0.0) -> np.ndarray:
        """The plant's state at the kinematic state ``x`` in the kinematic model's motion (no lateral slip)."""
        pose = [float(x[i]) for i in self._pose]  # X, Y, psi1, delta, psi2
        u = float(x[self._speed_state]) if self._speed_state is not None else float(speed)
        kin = _kinematic([pose[0], pose[1], pose[2], pose[4], pose[3], u, 0.0, 0.0, 0.0], 0.0, 0.0, self.parameters)
        z = [pose[0], pose[1], pose[2], pose[4], pose[3], u, 0.0, kin[2], kin[3]]
        if self._jerk is not None:
            z.append(float(x[self._acceleration_state]))
        return np.array(z, dtype=float)

    def state(self, z: np.ndarray) -> np.ndarray:
        """The kinematic state: the rear axle, the headings, the steering angle (and v = u, a)."""
        x = np.zeros(len(self.vehicle.states))
        x[self._pose] = [z[0], z[1], z[2], z[4], z[3]]
        if self._speed_state is not None:
            x[self._speed_state] = z[5]
        if self._acceleration_state is not None:
            x[self._acceleration_state] = z[9] if self._jerk is not None else 0.0
        return x

    def acceleration(self, z: np.ndarray, u: np.ndarray) -> float:
        """The longitudinal acceleration (the speed-tracking law on the rear axle's speed for a speed control)."""
        if self._acceleration_control is not None:
            return float(u[self._acceleration_control])
        if self._jerk is not None:
            return float(z[9])
        lo, hi = self.parameters.acceleration_limits
        return min(max(self.parameters.speed_gain * (float(u[self._speed_control]) - z[5]), lo), hi)

    def rhs(self, z: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The plant's state derivative under the kinematic model's controls ``u``."""
        f = articulated_rhs(z, float(u[self._steer]), self.acceleration(z, u), self.parameters)
        if self._jerk is not None:
            f.append(float(u[self._jerk]))
        return np.array(f, dtype=float)

    def extras(self, z: np.ndarray, u: np.ndarray) -> dict[str, float]:
        """The tractor's side slip at its centre of gravity (rad), yaw rates (rad/s), speed (m/s), the
        tractor's lateral acceleration at its centre of gravity (m/s^2) and the articulation angle (rad)."""
        f = self.rhs(z, u)
        b1 = self.parameters.lr
        u_, w, r1 = z[5], z[6], z[7]
        return {
            "beta": math.atan((w + b1 * r1) / u_) if u_ != 0 else 0.0,
            "yaw_rate": float(r1),
            "trailer_yaw_rate": float(z[8]),
            "speed": float(u_),
            "lateral_acceleration": float(f[6] + r1 * u_ + f[7] * b1),
            "articulation": float(z[2] - z[3]),
        }


__all__ = ["ArticulatedParameters", "TractorSemitrailerPlant", "articulated_parameters", "articulated_rhs"]
