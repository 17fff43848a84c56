"""Mission plan files (gcs.mission_files), without a vehicle: QGroundControl's .plan and QGC WPL 110.

Round trips of both formats, the DO_JUMP numbering of each, files in the shape QGroundControl and
MAVProxy write them, and every broken-file error naming its line or field.
"""

from __future__ import annotations

import json
import math

import pytest

from gcs.mission_files import (
    Plan,
    PlanFileError,
    format_qgc_plan,
    format_wpl,
    parse_qgc_plan,
    parse_wpl,
    read_plan_file,
    write_plan_file,
)
from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem

HOME = (47.3977418, 8.5455939, 488.1)
REL = mi.FRAME_GLOBAL_RELATIVE_ALT


def e7(deg: float) -> int:
    return round(deg * 1e7)


def mission() -> list[MissionItem]:
    """Takeoff, two waypoints with a speed change between them, a jump back to the first one, land."""
    return [
        MissionItem(0, REL, mi.NAV_TAKEOFF, 0, 0, 0, 90, e7(47.3977418), e7(8.5455939), 15.0),
        MissionItem(1, REL, mi.NAV_WAYPOINT, 2, 0, 0, 0, e7(47.3985123), e7(8.5461234), 25.5),
        MissionItem(2, mi.FRAME_MISSION, mi.DO_CHANGE_SPEED, 1, 8.5, -1, 0),
        MissionItem(3, REL, mi.NAV_WAYPOINT, 0, 1.5, 0, 0, e7(47.3990001), e7(8.5449999), 30.0),
        MissionItem(4, mi.FRAME_MISSION, mi.DO_JUMP, 1, 2, 0, 0),
        MissionItem(5, REL, mi.NAV_LAND, 0, 0, 0, 0, e7(47.3977418), e7(8.5455939), 0.0),
    ]


def fence_item(seq: int, command: int, param1: float, lat: float, lon: float) -> MissionItem:
    return MissionItem(seq, mi.FRAME_GLOBAL, command, param1, x=e7(lat), y=e7(lon), mission_type=mi.FENCE)


def full_plan() -> Plan:
    inc, exc = mi.FENCE_POLYGON_INCLUSION, mi.FENCE_POLYGON_EXCLUSION
    inclusion = [(47.4000, 8.5400), (47.4000, 8.5500), (47.3950, 8.5500), (47.3950, 8.5400)]
    exclusion = [(47.3980, 8.5430), (47.3982, 8.5433), (47.3979, 8.5436)]
    fence = [fence_item(k, inc, 4, *v) for k, v in enumerate(inclusion)]
    fence += [fence_item(4 + k, exc, 3, *v) for k, v in enumerate(exclusion)]
    fence.append(fence_item(7, mi.FENCE_CIRCLE_EXCLUSION, 12.5, 47.3970, 8.5470))
    rally = [
        MissionItem(k, REL, mi.RALLY_POINT, x=e7(lat), y=e7(lon), z=alt, mission_type=mi.RALLY)
        for k, (lat, lon, alt) in enumerate([(47.3981, 8.5441, 20.0), (47.3969, 8.5472, 25.0)])
    ]
    return Plan(mission(), fence, rally, HOME)


# --------------------------------------------------------------------------- .plan


def test_plan_round_trip(tmp_path):
    plan = full_plan()
    assert parse_qgc_plan(format_qgc_plan(plan)) == plan
    write_plan_file(tmp_path / "flight.plan", plan)
    assert read_plan_file(tmp_path / "flight.plan") == plan
    assert read_plan_file(tmp_path / "flight.plan").fence[7].param1 == 12.5


def test_plan_round_trip_without_home_fence_or_rally():
    plan = Plan(mission())
    assert parse_qgc_plan(format_qgc_plan(plan)) == plan


def test_plan_is_written_in_qgroundcontrol_shape():
    doc = json.loads(format_qgc_plan(full_plan()))
    assert (doc["fileType"], doc["version"], doc["groundStation"]) == ("Plan", 1, "QGroundControl")
    m = doc["mission"]
    assert (m["version"], m["firmwareType"], m["vehicleType"]) == (2, 12, 2)
    assert m["plannedHomePosition"] == list(HOME)
    takeoff, speed, jump = m["items"][0], m["items"][2], m["items"][4]
    assert takeoff["params"] == [0, 0, 0, 90, 47.3977418, 8.5455939, 15]
    assert (takeoff["Altitude"], takeoff["AltitudeMode"], takeoff["AMSLAltAboveTerrain"]) == (15, 1, None)
    assert "Altitude" not in speed and speed["params"] == [1, 8.5, -1, 0, 0, 0, 0]
    assert [item["doJumpId"] for item in m["items"]] == [1, 2, 3, 4, 5, 6]
    assert jump["params"][0] == 2  # the doJumpId of mission item 1
    fence = doc["geoFence"]
    assert [(p["inclusion"], len(p["polygon"])) for p in fence["polygons"]] == [(True, 4), (False, 3)]
    circle = {"center": [47.397, 8.547], "radius": 12.5}
    assert fence["circles"] == [{"circle": circle, "inclusion": False, "version": 1}]
    assert doc["rallyPoints"] == {"points": [[47.3981, 8.5441, 20], [47.3969, 8.5472, 25]], "version": 2}


