"""The simulator's camera-frame log read back: what the vision companion saw in each frame.

``<stem>.frames.npy`` lies beside the flight's ``<stem>.truth.npy`` (written by ``sitl/truth_log.py``): one record
per camera frame, stamped with its capture time (simulated microseconds, the truth log's clock), holding the
gimbal's joint angles then (``gimbal_{roll,pitch,yaw}_deg``, degrees; NaN for a fixed camera), whether the frame
was rendered, and the ids of the pad's markers the detector used (``n_markers``, ``marker_0`` ...; -1 past
``n_markers``).  Flights logged before this file existed have none: :func:`frames_beside` then gives None.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mavsim_core.npy_log import read_npy_log

TRUTH_SUFFIX, FRAMES_SUFFIX = ".truth.npy", ".frames.npy"
GIMBAL_COLUMNS = ("gimbal_roll_deg", "gimbal_pitch_deg", "gimbal_yaw_deg")


def frames_path(truth: Path) -> Path:
    """The camera-frame log that belongs to the truth log ``truth`` (same stem)."""
    name = truth.name[: -len(TRUTH_SUFFIX)] if truth.name.endswith(TRUTH_SUFFIX) else truth.stem
    return truth.with_name(name + FRAMES_SUFFIX)


def read_frames(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """A camera-frame log as (capture times in simulated seconds, columns as float arrays by name)."""
    a = read_npy_log(path)
    return a["time_us"] / 1e6, {name: a[name].astype(float) for name in a.dtype.names if name != "time_us"}


def frames_beside(truth: Path) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """:func:`read_frames` of the truth log's frame log, or None when there is none (or it holds no frame)."""
    path = frames_path(truth)
    if not path.exists():
        return None
    t_s, cols = read_frames(path)
    return (t_s, cols) if t_s.size else None


def marker_ids(cols: dict[str, np.ndarray]) -> np.ndarray:
    """The ids of every marker used in any frame, sorted (int)."""
    ids = np.concatenate([cols[k] for k in cols if k.startswith("marker_")] or [np.empty(0)])
    return np.unique(ids[ids >= 0]).astype(int)


def frames_using(cols: dict[str, np.ndarray], marker_id: int) -> np.ndarray:
    """A boolean per frame: the detector used marker ``marker_id`` in it."""
    used = [cols[k] == marker_id for k in cols if k.startswith("marker_")]
    return np.logical_or.reduce(used) if used else np.zeros(len(cols["n_markers"]), bool)
