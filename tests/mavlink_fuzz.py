"""Random MAVLink traffic for the fuzz test (tests/test_e2e_fuzz.py): junk datagrams and CRC-valid frames of
every message of the common dialect, with NaN, infinities and extreme values in float fields and edge values
in integers.

:class:`Fuzzer` (seeded: a failure reproduces) makes datagrams of three kinds:

- junk: random bytes, some starting with a MAVLink 1 or 2 magic byte, some a valid frame with bytes flipped;
- frames: one message of a dialect type, every field random (half of the frames addressed to the vehicle
  under test: ``target_system`` = its system id, so they are not all dropped by the target check);
- frames that must be refused: their valid values could legitimately change what the test watches (the
  parameters, the mode, the arming state, the hover), so they are made of values the vehicle must refuse:
  COMMAND_LONG / COMMAND_INT of a command the vehicle implements (:data:`STATEFUL_COMMANDS`) with an infinity
  in a parameter; SET_MODE with a custom mode PX4 does not have; PARAM_SET of an existing REAL32 parameter to
  NaN, an infinity or +-3.4e38.  Commands outside that list are random (MAV_RESULT_UNSUPPORTED or harmless).

Left out (:data:`EXCLUDED`): SETUP_SIGNING (a valid one sets a signing key: every unsigned client, this test's
included, is then refused, as it should) and LOG_ERASE (erases the flight logs, as it should).  MANUAL_CONTROL
goes only to other systems (the target check): sticks that appear and then stop are an RC loss, whose failsafe
(NAV_RCL_ACT) legitimately changes the mode.  Missions,
fences, rally points, FTP and the stick/offboard messages stay in: random ones are refused, or change nothing
the test watches while the vehicle holds in AUTO.LOITER.
"""

from __future__ import annotations

import math
import random
from typing import Iterator

from pymavlink.dialects.v20 import common as mavlink

FLOATS = (math.nan, math.inf, -math.inf, 0.0, -0.0, 1.0, -1.0, 1e38, -1e38, 3.4e38, -3.4e38, 1e-45, 21196.0)
DOUBLES = (*FLOATS, 1e308, -1e308)
INTS = {
    "int8_t": (-(2**7), 2**7 - 1), "uint8_t": (0, 2**8 - 1), "int16_t": (-(2**15), 2**15 - 1),
    "uint16_t": (0, 2**16 - 1), "int32_t": (-(2**31), 2**31 - 1), "uint32_t": (0, 2**32 - 1),
    "int64_t": (-(2**63), 2**63 - 1), "uint64_t": (0, 2**64 - 1), "uint8_t_mavlink_version": (0, 255),
}  # fmt: skip
EXCLUDED = {"SETUP_SIGNING", "LOG_ERASE"}
# MAV_CMDs the vehicle acts on (autopilot/mavlink/commands.py and its link services): sent only with an infinity
STATEFUL_COMMANDS = (
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LAND,
    mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_DO_REPOSITION,
    mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, mavlink.MAV_CMD_DO_CHANGE_SPEED, mavlink.MAV_CMD_DO_SET_HOME,
    mavlink.MAV_CMD_CONDITION_YAW, mavlink.MAV_CMD_DO_PAUSE_CONTINUE, mavlink.MAV_CMD_DO_FLIGHTTERMINATION,
    mavlink.MAV_CMD_PREFLIGHT_STORAGE, mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, mavlink.MAV_CMD_DO_MOTOR_TEST,
    mavlink.MAV_CMD_DO_ORBIT, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAV_CMD_REQUEST_MESSAGE,
    mavlink.MAV_CMD_INJECT_FAILURE,
)  # fmt: skip
MUST_REFUSE_ACKS = frozenset(STATEFUL_COMMANDS)  # never ACCEPTED here (SET_MODE's ACK names DO_SET_MODE, as PX4's)
REAL32 = mavlink.MAV_PARAM_TYPE_REAL32


