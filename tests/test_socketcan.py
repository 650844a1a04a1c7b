"""SocketCAN (Linux kernel CAN interfaces) in `r2p`: the kernel probe and the error messages
always; frames to and from a virtual CAN interface where the kernel has AF_CAN and `vcan0` is
up (these machines' kernel has no AF_CAN: those tests skip, saying why)."""
from __future__ import annotations

import errno
import socket
import subprocess
import time

import pytest

from conftest import ROOT, run

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
VCAN_HINT = "modprobe vcan; ip link add dev vcan0 type vcan; ip link set up vcan0"


def af_can() -> OSError | None:
    """None if this kernel opens raw CAN sockets, else the error (errno 97: no AF_CAN)."""
    if not hasattr(socket, "AF_CAN"):
        return OSError(errno.EAFNOSUPPORT, "Python has no AF_CAN on this platform")
    try:
        socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
        return None
    except OSError as e:
        return e


def vcan0_up() -> str | None:
    """None if vcan0 can be bound, else why not."""
    if (e := af_can()) is not None:
        return f"this kernel has no SocketCAN ({e})"
    s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    try:
        s.bind(("vcan0",))
        return None
    except OSError as e:
        return f"no usable vcan0 ({e}); create it with `{VCAN_HINT}`"
    finally:
        s.close()


@pytest.fixture(scope="module")
def built() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout


def test_opening_an_interface_says_why_it_cannot(built):
    err = af_can()
    p = run([str(R2P), "--socketcan", "vcan0", "nodes"], timeout=30)
    if err is not None and err.errno == errno.EAFNOSUPPORT:
        # No AF_CAN in this kernel: whatever the interface, r2p must say so, and how to fix it.
        assert p.returncode == 1, p.stdout
        assert "--socketcan vcan0: this kernel has no SocketCAN" in p.stdout, p.stdout
        assert VCAN_HINT in p.stdout and "--socketcand" in p.stdout
        for iface in ("can0", "r2pnosuch0"):
            q = run([str(R2P), "--socketcan", iface, "monitor", "--count", "1"], timeout=30)
            assert q.returncode == 1 and "this kernel has no SocketCAN" in q.stdout, q.stdout
    else:
        # A kernel with SocketCAN: a missing interface is named, with how to create it.
        q = run([str(R2P), "--socketcan", "r2pnosuch0", "nodes"], timeout=30)
        assert q.returncode == 1, q.stdout
        assert "no network interface named r2pnosuch0" in q.stdout, q.stdout
        assert "ip link add dev r2pnosuch0 type vcan" in q.stdout
        q = run([str(R2P), "--socketcan", "lo", "nodes"], timeout=30)
        assert q.returncode == 1 and "lo is not a CAN interface" in q.stdout, q.stdout
    bad = run([str(R2P), "--socketcan", "a/b", "nodes"], timeout=30)
    assert bad.returncode == 1 and "is not a network interface name" in bad.stdout, bad.stdout


def test_frames_cross_between_r2p_and_vcan0(built, tmp_path):
    """monitor decodes what another SocketCAN program sends; replay sends onto the interface."""
    if (why := vcan0_up()) is not None:
        pytest.skip(f"SocketCAN I/O over vcan0: {why}")
    tool = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    tool.bind(("vcan0",))
    tool.settimeout(5)
    try:
        mon = subprocess.Popen([str(R2P), "--socketcan", "vcan0", "monitor", "--count", "1", "--json"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(0.5)
        # struct can_frame: ID with the extended flag (host order), length, padding, data.
        sync = (0x2280 | 0x80000000).to_bytes(4, "little") + bytes([8, 0, 0, 0]) + bytes([6] + [0] * 7)
        tool.send(sync)
        out, err = mon.communicate(timeout=10)
        assert mon.returncode == 0, err
        assert '"kind":"sync"' in out and '"cycle":69' in out, out

        trace = tmp_path / "t.log"
        trace.write_text("(1.000000) vcan0 1FFFFF00#C0FFEE\n")
        p = run([str(R2P), "--socketcan", "vcan0", "replay", str(trace)], timeout=30)
        assert p.returncode == 0, p.stdout
        frame = tool.recv(16)
        assert int.from_bytes(frame[:4], "little") == 0x1FFFFF00 | 0x80000000 and frame[8:11] == b"\xc0\xff\xee"
    finally:
        tool.close()
