"""Physical and timing constants, each defined once (SI units).

Gravity is the standard value (CODATA / ISO 80000-3), used by the simulator's MuJoCo model,
its accelerometer and the flight controller's estimators and thrust computation alike, so
the two processes agree on what hover means.
"""

from __future__ import annotations

GRAVITY_M_S2 = 9.80665  # standard gravity, m/s^2

LOCKSTEP_DT_S = 0.004  # s: the lockstep period, 250 Hz sensors, rate control and physics
LOCKSTEP_DT_US = 4000  # the same period in microseconds (MAVLink time_usec)

# International Standard Atmosphere (ISO 2533), troposphere
SEA_LEVEL_PRESSURE_HPA = 1013.25  # hPa at 0 m AMSL
SEA_LEVEL_TEMPERATURE_C = 15.0  # deg C at 0 m AMSL
TEMPERATURE_LAPSE_K_M = 0.0065  # K per m of altitude

# The World Magnetic Model (pygeomag's WMM) is evaluated at this decimal year by both the
# simulated magnetometer and the flight controller's declination lookup.
MAGNETIC_MODEL_EPOCH_YEAR = 2026.9
