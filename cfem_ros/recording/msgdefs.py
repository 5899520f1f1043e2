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
_TRANSFORM = 'Vector3 translation\nQuaternion rotation\n'
_COLOR = 'float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n'
_MARKER = (
    'int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n'
    'int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n'
    'int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\n'
    'int32 ARROW_STRIP=12\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n'
    'std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n'
    'geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n'
    'builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n'
    'std_msgs/ColorRGBA[] colors\nstring texture_resource\n'
    'sensor_msgs/CompressedImage texture\nUVCoordinate[] uv_coordinates\nstring text\n'
    'string mesh_resource\nMeshFile mesh_file\nbool mesh_use_embedded_materials\n')

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
    'geometry_msgs/msg/Vector3Stamped': _join(
        'std_msgs/Header header\nVector3 vector\n',
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/Vector3', _VECTOR3)),
    'nav_msgs/msg/Odometry': _join(
        'std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n'
        'geometry_msgs/TwistWithCovariance twist\n',
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/PoseWithCovariance', 'Pose pose\nfloat64[36] covariance\n'),
        ('geometry_msgs/Pose', _POSE),
        ('geometry_msgs/Point', _POINT),
        ('geometry_msgs/Quaternion', _QUATERNION),
        ('geometry_msgs/TwistWithCovariance', 'Twist twist\nfloat64[36] covariance\n'),
        ('geometry_msgs/Twist', _TWIST),
        ('geometry_msgs/Vector3', _VECTOR3)),
    'std_msgs/msg/String': _join(
        'string data\n'),
    'tf2_msgs/msg/TFMessage': _join(
        'geometry_msgs/TransformStamped[] transforms\n',
        ('geometry_msgs/TransformStamped',
         'std_msgs/Header header\nstring child_frame_id\nTransform transform\n'),
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/Transform', _TRANSFORM),
        ('geometry_msgs/Vector3', _VECTOR3),
        ('geometry_msgs/Quaternion', _QUATERNION)),
    'visualization_msgs/msg/MarkerArray': _join(
        'Marker[] markers\n',
        ('visualization_msgs/Marker', _MARKER),
        ('std_msgs/Header', _HEADER),
        ('builtin_interfaces/Time', _TIME),
        ('geometry_msgs/Pose', _POSE),
        ('geometry_msgs/Point', _POINT),
        ('geometry_msgs/Quaternion', _QUATERNION),
        ('geometry_msgs/Vector3', _VECTOR3),
        ('std_msgs/ColorRGBA', _COLOR),
        ('builtin_interfaces/Duration', _TIME),
        ('sensor_msgs/CompressedImage', 'std_msgs/Header header\nstring format\nuint8[] data\n'),
        ('visualization_msgs/UVCoordinate', 'float32 u\nfloat32 v\n'),
        ('visualization_msgs/MeshFile', 'string filename\nuint8[] data\n')),
}