def test_nan_params_are_written_as_null_and_read_back_as_nan():
    plan = Plan([MissionItem(0, REL, mi.NAV_WAYPOINT, 0, 0, 0, math.nan, e7(47.4), e7(8.5), 10.0)])
    doc = json.loads(format_qgc_plan(plan))
    assert doc["mission"]["items"][0]["params"][3] is None
    assert math.isnan(parse_qgc_plan(json.dumps(doc)).mission[0].param4)


def test_do_jump_target_is_converted_from_do_jump_id_to_seq():
    doc = json.loads(format_qgc_plan(Plan(mission())))
    for item, jump_id in zip(doc["mission"]["items"], (1, 2, 7, 8, 9, 10)):  # ids need not be consecutive
        item["doJumpId"] = jump_id
    doc["mission"]["items"][4]["params"][0] = 8  # jump to the third item (doJumpId 8)
    assert parse_qgc_plan(json.dumps(doc)).mission[4].param1 == 3.0


# A file as QGroundControl (4.x, PX4 multicopter) saves it: keys sorted, each item with its doJumpId.
QGC_PLAN = """{
    "fileType": "Plan",
    "geoFence": {
        "circles": [{"circle": {"center": [47.39752, 8.54498], "radius": 30}, "inclusion": false, "version": 1}],
        "polygons": [
            {
                "inclusion": true,
                "polygon": [[47.3992, 8.5432], [47.3992, 8.5481], [47.3961, 8.5481], [47.3961, 8.5432]],
                "version": 1
            }
        ],
        "version": 2
    },
    "groundStation": "QGroundControl",
    "mission": {
        "cruiseSpeed": 15,
        "firmwareType": 12,
        "globalPlanAltitudeMode": 1,
        "hoverSpeed": 5,
        "items": [
            {"AMSLAltAboveTerrain": null, "Altitude": 15, "AltitudeMode": 1, "autoContinue": true, "command": 22,
             "doJumpId": 1, "frame": 3, "params": [0, 0, 0, null, 47.3977419, 8.5455938, 15], "type": "SimpleItem"},
            {"AMSLAltAboveTerrain": null, "Altitude": 20, "AltitudeMode": 1, "autoContinue": true, "command": 16,
             "doJumpId": 2, "frame": 3, "params": [0, 0, 0, null, 47.3983542, 8.5462077, 20], "type": "SimpleItem"},
            {"autoContinue": true, "command": 178, "doJumpId": 3, "frame": 2, "params": [1, 6, -1, 0, 0, 0, 0],
             "type": "SimpleItem"},
            {"AMSLAltAboveTerrain": null, "Altitude": 510, "AltitudeMode": 2, "autoContinue": true, "command": 16,
             "doJumpId": 4, "frame": 0, "params": [2, 0, 0, null, 47.3987156, 8.5449343, 510],
             "type": "SimpleItem"},
            {"autoContinue": true, "command": 177, "doJumpId": 5, "frame": 2, "params": [2, 1, 0, 0, 0, 0, 0],
             "type": "SimpleItem"},
            {"autoContinue": true, "command": 20, "doJumpId": 6, "frame": 2, "params": [0, 0, 0, 0, 0, 0, 0],
             "type": "SimpleItem"}
        ],
        "plannedHomePosition": [47.3977419, 8.5455938, 488.1],
        "vehicleType": 2,
        "version": 2
    },
    "rallyPoints": {"points": [[47.3979, 8.5441, 20], [47.3969, 8.5471, 25.5]], "version": 2},
    "version": 1
}
"""


