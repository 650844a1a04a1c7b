"""Message schemas (firmware/msgs/*.msg): every schema reads, has a fixed size and a stable
type hash, payloads round-trip, and a malformed schema is refused naming file and line."""
import math

import pytest

from r2ptools import msgs


def test_every_schema_reads_with_its_size():
    types = msgs.load()
    assert {"Battery", "Proximity", "Obstacle", "WheelSetpoint", "WheelState", "Twist2D"} <= set(types)
    assert types["Battery"].size == 16
    assert types["Proximity"].size == 4 * 4 + 4 + 1
    assert types["Obstacle"].size == 5          # packed: no padding after the uint8
    for t in types.values():
        assert 0 < t.size <= msgs.MAX_SIZE


def test_type_hash_is_fnv1a_of_the_canonical_text():
    battery = msgs.load()["Battery"]
    assert battery.canonical == "Battery:float32 voltage;float32 current;float32 charge_used;uint32 remaining_s"
    h = 0x811C9DC5
    for b in battery.canonical.encode():
        h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
    assert battery.type_hash == h
    # Any change to a field changes the hash (subscribers with another layout are refused).
    assert msgs.load()["Twist2D"].type_hash != msgs.load()["Battery"].type_hash


def test_payloads_roundtrip_little_endian_packed():
    prox = msgs.load()["Proximity"]
    values = {"distance": [0.5, float("nan"), 1.25, 0.0], "status": [0, 2, 0, 3], "supply_fault": True}
    payload = prox.encode(values)
    assert len(payload) == prox.size
    assert payload[:4] == bytes.fromhex("0000003f")     # 0.5f, little-endian
    back = prox.decode(payload)
    assert msgs.nan_safe_equal(back["distance"], values["distance"]) and math.isnan(back["distance"][1])
    assert back["status"] == [0, 2, 0, 3] and back["supply_fault"] is True


def test_wrong_payload_size_and_fields_are_refused():
    battery = msgs.load()["Battery"]
    with pytest.raises(ValueError, match="Battery is 16 bytes, got 15"):
        battery.decode(bytes(15))
    with pytest.raises(ValueError, match=r"missing fields \['remaining_s'\]"):
        battery.encode({"voltage": 1.0, "current": 0.0, "charge_used": 0.0})


@pytest.mark.parametrize("text, error", [
    ("float32 x\nstring name\n", r"Bad.msg:2: unknown type 'string'"),
    ("float32 x\nfloat32 x\n", r"Bad.msg:2: field 'x' appears twice"),
    ("float32 X\n", r"Bad.msg:1: cannot read 'float32 X'"),
    ("# only a comment\n", r"Bad.msg: no fields"),
    ("uint8[2000] big\n", r"Bad.msg:1: array length 2000 out of range"),
])
def test_malformed_schema_names_file_line_and_fix(tmp_path, text, error):
    (tmp_path / "Bad.msg").write_text(text)
    with pytest.raises(msgs.SchemaError, match=error):
        msgs.load(tmp_path)
