"""Mission plan files: QGroundControl's ``.plan`` (JSON) and the ``QGC WPL 110`` text format.

A :class:`Plan` is what a vehicle holds: the mission, the geofence and the rally points, each a list
of :class:`~mavsim_core.mission_items.MissionItem` (MISSION_ITEM_INT: ``x``/``y`` latitude/longitude
in degE7, ``z`` altitude in metres, AMSL for ``FRAME_GLOBAL``, above home for
``FRAME_GLOBAL_RELATIVE_ALT``), numbered from 0, plus the planned home (latitude and longitude in
degrees, altitude in metres AMSL).  Files carry latitude and longitude in degrees.

* ``.plan`` (QGroundControl, JSON): ``mission.items`` are SimpleItems, ``params`` the seven
  parameters (``null`` is NaN; 5-7 latitude, longitude, altitude).  A DO_JUMP's first parameter is
  the target's ``doJumpId`` (1-based) in the file, the target's 0-based ``seq`` in a Plan.
  ``geoFence`` holds polygons (one vertex item per vertex, param1 the vertex count) and circles
  (param1 the radius in metres), ``rallyPoints`` latitude, longitude and altitude above home.
  Complex items (surveys, corridor scans) are refused: convert them to waypoints in QGroundControl.
* ``QGC WPL 110`` (MAVProxy's ``wp save``, QGroundControl's export): the header line, then one
  item a line, ``seq current frame command param1..param4 x(lat deg) y(lon deg) z(alt m)
  autocontinue``.  A first line with seq 0, NAV_WAYPOINT and current 1 is the planned home; the
  other lines are the mission, renumbered from 0 (a DO_JUMP's param1 is the target's line seq in
  the file).  The mission only: no fence, no rally points.

An all-zero planned home (what the writers write for ``home=None``) reads back as None.  Errors
are :class:`PlanFileError`, which names the file, the line (WPL, JSON syntax) and the field (a
column name, or a JSON path such as ``mission.items[3].params[4]``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NoReturn

from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem

PLAN_SUFFIXES = (".plan",)
WPL_SUFFIXES = (".waypoints", ".txt", ".wpl")
WPL_HEADER = "QGC WPL 110"
WPL_COLUMNS = (
    "seq", "current", "frame", "command", "param1", "param2", "param3", "param4",
    "x (latitude)", "y (longitude)", "z (altitude)", "autocontinue",
)  # fmt: skip
WPL_INT_COLUMNS = frozenset({0, 1, 2, 3, 11})  # seq, current, frame, command, autocontinue
FIRMWARE_PX4, VEHICLE_MULTIROTOR = 12, 2  # MAV_AUTOPILOT_PX4, MAV_TYPE_QUADROTOR
CRUISE_SPEED_M_S, HOVER_SPEED_M_S = 15, 5  # QGroundControl's defaults (a Plan carries no speeds)
ALTITUDE_MODES = {**dict.fromkeys(mi.RELATIVE_FRAMES, 1), **dict.fromkeys(mi.GLOBAL_FRAMES, 2)}  # QGC AltitudeMode
POLYGON_COMMANDS = {True: mi.FENCE_POLYGON_INCLUSION, False: mi.FENCE_POLYGON_EXCLUSION}
CIRCLE_COMMANDS = {True: mi.FENCE_CIRCLE_INCLUSION, False: mi.FENCE_CIRCLE_EXCLUSION}
_KINDS = {
    dict: "an object", list: "a list", bool: "true or false", int: "an integer", float: "a number", str: "a string",
    type(None): "null",
}  # fmt: skip


@dataclass
class Plan:
    """A vehicle's three plans and its planned home (lat deg, lon deg, alt m AMSL), or None."""

    mission: list[MissionItem] = field(default_factory=list)  # mission_type 0, seq 0..n-1
    fence: list[MissionItem] = field(default_factory=list)  # mission_type 1
    rally: list[MissionItem] = field(default_factory=list)  # mission_type 2
    home: tuple[float, float, float] | None = None


