"""scripts/msggen ros: the r2p_msgs ROS 2 package and the RIHS01 type hashes the gateway names its
Zenoh key expressions with, checked against an independent implementation (PyPI rosbags)."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from r2ptools import msggen, msgs, rihs

ROS_TYPES = {"geometry_msgs/msg/Twist", "nav_msgs/msg/Odometry", "sensor_msgs/msg/BatteryState",
             "sensor_msgs/msg/Range", "sensor_msgs/msg/Imu", "sensor_msgs/msg/MagneticField",
             "sensor_msgs/msg/FluidPressure", "sensor_msgs/msg/NavSatFix"}


@pytest.fixture(scope="module")
def jazzy():
    return get_typestore(Stores.ROS2_JAZZY)


@pytest.fixture(scope="module")
def r2p_store():
    """rosbags' Jazzy store with every committed r2p_msgs/msg/*.msg registered from its text."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for path in sorted((msggen.ROS_OUT / "msg").glob("*.msg")):
        store.register(get_types_from_msg(path.read_text(), f"r2p_msgs/msg/{path.stem}"))
    return store


def test_the_mapped_standard_types_hash_as_rosbags_hashes_them(jazzy):
    assert set(rihs.MAPPED) == ROS_TYPES
    for name in rihs.MAPPED:
        assert rihs.rihs01(name, rihs.STANDARD) == jazzy.hash_rihs01(name), name
    # The note's values (docs/ros2.md's table uses them too).
    assert rihs.rihs01("nav_msgs/msg/Odometry", rihs.STANDARD) == \
        "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"


def test_every_r2p_type_hashes_as_rosbags_hashes_its_generated_msg(r2p_store):
    types = msgs.load()
    ours = msggen.ros_hashes(types)
    for t in types.values():
        name = f"r2p_msgs/msg/{t.name}"
        assert ours[name] == r2p_store.hash_rihs01(name), name
    assert len({h for n, h in ours.items() if n.startswith("r2p_msgs/")}) == len(types)


def test_the_hash_covers_types_names_and_arrays_but_not_comments():
    base = {"a/msg/T": "float32 x  # one comment\nuint8[4] s"}
    h = rihs.rihs01("a/msg/T", base)
    assert rihs.rihs01("a/msg/T", {"a/msg/T": "# other\nfloat32 x # other\nuint8[4] s"}) == h
    assert rihs.rihs01("a/msg/T", {"a/msg/T": "float32 x\nuint8[3] s"}) != h
    assert rihs.rihs01("a/msg/T", {"a/msg/T": "float64 x\nuint8[4] s"}) != h
    assert rihs.rihs01("a/msg/T", {"a/msg/T": "float32 y\nuint8[4] s"}) != h
    assert rihs.rihs01("a/msg/T", {"a/msg/T": "float32 x\nuint8[] s"}) != h
    assert rihs.rihs01("a/msg/T", {"a/msg/T": "uint8 K=3\nfloat32 x\nuint8[4] s"}) == h


def test_a_type_with_a_missing_reference_says_which():
    with pytest.raises(rihs.RosMsgError, match="a/msg/T refers to a/msg/U"):
        rihs.rihs01("a/msg/T", {"a/msg/T": "U u"})


def test_the_generated_types_rs_carries_the_same_hashes():
    text = msggen.ZENOH_TYPES_OUT.read_text()
    for name, h in msggen.ros_hashes(msgs.load()).items():
        assert f'"{rihs.dds_type_name(name)}"' in text, name
        assert re.search(rf'dds_name: "{re.escape(rihs.dds_type_name(name))}",\s*hash: "{h}"', text), name


def test_the_ros_package_builds_every_message():
    pkg = ET.parse(msggen.ROS_OUT / "package.xml").getroot()
    assert pkg.get("format") == "3" and pkg.findtext("name") == "r2p_msgs"
    assert pkg.findtext("member_of_group") == "rosidl_interface_packages"
    assert {e.text for e in pkg.findall("buildtool_depend")} == {"ament_cmake", "rosidl_default_generators"}
    cmake = (msggen.ROS_OUT / "CMakeLists.txt").read_text()
    listed = re.findall(r'"msg/(\w+)\.msg"', cmake)
    assert listed == sorted(msgs.load()) == sorted(p.stem for p in (msggen.ROS_OUT / "msg").glob("*.msg"))
    assert "rosidl_generate_interfaces(${PROJECT_NAME}" in cmake


def test_generated_msg_has_the_schemas_fields_and_cdr_decodes_what_r2p_encodes(r2p_store):
    """The same fields in the same order: a Proximity's values survive R2P's packed encoding →
    the gateway's CDR layout (rosbags serializes here as the gateway's generic path must)."""
    t = msgs.load()["Proximity"]
    assert [ln.split("#")[0].split() for ln in (msggen.ROS_OUT / "msg" / "Proximity.msg").read_text().splitlines()
            if ln and not ln.startswith("#")] == [f.canonical.split() for f in t.fields]
    cls = r2p_store.types["r2p_msgs/msg/Proximity"]
    import numpy as np
    msg = cls(distance=np.array([0.5, 1.0, 1.5, 2.0], dtype=np.float32),
              status=np.array([0, 1, 2, 3], dtype=np.uint8), supply_fault=True)
    cdr = bytes(r2p_store.serialize_cdr(msg, "r2p_msgs/msg/Proximity"))
    assert cdr[:4] == b"\x00\x01\x00\x00"       # CDR, little-endian
    assert len(cdr) == 4 + 16 + 4 + 1


def test_check_finds_a_stale_ros_package(tmp_path, monkeypatch):
    out = tmp_path / "r2p_msgs"
    monkeypatch.setattr(msggen, "ROS_OUT", out)
    monkeypatch.setattr(msggen, "ZENOH_TYPES_OUT", tmp_path / "types.rs")
    files = msggen.generate_ros(msgs.load())
    for path, text in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    monkeypatch.setattr(msggen, "RUST_OUT", msggen.RUST_OUT)
    assert msggen.check(msgs.MSG_DIR) == 0
    (out / "msg" / "Battery.msg").write_text("float32 voltage\n")
    assert msggen.check(msgs.MSG_DIR) == 1
