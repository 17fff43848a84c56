"""``gcs plot`` (the flight controller's ULog, truth log, .tlog), and the logs a real flight leaves, plotted.

Unit tests write files in pytest's tmp_path; the end-to-end test (marked ``e2e``) flies the
real processes (``Stack``) on a free instance (``free_instance``, tests/conftest.py) and reads the logs they
leave.  The simulator's UDP truth is off (``--truth-port 0``): the test reads the truth from the
simulator's log.  Writing the logs is tested in tests/test_flight_logs.py.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402
from pyulog import ULog  # noqa: E402

from autopilot import ulog_topics  # noqa: E402
from gcs import plot  # noqa: E402
from gcs.__main__ import main as gcs_main  # noqa: E402
from mavsim_core import tlog  # noqa: E402
from mavsim_core.npy_log import NpyLogWriter  # noqa: E402
from mavsim_core.quaternion import from_euler  # noqa: E402
from mavsim_core.ulog_writer import ULogWriter  # noqa: E402
from sitl.truth_log import CameraFrame, frame_log_fields, truth_log_fields  # noqa: E402

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py
from flight_log_helpers import EPOCH0_US, make_mav, read_tlog  # tests/flight_log_helpers.py

ROOT = Path(__file__).resolve().parent.parent
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
TOPICS = ("vehicle_attitude", "vehicle_local_position", "actuator_motors", "flight_mode", "vehicle_attitude_setpoint",
          "vehicle_local_position_setpoint")  # fmt: skip


# --------------------------------------------------------------------------- plots


def _synthetic_flight(tmp_path: Path, stem: str = "2026-01-02_03-04-05") -> tuple[Path, Path]:
    """A 20 s flight controller's ULog (take-off to 3 m and a roll wobble) and its truth log."""
    t_us = np.arange(0, 20_000_000, 4000)
    alt = np.clip((t_us / 1e6 - 2.0) * 1.0, 0.0, 3.0)
    roll = 0.05 * np.sin(t_us / 1e6 * 3.0)
    fc_path, truth_path = tmp_path / (stem + ".ulg"), tmp_path / (stem + ".truth.npy")
    with ULogWriter(fc_path, 0) as w:  # the flight controller's topics (autopilot/ulog_topics.py), every 4 ms
        for fmt in ulog_topics.FORMATS:
            w.add_format(fmt)
        subs = {name: w.subscribe(name) for name in TOPICS}
        nan8 = [math.nan] * 8
        for k, t in enumerate(t_us):
            t = int(t)
            q = from_euler(float(roll[k]), 0.0, 0.2)
            w.write(subs["vehicle_attitude"], t, t, *q, 0.0, 0.0, 0.0, 0.0, 0)
            w.write(subs["vehicle_local_position"], t, t, *[True] * 4, 0.9, 0.0, -alt[k], *[0.0] * 6, 0.2, 0, 0,
                    False, False, math.nan, math.nan, math.nan)  # fmt: skip
            w.write(subs["actuator_motors"], t, t, 0, 0.5, 0.52, 0.48, 0.5, *nan8)
            w.write(subs["flight_mode"], t, 4, 2 if t < 8e6 else 3)
            if t > 2e6:  # setpoints once the cascade flies
                w.write(subs["vehicle_attitude_setpoint"], t, *from_euler(float(roll[k]) * 1.2, 0.0, 0.2), 0, 0, -0.5)
                w.write(subs["vehicle_local_position_setpoint"], t, 1.0, 0.0, -3.0, *[0.0] * 9, 0.2, math.nan)
    w = NpyLogWriter(truth_path, truth_log_fields(4), chunk_rows=500)
    for k, t in enumerate(t_us):
        w.append(
            int(t),
            1,
            1.0,
            0.02,
            -alt[k] - 0.2,
            0.0,
            0.0,
            0.0,
            float(roll[k]) + 0.01,
            0.0,
            0.2,
            0.0,
            0.0,
            0.0,
            0.5,
            0.5,
            0.5,
            0.5,
        )
    w.close()
    return fc_path, truth_path


def _check_pngs(out: Path) -> None:
    for name in plot.FIGURES:
        png = out / f"{name}.png"
        assert png.exists(), png
        data = png.read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 10_000, png


