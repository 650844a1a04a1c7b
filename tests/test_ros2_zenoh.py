"""The emulated Triskar2's gateway as a native ROS 2 node over Zenoh (issue 20 items 3-4):
`r2p sim ROBOT --realtime --zenoh tcp/HOST:PORT` runs the gateway application's Zenoh client
(r2p-app-gateway's RosBridge on r2p-zenoh, the code its STM32F407 image runs) over host TCP to a
real Zenoh router (PyPI eclipse-zenoh, the Rust implementation rmw_zenoh's router runs). A
ROS-side peer checks what rmw_zenoh would see: liveliness tokens, /odom as nav_msgs/msg/Odometry
(decoded by rosbags, an independent CDR implementation) with rmw_zenoh's attachment, /cmd_vel
driving the base, the watchdog stopping it, and the gateway reconnecting after a router restart.
Loopback only, multicast scouting off."""
from __future__ import annotations

import json
import math
import socket
import struct
import threading
import time

import pytest

zenoh = pytest.importorskip("zenoh")
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from conftest import ROOT, SocketcandProcess, free_port, run  # noqa: E402

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"
TS = get_typestore(Stores.ROS2_JAZZY)
ODOM_TYPE = "nav_msgs::msg::dds_::Odometry_"
TWIST_TYPE = "geometry_msgs::msg::dds_::Twist_"
ODOM_KEY = f"0/odom/{ODOM_TYPE}/{TS.hash_rihs01('nav_msgs/msg/Odometry')}"
CMD_KEY = f"0/cmd_vel/{TWIST_TYPE}/{TS.hash_rihs01('geometry_msgs/msg/Twist')}"


def config(mode: str, **endpoints) -> "zenoh.Config":
    cfg = zenoh.Config()
    cfg.insert_json5("mode", f'"{mode}"')
    cfg.insert_json5("scouting/multicast/enabled", "false")
    for k, v in endpoints.items():
        cfg.insert_json5(f"{k}/endpoints", f'["{v}"]')
    return cfg


class Router:
    """A Zenoh router on 127.0.0.1:port (what `ros2 run rmw_zenoh_cpp rmw_zenohd` runs)."""

    def __init__(self, port: int):
        self.port = port
        self.session = zenoh.open(config("router", listen=f"tcp/127.0.0.1:{port}"))

    def close(self):
        self.session.close()


class Peer:
    """The ROS side: a Zenoh peer of the router, collecting /odom samples."""

    def __init__(self, port: int):
        self.session = zenoh.open(config("peer", connect=f"tcp/127.0.0.1:{port}"))
        self.odom: list[tuple[float, object, bytes]] = []
        self.lock = threading.Lock()
        self.sub = self.session.declare_subscriber(ODOM_KEY, self._on_odom)

    def _on_odom(self, sample):
        msg = TS.deserialize_cdr(bytes(sample.payload.to_bytes()), "nav_msgs/msg/Odometry")
        att = bytes(sample.attachment.to_bytes()) if sample.attachment is not None else b""
        with self.lock:
            self.odom.append((time.monotonic(), msg, att))

    def samples_since(self, t: float):
        with self.lock:
            return [(m, a) for (ts, m, a) in self.odom if ts >= t]

    def tokens(self) -> list[str]:
        return [str(r.ok.key_expr) for r in self.session.liveliness().get("@ros2_lv/0/**", timeout=2)
                if r.ok is not None]

    def twist(self, vx: float, vy: float = 0.0, wz: float = 0.0) -> bytes:
        v3 = TS.types["geometry_msgs/msg/Vector3"]
        msg = TS.types["geometry_msgs/msg/Twist"](linear=v3(x=vx, y=vy, z=0.0), angular=v3(x=0.0, y=0.0, z=wz))
        return bytes(TS.serialize_cdr(msg, "geometry_msgs/msg/Twist"))

    def drive(self, seconds: float, vx: float, vy: float = 0.0, wz: float = 0.0):
        """Publishes a Twist at 20 Hz, as teleop_twist_keyboard would, with rmw_zenoh's attachment."""
        payload = self.twist(vx, vy, wz)
        gid = bytes(range(16))
        end, seq = time.monotonic() + seconds, 1
        while time.monotonic() < end:
            att = struct.pack("<qq", seq, time.time_ns()) + b"\x10" + gid
            self.session.put(CMD_KEY, payload, attachment=att)
            seq += 1
            time.sleep(0.05)

    def close(self):
        self.sub.undeclare()
        self.session.close()


