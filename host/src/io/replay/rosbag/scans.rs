//! From bag messages to scans at poses ([`scans_from_messages`]): odometry and `tf` at each scan's stamp.

use super::*;
use crate::io::replay::cdr::{self, CdrError};
use crate::io::replay::{BadRecords, Location, ReplayError, ScanRecord};
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::path::Path;

/// Scans read but not used because they could not be placed, by reason (a bag's, a CARMEN
/// log's `RAWLASER1` lines).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Unplaced {
    /// Scans whose frame could not be placed in a tree with a root.
    pub no_pose: usize,
    /// Scans stamped before the first odometry sample (e.g. the scanner started first).
    pub no_odometry_yet: usize,
    /// Scans whose nearest odometry sample is more than [`MAX_POSE_AGE_NS`] away.
    pub stale_pose: usize,
    /// Scans whose header stamp is before the previous scan's on the same frame.
    pub scan_stamp_backwards: usize,
    /// Scans cut from point clouds whose frame is tilted ([`MAX_CLOUD_TILT_DEG`]): not used.
    pub tilted_cloud: usize,
    /// Scans (or clouds) of a second topic in a frame another topic already scans: not used
    /// ([`one_topic_per_frame`]).
    pub duplicate_topic: usize,
}

impl Unplaced {
    /// Counts a scan the frame tree could not place at its stamp.
    pub(crate) fn count(&mut self, e: PoseError) {
        match e {
            PoseError::NoPose => self.no_pose += 1,
            PoseError::NoOdometryYet => self.no_odometry_yet += 1,
            PoseError::Stale => self.stale_pose += 1,
        }
    }

    /// Adds another log part's counts.
    pub fn add(&mut self, o: &Unplaced) {
        self.no_pose += o.no_pose;
        self.no_odometry_yet += o.no_odometry_yet;
        self.stale_pose += o.stale_pose;
        self.scan_stamp_backwards += o.scan_stamp_backwards;
        self.tilted_cloud += o.tilted_cloud;
        self.duplicate_topic += o.duplicate_topic;
    }

    /// Every scan not placed.
    pub fn total(&self) -> usize {
        self.no_pose + self.no_odometry_yet + self.stale_pose + self.scan_stamp_backwards + self.tilted_cloud + self.duplicate_topic
    }
}

/// What the messages gave.
#[derive(Debug, Default)]
pub struct BagScans {
    /// Scans with their laser poses, time order.
    pub scans: Vec<ScanRecord>,
    /// Scans read but not placed, by reason.
    pub unplaced: Unplaced,
    /// Transforms rejected.
    pub transforms_rejected: RejectedTransforms,
    /// Odometry messages.
    pub odometry: usize,
    /// Transforms received (tf and tf_static).
    pub transforms: usize,
    /// Notes for the user (assumptions made).
    pub warnings: Vec<String>,
    /// Messages that did not decode (skipped).
    pub bad_records: BadRecords,
}

pub(crate) enum Decoded {
    Scan(cdr::LaserScan),
    /// The planar scan cut from a `PointCloud2` ([`super::cut`]).
    Cloud(cdr::LaserScan),
    Odom(cdr::Odometry),
    Tf(Vec<cdr::TransformStamped>),
}

/// A header stamp in nanoseconds; `fallback` (the receive time) when the stamp is zero or
/// negative (a bag whose publisher did not stamp).
pub(crate) fn stamp_ns(h: &cdr::Header, fallback: u64) -> u64 {
    let ns = h.stamp.sec as i64 * 1_000_000_000 + h.stamp.nanosec as i64;
    if ns > 0 {
        ns as u64
    } else {
        fallback
    }
}

