"""Type aliases shared by the packages (numpy arrays of SI values)."""

from __future__ import annotations

from typing import TypeAlias

import numpy as np
from numpy.typing import NDArray

__all__ = ['FloatArray']

#: A float64 array: displacements [m], forces [N], matrices.
FloatArray: TypeAlias = NDArray[np.float64]
