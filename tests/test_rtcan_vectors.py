"""RTCAN's fragmentation vectors (tests/vectors/rtcan/fragmentation.json), checked by the Python
reference written from docs/rtcan.md (scripts/r2ptools/rtcan_fragment.py) as the Rust crate's
fragment::vectors test checks them: two implementations, one wire format."""
import importlib.util
import json
from pathlib import Path

import pytest

from r2ptools import rtcan_fragment as rf

VECTORS = Path(__file__).parent / "vectors" / "rtcan"
DOC = json.loads((VECTORS / "fragmentation.json").read_text())


def test_transfer_crc_is_crc16_ccitt_false():
    assert rf.crc16(b"123456789") == 0x29B1          # the catalogue's check value
    payload = bytes(range(40))
    assert rf.crc16(rf.wire(payload)) == 0            # payload + CRC (big-endian): residue 0
    assert rf.wire(bytes(8)) == bytes(8)              # single frames carry no CRC


def test_constants_match_the_spec():
    assert DOC["constants"] == {"MAX_PAYLOAD": 8, "MAX_FRAGMENTS": 127, "MAX_MESSAGE_LEN": 1014, "CRC_LEN": 2}


@pytest.mark.parametrize("case", DOC["fragmentation"], ids=lambda c: c["name"])
def test_fragmentation_vector(case):
    payload = bytes.fromhex(case["payload"]) if "payload" in case else bytes(case["payload_len"])
    if case.get("error") == "too_long":
        with pytest.raises(ValueError):
            rf.fragments(case["laxity"], int(case["message_id"], 16), payload)
        return
    got = [(f"0x{i:08x}", d.hex()) for i, d in rf.fragments(case["laxity"], int(case["message_id"], 16), payload)]
    assert got == [(f["id"], f["data"]) for f in case["frames"]]


@pytest.mark.parametrize("case", DOC["reassembly"], ids=lambda c: c["name"])
def test_reassembly_vector(case):
    r = rf.Reassembler(case["slots"], case["buffer"], case["timeout_us"])
    got = []
    for k, f in enumerate(case["frames"]):
        m = r.accept(int(f["id"], 16), bytes.fromhex(f["data"]), f["at"], case["expect_len"])
        if m is not None:
            got.append((k, m.hex()))
    assert got == [(m["after_frame"], m["data"]) for m in case["messages"]]
    assert r.stats == case["stats"]


def test_the_committed_vectors_are_the_generators_output():
    spec = importlib.util.spec_from_file_location("gen", VECTORS / "fragmentation_gen.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.main() == (VECTORS / "fragmentation.json").read_text()


def test_a_splice_is_rejected_and_a_repeated_last_frame_is_not_a_message():
    a, b = bytes(range(20)), bytes(range(100, 120))
    fa, fb = rf.fragments(9, 0x77, a), rf.fragments(9, 0x77, b)
    r = rf.Reassembler(1, 64, 1000)
    assert [r.accept(i, d, 0, None) for i, d in [fa[0], fa[1], fb[2]]] == [None] * 3
    assert r.stats["bad_crc"] == 1
    assert [r.accept(i, d, 1, None) for i, d in [*fb, fb[2]]] == [None, None, b, None]
    assert r.stats["duplicate"] == 1
