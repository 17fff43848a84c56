"""Fixtures shared by the unit-test files (pytest finds them here by name).

Instance numbers of tests that bind ports are in ``instances.py`` beside this file.
"""

from __future__ import annotations

import pytest

from autopilot.param_catalogue import default_store
from params.vehicle import load_vehicle


@pytest.fixture(scope="module")
def quad():
    """The quad_x vehicle file (params/vehicles/quad_x.toml)."""
    return load_vehicle("quad_x")


@pytest.fixture
def params():
    """A fresh parameter store with every declared parameter at its default."""
    return default_store()
