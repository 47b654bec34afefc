"""Node trajectories as named columns: a pandas DataFrame or a plain mapping of arrays."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

Columns = Mapping[str, Any]  # a DataFrame, or a dict of name -> 1-D array


def as_arrays(columns: Columns) -> dict[str, np.ndarray]:
    """Every column as a float array (iterating a DataFrame or a dict yields its column names)."""
    return {name: np.asarray(columns[name], dtype=float) for name in columns}
