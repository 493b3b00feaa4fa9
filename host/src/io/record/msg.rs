//! The recorded messages as serde types, field for field as Foxglove's JSON schemas
//! (`schemas/*.json`) lay them out, plus `lives.Status`.

use firmware::protocol::StatusMsg;
use firmware::{BinaryAngle, Pose2};
use serde::ser::{SerializeStruct, Serializer};
use serde::Serialize;

/// `time`: seconds and nanoseconds.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Time {
    pub sec: u64,
    pub nsec: u32,
}

impl Time {
    pub fn of(t_us: u64) -> Self {
        Time { sec: t_us / 1_000_000, nsec: (t_us % 1_000_000) as u32 * 1000 }
    }
}

/// `duration`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DurationMsg {
    pub sec: i64,
    pub nsec: u32,
}

/// `foxglove.Vector2`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Vec2 {
    pub x: f64,
    pub y: f64,
}

/// `foxglove.Vector3` (also `foxglove.Point3`).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Vec3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl Vec3 {
    pub const ZERO: Vec3 = Vec3 { x: 0.0, y: 0.0, z: 0.0 };
}

/// `foxglove.Quaternion`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Quat {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quat {
    pub const IDENTITY: Quat = Quat { x: 0.0, y: 0.0, z: 0.0, w: 1.0 };

    /// A rotation by `yaw` about z (REP-103: counter-clockwise seen from above).
    pub fn yaw(yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Quat { x: 0.0, y: 0.0, z: s, w: c }
    }
}

/// `foxglove.Pose`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Pose {
    pub position: Vec3,
    pub orientation: Quat,
}

impl Pose {
    pub const IDENTITY: Pose = Pose { position: Vec3::ZERO, orientation: Quat::IDENTITY };

    pub fn xy_yaw(x: f64, y: f64, yaw: f64) -> Self {
        Pose { position: Vec3 { x, y, z: 0.0 }, orientation: Quat::yaw(yaw) }
    }

    pub fn of(p: &Pose2) -> Self {
        Pose::xy_yaw(p.x.to_num::<f64>(), p.y.to_num::<f64>(), p.theta.to_radians())
    }
}

/// `foxglove.FrameTransform`.
#[derive(Debug, Serialize)]
pub struct FrameTransform {
    pub timestamp: Time,
    pub parent_frame_id: &'static str,
    pub child_frame_id: &'static str,
    pub translation: Vec3,
    pub rotation: Quat,
}

/// `foxglove.FrameTransforms`.
#[derive(Debug, Serialize)]
pub struct FrameTransforms {
    pub transforms: [FrameTransform; 2],
}

/// `foxglove.PoseInFrame`.
#[derive(Debug, Serialize)]
pub struct PoseInFrame {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub pose: Pose,
}

/// `foxglove.PosesInFrame`.
#[derive(Debug, Serialize)]
pub struct PosesInFrame {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub poses: Vec<Pose>,
}

/// `foxglove.PackedElementField`; `type` is `foxglove.NumericType`.
#[derive(Debug, Serialize)]
pub struct Field {
    pub name: &'static str,
    pub offset: u32,
    #[serde(rename = "type")]
    pub kind: u8,
}

const UINT8: u8 = 1;
const INT8: u8 = 2;
const UINT16: u8 = 3;
const FLOAT32: u8 = 7;

/// Points of x, y, z (float32), one attribute `name` of `kind` and `size` bytes, then red,
/// green, blue, alpha (uint8).
const fn point_fields(name: &'static str, kind: u8, size: u32) -> [Field; 8] {
    let rgba = 12 + size;
    [
        Field { name: "x", offset: 0, kind: FLOAT32 },
        Field { name: "y", offset: 4, kind: FLOAT32 },
        Field { name: "z", offset: 8, kind: FLOAT32 },
        Field { name, offset: 12, kind },
        Field { name: "red", offset: rgba, kind: UINT8 },
        Field { name: "green", offset: rgba + 1, kind: UINT8 },
        Field { name: "blue", offset: rgba + 2, kind: UINT8 },
        Field { name: "alpha", offset: rgba + 3, kind: UINT8 },
    ]
}

/// Scan points: x, y, z (float32), label (uint8: 0 unlabelled, 1 map, 2 non-map), red, green,
/// blue, alpha (uint8); 17 bytes.
pub const SCAN_FIELDS: [Field; 8] = point_fields("label", UINT8, 1);

/// Non-map points: x, y, z (float32), hits (uint16), red, green, blue, alpha; 18 bytes.
pub const NONMAP_FIELDS: [Field; 8] = point_fields("hits", UINT16, 2);

/// Grid cells: one int8 ROS occupancy value (−1 unknown, 0 free, 100 occupied).
pub const GRID_FIELDS: [Field; 1] = [Field { name: "occupancy", offset: 0, kind: INT8 }];

/// `foxglove.PointCloud`.
#[derive(Debug, Serialize)]
pub struct PointCloud {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub pose: Pose,
    pub point_stride: u32,
    pub fields: &'static [Field],
    /// Base64.
    pub data: String,
}

