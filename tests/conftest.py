"""Fixtures shared by the unit-test files (pytest finds them here by name).

Tests that bind ports take their instance numbers from ``free_instance`` (or ``inst``, one per module), which
leases them at run time (``instances.py`` beside this file).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # camera tests render headless (before anything imports MuJoCo)
# The stacks the tests start (and their children) wait for their lockstep peer without spinning: the suite runs
# more stacks than the machine has cores, where a spin only takes a core from another stack's process
# (mavsim_core/spin_receiver.py; docs/testing.md, "Time").  A person's own setting is kept.
os.environ.setdefault("MAVSIM_LOCKSTEP_SPIN_US", "0")

import pytest  # noqa: E402

from autopilot.param_catalogue import default_store  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402


@pytest.fixture(scope="session", autouse=True)
def _temp_dirs_under_pytest_basetemp(tmp_path_factory):
    """A Stack started without ``log_dir`` makes a temp dir for its logs (kept after it stops, for a person
    to read), and so does ``flight-demo`` run as a command; in the tests those go under pytest's own base
    temp directory, which pytest prunes (the last three runs are kept), instead of piling up in /tmp:
    ``tempfile`` in this process, ``TMPDIR`` for the processes the tests start."""
    import tempfile

    temp = str(tmp_path_factory.mktemp("temp"))
    before, before_env = tempfile.tempdir, os.environ.get("TMPDIR")
    tempfile.tempdir = os.environ["TMPDIR"] = temp
    yield
    tempfile.tempdir = before
    if before_env is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = before_env


@pytest.fixture(scope="module")
def free_instance():
    """``free_instance()`` -> an instance number (``-i``) that no other test, in this run or a concurrent one, and
    no stack a person runs on this machine is using; each call gives another.  All are released when the test
    module ends.  See ``tests/instances.py``."""
    from instances import lease

    leases = []

    def take() -> int:
        leases.append(lease())
        return leases[-1].number

    yield take
    for held in leases:
        held.release()


@pytest.fixture(scope="module")
def inst(free_instance) -> int:
    """One free instance for the test module's stack (``free_instance()`` once); ``truth_and_stack_fixtures``
    (tests/e2e_flight_helpers.py) starts its stack on it."""
    return free_instance()


@pytest.fixture(scope="module")
def quad():
    """The quad_x vehicle file (params/vehicles/quad_x.toml)."""
    return load_vehicle("quad_x")


@pytest.fixture
def params():
    """A fresh parameter store with every declared parameter at its default."""
    return default_store()


@pytest.fixture
def store(params):
    """``params`` under the name the parameter tests use (test_param_files.py, test_param_rules.py, ...)."""
    return params


@pytest.fixture
def make_harness():
    """``make(instance, vehicle=None)``: a GcsLink harness (tests/gcs_link_harness.py); all are closed after the test.

    For tests/test_gcs_link_*.py.  The harness module is imported here, not above, so that only
    those tests load pymavlink through it.
    """
    from gcs_link_harness import Harness, StubVehicle

    made: list[Harness] = []

    def make(instance: int, vehicle: StubVehicle | None = None) -> Harness:
        h = Harness(instance, vehicle)
        made.append(h)
        return h

    yield make
    for h in made:
        h.close()


def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject.toml's addopts): one worker more than the machine has cores.  The e2e files whose
    client acts in wall time run their stack at CLIENT_SPEED (tests/e2e_flight_helpers.py) and leave part of a
    core idle while they wait on the client; the extra worker's file uses it (docs/testing.md, "Time")."""
    return (os.cpu_count() or 1) + 1


def pytest_collection_modifyitems(config, items):
    """The order in which ``--dist loadfile`` hands the files out (xdist's own reordering is off: addopts): the
    files marked ``long``, then the other files with e2e tests, then the unit-test files; within each group by
    their number of tests, most first (xdist's default order); each file's tests in their own order.

    A file is one worker's from its first test to its last, so the run ends when the last file handed out ends.
    By xdist's order alone (number of tests) the e2e files of one test came last, and the campaign file (a
    minute of a worker: a landing campaign interrupted, resumed, and resumed again on Ray) ended the run with
    the other two workers done (20 s, 2026-12-05).  The unit files, most under a second, now fill the end."""
    files: dict[str, list] = {}
    for item in items:
        files.setdefault(item.nodeid.split("::", 1)[0], []).append(item)

    def key(tests: list) -> tuple[bool, bool, int]:
        e2e = any(t.get_closest_marker("e2e") is not None for t in tests)
        return (tests[0].get_closest_marker("long") is None, not e2e, -len(tests))

    items[:] = [item for tests in sorted(files.values(), key=key) for item in tests]


# ---------------------------------------------------------------------------------------------
# A failed e2e test prints the tails of both processes' logs and each link's last messages
# (tests/e2e_diagnostics.py), so a CI failure can be read without re-running it.


def pytest_configure(config):
    import e2e_diagnostics

    e2e_diagnostics.install()
    from gcs.launcher import fork_server

    # This process's stacks are forked from one server that has imported both processes' modules (about 0.8 CPU
    # s a stack, sixty stacks a run: gcs/launcher/fork_server.py, docs/testing.md); the commands the tests run as
    # processes start theirs as a user's would (the switch is this process's, not its environment's).
    fork_server.use_here()
    if not hasattr(config, "workerinput"):  # the run's main process (xdist's controller, or -n0's only one)
        from rewrite_cache import write_for_workers

        from mavproxy_env import prepare_in_background

        # pytest's rewritten test files, once for all workers (tests/rewrite_cache.py); it forks, so before any thread
        write_for_workers(config)
        prepare_in_background()  # MAVProxy's environment made beside the unit tests (tests/mavproxy_env.py)


def pytest_runtest_setup(item):
    import e2e_diagnostics

    e2e_diagnostics.enter_module(item.module.__name__)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    if report.failed and item.get_closest_marker("e2e") is not None:
        import e2e_diagnostics

        sections = e2e_diagnostics.sections()
        for title, text in sections:
            report.sections.append((title, text))
        e2e_diagnostics.keep(report.nodeid, report.when, sections)  # the flake hunt's file (E2E_DIAGNOSTICS)