class Fuzzer:
    """Seeded random MAVLink datagrams for a vehicle of system id ``target_sysid`` whose REAL32 parameters are
    ``real32_names`` (see the module docstring)."""

    def __init__(self, seed: int, target_sysid: int, real32_names: list[str]) -> None:
        self.rng = random.Random(seed)
        self.target = target_sysid
        self.real32_names = real32_names
        self.types = sorted(
            (cls for cls in mavlink.mavlink_map.values() if cls.msgname not in EXCLUDED), key=lambda c: c.id
        )
        self.sent_types: dict[str, int] = {}

    # ------------------------------------------------------------------ values

    def number(self, ftype: str) -> int | float:
        """A random value of a MAVLink field type: specials and extremes a third of the time."""
        rng = self.rng
        if ftype in ("float", "double"):
            if rng.random() < 0.5:
                return rng.choice(DOUBLES if ftype == "double" else FLOATS)
            return rng.choice((rng.uniform(-1e4, 1e4), rng.gauss(0.0, 1.0), float(rng.randint(-3, 300))))
        lo, hi = INTS[ftype]
        roll = rng.random()
        if roll < 0.3:
            return rng.choice((lo, hi, 0, 1, min(hi, 2), max(lo, -1)))
        if roll < 0.6:
            return rng.randint(max(lo, -300), min(hi, 300))
        return rng.randint(lo, hi)

    def text(self, length: int) -> bytes:
        """A char array: printable, or any bytes."""
        n = self.rng.randint(0, length)
        if self.rng.random() < 0.5:
            return bytes(self.rng.choice(b"ABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789/.") for _ in range(n))
        return bytes(self.rng.randint(0, 255) for _ in range(n))

    def target_system(self) -> int:
        """Half the frames to the vehicle under test, the others to random systems (never 0: broadcast)."""
        if self.rng.random() < 0.5:
            return self.target
        return self.rng.choice([s for s in range(1, 256) if s != self.target])

    # ------------------------------------------------------------------ messages

    def fields(self, cls) -> dict[str, object]:
        """Random values of every field of message class ``cls``."""
        lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths))
        out: dict[str, object] = {}
        for name, ftype in zip(cls.fieldnames, cls.fieldtypes):
            n = lengths.get(name, 0)
            if ftype == "char":
                out[name] = self.text(max(n, 1))
            elif n:
                out[name] = [self.number(ftype) for _ in range(n)]
            else:
                out[name] = self.number(ftype)
        for name in ("target_system", "target"):
            if name in out and isinstance(out[name], int):
                out[name] = self.target_system()
        if "target_component" in out:
            out["target_component"] = self.rng.choice((0, 1, self.rng.randint(0, 255)))
        return out

    def refusable(self, name: str, values: dict[str, object]) -> None:
        """Make a message whose valid values could change the watched state one the vehicle must refuse."""
        rng = self.rng
        if name in ("COMMAND_LONG", "COMMAND_INT"):
            if rng.random() < 0.5:
                values["command"] = rng.choice(STATEFUL_COMMANDS)
                floats = [f"param{k}" for k in range(1, 8 if name == "COMMAND_LONG" else 5)]
                floats += ["z"] if name == "COMMAND_INT" else []
                values[rng.choice(floats)] = rng.choice((math.inf, -math.inf))
            else:
                while (command := rng.randint(0, 2**16 - 1)) in MUST_REFUSE_ACKS:
                    pass
                values["command"] = command
        elif name == "SET_MODE":
            values["custom_mode"] = (int(values["custom_mode"]) & ~0x00FF0000) | (rng.randint(16, 255) << 16)
        elif name == "MANUAL_CONTROL":  # sticks that come and go are an RC loss (NAV_RCL_ACT), as they should
            values["target"] = rng.choice([s for s in range(1, 256) if s != self.target])
        elif name == "PARAM_SET" and rng.random() < 0.5 and self.real32_names:
            values["param_id"] = rng.choice(self.real32_names).encode()
            values["param_value"] = rng.choice((math.nan, math.inf, -math.inf, 3.4e38, -3.4e38))
            values["param_type"] = REAL32

    def frame(self, cls) -> bytes:
        """One CRC-valid MAVLink 2 frame of ``cls`` from a random sender."""
        values = self.fields(cls)
        self.refusable(cls.msgname, values)
        msg = cls(**values)
        mav = mavlink.MAVLink(None, self.rng.randint(1, 255), self.rng.randint(0, 255))
        mav.seq = self.rng.randint(0, 255)
        self.sent_types[cls.msgname] = self.sent_types.get(cls.msgname, 0) + 1
        return msg.pack(mav)

    def junk(self) -> bytes:
        """Random bytes, a random datagram behind a magic byte, or a valid frame with some bytes flipped."""
        rng = self.rng
        kind = rng.random()
        if kind < 0.4:
            return bytes(rng.randint(0, 255) for _ in range(rng.randint(1, 300)))
        if kind < 0.7:
            return bytes([rng.choice((0xFD, 0xFE))]) + bytes(rng.randint(0, 255) for _ in range(rng.randint(0, 280)))
        data = bytearray(self.frame(rng.choice(self.types)))
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] = rng.randint(0, 255)
        return bytes(data)

    def datagrams(self, n_frames: int, n_junk: int) -> Iterator[bytes]:
        """``n_frames`` frames spread evenly over every message type (shuffled) and ``n_junk`` junk datagrams,
        mixed; now and then several frames in one datagram."""
        kinds = [self.types[k % len(self.types)] for k in range(n_frames)] + [None] * n_junk
        self.rng.shuffle(kinds)
        for cls in kinds:
            if cls is None:
                yield self.junk()
            elif self.rng.random() < 0.1:
                yield self.frame(cls) + self.frame(self.rng.choice(self.types))
            else:
                yield self.frame(cls)
