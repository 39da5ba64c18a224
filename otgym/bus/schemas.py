"""The ROS 2 message types otgym's topics use (``otgym.bus.messages``), as schema text
in MCAP's ``ros2msg`` encoding (``SCHEMAS``: the type's own definition, then each
dependency after a line of 80 ``=`` and ``MSG: pkg/Type``; the definitions of ROS 2
Humble's common_interfaces), and their CDR encoders and decoders (mcap-ros2-support's
dynamic serialiser)."""

from __future__ import annotations

from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

_RULE = "=" * 80
_HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
_VECTOR3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
_POSE = (
    "MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n"
    + _RULE
    + "\nMSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n"
    + _RULE
    + "\nMSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
)


def _schema(body: str, *dependencies: str) -> str:
    return "\n".join([body, *(f"{_RULE}\n{d}" for d in dependencies)])


POSE_ARRAY = "geometry_msgs/msg/PoseArray"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
JOY = "sensor_msgs/msg/Joy"
FLOAT64 = "std_msgs/msg/Float64"
STRING = "std_msgs/msg/String"
PATH = "nav_msgs/msg/Path"
TWIST = "geometry_msgs/msg/Twist"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"

SCHEMAS: dict[str, str] = {
    POSE_ARRAY: _schema("std_msgs/Header header\ngeometry_msgs/Pose[] poses\n", _HEADER, _POSE),
    TWIST_STAMPED: _schema(
        "std_msgs/Header header\nTwist twist\n",
        _HEADER,
        "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n",
        _VECTOR3,
    ),
    WRENCH_STAMPED: _schema(
        "std_msgs/Header header\nWrench wrench\n",
        _HEADER,
        "MSG: geometry_msgs/Wrench\nVector3 force\nVector3 torque\n",
        _VECTOR3,
    ),
    JOY: _schema("std_msgs/Header header\nfloat32[] axes\nint32[] buttons\n", _HEADER),
    FLOAT64: "float64 data\n",
    STRING: "string data\n",
    PATH: _schema(
        "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
        _HEADER,
        "MSG: geometry_msgs/PoseStamped\nstd_msgs/Header header\nPose pose\n",
        _POSE,
    ),
    COMPRESSED_IMAGE: _schema("std_msgs/Header header\nstring format\nuint8[] data\n", _HEADER),
    TWIST: _schema("Vector3 linear\nVector3 angular\n", _VECTOR3),
}
"""ros2msg schema text per type (definitions of ROS 2 Humble's common_interfaces)."""

ENCODERS = {name: serialize_dynamic(name, text)[name] for name, text in SCHEMAS.items()}
DECODERS = {name: generate_dynamic(name, text)[name] for name, text in SCHEMAS.items()}
