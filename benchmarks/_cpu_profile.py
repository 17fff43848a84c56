"""``python -m _cpu_profile OUT MODULE [ARGS...]``: run MODULE as ``python -m MODULE ARGS`` does, under cProfile
with a CPU-time clock (``time.process_time``: time spent blocked in ``recv`` or ``select`` counts nothing, and
other processes on a loaded machine do not inflate it), and write the statistics to OUT when it exits.

The profiler starts disabled: SIGUSR1 starts it (and drops what it had), SIGUSR2 stops it, so a benchmark
profiles one window of a flight (not the imports and start-up).  Not a benchmark itself (the leading
underscore): ``benchmarks/profile_lockstep.py`` runs each process of a stack through it.
"""

from __future__ import annotations

import cProfile
import runpy
import signal
import sys
import time


def main() -> None:
    out, module = sys.argv[1], sys.argv[2]
    sys.argv = [module, *sys.argv[3:]]
    prof = cProfile.Profile(time.process_time)

    def start(*_) -> None:
        prof.clear()
        prof.enable()

    signal.signal(signal.SIGUSR1, start)
    signal.signal(signal.SIGUSR2, lambda *_: prof.disable())
    try:
        runpy.run_module(module, run_name="__main__", alter_sys=True)
    except SystemExit:
        pass
    finally:
        prof.disable()
        prof.dump_stats(out)


if __name__ == "__main__":
    main()
