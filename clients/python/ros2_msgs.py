"""The ROS 2 (Jazzy) messages that `lives ros2` and the simulated robot exchange, as PyPI
`cyclonedds` IDL dataclasses with the DDS type names every ROS 2 DDS middleware uses
(``pkg::msg::dds_::Name_``), so that they match `lives ros2` (and a real ROS 2 node) on the wire.

Field order and types follow the ``.msg`` definitions of ROS 2 Jazzy (common_interfaces 5.3,
vision_msgs 4.x); ``float64[36]`` covariances are fixed-size arrays, ``T[]`` are sequences.
Encode with XCDR1 (ROS 2's ``CDR_LE``), see :data:`XCDR1` in ``ros2_sim_robot.py``.

Types: builtin_interfaces Time, Duration; std_msgs Header, ColorRGBA, Bool, String;
geometry_msgs Point, Vector3, Quaternion, Pose, PointStamped, PoseStamped, PoseWithCovariance, Twist,
TwistWithCovariance, Transform, TransformStamped; sensor_msgs LaserScan, PointField, PointCloud2,
CompressedImage;
nav_msgs Odometry, Path, MapMetaData, OccupancyGrid; tf2_msgs TFMessage; visualization_msgs
UVCoordinate, MeshFile, Marker, MarkerArray; vision_msgs Point2D, Pose2D, BoundingBox2D,
ObjectHypothesis, ObjectHypothesisWithPose, Detection2D, Detection2DArray.
"""
import types
import typing
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int8, int32, sequence, uint8, uint32


def _default(t):
    """The default of a field of IDL type ``t``, as a ``.msg`` field without one starts: zero,
    false, empty, a default message, or a fixed-size array of zeros."""
    if isinstance(t, type) and issubclass(t, IdlStruct):
        return field(default_factory=t)
    if t is str:
        return ""
    if t is bool:
        return False
    base, holder = typing.get_args(t)
    if isinstance(holder, array):
        zero = _default(holder.subtype)
        return field(default_factory=lambda: [zero] * holder.length)
    if isinstance(holder, sequence):
        return field(default_factory=list)
    return base()  # int or float: 0 or 0.0


def _msg(pkg, name, /, **fields):
    """The dataclass of ROS 2 message ``pkg/msg/name`` with DDS type name ``pkg::msg::dds_::name_``,
    its fields in ``.msg`` order as ``field=type`` (or ``field=(type, default)``)."""

    def body(ns):
        ns["__module__"] = __name__
        for key, spec in fields.items():
            t, default = spec if isinstance(spec, tuple) else (spec, _default(spec))
            ns["__annotations__"][key] = t
            ns[key] = default

    kwds = {"typename": f"{pkg}::msg::dds_::{name}_"}
    return dataclass(types.new_class(name, (IdlStruct,), kwds, body))


# builtin_interfaces
Time = _msg("builtin_interfaces", "Time", sec=int32, nanosec=uint32)
Duration = _msg("builtin_interfaces", "Duration", sec=int32, nanosec=uint32)

# std_msgs
Header = _msg("std_msgs", "Header", stamp=Time, frame_id=str)
ColorRGBA = _msg("std_msgs", "ColorRGBA", r=float32, g=float32, b=float32, a=float32)
Bool = _msg("std_msgs", "Bool", data=bool)
String = _msg("std_msgs", "String", data=str)

# geometry_msgs
Point = _msg("geometry_msgs", "Point", x=float64, y=float64, z=float64)
Vector3 = _msg("geometry_msgs", "Vector3", x=float64, y=float64, z=float64)
Quaternion = _msg("geometry_msgs", "Quaternion", x=float64, y=float64, z=float64, w=(float64, 1.0))
Pose = _msg("geometry_msgs", "Pose", position=Point, orientation=Quaternion)
PointStamped = _msg("geometry_msgs", "PointStamped", header=Header, point=Point)
PoseStamped = _msg("geometry_msgs", "PoseStamped", header=Header, pose=Pose)
_COVARIANCE = array[float64, 36]
PoseWithCovariance = _msg("geometry_msgs", "PoseWithCovariance", pose=Pose, covariance=_COVARIANCE)
Twist = _msg("geometry_msgs", "Twist", linear=Vector3, angular=Vector3)
TwistWithCovariance = _msg(
    "geometry_msgs", "TwistWithCovariance", twist=Twist, covariance=_COVARIANCE
)
Transform = _msg("geometry_msgs", "Transform", translation=Vector3, rotation=Quaternion)
TransformStamped = _msg(
    "geometry_msgs", "TransformStamped", header=Header, child_frame_id=str, transform=Transform
)

