"""The flight controller's parameter store: PX4's names, cross-parameter rules, vehicle defaults.

A refused set changes nothing; rules on missing parameters are dropped; a vehicle's default set
must keep the rules too.  Parameter files are tested in tests/test_param_files.py.
"""

from __future__ import annotations

import pytest

from autopilot.parameters import FLIGHT_FLOORS, RULES, ParamDef, ParamError, ParameterStore, ParamRule, ParamType

from float32 import f32  # tests/float32.py

# --------------------------------------------------------------------------- cross-parameter rules


def test_px4_names_of_the_issue_are_declared(store):
    for name in (
        "MC_ROLL_P",
        "MC_ROLLRATE_P",
        "MC_ROLLRATE_I",
        "MC_ROLLRATE_D",
        "MC_YAWRATE_P",
        "MPC_XY_P",
        "MPC_XY_VEL_P_ACC",
        "MPC_XY_VEL_I_ACC",
        "MPC_XY_VEL_D_ACC",
        "MPC_Z_P",
        "MPC_Z_VEL_P_ACC",
        "MPC_Z_VEL_I_ACC",
        "MPC_Z_VEL_D_ACC",
        "MPC_XY_VEL_MAX",
        "MPC_Z_VEL_MAX_UP",
        "MPC_Z_VEL_MAX_DN",
        "MPC_LAND_SPEED",
        "MPC_TILTMAX_AIR",
        "MIS_TAKEOFF_ALT",
        "RTL_RETURN_ALT",
        "COM_DISARM_LAND",
        "SYS_AUTOSTART",
    ):
        assert name in store, name
    assert {str(r) for r in store.rules()} == {str(r) for r in RULES}  # every rule's parameters exist


@pytest.mark.parametrize(
    ("name", "value", "why"),
    [
        ("MPC_LAND_SPEED", 1.8, "MPC_LAND_SPEED 1.8 refused: must be <= MPC_Z_VEL_MAX_DN (1.5 m/s)"),
        ("MPC_Z_VEL_MAX_DN", 0.6, "MPC_Z_VEL_MAX_DN 0.6 refused: must be >= MPC_LAND_SPEED (0.7 m/s)"),
        ("MPC_THR_MIN", 0.5, None),  # allowed: 0.5 < 1.0
        ("MPC_TKO_SPEED", 3.5, "must be <= MPC_Z_VEL_MAX_UP"),
        ("MPC_XY_CRUISE", 6.0, "must be <= MPC_XY_VEL_MAX"),
        ("MPC_XY_VEL_MAX", 2.0, "must be >= MPC_XY_CRUISE"),
        ("LNDMC_Z_VEL_MAX", 0.7, "must be < MPC_LAND_SPEED"),
    ],
)
def test_rules_refuse_and_change_nothing(store, name, value, why):
    seen = []
    store.subscribe(lambda n, v: seen.append(n))
    before = store.values()
    if why is None:
        store.set(name, value)
        assert store.get(name) == value
        return
    with pytest.raises(ParamError, match=why.replace("(", r"\(").replace(")", r"\)")):
        store.set(name, value)
    assert store.values() == before and seen == []


def test_rule_with_strict_order_and_both_sides():
    defs = {n: ParamDef(n, ParamType.REAL32, d, 0.0, 1.0, "norm", n) for n, d in (("T_LO", 0.2), ("T_HI", 0.8))}
    store = ParameterStore(defs, rules=(ParamRule("T_LO", "<", "T_HI", "test"), ParamRule("T_LO", "<", "NOPE", "x")))
    assert [str(r) for r in store.rules()] == ["T_LO < T_HI"]  # rules on missing parameters are dropped
    with pytest.raises(ParamError, match="T_LO 0.8 refused: must be < T_HI"):
        store.set("T_LO", 0.8)
    store.set("T_HI", 1.0)
    store.set("T_LO", 0.8)
    with pytest.raises(ValueError, match="declared defaults break the rule T_HI < T_LO"):
        ParameterStore(defs, rules=(ParamRule("T_HI", "<", "T_LO", "backwards"),))
    with pytest.raises(ValueError, match="operator"):
        ParamRule("T_LO", ">", "T_HI", "no")


