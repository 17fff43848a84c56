"""``gcs fly``: pilot the vehicle from the keyboard, as a joystick through QGroundControl does.

MANUAL_CONTROL goes to the vehicle at ``--rate`` Hz (default 25, wall clock): x = pitch (forward +),
y = roll (right +), r = yaw (clockwise +) in -1000..1000, z = throttle 0..1000 with 500 centred.

Keys::

    w / s   forward / back          a / d   left / right
    i / k   up / down (throttle)    j / l   yaw left / right
    space   centre all sticks
    m  POSCTL (position mode)       p  ALTCTL (altitude mode)
    t  take off (arms first)        r  RTL (return to launch)
    q  quit (Ctrl-C too)

A key deflects its stick by ``--stick`` of the full travel (default 1.0: in POSCTL full stick is
MPC_VEL_MANUAL).  A terminal sends no key release: a stick stays deflected while its key keeps
coming (the terminal's auto-repeat) and returns to centre once the key has not come for
:data:`HOLD_S`, ramping over :data:`DECAY_S`.  The terminal is put in cbreak mode (keys at once, no
echo) and restored on exit, Ctrl-C included.  When ``gcs fly`` ends the sticks stop: after
COM_RC_LOSS_T the vehicle's manual-control-loss failsafe acts.

Key scripts (``--keys FILE``, or stdin when it is not a terminal): one step per line,
``SECONDS KEY``: hold KEY for SECONDS wall seconds (pressed every :data:`REPEAT_S`, as auto-repeat
does); KEY is one of the keys above, ``space``, or ``-`` (no key: wait).  A line with only a key
presses it once.  ``#`` starts a comment.  The script ends the session (as ``q``) after its last step.
"""

from __future__ import annotations

import argparse
import math
import os
import select
import sys
import time
from dataclasses import dataclass, field
from typing import Callable, TextIO

from . import cli_types
from .client import VehicleClient
from .errors import GcsError

HOLD_S = 0.6  # a stick stays deflected this long after its key last came (terminal auto-repeat delay)
DECAY_S = 0.25  # then returns from full deflection to centre over this long
REPEAT_S = 0.05  # a held key in a key script is pressed this often
STATUS_PERIOD_S = 0.2  # the status line on a terminal; once a second otherwise
KEY_HELP = (
    "keys: w/s forward/back  a/d left/right  i/k up/down  j/l yaw  space centre  "
    "m POSCTL  p ALTCTL  t takeoff  r RTL  q quit"
)
# key -> (axis, direction); axes: pitch, roll, throttle (about centre), yaw
STICK_KEYS = {
    "w": ("pitch", 1.0), "s": ("pitch", -1.0), "d": ("roll", 1.0), "a": ("roll", -1.0),
    "i": ("throttle", 1.0), "k": ("throttle", -1.0), "l": ("yaw", 1.0), "j": ("yaw", -1.0),
}  # fmt: skip
ACTION_KEYS = {"m": "POSCTL", "p": "ALTCTL", "t": "takeoff", "r": "RTL"}
KEY_NAMES = {"space": " ", "-": ""}


def add_fly_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fly",
        help="pilot the vehicle from the keyboard (MANUAL_CONTROL): " + KEY_HELP,
        description="Pilot the vehicle from the keyboard with MANUAL_CONTROL. " + KEY_HELP + ". "
        "Sticks return to centre when their key stops coming; key scripts: lines 'SECONDS KEY'.",
    )
    p.add_argument("--keys", metavar="FILE", default=None, help="a key script instead of the keyboard")
    p.add_argument(
        "--rate", type=cli_types.positive, default=25.0, metavar="HZ", help="MANUAL_CONTROL rate (default 25)"
    )
    p.add_argument(
        "--stick", type=cli_types.fraction, default=1.0, metavar="F", help="deflection per key, 0-1 (default 1)"
    )


@dataclass
class Sticks:
    """The four sticks (-1..1; throttle about its centre) and when each axis's key last came (wall s)."""

    deflection: float = 1.0
    value: dict[str, float] = field(default_factory=lambda: dict.fromkeys(("pitch", "roll", "throttle", "yaw"), 0.0))
    pressed_at: dict[str, float] = field(default_factory=dict)

    def press(self, key: str, now: float) -> None:
        if key == " ":
            self.value = dict.fromkeys(self.value, 0.0)
            self.pressed_at.clear()
        elif key in STICK_KEYS:
            axis, sign = STICK_KEYS[key]
            self.value[axis] = sign * self.deflection
            self.pressed_at[axis] = now

    def relax(self, now: float, dt: float) -> None:
        """Axes whose key has not come for HOLD_S move toward centre (full travel in DECAY_S)."""
        for axis, v in self.value.items():
            if v != 0.0 and now - self.pressed_at.get(axis, -math.inf) > HOLD_S:
                step = dt / DECAY_S
                self.value[axis] = 0.0 if abs(v) <= step else v - math.copysign(step, v)

    def manual_control(self) -> tuple[int, int, int, int]:
        """MANUAL_CONTROL x, y, z, r."""
        v = self.value
        return (
            round(1000 * v["pitch"]),
            round(1000 * v["roll"]),
            round(500 + 500 * v["throttle"]),
            round(1000 * v["yaw"]),
        )


class TerminalKeys:
    """Key presses from a terminal in cbreak mode (restored by :meth:`close`)."""

    def __init__(self, stream: TextIO) -> None:
        import termios
        import tty

        self.fd = stream.fileno()
        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)

    def read(self, timeout_s: float) -> str | None:
        """One key, "" if none came within ``timeout_s``."""
        ready, _, _ = select.select([self.fd], [], [], timeout_s)
        if not ready:
            return ""
        return os.read(self.fd, 1).decode(errors="ignore")

    def close(self) -> None:
        import termios

        termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)


