//! The `tf` frame tree: transforms by frame pair, interpolated to a stamp, with the rejections counted.

use crate::io::replay::cdr::Transform;
use std::collections::HashMap;

/// A rigid transform in 3D, for walking the frame tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Iso {
    pub(crate) t: [f64; 3],
    /// `[x, y, z, w]`, unit.
    pub(crate) q: [f64; 4],
}

impl Iso {
    const IDENTITY: Iso = Iso { t: [0.0; 3], q: [0.0, 0.0, 0.0, 1.0] };

    /// From a message's transform; `None` when it is not finite or the quaternion is zero.
    pub(crate) fn from(t: &Transform) -> Option<Iso> {
        let q = t.rotation;
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        let finite = t.translation.iter().chain(q.iter()).all(|v| v.is_finite());
        (finite && n > 1e-9).then(|| Iso { t: t.translation, q: [q[0] / n, q[1] / n, q[2] / n, q[3] / n] })
    }

    pub(crate) fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        let [x, y, z, w] = self.q;
        // v + 2w (u × v) + 2 u × (u × v), u = (x, y, z).
        let c1 = [y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0]];
        let c2 = [y * c1[2] - z * c1[1], z * c1[0] - x * c1[2], x * c1[1] - y * c1[0]];
        [v[0] + 2.0 * (w * c1[0] + c2[0]), v[1] + 2.0 * (w * c1[1] + c2[1]), v[2] + 2.0 * (w * c1[2] + c2[2])]
    }

    /// The yaw of its x axis in the parent's plane, radians (a pose projected to the plane).
    pub(crate) fn yaw(&self) -> f64 {
        let x = self.rotate([1.0, 0.0, 0.0]);
        x[1].atan2(x[0])
    }

    /// `self ∘ other`: `other` expressed in `self`'s parent.
    pub(crate) fn compose(&self, other: &Iso) -> Iso {
        let r = self.rotate(other.t);
        let (a, b) = (self.q, other.q);
        let q = [
            a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
            a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
            a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
            a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
        ];
        Iso { t: [self.t[0] + r[0], self.t[1] + r[1], self.t[2] + r[2]], q }
    }
}

/// A scan is placed only if the odometry (the moving edge of its frame chain nearest the laser,
/// e.g. `odom` → `base_link`) has a sample at most this long before its stamp, or brackets the
/// stamp with a sample this close: 0.5 s. Odometry is published at 20–100 Hz; a gap of half a
/// second means the robot's motion during it is unknown.
pub const MAX_POSE_AGE_NS: u64 = 500_000_000;

/// A moving edge (odometry or `tf`) whose translation moves more than this between consecutive
/// samples, plus [`MAX_SPEED_M_S`] times the time between them, has jumped (a corrupt message,
/// an odometry reset): the sample is rejected (`odometry_jump`), the edge keeps its history.
pub const MAX_JUMP_M: f64 = 1.0;

/// The fastest a robot's frame is assumed to move, m/s (with [`MAX_JUMP_M`]).
pub const MAX_SPEED_M_S: f64 = 10.0;

/// Where a moving edge's samples come from. A robot commonly publishes one edge twice — the
/// wheel controller's or the EKF's `nav_msgs/Odometry` topic and `tf` (`odom` → `base_link`),
/// or two odometry topics (raw and filtered) with the same frames — and the two drift apart:
/// merged, the laser's pose would jump between them from one sample to the next. An edge takes
/// its samples from one source: `tf` (what the robot's own stack looked up) before any odometry
/// topic, else the first odometry topic that carried it; the other's samples are not used
/// ([`EdgeReject::Superseded`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EdgeSource<'a> {
    /// `tf` (or `tf_static`).
    Tf,
    /// A `nav_msgs/Odometry` topic.
    Odometry(&'a str),
}

/// One edge of the frame tree: its parent, and the child's pose in it over time (one sample for
/// a `tf_static` edge).
#[derive(Clone, Debug)]
pub(crate) struct Edge {
    parent: String,
    /// From `tf_static`: holds at every time.
    fixed: bool,
    /// The odometry topic its samples come from; `None`: `tf`.
    topic: Option<String>,
    /// `(stamp ns, pose)`, stamps non-decreasing.
    pub(crate) samples: Vec<(u64, Iso)>,
}

