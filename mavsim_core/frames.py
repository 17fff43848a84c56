"""The one place where MuJoCo's ENU/FLU frames meet MAVLink's NED/FRD frames.

MuJoCo world: x East, y North, z Up (ENU).  MuJoCo body: x forward, y left, z up
(FLU).  MAVLink world: North, East, Down (NED); body: forward, right, down (FRD).
Quaternions are (w, x, y, z); :func:`wxyz_to_xyzw` / :func:`xyzw_to_wxyz` are the
only conversions to SciPy's (x, y, z, w) order.
"""

from __future__ import annotations

import math

import numpy as np

from mavsim_core.quaternion import mul

# q_NED<-ENU: maps ENU vectors to NED (swap x/y, negate z): rotation of pi about (1,1,0)/sqrt2.
_Q_NED_ENU = np.array([0.0, math.sqrt(0.5), math.sqrt(0.5), 0.0])
# q_FLU<-FRD: rotation of pi about x.
_Q_FLU_FRD = np.array([0.0, 1.0, 0.0, 0.0])


def enu_to_ned(v_enu: np.ndarray) -> np.ndarray:
    """World vector ENU -> NED."""
    return np.array([v_enu[1], v_enu[0], -v_enu[2]])


def ned_to_enu(v_ned: np.ndarray) -> np.ndarray:
    """World vector NED -> ENU (the same swap; it is its own inverse)."""
    return np.array([v_ned[1], v_ned[0], -v_ned[2]])


def flu_to_frd(v_flu: np.ndarray) -> np.ndarray:
    """Body vector FLU -> FRD (and FRD -> FLU: its own inverse)."""
    return np.array([v_flu[0], -v_flu[1], -v_flu[2]])


frd_to_flu = flu_to_frd


def quat_enu_flu_to_ned_frd(q_enu_flu: np.ndarray) -> np.ndarray:
    """Attitude quaternion (w,x,y,z) FLU->ENU (MuJoCo) to FRD->NED (MAVLink)."""
    out = mul(mul(_Q_NED_ENU, q_enu_flu), _Q_FLU_FRD)
    if out[0] < 0:
        out = -out
    return out


def quat_ned_frd_to_enu_flu(q_ned_frd: np.ndarray) -> np.ndarray:
    """Inverse of :func:`quat_enu_flu_to_ned_frd`."""
    # q_enu_flu = q_enu_ned * q_ned_frd * q_frd_flu; both fixed rotations are their own inverse up to sign.
    out = mul(mul(_Q_NED_ENU, q_ned_frd), _Q_FLU_FRD)
    if out[0] < 0:
        out = -out
    return out


def wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    """(w, x, y, z) -> SciPy's (x, y, z, w)."""
    return np.array([q[1], q[2], q[3], q[0]])


def xyzw_to_wxyz(q: np.ndarray) -> np.ndarray:
    """SciPy's (x, y, z, w) -> (w, x, y, z)."""
    return np.array([q[3], q[0], q[1], q[2]])


def heading_to_ned(forward: float, right: float, yaw_rad: float) -> np.ndarray:
    """A horizontal vector of the heading frame (forward, right; the body frame turned by the yaw only)
    as (north, east), for a vehicle heading ``yaw_rad`` (rad from north, clockwise)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([c * forward - s * right, s * forward + c * right])
