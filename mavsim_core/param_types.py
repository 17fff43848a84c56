"""The one parameter-type enum of the stack: INT32 or REAL32, the two types PX4 parameters have.

Kept apart from the MAVLink encoding (:mod:`mavsim_core.param_encoding`) so that the parameter
registry, and the controllers that define parameters, import no MAVLink library.
"""

from __future__ import annotations

from enum import Enum

# MAV_PARAM_TYPE numbers of the two types (MAVLink common.xml, enum MAV_PARAM_TYPE)
MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9


class ParamType(str, Enum):
    """A parameter's type: its name compares equal to the string (``ParamType.INT32 == "INT32"``)."""

    INT32 = "INT32"
    REAL32 = "REAL32"

    def __str__(self) -> str:
        return self.value

    @property
    def mav_type(self) -> int:
        """The MAV_PARAM_TYPE number PARAM_VALUE carries for this type."""
        return MAV_PARAM_TYPE_INT32 if self is ParamType.INT32 else MAV_PARAM_TYPE_REAL32

    @classmethod
    def from_mav_type(cls, mav_type: int) -> "ParamType":
        """INT32 or REAL32 for their MAV_PARAM_TYPE numbers; ValueError for any other."""
        if mav_type == MAV_PARAM_TYPE_INT32:
            return cls.INT32
        if mav_type == MAV_PARAM_TYPE_REAL32:
            return cls.REAL32
        raise ValueError(f"unsupported MAV_PARAM_TYPE {mav_type}")
