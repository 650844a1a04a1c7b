"""RTCAN fragmentation and reassembly (docs/rtcan.md, "Fragmentation" and "Reassembly"), written
from the spec independently of the Rust crate, so that the shared vectors
(tests/vectors/rtcan/fragmentation.json) are checked by two implementations.

A message of at most 8 bytes is one frame with fragment counter 0. A longer one is its payload
followed by its transfer CRC (CRC-16/CCITT-FALSE, big-endian), cut into 8-byte frames whose
counters run from the frame count down to 1.
"""
from __future__ import annotations

from dataclasses import dataclass, field

MAX_PAYLOAD = 8
CRC_LEN = 2
MAX_FRAGMENTS = 127
MAX_MESSAGE_LEN = MAX_FRAGMENTS * MAX_PAYLOAD - CRC_LEN
MIN_MULTI_WIRE = MAX_PAYLOAD + 1 + CRC_LEN


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final XOR)."""
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def identifier(laxity: int, message: int, fragment: int) -> int:
    """The 29-bit identifier: laxity 6 | message ID 16 | fragment 7."""
    return laxity << 23 | message << 7 | fragment


def split(raw: int) -> tuple[int, int, int]:
    return raw >> 23 & 0x3F, raw >> 7 & 0xFFFF, raw & 0x7F


def wire(payload: bytes) -> bytes:
    """The bytes a message puts on the wire: the payload, and its CRC if it needs two frames."""
    if len(payload) <= MAX_PAYLOAD:
        return bytes(payload)
    return bytes(payload) + crc16(payload).to_bytes(2, "big")


def frame_count(length: int) -> int | None:
    if length > MAX_MESSAGE_LEN:
        return None
    return max(1, -(-len(wire(bytes(length))) // MAX_PAYLOAD))


def fragments(laxity: int, message: int, payload: bytes) -> list[tuple[int, bytes]]:
    """(identifier, data) of each frame, first to last; ValueError if the payload is too long."""
    n = frame_count(len(payload))
    if n is None:
        raise ValueError(f"{len(payload)} bytes: longer than {MAX_MESSAGE_LEN}")
    w = wire(payload)
    if n == 1:
        return [(identifier(laxity, message, 0), w)]
    return [(identifier(laxity, message, n - k), w[8 * k:8 * k + 8]) for k in range(n)]


STATS = ("completed", "duplicate", "foreign", "out_of_order", "truncated", "timed_out",
         "too_long", "no_slot", "bad_length", "bad_crc")


@dataclass
class _Slot:
    state: str = "free"          # free | receiving | between
    message: int = 0
    first: int = 0
    next: int = 0
    last: int = 0
    last_at: int = 0
    last_data: bytes = b""
    data: bytearray = field(default_factory=bytearray)


class Reassembler:
    """The reassembler of the spec: `slots` slots of `buffer` payload bytes, a timeout."""

    def __init__(self, slots: int, buffer: int, timeout_us: int):
        self.slots = [_Slot() for _ in range(slots)]
        self.buffer = buffer
        self.timeout = timeout_us
        self.stats = dict.fromkeys(STATS, 0)

    def expire(self, now: int) -> None:
        for s in self.slots:
            if s.state != "free" and max(0, now - s.last_at) > self.timeout:
                if s.state == "receiving":
                    self.stats["timed_out"] += 1
                s.state = "free"

    def accept(self, raw: int, data: bytes, at: int, expect: int | None) -> bytes | None:
        self.expire(at)
        _, message, c = split(raw)
        slot = next((s for s in self.slots if s.state != "free" and s.message == message), None)
        if slot is not None and slot.state == "receiving":
            return self._continue(slot, c, data, at, expect)
        if slot is not None and slot.state == "between":
            if c == slot.last and data == slot.last_data:
                self.stats["duplicate"] += 1
                return None
            if 0 < c < slot.last:
                self.stats["foreign"] += 1
                slot.last, slot.last_data, slot.last_at = c, data, at
                return None
        return self._start(slot, message, c, data, at, expect)

    def _first(self, c: int, n: int, expect: int | None) -> tuple[str | None, int]:
        """(refusal, fewest payload bytes) of a frame taken as a message's first."""
        if expect is None:
            if c == 0:
                return None, n
            if c == 1:
                return "foreign", 0
            if n != MAX_PAYLOAD:
                return "bad_length", 0
            return None, max((c - 1) * MAX_PAYLOAD + 1, MIN_MULTI_WIRE) - CRC_LEN
        frames = frame_count(expect)
        if frames is None:
            return "too_long", 0
        if frames == 1:
            return (None, expect) if c == 0 and n == expect else ("bad_length", 0)
        if c == 0 or c > frames or (c == frames and n != MAX_PAYLOAD):
            return "bad_length", 0
        if c < frames:
            return "foreign", 0
        return None, expect

    def _start(self, slot, message, c, data, at, expect):
        refusal, fewest = self._first(c, len(data), expect)
        if refusal is None and fewest > self.buffer:
            refusal = "too_long"
        if refusal is not None:
            self.stats[refusal] += 1
            if refusal == "too_long":
                target = slot or (self._allocate() if c > 1 else None)
                if target is not None:
                    target.message = message
                    target.state = "between" if c > 1 else "free"
                    target.last, target.last_data, target.last_at = c, data, at
            return None
        if c == 0:
            self.stats["completed"] += 1
            return bytes(data)
        target = slot or self._allocate()
        if target is None:
            self.stats["no_slot"] += 1
            return None
        target.message, target.state = message, "receiving"
        target.first, target.next = c, c - 1
        target.data = bytearray(data)
        target.last, target.last_data, target.last_at = c, data, at
        return None

    def _continue(self, slot, c, data, at, expect):
        if c == slot.next:
            before = (slot.first - 1) * MAX_PAYLOAD
            if c > 1:
                ok = len(data) == MAX_PAYLOAD
            elif expect is None:
                ok = len(data) >= 1 and before + len(data) >= MIN_MULTI_WIRE
            else:
                ok = len(wire(bytes(expect))) - before == len(data)
            if not ok:
                self.stats["bad_length"] += 1
                return None
            slot.last, slot.last_data, slot.last_at = c, data, at
            slot.data += data
            if len(slot.data) > self.buffer + CRC_LEN:
                self.stats["too_long"] += 1
                slot.state = "between"
                return None
            if c > 1:
                slot.next = c - 1
                return None
            slot.state, slot.last = "between", 1
            if crc16(bytes(slot.data)) != 0:
                self.stats["bad_crc"] += 1
                return None
            self.stats["completed"] += 1
            return bytes(slot.data[:-CRC_LEN])
        if c == slot.next + 1 and data == slot.last_data:
            self.stats["duplicate"] += 1
            return None
        if 0 < c < slot.next:
            self.stats["out_of_order"] += 1
            slot.state = "between"
            slot.last, slot.last_data, slot.last_at = c, data, at
            return None
        refusal, _ = self._first(c, len(data), expect)
        if refusal in ("foreign", "bad_length"):
            self.stats[refusal] += 1
            return None
        self.stats["truncated"] += 1
        slot.state = "free"
        return self._start(slot, slot.message, c, data, at, expect)

    def _allocate(self):
        free = next((s for s in self.slots if s.state == "free"), None)
        if free is not None:
            return free
        idle = [s for s in self.slots if s.state == "between"]
        return min(idle, key=lambda s: s.last_at) if idle else None