def test_reads_a_file_written_by_qgroundcontrol():
    plan = parse_qgc_plan(QGC_PLAN)
    assert plan.home == (47.3977419, 8.5455938, 488.1)
    assert [i.command for i in plan.mission] == [22, 16, 178, 16, 177, 20]
    assert [i.seq for i in plan.mission] == [0, 1, 2, 3, 4, 5]
    takeoff, wp, speed, amsl, jump, _ = plan.mission
    assert (takeoff.x, takeoff.y, takeoff.z, takeoff.frame) == (473977419, 85455938, 15.0, REL)
    assert math.isnan(wp.param4) and wp.autocontinue == 1 and wp.mission_type == mi.MISSION
    assert speed.params == (1.0, 6.0, -1.0, 0.0) and (speed.x, speed.y) == (0, 0)
    assert (amsl.frame, amsl.z, amsl.param1) == (mi.FRAME_GLOBAL, 510.0, 2.0)
    assert (jump.param1, jump.param2) == (1.0, 1.0)  # doJumpId 2 is mission item 1
    assert [(i.seq, i.command, i.param1) for i in plan.fence] == [(k, 5001, 4.0) for k in range(4)] + [(4, 5004, 30.0)]
    assert (plan.fence[1].x, plan.fence[1].y, plan.fence[1].frame) == (473992000, 85481000, mi.FRAME_GLOBAL)
    assert {i.mission_type for i in plan.fence} == {mi.FENCE}
    assert [(i.seq, i.command, i.frame, i.mission_type, i.z) for i in plan.rally] == [
        (0, mi.RALLY_POINT, REL, mi.RALLY, 20.0),
        (1, mi.RALLY_POINT, REL, mi.RALLY, 25.5),
    ]
    assert parse_qgc_plan(format_qgc_plan(plan)).mission[4] == jump


def test_missing_fence_and_rally_sections_are_empty():
    doc = json.loads(QGC_PLAN)
    del doc["geoFence"], doc["rallyPoints"], doc["mission"]["plannedHomePosition"]
    plan = parse_qgc_plan(json.dumps(doc))
    assert (plan.fence, plan.rally, plan.home, len(plan.mission)) == ([], [], None, 6)


DELETE = object()


def _set(path: str, value):
    """A change to the QGroundControl file: ``value`` at the dotted ``path`` (DELETE: remove the key)."""

    def change(doc):
        *parents, last = path.split(".")
        for key in parents:
            doc = doc[int(key)] if isinstance(doc, list) else doc[key]
        if value is DELETE:
            del doc[last]
        elif isinstance(doc, list):
            doc[int(last)] = value
        else:
            doc[last] = value

    return change


@pytest.mark.parametrize(
    "change, field, words",
    [
        (_set("fileType", DELETE), "fileType", "missing"),
        (_set("fileType", "GeoFence"), "fileType", "not 'Plan'"),
        (_set("mission.items", DELETE), "mission.items", "missing"),
        (_set("mission.items.1.params.4", "47.39"), "mission.items[1].params[4]", "must be a number"),
        (_set("mission.items.2.params.0", True), "mission.items[2].params[0]", "must be a number"),
        (_set("mission.items.1.params", [0, 0, 0, 0, 47.4, 8.5]), "mission.items[1].params", "7 numbers, not 6"),
        (_set("mission.items.1.params.4", 90.5), "mission.items[1].params[4]", "latitude 90.5 is outside [-90, 90]"),
        (_set("mission.items.3.params.5", -180.01), "mission.items[3].params[5]", "outside [-180, 180]"),
        (_set("mission.items.0.params.4", None), "mission.items[0].params[4]", "latitude must be a finite"),
        (_set("mission.items.1.command", "16"), "mission.items[1].command", "must be an integer"),
        (_set("mission.items.4.params.0", 9), "mission.items[4].params[0]", "DO_JUMP target 9"),
        (_set("mission.items.3.doJumpId", 2), "mission.items[3].doJumpId", "also mission.items[1]"),
        (_set("mission.plannedHomePosition.0", 91), "mission.plannedHomePosition[0]", "outside [-90, 90]"),
        (_set("geoFence.polygons.0.polygon", [[47.39, 8.54], [47.4, 8.55]]), "geoFence.polygons[0].polygon", "3 vert"),
        (_set("geoFence.polygons.0.polygon.2", [47.39]), "geoFence.polygons[0].polygon[2]", "list of 2 numbers"),
        (_set("geoFence.polygons.0.inclusion", 1), "geoFence.polygons[0].inclusion", "true or false"),
        (_set("geoFence.circles.0.circle.radius", -1), "geoFence.circles[0].circle.radius", "0 or more"),
        (_set("geoFence.circles.0.circle.radius", None), "geoFence.circles[0].circle.radius", "must be a number"),
        (_set("rallyPoints.points.1.1", 200), "rallyPoints.points[1][1]", "longitude 200"),
        (_set("mission.version", 1), "mission.version", "not supported"),
    ],
)
def test_broken_plan_names_the_json_path(change, field, words):
    doc = json.loads(QGC_PLAN)
    change(doc)
    with pytest.raises(PlanFileError) as err:
        parse_qgc_plan(json.dumps(doc), "mission.plan")
    assert (err.value.path, err.value.line, err.value.field) == ("mission.plan", None, field)
    assert str(err.value).startswith(f"mission.plan: {field}: ")
    assert words in err.value.message