/// Why a moving transform was not taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EdgeReject {
    /// Not finite, a zero quaternion, or a frame its own parent.
    Invalid,
    /// It would close a cycle in the frame tree.
    Loop,
    /// Its stamp is before the edge's previous one.
    Backwards,
    /// Its translation jumped ([`MAX_JUMP_M`], [`MAX_SPEED_M_S`]).
    Jump,
    /// Another source carries the edge ([`EdgeSource`]): not used, and not an error.
    Superseded,
    /// A live tree is full (`lives ros2`'s bound on frames).
    #[cfg_attr(not(feature = "ros2"), allow(dead_code))]
    TooManyFrames,
}

/// Why a scan could not be placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PoseError {
    /// Its frame is in no tree with a root (or a cycle).
    NoPose,
    /// The odometry has no sample at or before the scan's stamp.
    NoOdometryYet,
    /// The odometry's nearest sample is more than [`MAX_POSE_AGE_NS`] from the stamp.
    Stale,
}

/// The frame tree: child → edge. Moving edges keep every sample, so a scan is placed with the
/// transforms interpolated to its own stamp.
#[derive(Default)]
pub(crate) struct FrameTree {
    pub(crate) edges: HashMap<String, Edge>,
}

/// Frame names without the ROS 1 leading slash.
pub(crate) fn frame(name: &str) -> String {
    name.trim_start_matches('/').to_string()
}

/// Shortest-arc spherical interpolation between unit quaternions (for a planar pose: yaw
/// interpolated the short way round), `s` in [0, 1].
pub(crate) fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let mut d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    let mut b = b;
    if d < 0.0 {
        d = -d;
        b = b.map(|v| -v);
    }
    let (wa, wb) = if d > 0.9995 {
        (1.0 - s, s)
    } else {
        let th = d.min(1.0).acos();
        let sn = th.sin();
        (((1.0 - s) * th).sin() / sn, (s * th).sin() / sn)
    };
    let q = [0, 1, 2, 3].map(|i| wa * a[i] + wb * b[i]);
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|v| v / n)
}

/// `a` and `b` interpolated at `s` in [0, 1]: translation linear, rotation shortest arc.
pub(crate) fn interpolate(a: &Iso, b: &Iso, s: f64) -> Iso {
    Iso { t: [0, 1, 2].map(|i| a.t[i] + (b.t[i] - a.t[i]) * s), q: slerp(a.q, b.q, s) }
}

impl FrameTree {
    /// Would `parent` → `child` close a cycle (is `child` an ancestor of `parent`, or `parent`)?
    fn closes_loop(&self, parent: &str, child: &str) -> bool {
        let mut cur = parent.to_string();
        for _ in 0..=64 {
            if cur == child {
                return true;
            }
            match self.edges.get(&cur) {
                None => return false,
                Some(e) => cur = e.parent.clone(),
            }
        }
        true
    }

    /// A `tf_static` edge: holds at every time, replaces what the edge was.
    pub(crate) fn set_static(&mut self, parent: &str, child: &str, t: &Transform) -> Result<(), EdgeReject> {
        let (parent, child) = (frame(parent), frame(child));
        let iso = Iso::from(t).filter(|_| parent != child).ok_or(EdgeReject::Invalid)?;
        if self.closes_loop(&parent, &child) {
            return Err(EdgeReject::Loop);
        }
        self.edges.insert(child, Edge { parent, fixed: true, topic: None, samples: vec![(0, iso)] });
        Ok(())
    }

