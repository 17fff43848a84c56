"""Instance numbers for the tests that bind ports: leased at run time, never written down.

The leasing itself lives in :mod:`gcs.launcher.instance_pool` (campaigns lease from the same pool
and the same kernel locks, so a campaign and the tests never collide); this module is what the test
files import (``from instances import lease``).

A test takes its numbers from the ``free_instance`` fixture (tests/conftest.py), which calls
:func:`lease`: the lowest number of :data:`POOL` that no other test or campaign holds (in this run,
another pytest-xdist worker or a concurrent run) and whose ports nothing on this machine binds (a
person's stack, a benchmark).  The pool keeps clear of people's instances (0-9: ``flight-demo``,
``gcs``), of 10 (its API port is the shared 14550) and of the benchmarks' defaults (11-29).
"""

from __future__ import annotations

from gcs.launcher.instance_pool import BENCHMARKS, LOCK_NAMESPACE, PEOPLE, POOL, Lease, collisions, lease, ports

__all__ = ["BENCHMARKS", "LOCK_NAMESPACE", "PEOPLE", "POOL", "Lease", "collisions", "lease", "ports"]