def parse_script(text: str) -> list[tuple[float, str]]:
    """Key-script steps (seconds, key); ValueError naming the bad line."""
    steps = []
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        try:
            seconds, name = (0.0, parts[0]) if len(parts) == 1 else (float(parts[0]), parts[1])
        except ValueError:
            raise ValueError(f"key script line {n}: expected 'SECONDS KEY', got {raw!r}") from None
        key = KEY_NAMES.get(name, name)
        if len(parts) > 2 or not math.isfinite(seconds) or seconds < 0 or (len(key) > 1):
            raise ValueError(f"key script line {n}: expected 'SECONDS KEY', got {raw!r}")
        if key and key not in STICK_KEYS and key not in ACTION_KEYS and key not in " q":
            raise ValueError(f"key script line {n}: unknown key {name!r}")
        steps.append((seconds, key))
    return steps


class ScriptKeys:
    """Key presses from a key script, on the wall clock; None once the script is over."""

    def __init__(self, steps: list[tuple[float, str]], clock: Callable[[], float] = time.monotonic) -> None:
        self.steps = list(steps)
        self.clock = clock
        self._step_end: float | None = None
        self._next_press = 0.0

    def read(self, timeout_s: float) -> str | None:
        now = self.clock()
        if self._step_end is None or now >= self._step_end:
            if not self.steps:
                return None
            seconds, self._key = self.steps.pop(0)
            self._step_end, self._next_press = now + seconds, now
        if self._key and self._next_press <= now:
            self._next_press = now + REPEAT_S
            if self._next_press >= self._step_end:
                self._next_press = math.inf  # pressed for the last time in this step
            return self._key
        wake = min(self._step_end, self._next_press, now + timeout_s)
        time.sleep(max(wake - now, 0.0))
        return ""

    def close(self) -> None:
        pass


def run_fly_command(client: VehicleClient, args: argparse.Namespace) -> int:
    """Fly until q, Ctrl-C or the end of the key script; 0 done, 1 a bad key script."""
    stdin = sys.stdin
    try:
        if args.keys is not None:
            with open(args.keys, encoding="utf-8") as f:
                keys = ScriptKeys(parse_script(f.read()))
        elif stdin is not None and not stdin.isatty():
            keys = ScriptKeys(parse_script(stdin.read()))
        else:
            keys = TerminalKeys(stdin)
    except (OSError, ValueError) as exc:
        print(f"gcs: fly: {exc}", file=sys.stderr)
        return 1
    tty = isinstance(keys, TerminalKeys)
    print(f"flying {client.url}: {KEY_HELP}", flush=True)
    try:
        _fly(client, keys, Sticks(min(max(args.stick, 0.0), 1.0)), max(args.rate, 1.0), tty)
    finally:
        keys.close()
        if tty:
            print()
        print("stopped sending sticks (the vehicle's manual control loss failsafe acts after COM_RC_LOSS_T)")
    return 0


def _fly(client: VehicleClient, keys, sticks: Sticks, rate_hz: float, tty: bool) -> None:
    period = 1.0 / rate_hz
    now = time.monotonic()
    next_send, next_status, last_send = now, now, now
    while True:
        key = keys.read(max(next_send - time.monotonic(), 0.0))
        now = time.monotonic()
        if key is None or key == "q":
            return
        if key in ACTION_KEYS:
            _say(_action(client, ACTION_KEYS[key]), tty)
        elif key:
            sticks.press(key, now)
        if now >= next_send:
            sticks.relax(now, now - last_send)
            last_send = now
            x, y, z, r = sticks.manual_control()
            client.conn.mav.manual_control_send(client.target_system, x, y, z, r, 0)
            client.pump(0.0)
            next_send = next_send + period if next_send + period > now else now + period
        if now >= next_status:
            next_status = now + (STATUS_PERIOD_S if tty else 1.0)
            line = status_line(client, sticks)
            print(f"\r{line}\033[K" if tty else line, end="" if tty else "\n", flush=True)


def _say(text: str, tty: bool) -> None:
    print(("\r\033[K" if tty else "") + text, flush=True)


def _action(client: VehicleClient, what: str) -> str:
    """Switch mode, or arm and take off; the outcome as a line for the screen."""
    try:
        if what == "takeoff":
            if not client.armed():
                client.arm(timeout_s=2.0).check()
            client.takeoff(timeout_s=2.0).check()
            return "taking off"
        if what == "RTL":
            client.return_to_launch(timeout_s=2.0).check()
            return "returning to launch"
        client.set_mode(what, timeout_s=2.0).check()
        return f"mode {what} requested"
    except GcsError as exc:
        return f"{what}: {exc}"


def status_line(client: VehicleClient, sticks: Sticks) -> str:
    """Mode, arming, position and the sticks sent."""
    pos = client.position_ned()
    where = f"N {pos[0]:7.2f} E {pos[1]:7.2f} alt {-pos[2]:6.2f} m" if pos else "position ?"
    gs = client.ground_speed_m_s()
    x, y, z, r = sticks.manual_control()
    return (
        f"{client.mode_name() or '?':<8} {'ARMED' if client.armed() else 'disarmed':<8} {where}  "
        f"gs {gs if gs is not None else math.nan:4.1f} m/s  sticks x {x:+5d} y {y:+5d} z {z:4d} r {r:+5d}"
    )
