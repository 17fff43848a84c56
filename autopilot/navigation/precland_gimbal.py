"""Where a precision landing wants the camera gimbal: a pure decision, applied by the gimbal manager.

Issue 34: over a turning or wind-blown deck the vehicle tilts 20-40 deg and a camera that only holds the
horizon looks past the marker; pointing it at the landing target's estimate keeps the marker in view.  The
decision (:func:`landing_gimbal_request`) reads the landing's phase, the target's estimated position and the
vehicle's, and returns a :class:`autopilot.topics.GimbalRequest`:

* TRACKING, APPROACHING, DOCKING with a target estimate more than NEAR_NADIR_DEG off straight down: ALONG the line
  from the vehicle to it; nearer: DOWN, which sees it as well (the 90 x 74 deg lens sees 37 deg fore and aft, 45
  to the sides).  Pointed along the line near the nadir, the camera's yaw follows the target's bearing, which
  turns fast under the vehicle: over a 2 m circle at 2 m/s it passed behind the nose every 6 s, the yaw joint met
  its +-160 deg stop and slewed 320 deg the other way round at 180 deg/s, and for 0.7 s the camera looked 55-70 deg
  off the marker (kept logs of the campaign, issue 34 item 5);
* PREPARATION, SEARCH, FALLBACK (no target, or one lost and being searched for) and the phases above without an
  estimate: DOWN;
* no precision landing, DONE (the motors cut), or PLD_GIMB_POINT 0: RELEASE (the gimbal back to whoever held it
  before the landing, :mod:`autopilot.mavlink.gimbal_manager`).

Frames: NED metres from the estimator's origin.  The companion computer turns detections into the body frame
with the gimbal's measured angles at capture, so the pointing never bends the LANDING_TARGET geometry.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.control.gimbal_pointing import NO_GIMBAL_REQUEST, GimbalAim, GimbalRequest
from autopilot.navigation.precland import PrecLandPhase
from autopilot.parameters import ParamDef, ParamType, param

PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_GIMB_POINT", 1, 0, 1, "",
        "Precision landing points the camera gimbal at the target estimate (straight down without one) and "
        "gives control back after: 1 on, 0 off (the gimbal is left to its clients)",
        ParamType.INT32,
    ),
)  # fmt: skip

TOWARD_TARGET_PHASES = frozenset(
    {PrecLandPhase.TRACKING, PrecLandPhase.APPROACHING, PrecLandPhase.DOCKING, PrecLandPhase.TOUCHDOWN}
)
DOWN_PHASES = frozenset({PrecLandPhase.PREPARATION, PrecLandPhase.SEARCH, PrecLandPhase.FALLBACK})
LOOK_DOWN = GimbalRequest(GimbalAim.DOWN)
TOO_CLOSE_M = 1e-3  # a target estimate this close to the vehicle gives no direction: look down
NEAR_NADIR_DEG = 25.0  # a target estimate within this of straight down: look down (no yaw to follow its bearing)


def landing_gimbal_request(
    enabled: bool,
    phase: PrecLandPhase | None,
    target_pos_ned_m: np.ndarray | None,
    vehicle_pos_ned_m: np.ndarray | None,
) -> GimbalRequest:
    """The gimbal request of a precision landing in ``phase`` (None: no precision landing) with the target's
    estimated position and the vehicle's (NED m, one origin; None: unknown); ``enabled``: PLD_GIMB_POINT."""
    if not enabled or phase is None or (phase not in TOWARD_TARGET_PHASES and phase not in DOWN_PHASES):
        return NO_GIMBAL_REQUEST
    if phase in DOWN_PHASES or target_pos_ned_m is None or vehicle_pos_ned_m is None:
        return LOOK_DOWN
    line = np.asarray(target_pos_ned_m, float) - np.asarray(vehicle_pos_ned_m, float)
    if not np.all(np.isfinite(line)) or float(np.linalg.norm(line)) < TOO_CLOSE_M:
        return LOOK_DOWN
    n, e, d = (float(c) for c in line)
    if d > 0.0 and math.degrees(math.atan2(math.hypot(n, e), d)) < NEAR_NADIR_DEG:
        return LOOK_DOWN
    return GimbalRequest(GimbalAim.ALONG, (n, e, d))
