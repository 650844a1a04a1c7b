"""r2p-emu in real time: the built-in demo robot runs against the wall clock with a socketcand
server, so python-can sees the boards' heartbeats and syncs and its frames go on the virtual
bus. Everything on 127.0.0.1, every process bounded and killed."""
from __future__ import annotations

import re
import socket
import time
from pathlib import Path

import pytest

from conftest import ROOT, SocketcandProcess, free_port, run

can = pytest.importorskip("can")

FIRMWARE = ROOT / "firmware"
BINARY = FIRMWARE / "target" / "debug" / "r2p-emu"
HEARTBEAT = 0x11


@pytest.fixture(scope="module")
def binary() -> Path:
    p = run(["cargo", "build", "-q", "-p", "r2p-emu"], cwd=FIRMWARE, timeout=600)
    assert p.returncode == 0, p.stdout
    return BINARY


def decode(msg):
    """(laxity, message id, fragment) of a 29-bit RTCAN identifier."""
    i = msg.arbitration_id
    return i >> 23, (i >> 7) & 0xFFFF, i & 0x7F


class Emu(SocketcandProcess):
    """A running `r2p-emu demo --realtime`."""

    def __init__(self, binary: Path, *extra: str):
        super().__init__([str(binary), "demo", "--realtime", *extra], "r2p-emu")


@pytest.fixture
def emu(binary):
    started: list[Emu] = []

    def start(*extra: str) -> Emu:
        started.append(Emu(binary, *extra))
        return started[-1]

    try:
        yield start
    finally:
        for e in started:
            e.kill()


def collect(bus, seconds: float, until=None) -> list:
    """Frames received for at most `seconds`, or until `until(frames)` holds."""
    frames = []
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        m = bus.recv(timeout=max(0.0, deadline - time.monotonic()))
        if m is not None:
            frames.append(m)
            if until is not None and until(frames):
                break
    return frames


def heartbeat_streams(frames) -> set[int]:
    """Management streams (message id, low byte 0) that carried a heartbeat's first fragment."""
    streams = set()
    for m in frames:
        laxity, msg, _ = decode(m)
        # The first fragment of a heartbeat message: payload type byte 0x11.
        if m.is_extended_id and msg >= 0x100 and msg & 0xFF == 0 and m.data[:1] == bytes([HEARTBEAT]):
            streams.add(msg)
    return streams


def is_sync(m) -> bool:
    laxity, msg, frag = decode(m)
    return m.is_extended_id and laxity == 0 and msg < 0x100 and frag == 0


def test_help_names_the_options(binary):
    p = run([str(binary), "--help"], timeout=30)
    assert p.returncode == 0
    for option in ("demo", "--realtime", "--socketcand", "--log", "--seconds", "127.0.0.1:29536"):
        assert option in p.stdout


def test_python_can_sees_heartbeats_and_syncs_within_2_s(emu):
    e = emu()
    bus = e.bus()
    try:
        t0 = time.monotonic()
        frames = collect(bus, 2.0, until=lambda fs: len(heartbeat_streams(fs)) >= 3 and any(map(is_sync, fs)))
        took = time.monotonic() - t0
    finally:
        bus.shutdown()
    assert len(heartbeat_streams(frames)) >= 3, f"{len(frames)} frames, streams {heartbeat_streams(frames)}"
    syncs = [m for m in frames if is_sync(m)]
    assert syncs, "no sync frame"
    assert took < 2.0
    err = e.stop()
    assert "stopped (signal)" in err, err


def test_syncs_come_every_10_ms_of_real_time(emu):
    e = emu()
    bus = e.bus()
    try:
        frames = collect(bus, 1.0)
    finally:
        bus.shutdown()
    syncs = [m for m in frames if is_sync(m)]
    # 10 ms cycles paced against the wall clock: about 100 syncs per second.
    assert 60 <= len(syncs) <= 130, len(syncs)
    e.stop()


def test_frames_from_python_can_go_on_the_virtual_bus(emu):
    e = emu()
    a, b = e.bus(), e.bus()
    ext = can.Message(arbitration_id=0x1FFFFF00, data=bytes.fromhex("C0FFEE"), is_extended_id=True)
    std = can.Message(arbitration_id=0x123, data=[1], is_extended_id=False)
    try:
        assert collect(b, 2.0, until=lambda fs: True), "no traffic"
        a.send(ext)
        a.send(std)
        # Another client gets both straight from the hub.
        got = collect(b, 2.0, until=lambda fs: sum(m.arbitration_id in (0x1FFFFF00, 0x123) for m in fs) == 2)
    finally:
        a.shutdown()
        b.shutdown()
    mine = [(m.arbitration_id, m.is_extended_id, bytes(m.data)) for m in got if m.arbitration_id in (0x1FFFFF00, 0x123)]
    assert mine == [(0x1FFFFF00, True, bytes(ext.data)), (0x123, False, b"\x01")], mine
    time.sleep(0.2)
    err = e.stop()
    m = re.search(r"(\d+) injected from tools \((\d+) sent on the virtual bus\), (\d+) standard-ID frames dropped", err)
    assert m, err
    assert (int(m[1]), int(m[2]), int(m[3])) == (1, 1, 1), err


def test_stops_when_stdin_closes_and_after_seconds(emu, binary):
    e = emu()
    _, err = e.proc.communicate(input="", timeout=10)
    assert e.proc.returncode == 0 and "standard input closed" in err, err
    p = run([str(binary), "demo", "--realtime", "--socketcand", f"127.0.0.1:{free_port()}", "--seconds", "0.5", "--no-stdin"],
            timeout=30)
    assert p.returncode == 0 and "stopped (--seconds) at 0.500 s" in p.stdout, p.stdout


def test_an_address_in_use_is_a_clear_error(binary):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        p = run([str(binary), "demo", "--realtime", "--socketcand", f"127.0.0.1:{port}"], timeout=30)
    assert p.returncode == 2
    assert f"127.0.0.1:{port} is already in use" in p.stdout, p.stdout


def test_virtual_time_logs_are_deterministic(binary, tmp_path):
    logs = []
    for name in ("a.log", "b.log"):
        path = tmp_path / name
        p = run([str(binary), "demo", "--seconds", "0.5", "--log", str(path)], timeout=60)
        assert p.returncode == 0, p.stdout
        logs.append(path.read_bytes())
    assert logs[0] == logs[1] and len(logs[0]) > 1000
    records = list(can.LogReader(str(tmp_path / "a.log")))
    assert len(records) > 100 and all(r.is_extended_id for r in records)
    assert heartbeat_streams(records) and any(map(is_sync, records))
