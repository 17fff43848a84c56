"""MAVSDK (the 4.x native binding) flies the real stack: the README's example, run as a user runs it.

``examples/mavsdk_fly.py`` is what a MAVSDK user does first: connect on udpin 14540+N, wait for
health, set the take-off altitude (a PX4 parameter), arm, take off, land.  This test runs that very
file against a stack, so the README's MAVSDK block cannot rot, and checks what it printed and what
the vehicle did.  (It caught a real bug once: MAVSDK sends NaN in COMPONENT_ARM_DISARM's unused
param 2.)
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from gcs.client import VehicleClient
from gcs.launcher import Stack

pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")

from mavsim_core import ports  # noqa: E402

from instances import instance  # tests/instances.py: every test's instance numbers  # noqa: E402

pytestmark = pytest.mark.e2e
INSTANCE = instance("test_e2e_mavsdk", "stack")
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "mavsdk_fly.py"


def test_the_readme_mavsdk_example_arms_takes_off_and_lands():
    with Stack(instance=INSTANCE, speed="max") as stack:
        proc = subprocess.run(
            [sys.executable, str(EXAMPLE), f"udpin://0.0.0.0:{ports.api_port(INSTANCE)}"],
            capture_output=True,
            text=True,
            timeout=300,  # a safety net only
        )
        stack.check_alive()
        with VehicleClient(stack.gcs_url, timeout_s=60, target_system=stack.sysid) as client:
            assert client.param_get("MIS_TAKEOFF_ALT") == pytest.approx(4.0)  # set by MAVSDK
            assert not client.armed()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "connected: autopilot PX4"  # MAVSDK treats it as PX4 (heartbeat identity)
    assert lines[1] == "ready to arm"
    altitude = float(lines[2].split()[1])  # "at 4.02 m above home; landing"
    assert altitude == pytest.approx(4.0, abs=0.5)
    final = float(lines[3].split()[-2])  # "landed and disarmed at 0.01 m"
    assert abs(final) < 0.5
