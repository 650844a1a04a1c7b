"""The emulated Triskar2's gateway serving the bus on TCP through its own application's socketcand
server (r2p-app-gateway, the code its STM32F407 image runs over embassy-net, here over host TCP):
`r2p sim --realtime --gateway ADDR`. Every tool that works through the emulator's r2p-canlink
endpoint works through the gateway's, unchanged (issue 20 item 2)."""
from __future__ import annotations

import json
import re
import socket
import subprocess
import time

import pytest

from conftest import ROOT, SocketcandProcess, free_port, run

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"
BOARDS = {"psu", "motor1", "motor2", "motor3", "proximity", "gateway"}
# The gateway node's parameters: the network's first (tcp_port the sixth), then the base controller's.
TCP_PORT_PARAM = 5


@pytest.fixture(scope="module")
def built() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout


@pytest.fixture(scope="module")
def robot(built):
    gateway = free_port()
    sim = SocketcandProcess([str(R2P), "sim", str(TRISKAR2), "--realtime", "--gateway", f"127.0.0.1:{gateway}"],
                            "r2p sim")
    sim.gateway = gateway
    try:
        yield sim
    finally:
        sim.kill()


def r2p(port: int, *args: str, timeout: str = "2"):
    return run([str(R2P), "--socketcand", f"127.0.0.1:{port}", "--timeout", timeout, *args], timeout=60)


def nodes(port: int) -> set[tuple[int, str]]:
    p = r2p(port, "nodes", "--json")
    assert p.returncode == 0, p.stdout
    return {(n["node"], n["name"]) for n in map(json.loads, p.stdout.splitlines())}


def test_r2p_nodes_and_topics_through_the_gateway_as_through_canlink(robot):
    through_gateway, through_canlink = nodes(robot.gateway), nodes(robot.port)
    assert {name for _, name in through_gateway} == BOARDS, through_gateway
    assert through_gateway == through_canlink
    p, q = r2p(robot.gateway, "topics"), r2p(robot.port, "topics")
    assert p.returncode == 0 and q.returncode == 0, p.stdout + q.stdout
    topics = lambda out: {line.split()[0] for line in out.splitlines()[1:] if line.strip()}
    assert topics(p.stdout) == topics(q.stdout), (p.stdout, q.stdout)
    for topic in ("psu/battery", "motor1/state", "odom", "gateway/status"):
        assert topic in p.stdout, (topic, p.stdout)


def test_echo_and_param_through_the_gateway_reach_the_modules_and_the_gateway_itself(robot):
    p = r2p(robot.gateway, "echo", "motor2/state", "--count", "3")
    assert p.returncode == 0, p.stdout
    assert p.stdout.count("speed") >= 3, p.stdout
    p = r2p(robot.gateway, "param", "get", "motor2", "0")
    assert p.returncode == 0 and "2" in p.stdout, p.stdout
    # The gateway's own node answers a client of its own server: the client's request, sent by
    # the gateway's controller, is looped back to its node as SocketCAN loops a host's frames.
    p = r2p(robot.gateway, "param", "get", "gateway", str(TCP_PORT_PARAM))
    assert p.returncode == 0 and "29536" in p.stdout, p.stdout


def test_gateway_status_reports_the_link_and_its_clients(robot):
    p = r2p(robot.port, "echo", "gateway/status", "--count", "1", "--json", timeout="5")
    assert p.returncode == 0, p.stdout
    s = json.loads(p.stdout)["value"]
    assert s["link_up"] and s["configured"] and not s["dhcp"], s
    assert s["ip"] == (127 << 24) | 1, "the address it listens on"
    assert s["frames_to_clients"] > 0 or s["clients"] == 0, s


def pub_and_echo(robot):
    echo = subprocess.Popen([str(R2P), "--socketcand", f"127.0.0.1:{robot.port}", "--timeout", "20", "echo",
                             "gw_test", "--count", "1", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        time.sleep(0.3)
        p = r2p(robot.gateway, "pub", "gw_test", "--type", "WheelSetpoint", "mode=1", "value=-2.5", "--timeout", "20")
        assert p.returncode == 0, p.stdout
        assert re.search(r"published 1 message\(s\) of type WheelSetpoint", p.stdout), p.stdout
        out, err = echo.communicate(timeout=30)
    finally:
        echo.kill()
    return echo.returncode, out, err


def test_pub_through_the_gateway_reaches_an_echo_through_canlink(robot):
    # A tool behind the gateway sends its advertisement and its answer to a subscription once:
    # a fragment of them the gateway gave up on (its lowest-priority NRT frames lose arbitration
    # to the burst after every sync) failed this test in 2 of 5 runs until the gateway kept
    # trying a client frame for its patience rather than three times.
    code, out, err = pub_and_echo(robot)
    assert code == 0, err
    assert json.loads(out)["value"] == {"mode": 1, "value": -2.5}


def test_python_can_through_the_gateway_sees_the_robot(robot):
    import can
    bus = can.Bus(interface="socketcand", host="127.0.0.1", port=robot.gateway, channel="vcan0")
    try:
        t0, frames = time.monotonic(), []
        while time.monotonic() - t0 < 1.0:
            m = bus.recv(timeout=0.2)
            if m is not None:
                frames.append(m)
        assert len(frames) > 200, f"{len(frames)} frames in a second"
        assert all(m.is_extended_id for m in frames)
    finally:
        bus.shutdown()


def test_bad_input_gets_an_error_and_the_session_goes_on(robot):
    with socket.create_connection(("127.0.0.1", robot.gateway), timeout=5) as s:
        def reply() -> str:
            data = b""
            while not data.endswith(b">"):
                data += s.recv(1)
            return data.decode().strip()
        assert reply() == "< hi >"
        s.sendall(b"< open can9 >")
        assert reply() == "< error could not open bus >"
        s.sendall(b"\xff\xfe< open vcan0 >< send 123 1 7 >< echo >")
        assert reply() == "< error data outside a message >"
        assert reply() == "< ok >"
        assert reply() == "< error the R2P bus carries 29-bit identifiers only, frame dropped >"
        assert reply() == "< echo >"


def test_gateway_without_realtime_is_a_clear_error(built, tmp_path):
    p = run([str(R2P), "sim", str(TRISKAR2), "--seconds", "1", "--log", str(tmp_path / "x.log"),
             "--gateway", "127.0.0.1:1"], timeout=60)
    assert p.returncode != 0 and "--realtime" in p.stdout, p.stdout