class PlanFileError(ValueError):
    """A broken plan file: str() is 'PATH:LINE: FIELD: what is wrong' (LINE omitted when unknown;
    in a .plan FIELD is the JSON path, e.g. 'mission.items[3].params[4]')."""

    def __init__(self, path: str | Path, line: int | None, field: str, message: str) -> None:
        self.path, self.line, self.field, self.message = str(path), line, field, message
        where = self.path if line is None else f"{self.path}:{line}"
        super().__init__(f"{where}: {field}: {message}" if field else f"{where}: {message}")


def _fail(name: str, where: str, message: str, line: int | None = None) -> NoReturn:
    raise PlanFileError(name, line, where, message)


def read_plan_file(path: str | Path) -> Plan:
    """Read a plan file, either format, told apart by its content (OSError when it cannot be read).

    A first line "QGC WPL ..." is WPL, "{" JSON; anything else is read as its suffix says (JSON for ``.plan``)."""
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise PlanFileError(p, None, "", f"not a text file ({e.reason})") from None
    first = next((line.strip() for line in text.splitlines() if line.strip()), "")
    if first.startswith("QGC WPL") or (not first.startswith(("{", "[")) and p.suffix.lower() in WPL_SUFFIXES):
        return parse_wpl(text, str(p))
    return parse_qgc_plan(text, str(p))


def write_plan_file(path: str | Path, plan: Plan) -> None:
    """Write ``plan``: ``.plan`` as QGroundControl JSON, ``.waypoints``/``.txt``/``.wpl`` as QGC WPL 110."""
    p = Path(path)
    writer = {**dict.fromkeys(PLAN_SUFFIXES, format_qgc_plan), **dict.fromkeys(WPL_SUFFIXES, format_wpl)}
    try:
        if (write := writer.get(p.suffix.lower())) is None:
            _fail(str(p), "suffix", f"{p.suffix!r}: use .plan (QGroundControl) or .waypoints (QGC WPL 110)")
        text = write(plan)
    except PlanFileError as e:
        raise PlanFileError(p, e.line, e.field, e.message) from None
    p.write_text(text, encoding="utf-8")


def _scaled(value: float, axis: str, command: int, frame: int, name: str, where: str, line: int | None) -> int:
    """x or y of an item (``axis`` 'x' or 'y') from degrees (metres in a local frame), checked."""
    scale = 1e4 if frame == mi.FRAME_LOCAL_NED else mi.DEG_E7
    what, limit = ("latitude", 90.0) if axis == "x" else ("longitude", 180.0)
    position = command in mi.POSITION_COMMANDS
    if not math.isfinite(value):
        if position:
            _fail(name, where, f"{what} must be a finite number on a position command ({command})", line)
        return 0
    if position and frame != mi.FRAME_LOCAL_NED and abs(value) > limit:
        _fail(name, where, f"{what} {value!r} is outside [-{limit:g}, {limit:g}]", line)
    if abs(value * scale) >= 2**31:
        _fail(name, where, f"{value!r} does not fit a MISSION_ITEM_INT", line)
    return round(value * scale)


def _altitude(value: float, command: int, name: str, where: str, line: int | None) -> float:
    if command in mi.POSITION_COMMANDS and not math.isfinite(value):
        _fail(name, where, f"altitude must be a finite number on a position command ({command})", line)
    return value


def _unscaled(value: int, frame: int) -> float:
    return value / (1e4 if frame == mi.FRAME_LOCAL_NED else mi.DEG_E7)