def test_the_camera_frames_beside_the_truth_are_loaded_for_the_flights_span(tmp_path):
    fc_path, _ = _synthetic_flight(tmp_path)
    assert plot.load(fc_path).frames is None  # an older flight: no frame log
    w = NpyLogWriter(tmp_path / "2026-01-02_03-04-05.frames.npy", frame_log_fields())
    for t_us in range(19_000_000, 21_000_000, 100_000):  # past the control log's end (20 s) too
        w.append(*CameraFrame(t_us, (0.0, -1.5, 0.1), True, (76, 42)).row())
    w.close()
    frames = plot.load(fc_path).frames
    assert frames is not None and frames.t_s[0] == 19.0 and frames.t_s[-1] == pytest.approx(19.9)
    assert frames.cols["gimbal_pitch_deg"][0] == pytest.approx(math.degrees(-1.5))
    assert frames.cols["marker_1"][0] == 42 and frames.cols["n_markers"][0] == 2


def test_gcs_plot_control_log_finds_truth_and_writes_pngs(tmp_path, capsys):
    fc_path, _ = _synthetic_flight(tmp_path)
    assert gcs_main(["plot", str(tmp_path), "--out", str(tmp_path / "png")]) == 0  # a directory: newest log
    out = capsys.readouterr().out
    assert "ground truth from 2026-01-02_03-04-05.truth.npy" in out
    _check_pngs(tmp_path / "png")
    data = plot.load(fc_path)
    assert data.truth is not None and data.truth.cols["alt_m"][0] == 0.0  # truth altitude from its start
    assert np.nanmax(data.setpoint.cols["alt_m"]) == pytest.approx(3.0)
    assert [name for _, name in data.modes] == ["TAKEOFF", "LOITER"]
    assert gcs_main(["plot", str(fc_path), "--no-truth"]) == 0  # default --out: beside the log
    _check_pngs(tmp_path / "2026-01-02_03-04-05_plots")


def test_gcs_plot_tlog(tmp_path):
    """From a tlog: ATTITUDE vs ATTITUDE_TARGET, LOCAL_POSITION_NED vs POSITION_TARGET_LOCAL_NED, SERVO_OUTPUT_RAW."""
    mav = make_mav()
    w = tlog.TlogWriter(tmp_path / "2026-01-02_03-04-05.tlog")
    for k in range(200):  # 10 s at 20 Hz, every message twice (two endpoints)
        ms = k * 50
        q = list(from_euler(0.1, 0.0, 0.0))
        msgs = [
            mavlink.MAVLink_attitude_message(ms, 0.09, 0.01, 0.0, 0, 0, 0),
            mavlink.MAVLink_attitude_target_message(ms, 0, q, 0, 0, 0, 0.5),
            mavlink.MAVLink_local_position_ned_message(ms + 10, 0.0, 0.0, -min(ms / 1000.0, 3.0), 0, 0, 0),
            mavlink.MAVLink_position_target_local_ned_message(ms + 10, 1, 0, 0.0, 0.0, -3.0, 0, 0, 0, 0, 0, 0, 0, 0),
            mavlink.MAVLink_servo_output_raw_message(ms * 1000, 0, 1500, 1500, 1500, 1500, 0, 0, 0, 0),
        ]
        if k % 20 == 0:
            msgs.append(mavlink.MAVLink_heartbeat_message(2, 12, 129, 4 << 16 | 3 << 24, 4, 3))
        for m in msgs * 2:
            w.write(EPOCH0_US + ms * 1000, m.pack(mav))
    w.close()
    out = tmp_path / "png"
    assert gcs_main(["plot", str(tmp_path / "2026-01-02_03-04-05.tlog"), "--out", str(out)]) == 0
    _check_pngs(out)
    data = plot.load(tmp_path / "2026-01-02_03-04-05.tlog")
    assert data.truth is None and data.motors is not None and len(data.motors.cols) == 4
    assert np.nanmax(data.setpoint.cols["roll_deg"]) == pytest.approx(math.degrees(0.1), abs=1e-3)
    assert np.isfinite(data.estimate.cols["alt_m"]).sum() == 200  # duplicates dropped
    assert data.motors.cols["motor_0"][0] == pytest.approx(0.5)


def test_gcs_plot_reports_a_bad_log(tmp_path, capsys):
    assert gcs_main(["plot", str(tmp_path / "missing.ulg")]) == 1
    assert "no such file" in capsys.readouterr().err
    assert gcs_main(["plot", str(tmp_path)]) == 1  # an empty directory
    assert "no *.ulg or *.tlog" in capsys.readouterr().err
    (tmp_path / "2026-01-02_03-04-05.fc.npy").write_bytes(b"")  # a flight from before the ULog was the only log
    assert gcs_main(["plot", str(tmp_path)]) == 1
    assert "its .fc.npy is the control-rate log flights wrote before" in capsys.readouterr().err


