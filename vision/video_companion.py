"""The running part of ``python -m vision``: open the source, detect in every frame, send LANDING_TARGET.

:func:`start` opens everything before the first detection (the video or camera and its first frame, the
calibration, the output directory, the UDP socket) and raises one of :data:`STARTUP_ERRORS`, naming the
option, when it cannot; :func:`run` is the loop.  The options are those of :mod:`vision.__main__`.
"""

from __future__ import annotations

import argparse
import math
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import ports
from mavsim_core.cli_checks import check_readable, make_dir
from vision.annotate import annotate
from vision.camera_model import CameraModel, load_calibration, pinhole
from vision.detector import MarkerDetector
from vision.landing_target import CameraMount, landing_target_message
from vision.marker import MARKER_ID, MARKER_SIZE_M
from vision.pad import NESTED_PAD, SINGLE_PAD, PadLayout, PadMarker

STARTUP_ERRORS = (OSError, ValueError, cv2.error)


@dataclass
class Companion:
    """The opened source and sink: the frames, the detector (built for the first frame's size), the UDP socket."""

    cap: cv2.VideoCapture
    first_frame: object
    detector: MarkerDetector
    sock: socket.socket
    dest: tuple[str, int]
    mav: mavlink.MAVLink
    save: Path | None
    wall0: float = field(default_factory=time.monotonic)

    def close(self) -> None:
        self.cap.release()
        self.sock.close()


def _camera_model(args: argparse.Namespace, width: int, height: int) -> CameraModel:
    if not args.calibration:
        return pinhole(width, height, math.radians(args.hfov))
    try:
        return load_calibration(args.calibration, width, height)
    except (ValueError, KeyError, cv2.error) as exc:
        raise ValueError(f"--calibration {args.calibration}: {exc}") from None


def _open_source(args: argparse.Namespace) -> tuple[cv2.VideoCapture, object]:
    """The capture and its first frame; OSError naming the option if there is none."""
    if args.video:
        check_readable("--video", args.video)
        what = f"--video {args.video}"
    else:
        what = f"--camera {args.camera}"
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # our one line says it, not OpenCV's
    try:
        cap = cv2.VideoCapture(args.video if args.video else args.camera)
    finally:
        cv2.utils.logging.setLogLevel(level)
    if not cap.isOpened():
        raise OSError(0, f"{what}: cannot open it" + (" as a video" if args.video else ""))
    ok, frame = cap.read()
    if not ok:
        cap.release()
        raise OSError(0, f"{what}: no frame could be read from it")
    return cap, frame


def pad_of(args: argparse.Namespace) -> PadLayout:
    """The pad to look for: one marker of ``--marker-id``/``--marker-size`` if either is given, else ``--pad``'s."""
    if args.marker_id is None and args.marker_size is None:
        return SINGLE_PAD if args.pad == "single" else NESTED_PAD
    marker_id = MARKER_ID if args.marker_id is None else args.marker_id
    return PadLayout((PadMarker(marker_id, MARKER_SIZE_M if args.marker_size is None else args.marker_size),))


def start(args: argparse.Namespace) -> Companion:
    """Open everything before the first detection; OSError or ValueError naming the option when it cannot."""
    if args.calibration:
        check_readable("--calibration", args.calibration)
    if args.save_annotated:
        make_dir("--save-annotated", args.save_annotated)
    cap, frame = _open_source(args)
    try:
        camera = _camera_model(args, frame.shape[1], frame.shape[0])
        detector = MarkerDetector(camera, layout=pad_of(args))
    except BaseException:
        cap.release()
        raise
    dest = args.to or ("127.0.0.1", ports.api_local_port(args.instance))
    system = args.system if args.system is not None else ports.system_id(args.instance)
    mav = mavlink.MAVLink(None, system, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
    save = Path(args.save_annotated) if args.save_annotated else None
    return Companion(cap, frame, detector, socket.socket(socket.AF_INET, socket.SOCK_DGRAM), dest, mav, save)


def _frames(c: Companion, args: argparse.Namespace):
    """(frame, time s) from the source, the first frame included, up to --max-frames."""
    frame, count = c.first_frame, 0
    while frame is not None and (args.max_frames is None or count < args.max_frames):
        count += 1
        yield frame, c.cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0 if args.video else time.monotonic() - c.wall0
        ok, frame = c.cap.read()
        if not ok:
            frame = None


def run(c: Companion, args: argparse.Namespace) -> tuple[int, int]:
    """Detect in every frame and send LANDING_TARGET; (frames, frames with the marker)."""
    frames = found = 0
    next_heartbeat = 0.0
    mount = CameraMount(position_frd_m=args.mount_frd)
    for frame, t_s in _frames(c, args):
        frames += 1
        if time.monotonic() >= next_heartbeat:
            next_heartbeat = time.monotonic() + 1.0
            hb = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3)
            c.sock.sendto(hb.pack(c.mav), c.dest)
        grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
        det = c.detector.detect(grey)
        if c.save:
            cv2.imwrite(str(c.save / f"frame_{frames:06d}.png"), annotate(frame, det, c.detector.camera))
        if det is None:
            continue
        found += 1
        q_level = (1.0, 0.0, 0.0, 0.0)  # unused by the body form
        msg = landing_target_message(det, mount, q_level, round(t_s * 1e6), frame=mavlink.MAV_FRAME_BODY_FRD)
        c.sock.sendto(msg.pack(c.mav), c.dest)
        if not args.quiet:
            print(
                f"t {t_s:7.3f} s  markers {'+'.join(map(str, det.marker_ids))}  distance {det.distance_m:.2f} m  "
                f"body FRD {msg.x:+.2f} {msg.y:+.2f} {msg.z:+.2f} m",
                flush=True,
            )
    return frames, found