/// `foxglove.Grid`.
#[derive(Debug, Serialize)]
pub struct Grid<'a> {
    pub timestamp: Time,
    pub frame_id: &'a str,
    pub pose: Pose,
    pub column_count: u32,
    pub cell_size: Vec2,
    pub row_stride: u32,
    pub cell_stride: u32,
    pub fields: &'static [Field],
    /// Base64, row-major from the corner at `pose`.
    pub data: String,
}

/// `foxglove.Color`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

impl Color {
    pub fn rgba(r: f64, g: f64, b: f64, a: f64) -> Self {
        Color { r, g, b, a }
    }
}

/// `foxglove.KeyValuePair`.
#[derive(Debug, Serialize)]
pub struct KeyValue {
    pub key: &'static str,
    pub value: String,
}

impl KeyValue {
    pub fn new(key: &'static str, value: String) -> Self {
        KeyValue { key, value }
    }
}

/// `foxglove.ArrowPrimitive`.
#[derive(Debug, Serialize)]
pub struct Arrow {
    pub pose: Pose,
    pub shaft_length: f64,
    pub shaft_diameter: f64,
    pub head_length: f64,
    pub head_diameter: f64,
    pub color: Color,
}

/// `foxglove.SpherePrimitive`.
#[derive(Debug, Serialize)]
pub struct Sphere {
    pub pose: Pose,
    pub size: Vec3,
    pub color: Color,
}

/// `foxglove.TextPrimitive`.
#[derive(Debug, Serialize)]
pub struct Text {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

impl Text {
    /// A billboard text of `font_size` pixels.
    pub fn new(pose: Pose, font_size: f64, color: Color, text: String) -> Self {
        Text { pose, billboard: true, font_size, scale_invariant: true, color, text }
    }
}

/// `foxglove.SceneEntity` (the primitive kinds not used here stay empty arrays).
#[derive(Debug, Serialize)]
pub struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub id: String,
    pub lifetime: DurationMsg,
    pub frame_locked: bool,
    pub metadata: Vec<KeyValue>,
    pub arrows: Vec<Arrow>,
    pub cubes: [u8; 0],
    pub spheres: Vec<Sphere>,
    pub cylinders: [u8; 0],
    pub lines: [u8; 0],
    pub triangles: [u8; 0],
    pub texts: Vec<Text>,
    pub models: [u8; 0],
}

impl SceneEntity {
    /// No primitives, lives until replaced (lifetime 0).
    pub fn empty() -> Self {
        SceneEntity {
            timestamp: Time { sec: 0, nsec: 0 },
            frame_id: "",
            id: String::new(),
            lifetime: DurationMsg { sec: 0, nsec: 0 },
            frame_locked: false,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: [],
            spheres: Vec::new(),
            cylinders: [],
            lines: [],
            triangles: [],
            texts: Vec::new(),
            models: [],
        }
    }
}

/// `foxglove.SceneEntityDeletion`.
#[derive(Debug, Serialize)]
pub struct Deletion {
    pub timestamp: Time,
    #[serde(rename = "type")]
    pub kind: u8,
    pub id: String,
}

impl Deletion {
    /// Deletes every entity of the topic (`type` ALL = 1) before the update's entities.
    pub fn all(timestamp: Time) -> Self {
        Deletion { timestamp, kind: 1, id: String::new() }
    }
}

/// `foxglove.SceneUpdate`.
#[derive(Debug, Serialize)]
pub struct SceneUpdate {
    pub deletions: Vec<Deletion>,
    pub entities: Vec<SceneEntity>,
}

/// `foxglove.Log`.
#[derive(Debug, Serialize)]
pub struct Log {
    pub timestamp: Time,
    pub level: u8,
    pub message: String,
    pub name: &'static str,
    pub file: &'static str,
    pub line: u32,
}

/// `lives.Status` (`schemas/lives.Status.json`): the core's [`StatusMsg`] as the schema lays it
/// out (its time as `timestamp`, the mode and the scan error by name, the gaze in radians).
#[derive(Debug)]
pub struct Status<'a>(pub &'a StatusMsg);

impl Serialize for Status<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let s = self.0;
        let mut out = serializer.serialize_struct("Status", 17)?;
        out.serialize_field("timestamp", &Time::of(s.t_us))?;
        out.serialize_field("mode", &format!("{:?}", s.mode))?;
        out.serialize_field("ticks", &s.ticks)?;
        out.serialize_field("scans", &s.scans)?;
        out.serialize_field("scans_rejected", &s.scans_rejected)?;
        out.serialize_field("poses_rejected", &s.poses_rejected)?;
        out.serialize_field("last_scan_error", &s.last_scan_error.map(|e| format!("{e:?}")))?;
        out.serialize_field("plans", &s.plans)?;
        out.serialize_field("goals", &s.goals)?;
        out.serialize_field("blacklisted", &s.blacklisted)?;
        out.serialize_field("retired", &s.retired)?;
        out.serialize_field("watchdog_trips", &s.watchdog_trips)?;
        out.serialize_field("cost", &s.cost)?;
        out.serialize_field("overruns", &s.overruns)?;
        out.serialize_field("heap_overflows", &s.heap_overflows)?;
        out.serialize_field("link", &s.link)?;
        out.serialize_field("gaze_rad", &s.gaze.map(|h| BinaryAngle(h).to_radians()))?;
        out.end()
    }
}