def wait_for(what, predicate, timeout: float = 15.0):
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.1)


@pytest.fixture(scope="module")
def built() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout


@pytest.fixture(scope="module")
def ros(built, tmp_path_factory):
    """A router, the emulated Triskar2 (without its teleop script: ROS drives) connected to it,
    and a ROS-side peer."""
    robot = tmp_path_factory.mktemp("robot") / "triskar2.toml"
    robot.write_text(TRISKAR2.read_text().split("[[teleop]]")[0])
    port = free_port()
    router = Router(port)
    sim = SocketcandProcess([str(R2P), "sim", str(robot), "--realtime", "--zenoh", f"tcp/127.0.0.1:{port}"],
                            "r2p sim")
    peer = Peer(port)
    state = {"router": router, "sim": sim, "peer": peer, "port": port}
    try:
        yield state
    finally:
        state["peer"].close()
        sim.kill()
        state["router"].close()


def parse_token(key: str) -> dict:
    """rmw_zenoh's Entity::make: @ros2_lv/domain/zid/nid/id/kind/enclave/ns/node[/topic/type/hash/qos]."""
    p = key.split("/")
    assert p[0] == "@ros2_lv" and len(p) in (9, 13) and all(p), key
    d = {"domain": int(p[1]), "zid": p[2], "nid": p[3], "id": p[4], "kind": p[5],
         "enclave": p[6].replace("%", "/"), "ns": p[7].replace("%", "/"), "node": p[8].replace("%", "/")}
    if len(p) == 13:
        qos = p[12].split(":")
        assert len(qos) == 6 and len(qos[2].split(",")) == 2 and len(qos[5].split(",")) == 3, key
        d.update(topic=p[9].replace("%", "/"), type=p[10], hash=p[11], qos=p[12])
    return d


def test_the_gateway_node_its_publishers_and_its_subscription_are_in_the_ros_graph(ros):
    tokens = wait_for("the gateway's tokens", lambda: [t for t in ros["peer"].tokens() if "r2p_gateway" in t])
    entities = [parse_token(t) for t in tokens]
    nodes = [e for e in entities if e["kind"] == "NN"]
    assert len(nodes) == 1 and nodes[0]["node"] == "r2p_gateway" and nodes[0]["ns"] == "/", entities
    pubs = {e["topic"]: e for e in entities if e["kind"] == "MP"}
    subs = {e["topic"]: e for e in entities if e["kind"] == "MS"}
    assert pubs["/odom"]["type"] == ODOM_TYPE
    assert pubs["/odom"]["hash"] == TS.hash_rihs01("nav_msgs/msg/Odometry")
    assert pubs["/battery_state"]["hash"] == TS.hash_rihs01("sensor_msgs/msg/BatteryState")
    assert pubs["/imu/data"]["hash"] == TS.hash_rihs01("sensor_msgs/msg/Imu")
    assert {f"/range_{i}" for i in range(4)} <= set(pubs)
    assert pubs["/gateway/status"]["type"] == "r2p_msgs::msg::dds_::GatewayStatus_"
    assert subs["/cmd_vel"]["type"] == TWIST_TYPE
    assert subs["/cmd_vel"]["hash"] == TS.hash_rihs01("geometry_msgs/msg/Twist")
    # One session: one Zenoh ID; entity ids unique.
    assert len({e["zid"] for e in entities}) == 1
    assert len({e["id"] for e in entities}) == len(entities)


