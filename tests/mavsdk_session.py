"""MAVSDK's native API (``mavsdk`` 4.x) as the tests open it: a ground station whose plugins are all released, in
this thread, before its core is destroyed.

The binding destroys a plugin from its ``__del__``, wherever its last reference goes.  A plugin made for one
call (``await ParamAsync(system).get_param_int(...)``) is last held by the event loop's executor thread that ran
the call (its work item), so it may be destroyed there at the moment the session's end destroys the core in the
main thread: a full suite died of it (``Fatal Python error: Aborted``, the main thread in ``mavsdk_destroy`` and
an executor thread in ``mavsdk_param_destroy``, test_e2e_identity.py, 2026-12-05).  The session runs its blocking
calls on an executor of its own, joins its threads at the end (their work items, and the plugins they held, are
gone then), collects the garbage, and only then destroys the core.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
from concurrent.futures import ThreadPoolExecutor
from typing import AsyncIterator

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

JOIN_S = 30.0  # wall seconds to wait for the executor's calls to end (a call stuck in the library: go on)


@contextlib.asynccontextmanager
async def ground_station() -> AsyncIterator[Mavsdk]:
    """``Mavsdk`` configured as a ground station, for an ``async with`` in the test's event loop."""
    loop = asyncio.get_running_loop()
    pool = ThreadPoolExecutor(thread_name_prefix="mavsdk-calls")
    loop.set_default_executor(pool)
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        yield sdk
    finally:
        loop.set_default_executor(ThreadPoolExecutor(thread_name_prefix="after-mavsdk"))
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(asyncio.to_thread(pool.shutdown, True), JOIN_S)
        gc.collect()  # plugins in reference cycles: destroyed here, in this thread
        sdk.destroy()
