"""ROS 2 interface type hashes (RIHS01, REP 2011) and the ROS 2 messages the gateway maps R2P
topics to: what `scripts/msggen ros` needs to name a topic the way rmw_zenoh does
(`<domain>/<topic>/<pkg>::msg::dds_::<Type>_/RIHS01_<sha256>`).

RIHS01 is the SHA-256 of a JSON text: the type's description (its name and its fields, each field
a type id, an array capacity, a string capacity and a nested type's name) and, sorted by name, the
descriptions of every type it refers to. Comments, constants and default values are not in it, so
a schema's comments can change without changing its hash. The JSON is Python's `json.dumps` with
its default separators (", " and ": "), as rosidl's generator writes it.

This is the project's own implementation; tests/test_ros2_msgs.py checks it against PyPI rosbags'
`hash_rihs01`, an independent one.
"""
from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass

# rosidl's FieldType ids (type_description_interfaces/msg/FieldType.msg)
TYPE_IDS = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
    "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "long double": 12, "char": 13,
    "wchar": 14, "bool": 15, "byte": 16, "string": 17, "wstring": 18, "fixed_string": 19,
    "fixed_wstring": 20, "bounded_string": 21, "bounded_wstring": 22,
}
ARRAY, BOUNDED_SEQUENCE, UNBOUNDED_SEQUENCE = 48, 96, 144   # added to the element's id

# The standard messages the gateway publishes or subscribes to, and the ones they refer to
# (ROS 2 Jazzy's common_interfaces; comments and constants left out: they are not hashed).
STANDARD = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/msg/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w",
    "geometry_msgs/msg/Pose": "Point position\nQuaternion orientation",
    "geometry_msgs/msg/Twist": "Vector3 linear\nVector3 angular",
    "geometry_msgs/msg/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
    "geometry_msgs/msg/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
    "nav_msgs/msg/Odometry": ("std_msgs/Header header\nstring child_frame_id\n"
                              "geometry_msgs/PoseWithCovariance pose\n"
                              "geometry_msgs/TwistWithCovariance twist"),
    "sensor_msgs/msg/BatteryState": (
        "std_msgs/Header header\nfloat32 voltage\nfloat32 temperature\nfloat32 current\n"
        "float32 charge\nfloat32 capacity\nfloat32 design_capacity\nfloat32 percentage\n"
        "uint8 power_supply_status\nuint8 power_supply_health\nuint8 power_supply_technology\n"
        "bool present\nfloat32[] cell_voltage\nfloat32[] cell_temperature\nstring location\n"
        "string serial_number"),
    "sensor_msgs/msg/Range": ("std_msgs/Header header\nuint8 radiation_type\nfloat32 field_of_view\n"
                              "float32 min_range\nfloat32 max_range\nfloat32 range\nfloat32 variance"),
    "sensor_msgs/msg/Imu": (
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
        "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
        "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
        "float64[9] linear_acceleration_covariance"),
    "sensor_msgs/msg/MagneticField": (
        "std_msgs/Header header\ngeometry_msgs/Vector3 magnetic_field\n"
        "float64[9] magnetic_field_covariance"),
    "sensor_msgs/msg/FluidPressure": "std_msgs/Header header\nfloat64 fluid_pressure\nfloat64 variance",
    "sensor_msgs/msg/NavSatStatus": "int8 status\nuint16 service",
    "sensor_msgs/msg/NavSatFix": (
        "std_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\n"
        "float64 altitude\nfloat64[9] position_covariance\nuint8 position_covariance_type"),
}
# The ones the gateway maps R2P topics to (the rest are parts of these).
MAPPED = ("geometry_msgs/msg/Twist", "nav_msgs/msg/Odometry", "sensor_msgs/msg/BatteryState",
          "sensor_msgs/msg/Range", "sensor_msgs/msg/Imu", "sensor_msgs/msg/MagneticField",
          "sensor_msgs/msg/FluidPressure", "sensor_msgs/msg/NavSatFix")