/// Decodes the messages (skipping and counting those that do not decode), builds the frame tree
/// with every moving transform at its header stamp, and returns every scan with the laser's pose
/// at the scan's header stamp (transforms interpolated to it; receive times where a message has
/// no stamp).
pub fn scans_from_messages(file: &Path, mut messages: Vec<BagMessage>) -> BagScans {
    let mut out = BagScans::default();
    // Receive-time order (a stable sort keeps file order for equal stamps).
    messages.sort_by_key(|m| m.t_ns);
    let mut decoded = Vec::with_capacity(messages.len());
    for m in &messages {
        let d: Result<Decoded, CdrError> = match m.kind {
            MsgType::LaserScan => cdr::decode_laser_scan(&m.data, m.wire).map(Decoded::Scan),
            MsgType::PointCloud2 => cdr::decode_laser_scan(&m.data, m.wire).map(Decoded::Cloud),
            MsgType::Odometry => cdr::decode_odometry(&m.data, m.wire).map(Decoded::Odom),
            MsgType::Tf | MsgType::TfStatic => cdr::decode_tf_message(&m.data, m.wire).map(Decoded::Tf),
        };
        match d {
            Ok(d) => decoded.push((m, d)),
            Err(error) => out.bad_records.add(ReplayError::Message { file: file.to_path_buf(), at: m.at, topic: m.topic.clone(), error }),
        }
    }
    let mut tree = FrameTree::default();
    let mut rej = RejectedTransforms::default();
    // tf_static describes the robot's fixed geometry: it holds for the whole bag.
    for (m, d) in &decoded {
        if let (MsgType::TfStatic, Decoded::Tf(ts)) = (m.kind, d) {
            for t in ts {
                out.transforms += 1;
                rej.count(tree.set_static(&t.header.frame_id, &t.child_frame_id, &t.transform));
            }
        }
    }
    // The edges `tf` carries anywhere in the bag: odometry messages of the same edge are not
    // used, from the first on ([`EdgeSource`]; live, `tf` takes the edge over when it comes).
    let tf_edges: HashSet<(String, String)> = decoded
        .iter()
        .filter(|(m, _)| m.kind == MsgType::Tf)
        .flat_map(|(_, d)| match d {
            Decoded::Tf(ts) => ts.iter().map(|t| (frame(&t.header.frame_id), frame(&t.child_frame_id))).collect(),
            _ => Vec::new(),
        })
        .collect();
    // Odometry that names no frame (some drivers leave them empty): [`FrameTree::odometry_edge`]
    // over the scans' frames.
    let scan_frames: BTreeSet<String> = decoded
        .iter()
        .filter_map(|(_, d)| match d {
            Decoded::Scan(s) | Decoded::Cloud(s) => Some(frame(&s.header.frame_id)),
            _ => None,
        })
        .collect();
    let mut unnamed: BTreeMap<String, (String, String)> = BTreeMap::new();
    // Every moving transform, at its stamp (a scan is placed with samples before and after it).
    let mut odom_child: Option<String> = None;
    // (parent, child, the topic not used) → (the source used, messages not used).
    let mut superseded: BTreeMap<(String, String, String), (String, u32)> = BTreeMap::new();
    for (m, d) in &decoded {
        match d {
            Decoded::Tf(ts) if m.kind == MsgType::Tf => {
                for t in ts {
                    out.transforms += 1;
                    let r = tree.push(&t.header.frame_id, &t.child_frame_id, stamp_ns(&t.header, m.t_ns), &t.transform, EdgeSource::Tf);
                    rej.count(r);
                }
            }
            Decoded::Odom(o) => {
                out.odometry += 1;
                let (parent, child, filled_in) =
                    tree.odometry_edge(&o.header.frame_id, &o.child_frame_id, scan_frames.iter().map(String::as_str));
                if filled_in {
                    unnamed.entry(m.topic.clone()).or_insert_with(|| (parent.clone(), child.clone()));
                }
                let by_tf = tf_edges.contains(&(parent.clone(), child.clone()));
                let r = if by_tf {
                    Err(EdgeReject::Superseded)
                } else {
                    tree.push(&parent, &child, stamp_ns(&o.header, m.t_ns), &o.pose, EdgeSource::Odometry(&m.topic))
                };
                // The body frame odometry moves (by this topic or by another source).
                if matches!(r, Ok(()) | Err(EdgeReject::Superseded)) && odom_child.is_none() {
                    odom_child = Some(child.clone());
                }
                if r == Err(EdgeReject::Superseded) {
                    let by = if by_tf { "tf".to_string() } else { tree.source_of(&child).unwrap_or_default() };
                    superseded.entry((parent, child, m.topic.clone())).or_insert((by, 0)).1 += 1;
                }
                rej.count(r);
            }
            _ => {}
        }
    }
    for (topic, (parent, child)) in &unnamed {
        out.warnings.push(if child.is_empty() {
            format!(
                "odometry on {topic} names no child frame and the scans' fixed transforms do not end in one frame: it moves \
                 nothing they are mounted on"
            )
        } else {
            format!("odometry on {topic} leaves its frames empty: taken as `{parent}` → `{child}` (where the scans' fixed transforms end)")
        });
    }
    let mut assumed: Vec<String> = Vec::new();
    let mut last_stamp: HashMap<String, u64> = HashMap::new();
    let mut first_unplaced: Vec<String> = Vec::new();
    // A bag with a LaserScan topic maps its scans; its point clouds (often what the scans were
    // made from) are then not used. A bag of clouds alone maps the planar cuts of its clouds.
    let scan_topics: BTreeSet<&str> = decoded.iter().filter(|(m, _)| m.kind == MsgType::LaserScan).map(|(m, _)| m.topic.as_str()).collect();
    let cloud_topics: BTreeSet<&str> =
        decoded.iter().filter(|(m, _)| m.kind == MsgType::PointCloud2).map(|(m, _)| m.topic.as_str()).collect();
    if !cloud_topics.is_empty() {
        let clouds = cloud_topics.iter().copied().collect::<Vec<_>>().join(", ");
        out.warnings.push(if scan_topics.is_empty() {
            format!(
                "point clouds ({clouds}) cut to planar scans: the points within {CLOUD_BAND_DEG}° of the sensor's horizontal \
                 plane, nearest per beam of {CLOUD_BEAMS}, none nearer than {CLOUD_RANGE_MIN_M} m"
            )
        } else {
            format!(
                "point clouds ({clouds}) not used: the bag's LaserScan topics ({}) are",
                scan_topics.iter().copied().collect::<Vec<_>>().join(", ")
            )
        });
    }
    let use_clouds = scan_topics.is_empty();
    let kind = if use_clouds { MsgType::PointCloud2 } else { MsgType::LaserScan };
    let (dropped_topics, notes) = one_topic_per_frame(decoded.iter().filter(|(m, _)| m.kind == kind).map(|(m, d)| {
        let header = match d {
            Decoded::Scan(s) | Decoded::Cloud(s) => Some(frame(&s.header.frame_id)),
            _ => None,
        };
        (m.topic.as_str(), header.unwrap_or_default())
    }));
    out.warnings.extend(notes);
    // A bag in which nothing moves is a sensor that stood still: its scans are placed at their
    // fixed poses (a warning says so). One whose odometry moves does not place a scan by fixed
    // transforms alone.
    let moving = tree.has_moving_edges();
    let has_scans = !scan_topics.is_empty() || !cloud_topics.is_empty();
    if !moving && has_scans {
        out.warnings
            .push("no odometry or moving tf in the bag: every scan is placed at its frame's fixed pose (a sensor that stood still)".into());
    }
    let mut unconnected: Vec<String> = Vec::new();
    for (m, d) in &decoded {
        let s = match d {
            Decoded::Scan(s) => s,
            Decoded::Cloud(s) if use_clouds => s,
            _ => continue,
        };
        if dropped_topics.contains(m.topic.as_str()) {
            out.unplaced.duplicate_topic += 1;
            continue;
        }
        let laser = frame(&s.header.frame_id);
        let t = stamp_ns(&s.header, m.t_ns);
        if last_stamp.get(&laser).is_some_and(|&prev| t < prev) {
            out.unplaced.scan_stamp_backwards += 1;
            continue;
        }
        last_stamp.insert(laser.clone(), t);
        let mut target = laser.clone();
        if !tree.edges.contains_key(&laser) {
            if let Some(child) = &odom_child {
                // The laser's frame is in no transform: assume it sits at the odometry's body
                // frame (say so once).
                if !assumed.contains(&laser) {
                    out.warnings.push(format!(
                        "no transform places laser frame `{laser}` (topic {}): assumed mounted at `{child}` with no offset",
                        m.topic
                    ));
                    assumed.push(laser.clone());
                }
                target = child.clone();
            }
        }
        let fixed_only = tree.moving_until(&target).is_none();
        match tree.resolve_at(&target, t) {
            // Only fixed transforms place it while odometry moves another tree: drawn at its
            // mount's offset from a made-up origin, every scan would sit in one place.
            Ok((_, root, depth)) if depth > 0 && fixed_only && moving => {
                out.unplaced.no_pose += 1;
                if !unconnected.contains(&target) {
                    out.warnings.push(format!(
                        "scans in frame `{target}` (topic {}) were not used: only fixed transforms place it (in `{root}`), and the \
                         odometry moves frames not connected to it ({}); a transform between the two trees is missing",
                        m.topic,
                        tree.moving_children().join(", ")
                    ));
                    unconnected.push(target.clone());
                }
            }
            Ok((pose, _, depth)) if depth > 0 && m.kind == MsgType::PointCloud2 && tilted(&pose) => out.unplaced.tilted_cloud += 1,
            Ok((pose, _root, depth)) if depth > 0 => out.scans.push(scan_record(s, &pose, m.t_ns, m.at)),
            Ok(_) => out.unplaced.no_pose += 1,
            Err(e) => {
                if first_unplaced.len() < 3 {
                    first_unplaced.push(format!("{} ({} s)", m.at, t as f64 / 1e9));
                }
                out.unplaced.count(e);
            }
        }
    }
    if out.unplaced.no_odometry_yet + out.unplaced.stale_pose > 0 {
        out.warnings.push(format!(
            "{} scans stamped before the first odometry and {} whose nearest odometry is more than {} s from their stamp \
             were not used (not placed at the frame tree's origin): first at {}",
            out.unplaced.no_odometry_yet,
            out.unplaced.stale_pose,
            MAX_POSE_AGE_NS as f64 / 1e9,
            first_unplaced.join(", ")
        ));
    }
    if out.unplaced.tilted_cloud > 0 {
        out.warnings.push(format!(
            "{} point clouds were not used: their frame is tilted more than {MAX_CLOUD_TILT_DEG}° from level (a depth \
             camera's optical frame?), and a cut of its horizontal plane would be a slanted one",
            out.unplaced.tilted_cloud
        ));
    }
    if out.unplaced.scan_stamp_backwards > 0 {
        out.warnings.push(format!("{} scans stamped before the scan before them were not used", out.unplaced.scan_stamp_backwards));
    }
    for ((parent, child, topic), (by, n)) in &superseded {
        out.warnings.push(format!(
            "{parent} → {child} comes from {by} and from odometry topic {topic} too: {by}'s samples are used, {topic}'s {n} \
             are not (the two drift apart; merged, the laser's pose would jump between them)"
        ));
    }
    if rej.invalid > 0 {
        out.warnings.push(format!("{} transforms ignored (not finite, zero quaternion, or a frame its own parent)", rej.invalid));
    }
    if rej.odometry_jump + rej.tf_loop + rej.stamp_backwards > 0 {
        out.warnings.push(format!(
            "transforms rejected: {} odometry_jump (moved more than {MAX_JUMP_M} m + {MAX_SPEED_M_S} m/s since the sample before), \
             {} tf_loop (would close a cycle of frames), {} stamp_backwards; the others were used",
            rej.odometry_jump, rej.tf_loop, rej.stamp_backwards
        ));
    }
    out.transforms_rejected = rej;
    out
}

