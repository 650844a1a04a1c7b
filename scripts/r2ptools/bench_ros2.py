"""`make bench`, ROS 2 over Zenoh: the latency from a `/cmd_vel` sample put by a ROS-side Zenoh
peer to the wheel setpoints it causes on the emulated Triskar2's bus (issue 20), p50/p99, in
real time on this machine (a number, never a pass/fail).

Path measured: Python peer `put` → Zenoh router (loopback TCP) → the emulated gateway's Zenoh
client thread → the gateway's 1 kHz step (`cmd_vel` to the base controller) → the base's next
inverse-kinematics step (`ik_rate_hz`, 100 Hz) → the setpoint's HRT slot in the next TDMA cycle
→ the bus → the gateway's socketcand server → a python-can client here. The baseline, in the
same run: a put's round trip through the same router to a second Zenoh peer here (the Zenoh and
Python share of the path).

    scripts/py -m r2ptools.bench_ros2 [--samples N]
"""
from __future__ import annotations

import argparse
import json
import logging
import random
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from . import ROOT

R2P = ROOT / "firmware" / "target" / "release" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _config(zenoh, mode: str, key: str, endpoint: str):
    cfg = zenoh.Config()
    cfg.insert_json5("mode", f'"{mode}"')
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5(f"{key}/endpoints", f'["{endpoint}"]')
    return cfg


def _percentile(values: list[float], p: float) -> float:
    v = sorted(values)
    return v[min(len(v) - 1, int(round(p / 100 * (len(v) - 1))))]


