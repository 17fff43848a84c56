"""A kinematic stand-in for the flight controller, for testing ground-station code.

It is *not* a simulator: position moves straight toward the current setpoint
with capped speeds.  What it imitates is the MAVLink face of the real
flight controller (PX4's): HEARTBEAT with PX4 custom modes, SYS_STATUS with the
pre-arm bit, EXTENDED_SYS_STATE, ATTITUDE, GLOBAL_POSITION_INT,
LOCAL_POSITION_NED, GPS_RAW_INT, VFR_HUD, HOME_POSITION, BATTERY_STATUS,
STATUSTEXT for refusals, a COMMAND_ACK for every command, and a small
parameter set with byte-wise INT32 encoding.

Used by the tests of :mod:`gcs` in a thread (:class:`FakeVehicle`) and, through
``python -m gcs.fake_vehicle autopilot|sitl``, as a drop-in for the two
processes a :class:`gcs.stack.Stack` starts::

    Stack(instance=5, sitl_module="gcs.fake_vehicle sitl", autopilot_module="gcs.fake_vehicle autopilot",
          extra_autopilot_args=["--speed", "20"])

Time: a simulated clock advancing ``dt_s`` per step, paced to ``speed`` x real
time (``speed`` None = as fast as the 1 ms receive wait allows).
"""

from __future__ import annotations

import argparse
import math
import os
import select
import socket
import struct
import sys
import threading
import time

from pymavlink import mavutil

from . import geo, modes, param_codec

HOME = (47.397742, 8.545594, 488.0)  # lat deg, lon deg, alt AMSL m (PX4's default SITL home)
MAX_H_SPEED_M_S = 5.0
MAX_CLIMB_M_S = 2.0
LAND_SPEED_M_S = 1.0
READY_AFTER_S = 1.0
DISARM_AFTER_LAND_S = 1.0


