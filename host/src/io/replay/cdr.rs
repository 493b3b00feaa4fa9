//! A small, careful reader (and writer) of OMG CDR for the three ROS 2 message types replay needs:
//! `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` and `tf2_msgs/msg/TFMessage`, and of the
//! same three types in ROS 1's serialisation ([`Wire::Ros1`]).
//!
//! ROS 2 serialises messages as CDR with a 4-byte encapsulation header: byte 1 is the
//! representation (`0x00` CDR big-endian, `0x01` CDR little-endian, `0x06`/`0x07` XCDR2 plain
//! big/little-endian), bytes 2–3 are options and are ignored. Primitives are aligned to their size
//! counted from the end of that header (XCDR2 caps alignment at 4 bytes, so `float64` aligns to 4
//! there). Strings are a `uint32` length that includes the terminating NUL, then the bytes.
//! Sequences are a `uint32` count, then the elements. Fixed arrays (`float64[36]` covariances)
//! have no count.
//!
//! ROS 1 serialises the same fields in order with no encapsulation header and no alignment,
//! little-endian; a string is a `uint32` byte count and the bytes (no NUL); `time` is two
//! `uint32`s; and `std_msgs/Header` starts with a `uint32 seq`, which is read and dropped. The
//! same reader serves both ([`CdrReader::ros1`]): one set of field lists, two layouts.
//!
//! The reader checks every length against the bytes left before it reads or allocates, and every
//! error names the byte offset (from the start of the serialised message, header included) and
//! what was being read. It never panics on any input (a test feeds it every truncation and many
//! random mutations of real messages).
//!
//! The writer exists so tests (and anyone making a bag) can produce messages; it writes CDR
//! little-endian (`00 01 00 00`), as ROS 2 does on every common platform.
//!
//! What this module must not do: know about bags, frames or the controller.

use std::fmt;

/// Why a message could not be decoded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CdrError {
    /// Byte offset in the serialised message (encapsulation header included).
    pub offset: usize,
    /// What was being read and what went wrong.
    pub kind: CdrErrorKind,
}

/// The cause of a [`CdrError`].
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum CdrErrorKind {
    /// The message is shorter than its 4-byte encapsulation header.
    NoHeader,
    /// An encapsulation this reader does not know (bytes 0–1 of the header).
    Encapsulation(u16),
    /// The message ended while reading `what`.
    Truncated {
        /// The field.
        what: &'static str,
        /// Bytes it needed.
        needed: usize,
        /// Bytes that were left.
        left: usize,
    },
    /// A string without its terminating NUL, or with a zero length.
    BadString {
        /// The field.
        what: &'static str,
    },
    /// A sequence count larger than the bytes left could hold.
    BadCount {
        /// The field.
        what: &'static str,
        /// The count it gave.
        count: u32,
    },
    /// The message decodes but its fields do not describe what they must (a point cloud whose
    /// points lie beyond its data, or with no `x` field).
    Unusable {
        /// The field.
        what: &'static str,
        /// Why.
        why: String,
    },
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.kind {
            CdrErrorKind::NoHeader => write!(f, "CDR message of {} bytes has no 4-byte encapsulation header", self.offset),
            CdrErrorKind::Encapsulation(e) => write!(f, "unknown CDR encapsulation 0x{e:04x}"),
            CdrErrorKind::Truncated { what, needed, left } => {
                write!(f, "CDR message ends at byte {} while reading {what} ({needed} bytes needed, {left} left)", self.offset)
            }
            CdrErrorKind::BadString { what } => write!(f, "bad CDR string {what} at byte {} (no terminating NUL)", self.offset),
            CdrErrorKind::BadCount { what, count } => {
                write!(f, "CDR sequence {what} at byte {} claims {count} elements, more than the message holds", self.offset)
            }
            CdrErrorKind::Unusable { what, why } => write!(f, "{what} (byte {}): {why}", self.offset),
        }
    }
}

impl std::error::Error for CdrError {}

/// How a message is serialised: a bag says it per topic (MCAP's `message_encoding`, rosbag2's
/// `serialization_format`; a ROS 1 bag is all `ros1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wire {
    /// OMG CDR with its encapsulation header (ROS 2).
    Cdr,
    /// ROS 1 serialisation.
    Ros1,
}

