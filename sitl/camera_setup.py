"""Assembles the camera's MAVLink side and media for a simulation whose vision companion renders frames.

The camera component (:mod:`sitl.camera_component`) talks from UDP 14030+N to the flight controller's payload
link 14280+N; the video (SIM_VID_EN) goes as RTP H.264 to 5600+N (:mod:`sitl.video_stream`); photos and
recordings go to ``--media-dir`` (default: ``camera/`` under ``--log-dir``, else a folder in the temporary
directory named for the instance).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from mavsim_core import ports
from sitl.camera_component import CameraComponent
from sitl.camera_media import CameraMedia, camera_pose
from sitl.model import part_name


def media_dir(args: argparse.Namespace, k: int = 0) -> Path:
    """Where vehicle ``k``'s photos and recordings go (see the module docstring; vehicle k >= 1 of a world of several:
    a folder ``vehicle-<k>`` in it)."""
    if args.media_dir:
        base = Path(args.media_dir)
    elif args.log_dir:
        base = Path(args.log_dir) / "camera"
    else:
        return Path(tempfile.gettempdir()) / f"mavsim-camera-{args.instance + k}"
    return base if k == 0 else base / f"vehicle-{k}"


def _own_port(explicit: int | None, k: int, default: int) -> int:
    """An explicit port option is vehicle 0's (vehicle k's is +k, as ``sitl --count``'s other ports); else the
    instance's default."""
    return explicit + k if explicit else default


def camera_component(companion, sim, args: argparse.Namespace, k: int = 0) -> CameraComponent:
    """The camera component of vehicle ``k`` (instance ``--instance`` + k), its media handed to ``companion`` (which
    renders the frames)."""
    spec, settings = sim.spec.camera, sim.camera_settings
    fps = float(settings.video_fps) or spec.rate_hz
    host, instance = args.video_host, args.instance + k
    video_port = _own_port(args.video_port, k, ports.video_port(instance))
    stream = None
    if settings.video:
        from sitl.video_stream import RtpVideoStream

        stream = RtpVideoStream(host, video_port, spec.width_px, spec.height_px, fps, int(settings.video_kbps))
    home = sim.sensors.home
    media = CameraMedia(spec.width_px, spec.height_px, spec.rate_hz, media_dir(args, k), stream, fps, home)
    companion.media = media
    if stream is not None:  # SIM_VID_ANNOT: read at each frame, so it can be turned on in flight
        import math

        from sitl.video_stream import annotated_rgb
        from vision.camera_model import pinhole

        model = pinhole(spec.width_px, spec.height_px, math.radians(spec.hfov_deg))
        media.annotate = lambda rgb, det: annotated_rgb(rgb, det, model) if settings.video_annotate else rgb
    cam_id = sim.model.camera(part_name(k, "downward")).id
    camera_port = _own_port(args.camera_port, k, ports.camera_port(instance))
    payload_port = _own_port(args.payload_port, k, ports.payload_local_port(instance))
    return CameraComponent(
        media, spec, ports.system_id(instance), (args.bind, camera_port), ("127.0.0.1", payload_port),
        f"udp://{host}:{video_port}", fps, int(settings.video_kbps), lambda: camera_pose(sim.data, cam_id, home),
    )  # fmt: skip