# sensor_msgs
LaserScan = _msg(
    "sensor_msgs", "LaserScan", header=Header,
    angle_min=float32, angle_max=float32, angle_increment=float32,
    time_increment=float32, scan_time=float32,
    range_min=float32, range_max=float32,
    ranges=sequence[float32], intensities=sequence[float32],
)  # fmt: skip
PointField = _msg("sensor_msgs", "PointField", name=str, offset=uint32, datatype=uint8, count=uint32)
PointCloud2 = _msg(
    "sensor_msgs", "PointCloud2", header=Header, height=uint32, width=uint32,
    fields=sequence[PointField], is_bigendian=bool, point_step=uint32, row_step=uint32,
    data=sequence[uint8], is_dense=bool,
)  # fmt: skip
CompressedImage = _msg(
    "sensor_msgs", "CompressedImage", header=Header, format=str, data=sequence[uint8]
)

# nav_msgs
Odometry = _msg(
    "nav_msgs", "Odometry",
    header=Header, child_frame_id=str, pose=PoseWithCovariance, twist=TwistWithCovariance,
)  # fmt: skip
Path = _msg("nav_msgs", "Path", header=Header, poses=sequence[PoseStamped])
MapMetaData = _msg(
    "nav_msgs", "MapMetaData",
    map_load_time=Time, resolution=float32, width=uint32, height=uint32, origin=Pose,
)  # fmt: skip
OccupancyGrid = _msg(
    "nav_msgs", "OccupancyGrid", header=Header, info=MapMetaData, data=sequence[int8]
)

# tf2_msgs
TFMessage = _msg("tf2_msgs", "TFMessage", transforms=sequence[TransformStamped])

# visualization_msgs (Jazzy: textures and embedded meshes)
UVCoordinate = _msg("visualization_msgs", "UVCoordinate", u=float32, v=float32)
MeshFile = _msg("visualization_msgs", "MeshFile", filename=str, data=sequence[uint8])
Marker = _msg(
    "visualization_msgs", "Marker", header=Header,
    ns=str, id=int32, type=int32, action=int32,
    pose=Pose, scale=Vector3, color=ColorRGBA, lifetime=Duration, frame_locked=bool,
    points=sequence[Point], colors=sequence[ColorRGBA],
    texture_resource=str, texture=CompressedImage, uv_coordinates=sequence[UVCoordinate],
    text=str, mesh_resource=str, mesh_file=MeshFile, mesh_use_embedded_materials=bool,
)  # fmt: skip
MarkerArray = _msg("visualization_msgs", "MarkerArray", markers=sequence[Marker])

# vision_msgs 4.x
Point2D = _msg("vision_msgs", "Point2D", x=float64, y=float64)
Pose2D = _msg("vision_msgs", "Pose2D", position=Point2D, theta=float64)
BoundingBox2D = _msg("vision_msgs", "BoundingBox2D", center=Pose2D, size_x=float64, size_y=float64)
ObjectHypothesis = _msg("vision_msgs", "ObjectHypothesis", class_id=str, score=float64)
ObjectHypothesisWithPose = _msg(
    "vision_msgs", "ObjectHypothesisWithPose", hypothesis=ObjectHypothesis, pose=PoseWithCovariance
)
Detection2D = _msg(
    "vision_msgs", "Detection2D",
    header=Header, results=sequence[ObjectHypothesisWithPose], bbox=BoundingBox2D, id=str,
)  # fmt: skip
Detection2DArray = _msg(
    "vision_msgs", "Detection2DArray", header=Header, detections=sequence[Detection2D]
)
