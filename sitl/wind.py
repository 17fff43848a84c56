"""Wind: steady wind + Dryden turbulence + discrete 1-cosine gusts, in NED (m/s).

``WindModel.step(dt_s, altitude_agl_m, airspeed_m_s)`` returns the velocity of
the air (m/s, world NED: North, East, Down) at the vehicle.  It reads its
``WindSettings`` object on every call, so a change of any ``SIM_WIND_*`` /
``SIM_GUST_*`` parameter acts on the very next step.  All randomness comes
from ``numpy.random.default_rng(seed)``: the same seed and the same sequence
of calls and settings give the same wind, bit for bit.

Steady wind
-----------
``direction_deg`` is meteorological: the direction the wind blows FROM,
degrees true.  The air moves towards psi = direction + 180 deg, so

    wind_steady_ned = speed * (cos psi, sin psi, 0)

(from 270 deg = from the West: (0, +speed, 0), moving East).

Turbulence: Dryden, low-altitude model of MIL-F-8785C / MIL-HDBK-1797
----------------------------------------------------------------------
With h the height above ground in feet, clamped to the model's validity range
10 ft .. 1000 ft (3.05 m .. 305 m):

    L_u = L_v = h / (0.177 + 0.000823 h)^1.2        L_w = h          (ft)
    sigma_u = sigma_v = SIM_WIND_TURB
    sigma_w = sigma_u * (0.177 + 0.000823 h)^0.4

u is along the mean wind (towards psi), v across it (to the right of psi, i.e.
towards psi + 90 deg), w vertical (taken as Down).  With no steady wind the
reference direction is North.  Frozen turbulence (Taylor's hypothesis): the
spatial field is swept past the vehicle at V = max(airspeed, steady speed,
1 m/s), so a shaping filter's time constant is tau = L / V; the 1 m/s floor
keeps it defined in hover.  The Dryden transfer functions (MIL-F-8785C form,
driven by unit white noise) are

    H_u(s) = sigma_u sqrt(2 L_u / (pi V)) / (1 + tau_u s)
    H_v(s) = sigma_v sqrt(L_v / (pi V)) (1 + sqrt(3) tau_v s) / (1 + tau_v s)^2
    H_w(s) = sigma_w sqrt(L_w / (pi V)) (1 + sqrt(3) tau_w s) / (1 + tau_w s)^2

Discretisation chosen (exact in distribution, for any dt):

* u: first-order Gauss-Markov.  With a = exp(-dt/tau_u),
  x_u <- a x_u + sqrt(1 - a^2) n, u = sigma_u x_u; Var = sigma_u^2 and the
  autocorrelation is exp(-|lag|/tau_u), exactly as the Dryden u spectrum.

* v and w: the full second-order Dryden filters, not a first-order shortcut,
  because their spectrum, sigma^2 L/(pi V) (1 + 3 (tau om)^2) / (1 + (tau om)^2)^2,
  rises to a mild peak (9/8 of its low-frequency level) at om = 1/(sqrt(3) tau)
  before rolling off (more energy where the attitude loops work than a
  first-order lag of the same sigma and L would give), and their
  correlation R(xi) = sigma^2 (1 - xi / (2L)) exp(-xi/L) goes negative beyond
  xi = 2L; a first-order shaping would get neither right.
  Partial fractions make it cheap: with two identical unit-variance lags

      tau dx1/dt = -x1 + sqrt(2 tau) white,     tau dx2/dt = x1 - x2,

  (1 + sqrt(3) tau s) / (1 + tau s)^2 is  y = sqrt(3) x1 + (1 - sqrt(3)) x2,
  whose stationary variance is 2, so  v = sigma_v y / sqrt(2).  The exact
  discrete model of (x1, x2) over one step, with r = dt/tau and a = exp(-r), is

      x1' = a x1                + w1
      x2' = a r x1 + a x2       + w2
      Cov(w) = Q: Q11 = 1 - a^2,  Q12 = Q11/2 - a^2 r,
                  Q22 = 1/2 - a^2 (r^2 + r + 1/2)

  and (w1, w2) = L (n1, n2) with the Cholesky factor L of Q.  Q22 - Q12^2/Q11
  (= r^3/6 (1 - r + 7 r^2/15) + O(r^6)) cancels badly in floating point for
  small r, so below r = 0.01 its series is used.  Stationary covariance is
  [[1, 1/2], [1/2, 1/2]].

The coefficients are recomputed on every step from the current altitude,
airspeed and dt (three exp, a few sqrt), so the time constants follow the
flight.  States are kept normalised (unit variance) and the current sigma is
applied at the output, so a change of SIM_WIND_TURB acts at once; they start
from a draw of their stationary distribution, so turbulence switched on is
fully developed from the first step.  While SIM_WIND_TURB is 0 the states are
not advanced (they stay a valid stationary sample).

Gusts: discrete 1-cosine (MIL-F-8785C / MIL-HDBK-1797 discrete gust shape)
-------------------------------------------------------------------------
    g(t) = A/2 (1 - cos(2 pi t / T)),  0 <= t <= T,  A = SIM_GUST_SPD,
                                                      T = SIM_GUST_DUR

horizontal, along the steady wind (towards psi); with no steady wind a random
horizontal direction is drawn for each gust.  Gust starts form a Poisson
process of rate 1 / SIM_GUST_INT, run as a unit-exponential countdown that
loses dt / SIM_GUST_INT each step (so a change of the interval acts at once).
One gust at a time: a start falling inside a gust is deferred to its end.  A
gust's duration and direction are fixed when it starts; its amplitude is read
live, so SIM_GUST_SPD = 0 ends the current gust and stops new ones.
``trigger_gust()`` starts one now (scenarios, tests).

Speed: ``step`` uses plain floats and ``math`` only; normal deviates are drawn
from the generator in blocks and consumed from a list.  With speed, turbulence
and gust speed all 0 it returns (0, 0, 0) at once.
"""

