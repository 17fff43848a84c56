"""The gimbal manager of gimbal protocol v2, on the flight controller, as PX4's gimbal module runs it.

The gimbal is a MAVLink gimbal device on the simulator link (``sitl/gimbal_link.py``: SET_ATTITUDE in, ATTITUDE_STATUS
at 50 Hz and INFORMATION at 1 Hz out).  Ground stations talk to this manager and see the device as PX4 shows a
MAVLink gimbal it forwards: component MNT_MAV_COMPID (154, MAV_COMP_ID_GIMBAL), the ``gimbal_device_id``.

* Advertised once the device has reported; before, and with MNT_MODE_IN not 0 or 4 or MNT_MODE_OUT not 2, gimbal
  commands and requests are UNSUPPORTED, as PX4 without a gimbal.  MNT_MODE_IN 4 / MNT_MODE_OUT 2 are the defaults
  as in PX4's gimbal SITL airframe (4019_gz_x500_gimbal); PX4's own are -1 (disabled) and 0 (AUX).
* A device silent for DEVICE_TIMEOUT_US of simulated time is lost (a STATUSTEXT; UNSUPPORTED again) until it
  reports again, control and setpoint kept (PX4 keeps a device once found; the 3 s are this project's choice).
* GIMBAL_MANAGER_INFORMATION on request: PX4's capability flags and PX4's manager range (pitch -90..90 deg, yaw
  -180..180 deg) narrowed to the device's reported range.  GIMBAL_MANAGER_STATUS at 5 Hz (the spec's "low
  regular rate") and at once when who is in control changes.  The device's status is relayed at 10 Hz and its
  information as it comes (1 Hz); both are also answered on REQUEST_MESSAGE.
* Who is in control (:mod:`autopilot.mavlink.gimbal_control`): MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE with PX4's
  meanings (a system or component id, -1 unchanged, -2 the autopilot itself, -3 release if the sender holds it),
  for the primary (param1/2) and the secondary (param3/4) controller; ACCEPTED whoever asks (PX4 lets any client
  take over). Nobody is in control at start. MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW from a client not in control is
  DENIED with a STATUSTEXT; GIMBAL_MANAGER_SET_ATTITUDE / SET_PITCHYAW / SET_MANUAL_CONTROL from one (messages: no
  ACK) are ignored with a STATUSTEXT (once per client until control changes).
* Angles out of range (:class:`autopilot.control.gimbal_pointing.AngleLimits`): the command is DENIED, a
  message ignored, with a STATUSTEXT naming the axis; the gimbal keeps what it held (no jump).  Rates (from
  SET_MANUAL_CONTROL, scaled by MNT_RATE_PITCH/YAW, or a rates-only SET_ATTITUDE / SET_PITCHYAW) are integrated
  here into an attitude held inside the range: the device takes attitudes only.
* MAV_CMD_DO_SET_ROI_LOCATION points at a global location from the ESTIMATED position (recomputed at every
  step); DO_SET_ROI_NONE: neutral.  As in PX4, ROI commands are taken from any client (the vehicle's ROI).
* What the manager decides reaches the device as GIMBAL_DEVICE_SET_ATTITUDE, queued on the simulator link for
  the next HIL_ACTUATOR_CONTROLS: the simulator applies it at the same step in every run.

The flight controller's own use (a precision landing, :mod:`autopilot.navigation.precland_gimbal`): the
commander's status carries a :class:`autopilot.topics.GimbalRequest`, applied here in :meth:`GimbalManager.
_apply_request` at each of the link's scheduled steps (:meth:`GimbalManager.control_step`, never from a
poll: the same steps in every run).  While it asks DOWN or ALONG a direction, the autopilot itself is the
primary controller (GIMBAL_MANAGER_STATUS shows it; other clients are DENIED as usual) and the camera is pointed
(:meth:`GimbalManager.point_along`, held in range, sent again once it moved RESEND_ANGLE_RAD); when it asks
RELEASE again, the controllers and the setpoint (attitude, ROI or rates) held before come back.  A client that
takes control during the landing (CONFIGURE, as PX4 lets any client) keeps it: the autopilot stops pointing and
restores nothing.  At those steps the device's reach goes to the commander (``publish_reach``, PLD_CAM_REACH -1).

Frames NED/FRD, radians inside; degrees only in MAV_CMD parameters.  Time is the link's simulated time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.gimbal_pointing import AngleLimits, CameraAttitude, GimbalAim, GimbalRequest, look_along
from autopilot.mavlink import command_fields as f
from autopilot.mavlink import gimbal_commands
from autopilot.mavlink.command_fields import FieldError
from autopilot.mavlink.gimbal_control import (
    DeviceRange,
    GimbalControl,
    Roi,
    Source,
    device_setpoint,
    manager_information,
    manager_limits,
    manager_status,
)  # fmt: skip
from autopilot.parameters import ParameterStore
from autopilot.topics import CommanderStatus, LandedState
from mavsim_core.geodesy import geodetic_to_ned

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint
    from autopilot.mavlink.link_service import Handler, ServiceCommand


STATUS_PERIOD_US = 200_000  # GIMBAL_MANAGER_STATUS at 5 Hz (and on change)
RELAY_PERIOD_US = 100_000  # the device's GIMBAL_DEVICE_ATTITUDE_STATUS relayed at 10 Hz
DEVICE_TIMEOUT_US = 3_000_000  # a device without status for this long (simulated time) is lost
RESEND_ANGLE_RAD = math.radians(0.05)  # an ROI or rate setpoint is sent again once it moved this much
Say = Callable[[int, str], None]  # (MAV_SEVERITY, text): a STATUSTEXT to the ground stations


# --------------------------------------------------------------------------- the manager


@dataclass(frozen=True, slots=True)
class _Held:
    """What the autopilot's own use of the gimbal took over: the controllers and the setpoint they had set."""

    control: GimbalControl
    target: CameraAttitude | None
    roi: Roi | None
    rates: tuple[float, float] | None