def _member(obj: dict, key: str, where: str, name: str, kind: type, default: Any = ...) -> Any:
    """``obj[key]`` of type ``kind``; ``default`` when missing or null (if given), else an error."""
    path = f"{where}.{key}" if where else key
    value = obj.get(key)
    if value is None:
        if default is ...:
            _fail(name, path, f"missing ({_KINDS[kind]})" if key not in obj else f"must be {_KINDS[kind]}, not null")
        return default
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        _fail(name, path, f"must be {_KINDS[kind]}, not {_KINDS[type(value)]}")
    return value


def _object(value: Any, where: str, name: str) -> dict:
    if not isinstance(value, dict):
        _fail(name, where, f"must be an object, not {_KINDS[type(value)]}")
    return value


def _number(value: Any, where: str, name: str, null_ok: bool = True) -> float:
    if value is None and null_ok:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)) or isinstance(value, int) and abs(value) > 1e308:
        _fail(name, where, f"must be a number{' (or null)' if null_ok else ''}, not {_KINDS[type(value)]}")
    return float(value)


def _version(obj: dict, where: str, name: str) -> None:
    version = obj.get("version", 2)
    if version != 2:
        _fail(name, f"{where}.version", f"{version!r} is not supported (2 is)")


def _point(value: Any, size: int, command: int, where: str, name: str) -> tuple[int, int, float]:
    """A [lat, lon] (or [lat, lon, alt]) list of a fence or rally point: x, y (degE7), alt (0 if none)."""
    if not isinstance(value, list) or len(value) != size:
        _fail(name, where, f"must be a list of {size} numbers ({'lat, lon, alt' if size == 3 else 'lat, lon'})")
    lat, lon, *alt = (_number(v, f"{where}[{k}]", name, null_ok=False) for k, v in enumerate(value))
    x = _scaled(lat, "x", command, mi.FRAME_GLOBAL, name, f"{where}[0]", None)
    y = _scaled(lon, "y", command, mi.FRAME_GLOBAL, name, f"{where}[1]", None)
    return x, y, _altitude(alt[0], command, name, f"{where}[2]", None) if alt else 0.0