def test_vehicle_defaults_replace_declared_ones(store):
    seen = []
    store.subscribe(lambda n, v: seen.append((n, v)))
    store.set_defaults({"SYS_AUTOSTART": 6001, "MPC_XY_P": 1.1})
    assert store.get("SYS_AUTOSTART") == 6001 and store.default("SYS_AUTOSTART") == 6001
    assert store.changed() == {} and seen == [("SYS_AUTOSTART", 6001), ("MPC_XY_P", 1.1)]
    store.set("MPC_XY_P", f32(1.1))  # the default as it comes over MAVLink (float32) is still the default
    assert store.changed() == {}
    store.set("MPC_XY_P", 0.95)
    assert store.changed() == {"MPC_XY_P": 0.95}
    before = store.values()
    with pytest.raises(ParamError, match="default set breaks the rule MPC_LAND_SPEED <= MPC_Z_VEL_MAX_DN"):
        store.set_defaults({"MPC_LAND_SPEED": 1.8})
    with pytest.raises(ParamError, match="outside range"):
        store.set_defaults({"MPC_Z_VEL_MAX_DN": 2.0, "MPC_XY_P": 9.0})
    assert store.values() == before
    store.set_defaults({"MPC_LAND_SPEED": 1.8, "MPC_Z_VEL_MAX_DN": 2.0})  # together they are fine
    assert store.get("MPC_LAND_SPEED") == 1.8


# --------------------------------------------------------------------------- gains' floors while armed


def test_flight_critical_gains_have_floors_while_armed(store):
    """Issue 18, finding 6: MC_ROLLRATE_P = 0 (in range) was accepted in flight.  Armed, the gains of
    FLIGHT_FLOORS are refused below their floor (a fraction of the default) and nothing changes; raising
    them stays allowed (live tuning); disarmed, any declared value is accepted."""
    armed = [True]
    store.armed = lambda: armed[0]
    default = store.get("MC_ROLLRATE_P")
    for low in (0.0, 0.4 * default):
        with pytest.raises(ParamError, match="MC_ROLLRATE_P .* refused while armed: at least 6"):
            store.set("MC_ROLLRATE_P", low)
    assert store.get("MC_ROLLRATE_P") == default
    assert store.set("MC_ROLLRATE_P", f32(0.5 * default)) == f32(0.5 * default)  # the floor itself (float32)
    assert store.set("MC_ROLLRATE_P", 10 * default) == 10 * default  # up: within the declared range
    with pytest.raises(ParamError, match="MC_PITCH_P .* refused while armed"):
        store.set("MC_PITCH_P", 0.0)
    with pytest.raises(ParamError, match="MC_YAWRATE_MAX .* refused while armed"):
        store.set("MC_YAWRATE_MAX", 0.0)
    store.set("IMU_GYRO_CUTOFF", 0.0)  # 0: no filter, which flies
    with pytest.raises(ParamError, match=r"IMU_GYRO_CUTOFF 1\.5 refused while armed: at least 7\.5 or 0"):
        store.set("IMU_GYRO_CUTOFF", 1.5)
    assert store.set("MC_ROLLRATE_I", 0.0) == 0.0  # not a floored gain
    armed[0] = False
    assert store.set("MC_ROLLRATE_P", 0.0) == 0.0 and store.set("IMU_GYRO_CUTOFF", 1.5) == 1.5
    armed[0] = True  # already below: may be raised, not set lower still
    with pytest.raises(ParamError):
        store.set("MC_ROLLRATE_P", 1.0)
    assert store.set("MC_ROLLRATE_P", default) == default


def test_floors_follow_the_vehicle_defaults_and_every_floor_names_a_declared_gain(store):
    assert {f.name for f in FLIGHT_FLOORS} <= set(store.names())
    assert all(0 < f.fraction < 1 for f in FLIGHT_FLOORS)
    store.set_defaults({"MC_ROLL_P": 8.0})
    store.armed = lambda: True
    with pytest.raises(ParamError, match="at least 2 until disarmed"):  # 0.25 of the vehicle's 8
        store.set("MC_ROLL_P", 1.9)
    assert store.set("MC_ROLL_P", 2.0) == 2.0
