"""Vehicle models, one file per model; each names its states, controls and SymPy dynamics.

A new vehicle is one small subclass of ``Vehicle``: the transcription, the validator
and the Pontryagin engine read ``states``, ``controls`` and ``dynamics()`` only.
"""

from model.vehicles.base import Vehicle, sym
from model.vehicles.truck import Truck
from model.vehicles.unicycle import Unicycle

VEHICLES: dict[str, type[Vehicle]] = {"truck": Truck, "unicycle": Unicycle}

__all__ = ["VEHICLES", "Truck", "Unicycle", "Vehicle", "sym"]