def parse_qgc_plan(text: str, name: str = "<plan>") -> Plan:
    """A Plan from the text of a QGroundControl ``.plan`` file."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise PlanFileError(name, e.lineno, "json", f"{e.msg} (column {e.colno})") from None
    doc = _object(doc, "(top level)", name)
    if doc.get("fileType") != "Plan":
        found = f"is {doc['fileType']!r}, not 'Plan'" if "fileType" in doc else "missing"
        _fail(name, "fileType", f"{found}: not a QGroundControl plan file")
    mission = _member(doc, "mission", "", name, dict)
    _version(mission, "mission", name)
    home = None
    if (planned := _member(mission, "plannedHomePosition", "mission", name, list, None)) is not None:
        x, y, alt = _point(planned, 3, mi.NAV_WAYPOINT, "mission.plannedHomePosition", name)
        home = (float(planned[0]), float(planned[1]), alt) if any(planned) else None  # all zeros: unknown
    return Plan(_mission_items(mission, name), _fence_items(doc, name), _rally_items(doc, name), home)


def _simple_item(entry: Any, seq: int, name: str) -> MissionItem:
    where = f"mission.items[{seq}]"
    entry = _object(entry, where, name)
    kind = _member(entry, "type", where, name, str)
    if kind == "ComplexItem":
        complex_type = entry.get("complexItemType", "?")
        _fail(name, where, f"complex item {complex_type!r} is not supported: convert it to waypoints in QGroundControl")
    if kind != "SimpleItem":
        _fail(name, f"{where}.type", f"{kind!r} is not an item type (SimpleItem)")
    command = _member(entry, "command", where, name, int)
    frame = _member(entry, "frame", where, name, int)
    params = _member(entry, "params", where, name, list)
    if len(params) != 7:
        _fail(name, f"{where}.params", f"must hold 7 numbers, not {len(params)}")
    p = [_number(v, f"{where}.params[{k}]", name) for k, v in enumerate(params)]
    x = _scaled(p[4], "x", command, frame, name, f"{where}.params[4]", None)
    y = _scaled(p[5], "y", command, frame, name, f"{where}.params[5]", None)
    z = _altitude(p[6], command, name, f"{where}.params[6]", None)
    auto = _member(entry, "autoContinue", where, name, bool, True)
    return MissionItem(seq, frame, command, p[0], p[1], p[2], p[3], x, y, z, mi.MISSION, 0, int(auto))


def _mission_items(mission: dict, name: str) -> list[MissionItem]:
    entries = _member(mission, "items", "mission", name, list)
    items = [_simple_item(entry, seq, name) for seq, entry in enumerate(entries)]
    seq_of_id: dict[int, int] = {}
    for seq, entry in enumerate(entries):
        jump_id = _member(entry, "doJumpId", f"mission.items[{seq}]", name, int, seq + 1)
        if jump_id in seq_of_id:
            _fail(name, f"mission.items[{seq}].doJumpId", f"{jump_id} is also mission.items[{seq_of_id[jump_id]}]'s")
        seq_of_id[jump_id] = seq
    for seq, item in enumerate(items):
        if item.command == mi.DO_JUMP:
            target = item.param1
            if not (target.is_integer() and int(target) in seq_of_id):
                _fail(name, f"mission.items[{seq}].params[0]", f"DO_JUMP target {target:g} is no item's doJumpId")
            items[seq] = replace(item, param1=float(seq_of_id[int(target)]))
    return items


def _fence_item(seq: int, command: int, param1: float, x: int, y: int) -> MissionItem:
    return MissionItem(seq, mi.FRAME_GLOBAL, command, param1, x=x, y=y, mission_type=mi.FENCE)


def _fence_items(doc: dict, name: str) -> list[MissionItem]:
    fence = _member(doc, "geoFence", "", name, dict, {})
    _version(fence, "geoFence", name)
    items: list[MissionItem] = []
    for i, entry in enumerate(_member(fence, "polygons", "geoFence", name, list, [])):
        where = f"geoFence.polygons[{i}]"
        entry = _object(entry, where, name)
        command = POLYGON_COMMANDS[_member(entry, "inclusion", where, name, bool)]
        vertices = _member(entry, "polygon", where, name, list)
        if len(vertices) < 3:
            _fail(name, f"{where}.polygon", f"a polygon needs at least 3 vertices, not {len(vertices)}")
        for k, vertex in enumerate(vertices):
            x, y, _ = _point(vertex, 2, command, f"{where}.polygon[{k}]", name)
            items.append(_fence_item(len(items), command, float(len(vertices)), x, y))
    for i, entry in enumerate(_member(fence, "circles", "geoFence", name, list, [])):
        where = f"geoFence.circles[{i}]"
        entry = _object(entry, where, name)
        command = CIRCLE_COMMANDS[_member(entry, "inclusion", where, name, bool)]
        circle = _member(entry, "circle", where, name, dict)
        center = _member(circle, "center", f"{where}.circle", name, list)
        x, y, _ = _point(center, 2, command, f"{where}.circle.center", name)
        radius = _number(circle.get("radius"), f"{where}.circle.radius", name, null_ok=False)
        if not (math.isfinite(radius) and radius >= 0):  # (0: a circle that encloses nothing, as PX4 stores it)
            _fail(name, f"{where}.circle.radius", f"{radius!r} is not a radius (metres, 0 or more)")
        items.append(_fence_item(len(items), command, radius, x, y))
    return items


def _rally_items(doc: dict, name: str) -> list[MissionItem]:
    rally = _member(doc, "rallyPoints", "", name, dict, {})
    _version(rally, "rallyPoints", name)
    items = []
    for i, point in enumerate(_member(rally, "points", "rallyPoints", name, list, [])):
        x, y, z = _point(point, 3, mi.RALLY_POINT, f"rallyPoints.points[{i}]", name)
        items.append(MissionItem(i, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.RALLY_POINT, x=x, y=y, z=z, mission_type=mi.RALLY))
    return items


def _json_number(value: float) -> int | float | None:
    """NaN (and infinities, which JSON lacks) as null, whole numbers without '.0' as QGroundControl writes them."""
    if not math.isfinite(value := float(value)):
        return None
    return int(value) if value.is_integer() and abs(value) < 2**53 else value


def _item_json(index: int, item: MissionItem) -> dict:
    param1 = item.param1 + 1 if item.command == mi.DO_JUMP else item.param1  # seq -> doJumpId
    params = [param1, item.param2, item.param3, item.param4]
    params += [_unscaled(item.x, item.frame), _unscaled(item.y, item.frame), item.z]
    out: dict[str, Any] = {
        "autoContinue": bool(item.autocontinue), "command": item.command, "doJumpId": index + 1,
        "frame": item.frame, "params": [_json_number(p) for p in params], "type": "SimpleItem",
    }  # fmt: skip
    if item.frame in ALTITUDE_MODES:
        out |= {"AMSLAltAboveTerrain": None, "Altitude": _json_number(item.z)}
        out["AltitudeMode"] = ALTITUDE_MODES[item.frame]
    return out


def _lat_lon(item: MissionItem) -> list:
    return [_json_number(item.lat_deg), _json_number(item.lon_deg)]


def _fence_json(fence: list[MissionItem]) -> dict:
    polygons, circles = [], []
    i = 0
    while i < len(fence):
        item = fence[i]
        if item.command in CIRCLE_COMMANDS.values():
            circle = {"center": _lat_lon(item), "radius": _json_number(item.param1)}
            circles.append({"circle": circle, "inclusion": item.command == mi.FENCE_CIRCLE_INCLUSION, "version": 1})
            i += 1
            continue
        if item.command not in POLYGON_COMMANDS.values():
            _fail("<plan>", f"fence[{i}]", f"{item.name} is not a fence command")
        n = float(item.param1)
        group = fence[i : i + int(n)] if math.isfinite(n) and n.is_integer() and n >= 3 else []
        if len(group) != n or any(g.command != item.command or g.param1 != n for g in group):
            _fail("<plan>", f"fence[{i}]", f"vertex count (param1) {n:g} does not match the {item.name} items")
        inclusion = item.command == mi.FENCE_POLYGON_INCLUSION
        polygons.append({"inclusion": inclusion, "polygon": [_lat_lon(g) for g in group], "version": 1})
        i += len(group)
    return {"circles": circles, "polygons": polygons, "version": 2}


def format_qgc_plan(plan: Plan) -> str:
    """The text of a QGroundControl ``.plan`` file holding ``plan`` (an unknown home is written as zeros)."""
    home = plan.home if plan.home is not None else (0.0, 0.0, 0.0)
    mission = {
        "cruiseSpeed": CRUISE_SPEED_M_S, "firmwareType": FIRMWARE_PX4, "hoverSpeed": HOVER_SPEED_M_S,
        "items": [_item_json(k, item) for k, item in enumerate(plan.mission)],
        "plannedHomePosition": [_json_number(v) for v in home], "vehicleType": VEHICLE_MULTIROTOR, "version": 2,
    }  # fmt: skip
    rally = {"points": [[*_lat_lon(p), _json_number(p.z)] for p in plan.rally], "version": 2}
    doc = {
        "fileType": "Plan", "geoFence": _fence_json(plan.fence), "groundStation": "QGroundControl",
        "mission": mission, "rallyPoints": rally, "version": 1,
    }  # fmt: skip
    return json.dumps(doc, indent=4, sort_keys=True, allow_nan=False) + "\n"


def _wpl_row(line: int, text: str, expected_seq: int, name: str) -> tuple[MissionItem, float, float, int]:
    """One item line: the item (seq as in the file), its latitude and longitude as written, its line number."""
    cols = text.split()
    if len(cols) != len(WPL_COLUMNS):
        _fail(name, "columns", f"expected {len(WPL_COLUMNS)} ({', '.join(WPL_COLUMNS)}), found {len(cols)}", line)
    values: list[Any] = []
    for k, col in enumerate(cols):
        try:
            values.append(int(col) if k in WPL_INT_COLUMNS else float(col))
        except ValueError:
            _fail(name, WPL_COLUMNS[k], f"{col!r} is not {'an integer' if k in WPL_INT_COLUMNS else 'a number'}", line)
    seq, current, frame, command, p1, p2, p3, p4, lat, lon, alt, autocontinue = values
    if seq != expected_seq:
        _fail(name, "seq", f"{seq} does not follow the line before: expected {expected_seq}", line)
    x = _scaled(lat, "x", command, frame, name, WPL_COLUMNS[8], line)
    y = _scaled(lon, "y", command, frame, name, WPL_COLUMNS[9], line)
    z = _altitude(alt, command, name, WPL_COLUMNS[10], line)
    return MissionItem(seq, frame, command, p1, p2, p3, p4, x, y, z, mi.MISSION, current, autocontinue), lat, lon, line


def parse_wpl(text: str, name: str = "<wpl>") -> Plan:
    """A Plan (mission and planned home) from the text of a ``QGC WPL 110`` file."""
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1) if line.strip()]
    if not lines or lines[0][1].strip() != WPL_HEADER:
        _fail(name, "header", f'first line must be "{WPL_HEADER}"', lines[0][0] if lines else 1)
    rows = [_wpl_row(n, line, k, name) for k, (n, line) in enumerate(lines[1:])]
    home, offset = None, 0  # offset: the line seq of mission item 0
    if rows and rows[0][0].command == mi.NAV_WAYPOINT and rows[0][0].current == 1:
        home_item, lat, lon, _ = rows.pop(0)
        home, offset = ((lat, lon, home_item.z) if any((lat, lon, home_item.z)) else None), 1  # zeros: unknown
    mission = []
    for seq, (item, _, _, line) in enumerate(rows):
        if item.command == mi.DO_JUMP:
            target = item.param1 - offset  # line seq -> mission seq
            if not (target.is_integer() and 0 <= target < len(rows)):
                _fail(name, "param1", f"DO_JUMP target {item.param1:g} is not the seq of a mission item line", line)
            item = replace(item, param1=target)
        mission.append(replace(item, seq=seq))
    return Plan(mission, [], [], home)


def format_wpl(plan: Plan) -> str:
    """The text of a ``QGC WPL 110`` file: the planned home line (zeros when unknown), then the mission."""
    if plan.fence or plan.rally:
        what = "the fence" if plan.fence else "rally points"
        _fail("<wpl>", "fence" if plan.fence else "rally", f"a QGC WPL 110 file holds no {what}: save to a .plan file")
    lat, lon, alt = plan.home if plan.home is not None else (0.0, 0.0, 0.0)
    home = ["0", "1", str(mi.FRAME_GLOBAL), str(mi.NAV_WAYPOINT), "0", "0", "0", "0"]
    lines = [WPL_HEADER, "\t".join(home + [repr(float(v)) for v in (lat, lon, alt)] + ["1"])]
    for seq, item in enumerate(plan.mission, 1):
        param1 = item.param1 + 1 if item.command == mi.DO_JUMP else item.param1  # mission seq -> line seq
        cols = [str(seq), str(item.current), str(item.frame), str(item.command)]
        cols += [repr(float(p)) for p in (param1, item.param2, item.param3, item.param4)]
        cols += [f"{_unscaled(item.x, item.frame):.8f}", f"{_unscaled(item.y, item.frame):.8f}", repr(float(item.z))]
        lines.append("\t".join(cols + [str(item.autocontinue)]))
    return "\n".join(lines) + "\n"
