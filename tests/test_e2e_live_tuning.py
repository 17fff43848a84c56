"""End-to-end: live tuning of the roll-rate gain in a hover ([Q 3.5]: gains changed in flight).

A real ``sitl`` + ``autopilot`` stack (a free instance, ``--speed max``, the default seed unless ``E2E_SEED``) flown in
simulated time (``stepped_flight_fixture``, tests/e2e_flight_helpers.py) by a :class:`VehicleClient`
on the flight controller's ground-station link.  The test does what someone tuning with a ground
station does.  It asks for ATTITUDE, ATTITUDE_TARGET and SERVO_OUTPUT_RAW at 250 Hz with
MAV_CMD_SET_MESSAGE_INTERVAL (the link sends at most at its own update rate, 50 Hz of simulated
time, and the received rate is printed).  It hovers at 5 m, raises MC_ROLLRATE_P from the vehicle's
default (50.7 on quad_x, from `design-gains`) to its declared maximum, 150, and then sets it back.
Each change is sent while the simulator holds, so it acts from the next step and every window starts
and ends at the same simulated time in every run: every figure is the same in every run.

Why a three-fold rate gain oscillates: the roll-rate loop is angular acceleration
P * error through the motors' first-order lag (12.5 ms up, 25 ms down), the 4 ms
control period and the gyro low-pass the rate controller flies on (IMU_GYRO_CUTOFF,
30 Hz, as PX4).  The designed default crosses over near 9 Hz with a 6.3 dB gain margin
(`design-gains quad_x`): about 2.1 x more P and the lags add up to 180 deg at the
crossover, so at 150 (3 x) the loop is unstable: the oscillation grows until the motors
saturate and then stays as a limit cycle.  The oscillation is fast, so it is plain in
ATTITUDE.rollspeed and in the motor outputs but small in the roll angle.  It is
measured as the part of ATTITUDE.rollspeed above ~5 Hz: the rate minus its 0.1 s
running mean, which takes out the slow motion of the hover.

Assertions (each a FIGURE line with ``pytest -s``):

* at the high gain the fast roll-rate amplitude is >= 8 x the baseline, the rate moves
  >= 5 x as much per unit of the fast rate setpoint (ATTITUDE_TARGET.body_roll_rate),
  and the motors' roll differential (SERVO_OUTPUT_RAW) oscillates >= 10 x as much;
* it is still >= 8 x the baseline in the second half of the 5 s high-gain window: a
  limit cycle, not a transient that dies away (how fast it grows is not asserted);
* within 2 s of setting the gain back to the default, the fast roll-rate amplitude is back within
  2 x the baseline and below 0.2 x the high-gain amplitude.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.client import mavlink
from params.vehicle import load_vehicle

from e2e_flight_helpers import record_figure, stepped_flight_fixture

pytestmark = pytest.mark.e2e
ALT_M = 5.0
HIGH_P = 150.0  # MC_ROLLRATE_P's declared maximum: about 3 x the designed default, beyond its 6.3 dB gain margin
REQUESTED_INTERVAL_US = 4_000  # 250 Hz, as ground stations ask while tuning
WINDOW_S = 5.0  # baseline and high-gain windows, simulated seconds
SETTLE_S = 2.0  # the restored window ends this long after the gain is set back
SKIP_S = 0.2  # left out after each gain change
RUNNING_MEAN_S = 0.1  # the slow motion taken out of the rates: what is left is above ~5 Hz


flight = stepped_flight_fixture()  # one stack, flown in simulated time


def fast_part(t_s: np.ndarray, x: np.ndarray, width_s: float = RUNNING_MEAN_S) -> np.ndarray:
    """``x`` minus its centred running mean over ``width_s`` (samples at times ``t_s``, any rate)."""
    c = np.concatenate(([0.0], np.cumsum(x)))
    lo = np.searchsorted(t_s, t_s - width_s / 2, side="left")
    hi = np.searchsorted(t_s, t_s + width_s / 2, side="right")
    return x - (c[hi] - c[lo]) / (hi - lo)


class Record:
    """ATTITUDE, ATTITUDE_TARGET and SERVO_OUTPUT_RAW as they arrive, by simulated time."""

    def __init__(self, roll_weights: list[float]) -> None:
        self.att: list[tuple[float, float, float]] = []  # t_s, roll rad, rollspeed rad/s
        self.target: dict[int, float] = {}  # time_boot_ms -> body_roll_rate setpoint rad/s
        self.servo: list[tuple[float, float]] = []  # t_s, roll differential of the motors, µs
        self.roll_weights = roll_weights

    def __call__(self, msg) -> None:
        kind = msg.get_type()
        if kind == "ATTITUDE":
            self.att.append((msg.time_boot_ms / 1000.0, msg.roll, msg.rollspeed))
        elif kind == "ATTITUDE_TARGET":
            self.target[msg.time_boot_ms] = msg.body_roll_rate
        elif kind == "SERVO_OUTPUT_RAW":
            pwm = [getattr(msg, f"servo{i + 1}_raw") for i in range(len(self.roll_weights))]
            self.servo.append((msg.time_usec / 1e6, sum(w * p for w, p in zip(self.roll_weights, pwm))))

    def arrays(self) -> dict[str, np.ndarray]:
        att = np.array(sorted(self.att))
        t, roll, rate = att[:, 0], att[:, 1], att[:, 2]
        # ATTITUDE carries the estimate's time, ATTITUDE_TARGET the controller's: pair each ATTITUDE with the
        # setpoint nearest in time, within one 4 ms control period.
        tgt_ms = np.array(sorted(self.target))
        tgt_sp = np.array([self.target[m] for m in tgt_ms])
        ms = t * 1000.0
        k = np.clip(np.searchsorted(tgt_ms, ms), 1, len(tgt_ms) - 1)
        k = np.where(np.abs(tgt_ms[k - 1] - ms) <= np.abs(tgt_ms[k] - ms), k - 1, k)
        paired = np.abs(tgt_ms[k] - ms) <= 4.0
        sp = tgt_sp[k[paired]]
        servo = np.array(sorted(self.servo))
        return {
            "t": t,
            "roll_deg": np.degrees(roll),
            "rate": rate,
            "rate_fast": fast_part(t, rate),
            "roll_fast_deg": fast_part(t, np.degrees(roll)),
            "tp": t[paired],
            "rate_fast_p": fast_part(t[paired], rate[paired]),
            "sp_fast": fast_part(t[paired], sp),
            "ts": servo[:, 0],
            "motor_fast": fast_part(servo[:, 0], servo[:, 1]),
        }


def amplitudes(a: dict[str, np.ndarray], start_s: float, end_s: float, min_samples: int = 20) -> dict[str, float]:
    """RMS amplitudes within [start_s, end_s) of simulated time."""
    m = (a["t"] >= start_s) & (a["t"] < end_s)
    mp = (a["tp"] >= start_s) & (a["tp"] < end_s)
    ms = (a["ts"] >= start_s) & (a["ts"] < end_s)
    assert min(m.sum(), mp.sum(), ms.sum()) >= min_samples, f"too few samples in [{start_s:.2f}, {end_s:.2f}) s"
    return {
        "rate_fast": float(a["rate_fast"][m].std()),  # rad/s, the oscillation
        "rate": float(a["rate"][m].std()),  # rad/s, everything
        "gain": float(a["rate_fast_p"][mp].std() / a["sp_fast"][mp].std()),  # fast rate per fast setpoint
        "roll": float(a["roll_deg"][m].std()),  # deg
        "roll_fast": float(a["roll_fast_deg"][m].std()),  # deg
        "motor_fast": float(a["motor_fast"][ms].std()),  # µs of PWM
        "n": int(m.sum()),
    }


def describe(name: str, w: dict[str, float]) -> str:
    return (
        f"{name:<26s} rollspeed: fast {w['rate_fast']:.4f} rad/s, all {w['rate']:.4f} rad/s, "
        f"per setpoint {w['gain']:.2f} | roll: all {w['roll']:.3f} deg, fast {w['roll_fast']:.4f} deg | "
        f"motor roll differential: fast {w['motor_fast']:5.1f} us | {w['n']} samples"
    )


def roll_weights(vehicle: str = "quad_x") -> list[float]:
    """Per motor: -1 on the right (FRD y > 0), +1 on the left; half of it, so the sum is a per-side difference."""
    return [-0.5 * math.copysign(1.0, r.position_frd_m[1]) for r in load_vehicle(vehicle).rotors]


def test_roll_rate_gain_raised_in_hover_makes_roll_rate_oscillate_and_restoring_it_settles(flight):
    f = flight
    client = f.client
    for msg_id in (
        mavlink.MAVLINK_MSG_ID_ATTITUDE,
        mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET,
        mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,
    ):
        client.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, REQUESTED_INTERVAL_US).check()
    default_p = client.param_get("MC_ROLLRATE_P")
    assert default_p * 2.5 < HIGH_P, default_p  # beyond the default's gain margin
    record = Record(roll_weights())
    client.add_listener(record)
    try:
        f.take_off(ALT_M, settle_s=3.0)  # settled in the hover

        # Each window runs from one hold to the next; a change sent in a hold acts from the next step.
        t_base = f.now_s
        f.wait(WINDOW_S)
        t_base_end = t_high = f.now_s
        high_p = client.param_set("MC_ROLLRATE_P", HIGH_P)
        f.wait(WINDOW_S)
        t_high_end = t_restored = f.now_s
        assert client.param_set("MC_ROLLRATE_P", default_p) == pytest.approx(default_p)
        f.wait(SETTLE_S)  # all the telemetry before the hold has arrived (SimStepper)
    finally:
        client.remove_listener(record)
    assert client.armed(), "the vehicle disarmed during the test"

    a = record.arrays()
    rate_hz = (len(a["t"]) - 1) / (a["t"][-1] - a["t"][0])
    base = amplitudes(a, t_base, t_base_end)
    high = amplitudes(a, t_high + SKIP_S, t_high_end)
    mid = (t_high + SKIP_S + t_high_end) / 2
    high_1 = amplitudes(a, t_high + SKIP_S, mid)
    high_2 = amplitudes(a, mid, t_high_end)
    restored = amplitudes(a, t_restored + SKIP_S, t_restored + SETTLE_S)

    print(
        f"\nlive tuning: ATTITUDE requested at {1e6 / REQUESTED_INTERVAL_US:.0f} Hz, received at {rate_hz:.1f} Hz "
        f"of simulated time; MC_ROLLRATE_P {default_p:g} -> {high_p:g} -> {default_p:g}"
    )
    print(describe(f"baseline P={default_p:g}", base))
    print(describe(f"P={high_p:g}", high))
    print(describe(f"P={high_p:g}, first half", high_1))
    print(describe(f"P={high_p:g}, second half", high_2))
    print(describe(f"restored, {SKIP_S:g}-{SETTLE_S:g} s after", restored))
    print(
        f"ratios to baseline: fast rollspeed {high['rate_fast'] / base['rate_fast']:.2f} x "
        f"(halves {high_1['rate_fast'] / base['rate_fast']:.2f}, {high_2['rate_fast'] / base['rate_fast']:.2f}), "
        f"per setpoint {high['gain'] / base['gain']:.2f} x, motors {high['motor_fast'] / base['motor_fast']:.2f} x; "
        f"restored {restored['rate_fast'] / base['rate_fast']:.2f} x"
    )

    record_figure("live_tuning_attitude_rate_hz", rate_hz, 40.0, below=False, unit="Hz")
    # the raised gain makes the roll rate oscillate ...
    record_figure("live_tuning_high_gain_fast_roll_rate_ratio", high["rate_fast"] / base["rate_fast"], 8.0, below=False)
    record_figure("live_tuning_high_gain_rate_per_setpoint_ratio", high["gain"] / base["gain"], 5.0, below=False)
    record_figure("live_tuning_high_gain_motor_roll_ratio", high["motor_fast"] / base["motor_fast"], 10.0, below=False)
    # ... for as long as it stays high (a limit cycle, not a transient that dies away) ...
    record_figure(
        "live_tuning_high_gain_second_half_fast_roll_rate_ratio",
        high_2["rate_fast"] / base["rate_fast"],
        8.0,
        below=False,
    )
    # ... and settles within SETTLE_S of the gain being set back
    record_figure("live_tuning_restored_to_baseline_ratio", restored["rate_fast"] / base["rate_fast"], 2.0)
    record_figure("live_tuning_restored_to_high_gain_ratio", restored["rate_fast"] / high["rate_fast"], 0.2)