impl Wire {
    /// The wire of a bag's encoding name (`cdr`, `ros1`); `None` for one replay does not read.
    pub fn of_encoding(name: &str) -> Option<Wire> {
        match name {
            "cdr" => Some(Wire::Cdr),
            "ros1" => Some(Wire::Ros1),
            _ => None,
        }
    }
}

/// A cursor over one serialised message.
pub struct CdrReader<'a> {
    buf: &'a [u8],
    pos: usize,
    little: bool,
    max_align: usize,
    /// Where alignment is counted from: the end of the encapsulation header (0 for ROS 1).
    base: usize,
    ros1: bool,
}

/// Size of the encapsulation header.
const HEADER: usize = 4;

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header and positions the cursor after it.
    pub fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        if buf.len() < HEADER {
            return Err(CdrError { offset: buf.len(), kind: CdrErrorKind::NoHeader });
        }
        let id = u16::from_be_bytes([buf[0], buf[1]]);
        let (little, max_align) = match id {
            0x0000 => (false, 8),
            0x0001 => (true, 8),
            0x0006 => (false, 4),
            0x0007 => (true, 4),
            other => return Err(CdrError { offset: 0, kind: CdrErrorKind::Encapsulation(other) }),
        };
        Ok(CdrReader { buf, pos: HEADER, little, max_align, base: HEADER, ros1: false })
    }

    /// A reader of ROS 1 serialisation: no header, no alignment, little-endian, strings without
    /// NUL, headers with `seq`.
    pub fn ros1(buf: &'a [u8]) -> Self {
        CdrReader { buf, pos: 0, little: true, max_align: 1, base: 0, ros1: true }
    }

    /// A reader of `buf` as `wire` says.
    pub fn of(buf: &'a [u8], wire: Wire) -> Result<Self, CdrError> {
        match wire {
            Wire::Cdr => Self::new(buf),
            Wire::Ros1 => Ok(Self::ros1(buf)),
        }
    }

    /// The current byte offset (header included).
    pub fn offset(&self) -> usize {
        self.pos
    }

    fn err(&self, kind: CdrErrorKind) -> CdrError {
        CdrError { offset: self.pos, kind }
    }

    fn align(&mut self, size: usize) {
        let a = size.min(self.max_align);
        let rel = self.pos - self.base;
        // Padding that runs past the end leaves the cursor at the end (errors name real offsets).
        self.pos = (self.pos + (a - rel % a) % a).min(self.buf.len());
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], CdrError> {
        let left = self.buf.len().saturating_sub(self.pos);
        if n > left {
            return Err(self.err(CdrErrorKind::Truncated { what, needed: n, left }));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn fixed<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], CdrError> {
        self.align(N);
        let s = self.take(N, what)?;
        let mut b = [0u8; N];
        b.copy_from_slice(s);
        if self.little != cfg!(target_endian = "little") {
            b.reverse();
        }
        Ok(b)
    }

    /// A `uint8` (or a `bool`, `byte`, `char`).
    pub fn u8(&mut self, what: &'static str) -> Result<u8, CdrError> {
        Ok(self.fixed::<1>(what)?[0])
    }

    /// A `uint32`.
    pub fn u32(&mut self, what: &'static str) -> Result<u32, CdrError> {
        Ok(u32::from_ne_bytes(self.fixed::<4>(what)?))
    }

    /// An `int32`.
    pub fn i32(&mut self, what: &'static str) -> Result<i32, CdrError> {
        Ok(i32::from_ne_bytes(self.fixed::<4>(what)?))
    }

    /// A `float32`.
    pub fn f32(&mut self, what: &'static str) -> Result<f32, CdrError> {
        Ok(f32::from_ne_bytes(self.fixed::<4>(what)?))
    }

    /// A `float64`.
    pub fn f64(&mut self, what: &'static str) -> Result<f64, CdrError> {
        Ok(f64::from_ne_bytes(self.fixed::<8>(what)?))
    }

    /// A `string` (invalid UTF-8 is replaced, frame names are compared as text).
    pub fn string(&mut self, what: &'static str) -> Result<String, CdrError> {
        let start = self.pos;
        let n = self.u32(what)? as usize;
        let bytes = self.take(n, what)?;
        if self.ros1 {
            return Ok(String::from_utf8_lossy(bytes).into_owned());
        }
        match bytes.split_last() {
            Some((0, text)) => Ok(String::from_utf8_lossy(text).into_owned()),
            _ => Err(CdrError { offset: start, kind: CdrErrorKind::BadString { what } }),
        }
    }

    /// A sequence count, checked against the bytes left for elements of `elem_size` bytes.
    pub fn count(&mut self, what: &'static str, elem_size: usize) -> Result<usize, CdrError> {
        let start = self.pos;
        let n = self.u32(what)?;
        let left = self.buf.len().saturating_sub(self.pos);
        if (n as usize).saturating_mul(elem_size.max(1)) > left {
            return Err(CdrError { offset: start, kind: CdrErrorKind::BadCount { what, count: n } });
        }
        Ok(n as usize)
    }

    /// A `uint8[]` sequence, borrowed.
    pub fn bytes(&mut self, what: &'static str) -> Result<&'a [u8], CdrError> {
        let n = self.count(what, 1)?;
        self.take(n, what)
    }

    /// An error at the cursor: the message's `what` is not usable, for `why`.
    pub fn unusable(&self, what: &'static str, why: String) -> CdrError {
        self.err(CdrErrorKind::Unusable { what, why })
    }

    /// A `float32[]` sequence.
    pub fn f32_seq(&mut self, what: &'static str) -> Result<Vec<f32>, CdrError> {
        let n = self.count(what, 4)?;
        (0..n).map(|_| self.f32(what)).collect()
    }

    /// `n` consecutive `float64`s (a fixed array or the fields of a struct).
    pub fn f64s<const N: usize>(&mut self, what: &'static str) -> Result<[f64; N], CdrError> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(what)?;
        }
        Ok(out)
    }
}

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds.
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Header {
    /// Stamp.
    pub stamp: Time,
    /// Frame the data is expressed in.
    pub frame_id: String,
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LaserScan {
    /// Header (`frame_id` is the laser's frame).
    pub header: Header,
    /// First beam's angle, radians, counter-clockwise about the frame's z axis from x.
    pub angle_min: f32,
    /// Last beam's angle.
    pub angle_max: f32,
    /// Angle between beams.
    pub angle_increment: f32,
    /// Time between beams, seconds.
    pub time_increment: f32,
    /// Time between scans, seconds.
    pub scan_time: f32,
    /// Readings below this are not valid.
    pub range_min: f32,
    /// Readings above this are not valid.
    pub range_max: f32,
    /// Ranges, metres (`+inf` no return, `-inf` too close, NaN invalid: REP 117).
    pub ranges: Vec<f32>,
    /// Intensities (ignored by replay).
    pub intensities: Vec<f32>,
}

/// A rigid transform: translation and unit quaternion `[x, y, z, w]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Translation, metres.
    pub translation: [f64; 3],
    /// Rotation `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl Transform {
    /// No motion.
    pub const IDENTITY: Transform = Transform { translation: [0.0; 3], rotation: [0.0, 0.0, 0.0, 1.0] };

    /// A planar transform: `(x, y)` and a yaw about z.
    pub fn planar(x: f64, y: f64, yaw: f64) -> Transform {
        let (s, c) = (yaw / 2.0).sin_cos();
        Transform { translation: [x, y, 0.0], rotation: [0.0, 0.0, s, c] }
    }
}

