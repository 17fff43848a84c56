"""gcs.connection.Connection against a vehicle played by a plain UDP socket (no stack).

What a user of the ground-station side relies on: the vehicle hears our HEARTBEAT as soon as we have
heard it, not up to a period later (a vehicle that never heard its ground station has no data link to
lose: tests/test_e2e_failsafes.py silences the client right after a take-off that takes well under a
second of wall time at full speed).
"""

from __future__ import annotations

import socket

from pymavlink.dialects.v20 import common as mavlink

from gcs.connection import Connection

SAFETY_NET_S = 10.0  # wall seconds before a receive gives up (not a measured limit)


class FakeVehicle:
    """A UDP socket that sends a PX4 quadrotor's HEARTBEAT (system 1, component 1) and reads what comes back."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(SAFETY_NET_S)
        self.mav = mavlink.MAVLink(None, 1, 1)
        self.parser = mavlink.MAVLink(None)

    def heartbeat_to(self, port: int) -> None:
        hb = self.mav.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 0)
        self.sock.sendto(hb.pack(self.mav), ("127.0.0.1", port))

    def next_message(self):
        while True:
            data, _ = self.sock.recvfrom(4096)
            msgs = self.parser.parse_buffer(data)
            if msgs:
                return msgs[0]


def test_the_vehicle_hears_our_heartbeat_as_soon_as_we_have_heard_it():
    vehicle = FakeVehicle()
    conn = Connection("udpin:127.0.0.1:0", wait_heartbeat=False, heartbeat_period_s=3600.0)
    try:
        port = conn.conn.port.getsockname()[1]
        conn.pump(0.0)  # our first HEARTBEAT is due now, but no vehicle has been heard: it goes nowhere
        vehicle.heartbeat_to(port)
        conn.wait_heartbeat(SAFETY_NET_S)
        conn.pump(0.0)
        msg = vehicle.next_message()
        assert msg.get_type() == "HEARTBEAT" and msg.type == mavlink.MAV_TYPE_GCS
        assert (msg.get_srcSystem(), msg.get_srcComponent()) == (255, 190)
    finally:
        conn.close()
        vehicle.sock.close()
