"""End-to-end: an acknowledged parameter change survives a crash of the flight controller (issue 18, finding 10).

One max-speed stack (module scope, a free instance) with ``--state-dir``; it is never armed.
A pymavlink client (:class:`VehicleClient`) listens on the port the flight controller sends its
ground-station link to, so it also hears what the flight controller says while it starts.

* 100 PARAM_SETs sent at once; the flight controller is killed (SIGKILL) right after the last echo
  (PARAM_VALUE) arrived; after a restart every echoed value is the vehicle's value.
* A corrupt state file is kept as ``*.corrupt`` and reported (STATUSTEXT and log), the defaults are used;
  temporary files a killed write left behind are removed, another instance's are not.
* A save that fails (a directory where the state file goes) is reported by STATUSTEXT; the value is
  still echoed and used (PX4 keeps a value it could not save in RAM), and saved once it can be.

Wall-clock values are only "give up waiting" timeouts.
"""

from __future__ import annotations

import importlib
import shutil
import struct
import time
from pathlib import Path

import pytest

importlib.import_module("autopilot.flight_controller")  # declares every parameter
from autopilot.param_catalogue import default_store
from gcs.client import VehicleClient, mavlink
from gcs.errors import GcsTimeout
from gcs.launcher import Stack
from gcs.plugins.param import decode_param_value, param_id_text
from params.param_file import QGC, read_param_file

from e2e_flight_helpers import CLIENT_SPEED, WAIT_S, texts_since  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e

# quad_x's MPC_XY_P as its vehicle file sets it (the design-gains block), the value a lost state file falls back to.
XY_P = float(
    read_param_file(Path(__file__).resolve().parents[1] / "params" / "vehicles" / "quad_x.params").values()["MPC_XY_P"]
)
BURST = 100  # PARAM_SETs sent at once
ROUNDS = 4  # each chosen parameter is set this many times, to a new value each time


def f32(value: float) -> float:
    """``value`` as the 32-bit float a REAL32 parameter holds."""
    return struct.unpack("<f", struct.pack("<f", value))[0]


@pytest.fixture(scope="module")
def state_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fc-state")


@pytest.fixture(scope="module")
def stack(inst, state_dir):
    with Stack(
        instance=inst,
        speed=CLIENT_SPEED,
        extra_sitl_args=["--truth-port", "0"],
        extra_autopilot_args=["--state-dir", str(state_dir)],
        flight_logs=False,
    ) as s:
        yield s


@pytest.fixture(scope="module")
def client(stack):
    with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, target_system=stack.sysid, idle=stack.check_alive) as c:
        yield c


def state_path(state_dir: Path, stack: Stack) -> Path:
    """The flight controller's parameter file in ``state_dir`` (one per vehicle and instance)."""
    return state_dir / f"quad_x-{stack.instance}.params"


