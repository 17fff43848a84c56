"""3-vectors as plain Python floats: the per-step code works on floats (NumPy's per-call cost on three
values would be most of the work), and its inputs come as arrays or as sequences."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def floats3(v: np.ndarray | Sequence[float]) -> list[float]:
    """A 3-vector's components as Python floats (``tolist`` is the fast way out of an array)."""
    return v.tolist() if isinstance(v, np.ndarray) else [float(v[0]), float(v[1]), float(v[2])]
