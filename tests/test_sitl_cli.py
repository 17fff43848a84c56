"""The ``sitl`` command line and process: SIM_* parameters from ``--scenario`` and ``--param``.

``--list-params`` and its errors run :func:`sitl.__main__.main` in this process.  One test
(marked ``e2e``) starts the real ``sitl`` process (on a free instance: ``free_instance``), which
serves its parameters while it waits for a flight controller.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from mavsim_core import ports
from mavsim_core.param_encoding import INT32, REAL32  # noqa: E402
from sitl import __main__ as sitl_main  # noqa: E402

from sim_params_helpers import GCS_COMP, GCS_SYS, value_of, write  # tests/sim_params_helpers.py

ROOT = Path(__file__).resolve().parent.parent


# --------------------------------------------------------------------------- the CLI


def test_cli_list_params(capsys):
    assert (
        sitl_main.main(
            ["--list-params", "--scenario", "windy", "--param", "SIM_WIND_SPD=7", "--param", "SIM_ENGINE_FAIL=2"]
        )
        == 0
    )
    out = capsys.readouterr().out.splitlines()
    rows = {line.split()[0]: line.split() for line in out[1:]}
    assert rows["SIM_WIND_SPD"][1] == "7" and rows["SIM_WIND_DIR"][1] == "270" and rows["SIM_ENGINE_FAIL"][1] == "2"
    assert rows["SIM_WIND_SPD"][2:5] == ["0", "30", "m/s"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--param", "SIM_WIND_SPD=99"], "SIM_WIND_SPD: 99 outside range"),
        (["--param", "SIM_NOPE=1"], "SIM_NOPE: unknown parameter"),
        (["--param", "SIM_WIND_SPD=fast"], "value must be a number"),
        (["--param", "SIM_WIND_SPD"], "expected NAME=VALUE"),
        (["--scenario", "no_such_scenario"], "no such scenario file"),
    ],
)
def test_cli_errors_exit_2(capsys, args, message):
    with pytest.raises(SystemExit) as exit_:  # argparse errors exit by themselves ...
        sys.exit(sitl_main.main(["--list-params", *args]))  # ... checked values return 2
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_cli_bad_scenario_file_exits_2(tmp_path, capsys):
    path = write(tmp_path, "[parameters]\nSIM_ENGINE_FAIL = 99\n")
    assert sitl_main.main(["--list-params", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "parameters.SIM_ENGINE_FAIL" in err and "outside range" in err


# --------------------------------------------------------------------------- the real process


@pytest.mark.e2e
def test_sitl_process_serves_parameters_while_waiting_for_the_flight_controller(tmp_path, free_instance):
    instance = free_instance()
    port = ports.sim_component_port(instance)
    client = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=GCS_SYS, source_component=GCS_COMP)
    log_path = tmp_path / "sitl.log"
    log = open(log_path, "w")  # the child's; read through log_path (seeking this would move the child's offset)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sitl",
            "--instance",
            str(instance),
            "--speed",
            "max",
            "--scenario",
            "windy",
            "--param",
            "SIM_GPS_LAG_MS=80",
        ],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    try:
        hb = client.recv_match(type="HEARTBEAT", blocking=True, timeout=60)
        assert hb is not None, f"no HEARTBEAT from sitl:\n{log_path.read_text()}"
        assert (hb.get_srcSystem(), hb.get_srcComponent()) == (ports.system_id(instance), 51)

        def exchange(send, name):
            for _ in range(5):  # UDP: retry as a ground station would
                send()
                m = client.recv_match(
                    type="PARAM_VALUE", blocking=True, timeout=2, condition=f"PARAM_VALUE.param_id == '{name}'"
                )
                if m is not None:
                    return m
            raise AssertionError(f"no PARAM_VALUE for {name}")

        m = exchange(
            lambda: client.mav.param_request_read_send(ports.system_id(instance), 51, b"SIM_WIND_DIR", -1),
            "SIM_WIND_DIR",
        )
        assert m.param_value == 270.0  # from the scenario
        m = exchange(
            lambda: client.mav.param_request_read_send(ports.system_id(instance), 51, b"SIM_GPS_LAG_MS", -1),
            "SIM_GPS_LAG_MS",
        )
        assert value_of(m) == 80  # from --param
        m = exchange(
            lambda: client.mav.param_set_send(ports.system_id(instance), 51, b"SIM_WIND_SPD", 3.0, REAL32),
            "SIM_WIND_SPD",
        )
        assert m.param_value == 3.0
        m = exchange(
            lambda: client.mav.param_set_send(ports.system_id(instance), 51, b"SIM_ENGINE_FAIL", 2.0, INT32),
            "SIM_ENGINE_FAIL",
        )
        assert value_of(m) == 2
        assert proc.poll() is None
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        client.close()
        log.close()
    text = log_path.read_text()
    assert "scenario windy" in text and "SIM_WIND_SPD = 3 (PARAM_SET from" in text, text
