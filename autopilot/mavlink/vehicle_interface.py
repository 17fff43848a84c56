"""What the ground-station link needs from the flight controller, and its implementation.

The link (:mod:`autopilot.mavlink.link`) talks MAVLink to a :class:`VehicleInterface`;
keeping it a Protocol lets the link be tested with nothing flying and keeps the link
free of flight logic.  :class:`FlightControllerVehicle` implements it for a
:class:`~autopilot.flight_controller.FlightController`: telemetry is gathered from the
frozen records the parts publish (:func:`telemetry_snapshot`), commands run through the
command table (:mod:`autopilot.mavlink.commands`) on the commander's typed methods.
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING, Any, Protocol

from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander import health
from autopilot.mavlink import commands, control_messages, offboard_messages
from autopilot.parameters import ParameterStore
from autopilot.telemetry_extras import FlightTimes, TelemetryExtras
from autopilot.topics import (
    ActuatorStatus,
    BatteryWarning,
    CommanderStatus,
    ControlSetpoints,
    EstimatorStatus,
    TelemetrySnapshot,
)
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.flight_controller import FlightController


class VehicleInterface(Protocol):
    params: ParameterStore

    def snapshot(self) -> TelemetrySnapshot:
        """Current state for telemetry (cheap; called once per link update)."""

    def handle_command(self, command: int, params: tuple[float, ...], frame: int) -> int:
        """Run a COMMAND_LONG/COMMAND_INT and return its MAV_RESULT.

        ``params`` are the seven float parameters (for COMMAND_INT, params 5 and 6
        are already converted from degE7 to degrees).  A refusal queues a STATUSTEXT
        saying why (see :meth:`pop_events`).  Unknown commands return
        MAV_RESULT_UNSUPPORTED.  Commands handled by the link itself
        (REQUEST_MESSAGE, SET_MESSAGE_INTERVAL, REQUEST_AUTOPILOT_CAPABILITIES) never
        reach this method.
        """

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        """SET_MODE message or MAV_CMD_DO_SET_MODE: return MAV_RESULT."""

    def pop_events(self) -> list[tuple[int, str]]:
        """STATUSTEXT events (severity, text) queued since the last call."""

    def on_landing_target(self, msg: Any, src_sysid: int) -> None:
        """A LANDING_TARGET from a companion computer (any sender: the vehicle checks the system id)."""

    def on_control_message(self, msg: Any, now_us: int) -> None:
        """MANUAL_CONTROL, SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT or SET_ATTITUDE_TARGET addressed to us,
        received at simulated time ``now_us``."""

    def on_gcs_heartbeat(self, now_us: int) -> None:
        """A ground station's HEARTBEAT arrived (the data-link-loss failsafe's input)."""

    # The stored plans, for the mission protocol (autopilot.mavlink.mission_protocol.PlanHolder).
    def plan(self, mission_type: int) -> list[MissionItem]: ...
    def check_item(self, item: MissionItem) -> tuple[int, str]: ...
    def replace_plan(self, mission_type: int, items: list[MissionItem]) -> tuple[int, str]: ...
    def set_mission_current(self, seq: int) -> tuple[bool, str]: ...

    def pop_mission_reached(self) -> list[int]:
        """Mission items reached since the last call (MISSION_ITEM_REACHED)."""


def telemetry_snapshot(
    status: CommanderStatus,
    actuators: ActuatorStatus,
    control: ControlSetpoints | None,
    estimator_status: EstimatorStatus | None,
    ekf_in_use: bool,
    extras: TelemetryExtras | None = None,
) -> TelemetrySnapshot:
    """Everything the link reports, from the records of the commander, the controllers and the estimator.

    MAV_STATE: BOOT before the first estimate, EMERGENCY at battery emergency or after a failsafe stopped
    the motors, CRITICAL while a failsafe action is flown, ACTIVE armed, STANDBY disarmed; PX4's base_mode
    flags and custom_mode of the commander's mode; SYS_STATUS bits by :mod:`autopilot.commander.health`,
    the RC receiver's once sticks were seen (unhealthy when lost), the battery's unhealthy from critical.
    """
    armed = status.armed
    prearm_ok = armed or not status.prearm_failures
    if status.estimate is None:
        system_status = mavlink.MAV_STATE_BOOT
    elif status.failsafe.emergency:
        system_status = mavlink.MAV_STATE_EMERGENCY
    elif armed and status.failsafe.action_in_force:
        system_status = mavlink.MAV_STATE_CRITICAL
    elif armed:
        system_status = mavlink.MAV_STATE_ACTIVE
    else:
        system_status = mavlink.MAV_STATE_STANDBY
    sensors = health.SENSORS_PRESENT
    fence_bit = mavlink.MAV_SYS_STATUS_GEOFENCE if status.mission.fence_items else 0
    fence_ok = 0 if status.mission.fence_breached else fence_bit
    rc_bit = mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER if status.failsafe.rc_seen else 0
    fence_bit |= rc_bit  # (the geofence's and the RC receiver's bits: present when used)
    fence_ok |= 0 if status.failsafe.rc_lost else rc_bit
    battery_bad = mavlink.MAV_SYS_STATUS_SENSOR_BATTERY if status.battery_warning >= BatteryWarning.CRITICAL else 0
    return TelemetrySnapshot(
        timestamp_us=status.timestamp_us, mav_type=status.mav_type, armed=armed,
        base_mode=status.mode.base_mode_flags(armed), custom_mode=status.mode.custom_mode,
        system_status=system_status, landed_state=status.landed_state, estimate=status.estimate, gps=status.gps,
        home=status.home, battery=status.battery, throttle_frac=actuators.throttle_frac,
        sensors_present=sensors | fence_bit, sensors_enabled=sensors | fence_bit,
        sensors_health=fence_ok
        | health.sensors_health(status.estimate, status.gps_ok, estimator_status, ekf_in_use, prearm_ok) & ~battery_bad,
        prearm_ok=prearm_ok, position_setpoint_ned_m=status.position_setpoint_ned_m,
        motor_outputs=actuators.motor_outputs, control=control, estimator_status=estimator_status,
        battery_warning=status.battery_warning, mission=status.mission, extras=extras,
    )  # fmt: skip


class FlightControllerVehicle:
    """:class:`VehicleInterface` of a running :class:`~autopilot.flight_controller.FlightController`."""

    def __init__(self, fc: "FlightController") -> None:
        self.fc = fc
        self.params = fc.params
        # SYSTEM_TIME's clock, as PX4 SITL's: the wall clock at the first step, advancing with simulated time
        self.utc_at_zero_us = 0  # (UTC µs at simulated time 0; 0 unknown, before the first step)
        self.flight_times = FlightTimes(lambda: int(fc.params.get("COM_FLIGHT_UUID")))

    def snapshot(self) -> TelemetrySnapshot:
        fc = self.fc
        estimator, status = fc.estimator, fc.commander.status
        if not self.utc_at_zero_us and fc.last_us is not None:
            self.utc_at_zero_us = time.time_ns() // 1000 - fc.last_us
        self.flight_times.update(status)
        extras = self.flight_times.extras(fc.last_imu, self.utc_at_zero_us, fc.commander.inputs.manual)
        snap = telemetry_snapshot(
            status, fc.actuators, fc.control_setpoints(), estimator.status(), estimator.use_ekf, extras
        )
        if fc.sim_link_lost and snap.system_status != mavlink.MAV_STATE_EMERGENCY:  # no sensor data at all
            snap = dataclasses.replace(snap, system_status=mavlink.MAV_STATE_CRITICAL)
        return snap

    def handle_command(self, command: int, params: tuple[float, ...], frame: int) -> int:
        return commands.handle_vehicle_command(self.fc.commander, command, params, frame)

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        return commands.handle_set_mode(self.fc.commander, base_mode, custom_mode)

    def pop_events(self) -> list[tuple[int, str]]:
        return self.fc.commander.pop_events()

    def on_landing_target(self, msg: Any, src_sysid: int) -> None:
        self.fc.on_landing_target(msg, src_sysid)

    def on_control_message(self, msg: Any, now_us: int) -> None:
        inputs, wall_s = self.fc.commander.inputs, time.monotonic()
        if msg.get_type() == "MANUAL_CONTROL":
            inputs.on_manual(control_messages.manual_input(msg, now_us, wall_s))
            return
        commander = self.fc.commander
        setpoint = offboard_messages.offboard_setpoint(msg, now_us, wall_s, commander.est, commander.home)
        if setpoint is not None:
            inputs.on_offboard(setpoint)

    def on_gcs_heartbeat(self, now_us: int) -> None:
        self.fc.commander.inputs.on_gcs_heartbeat(now_us, time.monotonic())

    def plan(self, mission_type: int) -> list[MissionItem]:
        return self.fc.commander.plans.plan(mission_type)

    def check_item(self, item: MissionItem) -> tuple[int, str]:
        commander = self.fc.commander
        return commander.plans.check_item(item, commander.home)

    def replace_plan(self, mission_type: int, items: list[MissionItem]) -> tuple[int, str]:
        commander = self.fc.commander
        flying_it = commander.mode is Mode.AUTO_MISSION and commander.armed
        try:
            return commander.plans.replace(mission_type, items, mission_active=flying_it)
        finally:
            commander._publish()

    def set_mission_current(self, seq: int) -> tuple[bool, str]:
        return self.fc.commander.set_mission_current(seq)

    def pop_mission_reached(self) -> list[int]:
        plans = self.fc.commander.plans
        out, plans.reached = plans.reached, []
        return out