def test_complex_item_is_refused_with_its_index():
    doc = json.loads(QGC_PLAN)
    doc["mission"]["items"][2] = {"type": "ComplexItem", "complexItemType": "survey", "version": 5}
    with pytest.raises(PlanFileError, match=r"mission.items\[2\]: complex item 'survey' is not supported: convert"):
        parse_qgc_plan(json.dumps(doc))


def test_json_syntax_error_names_the_line(tmp_path):
    path = tmp_path / "broken.plan"
    path.write_text('{\n    "fileType": "Plan",\n    "version": 1\n    "mission": {}\n}\n')
    with pytest.raises(PlanFileError) as err:
        read_plan_file(path)
    assert err.value.line == 4
    assert str(err.value).startswith(f"{path}:4: json: Expecting ',' delimiter")


def test_top_level_must_be_an_object():
    with pytest.raises(PlanFileError, match="must be an object, not a list"):
        parse_qgc_plan("[1, 2]")


# --------------------------------------------------------------------------- QGC WPL 110


def test_wpl_round_trip(tmp_path):
    plan = Plan(mission(), home=HOME)
    assert parse_wpl(format_wpl(plan)) == plan
    for name in ("a.waypoints", "b.txt", "c.WPL"):
        write_plan_file(tmp_path / name, plan)
        assert read_plan_file(tmp_path / name) == plan
    assert parse_wpl(format_wpl(Plan(mission()))) == Plan(mission())  # unknown home: a zero home line


def test_wpl_is_written_with_the_home_line_first():
    lines = format_wpl(Plan(mission(), home=HOME)).splitlines()
    assert lines[0] == "QGC WPL 110"
    assert lines[1].split("\t") == ["0", "1", "0", "16", "0", "0", "0", "0", "47.3977418", "8.5455939", "488.1", "1"]
    assert [line.split("\t")[0] for line in lines[2:]] == ["1", "2", "3", "4", "5", "6"]
    takeoff, jump = lines[2].split("\t"), lines[6].split("\t")
    assert takeoff[2:4] == ["3", "22"] and takeoff[8:11] == ["47.39774180", "8.54559390", "15.0"]
    assert jump[3:5] == ["177", "2.0"]  # the file seq of mission item 1


# As MAVProxy's ``wp save`` writes it: the home line (seq 0, current 1), then the items.
MAVPROXY_WPL = """QGC WPL 110
0\t1\t0\t16\t0.000000\t0.000000\t0.000000\t0.000000\t-35.3632621\t149.1652374\t584.090000\t1
1\t0\t3\t22\t0.000000\t0.000000\t0.000000\t0.000000\t-35.3632621\t149.1652374\t20.000000\t1
2\t0\t3\t16\t0.000000\t0.000000\t0.000000\t0.000000\t-35.3620000\t149.1650000\t30.000000\t1
3\t0\t3\t178\t1.000000\t5.000000\t-1.000000\t0.000000\t0.000000\t0.000000\t0.000000\t1
4\t0\t3\t16\t0.000000\t0.000000\t0.000000\t0.000000\t-35.3610000\t149.1660000\t30.000000\t1
5\t0\t3\t177\t2.000000\t1.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t1
6\t0\t3\t20\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t1
"""


def test_reads_mavproxy_file_with_home_line():
    plan = parse_wpl(MAVPROXY_WPL)
    assert plan.home == (-35.3632621, 149.1652374, 584.09)
    assert [(i.seq, i.command) for i in plan.mission] == [(0, 22), (1, 16), (2, 178), (3, 16), (4, 177), (5, 20)]
    assert (plan.mission[1].x, plan.mission[1].y, plan.mission[1].z) == (-353620000, 1491650000, 30.0)
    assert plan.mission[2].params == (1.0, 5.0, -1.0, 0.0)
    assert plan.mission[4].param1 == 1.0  # line seq 2 is mission item 1
    assert (plan.fence, plan.rally) == ([], [])


