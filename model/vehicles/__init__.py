"""Vehicle models, one file per model; each names its states, controls and SymPy dynamics.

A new vehicle is one small subclass of ``Vehicle``: the transcription, the validator
and the Pontryagin engine read ``states``, ``controls`` and ``dynamics()`` only.
Bodies (``Body``) and named parameter presets (``preset``, ``PRESETS``) live beside them.
"""

from model.vehicles.base import Vehicle, sym
from model.vehicles.body import Body, Cover
from model.vehicles.presets import PRESETS, preset
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
    "Body",
    "Cover",
    "TractorTrailer",
    "Tricycle",
    "Truck",
    "Unicycle",
    "Vehicle",
    "preset",
    "sym",
]
