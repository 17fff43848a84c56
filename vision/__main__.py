"""``python -m vision``: the companion computer on real frames, sending LANDING_TARGET over UDP.

Reads a video file (``--video``) or a camera (``--camera N``, OpenCV's device index), finds the
landing pad's ArUco markers (``--pad``: nested, the default, ids 76, 151, 113 and 813 of DICT_ARUCO_ORIGINAL,
0.333 m, around id 42, 0.125 m, at the centre (:mod:`vision.pad`); single, id 76 alone; or one marker of
``--marker-id`` / ``--marker-size``) with
the same code the simulator's companion runs (:mod:`vision.detector`, one pose from every marker seen), and sends
each fix as LANDING_TARGET in the body form (MAV_FRAME_BODY_FRD: the pad's centre from the vehicle's
reference point along body FRD axes, m; angle_x/angle_y/distance too) to the flight controller,
from system ``--system`` (the vehicle's) as MAV_COMP_ID_ONBOARD_COMPUTER (191), with a HEARTBEAT
(MAV_TYPE_ONBOARD_CONTROLLER) every second.  The camera looks straight down, the top of the image
towards the nose, ``--mount-frd`` metres from the reference point.  ``time_usec`` is the frame's
time since the start (the video's own clock, or the wall clock for a camera).

Intrinsics: ``--calibration FILE`` (OpenCV YAML/XML or JSON, :mod:`vision.camera_model`) or, for
an ideal lens, ``--hfov`` degrees.  ``--save-annotated DIR`` writes each frame with the marker's
outline, axes, id and distance.  Exit codes: 0 done, 1 no frames or the source, the calibration or
the output directory cannot be used (one line naming the option), 2 usage error (argparse's own).
"""

from __future__ import annotations

import argparse
import math
import sys

from mavsim_core.cli_args import EXIT_CODES_EPILOG, add_instance_option, add_version_option, port_number
from mavsim_core.cli_checks import (
    host_address,
    non_negative_int,
    positive_int,
    positive_number,
    startup_failed,
    system_id,
)


def parse_destination(text: str) -> tuple[str, int]:
    """argparse ``type`` of ``--to``: ``HOST:PORT`` or ``:PORT`` (host 127.0.0.1)."""
    host, sep, port = text.rpartition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"must be HOST:PORT, not {text!r}")
    return host_address(host or "127.0.0.1"), port_number(port)


def parse_xyz(text: str) -> tuple[float, float, float]:
    """argparse ``type`` of ``--mount-frd``: three finite numbers ``X,Y,Z`` (m)."""
    try:
        x, y, z = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be X,Y,Z in metres, not {text!r}") from None
    if not all(math.isfinite(v) for v in (x, y, z)):
        raise argparse.ArgumentTypeError(f"must be three finite numbers, not {text!r}")
    return x, y, z


def field_of_view(text: str) -> float:
    """argparse ``type`` of ``--hfov``: degrees, more than 0 and less than 180."""
    value = positive_number(text)
    if not value < 180:
        raise argparse.ArgumentTypeError(f"must be more than 0 and less than 180 degrees, not {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m vision", description=__doc__.split("\n\n")[0], epilog=EXIT_CODES_EPILOG)
    add_version_option(p)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--video", metavar="FILE", help="a video file")
    src.add_argument("--camera", type=non_negative_int, metavar="N", help="an OpenCV camera index")
    p.add_argument("--calibration", metavar="FILE", help="OpenCV calibration (YAML/XML/JSON)")
    p.add_argument(
        "--hfov", type=field_of_view, default=90.0, metavar="DEG", help="ideal lens' horizontal FOV (default 90)"
    )
    p.add_argument(
        "--mount-frd", type=parse_xyz, default=(0.0, 0.0, 0.12), metavar="X,Y,Z",
        help="camera from the reference point, m (default 0,0,0.12)",
    )  # fmt: skip
    p.add_argument(
        "--to", type=parse_destination, default=None, metavar="HOST:PORT",
        help="the flight controller (default 127.0.0.1:14640+N)",
    )  # fmt: skip
    add_instance_option(p, help="the vehicle's instance N (PX4's -i): system id 1+N, sends to UDP 14640+N")
    p.add_argument("--system", type=system_id, default=None, help="the vehicle's MAVLink system id (default 1+N)")
    p.add_argument(
        "--pad", choices=("nested", "single"), default="nested",
        help="the landing pad: nested (markers 76, 151, 113, 813 around 42, default) or single (the seed's 76)",
    )  # fmt: skip
    p.add_argument(
        "--marker-id", type=non_negative_int, default=None,
        help="a pad of one marker of this id instead (default: --pad's)",
    )  # fmt: skip
    p.add_argument(
        "--marker-size", type=positive_number, default=None, metavar="M",
        help="a pad of one marker of this side, m, instead (default: --pad's; 0.333 with --marker-id)",
    )  # fmt: skip
    p.add_argument("--save-annotated", metavar="DIR", help="write annotated frames here")
    p.add_argument("--max-frames", type=positive_int, default=None, metavar="N")
    p.add_argument("--quiet", action="store_true", help="no line per detection")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from vision.video_companion import STARTUP_ERRORS, run, start  # OpenCV: once the options are good

    try:
        companion = start(args)
    except (*STARTUP_ERRORS, KeyboardInterrupt) as exc:  # the start only: the loop's bugs keep their traceback
        return startup_failed("vision", exc)
    try:
        frames, found = run(companion, args)
    except KeyboardInterrupt:
        return 130
    finally:
        companion.close()
    print(f"{frames} frames, marker in {found}; LANDING_TARGET sent to {companion.dest[0]}:{companion.dest[1]}")
    return 0 if frames else 1


if __name__ == "__main__":
    sys.exit(main())
