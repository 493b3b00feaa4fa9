//! The ROS 2 wire: DDS endpoints that carry messages as raw CDR (RustDDS does the transport; the
//! messages are read and written by the project's one CDR implementation,
//! [`crate::io::replay::cdr`], which also reads the bags), the QoS profiles ROS uses, and the
//! message types `lives ros2` adds to those the bags need.
//!
//! ROS 2 over DDS (the `rmw_*_cpp` convention): topic `/name` is DDS topic `rt/name`, type
//! `pkg/msg/Type` is DDS type `pkg::msg::dds_::Type_`, the payload is plain CDR (XCDR1).

use crate::io::replay::cdr::{CdrWriter, Header, Time, Transform};
use rustdds::no_key::{Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{QosPolicies, QosPolicyBuilder, RepresentationIdentifier};

/// One message as it crossed the wire: CDR with its 4-byte encapsulation header, as in a bag.
#[derive(Clone, Debug)]
pub struct Raw(pub Vec<u8>);

/// Why bytes from DDS are not a message this side reads.
#[derive(Debug)]
pub struct RawError(pub String);

impl std::fmt::Display for RawError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RawError {}

/// Passes CDR bytes through untouched (the reader and writer are [`crate::io::replay::cdr`]'s).
pub struct RawCdr;

/// The decoder [`RawCdr`] uses: prepends the encapsulation header RustDDS took off.
#[derive(Clone, Copy)]
pub struct RawDecoder;

impl DeserializerAdapter<Raw> for RawCdr {
    type Error = RawError;
    type Decoded = Raw;
    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[RepresentationIdentifier::CDR_LE, RepresentationIdentifier::CDR_BE]
    }
    fn transform_decoded(decoded: Raw) -> Raw {
        decoded
    }
}

impl DefaultDecoder<Raw> for RawCdr {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

impl<'de> Decode<'de, Raw> for RawDecoder {
    type Error = RawError;
    fn decode_bytes(self, input: &'de [u8], encoding: RepresentationIdentifier) -> Result<Raw, RawError> {
        let mut data = Vec::with_capacity(input.len() + 4);
        data.extend_from_slice(&encoding.to_bytes());
        data.extend_from_slice(&[0, 0]);
        data.extend_from_slice(input);
        Ok(Raw(data))
    }
}

impl SerializerAdapter<Raw> for RawCdr {
    type Error = RawError;
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }
    fn to_bytes(value: &Raw) -> Result<rustdds::bytes::Bytes, RawError> {
        // CdrWriter's output starts with the little-endian encapsulation header.
        value.0.get(4..).map(rustdds::bytes::Bytes::copy_from_slice).ok_or_else(|| RawError("a message shorter than its header".into()))
    }
}

/// The QoS profiles of `rclcpp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Qos {
    /// `SensorDataQoS`: best effort, volatile, keep last 5. A best-effort reader matches every
    /// writer, reliable or not.
    Sensor,
    /// The default: reliable, volatile, keep last `depth`.
    Reliable(i32),
    /// `tf_static`, maps (`map_server`'s): reliable, transient local ("latched"), keep last 1.
    Latched,
    /// Reliable, transient local, keep last `depth`: a reader that matches late still gets the
    /// last `depth` messages (a stream of changes, such as a team's orders).
    Durable(i32),
}

impl Qos {
    /// As DDS policies.
    pub fn policies(self) -> QosPolicies {
        let reliable = Reliability::Reliable { max_blocking_time: rustdds::Duration::from_millis(100) };
        let (rel, dur, depth) = match self {
            Qos::Sensor => (Reliability::BestEffort, Durability::Volatile, 5),
            Qos::Reliable(depth) => (reliable, Durability::Volatile, depth),
            Qos::Latched => (reliable, Durability::TransientLocal, 1),
            Qos::Durable(depth) => (reliable, Durability::TransientLocal, depth),
        };
        QosPolicyBuilder::new().reliability(rel).durability(dur).history(History::KeepLast { depth }).build()
    }
}

/// The DDS type name of ROS 2 type `pkg/msg/Type`.
pub fn dds_type(ros_type: &str) -> String {
    let mut parts = ros_type.split('/');
    match (parts.next(), parts.next(), parts.next()) {
        (Some(pkg), Some(kind), Some(name)) => format!("{pkg}::{kind}::dds_::{name}_"),
        _ => ros_type.to_string(),
    }
}

/// The DDS topic name of ROS 2 topic `name` (relative names are in the root namespace).
pub fn dds_topic(name: &str) -> String {
    format!("rt/{}", name.trim_start_matches('/'))
}

/// A header stamped `t_ns` in `frame`.
pub fn header_at(t_ns: u64, frame: &str) -> Header {
    Header { stamp: time_of(t_ns), frame_id: frame.to_string() }
}

/// `builtin_interfaces/Time` of a stamp in nanoseconds.
pub fn time_of(t_ns: u64) -> Time {
    Time { sec: (t_ns / 1_000_000_000).min(i32::MAX as u64) as i32, nanosec: (t_ns % 1_000_000_000) as u32 }
}

/// `geometry_msgs/msg/PoseStamped`.
pub fn encode_pose_stamped(h: &Header, pose: &Transform) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(h);
    w.transform(pose);
    w.finish()
}

/// `nav_msgs/msg/Path`: the poses share the path's header.
pub fn encode_path(h: &Header, poses: &[Transform]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(h);
    w.put((poses.len() as u32).to_le_bytes());
    for p in poses {
        w.header(h);
        w.transform(p);
    }
    w.finish()
}

/// `std_msgs/msg/String`.
pub fn encode_string(s: &str) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.string(s);
    w.finish()
}

