"""Benchmark: the EKF and the Mahony filter against ground truth, over a standard flight and several seeds.

Profile (one real ``sitl`` + ``autopilot`` stack per flight, ``--speed max``, the
simulator's default sensor errors): take off to 5 m, fly a 10 m square
(DO_REPOSITION to each corner), hover 20 s in 5 m/s wind with 1 m/s turbulence
and 2 m/s gusts (set through ``SIM_*`` parameters), land.  Each seed is flown
twice: with ``SYS_MC_EST_GROUP = 2`` (the EKF) and ``= 1`` (Mahony attitude + the
linear position filter), so each estimator is measured while the controllers fly
on it.

Errors, RMS over the airborne part of the flight, estimate minus truth at the same
simulated time (the truth is carried to the estimate's time stamp with its own
body rates and velocity; the two are sampled at 50 Hz with different phases):

* roll/pitch: sqrt(mean(droll^2 + dpitch^2) / 2), degrees; yaw, degrees;
* horizontal position: GLOBAL_POSITION_INT latitude/longitude against the truth's,
  so the GPS error at the moment the estimator set its origin counts too;
* vertical position: height above home (the barometer is the height reference)
  against the truth's height above the start point;
* velocity: horizontal and vertical, m/s.

Also printed: the real-time factor of each flight (simulated / wall seconds).  A progress bar
(stderr) counts the phases of every flight (ready, take-off, four corners, hover, landing) and shows
the current flight's simulated seconds.

Below the per-seed rows: each estimator's mean (RMS over the seeds) and max (worst seed), and issue
21's targets for the EKF.

Usage: ``python benchmarks/estimator_benchmark.py [--seeds 0 1 2 3 4] [--vehicle quad_x] [--estimators 2 1]
[-i N] [--fc-param NAME=VALUE]``
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import ports
from mavsim_core import quaternion as quat  # noqa: E402
from sitl.scenario import load_scenario  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ALT_M = 5.0
SQUARE_M = 10.0
HOVER_S = 20.0
WIND = load_scenario("windy").parameters  # params/scenarios/windy.toml: the same wind as `sitl --scenario windy`
EARTH_RADIUS_M = 6_378_137.0
ESTIMATORS = {2: "EKF", 1: "Mahony"}
PHASES = 8  # of each flight: ready, take-off, four corners, hover in wind, landed
TARGETS = {"rp_deg": 0.15, "yaw_deg": 0.3, "h_m": 0.08}  # issue 21's, for the EKF over five seeds


def _rms_over_seeds(rs: list[dict], key: str) -> float:
    return float(np.sqrt(np.mean([r[key] ** 2 for r in rs])))


def _max_over_seeds(rs: list[dict], key: str) -> float:
    return float(max(r[key] for r in rs))


def _truth_at(truth: SimClient, time_ms: int):
    """Truth (roll, pitch, yaw, lat, lon, alt_m, vel NED) carried to ``time_ms`` from the nearest sample."""
    st = truth.state_at(time_ms, within_ms=12)
    if st is None:
        return None
    dt = (time_ms - st.time_usec / 1000.0) / 1000.0
    q = quat.integrate(
        np.array(st.attitude_quaternion, dtype=float), np.array([st.rollspeed, st.pitchspeed, st.yawspeed]), dt
    )
    vel = np.array([st.vx, st.vy, st.vz]) / 100.0
    lat = st.lat / 1e7 + math.degrees(vel[0] * dt / EARTH_RADIUS_M)
    lon = st.lon / 1e7 + math.degrees(vel[1] * dt / (EARTH_RADIUS_M * math.cos(math.radians(st.lat / 1e7))))
    alt = st.alt / 1000.0 - vel[2] * dt
    return (*quat.to_euler(q), lat, lon, alt, vel)


class Recorder:
    """Keeps the flight controller's ATTITUDE and GLOBAL_POSITION_INT by time stamp while airborne."""

    def __init__(self) -> None:
        self.att: dict[int, tuple[float, float, float]] = {}
        self.pos: dict[int, object] = {}
        self.on = False

    def __call__(self, msg) -> None:
        if not self.on:
            return
        kind = msg.get_type()
        if kind == "ATTITUDE":
            self.att[msg.time_boot_ms] = (msg.roll, msg.pitch, msg.yaw)
        elif kind == "GLOBAL_POSITION_INT":
            self.pos[msg.time_boot_ms] = msg


def errors(rec: Recorder, truth: SimClient, home_truth_alt_m: float) -> dict:
    d_att, d_yaw, d_h, d_v, d_vh, d_vv = [], [], [], [], [], []
    for t, (r, p, y) in rec.att.items():
        tr = _truth_at(truth, t)
        if tr is None:
            continue
        d_att += [quat.wrap_pi(r - tr[0]), quat.wrap_pi(p - tr[1])]
        d_yaw.append(quat.wrap_pi(y - tr[2]))
    for t, m in rec.pos.items():
        tr = _truth_at(truth, t)
        if tr is None:
            continue
        lat, lon = m.lat / 1e7, m.lon / 1e7
        dn = math.radians(lat - tr[3]) * EARTH_RADIUS_M
        de = math.radians(lon - tr[4]) * EARTH_RADIUS_M * math.cos(math.radians(lat))
        d_h.append(math.hypot(dn, de))
        d_v.append(m.relative_alt / 1000.0 - (tr[5] - home_truth_alt_m))
        v = np.array([m.vx, m.vy, m.vz]) / 100.0
        d_vh.append(math.hypot(*(v[:2] - tr[6][:2])))
        d_vv.append(v[2] - tr[6][2])

    def rms(a):
        return float(np.sqrt(np.mean(np.square(a)))) if a else float("nan")

    return {
        "rp_deg": math.degrees(rms(d_att)),
        "yaw_deg": math.degrees(rms(d_yaw)),
        "h_m": rms(d_h),
        "v_m": rms(d_v),
        "vel_h": rms(d_vh),
        "vel_v": rms(d_vv),
        "n_att": len(d_att) // 2,
        "n_pos": len(d_h),
    }


