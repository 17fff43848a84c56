"""Every UDP/TCP port of an instance, in one place (PX4's multi-vehicle SITL scheme plus our own).

Instance N (``--instance`` / ``-i``, 0-99) of the stack uses, as PX4 SITL does:

- TCP 4560+N: the simulator link (the simulator listens, the flight controller connects);
- UDP 14550: where EVERY instance sends its ground-station link (QGroundControl listens there
  and shows all vehicles on its one link), from the flight controller's socket 18570+N;
- UDP 14540+N: where the flight controller sends its API link (MAVSDK listens there);
- MAVLink system id 1+N (PX4's ``MAV_SYS_ID`` in SITL);
- UDP 14280+N: the flight controller's onboard payload link (PX4's ``udp_onboard_payload_port_local``), which
  talks to a MAVLink camera on UDP 14030+N (``udp_onboard_payload_port_remote``) and forwards between it and the
  ground stations, so they see the camera as component 100 of the vehicle's system;
- UDP 5600+N: where the camera's video goes, RTP H.264 (PX4's simulated cameras send there; QGroundControl's
  default video source listens on 5600).

And ports of our own, chosen so that no two instances 0-99 share a port (a test checks it):

- UDP 14640+N: the flight controller's API-side socket (PX4 binds 14580+N, which is instance
  N+40's API port; a companion computer such as ``python -m vision`` sends to this one);
- UDP 14740+N: where the simulator's own MAVLink component (ground truth, ``SIM_*`` parameters,
  the ground vehicle) sends; its clients (``gcs ugv``, ``gcs sim``, tests) listen there;
- UDP 14840+N: a ground-station port of the instance's own, for scripts and tests that run
  several instances and must not share 14550 (``Stack(gcs_port=own_gcs_port(N))``).

The one overlap PX4's scheme itself has: instance 10's API port 14550 is also every instance's
ground-station port.  Avoid instance 10 when a ground station listens on 14550.
"""

from __future__ import annotations

MAX_INSTANCE = 99  # PX4's ports leave room for no more

SIM_TCP_BASE = 4560
GCS_PORT = 14550
GCS_LOCAL_BASE = 18570
API_BASE = 14540
API_LOCAL_BASE = 14640
SIM_COMPONENT_BASE = 14740
OWN_GCS_BASE = 14840
PAYLOAD_LOCAL_BASE = 14280
CAMERA_BASE = 14030
VIDEO_BASE = 5600


def system_id(instance: int) -> int:
    """MAVLink system id of instance ``instance``'s flight controller (and its simulator component)."""
    return 1 + instance


def sim_tcp_port(instance: int) -> int:
    return SIM_TCP_BASE + instance


def gcs_local_port(instance: int) -> int:
    """The flight controller's ground-station socket (sends to :data:`GCS_PORT`)."""
    return GCS_LOCAL_BASE + instance


def api_port(instance: int) -> int:
    """Where the flight controller sends its API link (MAVSDK listens)."""
    return API_BASE + instance


def api_local_port(instance: int) -> int:
    """The flight controller's API-side socket (companion computers send here)."""
    return API_LOCAL_BASE + instance


def sim_component_port(instance: int) -> int:
    """Where the simulator's MAVLink component (truth, SIM_* parameters, ground vehicle) sends."""
    return SIM_COMPONENT_BASE + instance


def own_gcs_port(instance: int) -> int:
    """A ground-station port of the instance's own (instead of the shared 14550)."""
    return OWN_GCS_BASE + instance


def payload_local_port(instance: int) -> int:
    """The flight controller's onboard payload socket (a MAVLink camera talks to it)."""
    return PAYLOAD_LOCAL_BASE + instance


def camera_port(instance: int) -> int:
    """The MAVLink camera component's socket (the flight controller's payload link sends there)."""
    return CAMERA_BASE + instance


def video_port(instance: int) -> int:
    """Where the camera's RTP H.264 video goes (a video player or QGroundControl listens there)."""
    return VIDEO_BASE + instance
