"""Writes fragmentation.json: the frames come from the Python reference
(scripts/r2ptools/rtcan_fragment.py); each reassembly case states by hand what must come out,
and the reference must agree before anything is written. Run: scripts/py tests/vectors/rtcan/fragmentation_gen.py"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from r2ptools import rtcan_fragment as rf  # noqa: E402

OUT = Path(__file__).with_name("fragmentation.json")
DESCRIPTION = (
    "RTCAN fragmentation and reassembly test vectors. Spec: docs/rtcan.md, sections 'Fragmentation' "
    "and 'Reassembly'. Identifiers are 29-bit CAN extended IDs (laxity 6 | message ID 16 | fragment 7), "
    "data is hex. A message of more than 8 bytes carries its transfer CRC (CRC-16/CCITT-FALSE of the "
    "payload, big-endian) after the payload; its frames count down from the frame count to 1; counter 0 "
    "is a single-frame message. 'fragmentation': payload -> frames in transmission order. 'reassembly': "
    "frames fed in order to a reassembler with `slots` slots of `buffer` payload bytes, timeout "
    "`timeout_us` (stale when more than that many microseconds passed since the slot last took a frame), "
    "each frame with its reception time `at` in microseconds and the expected message length `expect_len` "
    "(null = any length); `messages` lists each completed message (payload, without the CRC) with the "
    "index of the frame that completed it; `stats` are the counters after the last frame. Written by "
    "tests/vectors/rtcan/fragmentation_gen.py; checked by the Rust crate's fragment::vectors test and by "
    "tests/test_rtcan_vectors.py."
)


def pattern(n, seed):
    return bytes((i * 7 + seed) & 0xFF for i in range(n))


def frag_case(name, laxity, message, payload):
    return {
        "name": name, "laxity": laxity, "message_id": f"0x{message:04x}", "payload": payload.hex(),
        "frames": [{"id": f"0x{i:08x}", "data": d.hex()} for i, d in rf.fragments(laxity, message, payload)],
    }


def frames(message, payload, laxity=9):
    return rf.fragments(laxity, message, payload)


def reasm(name, feed, messages, stats, slots=4, buffer=1024, timeout=1000, expect=None):
    """feed: [(at, identifier, data)]; messages: [(index of the completing frame, payload)]."""
    r = rf.Reassembler(slots, buffer, timeout)
    got = []
    for k, (at, raw, data) in enumerate(feed):
        m = r.accept(raw, data, at, expect)
        if m is not None:
            got.append((k, m))
    want_stats = dict.fromkeys(rf.STATS, 0) | stats
    assert got == messages, (name, got)
    assert r.stats == want_stats, (name, r.stats)
    return {
        "name": name, "slots": slots, "buffer": buffer, "timeout_us": timeout, "expect_len": expect,
        "frames": [{"at": at, "id": f"0x{raw:08x}", "data": d.hex()} for at, raw, d in feed],
        "messages": [{"after_frame": k, "message_id": f"0x{rf.split(feed[k][1])[1]:04x}", "data": m.hex()}
                     for k, m in messages],
        "stats": want_stats,
    }


def at(t, fs):
    return [(t, i, d) for i, d in fs]


def main():
    frag = [
        frag_case("empty message: one empty frame, fragment 0", 5, 0x1234, b""),
        frag_case("1 byte", 63, 0x0100, bytes([0x42])),
        frag_case("7 bytes", 20, 0x0200, pattern(7, 1)),
        frag_case("8 bytes: one full frame, no CRC", 20, 0x0200, pattern(8, 2)),
        frag_case("9 bytes: 11 with the CRC, 8 + 3", 20, 0x0200, pattern(9, 3)),
        frag_case("14 bytes: 16 with the CRC, two full frames", 1, 0xFFFF, pattern(14, 4)),
        frag_case("15 bytes: the CRC's second byte alone in a third frame", 1, 0xFFFF, pattern(15, 5)),
        frag_case("16 bytes: 3 frames", 1, 0xFFFF, bytes(range(16))),
        frag_case("20 bytes, docs/rtcan.md example identifier on the first frame", 5, 0x1234, bytes([0xAB] * 20)),
        frag_case("HRT laxity 0, 24 bytes", 0, 0x0400, pattern(24, 6)),
        frag_case("1014 bytes: the longest, 127 frames, first fragment 127", 30, 0xABCD, pattern(1014, 7)),
        {"name": "1015 bytes: too long", "laxity": 5, "message_id": "0x1234", "payload_len": 1015, "error": "too_long"},
        {"name": "1024 bytes: too long", "laxity": 5, "message_id": "0x1234", "payload_len": 1024, "error": "too_long"},
    ]
    a20 = pattern(20, 0x9B)
    fa = frames(0x0505, a20)                   # counters 3, 2, 1
    b38 = pattern(38, 0xBA)
    fb = frames(0x0707, b38)                   # counters 5 … 1
    c38 = pattern(38, 0x55)
    fc = frames(0x0707, c38)
    d46 = pattern(46, 0xD9)
    fd = frames(0x0707, d46)                   # counters 6 … 1
    x10, y10 = pattern(10, 0x17), pattern(10, 0x36)
    fx, fy = frames(0x0909, x10), frames(0x0919, y10)
    r = [
        reasm("in order: 3 frames, one message", [(0, *fa[0]), (10, *fa[1]), (20, *fa[2])],
              [(2, a20)], {"completed": 1}),
        reasm("in order with the length known", [(0, *fa[0]), (10, *fa[1]), (20, *fa[2])],
              [(2, a20)], {"completed": 1}, expect=20),
        reasm("empty message", at(0, frames(0x0600, b"", 63)), [(0, b"")], {"completed": 1}),
        reasm("duplicates: first frame, middle frame, and the last frame after completion",
              at(0, [fa[0], fa[0], fa[1], fa[1], fa[2], fa[2]]), [(4, a20)], {"completed": 1, "duplicate": 3}),
        reasm("a single-frame message with the bytes of the previous message's last frame is a new message",
              at(0, [*fa, (rf.identifier(9, 0x0505, 0), fa[2][1])]), [(2, a20), (3, fa[2][1])], {"completed": 2}),
        reasm("gap: frame 3 lost; frame 2 abandons the message, frame 1 is foreign",
              at(0, [fb[0], fb[1], fb[3], fb[4]]), [], {"foreign": 1, "out_of_order": 1}),
        reasm("length known: a message whose first frame was lost is foreign",
              at(0, fb[1:]), [], {"foreign": 4}, expect=38),
        reasm("length unknown: a message whose first frame was lost is rejected by the transfer CRC",
              at(0, fb[1:]), [], {"bad_crc": 1}),
        reasm("truncated: a new first frame (counter above the one expected) before the old message is complete",
              at(0, [fb[0], fb[1], *fd]), [(7, d46)], {"completed": 1, "truncated": 1}),
        reasm("splice: one message's last frames and the next one's first frames lost; the transfer CRC rejects the join",
              at(0, [fb[0], fb[1], *fc[2:]]), [], {"bad_crc": 1}),
        reasm("splice with the length known: rejected by the transfer CRC, the stream's next message delivered",
              at(0, [fb[0], fb[1], *fc[2:], *fc]), [(9, c38)], {"bad_crc": 1, "completed": 1}, expect=38),
        reasm("timed out: more than timeout_us since the last frame taken",
              [(0, *fa[0]), (1000, *fa[1]), (2001, *fa[2])], [], {"foreign": 1, "timed_out": 1}, expect=20),
        reasm("too long for a 16-byte buffer: refused, its other frames foreign",
              at(0, frames(0x0808, pattern(30, 0xF8))), [], {"foreign": 3, "too_long": 1}, slots=1, buffer=16),
        reasm("exactly 16 bytes fit a 16-byte buffer (the CRC is checked, not stored)",
              at(0, frames(0x0808, bytes(range(16)))), [(2, bytes(range(16)))], {"completed": 1}, slots=1, buffer=16),
        reasm("no free slot: the second stream's first frame is dropped, its last frame is foreign; single frames need no slot",
              at(0, [fx[0], fy[0], fy[1], fx[1], *frames(0x0910, bytes([1, 2]), 63)]),
              [(3, x10), (4, bytes([1, 2]))], {"completed": 2, "no_slot": 1, "foreign": 1}, slots=1, buffer=64),
        reasm("two streams interleaved", at(0, [fx[0], fy[0], fy[1], fx[1]]), [(2, y10), (3, x10)], {"completed": 2}),
        reasm("bad length: a short middle frame and an empty last frame are dropped, the message goes on",
              at(0, [(fb[0][0], fb[0][1][:7]), *fb[:4], (fb[4][0], b""), fb[4]]), [(6, b38)],
              {"completed": 1, "bad_length": 2}),
        reasm("bad length with the length known: a last frame one byte too long, a single frame",
              at(0, [fa[0], fa[1], (fa[2][0], fa[2][1] + b"\0"), (rf.identifier(9, 0x0505, 0), fa[2][1]), fa[2]]),
              [(4, a20)], {"completed": 1, "bad_length": 2}, expect=20),
    ]
    doc = {
        "description": DESCRIPTION,
        "constants": {"MAX_PAYLOAD": rf.MAX_PAYLOAD, "MAX_FRAGMENTS": rf.MAX_FRAGMENTS,
                      "MAX_MESSAGE_LEN": rf.MAX_MESSAGE_LEN, "CRC_LEN": rf.CRC_LEN},
        "fragmentation": frag,
        "reassembly": r,
    }
    return json.dumps(doc, indent=1) + "\n"


if __name__ == "__main__":
    OUT.write_text(main())
