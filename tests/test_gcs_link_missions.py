"""The mission protocol of the ground-station link, on loopback UDP, with the commander's real plan store.

Upload and download of each plan type, the legacy MISSION_ITEM / MISSION_REQUEST, each kind of bad
item with its MAV_MISSION error (and the stored plan unchanged), a second client refused mid-upload,
a lost request sent again, a stalled upload ended, MISSION_CLEAR_ALL, MISSION_SET_CURRENT and
MISSION_CURRENT on request.
"""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink import mission_protocol  # noqa: E402

from gcs_link_harness import ORIGIN, of_type  # tests/gcs_link_harness.py

MISSION, FENCE, RALLY = mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE, mavlink.MAV_MISSION_TYPE_RALLY
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def lat_lon_e7(north_m: float, east_m: float) -> tuple[int, int]:
    return round((ORIGIN[0] + north_m / 111320.0) * 1e7), round((ORIGIN[1] + east_m / 75500.0) * 1e7)


def item(seq, command=mavlink.MAV_CMD_NAV_WAYPOINT, p=(0.0, 0.0, 0.0, float("nan")), north=0.0, east=0.0, z=10.0,
         frame=REL, mtype=MISSION):  # fmt: skip
    x, y = lat_lon_e7(north, east)
    return mavlink.MAVLink_mission_item_int_message(1, 1, seq, frame, command, 0, 1, *p, x, y, z, mtype)


