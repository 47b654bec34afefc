"""Vehicle models, one file per model; each names its states, controls, their roles and SymPy dynamics.

A new vehicle is one small subclass of ``Vehicle``: the transcription, the validator
and the Pontryagin engine read ``states``, ``controls`` and ``dynamics()`` only; what needs
to know which state is the heading or which control the speed (guesses, routes, the plant,
the controllers, the plots) reads ``roles``, a ``Roles``: the position ``x, y``, ``heading``,
``steering``, the controls ``speed``, ``steering_rate`` (or ``turn_rate``) and the
``trailers``' headings. Its defaults are the paper truck's names (x, y, theta, phi; u1, u2),
so a model with other names or another order declares them, e.g.::

    @dataclass
    class Car(Vehicle):
        model = "car"
        states = ("psi", "px", "py", "delta")
        controls = ("steer_rate", "v")
        roles = Roles(x="px", y="py", heading="psi", steering="delta", speed="v", steering_rate="steer_rate")

        def dynamics(self): ...

No name outside ``model/vehicles/`` is a literal state or control name (``tests/test_vehicle_roles.py``).
Bodies (``Body``) and named parameter presets (``preset``, ``PRESETS``) live beside them.
"""

from model.vehicles.base import Roles, Vehicle, expression, sym
from model.vehicles.body import Body, Cover
from model.vehicles.longitudinal import Longitudinal, integrated_speed
from model.vehicles.presets import PRESETS, OperationalLimits, operational_limits, preset
from model.vehicles.tractor_trailer import TractorTrailer
from model.vehicles.tricycle import Tricycle
from model.vehicles.truck import Truck
from model.vehicles.unicycle import Unicycle

VEHICLES: dict[str, type[Vehicle]] = {
    "truck": Truck,
    "tricycle": Tricycle,
    "unicycle": Unicycle,
    "tractor-trailer": TractorTrailer,
}

__all__ = [
    "PRESETS",
    "VEHICLES",
    "Roles",
    "Body",
    "Longitudinal",
    "Cover",
    "OperationalLimits",
    "TractorTrailer",
    "Tricycle",
    "Truck",
    "Unicycle",
    "Vehicle",
    "preset",
    "operational_limits",
    "expression",
    "integrated_speed",
    "sym",
]
