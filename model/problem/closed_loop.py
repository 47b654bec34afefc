"""The closed-loop keys of a scenario (docs/closed-loop-format.md): [disturbance] and [control].

The plant differs from the model the controller uses by a ``Disturbance``; ``ControlSettings``
say how often the controller acts and how far MPC looks ahead. ``parse_closed_loop`` reads both
tables with one ``InputError`` per bad key, as the rest of the scenario parser does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from model.errors import InputError
from model.problem.tables import is_number, no_unknown, number, table_of
from model.vehicles import Vehicle

DISTURBANCE_KEYS = {"speed_gain", "steering_bias", "drift", "wheelbase", "delay", "noise", "seed"}
CONTROL_KEYS = {"sample_time", "horizon", "interval_samples", "realtime"}
MULTIPLE_TOL = 1e-9  # relative: delay / sample_time within this of a whole number
PLANT_MODELS = ("kinematic", "single-track")
PLANT_NUMBERS = {  # [plant] key -> the model's name for it (model.simulation.single_track), each > 0
    "mass": "mass", "yaw_inertia": "yaw_inertia", "cg_to_front_axle": "lf", "cg_to_rear_axle": "lr",
    "cornering_coefficient_front": "cf", "cornering_coefficient_rear": "cr", "cg_height": "h_cg",
    "friction_coefficient": "mu", "speed_tracking_gain": "speed_gain",
    "trailer_mass": "trailer_mass", "trailer_yaw_inertia": "trailer_yaw_inertia", "hitch_to_trailer_cg": "trailer_cg",
    "cornering_coefficient_trailer": "ct",
}  # fmt: skip
TRAILER_NUMBERS = {"trailer_mass", "trailer_yaw_inertia", "trailer_cg", "ct"}  # the tractor-semitrailer's only
PLANT_KEYS = {"model", "acceleration_limits", *PLANT_NUMBERS}
LENGTH_TOL = 1e-6  # m: cg_to_front_axle + cg_to_rear_axle must be the plant's wheelbase within this


@dataclass(frozen=True)
class Disturbance:
    """How the plant differs from the model (all defaults: no disturbance).

    ``wheelbase`` maps the vehicle's length parameters (e.g. ``{"wheelbase": 5.3}``, or for a
    trailer also ``"trailer_wheelbase"``) to the plant's true values; missing ones are the model's.
    ``delay`` is a whole multiple of the sample time; ``noise`` the standard deviation on the
    measured x, y (m) and heading (rad / 10).
    """

    speed_gain: float = 1.0
    steering_bias: float = 0.0
    drift: tuple[float, float] = (0.0, 0.0)
    wheelbase: dict[str, float] = field(default_factory=dict)
    delay: float = 0.0
    noise: float = 0.0
    seed: int = 0

    @property
    def none(self) -> bool:
        """True if the plant is the model exactly (no disturbance, no delay, no noise)."""
        return self == Disturbance(seed=self.seed)


@dataclass(frozen=True)
class ControlSettings:
    """Sample time (s) of the zero-order hold, the MPC horizon (samples, or "shrinking") and the
    samples per interval of the MPC's prediction grid (``interval_samples``); ``realtime``: True, each MPC
    step one real-time iteration (warm-started Ipopt its fallback when a step's point is not usable);
    False, a warm-started Ipopt solve; None (the key absent), the real-time iteration wherever it
    applies (``model.simulation.mpc.MPCSettings.realtime``), warm-started Ipopt with the reason elsewhere."""

    sample_time: float = 0.1
    horizon: int | str = 40
    interval_samples: int = 1
    realtime: bool | None = None

    @property
    def intervals(self) -> int | None:
        """The MPC's prediction intervals (``horizon / interval_samples``); None when shrinking.

        Raises
        ------
        ValueError
            If ``interval_samples`` does not divide the horizon.
        """
        if self.horizon == "shrinking":
            return None
        count, rest = divmod(int(self.horizon), self.interval_samples)
        if rest:
            raise ValueError(f"interval_samples = {self.interval_samples} does not divide horizon = {self.horizon}")
        return count

    def delay_samples(self, disturbance: Disturbance) -> int:
        """The actuator delay in whole samples."""
        return int(round(disturbance.delay / self.sample_time))


def parse_closed_loop(data: dict[str, Any], vehicle: Vehicle | None = None) -> tuple[Disturbance, ControlSettings]:
    """The scenario's ``[disturbance]`` and ``[control]`` tables (defaults where absent).

    Parameters
    ----------
    data : dict
        The whole TOML document.
    vehicle : Vehicle, optional
        The scenario's vehicle: ``disturbance.wheelbase`` may name only its length parameters,
        and ``disturbance.steering_bias`` needs a steering angle ``phi``.

    Returns
    -------
    (Disturbance, ControlSettings)

    Raises
    ------
    InputError
        Naming the first bad key (unknown keys with a "did you mean" hint).
    """
    control = _control(table_of(data, "control") if "control" in data else {})
    disturbance = _disturbance(table_of(data, "disturbance") if "disturbance" in data else {}, vehicle)
    ratio = disturbance.delay / control.sample_time
    if abs(ratio - round(ratio)) > MULTIPLE_TOL * max(1.0, ratio):
        raise InputError(
            "disturbance.delay",
            f"must be a whole multiple of control.sample_time = {control.sample_time:g} s, got {disturbance.delay:g} s",
        )
    return disturbance, control


def _control(table: dict[str, Any]) -> ControlSettings:
    no_unknown(table, CONTROL_KEYS, "control.")
    sample_time = _finite(table, "sample_time", "control.", ControlSettings.sample_time)
    if sample_time <= 0:
        raise InputError("control.sample_time", f"must be > 0, got {sample_time:g}")
    horizon = table.get("horizon", ControlSettings.horizon)
    if horizon != "shrinking" and (isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 2):
        raise InputError("control.horizon", f'must be a whole number >= 2 or "shrinking", got {horizon!r}')
    samples = _interval_samples(table, horizon)
    realtime = table.get("realtime", ControlSettings.realtime)
    if realtime is not None and not isinstance(realtime, bool):
        raise InputError("control.realtime", f"must be true or false, got {realtime!r}")
    return ControlSettings(sample_time=sample_time, horizon=horizon, interval_samples=samples, realtime=realtime)


def _interval_samples(table: dict[str, Any], horizon: int | str) -> int:
    """``control.interval_samples``: a whole number >= 1 that divides the horizon into >= 2 intervals."""
    key = "control.interval_samples"
    samples = table.get("interval_samples", ControlSettings.interval_samples)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise InputError(key, f"must be a whole number >= 1, got {samples!r}")
    if samples == 1:
        return samples
    if horizon == "shrinking":
        raise InputError(key, 'must be 1 with horizon = "shrinking" (the scenario\'s own intervals are used)')
    if horizon % samples or horizon // samples < 2:
        raise InputError(key, f"must divide control.horizon = {horizon} into at least 2 intervals, got {samples}")
    return samples


def _disturbance(table: dict[str, Any], vehicle: Vehicle | None) -> Disturbance:
    where = "disturbance."
    no_unknown(table, DISTURBANCE_KEYS, where)
    gain = _finite(table, "speed_gain", where, 1.0)
    if gain <= 0:
        raise InputError(where + "speed_gain", f"must be > 0, got {gain:g}")
    bias = _finite(table, "steering_bias", where, 0.0)
    if bias != 0 and vehicle is not None and vehicle.roles.steering is None:
        raise InputError(where + "steering_bias", f"the {vehicle.model} model has no steering angle phi; leave it 0")
    delay = _finite(table, "delay", where, 0.0)
    noise = _finite(table, "noise", where, 0.0)
    for key, val in (("delay", delay), ("noise", noise)):
        if val < 0:
            raise InputError(where + key, f"must be >= 0, got {val:g}")
    seed = table.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise InputError(where + "seed", f"must be a whole number >= 0, got {seed!r}")
    return Disturbance(
        speed_gain=gain,
        steering_bias=bias,
        drift=_drift(table.get("drift", [0.0, 0.0])),
        wheelbase=_lengths(table["wheelbase"], vehicle) if "wheelbase" in table else {},
        delay=delay,
        noise=noise,
        seed=seed,
    )


def _finite(table: dict[str, Any], key: str, where: str, default: float) -> float:
    val = number(table, key, where, default)
    if not math.isfinite(val):
        raise InputError(where + key, f"must be a finite number, got {val}")
    return val


def _drift(val: Any) -> tuple[float, float]:
    if not (isinstance(val, list) and len(val) == 2 and all(is_number(v) and math.isfinite(v) for v in val)):
        raise InputError("disturbance.drift", f"must be [w_x, w_y] (two finite numbers, m/s), got {val!r}")
    return float(val[0]), float(val[1])


def _lengths(val: Any, vehicle: Vehicle | None) -> dict[str, float]:
    """``wheelbase = 5.3`` or ``wheelbase = {wheelbase = 3.9, trailer_wheelbase = 8.0}``: the plant's lengths."""
    key = "disturbance.wheelbase"
    allowed = set(vehicle.parameter_keys.values()) if vehicle is not None else {"wheelbase", "trailer_wheelbase"}
    if vehicle is not None and "wheelbase" not in allowed:
        raise InputError(key, f"the {vehicle.model} model has no wheelbase")
    table = val if isinstance(val, dict) else {"wheelbase": val}
    no_unknown(table, allowed, key + ".")
    lengths = {}
    for name in table:
        where = key if not isinstance(val, dict) else f"{key}.{name}"
        length = table[name]
        if not is_number(length) or not math.isfinite(length):
            raise InputError(where, f"must be a finite number (m) or a table of the model's lengths, got {length!r}")
        if name != "hitch_offset" and length <= 0:
            raise InputError(where, f"must be > 0, got {length:g}")
        lengths[name] = float(length)
    return lengths


@dataclass(frozen=True)
class PlantSettings:
    """The ``[plant]`` table: which model the plant integrates and the values a scenario sets for it.

    ``model`` is ``"kinematic"`` (the planning model with the disturbances, today's plant) or
    ``"single-track"`` (CommonRoad's dynamic single-track model, ``model.simulation.single_track``).
    ``values`` holds the numbers the scenario gives, by the model's names (``mass``, ``yaw_inertia``,
    ``lf``, ``lr``, ``cf``, ``cr``, ``h_cg``, ``mu``, ``speed_gain``, ``acceleration_limits``); the
    others take the defaults of ``model.simulation.single_track`` (from the wheelbase, with sources).
    """

    model: str = "kinematic"
    values: dict[str, Any] = field(default_factory=dict)


def parse_plant(data: dict[str, Any], vehicle: Vehicle, disturbance: Disturbance) -> PlantSettings:
    """The scenario's ``[plant]`` table (``PlantSettings()`` when absent).

    Raises
    ------
    InputError
        Naming the first bad key: unknown keys, a model not in ``PLANT_MODELS``, numbers that are
        not finite and > 0, keys of the single-track model beside ``model = "kinematic"``, axle
        distances that do not add up to the plant's wheelbase, a vehicle or disturbance the
        single-track plant does not take (``check_plant``).
    """
    table = table_of(data, "plant") if "plant" in data else {}
    no_unknown(table, PLANT_KEYS, "plant.")
    model = table.get("model", "kinematic")
    if model not in PLANT_MODELS:
        raise InputError("plant.model", f"must be one of {list(PLANT_MODELS)}, got {model!r}")
    values: dict[str, Any] = {}
    for key, name in PLANT_NUMBERS.items():
        if key in table:
            values[name] = _finite(table, key, "plant.", 0.0)
            if values[name] <= 0:
                raise InputError("plant." + key, f"must be > 0, got {values[name]:g}")
    if "acceleration_limits" in table:
        values["acceleration_limits"] = _acceleration_limits(table["acceleration_limits"])
    if model == "kinematic" and values:
        key = next(k for k in table if k != "model")
        raise InputError("plant." + key, 'only with model = "single-track" (the kinematic plant takes no parameters)')
    settings = PlantSettings(model=model, values=values)
    check_plant(settings, vehicle, disturbance)
    return settings


def check_plant(settings: PlantSettings, vehicle: Vehicle, disturbance: Disturbance, key: str = "plant.model") -> None:
    """Whether the single-track plant takes this vehicle and disturbance (nothing to check for the kinematic).

    Parameters
    ----------
    settings : PlantSettings
    vehicle : Vehicle
    disturbance : Disturbance
    key : str
        The key an error names (``--plant`` when the command line chose the model).

    Raises
    ------
    InputError
        For a vehicle without a steering angle and its rate, a tractor-trailer (not yet), a model
        whose speed is not along the heading times a factor of the steering angle, the disturbances
        of the kinematic plant (speed gain, steering bias, drift), axle distances that do not add
        up to the plant's wheelbase.
    """
    if settings.model == "kinematic":
        return
    r = vehicle.roles
    lengths = set(vehicle.parameter_keys.values())
    if len(r.trailers) > 1 or (r.trailers and not {"hitch_offset", "trailer_wheelbase"} <= lengths):
        raise InputError(key, f'"single-track" is not yet for {vehicle.model} (one semitrailer on a hitch only)')
    if r.steering is None or r.steering_rate is None or r.steering_rate not in vehicle.controls:
        raise InputError(key, f'"single-track" needs a steering angle and its rate; the {vehicle.model} model has none')
    if "wheelbase" not in vehicle.parameter_keys.values():
        raise InputError(key, f'"single-track" needs a wheelbase; the {vehicle.model} model has none')
    for name in ("speed_gain", "steering_bias", "drift"):
        if getattr(disturbance, name) != getattr(Disturbance(), name):
            raise InputError(f"disturbance.{name}", 'for the kinematic plant only (not with "single-track")')
    _axle_distances(settings.values, vehicle, disturbance)
    _trailer_numbers(settings.values, vehicle, disturbance)


def _trailer_numbers(values: dict[str, Any], vehicle: Vehicle, disturbance: Disturbance) -> None:
    """The trailer's numbers only with a trailer; no load transfer (cg_height) in the tractor-semitrailer
    plant; the trailer's centre of gravity between the kingpin and the trailer axle."""
    keys = {name: key for key, name in PLANT_NUMBERS.items()}
    if not vehicle.roles.trailers:
        for name in sorted(TRAILER_NUMBERS & set(values)):
            raise InputError("plant." + keys[name], f"only for a model with a trailer, not {vehicle.model}")
        return
    if "h_cg" in values:
        raise InputError("plant.cg_height", "the tractor-semitrailer plant has no load transfer; leave it out")
    length = disturbance.wheelbase.get("trailer_wheelbase", vehicle.parameter_values()["trailer_wheelbase"])
    if values.get("trailer_cg", 0.0) >= length:
        raise InputError("plant.hitch_to_trailer_cg", f"must be < the trailer wheelbase {length:g} m")


def _axle_distances(values: dict[str, Any], vehicle: Vehicle, disturbance: Disturbance) -> None:
    """Both axle distances given: their sum is the plant's wheelbase; one: it is shorter than the wheelbase."""
    wheelbase = disturbance.wheelbase.get("wheelbase", vehicle.parameter_values()["wheelbase"])
    given = {name: values[name] for name in ("lf", "lr") if name in values}
    keys = {"lf": "plant.cg_to_front_axle", "lr": "plant.cg_to_rear_axle"}
    if len(given) == 2 and abs(given["lf"] + given["lr"] - wheelbase) > LENGTH_TOL:
        raise InputError(
            keys["lr"], f"cg_to_front_axle + cg_to_rear_axle = {given['lf'] + given['lr']:g} m must be the wheelbase "
            f"{wheelbase:g} m (give one, the other follows)",
        )  # fmt: skip
    for name, val in given.items():
        if len(given) == 1 and val >= wheelbase:
            raise InputError(keys[name], f"must be < the wheelbase {wheelbase:g} m, got {val:g}")


def _acceleration_limits(val: Any) -> tuple[float, float]:
    ok = isinstance(val, list) and len(val) == 2 and all(is_number(v) and math.isfinite(v) for v in val)
    if not ok or not val[0] < 0 < val[1]:
        raise InputError("plant.acceleration_limits", f"must be [lo, hi] with lo < 0 < hi (m/s^2), got {val!r}")
    return float(val[0]), float(val[1])


__all__ = ["ControlSettings", "Disturbance", "PlantSettings", "check_plant", "parse_closed_loop", "parse_plant"]