def test_odom_is_a_nav_msgs_odometry_with_rmw_zenohs_attachment(ros):
    t0 = time.monotonic()
    samples = wait_for("/odom", lambda: (s := ros["peer"].samples_since(t0)) and len(s) >= 10 and s)
    msg, att = samples[-1]
    assert msg.header.frame_id == "odom" and msg.child_frame_id == "base_link"
    assert abs(msg.header.stamp.sec - time.time()) < 5
    assert len(att) == 33 and att[16] == 16
    seqs = [struct.unpack_from("<q", a)[0] for _, a in samples]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), seqs[:20]
    assert len({a[17:] for _, a in samples}) == 1  # one publisher GID
    stamps = [struct.unpack_from("<q", a, 8)[0] for _, a in samples]
    assert stamps == sorted(stamps)
    # About 20 Hz.
    t1 = time.monotonic()
    time.sleep(2.0)
    n = len(ros["peer"].samples_since(t1))
    assert 30 <= n <= 50, n


def test_a_twist_on_cmd_vel_drives_the_base_and_odom_follows_then_the_watchdog_stops_it(ros):
    peer = ros["peer"]
    start = wait_for("/odom", lambda: peer.samples_since(time.monotonic() - 0.5))[-1][0].pose.pose.position
    t0 = time.monotonic()
    # Ahead: the world's box, which the base's obstacle avoidance stops at (0.45 m): 0.2 m fit.
    peer.drive(1.2, vx=0.3)
    during = [m for m, _ in peer.samples_since(t0)]
    assert 0.25 < max(m.twist.twist.linear.x for m in during) < 0.4  # the wheels' speed loop overshoots a little
    moved = during[-1].pose.pose.position
    assert moved.x - start.x > 0.2, (start, moved)
    assert abs(moved.y - start.y) < 0.05
    # cmd_vel stops: within the watchdog (0.5 s) and the wheels' deceleration, the base stops.
    time.sleep(1.5)
    stopped = peer.samples_since(time.monotonic() - 0.3)[-1][0]
    assert abs(stopped.twist.twist.linear.x) < 0.02, stopped.twist.twist
    x = stopped.pose.pose.position.x
    time.sleep(1.0)
    assert peer.samples_since(time.monotonic() - 0.3)[-1][0].pose.pose.position.x == pytest.approx(x, abs=0.01)
    # Turning: yaw in the quaternion, about z.
    peer.drive(1.5, vx=0.0, wz=0.8)
    turning = peer.samples_since(time.monotonic() - 0.3)[-1][0]
    assert turning.twist.twist.angular.z == pytest.approx(0.8, abs=0.15)
    q = turning.pose.pose.orientation
    assert abs(q.x) < 1e-6 and abs(q.y) < 1e-6 and q.z > 0.2


def test_gateway_status_is_published_as_its_r2p_msgs_type(ros):
    from rosbags.typesys import get_types_from_msg
    store = get_typestore(Stores.ROS2_JAZZY)
    msg_text = (ROOT / "firmware" / "msgs" / "r2p_msgs" / "msg" / "GatewayStatus.msg").read_text()
    store.register(get_types_from_msg(msg_text, "r2p_msgs/msg/GatewayStatus"))
    key = f"0/gateway/status/r2p_msgs::msg::dds_::GatewayStatus_/{store.hash_rihs01('r2p_msgs/msg/GatewayStatus')}"
    got = []
    sub = ros["peer"].session.declare_subscriber(key, lambda s: got.append(bytes(s.payload.to_bytes())))
    try:
        wait_for("/gateway/status", lambda: got)
    finally:
        sub.undeclare()
    status = store.deserialize_cdr(got[0], "r2p_msgs/msg/GatewayStatus")
    assert status.clients == 0 and status.lost == 0