/// Whether a frame's z axis is farther than [`MAX_CLOUD_TILT_DEG`] from the vertical (up or down).
pub(crate) fn tilted(pose: &Iso) -> bool {
    pose.rotate([0.0, 0.0, 1.0])[2].abs() < MAX_CLOUD_TILT_DEG.to_radians().cos()
}

/// A scan in the replay's terms: the laser's planar pose and ranges by the ROS conventions.
pub(crate) fn scan_record(s: &cdr::LaserScan, pose: &Iso, t_ns: u64, at: Location) -> ScanRecord {
    let z_axis = pose.rotate([0.0, 0.0, 1.0]);
    let yaw = pose.yaw();
    // Upside down: a beam at +a in the laser frame points to −a about the world's z.
    let sign = if z_axis[2] < 0.0 { -1.0 } else { 1.0 };
    // The readings as recorded: the range rule (REP 117) is applied once, with the scan's own
    // limits, when the scan is encoded for the core (`crate::run::range`).
    let ranges_m = s.ranges.clone();
    ScanRecord {
        t_s: t_ns as f64 / 1e9,
        pose: [pose.t[0], pose.t[1], yaw],
        angle_min: sign * s.angle_min as f64,
        angle_increment: sign * s.angle_increment as f64,
        ranges_m,
        range_limits_m: [s.range_min as f64, s.range_max as f64],
        at,
    }
}