/// `nav_msgs/msg/Odometry` (the pose part; twist and covariances are read and dropped).
#[derive(Clone, Debug, PartialEq)]
pub struct Odometry {
    /// Header (`frame_id` is the odometry frame, e.g. `odom`).
    pub header: Header,
    /// The body frame the pose describes (e.g. `base_link`).
    pub child_frame_id: String,
    /// Pose of `child_frame_id` in `header.frame_id`.
    pub pose: Transform,
}

/// One `geometry_msgs/msg/TransformStamped`.
#[derive(Clone, Debug, PartialEq)]
pub struct TransformStamped {
    /// Header (`frame_id` is the parent frame).
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Pose of the child in the parent.
    pub transform: Transform,
}

/// A `std_msgs/Header`.
pub fn header(r: &mut CdrReader) -> Result<Header, CdrError> {
    if r.ros1 {
        r.u32("header.seq")?;
        // ROS 1 time is unsigned; stamps past 2038 wrap negative and count as unstamped.
        let sec = r.u32("header.stamp.secs")? as i32;
        let nanosec = r.u32("header.stamp.nsecs")?;
        let frame_id = r.string("header.frame_id")?;
        return Ok(Header { stamp: Time { sec, nanosec }, frame_id });
    }
    let sec = r.i32("header.stamp.sec")?;
    let nanosec = r.u32("header.stamp.nanosec")?;
    let frame_id = r.string("header.frame_id")?;
    Ok(Header { stamp: Time { sec, nanosec }, frame_id })
}

