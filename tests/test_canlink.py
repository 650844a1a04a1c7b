"""r2p-canlink: CAN tools join the emulated bus over TCP (socketcand protocol) and its traffic
is logged in candump format that python-can and can-utils read. Everything on 127.0.0.1."""
from __future__ import annotations

import shutil
import socket
import time
from pathlib import Path

import pytest

from conftest import ROOT, SocketcandProcess, run

can = pytest.importorskip("can")

FIRMWARE = ROOT / "firmware"
BINARY = FIRMWARE / "target" / "debug" / "r2p-canlink"
HEARTBEAT_ID = 0x1ABC0000


@pytest.fixture(scope="module")
def binary() -> Path:
    p = run(["cargo", "build", "-q", "-p", "r2p-canlink"], cwd=FIRMWARE, timeout=600)
    assert p.returncode == 0, p.stdout
    return BINARY


class Link(SocketcandProcess):
    """A running `r2p-canlink serve` logging to `tmp/bus.log`."""

    def __init__(self, binary: Path, tmp: Path, *extra: str):
        self.log = tmp / "bus.log"
        super().__init__([str(binary), "serve", "--log", str(self.log), *extra], "r2p-canlink")


@pytest.fixture
def serve(binary, tmp_path):
    links: list[Link] = []

    def start(*extra: str) -> Link:
        links.append(Link(binary, tmp_path, *extra))
        return links[-1]

    try:
        yield start
    finally:
        for link in links:
            link.kill()


def recv_matching(bus, pred, timeout: float = 5.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = bus.recv(timeout=max(0.0, deadline - time.monotonic()))
        if msg is not None and pred(msg):
            return msg
    raise AssertionError("no matching frame within the timeout")


def is_heartbeat(m) -> bool:
    return m.arbitration_id == HEARTBEAT_ID and m.is_extended_id


def test_help_names_the_options(binary):
    p = run([str(binary), "--help"], timeout=30)
    assert p.returncode == 0
    for option in ("serve", "--socketcand", "--log", "--heartbeat", "127.0.0.1:29536"):
        assert option in p.stdout


def test_python_can_receives_heartbeats(serve):
    link = serve("--heartbeat", f"{HEARTBEAT_ID:08X}:20")
    bus = link.bus()
    try:
        first = recv_matching(bus, is_heartbeat)
        second = recv_matching(bus, is_heartbeat)
    finally:
        bus.shutdown()
    assert first.dlc == 4 and second.dlc == 4
    assert int.from_bytes(second.data, "big") > int.from_bytes(first.data, "big")
    assert 0 < second.timestamp - first.timestamp < 2
    assert "stopped (signal)" in link.stop()


def test_a_frame_from_python_can_reaches_another_client_and_the_log(serve):
    link = serve("--heartbeat", f"{HEARTBEAT_ID:08X}:50")
    a, b = link.bus(), link.bus()
    sent = [
        can.Message(arbitration_id=0x123, data=[1, 2, 0xFF], is_extended_id=False),
        can.Message(arbitration_id=0x12345678, data=bytes.fromhex("DEADBEEF"), is_extended_id=True),
        can.Message(arbitration_id=0x7, data=b"", is_extended_id=True),
    ]
    try:
        heartbeat = recv_matching(b, is_heartbeat)
        for m in sent:
            a.send(m)
        got = [recv_matching(b, lambda m: not is_heartbeat(m)) for _ in sent]
    finally:
        a.shutdown()
        b.shutdown()
    for s, g in zip(sent, got):
        assert (g.arbitration_id, g.is_extended_id, bytes(g.data)) == (s.arbitration_id, s.is_extended_id, bytes(s.data))
    link.stop()

    # The log holds the same frames with the same timestamps, and python-can reads it.
    logged = list(can.LogReader(str(link.log)))
    assert isinstance(can.LogReader(str(link.log)), can.CanutilsLogReader)
    key = lambda m: (round(m.timestamp, 6), m.arbitration_id, m.is_extended_id, bytes(m.data))  # noqa: E731
    assert [key(m) for m in logged if not is_heartbeat(m)] == [key(m) for m in got]
    assert key(heartbeat) in [key(m) for m in logged]
    assert all(m.channel == "vcan0" and not m.is_remote_frame for m in logged)
    text = link.log.read_text()
    assert " vcan0 12345678#DEADBEEF\n" in text and " vcan0 123#0102FF\n" in text
    assert " vcan0 00000007#\n" in text


@pytest.mark.skipif(shutil.which("log2asc") is None, reason="can-utils not installed")
def test_can_utils_read_the_log(serve, tmp_path):
    link = serve()
    bus = link.bus()
    try:
        bus.send(can.Message(arbitration_id=0x1ABCDEF, data=[0xAA, 0x55], is_extended_id=True))
        time.sleep(0.3)
    finally:
        bus.shutdown()
    link.stop()
    asc = tmp_path / "bus.asc"
    p = run(["log2asc", "-I", str(link.log), "-O", str(asc), "vcan0"], timeout=30)
    assert p.returncode == 0, p.stdout
    lines = [l.split() for l in asc.read_text().splitlines()]
    assert any("1ABCDEFx" in l and l[-2:] == ["AA", "55"] for l in lines), asc.read_text()


def test_malformed_input_gets_an_error_and_the_server_lives_on(serve):
    link = serve()
    with socket.create_connection(("127.0.0.1", link.port), timeout=5) as s:
        assert s.recv(256) == b"< hi >"
        s.sendall(b"hello\n")
        assert s.recv(256).startswith(b"< error ")
        s.sendall(b"< open vcan0 >")
        assert s.recv(256) == b"< ok >"
        s.sendall(b"< send 123 9 >")
        assert s.recv(256).startswith(b"< error ")
    bus = link.bus()  # still serving
    bus.shutdown()
    assert "2 errors" in link.stop()


def test_stops_when_stdin_closes(serve):
    link = serve()
    link.proc.stdin.close()
    assert link.proc.wait(timeout=10) == 0
    assert "stopped (standard input closed)" in link.proc.stderr.read()


def test_address_in_use_is_a_clear_error(binary):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        p = run([str(binary), "serve", "--socketcand", f"127.0.0.1:{port}", "--no-stdin"], timeout=30)
    assert p.returncode == 2
    assert f"127.0.0.1:{port} is already in use" in p.stdout


def test_bad_arguments_are_refused(binary):
    for args in (["serve", "--heartbeat", "xyz"], ["serve", "--socketcand", "nowhere"], ["frob"]):
        p = run([str(binary), *args], timeout=30)
        assert p.returncode == 2 and "error" in p.stdout, (args, p.stdout)