/// Which scan topics not to use, and a note for each: of several topics whose messages share one
/// frame (one scanner published twice, e.g. raw and filtered, or at two rates), the one with the
/// most messages is used (on a tie, the first by name) and the others are not — integrated
/// together, every return would count twice and the evidence grid would trust the scanner
/// double. Topics in frames of their own (a robot's front and rear scanners) are all used.
/// `messages` gives each message's topic and frame.
pub(crate) fn one_topic_per_frame<'a>(messages: impl Iterator<Item = (&'a str, String)>) -> (BTreeSet<&'a str>, Vec<String>) {
    let mut per_frame: BTreeMap<String, BTreeMap<&'a str, usize>> = BTreeMap::new();
    for (topic, frame) in messages {
        *per_frame.entry(frame).or_default().entry(topic).or_default() += 1;
    }
    let (mut dropped, mut notes) = (BTreeSet::new(), Vec::new());
    for (frame, topics) in &per_frame {
        if topics.len() < 2 {
            continue;
        }
        // Most messages first, then by name.
        let mut order: Vec<(&str, usize)> = topics.iter().map(|(t, n)| (*t, *n)).collect();
        order.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
        let (kept, n) = order[0];
        let others: Vec<String> = order[1..].iter().map(|(t, k)| format!("{t} ({k})")).collect();
        dropped.extend(order[1..].iter().map(|(t, _)| *t));
        notes.push(format!(
            "topics {kept} and {} all scan in frame `{frame}` (one scanner published twice?): {kept}'s {n} messages are used, \
             not the others' (integrated together, every return would count twice)",
            others.join(", ")
        ));
    }
    (dropped, notes)
}
