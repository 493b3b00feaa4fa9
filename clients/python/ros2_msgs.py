"""The ROS 2 (Jazzy) messages that `lives ros2` and the simulated robot exchange, as PyPI
`cyclonedds` IDL dataclasses with the DDS type names every ROS 2 DDS middleware uses
(``pkg::msg::dds_::Name_``), so that they match `lives ros2` (and a real ROS 2 node) on the wire.

Field order and types follow the ``.msg`` definitions of ROS 2 Jazzy (common_interfaces 5.3,
vision_msgs 4.x); ``float64[36]`` covariances are fixed-size arrays, ``T[]`` are sequences.
Encode with XCDR1 (ROS 2's ``CDR_LE``), see :data:`XCDR1` in ``ros2_sim_robot.py``.

Types: builtin_interfaces Time, Duration; std_msgs Header, ColorRGBA, Bool, String;
geometry_msgs Point, Vector3, Quaternion, Pose, PointStamped, PoseStamped, PoseWithCovariance, Twist,
TwistWithCovariance, Transform, TransformStamped; sensor_msgs LaserScan, CompressedImage;
nav_msgs Odometry, Path, MapMetaData, OccupancyGrid; tf2_msgs TFMessage; visualization_msgs
UVCoordinate, MeshFile, Marker, MarkerArray; vision_msgs Point2D, Pose2D, BoundingBox2D,
ObjectHypothesis, ObjectHypothesisWithPose, Detection2D, Detection2DArray.
"""
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int8, int32, sequence, uint8, uint32


def _t(pkg, name):
    return f"{pkg}::msg::dds_::{name}_"


# builtin_interfaces
@dataclass
class Time(IdlStruct, typename=_t("builtin_interfaces", "Time")):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Duration(IdlStruct, typename=_t("builtin_interfaces", "Duration")):
    sec: int32 = 0
    nanosec: uint32 = 0


# std_msgs
@dataclass
class Header(IdlStruct, typename=_t("std_msgs", "Header")):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class ColorRGBA(IdlStruct, typename=_t("std_msgs", "ColorRGBA")):
    r: float32 = 0.0
    g: float32 = 0.0
    b: float32 = 0.0
    a: float32 = 0.0


@dataclass
class Bool(IdlStruct, typename=_t("std_msgs", "Bool")):
    data: bool = False


@dataclass
class String(IdlStruct, typename=_t("std_msgs", "String")):
    data: str = ""


