"""The parameter catalogue (autopilot.param_catalogue) and its generated reference docs/parameters.md.

The Markdown file is generated from the code; this test fails when the two disagree, and
checks what every declaration must have: a name of at most 16 characters (MAVLink's
param_id), declared once, a unit (or none), a description and a default within its range.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

from autopilot import param_catalogue
from autopilot.parameters import RULES
from mavsim_core.param_encoding import ParamType

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "parameters.md"
REGENERATE = "python -m autopilot.param_catalogue --markdown > docs/parameters.md"

# The unit spellings in use, PX4's where PX4 has one.  "" (and "-", which five derivative gains
# use) for dimensionless values; "norm" for a fraction of full scale; "SD" for standard deviations.
UNITS = {
    "",
    "m^2",  # variances of the landing-target estimator (LTEST_*, PX4's units)
    "s^2",  # PLD_CUT_LEAD: metres of aim per m/s^2 of thrust (autopilot/navigation/cut_lead.py)
    "(m/s)^2",
    "(m/s^2)^2",
    "tan(rad)^2",
    "-",
    "norm",
    "SD",
    "s",
    "ms",
    "Hz",
    "m",
    "m/s",
    "m/s^2",
    "m/s^3",
    "rad",
    "rad/s",
    "rad/s^2",
    "deg",
    "deg/s",
    "deg/s^2",  # MPC_YAWRAUTO_ACC (PX4's unit)
    "1/s",
    "1/s^2",
    "%",
    "V",
    "A",
    "mAh",
    "gauss",
}


def test_docs_parameters_md_is_what_the_code_generates():
    assert DOC.exists(), f"docs/parameters.md is missing: {REGENERATE}"
    assert DOC.read_text() == param_catalogue.markdown(), f"docs/parameters.md is out of date: {REGENERATE}"


def test_markdown_from_the_command_line_is_the_file():
    out = subprocess.run(
        [sys.executable, "-m", "autopilot.param_catalogue", "--markdown"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    assert out == DOC.read_text()


def test_every_parameter_is_in_the_table_once():
    names = re.findall(r"^\| `([A-Z0-9_]+)` \|", DOC.read_text(), flags=re.MULTILINE)
    assert names == sorted(param_catalogue.catalogue())
    assert len(names) == len(set(names))


def test_every_declaration_is_complete_and_consistent():
    cat = param_catalogue.catalogue()
    assert len(cat) > 50
    for name, d in cat.items():
        assert d.name == name
        assert re.fullmatch(r"[A-Z][A-Z0-9_]*", name) and len(name) <= 16, name  # param_id is 16 characters
        assert isinstance(d.ptype, ParamType), name
        assert isinstance(d.unit, str) and d.unit == d.unit.strip() and d.unit in UNITS, (name, d.unit)
        assert d.description.strip() and "|" not in d.description, name
        assert all(math.isfinite(v) for v in (d.default, d.min, d.max)), name
        assert d.min <= d.default <= d.max, name
        if d.ptype is ParamType.INT32:
            assert all(float(v).is_integer() for v in (d.default, d.min, d.max)), name
            assert -(2**31) <= d.min and d.max <= 2**31 - 1, name


def test_no_name_is_declared_by_two_modules():
    """A module may list a parameter that another module defines (the flight tasks list position
    control's speed limits): the same object, so each name is still defined in one place."""
    counts = Counter(d.name for d in {id(d): d for group in param_catalogue._MODULE_PARAMS for d in group}.values())
    assert [n for n, k in counts.items() if k > 1] == []


def test_rules_name_declared_parameters_and_hold_at_the_defaults():
    cat = param_catalogue.catalogue()
    store = param_catalogue.default_store()
    for r in RULES:
        assert r.lhs in cat and r.rhs in cat, r
        lhs, rhs = store.get(r.lhs), store.get(r.rhs)
        assert (lhs < rhs) if r.op == "<" else (lhs <= rhs), r
        assert f"- `{r.lhs} {r.op} {r.rhs}`: {r.why}" in DOC.read_text()
