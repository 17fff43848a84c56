"""Benchmark: the simulator's truth log as ``.npy`` (what ``sitl/truth_log.py`` writes) or as a ULog, compared.

Writes one simulated minute of truth (250 Hz, the rows ``TruthRecorder.record`` appends: time, armed, position,
velocity, roll/pitch/yaw, body rates, the motors, and with ``--ugv`` the deck's six columns) both ways into a
temporary directory, and prints for each: the writer's CPU time per simulated second (``time.process_time``, best
of ``--repeat``), the bytes per simulated minute, and the CPU time to read the minute back (``np.load`` against
pyulog, as ``gcs plot`` would).  Only the writing differs: the rows are built once beforehand.

Usage: ``python benchmarks/truth_log_format.py [--motors N] [--ugv] [--repeat N]``
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mavsim_core.constants import LOCKSTEP_DT_US  # noqa: E402
from mavsim_core.npy_log import NpyLogWriter  # noqa: E402
from mavsim_core.ulog_writer import ULogFormat, ULogWriter  # noqa: E402
from sitl.truth_log import truth_log_fields  # noqa: E402

from _cli import parser  # noqa: E402

ULOG_TYPES = {"q": "uint64_t", "B": "bool", "f": "float"}
SIM_S = 60.0


def _rows(fields: list[tuple[str, str]]) -> list[tuple]:
    """One simulated minute of rows of ``fields`` (time, armed, then floats)."""
    n = int(SIM_S * 1e6 / LOCKSTEP_DT_US)
    rng = np.random.default_rng(0)
    floats = rng.normal(size=(n, len(fields) - 2)).astype(np.float32).tolist()
    return [(k * LOCKSTEP_DT_US, True, *row) for k, row in enumerate(floats)]


def _write_npy(path: Path, fields, rows) -> None:
    w = NpyLogWriter(path, fields)
    for row in rows:
        w.append(*row)
    w.close()


def _write_ulog(path: Path, fields, rows) -> None:
    w = ULogWriter(path, 0)
    names = ["timestamp" if name == "time_us" else name for name, _ in fields]
    w.add_format(ULogFormat("sim_truth", [f"{ULOG_TYPES[code]} {name}" for name, (_, code) in zip(names, fields)]))
    sub = w.subscribe("sim_truth")
    for row in rows:
        w.write(sub, *row)
    w.close()


def _read_npy(path: Path) -> None:
    np.load(path)["pos_d_m"].sum()


def _read_ulog(path: Path) -> None:
    from pyulog import ULog

    ULog(str(path)).get_dataset("sim_truth").data["pos_d_m"].sum()


def _cpu_s(fn, *args, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        fn(*args)
        best = min(best, time.process_time() - t0)
    return best


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--motors", type=int, default=4, help="motor columns (quad_x: 4)")
    ap.add_argument("--ugv", action="store_true", help="with the ground vehicle's deck columns")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each, the best kept")
    args = ap.parse_args(argv)
    fields = truth_log_fields(args.motors, args.ugv)
    rows = _rows(fields)
    with tempfile.TemporaryDirectory(prefix="truth-format-") as tmp:
        for label, write, read, name in (
            (".npy (now)", _write_npy, _read_npy, "t.truth.npy"),
            ("ULog", _write_ulog, _read_ulog, "t.ulg"),
        ):
            path = Path(tmp) / name
            cpu = _cpu_s(write, path, fields, rows, repeat=args.repeat)
            size = path.stat().st_size
            read_s = _cpu_s(read, path, repeat=args.repeat)
            print(
                f"{label:11s} write {cpu / SIM_S * 1e6:6.0f} us CPU per simulated s ({cpu / len(rows) * 1e6:.2f} us "
                f"a row), {size / 1e3:7.1f} kB per simulated minute, read back {read_s * 1e3:6.1f} ms CPU"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