def test_malformed_cmd_vel_is_dropped_and_the_gateway_goes_on(ros):
    peer = ros["peer"]
    for bad in (b"", b"\x00\x01\x00\x00\x01", b"\x00\x00\x00\x00" + bytes(48), bytes(3000)):
        peer.session.put(CMD_KEY, bad)
    t0 = time.monotonic()
    wait_for("/odom after malformed input", lambda: len(peer.samples_since(t0)) >= 5)
    assert ros["sim"].proc.poll() is None


def test_after_a_router_restart_the_gateway_reconnects(ros):
    peer = ros["peer"]
    peer.close()
    ros["router"].close()
    # Without a router, the bus goes on: the modules' topics still flow (the gateway's Zenoh
    # client retries on its own thread; nothing waits for it).
    state = echo(ros, "motor2/state")
    assert state["faults"] == 0, state
    time.sleep(1.0)
    ros["router"] = Router(ros["port"])
    ros["peer"] = peer = Peer(ros["port"])
    wait_for("the gateway's tokens again", lambda: any("/NN/" in t and "r2p_gateway" in t for t in peer.tokens()))
    t0 = time.monotonic()
    wait_for("/odom again", lambda: len(peer.samples_since(t0)) >= 5)
    # ...and /cmd_vel drives it again.
    p0 = peer.samples_since(t0)[-1][0].pose.pose.position
    peer.drive(1.5, vx=-0.3)  # backwards, away from the box
    p1 = peer.samples_since(time.monotonic() - 0.3)[-1][0].pose.pose.position
    assert ((p1.x - p0.x) ** 2 + (p1.y - p0.y) ** 2) ** 0.5 > 0.15, (p0, p1)


def collect(peer: Peer, key: str, typename: str, n: int, timeout: float = 10.0) -> list:
    got = []
    sub = peer.session.declare_subscriber(key, lambda s: got.append(bytes(s.payload.to_bytes())))
    try:
        wait_for(key, lambda: len(got) >= n, timeout)
    finally:
        sub.undeclare()
    return [TS.deserialize_cdr(b, typename) for b in got]


def echo(ros, topic: str) -> dict:
    p = run([str(R2P), "--socketcand", f"127.0.0.1:{ros['sim'].port}", "--timeout", "5", "echo", topic,
             "--count", "1", "--json"], timeout=60)
    assert p.returncode == 0, p.stdout
    return json.loads(p.stdout.splitlines()[-1])["value"]


def test_battery_state_and_ranges_carry_what_the_modules_publish_on_the_bus(ros):
    peer = ros["peer"]
    battery_key = f"0/battery_state/sensor_msgs::msg::dds_::BatteryState_/{TS.hash_rihs01('sensor_msgs/msg/BatteryState')}"
    b = collect(peer, battery_key, "sensor_msgs/msg/BatteryState", 2, timeout=10)[-1]
    bus = echo(ros, "psu/battery")
    assert b.voltage == pytest.approx(bus["voltage"], abs=0.05) and 20 < b.voltage < 30, (b, bus)
    assert b.current == pytest.approx(-bus["current"], abs=0.3)   # ROS: negative while discharging
    assert b.present and b.power_supply_status == 2 and b.header.frame_id == "battery"
    bus = echo(ros, "proximity/ranges")
    range_type = f"sensor_msgs::msg::dds_::Range_/{TS.hash_rihs01('sensor_msgs/msg/Range')}"
    for ch in range(4):
        r = collect(peer, f"0/range_{ch}/{range_type}", "sensor_msgs/msg/Range", 2)[-1]
        assert r.header.frame_id == f"range_{ch}" and r.radiation_type == 1
        want = {0: bus["distance"][ch], 1: float("-inf"), 2: float("inf")}.get(bus["status"][ch])
        if want is None:
            assert r.range != r.range  # NaN: no sensor
        elif math.isinf(want):
            assert r.range == want
        else:
            assert r.range == pytest.approx(want, abs=0.03), (ch, r.range, bus)


