# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
ros2msg definitions of the recorded types, each with every nested type.

Field lines of the ROS 2 Kilted interface files (comments dropped), joined as
rosbag2 writes them into MCAP schemas: the top type, then each dependency after
a line of 80 "=" and a "MSG: package/Type" line.
"""

SEPARATOR = '=' * 80


def _join(*parts):
    """Join a top definition and its (name, text) dependencies."""
    text = parts[0]
    for name, body in parts[1:]:
        text += f'{SEPARATOR}\nMSG: {name}\n{body}'
    return text


_TIME = 'int32 sec\nuint32 nanosec\n'
_POINT = 'float64 x\nfloat64 y\nfloat64 z\n'
_POSE = 'Point position\nQuaternion orientation\n'
_QUATERNION = 'float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n'
_TWIST = 'Vector3 linear\nVector3 angular\n'
_VECTOR3 = 'float64 x\nfloat64 y\nfloat64 z\n'
_WRENCH = 'Vector3 force\nVector3 torque\n'
_HEADER = 'builtin_interfaces/Time stamp\nstring frame_id\n'

#: Full ros2msg schema text per type name.
DEFINITIONS = {
    'geometry_msgs/msg/PoseStamped': _join(
        'std_msgs/Header header\nPose pose\n',
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/Pose', _POSE),
        ('geometry_msgs/Point', _POINT),
        ('geometry_msgs/Quaternion', _QUATERNION)),
    'geometry_msgs/msg/TwistStamped': _join(
        'std_msgs/Header header\nTwist twist\n',
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/Twist', _TWIST),
        ('geometry_msgs/Vector3', _VECTOR3)),
    'geometry_msgs/msg/WrenchStamped': _join(
        'std_msgs/Header header\nWrench wrench\n',
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/Wrench', _WRENCH),
        ('geometry_msgs/Vector3', _VECTOR3)),
    'std_msgs/msg/String': _join(
        'string data\n'),
}
