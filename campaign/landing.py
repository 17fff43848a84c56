"""Campaign kind ``landing``: a precision landing on the UGV (gcs/launcher/landing_run.py), scored from truth.

Grid axes: ``vehicle`` (a vehicle file name), ``ugv_speed_m_s`` (0: the static pad: one cell whatever
the path), ``ugv_path`` (line, circle, figure8, random), ``wind`` (calm, or windy: 5 m/s from the
West, 1 m/s turbulence, 2 m/s gusts), ``camera`` (gimbal: the 3-axis gimbal, ``SIM_CAM_MOUNT`` 2; fixed:
the seed's body-fixed camera, 1) and ``pad`` (nested: the nested marker pad, ``SIM_PAD_LAYOUT`` 0; single:
the seed's single marker, 1), ``ugv_radius_m`` (the circle's and the figure-8 lobes' radius, ``SIM_UGV_RAD``;
default 2 m: the UGV turns at most 1.5 rad/s, so 4.2 m/s needs lobes of 2.8 m or more).  Cells in the order
vehicle, wind, speed, path, radius, camera, pad (the last two innermost, so a cell's gimbal and fixed-camera runs
stand next to each other in the report).

Randomised per run (:mod:`.plan` draws them): the UGV's start pose (NED metres from the
multicopter's start point, heading in degrees), the meeting point's offset from the UGV's path
(distance up to ``meet_offset_m``, bearing ``meet_bearing_deg``) and the simulator's seed
(``sim_seed``: ``sitl --seed``, which seeds the sensor noise, the wind's turbulence and gusts, the
camera noise and a random UGV path; the simulator has one seed for all of them).
"""

from __future__ import annotations

import math
import re
from typing import Any

from gcs.launcher.landing_run import (
    CAMERA_MOUNT_CODES,
    PAD_LAYOUT_CODES,
    WINDY,
    LandingSetup,
    Pose2,
    deck_model_params,
    fly_landing,
)
from gcs.sim_client import SimClient

from .kinds import Axis, Range, grid_cells, number_in, one_of, vehicle_name
from .plan import Run

PATHS = ("line", "circle", "figure8", "random")
CAMERAS = tuple(CAMERA_MOUNT_CODES)  # the grid's camera values (the first the default: the gimbal)
PADS = tuple(PAD_LAYOUT_CODES)  # the grid's pad values (the first the default: the nested pad)
FLIGHT_TIMEOUT_S = 240.0  # wall seconds of one wait inside the landing (arming, take-off, touchdown ...)
CAMERA_LINE = re.compile(
    r"camera: (\d+) frames, (\d+) with the marker .*farthest ([\d.]+) m\).*error against the truth "
    r"([\d.]+) cm mean, ([\d.]+) cm max"
)
CAMERA_HZ = 20.0
NAMES = ("ugv_radius_m", "camera", "pad")  # the grid's innermost axes, slowest first


def camera_figures(sitl_log: str) -> dict[str, float]:
    """The simulator's camera line (sitl/companion.py): detections per second of flight, the farthest
    detection (m), and the detections' position error against the truth (cm); NaN when absent."""
    m = CAMERA_LINE.search(sitl_log)
    if m is None:
        return dict.fromkeys(("detections_per_s", "farthest_m", "pose_err_mean_cm", "pose_err_max_cm"), math.nan)
    frames, found = int(m.group(1)), int(m.group(2))
    return {
        "detections_per_s": found / (frames / CAMERA_HZ) if frames else math.nan,
        "farthest_m": float(m.group(3)),
        "pose_err_mean_cm": float(m.group(4)),
        "pose_err_max_cm": float(m.group(5)),
    }


def setup_for(
    cell: dict[str, Any],
    draws: dict[str, float],
    extra_sim_params: dict[str, float] | None = None,
    fc_params: dict[str, float] | None = None,
):
    """The :class:`LandingSetup` of one run: its cell's vehicle, UGV, wind, camera and pad, and its random draws;
    the campaign's ``[fc_params]`` over the landing's own (:func:`gcs.launcher.landing_run.deck_model_params`:
    the flight sets them again before the arming, so the campaign's must win there too)."""
    r, bearing = draws["meet_offset_m"], math.radians(draws["meet_bearing_deg"])
    return LandingSetup(
        vehicle=cell["vehicle"],
        path=cell["ugv_path"],
        speed_m_s=float(cell["ugv_speed_m_s"]),
        windy=cell["wind"] == "windy",
        seed=int(draws["sim_seed"]),
        ugv_start=Pose2(draws["ugv_start_north_m"], draws["ugv_start_east_m"], math.radians(draws["ugv_heading_deg"])),
        meet_offset_m=(r * math.cos(bearing), r * math.sin(bearing)),
        camera=cell["camera"],
        pad=cell["pad"],
        radius_m=float(cell.get("ugv_radius_m", 2.0)),
        extra_sim_params=dict(extra_sim_params or {}),  # (no video unless they set SIM_VID_EN: LandingSetup.video)
        fc_params={**deck_model_params(), **(fc_params or {})},
    )