def run(samples: int = 200) -> dict:
    import can
    import zenoh
    from rosbags.typesys import Stores, get_typestore

    subprocess.run(["cargo", "build", "-q", "--release", "--locked", "-p", "r2p-cli"],
                   cwd=ROOT / "firmware", check=True)
    ts = get_typestore(Stores.ROS2_JAZZY)
    cmd_key = f"0/cmd_vel/geometry_msgs::msg::dds_::Twist_/{ts.hash_rihs01('geometry_msgs/msg/Twist')}"
    v3 = ts.types["geometry_msgs/msg/Vector3"]

    def twist(wz: float) -> bytes:
        msg = ts.types["geometry_msgs/msg/Twist"](linear=v3(x=0.0, y=0.0, z=0.0), angular=v3(x=0.0, y=0.0, z=wz))
        return bytes(ts.serialize_cdr(msg, "geometry_msgs/msg/Twist"))

    zport, cport = _free_port(), _free_port()
    router = zenoh.open(_config(zenoh, "router", "listen", f"tcp/127.0.0.1:{zport}"))
    with tempfile.TemporaryDirectory() as tmp:
        robot = Path(tmp) / "triskar2.toml"
        robot.write_text(TRISKAR2.read_text().split("[[teleop]]")[0])
        sim = subprocess.Popen([str(R2P), "sim", str(robot), "--realtime", "--no-stdin",
                                "--socketcand", f"127.0.0.1:{cport}", "--zenoh", f"tcp/127.0.0.1:{zport}"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        peer = echo = bus = None
        try:
            time.sleep(3.0)  # the bus settles, the gateway opens its session
            p = subprocess.run([str(R2P), "--socketcand", f"127.0.0.1:{cport}", "--timeout", "2",
                                "topics", "--json"], capture_output=True, text=True, check=True)
            topics = {t["topic"]: t for t in map(json.loads, p.stdout.splitlines())}
            setpoint_id = topics["motor1/setpoint"]["message_id"] << 7   # HRT: laxity 0, fragment 0
            peer = zenoh.open(_config(zenoh, "peer", "connect", f"tcp/127.0.0.1:{zport}"))
            logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)  # partial reads
            bus = can.Bus(interface="socketcand", host="127.0.0.1", port=cport, channel="vcan0")
            latencies = []
            sign = 1.0
            for _ in range(samples):
                sign = -sign
                while bus.recv(timeout=0) is not None:
                    pass
                t0 = time.perf_counter()
                peer.put(cmd_key, twist(0.5 * sign))
                while True:
                    m = bus.recv(timeout=1.0)
                    if m is None:
                        raise RuntimeError("no wheel setpoint within 1 s of a /cmd_vel")
                    if m.arbitration_id == setpoint_id and len(m.data) == 5:
                        value = struct.unpack_from("<f", bytes(m.data), 1)[0]
                        if value * sign > 0:
                            latencies.append(time.perf_counter() - t0)
                            break
                time.sleep(random.uniform(0.02, 0.08))
            # A wheel's new state on the bus to /odom out: turn one way, then the other; from the
            # first motor1/state whose speed has the new turn's sign (reassembled here from its
            # two frames) to the first /odom whose yaw rate has it.
            state_msg = topics["motor1/state"]["message_id"]
            odom_key = f"0/odom/nav_msgs::msg::dds_::Odometry_/{ts.hash_rihs01('nav_msgs/msg/Odometry')}"
            odoms: list[tuple[float, float]] = []
            lock = threading.Lock()

            def on_odom(sample):
                msg = ts.deserialize_cdr(bytes(sample.payload.to_bytes()), "nav_msgs/msg/Odometry")
                with lock:
                    odoms.append((time.perf_counter(), msg.twist.twist.angular.z))

            odom_sub = peer.declare_subscriber(odom_key, on_odom)
            try:
                odom_latencies = _state_to_odom(bus, peer, cmd_key, twist, state_msg, odoms, lock,
                                                max(samples // 4, 10))
            finally:
                odom_sub.undeclare()
            # Baseline: the same put, through the same router, to a subscriber here.
            got = threading.Event()
            echo = peer.declare_subscriber("bench/echo", lambda s: got.set())
            other = zenoh.open(_config(zenoh, "peer", "connect", f"tcp/127.0.0.1:{zport}"))
            time.sleep(0.5)
            base = []
            for _ in range(samples):
                got.clear()
                t0 = time.perf_counter()
                other.put("bench/echo", twist(0.5))
                if got.wait(1.0):
                    base.append(time.perf_counter() - t0)
                time.sleep(0.005)
            other.close()
        finally:
            if echo is not None:
                echo.undeclare()
            if bus is not None:
                bus.shutdown()
            if peer is not None:
                peer.close()
            sim.kill()
            sim.wait(timeout=10)
            router.close()
    ms = lambda v: [x * 1e3 for x in v]
    return {"samples": len(latencies), "cmd_vel_to_setpoint_ms": ms(latencies), "zenoh_put_to_peer_ms": ms(base),
            "state_to_odom_ms": ms(odom_latencies)}


def _state_to_odom(bus, peer, cmd_key, twist, state_msg, odoms, lock, samples: int) -> list[float]:
    """Seconds from a wheel state on the bus showing a turn's new direction to the first /odom
    showing it, over `samples` reversals of a 0.8 rad/s turn."""
    from .rtcan_fragment import Reassembler, split

    out, sign = [], 1.0
    for _ in range(samples):
        sign = -sign
        rx = Reassembler(slots=4, buffer=64, timeout_us=20_000)
        while bus.recv(timeout=0) is not None:  # frames from before the reversal
            pass
        deadline = time.perf_counter() + 3.0
        t_state, next_put = None, 0.0
        while t_state is None:
            now = time.perf_counter()
            if now >= next_put:  # 20 Hz, as teleop would: keeps the watchdog fed
                peer.put(cmd_key, twist(0.8 * sign))
                next_put = now + 0.05
            if now > deadline:
                raise RuntimeError("no motor1/state with the new direction within 3 s")
            m = bus.recv(timeout=0.01)
            if m is None or split(m.arbitration_id)[1] != state_msg:
                continue
            payload = rx.accept(m.arbitration_id, bytes(m.data), int(m.timestamp * 1e6), 13)
            # Triskar2 turning at wz: each wheel (the state's speed is the gearbox output's) at
            # wz · 0.25 m / 0.05 m = 5·wz rad/s, so 0.1 rad/s of wheel speed is the 0.02 rad/s
            # of yaw rate /odom is tested for.
            if payload is not None and struct.unpack_from("<f", payload, 4)[0] * sign > 0.1:
                t_state = time.perf_counter()
        while True:
            with lock:
                seen = [t for t, wz in odoms if t >= t_state and wz * sign > 0.02]
            if seen:
                out.append(seen[0] - t_state)
                break
            if time.perf_counter() > t_state + 1.0:
                raise RuntimeError("no /odom with the new direction within 1 s of the wheel state")
            peer.put(cmd_key, twist(0.8 * sign))
            time.sleep(0.01)
        time.sleep(random.uniform(0.2, 0.4))
    return out


def report(r: dict) -> None:
    a, b = r["cmd_vel_to_setpoint_ms"], r["zenoh_put_to_peer_ms"]
    print("\n=== ROS 2 over Zenoh (emulated Triskar2, real time, this machine): latency, ms")
    print(f"{'path':<58} {'p50':>6} {'p99':>6} {'max':>6}")
    for name, v in (("/cmd_vel put -> wheel setpoint on the bus (seen by a CAN tool)", a),
                    ("wheel state on the bus -> /odom at a ROS peer", r["state_to_odom_ms"]),
                    ("baseline: Zenoh put -> peer, same router", b)):
        print(f"{name:<58} {_percentile(v, 50):>6.2f} {_percentile(v, 99):>6.2f} {max(v):>6.2f}")
    print(f"({r['samples']} commands; the base's inverse kinematics run at 100 Hz, so ~5 ms of the "
          f"median and up to 10 ms are its period, plus the TDMA cycle's slot; /odom is published "
          f"at ~20 Hz, so up to 50 ms of the state's path is waiting for the next one)")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_ros2", description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=200)
    a = ap.parse_args(argv)
    try:
        report(run(a.samples))
    except (RuntimeError, subprocess.CalledProcessError, ImportError) as e:
        print(f"bench_ros2: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