# --------------------------------------------------------------------------- end to end


@pytest.mark.e2e
def test_e2e_flight_leaves_tlog_control_log_truth_and_plots(tmp_path, free_instance):
    """Real sitl + autopilot (max speed): take off to 3 m, hover 3 s, land; read the logs; plot them."""
    from gcs.client import VehicleClient
    from gcs.launcher import Stack

    wait_s, alt_m = 90.0, 3.0
    logs = tmp_path / "logs"
    with Stack(
        instance=free_instance(), speed=CLIENT_SPEED, log_dir=logs, extra_sitl_args=["--truth-port", "0"]
    ) as stack:
        with VehicleClient(stack.api_url, timeout_s=wait_s, idle=stack.check_alive) as c:
            c.wait_until(c.prearm_ok, wait_s, "ready to arm")
            home = c.wait_home(wait_s)
            c.arm().check()
            c.wait_armed(True, wait_s)
            c.takeoff(home.alt_amsl_m + alt_m).check()
            c.wait_until(lambda: c.takeoff_done(alt_m), wait_s, f"takeoff to {alt_m} m")
            c.wait_sim_time(3.0, wait_s, "3 s of hover")
            c.land().check()
            c.wait_until(c.landed_and_disarmed, wait_s, "landed and disarmed")
        codes = stack.stop()
    assert codes == {"autopilot": 143, "sitl": 143}  # SIGTERM: both closed their logs and exited

    tlogs, fcs, truths = (sorted(logs.glob("*" + sfx)) for sfx in (".tlog", ".ulg", ".truth.npy"))
    assert len(tlogs) == len(fcs) == len(truths) == 1, sorted(p.name for p in logs.iterdir())
    assert tlogs[0].name.endswith(f"_i{stack.instance}.tlog")
    assert fcs[0].name == tlogs[0].name.replace(".tlog", ".ulg")
    assert not list(logs.glob("*.fc.npy"))  # the ULog is the flight controller's only flight log

    msgs = read_tlog(tlogs[0])
    types = Counter(m.get_type() for m in msgs)
    for needed in (
        "HEARTBEAT",
        "ATTITUDE",
        "ATTITUDE_TARGET",
        "POSITION_TARGET_LOCAL_NED",
        "COMMAND_LONG",
        "COMMAND_ACK",
        "SERVO_OUTPUT_RAW",
    ):
        assert types[needed] > 0, types
    stamps = [m._timestamp for m in msgs]
    assert all(b >= a for a, b in zip(stamps, stamps[1:]))
    assert abs(stamps[0] - time.time()) < 24 * 3600  # wall-clock epoch seconds
    hover_z = [m.z for m in msgs if m.get_type() == "POSITION_TARGET_LOCAL_NED" and math.isfinite(m.z)]
    assert -min(hover_z) == pytest.approx(alt_m, abs=0.3)  # the commanded altitude (home ~ origin)
    targets = [m for m in msgs if m.get_type() == "ATTITUDE_TARGET"]
    assert all(abs(np.linalg.norm(m.q) - 1.0) < 1e-3 for m in targets)
    thrust = np.median([m.thrust for m in targets])
    assert 0.4 < thrust < 0.75  # hover: 57 % of full thrust for quad_x
    assert max(abs(m.roll) for m in msgs if m.get_type() == "ATTITUDE") < math.radians(15)

    log = {d.name: d.data for d in ULog(str(fcs[0])).data_list if d.multi_id == 0}
    status = log["vehicle_status"]["arming_state"]
    assert status[0] == ulog_topics.ARMING_STATE_ARMED and status[-1] == ulog_topics.ARMING_STATE_DISARMED
    att_t = log["vehicle_attitude"]["timestamp"]
    assert (np.diff(att_t) == 12_000).all()  # every third 250 Hz step, none lost
    assert -np.nanmin(log["vehicle_local_position_setpoint"]["z"]) == pytest.approx(alt_m, abs=0.3)
    assert -np.nanmin(log["vehicle_local_position"]["z"]) == pytest.approx(alt_m, abs=0.5)
    truth = np.load(truths[0])
    climb = -(truth["pos_d_m"] - truth["pos_d_m"][0])
    assert climb.max() == pytest.approx(alt_m, abs=0.5)
    assert abs(len(truth) - 3 * len(att_t)) < 50  # the same flight: the truth at 250 Hz, the attitude at 83 Hz

    out = tmp_path / "png"
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "plot", str(tlogs[0]), "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    assert "ground truth from" in proc.stdout
    _check_pngs(out)