/// A `geometry_msgs/Transform` (or a `Pose`: the same seven `float64`s).
pub fn transform(r: &mut CdrReader, what: &'static str) -> Result<Transform, CdrError> {
    let translation = r.f64s::<3>(what)?;
    let rotation = r.f64s::<4>(what)?;
    Ok(Transform { translation, rotation })
}

/// Decodes a serialised `sensor_msgs/msg/LaserScan`.
pub fn decode_laser_scan(buf: &[u8], wire: Wire) -> Result<LaserScan, CdrError> {
    let mut r = CdrReader::of(buf, wire)?;
    Ok(LaserScan {
        header: header(&mut r)?,
        angle_min: r.f32("angle_min")?,
        angle_max: r.f32("angle_max")?,
        angle_increment: r.f32("angle_increment")?,
        time_increment: r.f32("time_increment")?,
        scan_time: r.f32("scan_time")?,
        range_min: r.f32("range_min")?,
        range_max: r.f32("range_max")?,
        ranges: r.f32_seq("ranges")?,
        intensities: r.f32_seq("intensities")?,
    })
}

/// Decodes a serialised `nav_msgs/msg/Odometry`.
pub fn decode_odometry(buf: &[u8], wire: Wire) -> Result<Odometry, CdrError> {
    let mut r = CdrReader::of(buf, wire)?;
    let header = header(&mut r)?;
    let child_frame_id = r.string("child_frame_id")?;
    let pose = transform(&mut r, "pose.pose")?;
    r.f64s::<36>("pose.covariance")?;
    r.f64s::<6>("twist.twist")?;
    r.f64s::<36>("twist.covariance")?;
    Ok(Odometry { header, child_frame_id, pose })
}

/// Decodes a serialised `tf2_msgs/msg/TFMessage` (ROS 1: also `tf/tfMessage`, the same fields).
pub fn decode_tf_message(buf: &[u8], wire: Wire) -> Result<Vec<TransformStamped>, CdrError> {
    let mut r = CdrReader::of(buf, wire)?;
    // Each element is at least 4 + 4 + 4 (+ NUL) + 4 + 56 bytes in CDR, 4 + 8 + 4 + 4 + 56 in
    // ROS 1; 64 is a safe lower bound.
    let n = r.count("transforms", 64)?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let header = header(&mut r)?;
        let child_frame_id = r.string("transforms.child_frame_id")?;
        let transform = transform(&mut r, "transforms.transform")?;
        out.push(TransformStamped { header, child_frame_id, transform });
    }
    Ok(out)
}

/// `std_msgs/msg/Bool`.
pub fn decode_bool(buf: &[u8]) -> Result<bool, CdrError> {
    let mut r = CdrReader::new(buf)?;
    Ok(r.u8("data")? != 0)
}

/// `geometry_msgs/msg/PointStamped`: the header and `(x, y, z)`.
pub fn decode_point_stamped(buf: &[u8]) -> Result<(Header, [f64; 3]), CdrError> {
    let mut r = CdrReader::new(buf)?;
    let h = header(&mut r)?;
    Ok((h, r.f64s::<3>("point")?))
}

/// One detection's hypotheses: `(class_id, score)`.
pub type Hypotheses = Vec<(String, f64)>;

/// `vision_msgs/msg/Detection2DArray` (vision_msgs 4): the header and each detection's
/// hypotheses as `(class_id, score)`.
pub fn decode_detection2d_array(buf: &[u8]) -> Result<(Header, Vec<Hypotheses>), CdrError> {
    let mut r = CdrReader::new(buf)?;
    let h = header(&mut r)?;
    // A Detection2D is at least its header (12 bytes), two counts and the box (40 bytes).
    let n = r.count("detections", 60)?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        header(&mut r)?;
        let k = r.count("results", 8 + 8 + 56 + 288)?;
        let mut hyps = Vec::with_capacity(k);
        for _ in 0..k {
            let class_id = r.string("results.hypothesis.class_id")?;
            let score = r.f64("results.hypothesis.score")?;
            transform(&mut r, "results.pose.pose")?;
            r.f64s::<36>("results.pose.covariance")?;
            hyps.push((class_id, score));
        }
        r.f64s::<5>("bbox")?;
        r.string("id")?;
        out.push(hyps);
    }
    Ok((h, out))
}

