"""The stored mission, geofence and rally plans across restarts (``--state-dir``).

One JSON file per vehicle and instance, ``DIR/<vehicle>-<instance>.plan.json``, beside the
parameter file: ``{"version": 1, "mission": [item, ...], "fence": [...], "rally": [...]}`` with
each item the fields of a MISSION_ITEM_INT (:class:`mavsim_core.mission_items.MissionItem`).
Written atomically after every accepted upload or clear (a crash leaves the old or the new
file, never half of one); a broken file is reported and ignored at start-up, so the vehicle
comes up with empty plans rather than not at all.  Plans change rarely (an upload), so the
write happens in the caller's thread.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem
from params.param_file import atomic_write_text

VERSION = 1
_FIELDS = [f.name for f in dataclasses.fields(MissionItem)]


def plan_file(state_dir: str | Path, vehicle_name: str, instance: int) -> Path:
    """Where the plans of a vehicle and instance are kept."""
    return Path(state_dir) / f"{vehicle_name}-{instance}.plan.json"


def save_plans(path: Path, plans: dict[int, list[MissionItem]]) -> None:
    """Write the three plans (mission type -> items) atomically."""
    doc: dict[str, object] = {"version": VERSION}
    for mtype, name in mi.TYPE_NAMES.items():
        doc[name] = [dataclasses.asdict(it) for it in plans.get(mtype, [])]
    atomic_write_text(path, json.dumps(doc, indent=1) + "\n")


def load_plans(path: Path) -> dict[int, list[MissionItem]]:
    """The plans saved in ``path`` (empty when there is no file); ValueError saying what is wrong with a
    broken one."""
    if not path.exists():
        return {}
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: {exc}") from exc
    if not isinstance(doc, dict) or doc.get("version") != VERSION:
        raise ValueError(f"{path}: not a version {VERSION} plan file")
    out: dict[int, list[MissionItem]] = {}
    for mtype, name in mi.TYPE_NAMES.items():
        entries = doc.get(name, [])
        try:
            out[mtype] = [MissionItem(**{k: e[k] for k in _FIELDS}) for e in entries]
        except (KeyError, TypeError) as exc:
            raise ValueError(f"{path}: {name} item is missing or has a bad field ({exc})") from exc
        if [it.seq for it in out[mtype]] != list(range(len(out[mtype]))):
            raise ValueError(f"{path}: {name} items are not numbered 0..n-1")
    return out
