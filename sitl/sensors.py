"""Sensor models: IMU, magnetometer, barometer and GPS with white noise.

Inputs are ground truth in MAVLink frames (NED world, FRD body, SI units);
outputs are what the sensors would read, still in SI (the MAVLink edge converts
to its own units).  All randomness comes from one seeded numpy Generator so a
run is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.geodesy import ned_to_geodetic

SEA_LEVEL_PRESSURE_HPA = 1013.25


def pressure_hpa_at(alt_amsl_m: float) -> float:
    """International Standard Atmosphere pressure (hPa) at an altitude (m AMSL)."""
    return SEA_LEVEL_PRESSURE_HPA * (1.0 - 2.25577e-5 * alt_amsl_m) ** 5.25588


def earth_field_ned_gauss(lat_deg: float, lon_deg: float, alt_amsl_m: float, year: float = 2026.9) -> np.ndarray:
    """Earth's magnetic field (gauss, NED) from the World Magnetic Model."""
    from pygeomag import GeoMag

    r = GeoMag().calculate(glat=lat_deg, glon=lon_deg, alt=alt_amsl_m / 1000.0, time=year)
    return np.array([r.x, r.y, r.z]) * 1e-5  # nT -> gauss


@dataclass(frozen=True)
class NoiseLevels:
    """Standard deviations of the white noise on each sample."""

    accel_m_s2: float = 0.03
    gyro_rad_s: float = 0.003
    mag_gauss: float = 0.003
    baro_hpa: float = 0.006  # about 5 cm
    gps_horizontal_m: float = 0.1
    gps_vertical_m: float = 0.2
    gps_velocity_m_s: float = 0.05


@dataclass(frozen=True)
class ImuReading:
    accel_frd_m_s2: np.ndarray
    gyro_frd_rad_s: np.ndarray
    mag_frd_gauss: np.ndarray
    pressure_hpa: float
    temperature_c: float


@dataclass(frozen=True)
class GpsReading:
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    vel_ned_m_s: np.ndarray
    eph_m: float
    epv_m: float
    satellites: int
    fix_type: int


class SensorSuite:
    """Turns ground truth into noisy sensor readings."""

    def __init__(self, home_lat_deg: float, home_lon_deg: float, home_alt_m: float, seed: int,
                 noise: NoiseLevels = NoiseLevels()) -> None:
        self.home = (home_lat_deg, home_lon_deg, home_alt_m)
        self.noise = noise
        self.rng = np.random.default_rng(seed)
        self.field_ned_gauss = earth_field_ned_gauss(home_lat_deg, home_lon_deg, home_alt_m)

    def imu(self, specific_force_frd: np.ndarray, rate_frd: np.ndarray, r_ned_frd: np.ndarray,
            pos_ned_m: np.ndarray) -> ImuReading:
        """IMU, magnetometer and barometer at one instant.

        ``r_ned_frd`` is the rotation matrix taking FRD vectors to NED.
        """
        n = self.noise
        g = self.rng.standard_normal(10)
        mag = r_ned_frd.T @ self.field_ned_gauss
        alt = self.home[2] - float(pos_ned_m[2])
        return ImuReading(
            accel_frd_m_s2=specific_force_frd + n.accel_m_s2 * g[0:3],
            gyro_frd_rad_s=rate_frd + n.gyro_rad_s * g[3:6],
            mag_frd_gauss=mag + n.mag_gauss * g[6:9],
            pressure_hpa=pressure_hpa_at(alt) + n.baro_hpa * g[9],
            temperature_c=15.0 - 0.0065 * alt,
        )

    def gps(self, pos_ned_m: np.ndarray, vel_ned_m_s: np.ndarray) -> GpsReading:
        n = self.noise
        g = self.rng.standard_normal(6)
        noisy = pos_ned_m + np.array([n.gps_horizontal_m * g[0], n.gps_horizontal_m * g[1], n.gps_vertical_m * g[2]])
        lat, lon, alt = ned_to_geodetic(noisy, *self.home)
        return GpsReading(
            lat_deg=lat, lon_deg=lon, alt_amsl_m=alt,
            vel_ned_m_s=vel_ned_m_s + n.gps_velocity_m_s * g[3:6],
            eph_m=max(0.3, 2.0 * n.gps_horizontal_m), epv_m=max(0.5, 2.0 * n.gps_vertical_m),
            satellites=12, fix_type=3,
        )


def course_over_ground_deg(vel_ned_m_s: np.ndarray) -> float:
    return math.degrees(math.atan2(vel_ned_m_s[1], vel_ned_m_s[0])) % 360.0