/// Writes CDR little-endian (encapsulation `00 01 00 00`).
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// A writer holding just the encapsulation header.
    pub fn new() -> Self {
        CdrWriter { buf: vec![0x00, 0x01, 0x00, 0x00] }
    }

    fn align(&mut self, size: usize) {
        while !(self.buf.len() - HEADER).is_multiple_of(size) {
            self.buf.push(0);
        }
    }

    /// A primitive (`uint32`, `int32`, `float32`, `float64`) given as its little-endian bytes
    /// (`v.to_le_bytes()`), aligned to its size.
    pub fn put<const N: usize>(&mut self, le_bytes: [u8; N]) {
        self.align(N);
        self.buf.extend_from_slice(&le_bytes);
    }

    /// A `string`.
    pub fn string(&mut self, s: &str) {
        self.put((s.len() as u32 + 1).to_le_bytes());
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// The bytes.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }

    /// A `std_msgs/Header`.
    pub fn header(&mut self, h: &Header) {
        self.put(h.stamp.sec.to_le_bytes());
        self.put(h.stamp.nanosec.to_le_bytes());
        self.string(&h.frame_id);
    }

    /// A `Transform` or a `Pose` (translation or position, then the quaternion).
    pub fn transform(&mut self, t: &Transform) {
        for v in t.translation.iter().chain(t.rotation.iter()) {
            self.put(v.to_le_bytes());
        }
    }
}

// The message definitions (`ros2msg`, as rosbag2's MCAP writer stores them in a schema: the
// type's own `.msg` text, then each type it uses after a line of 80 `=` and `MSG: pkg/Type`), so
// that Foxglove and `ros2 bag` can decode what `lives export-bag` writes.

const SEP: &str = "================================================================================\n";
const DEF_TIME: &str = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const DEF_HEADER: &str = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
const DEF_VECTOR3: &str = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const DEF_QUATERNION: &str = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";

/// The `ros2msg` schema text of `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` or
/// `tf2_msgs/msg/TFMessage` (`None` for another type).
pub fn ros2msg_definition(type_name: &str) -> Option<String> {
    let join = |own: &str, deps: &[&str]| {
        let mut s = own.to_string();
        for d in deps {
            s.push_str(SEP);
            s.push_str(d);
        }
        s
    };
    Some(match type_name {
        "sensor_msgs/msg/LaserScan" => join(
            "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\nfloat32 time_increment\n\
             float32 scan_time\nfloat32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities\n",
            &[DEF_HEADER, DEF_TIME],
        ),
        "nav_msgs/msg/Odometry" => join(
            "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n\
             geometry_msgs/TwistWithCovariance twist\n",
            &[
                DEF_HEADER,
                DEF_TIME,
                "MSG: geometry_msgs/PoseWithCovariance\nPose pose\nfloat64[36] covariance\n",
                "MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n",
                "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n",
                DEF_QUATERNION,
                "MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n",
                "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n",
                DEF_VECTOR3,
            ],
        ),
        "tf2_msgs/msg/TFMessage" => join(
            "geometry_msgs/TransformStamped[] transforms\n",
            &[
                "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\nTransform transform\n",
                DEF_HEADER,
                DEF_TIME,
                "MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation\n",
                DEF_VECTOR3,
                DEF_QUATERNION,
            ],
        ),
        _ => return None,
    })
}

/// Serialises a `sensor_msgs/msg/LaserScan`.
pub fn encode_laser_scan(m: &LaserScan) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(&m.header);
    for v in [m.angle_min, m.angle_max, m.angle_increment, m.time_increment, m.scan_time, m.range_min, m.range_max] {
        w.put(v.to_le_bytes());
    }
    for seq in [&m.ranges, &m.intensities] {
        w.put((seq.len() as u32).to_le_bytes());
        for &v in seq.iter() {
            w.put(v.to_le_bytes());
        }
    }
    w.finish()
}

/// Serialises a `nav_msgs/msg/Odometry` (zero twist, zero covariances).
pub fn encode_odometry(m: &Odometry) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(&m.header);
    w.string(&m.child_frame_id);
    w.transform(&m.pose);
    for _ in 0..(36 + 6 + 36) {
        w.put(0f64.to_le_bytes());
    }
    w.finish()
}

