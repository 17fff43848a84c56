"""``python -m vision``: the companion computer on real frames, sending LANDING_TARGET over UDP.

Reads a video file (``--video``) or a camera (``--camera N``, OpenCV's device index), finds the
ArUco marker (id 76 of DICT_ARUCO_ORIGINAL, 0.333 m, or ``--marker-id`` / ``--marker-size``) with
the same code the simulator's companion runs (:mod:`vision.detector`), and sends each fix as
LANDING_TARGET in the body form (MAV_FRAME_BODY_FRD: the marker's centre from the vehicle's
reference point along body FRD axes, m; angle_x/angle_y/distance too) to the flight controller,
from system ``--system`` (the vehicle's) as MAV_COMP_ID_ONBOARD_COMPUTER (191), with a HEARTBEAT
(MAV_TYPE_ONBOARD_CONTROLLER) every second.  The camera looks straight down, the top of the image
towards the nose, ``--mount-frd`` metres from the reference point.  ``time_usec`` is the frame's
time since the start (the video's own clock, or the wall clock for a camera).

Intrinsics: ``--calibration FILE`` (OpenCV YAML/XML or JSON, :mod:`vision.camera_model`) or, for
an ideal lens, ``--hfov`` degrees.  ``--save-annotated DIR`` writes each frame with the marker's
outline, axes, id and distance.  Exit codes: 0 done, 1 no frames, 2 usage error.
"""

from __future__ import annotations

import argparse
import math
import socket
import sys
import time
from pathlib import Path

import cv2
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import ports
from vision.annotate import annotate
from vision.camera_model import CameraModel, load_calibration, pinhole
from vision.detector import MarkerDetector
from vision.landing_target import CameraMount, landing_target_message
from vision.marker import MARKER_ID, MARKER_SIZE_M


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m vision", description=__doc__.split("\n\n")[0])
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--video", metavar="FILE", help="a video file")
    src.add_argument("--camera", type=int, metavar="N", help="an OpenCV camera index")
    p.add_argument("--calibration", metavar="FILE", help="OpenCV calibration (YAML/XML/JSON)")
    p.add_argument("--hfov", type=float, default=90.0, metavar="DEG", help="ideal lens' horizontal FOV (default 90)")
    p.add_argument("--mount-frd", default="0,0,0.12", metavar="X,Y,Z", help="camera from the reference point, m")
    p.add_argument("--to", default=None, metavar="HOST:PORT", help="the flight controller (default 127.0.0.1:14640+I)")
    p.add_argument("--instance", "-i", type=int, default=0, help="the vehicle's instance N (PX4's -i)")
    p.add_argument("--system", type=int, default=None, help="the vehicle's MAVLink system id (default 1+N)")
    p.add_argument("--marker-id", type=int, default=MARKER_ID)
    p.add_argument("--marker-size", type=float, default=MARKER_SIZE_M, metavar="M")
    p.add_argument("--save-annotated", metavar="DIR", help="write annotated frames here")
    p.add_argument("--max-frames", type=int, default=None, metavar="N")
    p.add_argument("--quiet", action="store_true", help="no line per detection")
    return p


def _target(text: str | None, instance: int) -> tuple[str, int]:
    if text is None:
        return "127.0.0.1", ports.api_local_port(instance)
    host, _, port = text.rpartition(":")
    return host or "127.0.0.1", int(port)


def _camera_model(args: argparse.Namespace, width: int, height: int) -> CameraModel:
    if args.calibration:
        return load_calibration(args.calibration, width, height)
    return pinhole(width, height, math.radians(args.hfov))


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        dest = _target(args.to, args.instance)
        mount = CameraMount(position_frd_m=tuple(float(v) for v in args.mount_frd.split(",")))  # type: ignore[arg-type]
        if len(mount.position_frd_m) != 3:
            raise ValueError("--mount-frd needs three numbers")
    except ValueError as exc:
        parser.error(str(exc))
    cap = cv2.VideoCapture(args.video if args.video else args.camera)
    if not cap.isOpened():
        print(f"vision: cannot open {args.video or f'camera {args.camera}'}", file=sys.stderr)
        return 1
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    system = args.system if args.system is not None else ports.system_id(args.instance)
    mav = mavlink.MAVLink(None, system, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
    save = Path(args.save_annotated) if args.save_annotated else None
    if save:
        save.mkdir(parents=True, exist_ok=True)
    detector: MarkerDetector | None = None
    frames = found = 0
    wall0, next_heartbeat = time.monotonic(), 0.0
    try:
        while args.max_frames is None or frames < args.max_frames:
            ok, frame = cap.read()
            if not ok:
                break
            t_s = cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0 if args.video else time.monotonic() - wall0
            if detector is None:
                cam = _camera_model(args, frame.shape[1], frame.shape[0])
                detector = MarkerDetector(cam, args.marker_id, args.marker_size)
            frames += 1
            if time.monotonic() >= next_heartbeat:
                next_heartbeat = time.monotonic() + 1.0
                hb = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3)
                sock.sendto(hb.pack(mav), dest)
            grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
            det = detector.detect(grey)
            if save:
                cv2.imwrite(str(save / f"frame_{frames:06d}.png"), annotate(frame, det, detector.camera))
            if det is None:
                continue
            found += 1
            q_level = (1.0, 0.0, 0.0, 0.0)  # unused by the body form
            msg = landing_target_message(det, mount, q_level, round(t_s * 1e6), frame=mavlink.MAV_FRAME_BODY_FRD)
            sock.sendto(msg.pack(mav), dest)
            if not args.quiet:
                print(
                    f"t {t_s:7.3f} s  marker {det.marker_id}  distance {det.distance_m:.2f} m  "
                    f"body FRD {msg.x:+.2f} {msg.y:+.2f} {msg.z:+.2f} m",
                    flush=True,
                )
    finally:
        cap.release()
        sock.close()
    print(f"{frames} frames, marker in {found}; LANDING_TARGET sent to {dest[0]}:{dest[1]}")
    return 0 if frames else 1


if __name__ == "__main__":
    sys.exit(main())