def fly(vehicle: str, instance: int, seed: int, group: int, fc_params: list[str], progress: Progress) -> dict:
    """One flight on estimator ``group``; its errors against the truth and its real-time factor."""
    progress.phase("starting the stack")
    with (
        Stack(instance=instance, speed="max", vehicle=vehicle, seed=seed, flight_logs=False) as stack,
        SimClient(ports.sim_component_port(instance)) as truth,
    ):
        c = VehicleClient(stack.api_url, timeout_s=60, idle=progress.idle(stack.check_alive))
        progress.watch(c)
        c.param_set("SYS_MC_EST_GROUP", group)
        for item in fc_params:
            name, value = item.split("=", 1)
            c.param_set(name, float(value))
        for mid in (mavlink.MAVLINK_MSG_ID_ATTITUDE, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT):
            c.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mid, 20_000).check()
        c.wait_until(c.prearm_ok, 120, "ready to arm")
        truth.wait_connected()
        progress.done(phase="take-off")
        rec = Recorder()
        c.add_listener(rec)
        home_truth_alt = truth.latest_state.alt / 1000.0
        wall0, sim0 = time.monotonic(), c.sim_time_s()
        c.arm().check()
        c.takeoff(c.home().alt_amsl_m + ALT_M).check()
        rec.on = True
        c.wait_until(lambda: c.takeoff_done(ALT_M), 120, "take-off")
        for k, (dn, de) in enumerate(((SQUARE_M, 0), (SQUARE_M, SQUARE_M), (0, SQUARE_M), (0, 0))):
            progress.done(phase=f"corner {k + 1} of 4")
            c.goto_ned(dn, de, -ALT_M).check()  # m NED from home
            c.wait_until(lambda: c.arrived(dn, de, 0.5, 0.5), 120, "corner")
        progress.done(phase=f"hover {HOVER_S:g} s in wind")
        for name, value in WIND.items():
            truth.set(name, value)
        c.wait_sim_time(HOVER_S)
        progress.done(phase="landing")
        c.land().check()
        c.wait_until(lambda: c.landed_state() == mavlink.MAV_LANDED_STATE_ON_GROUND, 180, "landed")
        rec.on = False
        rtf = (c.sim_time_s() - sim0) / (time.monotonic() - wall0)
        c.wait_until(c.landed_and_disarmed, 60, "disarmed")
        progress.done(phase="landed")
        progress.watch(None)
        c.close()
        out = errors(rec, truth, home_truth_alt)
        out["rtf"] = rtf
        return out


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4], help="simulator seeds, one flight per estimator each"
    )
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    add_instance(ap, 25)
    ap.add_argument(
        "--estimators",
        type=int,
        nargs="+",
        default=[2, 1],
        choices=[1, 2],
        help="SYS_MC_EST_GROUP values to fly (2 = EKF, 1 = Mahony)",
    )
    ap.add_argument(
        "--fc-param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a flight-controller parameter set before take-off (e.g. ATT_MAHONY_KP=0.5), repeatable",
    )
    args = ap.parse_args(argv)
    print(
        f"{args.vehicle}: take-off to {ALT_M:.0f} m, {SQUARE_M:.0f} m square, {HOVER_S:.0f} s hover in "
        f"{WIND['SIM_WIND_SPD']:.0f} m/s wind with gusts, landing; RMS of estimate - truth while airborne"
    )
    print(
        f"{'estimator':9} {'seed':>4} {'roll/pitch':>10} {'yaw':>6} {'pos h':>7} {'pos v':>7} "
        f"{'vel h':>8} {'vel v':>8} {'RTF':>6}"
    )
    summary: dict[int, list[dict]] = {g: [] for g in args.estimators}
    with Progress(PHASES * len(args.seeds) * len(args.estimators), "phase") as progress:
        for seed in args.seeds:
            for g in args.estimators:
                progress.label(f"seed {seed} {ESTIMATORS[g]}")
                r = fly(args.vehicle, args.instance, seed, g, args.fc_param, progress)
                summary[g].append(r)
                progress.say(
                    f"{ESTIMATORS[g]:9} {seed:4d} {r['rp_deg']:9.3f}° {r['yaw_deg']:5.2f}° {r['h_m']:6.3f}m "
                    f"{r['v_m']:6.3f}m {r['vel_h']:5.3f}m/s {r['vel_v']:5.3f}m/s {r['rtf']:5.1f}x"
                )
    for g, rs in summary.items():
        for label, agg in (("mean", _rms_over_seeds), ("max", _max_over_seeds)):
            print(
                f"{ESTIMATORS[g]:9} {label:>4} {agg(rs, 'rp_deg'):9.3f}° {agg(rs, 'yaw_deg'):5.2f}° "
                f"{agg(rs, 'h_m'):6.3f}m {agg(rs, 'v_m'):6.3f}m {agg(rs, 'vel_h'):5.3f}m/s {agg(rs, 'vel_v'):5.3f}m/s "
                f"{np.mean([r['rtf'] for r in rs]) if label == 'mean' else max(r['rtf'] for r in rs):5.1f}x"
            )
    print(
        "mean: RMS over the seeds (each seed's RMS error squared, averaged, rooted); max: the worst seed.  "
        f"Targets (issue 21, the EKF, {len(args.seeds)} seeds): roll/pitch <= {TARGETS['rp_deg']} deg, "
        f"yaw <= {TARGETS['yaw_deg']} deg, horizontal <= {TARGETS['h_m']} m"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