class LandingKind:
    """See the module docstring."""

    name = "landing"
    axes = (
        Axis("vehicle", ("quad_x", "firefly"), vehicle_name, "vehicle file names"),
        Axis("wind", ("calm", "windy"), one_of("calm", "windy"), "wind case"),
        Axis("ugv_speed_m_s", (0, 0.5, 1, 2, 3), number_in(0.0, 5.0), "UGV speed, m/s (0: static pad)"),
        Axis("ugv_path", PATHS, one_of(*PATHS), "UGV path (for speeds above 0)"),
        # Added with issue 34: a results file written before them has no such column and is still a landing one.
        Axis("ugv_radius_m", (2,), number_in(1.0, 20.0), "circle and figure-8 radius, m", required_in_results=False),
        Axis("camera", CAMERAS[:1], one_of(*CAMERAS), "camera mount (SIM_CAM_MOUNT)", required_in_results=False),
        Axis("pad", PADS[:1], one_of(*PADS), "landing pad on the deck (SIM_PAD_LAYOUT)", required_in_results=False),
    )
    ranges = (
        Range("ugv_start_north_m", (3.5, 4.5), False, (-20.0, 20.0), "UGV start, m North of the multicopter"),
        Range("ugv_start_east_m", (-0.5, 0.5), False, (-20.0, 20.0), "UGV start, m East of the multicopter"),
        Range("ugv_heading_deg", (-180.0, 180.0), False, (-360.0, 360.0), "UGV start heading, degrees from North"),
        Range("meet_offset_m", (0.0, 0.5), False, (0.0, 5.0), "meeting point's distance from the UGV's path, m"),
        Range("meet_bearing_deg", (-180.0, 180.0), False, (-360.0, 360.0), "meeting point's offset bearing, degrees"),
        Range("sim_seed", (0, 999_999), True, (0, 2**31 - 1), "simulator seed (sitl --seed)"),
    )
    figures = (
        "success",
        "touchdown_error_m",
        "time_to_land_s",
        "ugv_speed_at_touchdown_m_s",
        "feet_on_deck",
        "deck_level_err_cm",
        "square_off_deg",
        "sim_s",
        "wall_s",
        "real_time_factor",
        "detections_per_s",
        "farthest_m",
        "pose_err_mean_cm",
        "pose_err_max_cm",
        "phases",
    )
    # The simulator parameters each run sets from its cell or its draws: [sim_params] may not set them (spec.py).
    owned_sim_params = {
        "SIM_CAM_MOUNT": "grid.camera",
        "SIM_PAD_LAYOUT": "grid.pad",
        "SIM_UGV_PATH": "grid.ugv_path",
        "SIM_UGV_RAD": "grid.ugv_radius_m",
        "SIM_UGV_X": "random.ugv_start_north_m",
        "SIM_UGV_Y": "random.ugv_start_east_m",
        "SIM_UGV_YAW": "random.ugv_heading_deg",
        **dict.fromkeys(WINDY, "grid.wind"),
    }
    error_figure = "touchdown_error_m"
    time_figure = "time_to_land_s"

    def cells(self, grid: dict[str, tuple]) -> list[dict[str, Any]]:
        out = []
        for vehicle in grid["vehicle"]:
            for wind in grid["wind"]:
                for speed in grid["ugv_speed_m_s"]:
                    for path in ("static",) if speed == 0 else grid["ugv_path"]:
                        where = {"vehicle": vehicle, "wind": wind, "ugv_speed_m_s": speed, "ugv_path": path}
                        turns = path in ("circle", "figure8")  # (the radius is theirs: one cell for the others)
                        radii = grid["ugv_radius_m"] if turns else grid["ugv_radius_m"][:1]
                        out += [{**where, **c} for c in grid_cells({**grid, "ugv_radius_m": radii}, NAMES)]
        return out

    def label(self, cell: dict[str, Any]) -> str:
        """e.g. ``quad_x figure8 2 m/s calm gimbal camera nested pad``."""
        speed = cell["ugv_speed_m_s"]
        where = "static pad" if speed == 0 else f"{cell['ugv_path']} {speed:g} m/s"
        radius = float(cell.get("ugv_radius_m", 2.0))
        where += f" r {radius:g} m" if speed != 0 and cell["ugv_path"] in ("circle", "figure8") and radius != 2 else ""
        return f"{cell['vehicle']} {where} {cell['wind']} {cell['camera']} camera {cell['pad']} pad"

    def fly(self, run: Run, ctx) -> dict[str, Any]:
        """One landing on the run's own stack (``ctx``: :class:`campaign.runs.RunContext`)."""
        from mavsim_core import ports

        setup = setup_for(run.axes, run.draws, ctx.settings.sim_params, ctx.settings.fc_params)
        stack = ctx.stack(setup.vehicle, setup.seed, setup.sim_args())
        stack.start()
        with SimClient(ports.sim_component_port(ctx.instance)) as truth:
            client = ctx.client()
            timeout_s = min(FLIGHT_TIMEOUT_S, ctx.settings.time_limit_s)
            res = fly_landing(client, truth, setup, timeout_s=timeout_s)
        stack.stop()
        figures: dict[str, Any] = {
            "success": res.success,
            "touchdown_error_m": res.touchdown_error_m,
            "time_to_land_s": res.time_to_land_s,
            "ugv_speed_at_touchdown_m_s": res.ugv_speed_at_touchdown_m_s,
            "feet_on_deck": res.feet_on_deck,
            "deck_level_err_cm": res.deck_level_err_cm,
            "square_off_deg": res.square_off_deg,
            "sim_s": res.sim_s,
            "wall_s": res.wall_s,
            "real_time_factor": res.real_time_factor,
            "phases": " | ".join(res.phases),
            "status": "ok" if res.success else "flight_failed",
            "reason": res.reason,
        }
        figures.update(camera_figures(stack.log_path("sitl").read_text(errors="replace")))
        return figures


KIND = LandingKind()