def square(n: int = 4) -> list:
    return [item(k, north=10.0 * (k % 2), east=10.0 * (k // 2)) for k in range(n)]


def upload(h, c, items, mtype=MISSION, answer=None) -> list:
    """Upload by answering each request; ``answer(msg) -> item or None`` may alter or drop an answer.
    Returns every message the client received."""
    c.mav.mission_count_send(1, 1, len(items), mtype)
    seen = []
    for _ in range(200):
        got = h.pump(0.02)["gcs"]
        seen += got
        for m in got:
            if m.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and m.mission_type == mtype:
                out = items[m.seq] if answer is None else answer(m)
                if out is not None:
                    c.mav.send(out)
        if of_type(seen, "MISSION_ACK"):
            return seen
    return seen


def download(h, c, mtype=MISSION, legacy=False) -> list:
    c.mav.mission_request_list_send(1, 1, mtype)
    (count,) = of_type(h.pump(0.05, until=lambda m: m.get_type() == "MISSION_COUNT")["gcs"], "MISSION_COUNT")
    out = []
    for seq in range(count.count):
        kind = "MISSION_ITEM" if legacy else "MISSION_ITEM_INT"
        (c.mav.mission_request_send if legacy else c.mav.mission_request_int_send)(1, 1, seq, mtype)
        got = of_type(h.pump(0.05, until=lambda m, k=kind: m.get_type() == k)["gcs"], kind)
        out.append(got[0])
    c.mav.mission_ack_send(1, 1, mavlink.MAV_MISSION_ACCEPTED, mtype)
    return out


def ack_types(msgs) -> list[int]:
    return [a.type for a in of_type(msgs, "MISSION_ACK")]


def test_upload_download_each_plan_type(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    got = upload(h, c, square(5))
    assert ack_types(got) == [mavlink.MAV_MISSION_ACCEPTED]
    assert [m.seq for m in of_type(got, "MISSION_REQUEST_INT")] == [0, 1, 2, 3, 4]
    back = download(h, c)
    assert [(m.seq, m.command, m.x, m.y, m.z, m.frame) for m in back] == [
        (m.seq, m.command, m.x, m.y, m.z, m.frame) for m in square(5)
    ]
    corners = [(-50, -50), (50, -50), (50, 50), (-50, 50)]
    vertex = mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    fence = [
        item(k, vertex, (4, 0, 0, 0), n, e, 0.0, mavlink.MAV_FRAME_GLOBAL_INT, FENCE)
        for k, (n, e) in enumerate(corners)
    ]
    assert ack_types(upload(h, c, fence, FENCE)) == [mavlink.MAV_MISSION_ACCEPTED]
    rally = [item(0, mavlink.MAV_CMD_NAV_RALLY_POINT, north=30, east=0, z=0.0, mtype=RALLY)]
    assert ack_types(upload(h, c, rally, RALLY)) == [mavlink.MAV_MISSION_ACCEPTED]
    assert len(download(h, c, FENCE)) == 4 and len(download(h, c, RALLY)) == 1 and len(download(h, c)) == 5
    # the legacy float download
    legacy = download(h, c, legacy=True)
    assert legacy[1].x == pytest.approx(square(5)[1].x / 1e7, abs=1e-6)
    # MISSION_CURRENT reports the total, on request too
    c.mav.command_long_send(1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, 0, 0, 0,
                            0, 0, 0)  # fmt: skip
    cur = of_type(h.pump(0.05, until=lambda m: m.get_type() == "MISSION_CURRENT")["gcs"], "MISSION_CURRENT")
    assert cur and (cur[-1].seq, cur[-1].total, cur[-1].mission_state) == (0, 5, mavlink.MISSION_STATE_NOT_STARTED)
    # clear everything
    c.mav.mission_clear_all_send(1, 1, mavlink.MAV_MISSION_TYPE_ALL)
    assert ack_types(h.pump(0.05)["gcs"]) == [mavlink.MAV_MISSION_ACCEPTED]
    assert download(h, c) == [] and download(h, c, FENCE) == [] and download(h, c, RALLY) == []


BAD = [
    (item(1, 31000), mavlink.MAV_MISSION_UNSUPPORTED),  # a command this stack does not fly
    (item(1, frame=mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    (mavlink.MAVLink_mission_item_int_message(1, 1, 1, REL, 16, 0, 1, 0, 0, 0, 0, 91 * 10**7, 0, 5.0, 0),
     mavlink.MAV_MISSION_INVALID_PARAM5_X),  # latitude 91
    (mavlink.MAVLink_mission_item_int_message(1, 1, 1, REL, 16, 0, 1, 0, 0, 0, 0, 0, -181 * 10**7, 5.0, 0),
     mavlink.MAV_MISSION_INVALID_PARAM6_Y),
    (item(1, z=float("nan")), mavlink.MAV_MISSION_INVALID_PARAM7),
    (item(1, z=20000.0), mavlink.MAV_MISSION_INVALID_PARAM7),  # above the ceiling
    (item(1, p=(-5.0, 0, 0, 0)), mavlink.MAV_MISSION_INVALID_PARAM1),  # negative hold time
    (item(1, mavlink.MAV_CMD_DO_CHANGE_SPEED, (1, float("nan"), -1, 0), frame=2), mavlink.MAV_MISSION_INVALID_PARAM2),
    (item(1, mavlink.MAV_CMD_DO_JUMP, (7, 1, 0, 0), frame=2), mavlink.MAV_MISSION_INVALID_PARAM1),  # no item 7
]  # fmt: skip


@pytest.mark.parametrize("bad, error", BAD, ids=[str(e) for _, e in BAD])
def test_a_bad_item_gets_its_error_and_the_stored_plan_stays(make_harness, bad, error, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    assert ack_types(upload(h, c, square(3))) == [mavlink.MAV_MISSION_ACCEPTED]
    plan = [square(3)[0], bad, square(3)[2]]
    got = upload(h, c, plan)
    assert ack_types(got) == [error]
    text = "".join(t.text for t in of_type(got, "STATUSTEXT"))  # chunks of one long STATUSTEXT
    assert "upload refused" in text, text
    assert [m.x for m in download(h, c)] == [m.x for m in square(3)]  # the earlier plan, whole


def test_the_ceiling_is_gf_max_ver_dist(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    h.vehicle.plans.params.set("GF_MAX_VER_DIST", 50.0)
    assert ack_types(upload(h, c, [item(0, z=60.0)])) == [mavlink.MAV_MISSION_INVALID_PARAM7]
    assert ack_types(upload(h, c, [item(0, z=40.0)])) == [mavlink.MAV_MISSION_ACCEPTED]


def test_a_broken_fence_polygon_is_refused(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    three_of_four = [item(k, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, (4, 0, 0, 0), k, k * k, 0.0,
                          mavlink.MAV_FRAME_GLOBAL_INT, FENCE) for k in range(3)]  # fmt: skip
    assert ack_types(upload(h, c, three_of_four, FENCE)) == [mavlink.MAV_MISSION_INVALID]
    assert download(h, c, FENCE) == []


def test_mavsdks_polygon_and_zero_circle_is_stored_and_broken_circles_and_polygons_refused(make_harness, inst):
    """Issue 36: MAVSDK's GeofenceData sends polygons and circles together, a circle of radius 0 at (0, 0) for
    none: stored as PX4 stores it, the circle said to be ignored.  A negative radius, a polygon of two vertices:
    refused, each with its MAV_MISSION error and a STATUSTEXT, the stored fence unchanged."""
    h = make_harness(inst)
    c = h.connect("gcs")
    g, vertex = mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    corners = [(-50, -50), (50, -50), (50, 50), (-50, 50)]
    fence = [item(k, vertex, (4, 0, 0, 0), n, e, 0.0, g, FENCE) for k, (n, e) in enumerate(corners)]

    def circle(seq: int, radius: float):
        return mavlink.MAVLink_mission_item_int_message(
            1, 1, seq, g, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 0, 1, radius, 0, 0, 0, 0, 0, 0.0, FENCE
        )

    got = upload(h, c, [*fence, circle(4, 0.0)], FENCE)
    assert ack_types(got) == [mavlink.MAV_MISSION_ACCEPTED]
    texts = [t.text for t in of_type(got, "STATUSTEXT")]
    assert "Fence item 4: circle of radius 0 ignored" in texts and "Fence plan: 5 items stored" in texts
    stored = download(h, c, FENCE)[4]  # stored as sent
    assert (stored.command, stored.param1, stored.x, stored.y) == (mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 0, 0, 0)
    two = [item(k, vertex, (2, 0, 0, 0), k, k, 0.0, g, FENCE) for k in range(2)]
    for bad, error in (([*fence, circle(4, -1.0)], mavlink.MAV_MISSION_INVALID_PARAM1),
                       (two, mavlink.MAV_MISSION_INVALID_PARAM1)):  # fmt: skip
        got = upload(h, c, bad, FENCE)
        assert ack_types(got) == [error]
        assert "Fence upload refused" in "".join(t.text for t in of_type(got, "STATUSTEXT"))
        assert len(download(h, c, FENCE)) == 5


def test_legacy_mission_item_upload_is_answered_with_mission_request(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")

    def as_float(req):
        m = square(3)[req.seq]
        return mavlink.MAVLink_mission_item_message(1, 1, m.seq, m.frame, m.command, 0, 1, m.param1, m.param2,
                                                    m.param3, m.param4, m.x / 1e7, m.y / 1e7, m.z, 0)  # fmt: skip

    got = upload(h, c, square(3), answer=as_float)
    assert ack_types(got) == [mavlink.MAV_MISSION_ACCEPTED]
    assert [m.seq for m in of_type(got, "MISSION_REQUEST")] == [1, 2]  # after the first float item
    # MISSION_ITEM carries float32 degrees: within 5e-6 deg (0.5 m) of what was meant
    assert [m.x for m in download(h, c)] == pytest.approx([m.x for m in square(3)], abs=50)


def test_a_second_client_is_denied_mid_upload_and_the_first_completes(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    other = h.connect("api")
    c.mav.mission_count_send(1, 1, 3, MISSION)
    first = h.pump(0.02, until=lambda m: m.get_type() == "MISSION_REQUEST_INT")
    assert of_type(first["gcs"], "MISSION_REQUEST_INT")
    other.mav.mission_count_send(1, 1, 2, MISSION)
    got = h.pump(0.05)
    assert ack_types(got["api"]) == [mavlink.MAV_MISSION_DENIED]
    assert ack_types(upload(h, c, square(3))) == [mavlink.MAV_MISSION_ACCEPTED]


def test_a_lost_item_is_requested_again_and_a_stalled_upload_ends(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    assert ack_types(upload(h, c, square(2))) == [mavlink.MAV_MISSION_ACCEPTED]
    now = [1000.0]
    h.link._missions.clock = lambda: now[0]  # the protocol's wall clock, advanced by hand
    dropped = []

    def drop_first_answer_to_seq1(req):
        if req.seq == 1 and not dropped:
            dropped.append(req.seq)
            now[0] += mission_protocol.RETRY_S + 0.01  # nothing arrives for longer than the retry time
            return None
        return square(3)[req.seq]

    got = upload(h, c, square(3), answer=drop_first_answer_to_seq1)
    assert ack_types(got) == [mavlink.MAV_MISSION_ACCEPTED]
    assert [m.seq for m in of_type(got, "MISSION_REQUEST_INT")].count(1) == 2  # asked again
    # a client that goes silent: the upload ends with OPERATION_CANCELLED, the stored plan stays
    c.mav.mission_count_send(1, 1, 5, MISSION)
    seen = []
    for _ in range(mission_protocol.MAX_RETRIES + 2):
        seen += h.pump(0.02)["gcs"]
        now[0] += mission_protocol.RETRY_S + 0.01
    seen += h.pump(0.02)["gcs"]
    assert len(of_type(seen, "MISSION_REQUEST_INT")) == mission_protocol.MAX_RETRIES + 1
    assert ack_types(seen) == [mavlink.MAV_MISSION_OPERATION_CANCELLED]
    assert len(download(h, c)) == 3


def test_set_current_answers_with_mission_current(make_harness, inst):
    h = make_harness(inst)
    c = h.connect("gcs")
    upload(h, c, square(4))
    c.mav.mission_set_current_send(1, 1, 2)
    cur = of_type(h.pump(0.05, until=lambda m: m.get_type() == "MISSION_CURRENT")["gcs"], "MISSION_CURRENT")
    assert cur[-1].seq == 2 and cur[-1].total == 4
    c.mav.mission_set_current_send(1, 1, 9)
    got = h.pump(0.05)["gcs"]
    assert "does not exist" in "".join(t.text for t in of_type(got, "STATUSTEXT"))
    assert h.vehicle.plans.current == 2


def test_poll_answers_between_updates_without_streaming(make_harness, inst):
    """The lockstep loop calls poll() on the steps between link updates: requests are answered there,
    one upload item per call, and nothing is streamed."""
    h = make_harness(inst)
    c = h.connect("gcs")
    items = square(3)
    c.mav.mission_count_send(1, 1, len(items), MISSION)
    got = []
    for _ in range(200):
        h.t_us += 4000
        h.link.poll(h.t_us)
        while (m := c.recv_match(blocking=True, timeout=0.01)) is not None:
            got.append(m)
            if m.get_type() == "MISSION_REQUEST_INT":
                c.mav.send(items[m.seq])
        if of_type(got, "MISSION_ACK"):
            break
    assert ack_types(got) == [mavlink.MAV_MISSION_ACCEPTED]
    assert [m.seq for m in of_type(got, "MISSION_REQUEST_INT")] == [0, 1, 2]
    assert not of_type(got, "ATTITUDE") and not of_type(got, "HEARTBEAT")  # streams wait for update()