class GimbalManager:
    """The gimbal manager (see the module docstring): a link service plus the simulator link's device side.

    ``status()`` gives the commander's latest status (the estimate, home, landed state); ``to_device(msg)``
    queues a message for the simulator link; ``broadcast(msg, compid)`` sends on both ground-station endpoints
    as component ``compid``; ``command_source()`` is the (sysid, compid) of the command being run;
    ``publish_reach(rad or None)`` takes the device's reach at each scheduled step (None: no device, range unknown).
    """

    def __init__(
        self,
        params: ParameterStore,
        status: Callable[[], CommanderStatus],
        to_device: Callable[[mavlink.MAVLink_message], None],
        broadcast: Callable[[mavlink.MAVLink_message, int], None],
        say: Say,
        command_source: Callable[[], Source],
        own: Source,
        publish_reach: Callable[[float | None], None] = lambda reach_rad: None,
    ) -> None:
        self.params = params
        self.vehicle_status, self._to_device, self._broadcast, self._say = status, to_device, broadcast, say
        self.command_source, self.own, self.publish_reach = command_source, own, publish_reach
        self.control = GimbalControl()
        self.device_status: Any = None  # the device's latest GIMBAL_DEVICE_ATTITUDE_STATUS (pymavlink's message)
        self.device_information = None  # its latest GIMBAL_DEVICE_INFORMATION
        self.device_range: DeviceRange | None = None
        self.target: CameraAttitude | None = None  # what the device was told (None: neutral)
        self.roi: Roi | None = None
        self.rates_rad_s: tuple[float, float] | None = None  # (pitch, yaw) being integrated into ``target``
        self.sent: CameraAttitude | None = None
        self._dirty = False  # a setpoint to send to the device
        self._fresh_status = self._fresh_information = False
        self._heard = False  # a device status came since the last update
        self._heard_us: int | None = None  # link time of the update that saw the device's latest status
        self._last_update_us: int | None = None
        self._next_status_us = self._next_relay_us = 0
        self.status_changed = False
        self.told: set[tuple[Source, str]] = set()  # (client, what) already said, until control changes
        self.before_autopilot: _Held | None = None  # what the autopilot's own use took over, given back after

    # ------------------------------------------------------------------ the device (simulator link)

    def device_handlers(self) -> dict[str, Callable[[mavlink.MAVLink_message], None]]:
        """The simulator link's messages this manager reads, by type."""
        return {
            "GIMBAL_DEVICE_ATTITUDE_STATUS": self.on_device_status,
            "GIMBAL_DEVICE_INFORMATION": self.on_device_information,
        }

    def on_device_status(self, msg) -> None:
        """The device's attitude (from the simulator link): the device exists.  Relayed as the separate component
        MNT_MAV_COMPID, whose gimbal_device_id field is then 0 (the spec: set only when the device shares the
        manager's component)."""
        msg.gimbal_device_id = 0
        self.device_status, self._fresh_status, self._heard = msg, True, True

    def on_device_information(self, msg) -> None:
        """The device's ranges (from the simulator link)."""
        self.device_information, self._fresh_information = msg, True
        self.device_range = DeviceRange.from_information(msg)

    @property
    def enabled(self) -> bool:
        """MNT_MODE_IN 0 or 4 and MNT_MODE_OUT 2: the manager runs."""
        return int(self.params.get("MNT_MODE_IN")) in (0, 4) and int(self.params.get("MNT_MODE_OUT")) == 2

    @property
    def advertised(self) -> bool:
        """The manager runs and its device has reported."""
        return self.enabled and self.device_status is not None

    @property
    def device_compid(self) -> int:
        return int(self.params.get("MNT_MAV_COMPID"))

    # ------------------------------------------------------------------ the autopilot's own use

    def point_along(self, direction_ned) -> None:
        """Point the camera along a NED direction (the autopilot's own use: whoever is in control), held inside
        the range, sent to the device once it moved more than RESEND_ANGLE_RAD."""
        self.roi, self.rates_rad_s = None, None
        self._set_if_moved(self._limits().clamped(look_along(direction_ned), self._vehicle_yaw_rad()))

    def _apply_request(self, request: GimbalRequest) -> None:
        """The commander's request (see the module docstring): take over, point, give back."""
        held = self.before_autopilot
        if request.aim is GimbalAim.RELEASE:
            if held is not None:
                self.before_autopilot = None
                if self.control.primary == self.own:  # still the autopilot's: back to who held it before
                    self.set_control(held.control)
                    self.target, self.roi, self.rates_rad_s, self._dirty = held.target, held.roi, held.rates, True
                    self.sent = None
            return
        if held is None:
            self.before_autopilot = _Held(self.control, self.target, self.roi, self.rates_rad_s)
            self.set_control(GimbalControl(self.own, self.control.secondary))
        elif self.control.primary != self.own:  # a client took control during the landing: it keeps it
            return
        self.point_along(request.direction_ned if request.aim is GimbalAim.ALONG else (0.0, 0.0, 1.0))

    def set_control(self, control: GimbalControl) -> None:
        """Who is in control now (GIMBAL_MANAGER_STATUS goes at once on a change; what was said is forgotten)."""
        if control != self.control:
            self.control, self.status_changed = control, True
            self.told.clear()

    def neutral(self) -> None:
        """Back to the device's neutral (straight down for the landing camera)."""
        self.roi, self.rates_rad_s = None, None
        self._set_target(None)

    # ------------------------------------------------------------------ LinkService

    def handlers(self) -> dict[str, Handler]:
        return {name: partial(handler, self) for name, handler in gimbal_commands.MESSAGES.items()}

    def commands(self) -> dict[int, ServiceCommand]:
        return {
            cmd: self._guarded(partial(handler, self), label) for cmd, (handler, label) in gimbal_commands.TABLE.items()
        }

    def requestable(self) -> dict[int, Callable[[LinkEndpoint], int]]:
        """REQUEST_MESSAGE answers (message id -> send(endpoint) -> MAV_RESULT) for GcsLink.requestable."""
        return {
            mavlink.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION: lambda ep: self._answer(ep, self.information()),
            mavlink.MAVLINK_MSG_ID_GIMBAL_MANAGER_STATUS: lambda ep: self._answer(ep, self.manager_status()),
            mavlink.MAVLINK_MSG_ID_GIMBAL_DEVICE_ATTITUDE_STATUS: lambda ep: self._answer(
                ep, self.device_status, self.device_compid
            ),
            mavlink.MAVLINK_MSG_ID_GIMBAL_DEVICE_INFORMATION: lambda ep: self._answer(
                ep, self.device_information, self.device_compid
            ),
        }

    def control_step(self, now_us: int) -> None:
        """At the link's scheduled steps only (``SimLink.device_steps``): the commander's request, rates and ROI
        into the setpoint, the setpoint to the device.  Not in :meth:`update`, which also runs when a ground
        station's datagram arrives (``GcsLink.poll``), at a step set by the wall clock."""
        dt_s = 0.0 if self._last_update_us is None else max(0.0, (now_us - self._last_update_us) * 1e-6)
        self._last_update_us = now_us
        self._watch_device(now_us)
        self.publish_reach(self.device_range.tilt_reach_rad if self.advertised and self.device_range else None)
        if not self.advertised:
            return
        self._apply_request(self.vehicle_status().gimbal_request)
        if self.roi is not None:
            self._follow_roi()
        elif self.rates_rad_s is not None and dt_s > 0:
            self._integrate_rates(dt_s)
        if self._dirty:
            self._dirty = False
            self.sent = self.target
            self._to_device(device_setpoint(self.target, self.own[0], self.device_compid))

    def update(self, now_us: int) -> None:
        """Every link update (and poll): the manager's status and the device's relayed."""
        if not self.advertised:
            return
        if self._fresh_status and now_us >= self._next_relay_us:
            self._fresh_status, self._next_relay_us = False, now_us + RELAY_PERIOD_US
            self._broadcast(self.device_status, self.device_compid)
        if self._fresh_information:
            self._fresh_information = False
            self._broadcast(self.device_information, self.device_compid)
        if self.status_changed or now_us >= self._next_status_us:
            self.status_changed, self._next_status_us = False, now_us + STATUS_PERIOD_US
            self._broadcast(self.manager_status(), self.own[1])

    def _watch_device(self, now_us: int) -> None:
        """The device heard from at ``now_us``, or lost after DEVICE_TIMEOUT_US of silence (see the module
        docstring)."""
        if self._heard:
            self._heard, self._heard_us = False, now_us
            return
        if self.device_status is None or self._heard_us is None or now_us - self._heard_us <= DEVICE_TIMEOUT_US:
            return
        self.device_status = self.device_information = self.device_range = None
        self._fresh_status = self._fresh_information = False
        self._dirty = True  # the setpoint goes again to a device that returns
        self._say(mavlink.MAV_SEVERITY_WARNING, f"Gimbal device lost: no status for {DEVICE_TIMEOUT_US / 1e6:g} s")

    # ------------------------------------------------------------------ messages out

    def information(self) -> mavlink.MAVLink_message | None:
        """GIMBAL_MANAGER_INFORMATION (None before the device reported)."""
        if not self.advertised:
            return None
        return manager_information(
            self._time_ms(), self.device_compid, manager_limits(self.device_range, False, (-90, 90))
        )

    def manager_status(self) -> mavlink.MAVLink_message | None:
        """GIMBAL_MANAGER_STATUS (None before the device reported): the device's flags, who is in control."""
        if not self.advertised:
            return None
        return manager_status(self._time_ms(), int(self.device_status.flags), self.device_compid, self.control)

    def _answer(self, ep: LinkEndpoint, msg, compid: int | None = None) -> int:
        if not self.advertised:
            return mavlink.MAV_RESULT_UNSUPPORTED
        if msg is None:
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        ep.send_as(msg, self.own[1] if compid is None else compid)
        return mavlink.MAV_RESULT_ACCEPTED

    def _time_ms(self) -> int:
        return ((self._last_update_us or 0) // 1000) & 0xFFFFFFFF

    # ------------------------------------------------------------------ decisions

    def _limits(self) -> AngleLimits:
        status = self.vehicle_status()
        landed = status.landed_state in (LandedState.ON_GROUND, LandedState.UNDEFINED)
        lnd = (float(self.params.get("MNT_LND_P_MIN")), float(self.params.get("MNT_LND_P_MAX")))
        return manager_limits(self.device_range, landed, lnd)

    def _vehicle_yaw_rad(self) -> float:
        est = self.vehicle_status().estimate
        return float(est.yaw_rad) if est is not None else 0.0

    def allows(self, sender: Source) -> bool:
        """May ``sender`` point the gimbal now?"""
        return self.control.allows(sender)

    def _set_target(self, target: CameraAttitude | None) -> None:
        self.target, self._dirty = target, True

    def _refusal(self, att: CameraAttitude) -> str | None:
        """Why the manager cannot take ``att`` (out of range), or None."""
        return self._limits().violation(att, self._vehicle_yaw_rad())

    def point(self, sender: Source, att: CameraAttitude | None, rates: tuple[float, float] | None) -> str | None:
        """A client's attitude (None: neutral) or rates (rad/s) taken by the manager; the refusal, or None."""
        if not self.allows(sender):
            c = self.control.primary
            return f"{sender[0]}/{sender[1]} is not in control (primary: {c[0]}/{c[1]})"
        if att is not None and (why := self._refusal(att)) is not None:
            return why
        self.roi = None
        if rates is not None and att is None:
            if not all(math.isfinite(r) for r in rates):
                return "neither angles nor rates given"
            self.rates_rad_s = rates if any(rates) else None
            if self.target is None:  # rates from the neutral: start from the device's neutral attitude
                self.target = CameraAttitude(0.0, -math.pi / 2, 0.0)
            return None
        self.rates_rad_s = None
        self._set_target(att)
        return None

    def _follow_roi(self) -> None:
        est = self.vehicle_status().estimate
        if est is None or not est.position_valid:
            return
        roi = self.roi
        if roi is None:
            return
        roi_ned = geodetic_to_ned(
            roi.lat_deg, roi.lon_deg, roi.alt_amsl_m, est.origin_lat_deg, est.origin_lon_deg, est.origin_alt_amsl_m
        )
        try:
            n, e, d = (float(r - p) for r, p in zip(roi_ned, est.pos_ned_m))
            att = look_along((n, e, d))
        except ValueError:  # at the ROI itself: keep the attitude
            return
        self._set_if_moved(self._limits().clamped(att, float(est.yaw_rad)))

    def _integrate_rates(self, dt_s: float) -> None:
        if self.rates_rad_s is None or self.target is None:
            return
        pitch_rate, yaw_rate = self.rates_rad_s
        t = self.target
        moved = CameraAttitude(t.roll_rad, t.pitch_rad + pitch_rate * dt_s, t.yaw_rad + yaw_rate * dt_s, t.yaw_earth)
        self._set_if_moved(self._limits().clamped(moved, self._vehicle_yaw_rad()))

    def _set_if_moved(self, att: CameraAttitude) -> None:
        old = self.sent
        if (
            old is None
            or old.yaw_earth != att.yaw_earth
            or max(abs(att.roll_rad - old.roll_rad), abs(att.pitch_rad - old.pitch_rad), abs(att.yaw_rad - old.yaw_rad))
            > RESEND_ANGLE_RAD
        ):
            self._set_target(att)
        else:
            self.target = att

    def tell_once(self, sender: Source, what: str, text: str) -> None:
        if (sender, what) not in self.told:
            self.told.add((sender, what))
            self._say(mavlink.MAV_SEVERITY_WARNING, text)

    # ------------------------------------------------------------------ commands

    def _guarded(self, handler: Callable[[tuple, int], int], label: str) -> ServiceCommand:
        """A command: UNSUPPORTED without a manager; a bad field or a refusal DENIED with a STATUSTEXT."""

        def run(ep: LinkEndpoint, params: tuple, frame: int) -> int:
            if not self.advertised:
                return mavlink.MAV_RESULT_UNSUPPORTED
            try:
                f.no_infinity(params)
                return handler(params, frame)
            except FieldError as exc:
                self._say(mavlink.MAV_SEVERITY_CRITICAL, f"{label} denied: {exc}")
                return mavlink.MAV_RESULT_DENIED

        return run