def test_other_r2p_topics_are_ros_topics_of_their_r2p_msgs_type(ros):
    """psu/state has no standard ROS 2 type: it is /psu/state, r2p_msgs/msg/PsuState, with the
    values on the bus (the CDR from the packed bus payload and the generated layout)."""
    from rosbags.typesys import get_types_from_msg
    store = get_typestore(Stores.ROS2_JAZZY)
    for name in ("PsuState", "MotorFault", "PsuEvent"):
        text = (ROOT / "firmware" / "msgs" / "r2p_msgs" / "msg" / f"{name}.msg").read_text()
        store.register(get_types_from_msg(text, f"r2p_msgs/msg/{name}"))
    tokens = [parse_token(t) for t in ros["peer"].tokens() if "r2p_gateway" in t]
    pubs = {e["topic"]: e for e in tokens if e["kind"] == "MP"}
    for topic, ty in (("/psu/state", "PsuState"), ("/psu/event", "PsuEvent"), ("/motor2/fault", "MotorFault")):
        assert pubs[topic]["type"] == f"r2p_msgs::msg::dds_::{ty}_"
        assert pubs[topic]["hash"] == store.hash_rihs01(f"r2p_msgs/msg/{ty}")
    key = f"0/psu/state/r2p_msgs::msg::dds_::PsuState_/{store.hash_rihs01('r2p_msgs/msg/PsuState')}"
    got = []
    sub = ros["peer"].session.declare_subscriber(key, lambda s: got.append(bytes(s.payload.to_bytes())))
    try:
        wait_for("/psu/state", lambda: got, timeout=10)
    finally:
        sub.undeclare()
    state = store.deserialize_cdr(got[-1], "r2p_msgs/msg/PsuState")
    bus = echo(ros, "psu/state")
    assert (state.output_on, state.latched, state.under_voltage) == (bus["output_on"], bus["latched"], bus["under_voltage"])
    assert state.output_on and state.bus_voltage == pytest.approx(bus["bus_voltage"], abs=0.05)


def test_with_the_base_controller_on_the_host_ros_still_drives_the_robot_through_the_gateway(built, tmp_path):
    """`[base] controller = "host"`: the gateway runs no base; /cmd_vel goes on the bus to the
    node that does, and /odom comes back from it (apps/gateway/src/remote_base.rs)."""
    robot = tmp_path / "triskar2-host.toml"
    text = TRISKAR2.read_text().split("[[teleop]]")[0]
    robot.write_text(text.replace('kind = "omni"', 'kind = "omni"\ncontroller = "host"', 1))
    assert 'controller = "host"' in robot.read_text()
    port = free_port()
    router = Router(port)
    sim = SocketcandProcess([str(R2P), "sim", str(robot), "--realtime", "--zenoh", f"tcp/127.0.0.1:{port}"],
                            "r2p sim")
    peer = Peer(port)
    try:
        start = wait_for("/odom", lambda: peer.samples_since(time.monotonic() - 0.5))[-1][0].pose.pose.position
        t0 = time.monotonic()
        peer.drive(1.2, vx=0.3)
        during = [m for m, _ in peer.samples_since(t0)]
        assert 0.25 < max(m.twist.twist.linear.x for m in during) < 0.4
        moved = during[-1].pose.pose.position
        assert moved.x - start.x > 0.2 and abs(moved.y - start.y) < 0.05, (start, moved)
        assert during[-1].header.frame_id == "odom"
    finally:
        peer.close()
        sim.kill()
        router.close()


def battery_frames(sim: SocketcandProcess, seconds: float) -> int:
    """Frames of `psu/battery` on the bus for `seconds` (`r2p monitor`: it joins the bus to
    name the streams, subscribing to nothing)."""
    p = run([str(R2P), "--socketcand", f"127.0.0.1:{sim.port}", "monitor", "--announce", "--seconds",
             str(seconds), "--json"], timeout=60)
    assert p.returncode == 0, p.stdout
    lines = [json.loads(line) for line in p.stdout.splitlines() if line.startswith("{")]
    return sum(1 for f in lines if f.get("kind") == "topic" and f.get("topic") == "psu/battery")