from __future__ import annotations

import math

import numpy as np

from sitl.sim_settings import WindSettings

FT_PER_M = 1.0 / 0.3048
H_MIN_FT = 10.0  # validity range of the low-altitude Dryden model
H_MAX_FT = 1000.0
V_MIN_M_S = 1.0  # floor of the speed that sweeps the frozen turbulence field
_SMALL_R = 0.01  # below this dt/tau the conditional variance uses its series
_MIN_GUST_DURATION_S = 1e-3
_MIN_GUST_INTERVAL_S = 1e-3
_NORMALS_PER_STEP = 5  # u: 1, v: 2, w: 2
_BLOCK_STEPS = 1024
_BLOCK = _NORMALS_PER_STEP * _BLOCK_STEPS
_C1 = math.sqrt(1.5)  # sqrt(3) / sqrt(2)
_C2 = (1.0 - math.sqrt(3.0)) / math.sqrt(2.0)
_TWO_PI = 2.0 * math.pi
_ZERO = (0.0, 0.0, 0.0)


def _discretisation(r: float) -> tuple[float, float, float, float]:
    """Exact discretisation of a shaping filter over a step of ``r`` correlation lengths:
    the decay a = e^-r and the Cholesky factor (l11; l21, l22) of the step's noise covariance
    (first-order state: a, l11; the second-order Dryden pair adds l21, l22)."""
    em = math.expm1(-r)
    a = 1.0 + em
    q11 = -em * (1.0 + a)
    l11 = math.sqrt(q11)
    a2 = a * a
    l21 = (0.5 * q11 - a2 * r) / l11
    if r < _SMALL_R:
        d = r * r * r * (1.0 - r + 0.4666666666666667 * r * r) * 0.16666666666666666
    else:
        d = 0.5 - a2 * (r * r + r + 0.5) - l21 * l21
    return a, l11, l21, (math.sqrt(d) if d > 0.0 else 0.0)


def _second_order(
    x1: float, x2: float, r: float, a: float, l11: float, l21: float, l22: float, n1: float, n2: float
) -> tuple[float, float]:
    """One step of the second-order (v or w) Dryden state with unit normal draws n1, n2."""
    return a * x1 + l11 * n1, a * (r * x1 + x2) + l21 * n1 + l22 * n2