def burst_parameters() -> list[str]:
    """REAL32 parameters no cross-parameter rule ties to another, with room above their default."""
    store = default_store()
    tied = {name for rule in store._rules for name in (rule.lhs, rule.rhs)}
    names = []
    for name in store.names():
        d = store.definition(name)
        if d.ptype != "REAL32" or name in tied or not name.startswith(("MC_", "MPC_", "ATT_")):
            continue
        if d.default > 0 and d.default * 1.2 <= d.max:
            names.append(name)
    assert len(names) >= BURST // ROUNDS
    return names[: BURST // ROUNDS]


def restart_after_kill(stack: Stack, client: VehicleClient, before_start=None) -> None:
    """SIGKILL the flight controller (unless already dead), run ``before_start``, start it again and wait until
    it answers."""
    client.idle = None  # (the stack's liveness check: the flight controller is down for a moment)
    if stack.procs["autopilot"].poll() is None:
        stack.kill_autopilot()
    if before_start is not None:
        before_start()
    client.drain()
    client._latest.pop("HEARTBEAT", None)
    stack.start_autopilot()
    client.idle = stack.check_alive
    client.wait_until(lambda: client.latest("HEARTBEAT") is not None, WAIT_S, "the restarted flight controller")
    deadline = time.monotonic() + WAIT_S
    while True:  # it answers parameter requests once its link runs
        try:
            client.param_get("MPC_XY_P", timeout_s=0.5, retries=1)
            return
        except GcsTimeout:
            assert time.monotonic() < deadline, "the restarted flight controller does not answer"


def test_every_acknowledged_value_survives_a_kill(stack, client, state_dir):
    names = burst_parameters()
    store = default_store()
    client.param_get("MPC_XY_P")  # the vehicle answers: its link runs
    vehicle_defaults = {name: client.param_get(name) for name in names}  # the vehicle file's, put back at the end
    sets = [
        (name, f32(store.default(name) * (1.0 + 0.04 * (r + 1) + 0.001 * i)))
        for r in range(ROUNDS)
        for i, name in enumerate(names)
    ]
    final = dict(sets)  # the last value set of each parameter
    acknowledged: dict[str, float] = {}

    def note(msg) -> None:
        if msg.get_type() == "PARAM_VALUE":
            acknowledged[param_id_text(msg.param_id)] = decode_param_value(msg)

    def send(name: str, value: float) -> None:
        client.conn.mav.param_set_send(stack.sysid, 1, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32)

    client.drain()
    client.add_listener(note)
    try:
        for name, value in sets:
            send(name, value)
        # The link may drop part of a burst (its flood defence): resend what is not echoed, as a ground
        # station does, until every last value is; then kill the flight controller at once (no exit handler).
        while True:
            missing = [name for name in names if acknowledged.get(name) != final[name]]
            if not missing:
                break
            try:
                client.wait_until(lambda: all(acknowledged.get(n) == final[n] for n in missing), 0.5, "echoes")
            except GcsTimeout:
                for name in missing:
                    if acknowledged.get(name) != final[name]:
                        send(name, final[name])
        client.idle = None
        stack.kill_autopilot()
    finally:
        client.remove_listener(note)
    echoed = {name: value for name, value in acknowledged.items() if name in names}
    print(f"\n{len(sets)} PARAM_SETs sent, {len(echoed)} parameters echoed before the kill")
    assert echoed, "no echo at all"

    restart_after_kill(stack, client)
    after = {name: client.param_get(name) for name in echoed}
    lost = {name: (value, after[name]) for name, value in echoed.items() if after[name] != value}
    assert not lost, f"acknowledged values lost by the kill (echoed, after restart): {lost}"
    assert after == final  # every last value was echoed, so every one must be there
    for name in names:  # leave the vehicle's defaults
        client.param_set(name, vehicle_defaults[name])


def test_a_corrupt_state_file_is_kept_reported_and_replaced_by_defaults(stack, client, state_dir):
    path = state_path(state_dir, stack)
    client.param_set("MPC_XY_P", 1.1)
    garbage = b"\x00\x17garbage\xff\xfe not a parameter file\n1\t1\tMPC_XY_P\t1.\x00\n"
    stale = state_dir / f".{path.name}.k1ll3d.tmp"  # what a write killed mid-way leaves behind
    stale_plan = state_dir / f".quad_x-{stack.instance}.plan.json.x7y8z9.tmp"
    others = state_dir / ".quad_x-5.params.abcdef.tmp"  # another instance's write in progress: not ours

    def damage() -> None:
        path.write_bytes(garbage)
        for p in (stale, stale_plan, others):
            p.write_text("half a file")

    texts_before = len(client.statustexts)
    restart_after_kill(stack, client, damage)
    corrupt = path.with_name(path.name + ".corrupt")
    assert corrupt.exists() and corrupt.read_bytes() == garbage, sorted(p.name for p in state_dir.iterdir())
    assert client.param_get("MPC_XY_P") == pytest.approx(XY_P)  # the vehicle's default
    assert not stale.exists() and not stale_plan.exists() and others.exists()
    client.wait_until(
        lambda: any("corrupt" in t for t in texts_since(client, texts_before)), WAIT_S, "a STATUSTEXT about it"
    )
    log = stack.tail("autopilot", 60)
    assert f"kept as {corrupt}" in log, log
    assert read_param_file(path, QGC).problems == []  # a good state file again
    others.unlink()


def test_a_failed_save_is_reported_and_the_value_still_used(stack, client, state_dir):
    path = state_path(state_dir, stack)
    path.unlink()
    path.mkdir()  # the next save cannot replace it (even as root)
    try:
        texts_before = len(client.statustexts)
        assert client.param_set("MPC_XY_P", 1.2) == pytest.approx(1.2)  # echoed: the vehicle uses it
        client.wait_until(
            lambda: any("not saved" in t for t in texts_since(client, texts_before)),
            WAIT_S,
            "a STATUSTEXT saying the value was not saved",
        )
        text = next(t for t in texts_since(client, texts_before) if "not saved" in t)
        print(f"\nSTATUSTEXT: {text}")
        assert client.param_get("MPC_XY_P") == pytest.approx(1.2)
    finally:
        shutil.rmtree(path)
    assert client.param_set("MPC_XY_P", 1.25) == pytest.approx(1.25)
    assert read_param_file(path, QGC).values()["MPC_XY_P"] == pytest.approx(1.25)  # saved before the echo
    client.param_set("MPC_XY_P", XY_P)
