"""Array helpers shared by the grasp core: the float array type and read-only marking."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def read_only(array: np.ndarray) -> np.ndarray:
    """Mark an array read-only: grasp sets and poses are shared, never edited in place."""
    array.flags.writeable = False
    return array
