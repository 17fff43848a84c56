"""File names of flight logs: ``YYYY-MM-DD_HH-MM-SS`` of arming, as QGroundControl names its tlogs.

Shared by the flight controller's logs (``.tlog``, ``.ulg``) and the simulator's ground-truth
log (``.truth.npy``) so that the files of one flight sort and pair by name.
"""

from __future__ import annotations

import time
from pathlib import Path


def flight_stem(log_dir: Path, epoch_s: float, instance: int = 0, suffixes: tuple[str, ...] = ()) -> str:
    """``YYYY-MM-DD_HH-MM-SS`` (local time) [``_i<instance>``], made unique among ``suffixes`` in ``log_dir``."""
    stem = time.strftime("%Y-%m-%d_%H-%M-%S", time.localtime(epoch_s)) + (f"_i{instance}" if instance else "")
    candidate, n = stem, 1
    while any((log_dir / (candidate + sfx)).exists() for sfx in suffixes):
        n += 1
        candidate = f"{stem}_{n}"
    return candidate