def test_the_gateway_imports_the_battery_only_while_a_zenoh_subscriber_listens(built, tmp_path):
    """Issue 22: the gateway asks the router for the subscribers of each key it publishes (a
    Zenoh INTEREST) and unsubscribes on the bus from an import whose ROS topics have had none for
    its hold-off (5 s): the PSU's battery stream, which nothing else on Triskar2 imports, leaves
    the bus; a plain Zenoh subscriber on /battery_state brings it back, the ROS samples with it."""
    robot = tmp_path / "triskar2.toml"
    robot.write_text(TRISKAR2.read_text().split("[[teleop]]")[0])
    port = free_port()
    router = Router(port)
    sim = SocketcandProcess([str(R2P), "sim", str(robot), "--realtime", "--zenoh", f"tcp/127.0.0.1:{port}"],
                            "r2p sim")
    peer = Peer(port)  # subscribes to /odom only
    battery_key = f"0/battery_state/sensor_msgs::msg::dds_::BatteryState_/{TS.hash_rihs01('sensor_msgs/msg/BatteryState')}"
    try:
        wait_for("the gateway's tokens", lambda: any("r2p_gateway" in t for t in peer.tokens()))
        # Nobody listens to /battery_state: within the hold-off and the unsubscription, the PSU
        # stops sending it.
        wait_for("the battery stream to stop", lambda: battery_frames(sim, 1.5) == 0, timeout=30)
        assert battery_frames(sim, 2.0) == 0
        # A subscriber (zenoh-python, no ROS liveliness token): the stream and the samples are back.
        got = []
        sub = peer.session.declare_subscriber(battery_key, lambda s: got.append(bytes(s.payload.to_bytes())))
        wait_for("/battery_state samples", lambda: len(got) >= 3, timeout=15)
        assert battery_frames(sim, 1.5) > 5
        b = TS.deserialize_cdr(got[-1], "sensor_msgs/msg/BatteryState")
        assert 20 < b.voltage < 30
        # It leaves: the stream runs on through the hold-off, then stops again.
        sub.undeclare()
        assert battery_frames(sim, 1.5) > 5, "still within the hold-off"
        wait_for("the battery stream to stop again", lambda: battery_frames(sim, 1.5) == 0, timeout=30)
        # /odom, which the peer still reads, never stopped.
        t0 = time.monotonic()
        wait_for("/odom", lambda: len(peer.samples_since(t0)) >= 5)
    finally:
        peer.close()
        sim.kill()
        router.close()


class Relay:
    """A TCP relay between the gateway and the router: what the gateway puts on its link to the
    router, byte for byte (`upstream`), as a capture on the robot's Ethernet would show it."""

    def __init__(self, router_port: int):
        self.router_port = router_port
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.up = bytearray()
        self.lock = threading.Lock()
        self.socks: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                gateway, _ = self.listener.accept()
            except OSError:
                return
            router = socket.create_connection(("127.0.0.1", self.router_port))
            self.socks += [gateway, router]
            threading.Thread(target=self._pump, args=(gateway, router, True), daemon=True).start()
            threading.Thread(target=self._pump, args=(router, gateway, False), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket, upstream: bool):
        try:
            while data := src.recv(65536):
                if upstream:
                    with self.lock:
                        self.up += data
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass

    def upstream(self) -> bytes:
        with self.lock:
            return bytes(self.up)

    def close(self):
        self.listener.close()
        for s in self.socks:
            s.close()


def cdr_frame_id(frame_id: str) -> bytes:
    """A sample's header.frame_id as CDR writes it (length with the NUL, the bytes, the NUL): in
    the gateway's PUTs only, not in its declarations (keys are Zenoh strings)."""
    return struct.pack("<I", len(frame_id) + 1) + frame_id.encode() + b"\0"


