"""Benchmark: what the estimators cost the flight controller per 4 ms IMU sample (in-process).

Feeds :class:`autopilot.estimation.estimator.Estimator` 60 s of synthetic IMU samples
at 250 Hz (a vehicle at rest, noisy gyro, accelerometer and magnetometer) and a 5 Hz GPS
fix, exactly as the flight controller does (deferred mode: ``update_imu`` on the
critical path, ``run_deferred`` after the motor commands), and prints the mean time per
sample of each part for ``SYS_MC_EST_GROUP`` 2 (EKF selected) and 1 (Mahony selected;
the other estimator always keeps running at 10 Hz).  CPU microseconds of this thread
(``time.thread_time``), so other processes on a busy machine do not count; still this
machine's: compare versions by alternating runs, not with another day's figure.  A progress bar
(stderr) counts the simulated seconds fed to each estimator.  No options.

Usage: ``python benchmarks/estimator_cost.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from autopilot.estimation.estimator import Estimator  # noqa: E402
from autopilot.param_catalogue import default_store
from autopilot.topics import GpsSample, ImuSample  # noqa: E402

from _cli import parser  # noqa: E402
from _progress import Progress  # noqa: E402

SECONDS = 60.0
WARM_UP_S = 20.0  # converged before timing starts
PERIOD_US = 4000
SAMPLES_PER_S = 1_000_000 // PERIOD_US
GROUPS = ((2, "EKF selected"), (1, "Mahony selected"))


def samples(n: int) -> list[ImuSample]:
    rng = np.random.default_rng(0)
    mag = np.array([0.21, 0.0, 0.43])
    return [
        ImuSample(
            (k + 1) * PERIOD_US,
            np.array([0.0, 0.0, -9.80665]) + rng.normal(0, 0.02, 3),
            rng.normal(0, 0.002, 3),
            mag + rng.normal(0, 0.003, 3),
            955.0,
            20.0,
            0,
        )
        for k in range(n)
    ]


def measure(group: int, imus: list[ImuSample], progress: Progress) -> tuple[float, float]:
    """Mean µs per sample: (update_imu + update_gps, run_deferred); one step of ``progress`` per simulated second."""
    params = default_store()
    params.set("SYS_MC_EST_GROUP", group)
    est = Estimator(params)
    est.defer_filters = True
    critical = deferred = 0.0
    warm = int(WARM_UP_S * 1e6 / PERIOD_US)
    for k, imu in enumerate(imus):
        gps = (
            GpsSample(imu.timestamp_us, 3, 47.397742, 8.545594, 488.0, np.zeros(3), 0.1, 0.2, 10)
            if k % 50 == 0
            else None
        )
        t0 = time.thread_time()
        est.update_imu(imu)
        if gps is not None:
            est.update_gps(gps)
        t1 = time.thread_time()
        est.run_deferred()
        t2 = time.thread_time()
        if k >= warm:
            critical += t1 - t0
            deferred += t2 - t1
        if (k + 1) % SAMPLES_PER_S == 0:
            progress.done(phase="timed" if k >= warm else f"warm-up {WARM_UP_S:g} s (not timed)")
    n = len(imus) - warm
    return critical / n * 1e6, deferred / n * 1e6


def main(argv: list[str] | None = None) -> int:
    parser(__doc__).parse_args(argv)  # --help, and no option
    imus = samples(int(SECONDS * 1e6 / PERIOD_US))
    print(f"estimators, mean CPU time per 4 ms IMU sample over {SECONDS - WARM_UP_S:.0f} s (in-process, this machine)")
    with Progress(int(SECONDS) * len(GROUPS), "sim s") as progress:
        for group, name in GROUPS:
            progress.label(f"SYS_MC_EST_GROUP={group}")
            critical, deferred = measure(group, imus, progress)
            progress.say(
                f"SYS_MC_EST_GROUP={group} ({name:15}): {critical:5.1f} us before the motor commands "
                f"(output predictor, IMU sums), {deferred:5.1f} us after them (the 50 Hz filter run, GPS "
                f"fusion), {critical + deferred:5.1f} us in all"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