class FakeVehicle:
    """PX4-like MAVLink responder over one or more pymavlink ``udpout:`` urls.

    ``refuse_arm``: answer every arm with DENIED and a STATUSTEXT reason.
    ``drop_acks``: ignore this many commands before answering (tests retries).
    """

    def __init__(self, urls: list[str], speed: float | None = 10.0, dt_s: float = 0.02,
                 refuse_arm: bool = False, drop_acks: int = 0, home: tuple[float, float, float] = HOME) -> None:
        self.links = [mavutil.mavlink_connection(u, source_system=1, source_component=1) for u in urls]
        self.mav = mavutil.mavlink
        self.speed = speed
        self.dt_s = dt_s
        self.refuse_arm = refuse_arm
        self.drop_acks = drop_acks
        self.home = home
        self.t_s = 0.0
        self.armed = False
        self.mode = modes.lookup_mode("LOITER")
        self.pos = [0.0, 0.0, 0.0]  # NED from home, m
        self.vel = [0.0, 0.0, 0.0]
        self.target: list[float] | None = None  # NED setpoint
        self.landing = False
        self.landed_since: float | None = 0.0
        self.params: dict[str, tuple[bytes, int]] = {
            "MIS_TAKEOFF_ALT": (struct.pack("<f", 2.5), param_codec.REAL32),
            "COM_DISARM_LAND": (struct.pack("<f", DISARM_AFTER_LAND_S), param_codec.REAL32),
            "SYS_AUTOSTART": (struct.pack("<i", 4001), param_codec.INT32),
            "RTL_RETURN_ALT": (struct.pack("<f", 10.0), param_codec.REAL32),
            "COM_RC_IN_MODE": (struct.pack("<i", 1), param_codec.INT32),
        }
        self.commands: list = []  # every COMMAND_LONG / COMMAND_INT received
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._next_tx: dict[str, float] = {}

    # ----------------------------------------------------------------- running

    def start(self) -> "FakeVehicle":
        """Run in a background thread (stop with :meth:`stop`)."""
        self._thread = threading.Thread(target=self.run, name="fake-vehicle", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
        for link in self.links:
            link.close()

    def __enter__(self) -> "FakeVehicle":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def run(self) -> None:
        """Step, send telemetry and answer requests until stopped."""
        self.text(6, "fake vehicle started")
        wall0 = time.monotonic()
        while not self._stop.is_set():
            self.step()
            if self.speed:
                delay = wall0 + self.t_s / self.speed - time.monotonic()
            else:
                delay = 0.001
            self._receive(max(delay, 0.0))

    def _receive(self, timeout_s: float) -> None:
        fds = [link.port.fileno() for link in self.links]
        try:
            ready, _, _ = select.select(fds, [], [], timeout_s)
        except (OSError, ValueError):
            return
        for link in self.links:
            if link.port.fileno() not in ready:
                continue
            while (msg := link.recv_msg()) is not None:
                if msg.get_type() != "BAD_DATA":
                    self.handle(msg, link)

    # ----------------------------------------------------------------- dynamics

    def step(self) -> None:
        dt = self.dt_s
        self.t_s += dt
        airborne = self.pos[2] < -0.05
        if self.armed and self.target is not None:
            err = [self.target[i] - self.pos[i] for i in range(3)]
            h = math.hypot(err[0], err[1])
            hs = min(MAX_H_SPEED_M_S, 1.5 * h)
            vn, ve = (err[0] / h * hs, err[1] / h * hs) if h > 1e-6 else (0.0, 0.0)
            vd = max(-MAX_CLIMB_M_S, min(MAX_CLIMB_M_S, 1.5 * err[2]))
            if self.landing and h < 0.3:
                vd = LAND_SPEED_M_S
            self.vel = [vn, ve, vd]
        else:
            self.vel = [0.0, 0.0, 0.0]
        self.pos = [self.pos[i] + self.vel[i] * dt for i in range(3)]
        if self.pos[2] >= 0.0:
            self.pos[2] = 0.0
            self.vel[2] = 0.0
            if self.landing or not airborne:
                if self.landed_since is None:
                    self.landed_since = self.t_s
        else:
            self.landed_since = None
        if self.mode.name == "TAKEOFF" and self.target is not None and abs(self.pos[2] - self.target[2]) < 0.05:
            self.mode = modes.lookup_mode("LOITER")
        if (self.armed and self.landed_since is not None and self.landing
                and self.t_s - self.landed_since >= DISARM_AFTER_LAND_S):
            self.armed = False
            self.landing = False
            self.target = None
            self.text(6, "Landing detected; disarmed")
        if self.mode.name == "RTL" and self.target is not None and not self.landing:
            if math.hypot(self.target[0] - self.pos[0], self.target[1] - self.pos[1]) < 0.3:
                self.landing = True
                self.target = [self.target[0], self.target[1], 0.5]
        self.send_telemetry()

    # ----------------------------------------------------------------- telemetry

    def _due(self, name: str, period_s: float) -> bool:
        if self.t_s + 1e-9 >= self._next_tx.get(name, 0.0):
            self._next_tx[name] = self.t_s + period_s
            return True
        return False

    def send_all(self, fn_name: str, *args) -> None:
        for link in self.links:
            getattr(link.mav, fn_name)(*args)

    def text(self, severity: int, text: str) -> None:
        self.send_all("statustext_send", severity, text.encode()[:50])

    def landed_state(self) -> int:
        m = self.mav
        if self.pos[2] >= 0.0:
            return m.MAV_LANDED_STATE_ON_GROUND if not (self.armed and self.target and self.target[2] < 0
                                                        and not self.landing) else m.MAV_LANDED_STATE_TAKEOFF
        return m.MAV_LANDED_STATE_LANDING if self.landing else m.MAV_LANDED_STATE_IN_AIR

    def send_telemetry(self) -> None:
        m = self.mav
        ms = int(self.t_s * 1000)
        lat, lon, alt = geo.ned_to_global(*self.home, *self.pos)
        if self._due("hb", 0.25):
            base = m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (m.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            self.send_all("heartbeat_send", m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_PX4, base,
                          self.mode.custom_mode, m.MAV_STATE_ACTIVE if self.armed else m.MAV_STATE_STANDBY)
        if self._due("fast", 0.05):
            self.send_all("attitude_send", ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            self.send_all("global_position_int_send", ms, geo.deg_to_e7(lat), geo.deg_to_e7(lon),
                          int(alt * 1000), int(-self.pos[2] * 1000), int(self.vel[0] * 100),
                          int(self.vel[1] * 100), int(self.vel[2] * 100), 0)
            self.send_all("local_position_ned_send", ms, *self.pos, *self.vel)
        if self._due("slow", 0.5):
            ready = self.t_s >= READY_AFTER_S
            prearm = 0x10000000 if ready else 0
            self.send_all("sys_status_send", prearm, prearm, prearm, 100, 16000, 500, 80, 0, 0, 0, 0, 0, 0)
            self.send_all("extended_sys_state_send", m.MAV_VTOL_STATE_MC, self.landed_state())
            self.send_all("gps_raw_int_send", ms * 1000, 3, geo.deg_to_e7(lat), geo.deg_to_e7(lon),
                          int(alt * 1000), 80, 120, int(math.hypot(self.vel[0], self.vel[1]) * 100), 0, 12)
            self.send_all("vfr_hud_send", math.hypot(self.vel[0], self.vel[1]), math.hypot(self.vel[0], self.vel[1]),
                          0, 50, alt, -self.vel[2])
            self.send_all("battery_status_send", 0, 0, 0, 32767, [4000, 4000, 4000, 4000] + [65535] * 6,
                          500, -1, -1, 80)
            self.send_all("home_position_send", geo.deg_to_e7(self.home[0]), geo.deg_to_e7(self.home[1]),
                          int(self.home[2] * 1000), 0, 0, 0, [1, 0, 0, 0], 0, 0, 0)

    # ----------------------------------------------------------------- requests

    def handle(self, msg, link) -> None:
        mtype = msg.get_type()
        if mtype in ("COMMAND_LONG", "COMMAND_INT"):
            self.commands.append(msg)
            if self.drop_acks > 0:
                self.drop_acks -= 1
                return
            result = self.command(msg)
            link.mav.command_ack_send(msg.command, result)
        elif mtype == "PARAM_REQUEST_READ":
            name = msg.param_id
            if name in self.params:
                self._param_value(link, name)
        elif mtype == "PARAM_SET":
            name = msg.param_id
            if name in self.params:
                raw = param_codec.raw_param_value(msg)
                if msg.param_type == self.params[name][1]:
                    self.params[name] = (raw, msg.param_type)
                else:
                    self.text(4, f"param {name}: wrong type")
                self._param_value(link, name)
        elif mtype == "SET_MODE":
            main, sub = modes.decode_custom_mode(msg.custom_mode)
            self._set_mode(main, sub)

    def _param_value(self, link, name: str) -> None:
        raw, ptype = self.params[name]
        value = struct.unpack("<f", raw)[0]
        dialect = sys.modules[type(link.mav).__module__]
        out = dialect.MAVLink_param_value_message(name.encode(), value, ptype, len(self.params),
                                                  sorted(self.params).index(name))
        name_b = name.encode().ljust(16, b"\0")
        payload = raw + struct.pack("<HH16sB", len(self.params), sorted(self.params).index(name), name_b, ptype)
        out.pack = lambda mav, force_mavlink1=False: out._pack(mav, out.crc_extra, payload,
                                                               force_mavlink1=force_mavlink1)
        link.mav.send(out)

    def _set_mode(self, main: int, sub: int) -> bool:
        mode = modes.mode_from_custom_mode(modes.encode_custom_mode(main, sub))
        if mode is None:
            return False
        self.mode = mode
        if mode.name == "LAND":
            self._start_land()
        elif mode.name == "RTL":
            self._start_rtl()
        elif mode.name == "LOITER":
            self.landing = False
            self.target = list(self.pos) if self.armed else None
        return True

    def _start_land(self) -> None:
        self.landing = True
        self.target = [self.pos[0], self.pos[1], 0.5]

    def _start_rtl(self) -> None:
        rtl_alt = struct.unpack("<f", self.params["RTL_RETURN_ALT"][0])[0]
        self.landing = False
        self.target = [0.0, 0.0, min(self.pos[2], -rtl_alt)]

    def command(self, msg) -> int:
        m = self.mav
        c = msg.command
        p = [msg.param1, msg.param2, msg.param3, msg.param4]
        if c == m.MAV_CMD_COMPONENT_ARM_DISARM:
            force = abs(p[1] - 21196) < 0.5
            if p[0] >= 0.5:
                if self.refuse_arm and not force:
                    self.text(3, "Arming denied: fake refusal for tests")
                    return m.MAV_RESULT_DENIED
                if self.t_s < READY_AFTER_S and not force:
                    self.text(3, "Arming denied: pre-arm checks not yet passed")
                    return m.MAV_RESULT_DENIED
                self.armed = True
                self.text(6, "Armed by external command")
            else:
                if self.pos[2] < -0.1 and not force:
                    self.text(3, "Disarming denied: not landed")
                    return m.MAV_RESULT_DENIED
                self.armed = False
                self.target = None
            return m.MAV_RESULT_ACCEPTED
        if c == m.MAV_CMD_DO_SET_MODE:
            return m.MAV_RESULT_ACCEPTED if self._set_mode(int(p[1]), int(p[2])) else m.MAV_RESULT_UNSUPPORTED
        if c == m.MAV_CMD_NAV_TAKEOFF:
            if not self.armed:
                self.text(3, "Takeoff denied: disarmed")
                return m.MAV_RESULT_TEMPORARILY_REJECTED
            alt = msg.param7 if msg.get_type() == "COMMAND_LONG" else msg.z
            rel = alt - self.home[2] if math.isfinite(alt) else struct.unpack("<f", self.params["MIS_TAKEOFF_ALT"][0])[0]
            self.mode = modes.lookup_mode("TAKEOFF")
            self.landing = False
            self.target = [self.pos[0], self.pos[1], -rel]
            return m.MAV_RESULT_ACCEPTED
        if c == m.MAV_CMD_NAV_LAND:
            if not self.armed:
                return m.MAV_RESULT_TEMPORARILY_REJECTED
            self.mode = modes.lookup_mode("LAND")
            self._start_land()
            return m.MAV_RESULT_ACCEPTED
        if c == m.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            if not self.armed:
                return m.MAV_RESULT_TEMPORARILY_REJECTED
            self.mode = modes.lookup_mode("RTL")
            self._start_rtl()
            return m.MAV_RESULT_ACCEPTED
        if c == m.MAV_CMD_DO_REPOSITION and msg.get_type() == "COMMAND_INT":
            if not self.armed or self.pos[2] > -0.5:
                self.text(3, "Reposition denied: not flying")
                return m.MAV_RESULT_TEMPORARILY_REJECTED
            if msg.frame not in (m.MAV_FRAME_GLOBAL, m.MAV_FRAME_GLOBAL_INT):
                return m.MAV_RESULT_UNSUPPORTED
            n, e, d = geo.global_to_ned(*self.home, msg.x * 1e-7, msg.y * 1e-7, msg.z)
            self.mode = modes.lookup_mode("LOITER")
            self.landing = False
            self.target = [n, e, d]
            return m.MAV_RESULT_ACCEPTED
        return m.MAV_RESULT_UNSUPPORTED


# --------------------------------------------------------------------------- processes


def _fake_sitl(instance: int) -> None:
    """Listen on TCP 4560+instance like the simulator and accept (and ignore) the flight controller."""
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind(("127.0.0.1", 4560 + instance))
    srv.listen(1)
    print(f"fake sitl listening on TCP {4560 + instance}", flush=True)
    conns = []
    while True:
        conn, _ = srv.accept()
        conns.append(conn)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcs.fake_vehicle")
    parser.add_argument("role", choices=("autopilot", "sitl"))
    parser.add_argument("--instance", type=int, default=0)
    parser.add_argument("--speed", default="10")
    parser.add_argument("--refuse-arm", action="store_true")
    args, _unknown = parser.parse_known_args(argv)
    if args.role == "sitl":
        _fake_sitl(args.instance)
        return 0
    os.environ["MAVLINK20"] = "1"  # speak MAVLink 2, as PX4 does
    mavutil.set_dialect(mavutil.current_dialect)
    speed = None if args.speed == "max" else float(args.speed)
    # the real autopilot reads the simulator speed from the simulator; the fake takes --speed itself
    vehicle = FakeVehicle([f"udpout:127.0.0.1:{14550 + args.instance}", f"udpout:127.0.0.1:{14540 + args.instance}"],
                          speed=speed, refuse_arm=args.refuse_arm)
    print(f"fake autopilot instance {args.instance}", flush=True)
    vehicle.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