    /// A moving edge's sample at `t_ns` from `source` (odometry or `tf`). A new parent for the
    /// child starts a new history; so does `tf` for an edge an odometry topic carried so far
    /// ([`EdgeSource`]), whose later samples are then [`EdgeReject::Superseded`].
    pub(crate) fn push(&mut self, parent: &str, child: &str, t_ns: u64, t: &Transform, source: EdgeSource<'_>) -> Result<(), EdgeReject> {
        let (parent, child) = (frame(parent), frame(child));
        let iso = Iso::from(t).filter(|_| parent != child).ok_or(EdgeReject::Invalid)?;
        let topic = match source {
            EdgeSource::Tf => None,
            EdgeSource::Odometry(name) => Some(name),
        };
        let moving = self.edges.get(&child).filter(|e| e.parent == parent && !e.fixed);
        let switch_to_tf = match moving.map(|e| e.topic.as_deref()) {
            Some(held) if held != topic => {
                if topic.is_some() {
                    return Err(EdgeReject::Superseded);
                }
                true
            }
            _ => false,
        };
        let same_parent = self.edges.get(&child).is_some_and(|e| e.parent == parent);
        if !same_parent && self.closes_loop(&parent, &child) {
            return Err(EdgeReject::Loop);
        }
        if let Some(e) = self.edges.get_mut(&child).filter(|e| e.parent == parent && !e.fixed && !switch_to_tf) {
            let &(t0, last) = e.samples.last().expect("an edge has a sample");
            if t_ns < t0 {
                return Err(EdgeReject::Backwards);
            }
            let moved = ((iso.t[0] - last.t[0]).powi(2) + (iso.t[1] - last.t[1]).powi(2) + (iso.t[2] - last.t[2]).powi(2)).sqrt();
            if moved > MAX_JUMP_M + MAX_SPEED_M_S * (t_ns - t0) as f64 / 1e9 {
                return Err(EdgeReject::Jump);
            }
            e.samples.push((t_ns, iso));
        } else {
            self.edges.insert(child, Edge { parent, fixed: false, topic: topic.map(str::to_string), samples: vec![(t_ns, iso)] });
        }
        Ok(())
    }

    /// Where the moving edge into `child` takes its samples from: `tf`, or an odometry topic.
    pub(crate) fn source_of(&self, child: &str) -> Option<String> {
        let e = self.edges.get(&frame(child)).filter(|e| !e.fixed)?;
        Some(e.topic.clone().unwrap_or_else(|| "tf".to_string()))
    }

    /// The frames moving edges move (`odom → base_footprint`), sorted.
    pub(crate) fn moving_children(&self) -> Vec<String> {
        let mut v: Vec<String> = self.edges.iter().filter(|(_, e)| !e.fixed).map(|(c, e)| format!("{} → {c}", e.parent)).collect();
        v.sort();
        v
    }

    /// Whether any edge moves (odometry or `tf`).
    pub(crate) fn has_moving_edges(&self) -> bool {
        self.edges.values().any(|e| !e.fixed)
    }

    /// The newest stamp of the first moving edge from `f` up (the odometry that places it), if
    /// any: a live source waits for it to reach a scan's stamp before placing the scan (as tf2's
    /// message filter waits for the transform at the scan's time); replay refuses a scan with
    /// none in a bag whose odometry moves another tree.
    pub(crate) fn moving_until(&self, f: &str) -> Option<u64> {
        let mut cur = frame(f);
        for _ in 0..=64 {
            let e = self.edges.get(&cur)?;
            if !e.fixed {
                return e.samples.last().map(|s| s.0);
            }
            cur = e.parent.clone();
        }
        None
    }

    /// The frame `f`'s fixed (`tf_static`) transforms end in: `f` walked up its fixed edges
    /// (`f` itself if it has none; a cycle stops after 64 edges).
    pub(crate) fn fixed_root(&self, f: &str) -> String {
        let mut cur = frame(f);
        for _ in 0..64 {
            match self.edges.get(&cur) {
                Some(e) if e.fixed => cur = e.parent.clone(),
                _ => break,
            }
        }
        cur
    }