def test_the_gateway_puts_no_sample_nobody_subscribes_to_counts_it_and_sends_once_subscribed(built, tmp_path):
    """Issue 22's write filter end to end: a client subscribing to /odom and /gateway/status
    only. On the gateway's link to the router (a relay in between) the /range_N and
    /battery_state samples stop while /odom's go on; /gateway/status's ros_filtered counts them;
    a subscriber on /range_0 makes its samples flow on the link again, /range_1's still held."""
    from rosbags.typesys import get_types_from_msg
    store = get_typestore(Stores.ROS2_JAZZY)
    msg_text = (ROOT / "firmware" / "msgs" / "r2p_msgs" / "msg" / "GatewayStatus.msg").read_text()
    store.register(get_types_from_msg(msg_text, "r2p_msgs/msg/GatewayStatus"))
    status_key = f"0/gateway/status/r2p_msgs::msg::dds_::GatewayStatus_/{store.hash_rihs01('r2p_msgs/msg/GatewayStatus')}"
    range_key = f"0/range_0/sensor_msgs::msg::dds_::Range_/{TS.hash_rihs01('sensor_msgs/msg/Range')}"
    robot = tmp_path / "triskar2.toml"
    robot.write_text(TRISKAR2.read_text().split("[[teleop]]")[0])
    port = free_port()
    router = Router(port)
    relay = Relay(port)
    sim = SocketcandProcess([str(R2P), "sim", str(robot), "--realtime", "--zenoh", f"tcp/127.0.0.1:{relay.port}"],
                            "r2p sim")
    peer = Peer(port)  # /odom
    statuses = []
    status_sub = peer.session.declare_subscriber(
        status_key, lambda s: statuses.append(store.deserialize_cdr(bytes(s.payload.to_bytes()), "r2p_msgs/msg/GatewayStatus")))
    filtered = lambda: statuses[-1].ros_filtered if statuses else 0  # noqa: E731
    odom, range0, range1, battery = (cdr_frame_id(f) for f in ("odom", "range_0", "range_1", "battery"))
    try:
        # The router has answered the gateway's interests: the status counts held-back samples.
        wait_for("ros_filtered to count", lambda: filtered() > 0, timeout=20)
        before, mark = filtered(), len(relay.upstream())
        time.sleep(2.0)
        link, counted = relay.upstream()[mark:], filtered()
        assert link.count(odom) >= 30, "the subscribed /odom goes on (20 Hz)"
        held = [link.count(f) for f in (range0, range1, battery)]
        assert held == [0, 0, 0], "no sample of a key nobody subscribes to on the link"
        # Four ranges at 10 Hz alone are 40 a second; the status comes once a second.
        assert counted - before >= 40, (before, counted)
        # A subscriber on /range_0: its samples are on the link and reach it; /range_1's are not.
        got = []
        sub = peer.session.declare_subscriber(range_key, lambda s: got.append(bytes(s.payload.to_bytes())))
        wait_for("/range_0 samples", lambda: len(got) >= 5, timeout=10)
        mark = len(relay.upstream())
        time.sleep(1.0)
        link = relay.upstream()[mark:]
        assert link.count(range0) >= 8 and link.count(range1) == 0, (link.count(range0), link.count(range1))
        assert TS.deserialize_cdr(got[-1], "sensor_msgs/msg/Range").header.frame_id == "range_0"
        sub.undeclare()
    finally:
        status_sub.undeclare()
        peer.close()
        sim.kill()
        relay.close()
        router.close()


def test_the_gateways_tokens_go_when_it_goes(ros):
    """Last (it stops the robot): `ros2 node list` forgets a gateway that is switched off."""
    peer = ros["peer"]
    assert any("r2p_gateway" in t for t in peer.tokens())
    ros["sim"].kill()
    wait_for("the tokens to go", lambda: not any("r2p_gateway" in t for t in peer.tokens()), timeout=12)
