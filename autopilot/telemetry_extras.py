"""The part of the telemetry snapshot that the extra messages need (autopilot/mavlink/telemetry_more.py).

:class:`TelemetryExtras` rides on :class:`autopilot.topics.TelemetrySnapshot` (``extras``): the IMU
sample the flight controller stepped on last (HIGHRES_IMU, ALTITUDE's barometric altitude), the
wall-clock UTC time the simulated clock started from (SYSTEM_TIME, UTM_GLOBAL_POSITION) and the
flight's number, arming, take-off and landing times (FLIGHT_INFORMATION), which :class:`FlightTimes`
keeps from the commander's status records as PX4's vehicle_status keeps armed_time and takeoff_time.
Times are simulated microseconds since the simulator started (MAVLink's "since boot"); 0 means "not yet".
The flight number counts the armings since start (1 = the first flight; PX4 keeps a saved
COM_FLIGHT_UUID instead).
"""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.topics import CommanderStatus, ImuSample


@dataclass(frozen=True, slots=True)
class TelemetryExtras:
    """See the module docstring."""

    imu: ImuSample | None = None  # the latest sample the flight controller stepped on
    utc_at_zero_us: int = 0  # UTC (µs since the Unix epoch) at simulated time 0; 0 unknown
    armed_us: int = 0  # the latest arming (kept after disarming: the last flight's)
    takeoff_us: int = 0  # the latest take-off (the land detector's "in air") since that arming
    landed_us: int = 0  # the latest landing after that take-off
    flight_number: int = 0  # armings since start: the latest flight's number (0: none yet)


class FlightTimes:
    """Arming, take-off and landing times, from each new commander status record (see the module docstring)."""

    def __init__(self) -> None:
        self._reset()

    def _reset(self) -> None:
        self.armed_us = self.takeoff_us = self.landed_us = self.flights = 0
        self._armed = self._in_air = False
        self._last_us = 0

    def update(self, status: CommanderStatus) -> None:
        """Note the transitions since the previous record (a record published at ``status.timestamp_us``)."""
        now = status.timestamp_us
        if now < self._last_us:  # the simulated clock restarted: the old times are from another run
            self._reset()
        self._last_us = now
        if status.armed and not self._armed:
            self.armed_us, self.takeoff_us, self.landed_us = now, 0, 0
            self.flights += 1
        if status.in_air and not self._in_air:
            self.takeoff_us, self.landed_us = now, 0
        elif self._in_air and not status.in_air:
            self.landed_us = now
        self._armed, self._in_air = status.armed, status.in_air

    def extras(self, imu: ImuSample | None, utc_at_zero_us: int) -> TelemetryExtras:
        return TelemetryExtras(imu, utc_at_zero_us, self.armed_us, self.takeoff_us, self.landed_us, self.flights)