_LINE = re.compile(r"^(?P<type>[A-Za-z0-9_/]+)(?P<arr>\[(?P<bound><=)?(?P<n>\d*)\])?"
                   r"\s+(?P<name>[a-z][a-z0-9_]*)(?:\s+(?P<default>[^#]*?))?\s*(?:#.*)?$")
_CONSTANT = re.compile(r"^\S+\s+[A-Z][A-Z0-9_]*\s*=")
_BOUNDED_STRING = re.compile(r"^(w?string)<=(\d+)$")


class RosMsgError(ValueError):
    """A ROS .msg text this reader does not understand."""


@dataclass(frozen=True)
class RosField:
    name: str
    type_id: int
    capacity: int
    string_capacity: int
    nested: str          # full name of a nested type ("" for primitives and strings)


def _full_name(type_name: str, package: str) -> str:
    parts = type_name.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{parts[0]}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return type_name


def parse_msg(text: str, full_name: str) -> list[RosField]:
    """The fields of a .msg text (constants, comments and defaults skipped)."""
    package = full_name.split("/")[0]
    fields = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if _CONSTANT.match(line):
            continue                                             # a constant: not hashed
        m = _LINE.match(line)
        if not m:
            raise RosMsgError(f"{full_name}:{lineno}: cannot read {raw!r}")
        ty, name = m["type"], m["name"]
        string_capacity, nested = 0, ""
        bs = _BOUNDED_STRING.match(ty)
        if bs:
            base = TYPE_IDS["bounded_" + bs[1]]
            string_capacity = int(bs[2])
        elif ty in TYPE_IDS and ty not in ("nested", "fixed_string", "fixed_wstring"):
            base = TYPE_IDS[ty]
        elif ty in ("float", "double"):
            raise RosMsgError(f"{full_name}:{lineno}: write float32/float64, not {ty}")
        else:
            base, nested = TYPE_IDS["nested"], _full_name(ty, package)
        capacity = 0
        if m["arr"]:
            if m["bound"]:
                base, capacity = base + BOUNDED_SEQUENCE, int(m["n"])
            elif m["n"]:
                base, capacity = base + ARRAY, int(m["n"])
            else:
                base += UNBOUNDED_SEQUENCE
        fields.append(RosField(name, base, capacity, string_capacity, nested))
    return fields


def _description(full_name: str, fields: list[RosField]) -> dict:
    if not fields:   # rosidl gives an empty message one placeholder member
        fields = [RosField("structure_needs_at_least_one_member", TYPE_IDS["uint8"], 0, 0, "")]
    return {"type_name": full_name,
            "fields": [{"name": f.name, "type": {"type_id": f.type_id, "capacity": f.capacity,
                                                 "string_capacity": f.string_capacity,
                                                 "nested_type_name": f.nested}} for f in fields]}


def rihs01(full_name: str, definitions: dict[str, str]) -> str:
    """`RIHS01_<sha256 hex>` of `full_name` (e.g. "nav_msgs/msg/Odometry"), whose .msg text and
    those of the types it refers to are in `definitions` (full name -> .msg text)."""
    seen: dict[str, list[RosField]] = {}
    todo = [full_name]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        if name not in definitions:
            raise RosMsgError(f"{full_name} refers to {name}, whose definition is not given")
        seen[name] = parse_msg(definitions[name], name)
        todo += [f.nested for f in seen[name] if f.nested]
    hashed = {"type_description": _description(full_name, seen[full_name]),
              "referenced_type_descriptions": [_description(n, seen[n]) for n in sorted(seen)
                                               if n != full_name]}
    return "RIHS01_" + hashlib.sha256(json.dumps(hashed).encode()).hexdigest()


def dds_type_name(full_name: str) -> str:
    """rmw_zenoh's type name in key expressions: `pkg::msg::dds_::Type_`."""
    package, kind, name = full_name.split("/")
    return f"{package}::{kind}::dds_::{name}_"