def test_wpl_without_home_line_is_all_mission():
    text = "QGC WPL 110\n" + "\n".join(
        ["0 0 3 22 0 0 0 0 -35.36 149.16 20 1", "1 0 3 16 0 0 0 0 -35.37 149.17 25 1", "2 0 2 177 0 3 0 0 0 0 0 1"]
    )
    plan = parse_wpl(text)
    assert plan.home is None
    assert [(i.seq, i.command) for i in plan.mission] == [(0, 22), (1, 16), (2, 177)]
    assert plan.mission[2].param1 == 0.0  # no home line: the file seq is the mission seq


def test_wpl_reading_accepts_any_whitespace_and_blank_lines():
    text = MAVPROXY_WPL.replace("\t", "  ").replace("\n", "\n\n", 3)
    assert parse_wpl("\n" + text) == parse_wpl(MAVPROXY_WPL)


BAD_WPL = [
    ("QGC WPL 120\n0 1 0 16 0 0 0 0 0 0 0 1\n", 1, "header", 'first line must be "QGC WPL 110"'),
    ("\n0 1 0 16 0 0 0 0 0 0 0 1\n", 2, "header", 'first line must be "QGC WPL 110"'),
    ("QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0 0 47.4 8.5 20\n", 3, "columns", "expected 12"),
    ("QGC WPL 110\nzero 1 0 16 0 0 0 0 0 0 0 1\n", 2, "seq", "'zero' is not an integer"),
    ("QGC WPL 110\n0 1 0.5 16 0 0 0 0 0 0 0 1\n", 2, "frame", "'0.5' is not an integer"),
    ("QGC WPL 110\n0 1 0 WAYPOINT 0 0 0 0 0 0 0 1\n", 2, "command", "not an integer"),
    ("QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 abc 0 0 47.4 8.5 20 1\n", 3, "param2", "'abc' is not a number"),
    ("QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n2 0 3 16 0 0 0 0 47.4 8.5 20 1\n", 3, "seq", "expected 1"),
    ("QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0 0 95 8.5 20 1\n", 3, "x (latitude)", "outside [-90, 90]"),
    ("QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0 0 47 nan 20 1\n", 3, "y (longitude)", "finite"),
    ("QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 2 177 0 1 0 0 0 0 0 1\n", 3, "param1", "DO_JUMP target 0"),
]


@pytest.mark.parametrize("text, line, field, words", BAD_WPL)
def test_broken_wpl_names_line_and_column(tmp_path, text, line, field, words):
    path = tmp_path / "bad.waypoints"
    path.write_text(text)
    with pytest.raises(PlanFileError) as err:
        read_plan_file(path)
    assert (err.value.line, err.value.field) == (line, field)
    assert str(err.value).startswith(f"{path}:{line}: {field}: ")
    assert words in err.value.message


# --------------------------------------------------------------------------- files


def test_format_is_told_by_content_not_suffix(tmp_path):
    (tmp_path / "plan.txt").write_text(QGC_PLAN)
    (tmp_path / "mission.plan").write_text(MAVPROXY_WPL)
    assert read_plan_file(tmp_path / "plan.txt") == parse_qgc_plan(QGC_PLAN)
    assert read_plan_file(tmp_path / "mission.plan") == parse_wpl(MAVPROXY_WPL)


@pytest.mark.parametrize("part", ["fence", "rally"])
def test_wpl_refuses_fence_and_rally_points(tmp_path, part):
    plan = full_plan()
    setattr(plan, "rally" if part == "fence" else "fence", [])
    path = tmp_path / "mission.waypoints"
    with pytest.raises(PlanFileError, match=r"save to a \.plan file") as err:
        write_plan_file(path, plan)
    assert (err.value.path, err.value.field) == (str(path), part)
    assert not path.exists()


def test_unknown_suffix_is_refused(tmp_path):
    with pytest.raises(PlanFileError, match=r"'\.json': use \.plan") as err:
        write_plan_file(tmp_path / "mission.json", full_plan())
    assert err.value.field == "suffix"


def test_fence_polygon_with_a_wrong_vertex_count_is_not_written():
    plan = full_plan()
    plan.fence = plan.fence[:3] + plan.fence[4:]  # the inclusion polygon lost a vertex, still says 4
    with pytest.raises(PlanFileError, match=r"fence\[0\]: vertex count \(param1\) 4 does not match"):
        format_qgc_plan(plan)


def test_error_message_shape():
    err = PlanFileError("m.waypoints", 7, "x (latitude)", "95 is outside [-90, 90]")
    assert str(err) == "m.waypoints:7: x (latitude): 95 is outside [-90, 90]"
    assert isinstance(err, ValueError)
    err = PlanFileError("m.plan", None, "mission.items[3].params[4]", "bad")
    assert str(err) == "m.plan: mission.items[3].params[4]: bad"
