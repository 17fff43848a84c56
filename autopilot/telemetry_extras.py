"""The part of the telemetry snapshot that the extra messages need (autopilot/mavlink/telemetry_more.py).

:class:`TelemetryExtras` rides on :class:`autopilot.topics.TelemetrySnapshot` (``extras``): the IMU
sample the flight controller stepped on last (HIGHRES_IMU, ALTITUDE's barometric altitude), the
wall-clock UTC time the simulated clock started from (SYSTEM_TIME, UTM_GLOBAL_POSITION) and the
flight's number, arming, take-off and landing times (FLIGHT_INFORMATION), which :class:`FlightTimes`
keeps from the commander's status records as PX4's vehicle_status keeps armed_time and takeoff_time.
Times are simulated microseconds since the simulator started (MAVLink's "since boot"); 0 means "not yet".
It also carries the latest MANUAL_CONTROL the vehicle read (the MANUAL_CONTROL stream echoes it).
The flight number is the parameter COM_FLIGHT_UUID (PX4's): the commander adds one at each arming
(:func:`count_flight`), so it is the latest flight's number (0: no flight yet), and with ``--state-dir`` it is
saved like any changed parameter and the next start continues the count.  (PX4 adds one at each disarm, so
between flights it reports the next flight's number where this reports the last one's.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from autopilot.manual_input import ManualInput
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import CommanderStatus, ImuSample
from mavsim_core.param_types import ParamType

FLIGHT_UUID_MAX = 2**31 - 1  # an INT32 parameter
PARAMS: tuple[ParamDef, ...] = (
    param(
        "COM_FLIGHT_UUID", 0, 0, FLIGHT_UUID_MAX, "",
        "Flight number: one more at each arming (FLIGHT_INFORMATION.flight_uuid), kept with --state-dir",
        ParamType.INT32,
    ),
)  # fmt: skip


def count_flight(params: ParameterStore) -> int:
    """A new flight (an arming): COM_FLIGHT_UUID one more (back to 1 past the INT32 range); the new number
    (0 and nothing counted in a store without it)."""
    if "COM_FLIGHT_UUID" not in params:
        return 0
    number = int(params.get("COM_FLIGHT_UUID")) + 1
    number = number if number <= FLIGHT_UUID_MAX else 1
    params.set("COM_FLIGHT_UUID", number)
    return number


@dataclass(frozen=True, slots=True)
class TelemetryExtras:
    """See the module docstring."""

    imu: ImuSample | None = None  # the latest sample the flight controller stepped on
    utc_at_zero_us: int = 0  # UTC (µs since the Unix epoch) at simulated time 0; 0 unknown
    armed_us: int = 0  # the latest arming (kept after disarming: the last flight's)
    takeoff_us: int = 0  # the latest take-off (the land detector's "in air") since that arming
    landed_us: int = 0  # the latest landing after that take-off
    flight_number: int = 0  # the latest flight's number (COM_FLIGHT_UUID; 0: none yet)
    manual: ManualInput | None = None  # the latest sticks read (None: none yet)


class FlightTimes:
    """Arming, take-off and landing times, from each new commander status record (see the module docstring);
    the flight number from ``flight_number()`` (COM_FLIGHT_UUID), or the armings counted here without it."""

    def __init__(self, flight_number: Callable[[], int] | None = None) -> None:
        self._flight_number = flight_number
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

    def extras(self, imu: ImuSample | None, utc_at_zero_us: int, manual: ManualInput | None = None) -> TelemetryExtras:
        number = self._flight_number() if self._flight_number is not None else self.flights
        return TelemetryExtras(imu, utc_at_zero_us, self.armed_us, self.takeoff_us, self.landed_us, number, manual)
