"""An attitude quaternion with its rotation matrix made only when read (the EKF's and the estimator's output).

The quaternion changes at every IMU sample (250 Hz); the matrix is read far less often (the 50 Hz outer
loop, the filters' corrections), so it is built from the quaternion on the first read after a change.
"""

from __future__ import annotations

import numpy as np

from mavsim_core import quaternion as quat


class LazyAttitudeMatrix:
    """``q``: unit quaternion (w, x, y, z), FRD -> NED; ``r_ned_frd``: the same as a 3x3 rotation matrix.

    Assigning ``q`` drops the matrix; a subclass that writes ``_q`` directly sets ``_r_ned_frd = None``
    itself (or to the matrix it already has)."""

    _q: np.ndarray
    _r_ned_frd: np.ndarray | None = None

    @property
    def q(self) -> np.ndarray:
        """Attitude: unit quaternion (w, x, y, z), FRD -> NED."""
        return self._q

    @q.setter
    def q(self, value: np.ndarray) -> None:
        self._q = value
        self._r_ned_frd = None

    @property
    def r_ned_frd(self) -> np.ndarray:
        """The attitude as a rotation matrix (FRD -> NED), made from :attr:`q` when first read after a change."""
        r = self._r_ned_frd
        if r is None:
            r = self._r_ned_frd = quat.to_matrix(self._q)
        return r