# geometry_msgs
@dataclass
class Point(IdlStruct, typename=_t("geometry_msgs", "Point")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Vector3(IdlStruct, typename=_t("geometry_msgs", "Vector3")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename=_t("geometry_msgs", "Quaternion")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Pose(IdlStruct, typename=_t("geometry_msgs", "Pose")):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PointStamped(IdlStruct, typename=_t("geometry_msgs", "PointStamped")):
    header: Header = field(default_factory=Header)
    point: Point = field(default_factory=Point)


@dataclass
class PoseStamped(IdlStruct, typename=_t("geometry_msgs", "PoseStamped")):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass
class PoseWithCovariance(IdlStruct, typename=_t("geometry_msgs", "PoseWithCovariance")):
    pose: Pose = field(default_factory=Pose)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Twist(IdlStruct, typename=_t("geometry_msgs", "Twist")):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistWithCovariance(IdlStruct, typename=_t("geometry_msgs", "TwistWithCovariance")):
    twist: Twist = field(default_factory=Twist)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Transform(IdlStruct, typename=_t("geometry_msgs", "Transform")):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename=_t("geometry_msgs", "TransformStamped")):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


# sensor_msgs
@dataclass
class LaserScan(IdlStruct, typename=_t("sensor_msgs", "LaserScan")):
    header: Header = field(default_factory=Header)
    angle_min: float32 = 0.0
    angle_max: float32 = 0.0
    angle_increment: float32 = 0.0
    time_increment: float32 = 0.0
    scan_time: float32 = 0.0
    range_min: float32 = 0.0
    range_max: float32 = 0.0
    ranges: sequence[float32] = field(default_factory=list)
    intensities: sequence[float32] = field(default_factory=list)


@dataclass
class CompressedImage(IdlStruct, typename=_t("sensor_msgs", "CompressedImage")):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: sequence[uint8] = field(default_factory=list)


# nav_msgs
@dataclass
class Odometry(IdlStruct, typename=_t("nav_msgs", "Odometry")):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class Path(IdlStruct, typename=_t("nav_msgs", "Path")):
    header: Header = field(default_factory=Header)
    poses: sequence[PoseStamped] = field(default_factory=list)


@dataclass
class MapMetaData(IdlStruct, typename=_t("nav_msgs", "MapMetaData")):
    map_load_time: Time = field(default_factory=Time)
    resolution: float32 = 0.0
    width: uint32 = 0
    height: uint32 = 0
    origin: Pose = field(default_factory=Pose)


@dataclass
class OccupancyGrid(IdlStruct, typename=_t("nav_msgs", "OccupancyGrid")):
    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: sequence[int8] = field(default_factory=list)


# tf2_msgs
@dataclass
class TFMessage(IdlStruct, typename=_t("tf2_msgs", "TFMessage")):
    transforms: sequence[TransformStamped] = field(default_factory=list)


# visualization_msgs (Jazzy: textures and embedded meshes)
@dataclass
class UVCoordinate(IdlStruct, typename=_t("visualization_msgs", "UVCoordinate")):
    u: float32 = 0.0
    v: float32 = 0.0


@dataclass
class MeshFile(IdlStruct, typename=_t("visualization_msgs", "MeshFile")):
    filename: str = ""
    data: sequence[uint8] = field(default_factory=list)


@dataclass
class Marker(IdlStruct, typename=_t("visualization_msgs", "Marker")):
    header: Header = field(default_factory=Header)
    ns: str = ""
    id: int32 = 0
    type: int32 = 0
    action: int32 = 0
    pose: Pose = field(default_factory=Pose)
    scale: Vector3 = field(default_factory=Vector3)
    color: ColorRGBA = field(default_factory=ColorRGBA)
    lifetime: Duration = field(default_factory=Duration)
    frame_locked: bool = False
    points: sequence[Point] = field(default_factory=list)
    colors: sequence[ColorRGBA] = field(default_factory=list)
    texture_resource: str = ""
    texture: CompressedImage = field(default_factory=CompressedImage)
    uv_coordinates: sequence[UVCoordinate] = field(default_factory=list)
    text: str = ""
    mesh_resource: str = ""
    mesh_file: MeshFile = field(default_factory=MeshFile)
    mesh_use_embedded_materials: bool = False


@dataclass
class MarkerArray(IdlStruct, typename=_t("visualization_msgs", "MarkerArray")):
    markers: sequence[Marker] = field(default_factory=list)


# vision_msgs 4.x
@dataclass
class Point2D(IdlStruct, typename=_t("vision_msgs", "Point2D")):
    x: float64 = 0.0
    y: float64 = 0.0


@dataclass
class Pose2D(IdlStruct, typename=_t("vision_msgs", "Pose2D")):
    position: Point2D = field(default_factory=Point2D)
    theta: float64 = 0.0


@dataclass
class BoundingBox2D(IdlStruct, typename=_t("vision_msgs", "BoundingBox2D")):
    center: Pose2D = field(default_factory=Pose2D)
    size_x: float64 = 0.0
    size_y: float64 = 0.0


@dataclass
class ObjectHypothesis(IdlStruct, typename=_t("vision_msgs", "ObjectHypothesis")):
    class_id: str = ""
    score: float64 = 0.0


@dataclass
class ObjectHypothesisWithPose(IdlStruct, typename=_t("vision_msgs", "ObjectHypothesisWithPose")):
    hypothesis: ObjectHypothesis = field(default_factory=ObjectHypothesis)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass
class Detection2D(IdlStruct, typename=_t("vision_msgs", "Detection2D")):
    header: Header = field(default_factory=Header)
    results: sequence[ObjectHypothesisWithPose] = field(default_factory=list)
    bbox: BoundingBox2D = field(default_factory=BoundingBox2D)
    id: str = ""


@dataclass
class Detection2DArray(IdlStruct, typename=_t("vision_msgs", "Detection2DArray")):
    header: Header = field(default_factory=Header)
    detections: sequence[Detection2D] = field(default_factory=list)