class WindModel:
    """Steady wind + Dryden turbulence + 1-cosine gusts; see the module docstring."""

    __slots__ = (
        "settings",
        "_rng",
        "_normals",
        "_k",
        "_vel",
        "_dir_deg",
        "_cos",
        "_sin",
        "_xu",
        "_xv1",
        "_xv2",
        "_xw1",
        "_xw2",
        "_gust_active",
        "_gust_t_s",
        "_gust_T_s",
        "_gust_n",
        "_gust_e",
        "_to_next_gust",
    )

    def __init__(self, settings: WindSettings, seed: int) -> None:
        self.settings = settings
        self._rng = np.random.default_rng(seed)
        self._normals: list[float] = self._rng.standard_normal(_BLOCK).tolist()
        self._k = 0
        self._vel = _ZERO
        self._dir_deg = math.nan  # cached steady direction and its unit vector
        self._cos = 1.0
        self._sin = 0.0
        # Turbulence states (unit variance), drawn from their stationary distribution.
        n = self._rng.standard_normal(5).tolist()
        self._xu = n[0]
        self._xv1 = n[1]
        self._xv2 = 0.5 * n[1] + 0.5 * n[2]
        self._xw1 = n[3]
        self._xw2 = 0.5 * n[3] + 0.5 * n[4]
        # Gusts
        self._gust_active = False
        self._gust_t_s = 0.0
        self._gust_T_s = 1.0
        self._gust_n = 0.0
        self._gust_e = 0.0
        self._to_next_gust = float(self._rng.standard_exponential())

    @property
    def velocity_ned_m_s(self) -> tuple[float, float, float]:
        """The wind returned by the last step (m/s, NED)."""
        return self._vel

    def trigger_gust(self) -> None:
        """Start a gust now (amplitude SIM_GUST_SPD, duration SIM_GUST_DUR); it replaces any current gust."""
        s = self.settings
        T = s.gust_duration_s
        self._gust_T_s = T if T > _MIN_GUST_DURATION_S else _MIN_GUST_DURATION_S
        self._gust_t_s = 0.0
        self._gust_active = True
        if s.speed_m_s > 0.0:
            psi = math.radians(s.direction_deg + 180.0)
            self._gust_n = math.cos(psi)
            self._gust_e = math.sin(psi)
        else:
            psi = float(self._rng.uniform(0.0, _TWO_PI))
            self._gust_n = math.cos(psi)
            self._gust_e = math.sin(psi)

    def _gusts(self, dt_s: float, gust_a: float, vn: float, ve: float) -> tuple[float, float]:
        """Advance the current gust by ``dt_s`` (s), amplitude ``gust_a`` (m/s, SIM_GUST_SPD, not 0), and
        start the next one if the countdown has run out; (vn, ve) (m/s, North/East) with the gust added.

        Called by :meth:`step` (after the countdown) only during a gust or when one is due."""
        if self._gust_active:
            t = self._gust_t_s + dt_s
            T = self._gust_T_s
            if t < T:  # one gust at a time: a start due now waits for its end
                self._gust_t_s = t
                g = 0.5 * gust_a * (1.0 - math.cos(_TWO_PI * t / T))
                return vn + g * self._gust_n, ve + g * self._gust_e
            self._gust_active = False
        if self._to_next_gust <= 0.0:
            self.trigger_gust()  # starts at t = 0, where g = 0
            self._to_next_gust = float(self._rng.standard_exponential())
        return vn, ve

    def step(self, dt_s: float, altitude_agl_m: float, airspeed_m_s: float) -> tuple[float, float, float]:
        """Advance by dt_s; return the wind (air velocity) in NED, m/s."""
        s = self.settings
        speed = s.speed_m_s
        sigma = s.turbulence_m_s
        gust_a = s.gust_speed_m_s
        if speed == 0.0 and sigma == 0.0 and gust_a == 0.0:
            self._gust_active = False
            self._vel = _ZERO
            return _ZERO
        if not dt_s >= 0.0:
            raise ValueError(f"WindModel.step: dt_s must be >= 0, got {dt_s!r}")

        direction = s.direction_deg
        if direction != self._dir_deg:
            psi = math.radians(direction + 180.0)
            self._cos = math.cos(psi)
            self._sin = math.sin(psi)
            self._dir_deg = direction
        c = self._cos
        sn = self._sin
        vn = speed * c
        ve = speed * sn
        vd = 0.0

        if sigma != 0.0:
            # Dryden turbulence.
            h_ft = altitude_agl_m * FT_PER_M
            if not h_ft > H_MIN_FT:  # also catches NaN
                h_ft = H_MIN_FT
            elif h_ft > H_MAX_FT:
                h_ft = H_MAX_FT
            k = 0.177 + 0.000823 * h_ft
            k04 = k**0.4
            v_m_s = airspeed_m_s if airspeed_m_s > speed else speed
            if not v_m_s > V_MIN_M_S:
                v_m_s = V_MIN_M_S
            if dt_s > 0.0:
                dx_ft = dt_s * v_m_s * FT_PER_M  # distance flown through the frozen field
                i = self._k
                buf = self._normals
                if i >= _BLOCK:
                    buf = self._normals = self._rng.standard_normal(_BLOCK).tolist()
                    i = 0
                self._k = i + _NORMALS_PER_STEP
                # u and v: r = dt / tau_u = dx / L_u
                r = dx_ft * k04 * k04 * k04 / h_ft
                a, l11, l21, l22 = _discretisation(r)
                self._xu = a * self._xu + l11 * buf[i]
                self._xv1, self._xv2 = _second_order(self._xv1, self._xv2, r, a, l11, l21, l22, buf[i + 1], buf[i + 2])
                # w: r = dx / L_w, L_w = h
                r = dx_ft / h_ft
                a, l11, l21, l22 = _discretisation(r)
                self._xw1, self._xw2 = _second_order(self._xw1, self._xw2, r, a, l11, l21, l22, buf[i + 3], buf[i + 4])
            tu = sigma * self._xu
            tv = sigma * (_C1 * self._xv1 + _C2 * self._xv2)
            vd = sigma * k04 * (_C1 * self._xw1 + _C2 * self._xw2)
            if speed > 0.0:
                vn += c * tu - sn * tv
                ve += sn * tu + c * tv
            else:  # no mean wind: u along North, v along East
                vn += tu
                ve += tv

        if gust_a != 0.0:
            interval = s.gust_interval_s
            if not interval > _MIN_GUST_INTERVAL_S:
                interval = _MIN_GUST_INTERVAL_S
            self._to_next_gust -= dt_s / interval  # the Poisson countdown runs every step
            if self._gust_active or self._to_next_gust <= 0.0:
                vn, ve = self._gusts(dt_s, gust_a, vn, ve)
        else:
            self._gust_active = False

        vel = (vn, ve, vd)
        self._vel = vel
        return vel
