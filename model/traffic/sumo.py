"""Finding Eclipse SUMO (the PyPI wheels ``eclipse-sumo`` and ``traci``), nothing downloaded at run time."""

from __future__ import annotations

import importlib
import shutil
from dataclasses import dataclass
from pathlib import Path

from model.errors import InputError

PACKAGES = "eclipse-sumo==1.28.0 traci==1.28.0 sumolib==1.28.0"


@dataclass(frozen=True)
class Sumo:
    """The binaries ``sumo`` and ``netconvert``, the ``traci`` module and SUMO's version."""

    sumo: str
    netconvert: str
    traci: object
    version: str


def find_sumo() -> Sumo:
    """SUMO from the installed wheels.

    Raises
    ------
    InputError
        Naming the package to install (``eclipse-sumo`` or ``traci``) if one is missing.
    """
    try:
        sumo = importlib.import_module("sumo")
    except ImportError:
        raise InputError("eclipse-sumo", f"not installed: pip install {PACKAGES}") from None
    try:
        traci = importlib.import_module("traci")
    except ImportError:
        raise InputError("traci", f"not installed: pip install {PACKAGES}") from None
    home = Path(sumo.SUMO_HOME) / "bin"
    binaries = [str(home / n) if (home / n).exists() else shutil.which(n) for n in ("sumo", "netconvert")]
    if None in binaries:
        raise InputError("eclipse-sumo", f"its sumo and netconvert binaries are missing: pip install {PACKAGES}")
    version = importlib.import_module("importlib.metadata").version("eclipse-sumo")
    return Sumo(binaries[0], binaries[1], traci, version)


__all__ = ["PACKAGES", "Sumo", "find_sumo"]
