"""Component metadata (autopilot/mavlink/component_metadata.py) on its own: the two messages' wire format
against pymavlink's own generator, and the JSON documents against the schemas ground stations read.

The messages are not in pymavlink 2.4.50's common dialect, so their fields (as in MAVLink's
common.xml) go through pymavlink's mavgen here: a wrong CRC extra or field order would make MAVSDK
and QGroundControl drop every COMPONENT_METADATA.  Serving them over the link is
tests/test_gcs_link_files.py.
"""

from __future__ import annotations

import json

import pytest

from autopilot.mavlink import component_metadata as cm
from autopilot.param_catalogue import default_store
from autopilot.parameters import ParamDef, ParameterStore, ParamType
from mavsim_core.mavftp import crc32

# MAVLink common.xml, messages 395 and 397 (fields in their declared order)
DEFINITIONS = """<?xml version="1.0"?>
<mavlink><version>3</version><messages>
<message id="395" name="COMPONENT_INFORMATION"><description>x</description>
 <field type="uint32_t" name="time_boot_ms" units="ms">x</field>
 <field type="uint32_t" name="general_metadata_file_crc">x</field>
 <field type="char[100]" name="general_metadata_uri">x</field>
 <field type="uint32_t" name="peripherals_metadata_file_crc">x</field>
 <field type="char[100]" name="peripherals_metadata_uri">x</field>
</message>
<message id="397" name="COMPONENT_METADATA"><description>x</description>
 <field type="uint32_t" name="time_boot_ms" units="ms">x</field>
 <field type="uint32_t" name="file_crc">x</field>
 <field type="char[100]" name="uri">x</field>
</message>
</messages></mavlink>
"""
# parameter.schema.json's properties of a parameter; QGroundControl reads these names
SCHEMA_KEYS = {
    "name", "type", "shortDesc", "longDesc", "units", "default", "decimalPlaces", "min", "max", "increment",
    "rebootRequired", "group", "category", "volatile", "values", "bitmask", "readOnly",
}  # fmt: skip


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """The two message definitions parsed by pymavlink's generator: {id: message}."""
    from pymavlink.generator import mavparse

    xml = tmp_path_factory.mktemp("xml") / "component.xml"
    xml.write_text(DEFINITIONS)
    return {m.id: m for m in mavparse.MAVXML(str(xml), mavparse.PROTOCOL_2_0).message}


@pytest.mark.parametrize("cls", [cm.ComponentMetadataMessage, cm.ComponentInformationMessage])
def test_messages_match_mavlink_definitions(generated, cls):
    m = generated[cls.id]
    assert cls.msgname == m.name and cls.crc_extra == m.crc_extra
    assert cls.fieldnames == [f.name for f in m.fields]
    assert cls.ordered_fieldnames == [f.name for f in m.ordered_fields]
    assert cls.unpacker.size == m.wire_length


def test_message_packs_and_round_trips():
    from pymavlink.dialects.v20 import common as mavlink

    enc = mavlink.MAVLink(None, 1, 1)
    raw = cm.metadata_message(cm.MSG_ID_COMPONENT_METADATA, 0xDEADBEEF, 5_000_000).pack(enc)
    time_ms, crc, uri = cm.ComponentMetadataMessage.unpacker.unpack(raw[10:-2].ljust(108, b"\0"))
    assert (time_ms, crc, uri.rstrip(b"\0")) == (5000, 0xDEADBEEF, cm.GENERAL_URI.encode())
    assert cm.metadata_message(0, 1, 0) is None


def test_parameter_metadata_follows_the_schema_and_the_store():
    store = default_store()
    store.set_defaults({"MPC_XY_P": 1.2})  # a vehicle's default: the metadata shows it
    params = cm.parameter_metadata(store)
    assert params["version"] == 1  # QGroundControl reads version 1 only
    by_name = {p["name"]: p for p in params["parameters"]}
    assert list(by_name) == store.names()
    for name, p in by_name.items():
        d = store.definition(name)
        assert set(p) <= SCHEMA_KEYS and p["type"] in ("Int32", "Float")
        assert p["min"] <= p["default"] <= p["max"]
        assert p["shortDesc"] and d.description.startswith(p["shortDesc"])
        assert p.get("units", "") == ("" if d.unit == "-" else d.unit)
        if p["type"] == "Int32":
            assert all(isinstance(p[k], int) for k in ("min", "max", "default")) and p["decimalPlaces"] == 0
    assert by_name["MPC_XY_P"]["default"] == 1.2
    assert by_name["MPC_XY_P"]["group"] == "Multicopter Position Control"


def test_descriptions_and_decimals():
    store = ParameterStore(
        [
            ParamDef("TST_A", ParamType.REAL32, 0.125, 0.0, 2.0, "m", "Short: then the long part"),
            ParamDef("TST_B", ParamType.INT32, 3, 0, 9, "-", "Only one sentence", reboot_required=True),
        ]
    )
    a, b = cm.parameter_metadata(store)["parameters"]
    assert (a["shortDesc"], a["longDesc"], a["decimalPlaces"], a["group"]) == (
        "Short", "Short: then the long part", 3, "TST",
    )  # fmt: skip
    assert (b["shortDesc"], b["longDesc"], b["rebootRequired"]) == (
        "Only one sentence", "Only one sentence Applies at the next start.", True,
    )  # fmt: skip
    assert "units" not in b


def test_general_file_names_the_parameter_file_with_its_crc():
    files = cm.metadata_files(default_store(), "mavsim", "quad_x", "1.14.0")
    general = json.loads(files.files[cm.GENERAL_FILE])
    assert files.general_crc == crc32(files.files[cm.GENERAL_FILE])
    assert general["metadataTypes"] == [
        {"type": 1, "uri": cm.PARAMETER_URI, "fileCrc": crc32(files.files[cm.PARAMETER_FILE])}
    ]
    assert cm.firmware_version(0x010E00FF) == "1.14.0"