/// `nav_msgs/msg/OccupancyGrid`: `cols` × `rows` cells of `resolution` metres, row-major from
/// the lower-left corner at `origin`, values 0–100 or −1 (unknown).
pub fn encode_occupancy_grid(h: &Header, resolution: f32, cols: u32, rows: u32, origin: [f64; 2], data: &[i8]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(h);
    w.put(h.stamp.sec.to_le_bytes()); // info.map_load_time
    w.put(h.stamp.nanosec.to_le_bytes());
    w.put(resolution.to_le_bytes());
    w.put(cols.to_le_bytes());
    w.put(rows.to_le_bytes());
    w.transform(&Transform::planar(origin[0], origin[1], 0.0));
    w.put((data.len() as u32).to_le_bytes());
    for &v in data {
        w.put(v.to_le_bytes());
    }
    w.finish()
}

/// One `visualization_msgs/msg/Marker` (ROS 2 Jazzy's definition) of the kinds `lives ros2`
/// draws: points, spheres, arrows, text.
#[derive(Clone, Debug, Default)]
pub struct Marker {
    /// Namespace.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// `ARROW` 0, `SPHERE_LIST` 7, `POINTS` 8, `TEXT_VIEW_FACING` 9.
    pub kind: i32,
    /// `ADD` 0, `DELETEALL` 3.
    pub action: i32,
    /// Pose.
    pub pose: Option<Transform>,
    /// Scale x, y, z.
    pub scale: [f64; 3],
    /// RGBA of the whole marker.
    pub color: [f32; 4],
    /// Points (`POINTS`, `SPHERE_LIST`).
    pub points: Vec<[f64; 2]>,
    /// Colour per point (empty: `color`).
    pub colors: Vec<[f32; 4]>,
    /// Text (`TEXT_VIEW_FACING`).
    pub text: String,
}

/// Marker kinds and actions.
pub mod marker {
    /// An arrow at the pose.
    pub const ARROW: i32 = 0;
    /// Spheres at the points.
    pub const SPHERE_LIST: i32 = 7;
    /// Squares at the points.
    pub const POINTS: i32 = 8;
    /// Text facing the viewer.
    pub const TEXT: i32 = 9;
    /// Add or replace.
    pub const ADD: i32 = 0;
    /// Delete every marker of the namespace... of every namespace (ROS: all markers).
    pub const DELETE_ALL: i32 = 3;
}

/// `visualization_msgs/msg/MarkerArray`, every marker with header `h`.
pub fn encode_marker_array(h: &Header, markers: &[Marker]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.put((markers.len() as u32).to_le_bytes());
    for m in markers {
        w.header(h);
        w.string(&m.ns);
        w.put(m.id.to_le_bytes());
        w.put(m.kind.to_le_bytes());
        w.put(m.action.to_le_bytes());
        w.transform(&m.pose.unwrap_or(Transform::IDENTITY));
        for v in m.scale {
            w.put(v.to_le_bytes());
        }
        for v in m.color {
            w.put(v.to_le_bytes());
        }
        w.put(0i32.to_le_bytes()); // lifetime: forever
        w.put(0u32.to_le_bytes());
        w.put([0u8]); // frame_locked
        w.put((m.points.len() as u32).to_le_bytes());
        for p in &m.points {
            for v in [p[0], p[1], 0.0] {
                w.put(v.to_le_bytes());
            }
        }
        w.put((m.colors.len() as u32).to_le_bytes());
        for c in &m.colors {
            for v in c {
                w.put(v.to_le_bytes());
            }
        }
        w.string(""); // texture_resource
        w.header(h); // texture: sensor_msgs/CompressedImage (empty)
        w.string("");
        w.put(0u32.to_le_bytes());
        w.put(0u32.to_le_bytes()); // uv_coordinates
        w.string(&m.text);
        w.string(""); // mesh_resource
        w.string(""); // mesh_file: filename, data
        w.put(0u32.to_le_bytes());
        w.put([0u8]); // mesh_use_embedded_materials
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::replay::cdr::{self, CdrReader};

    #[test]
    fn names_follow_the_rmw_dds_convention() {
        assert_eq!(dds_type("sensor_msgs/msg/LaserScan"), "sensor_msgs::msg::dds_::LaserScan_");
        assert_eq!(dds_topic("/scan"), "rt/scan");
        assert_eq!(dds_topic("lives/status"), "rt/lives/status");
    }

    #[test]
    fn raw_bytes_round_trip_through_the_adapter() {
        let msg = encode_string("hello");
        let body = <RawCdr as SerializerAdapter<Raw>>::to_bytes(&Raw(msg.clone())).unwrap();
        let back = RawDecoder.decode_bytes(&body, RepresentationIdentifier::CDR_LE).unwrap();
        assert_eq!(back.0, msg);
        let mut r = CdrReader::new(&back.0).unwrap();
        assert_eq!(r.string("data").unwrap(), "hello");
    }

    #[test]
    fn a_detection_array_decodes_and_a_cut_one_is_an_error() {
        let mut w = CdrWriter::new();
        w.header(&header_at(1_500_000_000, "camera"));
        w.put(1u32.to_le_bytes());
        w.header(&header_at(1_500_000_000, "camera"));
        w.put(1u32.to_le_bytes());
        w.string("target");
        w.put(0.9f64.to_le_bytes());
        w.transform(&Transform::IDENTITY);
        for _ in 0..36 + 5 {
            w.put(0f64.to_le_bytes());
        }
        w.string("");
        let buf = w.finish();
        let (h, d) = cdr::decode_detection2d_array(&buf).unwrap();
        assert_eq!(h.frame_id, "camera");
        assert_eq!(d, vec![vec![("target".to_string(), 0.9)]]);
        assert!(cdr::decode_detection2d_array(&buf[..buf.len() - 9]).is_err());
    }
}
