"""What arrives from outside the vehicle and steers it: sticks, offboard setpoints, ground-station heartbeats,
the target to follow.

:class:`ExternalInputs` keeps the latest MANUAL_CONTROL (:class:`~autopilot.topics.ManualInput`),
the latest offboard setpoint (:class:`~autopilot.topics.OffboardSetpoint`; OFFBOARD may be entered
while it is recent, as in PX4: :func:`autopilot.navigation.offboard.offboard_refusal`), and when a ground
station's HEARTBEAT last arrived (the data-link-loss failsafe), and the latest FOLLOW_TARGET
(:class:`~autopilot.navigation.follow_target_estimator.FollowTargetFix`) of the sender being followed
(:meth:`ExternalInputs.on_follow_target`), and the reach of the camera gimbal device the flight controller's
gimbal manager sees (:meth:`ExternalInputs.on_gimbal_reach`: a precision landing's view cone, PLD_CAM_REACH -1).
The link writes into it through the vehicle interface
(FOLLOW_TARGET: :mod:`autopilot.mavlink.follow_target_input`); the commander's mode tasks and
failsafes read it.  Every arrival carries its
simulated time (µs) and wall-clock time (s, time.monotonic): ages are
:func:`autopilot.topics.input_age_s` of both, or of the simulated time alone when ``on_wall_clock`` is
False (``autopilot --input-clock sim``: the clients act in simulated time, as a script stepping a held
simulator does, and nothing depends on the machine's speed).
"""

from __future__ import annotations

from autopilot.navigation.follow_target_estimator import TARGET_TIMEOUT_S, FollowTargetFix
from autopilot.topics import ManualInput, OffboardSetpoint, input_age_s


class ExternalInputs:
    """The latest sticks, offboard setpoint and ground-station heartbeat (see the module docstring)."""

    def __init__(self) -> None:
        self.manual: ManualInput | None = None
        self.offboard: OffboardSetpoint | None = None
        self.gcs_heartbeat: tuple[int, float] | None = None  # (sim µs, wall s) of the latest
        self.follow_target: FollowTargetFix | None = None  # the latest from the sender being followed
        self.on_wall_clock = True  # False: ages on simulated time alone (the module docstring)
        # How far the gimbal device turns the camera from the body's down axis (rad; None: no device reports),
        # published by the gimbal manager at each of the simulator link's scheduled steps.
        self.gimbal_reach_rad: float | None = None

    def on_manual(self, sticks: ManualInput) -> None:
        self.manual = sticks

    def on_offboard(self, setpoint: OffboardSetpoint) -> None:
        self.offboard = setpoint

    def on_gcs_heartbeat(self, now_us: int, wall_s: float) -> None:
        self.gcs_heartbeat = (now_us, wall_s)

    def on_gimbal_reach(self, reach_rad: float | None) -> None:
        """The gimbal device's reach now (rad from the body's down axis; None: no device reports, a fixed camera)."""
        self.gimbal_reach_rad = reach_rad

    def on_follow_target(self, fix: FollowTargetFix) -> bool:
        """Keep ``fix`` if its sender is the one followed, or that one has been silent for TARGET_TIMEOUT_S
        (on both clocks): the first sender heard keeps the target until it goes silent.  Whether it was kept."""
        cur = self.follow_target
        if cur is not None and fix.source != cur.source:
            if (
                self._age(cur.received_us, cur.received_wall_s, fix.received_us, fix.received_wall_s)
                <= TARGET_TIMEOUT_S
            ):
                return False
        self.follow_target = fix
        return True

    # -- ages (s); None when the input never arrived
    def _age(self, received_us: int, received_wall_s: float, now_us: int, wall_s: float | None) -> float:
        """:func:`~autopilot.topics.input_age_s`, on simulated time alone unless ``on_wall_clock``."""
        return input_age_s(received_us, received_wall_s, now_us, wall_s if self.on_wall_clock else None)

    def manual_age_s(self, now_us: int, wall_s: float | None) -> float | None:
        m = self.manual
        return None if m is None else self._age(m.received_us, m.received_wall_s, now_us, wall_s)

    def offboard_age_s(self, now_us: int, wall_s: float | None) -> float | None:
        o = self.offboard
        return None if o is None else self._age(o.received_us, o.received_wall_s, now_us, wall_s)

    def gcs_age_s(self, now_us: int, wall_s: float | None) -> float | None:
        h = self.gcs_heartbeat
        return None if h is None else self._age(h[0], h[1], now_us, wall_s)

    def follow_target_age_s(self, now_us: int, wall_s: float | None) -> float | None:
        f = self.follow_target
        return None if f is None else self._age(f.received_us, f.received_wall_s, now_us, wall_s)