/// Serialises a `tf2_msgs/msg/TFMessage`.
pub fn encode_tf_message(transforms: &[TransformStamped]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.put((transforms.len() as u32).to_le_bytes());
    for t in transforms {
        w.header(&t.header);
        w.string(&t.child_frame_id);
        w.transform(&t.transform);
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `TFMessage` with one transform `odom` → `base`, laid out by hand from the CDR rules:
    /// header, count, stamp, frame string (len 5 incl. NUL, 3 bytes padding to 4), child string
    /// (len 5), 3 bytes padding so the first float64 is 8-aligned counted after the header.
    #[rustfmt::skip]
    static TF_BYTES: [u8; 100] = [
        0x00, 0x01, 0x00, 0x00,             // CDR little-endian
        0x01, 0x00, 0x00, 0x00,             // 1 transform              (rel. 0)
        0x07, 0x00, 0x00, 0x00,             // stamp.sec = 7            (rel. 4)
        0x10, 0x27, 0x00, 0x00,             // stamp.nanosec = 10000    (rel. 8)
        0x05, 0x00, 0x00, 0x00, b'o', b'd', b'o', b'm', 0x00, // "odom" (rel. 12..21)
        0x00, 0x00, 0x00,                   // pad to 24
        0x05, 0x00, 0x00, 0x00, b'b', b'a', b's', b'e', 0x00, // "base" (rel. 24..33)
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // pad to 40 (8-aligned)
        0, 0, 0, 0, 0, 0, 0xf8, 0x3f,       // x = 1.5
        0, 0, 0, 0, 0, 0, 0x00, 0xc0,       // y = -2.0
        0, 0, 0, 0, 0, 0, 0, 0,             // z = 0
        0, 0, 0, 0, 0, 0, 0, 0,             // qx = 0
        0, 0, 0, 0, 0, 0, 0, 0,             // qy = 0
        0, 0, 0, 0, 0, 0, 0, 0,             // qz = 0
        0, 0, 0, 0, 0, 0, 0xf0, 0x3f,       // qw = 1
    ];

    fn tf_value() -> Vec<TransformStamped> {
        vec![TransformStamped {
            header: Header { stamp: Time { sec: 7, nanosec: 10_000 }, frame_id: "odom".into() },
            child_frame_id: "base".into(),
            transform: Transform { translation: [1.5, -2.0, 0.0], rotation: [0.0, 0.0, 0.0, 1.0] },
        }]
    }

    /// The same `TFMessage` in ROS 1's serialisation: no header, no padding, strings without
    /// NUL, and the header's `seq` first; the transform's seven float64s are the CDR message's
    /// last 56 bytes.
    fn tf_ros1_bytes() -> Vec<u8> {
        #[rustfmt::skip]
        let head: [u8; 32] = [
            0x01, 0x00, 0x00, 0x00,             // 1 transform
            0x2a, 0x00, 0x00, 0x00,             // header.seq = 42 (dropped)
            0x07, 0x00, 0x00, 0x00,             // stamp.secs = 7
            0x10, 0x27, 0x00, 0x00,             // stamp.nsecs = 10000
            0x04, 0x00, 0x00, 0x00, b'o', b'd', b'o', b'm', // "odom"
            0x04, 0x00, 0x00, 0x00, b'b', b'a', b's', b'e', // "base"
        ];
        [&head[..], &TF_BYTES[TF_BYTES.len() - 56..]].concat()
    }

    #[test]
    fn golden_ros1_tf_message_parses_and_every_truncation_is_an_error() {
        let bytes = tf_ros1_bytes();
        assert_eq!(bytes.len(), 88);
        assert_eq!(decode_tf_message(&bytes, Wire::Ros1).unwrap(), tf_value());
        for n in 0..bytes.len() {
            let e = decode_tf_message(&bytes[..n], Wire::Ros1).unwrap_err();
            assert!(e.offset <= n, "{e}");
        }
        // A string longer than the message is refused, not allocated.
        let mut b = bytes;
        b[16..20].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode_tf_message(&b, Wire::Ros1).unwrap_err();
        assert_eq!(e.offset, 20, "{e}");
        assert!(matches!(e.kind, CdrErrorKind::Truncated { what: "header.frame_id", .. }), "{e}");
    }

    #[test]
    fn golden_tf_message_parses_and_emits() {
        assert_eq!(decode_tf_message(&TF_BYTES, Wire::Cdr).unwrap(), tf_value());
        assert_eq!(encode_tf_message(&tf_value()), TF_BYTES.to_vec());
    }

    #[test]
    fn big_endian_and_xcdr2_alignment_are_read() {
        // The same message big-endian: swap every field, keep the layout.
        let mut be = TF_BYTES.to_vec();
        be[1] = 0x00;
        for (start, len) in [(4, 4), (8, 4), (12, 4), (16, 4), (28, 4)] {
            be[start..start + len].reverse();
        }
        for i in 0..7 {
            be[44 + 8 * i..52 + 8 * i].reverse();
        }
        assert_eq!(decode_tf_message(&be, Wire::Cdr).unwrap(), tf_value());
        // XCDR2: float64 aligns to 4, so the 4 padding bytes before x disappear.
        let mut x2 = TF_BYTES.to_vec();
        x2[1] = 0x07;
        x2.drain(37..41);
        assert_eq!(decode_tf_message(&x2, Wire::Cdr).unwrap(), tf_value());
    }

    fn scan() -> LaserScan {
        LaserScan {
            header: Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "laser".into() },
            angle_min: -1.0,
            angle_max: 1.0,
            angle_increment: 0.5,
            time_increment: 0.0,
            scan_time: 0.1,
            range_min: 0.05,
            range_max: 20.0,
            ranges: vec![1.0, f32::INFINITY, f32::NEG_INFINITY, 3.5, 25.0],
            intensities: vec![],
        }
    }

    #[test]
    fn laser_scan_and_odometry_round_trip() {
        let s = scan();
        assert_eq!(decode_laser_scan(&encode_laser_scan(&s), Wire::Cdr).unwrap(), s);
        let o = Odometry {
            header: Header { stamp: Time { sec: 3, nanosec: 4 }, frame_id: "odom".into() },
            child_frame_id: "base_link".into(),
            pose: Transform::planar(1.0, 2.0, 0.5),
        };
        let bytes = encode_odometry(&o);
        // After the 4-byte header: stamp 8, "odom" 4 + 5 → 17, pad → 20, "base_link" 4 + 10 → 34,
        // pad → 40 (float64 alignment), then 7 + 36 + 6 + 36 float64s.
        assert_eq!(bytes.len(), 4 + 40 + 8 * (7 + 36 + 6 + 36));
        assert_eq!(decode_odometry(&bytes, Wire::Cdr).unwrap(), o);
    }

    #[test]
    fn every_truncation_is_an_error_with_an_offset_never_a_panic() {
        let bytes = encode_laser_scan(&scan());
        for n in 0..bytes.len() {
            let e = decode_laser_scan(&bytes[..n], Wire::Cdr).unwrap_err();
            assert!(e.offset <= n, "offset {} beyond {n} bytes", e.offset);
        }
        // A huge sequence count is refused before anything is allocated.
        let mut bad = bytes.clone();
        let count_at = 4 + 4 + 4 + 4 + 6 + 2 + 7 * 4; // header, stamp, "laser" (10 B) + pad, 7 floats
        assert_eq!(&bad[count_at..count_at + 4], &5u32.to_le_bytes());
        bad[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode_laser_scan(&bad, Wire::Cdr).unwrap_err();
        assert_eq!(e, CdrError { offset: count_at, kind: CdrErrorKind::BadCount { what: "ranges", count: u32::MAX } });
        // Random byte flips: an error or a value, never a panic.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..20_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let mut m = bytes.clone();
            let i = (state % m.len() as u64) as usize;
            m[i] = (state >> 32) as u8;
            let _ = decode_laser_scan(&m, Wire::Cdr);
            let _ = decode_tf_message(&m, Wire::Cdr);
            let _ = decode_odometry(&m, Wire::Cdr);
        }
    }

    #[test]
    fn unknown_encapsulation_and_missing_nul_are_named() {
        assert_eq!(decode_tf_message(&[0, 1], Wire::Cdr).unwrap_err().kind, CdrErrorKind::NoHeader);
        assert_eq!(decode_tf_message(&[0, 0x0a, 0, 0], Wire::Cdr).unwrap_err().kind, CdrErrorKind::Encapsulation(0x000a));
        let mut b = TF_BYTES.to_vec();
        b[24] = b'!'; // the NUL ending "odom"
        let e = decode_tf_message(&b, Wire::Cdr).unwrap_err();
        assert_eq!(e, CdrError { offset: 16, kind: CdrErrorKind::BadString { what: "header.frame_id" } });
    }
}
