//! ROS 2 bags: MCAP (rosbag2's default storage since Iron) and sqlite3 (`.db3`, the default
//! before), with `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` and `tf2_msgs/msg/TFMessage`
//! on `/tf` and `/tf_static` (and `sensor_msgs/msg/PointCloud2`, cut to planar scans as it is
//! read: [`cut`]), CDR-encoded (MCAP channels encoded `ros1` are read too); and ROS 1
//! bags (format 2.0, [`read_bag1`]) with the same three types (`tf/tfMessage` too) in ROS 1's
//! serialisation.
//!
//! Reading happens in two steps:
//!
//! 1. [`read_mcap`] / [`read_db3`] / [`read_bag1`] pull the messages of those three types out of the container
//!    in file order, with where each came from ([`Location`]): the byte offset of its record
//!    (for a message inside a chunk, the chunk's offset) or its `messages` row id. A damaged
//!    chunk (its own length intact) or a row of the wrong column type is skipped and counted
//!    ([`BagContents::bad`]); they stop at the first damage that loses the framing (a top-level
//!    record cut off or unparsable, an unreadable sqlite page) and hand back what came before,
//!    plus the error.
//! 2. [`scans_from_messages`] decodes them (CDR or ROS 1, [`super::cdr`]; a message that does not decode
//!    is skipped and counted, the messages around it are used), sorts them by the bag's receive
//!    time, and builds the frame tree: `tf_static` transforms apply to the whole bag, `tf`
//!    transforms and odometry (`header.frame_id` → `child_frame_id`) are samples of their edge at
//!    their header stamps. Each scan's pose is the laser frame's pose in the root of its frame
//!    tree (`map` or `odom`) at the scan's header stamp, the moving edges interpolated to it
//!    (translation linear, rotation shortest arc), projected to the plane: x, y and the yaw of
//!    the laser's x axis. Scans with no odometry at or before their stamp, or none within
//!    [`MAX_POSE_AGE_NS`], are rejected by name, as are transforms that jump, loop or go back in
//!    time. A laser mounted upside down
//!    (its z axis pointing down) sees the world mirrored: its beam angles are negated.
//!
//! Ranges follow REP 117 and the `LaserScan` definition: NaN (invalid) and −inf (too close) are
//! invalid, +inf is "no return", finite readings outside `[range_min, range_max]` are discarded
//! (invalid).
//!
//! What this module must not do: know about the controller or pictures.

use super::cdr::Wire;
use super::{BadRecords, Location, ReplayError};

mod bag1;
mod cloud;
mod codec;
mod db3;
mod frames;
mod mcap_file;
mod scans;
pub use bag1::*;
pub use cloud::*;
pub use codec::*;
pub use db3::*;
pub use frames::*;
pub use mcap_file::*;
pub use scans::*;

/// The message types replay uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MsgType {
    /// `sensor_msgs/msg/LaserScan`.
    LaserScan,
    /// `nav_msgs/msg/Odometry`.
    Odometry,
    /// `tf2_msgs/msg/TFMessage` on a `tf` topic.
    Tf,
    /// `tf2_msgs/msg/TFMessage` on a `tf_static` topic.
    TfStatic,
    /// `sensor_msgs/msg/PointCloud2`, held as the planar scan cut from it ([`cut`]).
    PointCloud2,
}

impl MsgType {
    /// The type of a topic from its type name (ROS 2's `pkg/msg/Type` or ROS 1's `pkg/Type`) and
    /// topic name; `None` for types replay ignores.
    pub fn of(type_name: &str, topic: &str) -> Option<MsgType> {
        match type_name {
            "sensor_msgs/msg/LaserScan" | "sensor_msgs/LaserScan" => Some(MsgType::LaserScan),
            "nav_msgs/msg/Odometry" | "nav_msgs/Odometry" => Some(MsgType::Odometry),
            "sensor_msgs/msg/PointCloud2" | "sensor_msgs/PointCloud2" => Some(MsgType::PointCloud2),
            "tf2_msgs/msg/TFMessage" | "tf2_msgs/TFMessage" | "tf/tfMessage" if topic.ends_with("tf_static") => Some(MsgType::TfStatic),
            "tf2_msgs/msg/TFMessage" | "tf2_msgs/TFMessage" | "tf/tfMessage" => Some(MsgType::Tf),
            _ => None,
        }
    }
}

/// One message of a type replay uses, still serialised.
#[derive(Clone, Debug)]
pub struct BagMessage {
    /// The bag's receive time, nanoseconds.
    pub t_ns: u64,
    /// Topic.
    pub topic: String,
    /// Type.
    pub kind: MsgType,
    /// How `data` is serialised.
    pub wire: Wire,
    /// The serialised message (for a point cloud, the CDR of the planar scan cut from it).
    pub data: Vec<u8>,
    /// Where it came from.
    pub at: Location,
}

/// What a container gave: the messages before any damage, the number of messages of all types
/// (for the log's duration), their time span, and the damage.
#[derive(Debug, Default)]
pub struct BagContents {
    /// Messages of the three types, file order.
    pub messages: Vec<BagMessage>,
    /// Earliest and latest receive time of any message, nanoseconds.
    pub span_ns: Option<(u64, u64)>,
    /// Topics that carry a type replay uses, with the type.
    pub topics: Vec<(String, String)>,
    /// Channels skipped because their encoding is neither CDR nor ROS 1.
    pub skipped_encodings: Vec<String>,
    /// The first damage, after which nothing was read.
    pub error: Option<ReplayError>,
    /// Damage whose extent is known, skipped: a chunk that does not decompress or whose records
    /// do not parse (the records after it are read), a `messages` row of the wrong type.
    pub bad: BadRecords,
    /// Point clouds that could not be cut (`(where, topic, why)`): bad records once the file is
    /// named.
    pub bad_clouds: Vec<(Location, String, super::cdr::CdrError)>,
}

impl BagContents {
    /// Keeps a message of a type replay uses; a point cloud is cut to its planar scan now, so
    /// that a bag of clouds is held as scans.
    fn keep(&mut self, mut m: BagMessage) {
        if m.kind == MsgType::PointCloud2 {
            match cut(&m.data, m.wire) {
                Ok(scan) => {
                    m.data = super::cdr::encode_laser_scan(&scan);
                    m.wire = Wire::Cdr;
                }
                Err(e) => {
                    self.bad_clouds.push((m.at, m.topic, e));
                    return;
                }
            }
        }
        self.messages.push(m);
    }

    fn saw(&mut self, t_ns: u64) {
        self.span_ns = Some(match self.span_ns {
            None => (t_ns, t_ns),
            Some((a, b)) => (a.min(t_ns), b.max(t_ns)),
        });
    }
}

#[cfg(test)]
mod tests;