    /// The edge an odometry message moves, `parent` → `child` as it names them, except that some
    /// drivers leave them empty: an empty parent is `odom`, an empty child the frame the scan
    /// frames' fixed transforms all end in (`base_link` for a laser mounted on it), or stays
    /// empty when they end in several or there is no scan yet. The flag: a name was filled in.
    pub(crate) fn odometry_edge<'a>(
        &self,
        parent: &str,
        child: &str,
        scan_frames: impl Iterator<Item = &'a str>,
    ) -> (String, String, bool) {
        let (mut p, mut c) = (frame(parent), frame(child));
        let filled_in = p.is_empty() || c.is_empty();
        if p.is_empty() {
            p = "odom".to_string();
        }
        if c.is_empty() {
            let roots: std::collections::BTreeSet<String> = scan_frames.map(|f| self.fixed_root(f)).collect();
            if roots.len() == 1 {
                c = roots.into_iter().next().unwrap_or_default();
            }
        }
        (p, c, filled_in)
    }

    #[cfg(feature = "ros2")]
    /// Whether `f` is a frame of the tree (the child of an edge, or some edge's parent).
    pub(crate) fn knows(&self, f: &str) -> bool {
        let f = frame(f);
        self.edges.contains_key(&f) || self.edges.values().any(|e| e.parent == f)
    }

    #[cfg(feature = "ros2")]
    /// Drops the samples of moving edges older than `t_ns`, keeping each edge's newest sample
    /// before it (a live source's memory stays bounded).
    pub(crate) fn forget_before(&mut self, t_ns: u64) {
        for e in self.edges.values_mut().filter(|e| !e.fixed) {
            let k = e.samples.partition_point(|s| s.0 < t_ns);
            if k > 1 {
                e.samples.drain(..k - 1);
            }
        }
    }

    /// The pose of `f` in the root of its tree at time `t_ns`, the root's name and the number of
    /// edges walked. Moving edges are interpolated to `t_ns` between the samples around it. The
    /// first moving edge from `f` up (the odometry) must have a sample at or before `t_ns`
    /// ([`PoseError::NoOdometryYet`]) and one within [`MAX_POSE_AGE_NS`] of it
    /// ([`PoseError::Stale`]); edges above it (e.g. `map` → `odom`, published slowly) hold their
    /// nearest sample outside the span of their samples.
    pub(crate) fn resolve_at(&self, f: &str, t_ns: u64) -> Result<(Iso, String, usize), PoseError> {
        let mut pose = Iso::IDENTITY;
        let mut cur = frame(f);
        let mut odometry_seen = false;
        for depth in 0..=64 {
            let Some(e) = self.edges.get(&cur) else { return Ok((pose, cur, depth)) };
            let edge = if e.fixed {
                e.samples[0].1
            } else {
                let k = e.samples.partition_point(|s| s.0 <= t_ns);
                let before = k.checked_sub(1).map(|i| e.samples[i]);
                let after = e.samples.get(k).copied();
                if !odometry_seen {
                    odometry_seen = true;
                    let Some((tb, _)) = before else { return Err(PoseError::NoOdometryYet) };
                    let age = after.map_or(t_ns - tb, |(ta, _)| (t_ns - tb).min(ta - t_ns));
                    if age > MAX_POSE_AGE_NS {
                        return Err(PoseError::Stale);
                    }
                }
                match (before, after) {
                    (Some((tb, a)), Some((ta, b))) => interpolate(&a, &b, (t_ns - tb) as f64 / (ta - tb) as f64),
                    (Some((_, a)), None) | (None, Some((_, a))) => a,
                    (None, None) => unreachable!("an edge has a sample"),
                }
            };
            pose = edge.compose(&pose);
            cur = e.parent.clone();
        }
        Err(PoseError::NoPose)
    }
}

/// Moving transforms (odometry, `tf`) rejected, by reason: nothing else is lost with them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RejectedTransforms {
    /// The translation jumped ([`MAX_JUMP_M`] + [`MAX_SPEED_M_S`] × the time since the edge's
    /// previous sample), e.g. odometry 100 m away from the message before.
    pub odometry_jump: u32,
    /// The transform would close a cycle of frames (`a` → `b` → `a`).
    pub tf_loop: u32,
    /// Its header stamp is before the previous one of the same edge.
    pub stamp_backwards: u32,
    /// Not finite, a zero quaternion, or a frame its own parent.
    pub invalid: u32,
    /// Odometry messages not used because `tf`, or an odometry topic before them, carries the
    /// same edge ([`EdgeSource`]); not an error: a robot commonly publishes both.
    pub superseded: u32,
}

impl RejectedTransforms {
    /// Counts a rejected transform by its reason (nothing for one taken).
    pub(crate) fn count(&mut self, r: Result<(), EdgeReject>) {
        match r {
            Ok(()) => {}
            Err(EdgeReject::Invalid | EdgeReject::TooManyFrames) => self.invalid += 1,
            Err(EdgeReject::Loop) => self.tf_loop += 1,
            Err(EdgeReject::Backwards) => self.stamp_backwards += 1,
            Err(EdgeReject::Jump) => self.odometry_jump += 1,
            Err(EdgeReject::Superseded) => self.superseded += 1,
        }
    }

    /// Adds another log part's counts.
    pub fn add(&mut self, o: &RejectedTransforms) {
        self.odometry_jump += o.odometry_jump;
        self.tf_loop += o.tf_loop;
        self.stamp_backwards += o.stamp_backwards;
        self.invalid += o.invalid;
        self.superseded += o.superseded;
    }
}
