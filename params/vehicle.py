"""Vehicle description shared by the simulator and the flight controller.

One TOML file in ``params/vehicles/`` describes an airframe: mass, inertia, rotor
geometry, rotor constants, motor lag and legs.  The simulator builds its MuJoCo
model from it and the flight controller builds its mixer and hover thrust from it,
so the two can never disagree.

Frames: positions are body FRD (x forward, y right, z down) relative to the
centre of mass, metres.  Units are SI.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mavsim_core.constants import GRAVITY_M_S2

VEHICLE_DIR = Path(__file__).resolve().parent / "vehicles"


class VehicleFileError(ValueError):
    """A vehicle file is missing, unreadable or inconsistent."""


@dataclass(frozen=True)
class Rotor:
    """One rotor: position in FRD (m) and spin direction (+1 CCW seen from above)."""

    position_frd_m: tuple[float, float, float]
    spin_ccw: int  # +1 counter-clockwise seen from above, -1 clockwise


CAMERA_MOUNTS = ("fixed", "gimbal")


@dataclass(frozen=True)
class GimbalSpec:
    """The camera's 3-axis gimbal ([gimbal] of the vehicle file): yaw, roll and pitch joints from the frame
    out (as most drone gimbals), their pivot at the camera's ``position_frd_m``.

    Angles follow PX4's gimbal convention (FRD, degrees): pitch 0 looks forward, -90 straight down; roll
    positive right side down; yaw positive to the right.  ``*_range_deg`` are the joints' limits (relative to
    the frame), ``max_rate_deg_s`` the fastest a joint's setpoint moves, ``time_constant_s`` the motors'
    first-order response, ``neutral_pitch_deg`` where the camera looks when nobody points it (earth-framed).
    """

    roll_range_deg: tuple[float, float] = (-40.0, 40.0)
    pitch_range_deg: tuple[float, float] = (-120.0, 30.0)
    yaw_range_deg: tuple[float, float] = (-160.0, 160.0)
    max_rate_deg_s: float = 180.0
    time_constant_s: float = 0.02
    neutral_pitch_deg: float = -90.0


@dataclass(frozen=True)
class CameraSpec:
    """The camera ([camera] of the vehicle file): rate (Hz of simulated time; 0 = no camera), image size
    (px), horizontal field of view (deg) and the optical centre in body FRD (m).  ``mount`` "fixed": it looks
    straight down, the top of the image towards the nose ([F 2.3]'s camera); "gimbal": it hangs on the
    vehicle's [gimbal] (``gimbal``), which holds it pointed (down unless told otherwise) whatever the tilt."""

    rate_hz: float = 0.0
    width_px: int = 640
    height_px: int = 480
    hfov_deg: float = 53.13
    position_frd_m: tuple[float, float, float] = (0.0, 0.0, 0.1)
    mount: str = "fixed"
    gimbal: GimbalSpec = GimbalSpec()

    @property
    def gimballed(self) -> bool:
        """True when the camera hangs on a gimbal (and there is a camera)."""
        return self.rate_hz > 0 and self.mount == "gimbal"


@dataclass(frozen=True)
class VehicleSpec:
    name: str
    mav_type: str
    body_mass_kg: float
    body_inertia_kg_m2: tuple[float, float, float]
    body_size_m: tuple[float, float, float]
    rotors: tuple[Rotor, ...]
    rotor_mass_kg: float
    rotor_radius_m: float
    k_thrust: float
    k_moment: float
    max_speed_rad_s: float
    time_constant_up_s: float
    time_constant_down_s: float
    leg_positions_frd_m: tuple[tuple[float, float, float], ...]
    leg_size_m: tuple[float, float, float]
    rotor_drag_k_d: float  # k_d in F_d,i = w_i k_d V_a_perp, N/((rad/s)(m/s))     ([F eq. 4.12]
    rolling_moment_k_r: float  # k_r in M_r,i = w_i k_r V_a_perp, N m/((rad/s)(m/s))  ([F eq. 4.13]
    body_drag_cd_area_m2: tuple[float, float, float]  # drag coefficient x area along body x, y, z (FRD)
    battery_cells: int
    battery_capacity_mah: float
    battery_resistance_ohm: float
    camera: CameraSpec = CameraSpec()

    def with_camera_mount(self, mount: str) -> VehicleSpec:
        """This vehicle with its camera on ``mount`` ("fixed" or "gimbal"); the same spec if it has no camera."""
        if mount not in CAMERA_MOUNTS:
            raise VehicleFileError(f"camera mount must be one of {', '.join(CAMERA_MOUNTS)}, is {mount!r}")
        return replace(self, camera=replace(self.camera, mount=mount))

    @property
    def mass_kg(self) -> float:
        """Total mass: body plus rotors (kg)."""
        return self.body_mass_kg + len(self.rotors) * self.rotor_mass_kg

    @property
    def inertia_kg_m2(self) -> np.ndarray:
        """Total diagonal inertia about the centre of mass (kg m^2), rotors as point masses."""
        j = np.array(self.body_inertia_kg_m2, dtype=float)
        for r in self.rotors:
            x, y, z = r.position_frd_m
            j += self.rotor_mass_kg * np.array([y * y + z * z, x * x + z * z, x * x + y * y])
        return j

    @property
    def max_thrust_per_rotor_n(self) -> float:
        return self.k_thrust * self.max_speed_rad_s**2

    @property
    def hover_thrust_fraction(self) -> float:
        """Collective thrust needed to hover as a fraction of the maximum (0..1)."""
        return self.mass_kg * GRAVITY_M_S2 / (len(self.rotors) * self.max_thrust_per_rotor_n)

    @property
    def hover_speed_rad_s(self) -> float:
        """Rotor speed at hover: sqrt(m g / (n k_T)) ([F eq. 4.8]."""
        return math.sqrt(self.mass_kg * GRAVITY_M_S2 / (len(self.rotors) * self.k_thrust))

    def effectiveness_matrix(self) -> np.ndarray:
        """Map rotor thrusts (N, one column per rotor) to body wrench.

        Rows: roll, pitch, yaw torque (N m, FRD) and collective thrust (N, along -z).
        A rotor at (x, y) pushing T up (-z in FRD) gives torque r x F = (-y T, x T, 0);
        its drag torque on the body is +k_M T about FRD z for a CCW rotor ([F eq. 4.9].
        """
        cols = []
        for r in self.rotors:
            x, y, _ = r.position_frd_m
            cols.append([-y, x, r.spin_ccw * self.k_moment, 1.0])
        return np.array(cols, dtype=float).T


def _vec(table: dict, key: str, n: int, where: str) -> tuple[float, ...]:
    try:
        v = tuple(float(x) for x in table[key])
    except KeyError as exc:
        raise VehicleFileError(f"{where}: missing '{key}'") from exc
    except (TypeError, ValueError) as exc:
        raise VehicleFileError(f"{where}: '{key}' must be a list of numbers") from exc
    if len(v) != n:
        raise VehicleFileError(f"{where}: '{key}' must have {n} numbers, has {len(v)}")
    return v


def _vec3(table: dict, key: str, where: str) -> tuple[float, float, float]:
    """``table[key]``: three numbers (as :func:`_vec` checks them)."""
    x, y, z = _vec(table, key, 3, where)
    return x, y, z


def _num(table: dict, key: str, where: str, positive: bool = True) -> float:
    try:
        v = float(table[key])
    except KeyError as exc:
        raise VehicleFileError(f"{where}: missing '{key}'") from exc
    except (TypeError, ValueError) as exc:
        raise VehicleFileError(f"{where}: '{key}' must be a number") from exc
    if positive and not v > 0:
        raise VehicleFileError(f"{where}: '{key}' must be > 0, is {v}")
    return v


def _range(table: dict, key: str, where: str, lo: float, hi: float) -> tuple[float, float]:
    """A joint range [min, max] in degrees, inside [lo, hi] and holding zero."""
    a, b = _vec(table, key, 2, where)
    if not lo <= a <= 0.0 <= b <= hi or a == b:
        raise VehicleFileError(f"{where}: '{key}' must be [min, max] with {lo:g} <= min <= 0 <= max <= {hi:g}")
    return a, b


def _gimbal(table: object, where: str) -> GimbalSpec:
    """[gimbal]: absent means the defaults of :class:`GimbalSpec`."""
    if table is None:
        return GimbalSpec()
    if not isinstance(table, dict):
        raise VehicleFileError(f"{where}: [gimbal] must be a table")
    w = f"{where} [gimbal]"
    g = GimbalSpec(
        roll_range_deg=_range(table, "roll_range_deg", w, -90.0, 90.0),
        pitch_range_deg=_range(table, "pitch_range_deg", w, -180.0, 90.0),
        yaw_range_deg=_range(table, "yaw_range_deg", w, -180.0, 180.0),
        max_rate_deg_s=_num(table, "max_rate_deg_s", w),
        time_constant_s=_num(table, "time_constant_s", w),
        neutral_pitch_deg=_num(table, "neutral_pitch_deg", w, positive=False),
    )
    if not g.pitch_range_deg[0] <= g.neutral_pitch_deg <= g.pitch_range_deg[1]:
        raise VehicleFileError(f"{w}: 'neutral_pitch_deg' must lie inside pitch_range_deg")
    if g.time_constant_s > 1.0:
        raise VehicleFileError(f"{w}: 'time_constant_s' must be <= 1 s, is {g.time_constant_s}")
    return g


def _camera(table: object, gimbal: object, where: str) -> CameraSpec:
    """[camera] (absent: no camera) and the [gimbal] it may hang on."""
    if table is None:
        return CameraSpec()
    if not isinstance(table, dict):
        raise VehicleFileError(f"{where}: [camera] must be a table")
    w = f"{where} [camera]"
    mount = table.get("mount", "fixed")
    if mount not in CAMERA_MOUNTS:
        raise VehicleFileError(f"{w}: 'mount' must be one of {', '.join(CAMERA_MOUNTS)}, is {mount!r}")
    cam = CameraSpec(
        rate_hz=_num(table, "rate_hz", w, positive=False),
        width_px=int(_num(table, "width_px", w)),
        height_px=int(_num(table, "height_px", w)),
        hfov_deg=_num(table, "hfov_deg", w),
        position_frd_m=_vec3(table, "position_frd_m", w),
        mount=mount,
        gimbal=_gimbal(gimbal, where),
    )
    if not 0.0 <= cam.rate_hz <= 100.0 or not 1.0 <= cam.hfov_deg <= 170.0:
        raise VehicleFileError(f"{w}: rate_hz must be 0..100 and hfov_deg 1..170")
    return cam


def vehicle_path(name_or_path: str) -> Path:
    """Resolve a vehicle name (``quad_x``) or a path to a TOML file."""
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.exists():
        return p
    if p.suffix == ".toml" or len(p.parts) > 1:
        raise VehicleFileError(f"no such vehicle file '{name_or_path}'")
    cand = VEHICLE_DIR / f"{name_or_path}.toml"
    if cand.exists():
        return cand
    known = ", ".join(sorted(x.stem for x in VEHICLE_DIR.glob("*.toml")))
    raise VehicleFileError(f"unknown vehicle '{name_or_path}' (known: {known})")


def load_vehicle(name_or_path: str = "quad_x") -> VehicleSpec:
    """Load and check a vehicle file; raise VehicleFileError with a clear reason."""
    path = vehicle_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise VehicleFileError(f"{path}: {exc}") from exc
    where = str(path)
    try:
        body, rot, legs, aero, batt = data["body"], data["rotors"], data["legs"], data["aero"], data["battery"]
    except KeyError as exc:
        raise VehicleFileError(f"{where}: missing section [{exc.args[0]}]") from exc
    positions = rot.get("positions_frd_m")
    spins = rot.get("spin")
    if not isinstance(positions, list) or not isinstance(spins, list) or len(positions) != len(spins):
        raise VehicleFileError(f"{where}: [rotors] needs positions_frd_m and spin lists of equal length")
    if len(positions) < 4:
        raise VehicleFileError(f"{where}: a multirotor needs at least 4 rotors, has {len(positions)}")
    rotors = []
    for i, (pos, spin) in enumerate(zip(positions, spins)):
        if spin not in ("ccw", "cw"):
            raise VehicleFileError(f"{where}: rotor {i + 1} spin must be 'ccw' or 'cw', is {spin!r}")
        p = _vec3({"p": pos}, "p", f"{where} rotor {i + 1}")
        rotors.append(Rotor(p, 1 if spin == "ccw" else -1))
    leg_pos = tuple(_vec3({"p": p}, "p", f"{where} leg") for p in legs.get("positions_frd_m", []))
    if len(leg_pos) < 3:
        raise VehicleFileError(f"{where}: [legs] needs at least 3 positions_frd_m")
    spec = VehicleSpec(
        name=str(data.get("name", path.stem)),
        mav_type=str(data.get("mav_type", "QUADROTOR")),
        body_mass_kg=_num(body, "mass_kg", where),
        body_inertia_kg_m2=_vec3(body, "inertia_kg_m2", where),
        body_size_m=_vec3(body, "size_m", where),
        rotors=tuple(rotors),
        rotor_mass_kg=_num(rot, "mass_kg", where, positive=False),
        rotor_radius_m=_num(rot, "radius_m", where),
        k_thrust=_num(rot, "k_thrust", where),
        k_moment=_num(rot, "k_moment", where),
        max_speed_rad_s=_num(rot, "max_speed_rad_s", where),
        time_constant_up_s=_num(rot, "time_constant_up_s", where),
        time_constant_down_s=_num(rot, "time_constant_down_s", where),
        leg_positions_frd_m=leg_pos,
        leg_size_m=_vec3(legs, "size_m", where),
        rotor_drag_k_d=_num(aero, "rotor_drag_k_d", where, positive=False),
        rolling_moment_k_r=_num(aero, "rolling_moment_k_r", where, positive=False),
        body_drag_cd_area_m2=_vec3(aero, "body_drag_cd_area_m2", where),
        battery_cells=int(_num(batt, "cells", where)),
        battery_capacity_mah=_num(batt, "capacity_mah", where),
        battery_resistance_ohm=_num(batt, "internal_resistance_ohm", where),
        camera=_camera(data.get("camera"), data.get("gimbal"), where),
    )
    if spec.hover_thrust_fraction >= 0.9:
        raise VehicleFileError(
            f"{where}: cannot hover with margin: hover needs {spec.hover_thrust_fraction:.0%} of full thrust"
        )
    return spec
