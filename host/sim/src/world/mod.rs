//! [`World`]: a floor plan with furniture, clutter, targets, people and a start, and its TOML
//! file format (documented with an example in `docs/world-format.md`).
//!
//! Loading is three passes, each with its own [`WorldError`] variant: TOML syntax, the schema
//! (unknown keys, wrong types, missing fields; `deny_unknown_fields` everywhere) and the meaning
//! (finite numbers, positive sizes, at least 3 polygon points, targets clear of furniture, a clear
//! start, everything within the 51 m × 51 m area the controller's grid covers). Every error names
//! the file and the 1-based line of the offending element. Loading never panics.

use std::fmt;

use super::geometry::{dist, Scene, SceneBuilder, TARGET_OWNER_BASE};
use super::{HitKind, Material, Scenario, Shape, P2};

mod load;
mod raw;
mod write;
use raw::*;

/// Every coordinate of a world must lie in `[0, WORLD_LIMIT_M]` in x and y (the controller's
/// occupancy grid is 51.2 m square, anchored at the origin).
pub const WORLD_LIMIT_M: f64 = 51.0;

/// The longest time limit a world may set: an hour (the paper's longest is 300 s). A search
/// runs until it, so this bounds every run of a world file.
pub const MAX_TIME_LIMIT_S: f64 = 3600.0;

/// The largest world file [`World::load`] reads: 1 MiB, about 20 000 walls (a built-in world is
/// about 10 kB). Parsing holds the whole document in memory at several times its size.
pub const MAX_WORLD_FILE_BYTES: u64 = 1 << 20;

/// The start must be this far from everything, plus `jitter_m · √2` (the default robot radius).
pub const START_CLEARANCE_M: f64 = 0.3;

/// Default radius of a person when `radius_m` is not given.
pub const DEFAULT_PERSON_RADIUS_M: f64 = 0.25;

/// A furniture or clutter object: a non-map obstacle the LiDAR sees and the robot must avoid.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    pub shape: Shape,
    /// [`HitKind::Furniture`] or [`HitKind::Clutter`].
    pub kind: HitKind,
    /// Free text for people reading the file or a plot ("bed", "box"); may be empty.
    pub label: String,
    /// What its outline is made of, for the LiDAR.
    pub material: Material,
}

/// An object to be found. The simulator places it at one of [`Target::positions`], picked by
/// the seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    pub name: String,
    /// The shape at its default position.
    pub shape: Shape,
    /// Alternative positions for the shape's centre (in addition to the default).
    pub candidates: Vec<P2>,
}

impl Target {
    /// The default centre followed by the alternatives: the seed picks one of these.
    pub fn positions(&self) -> Vec<P2> {
        let mut v = vec![self.shape.center()];
        v.extend(self.candidates.iter().copied());
        v
    }

    /// The shape moved to centre `p`.
    pub fn shape_at(&self, p: P2) -> Shape {
        self.shape.moved_to(p)
    }
}

/// A person walking a closed loop at constant speed (they wait while the robot is in the way).
#[derive(Clone, Debug, PartialEq)]
pub struct Person {
    /// The loop's corners; the last point connects back to the first. One point: standing still.
    pub path: Vec<P2>,
    pub speed_mps: f64,
    pub radius_m: f64,
}

/// Where the robot starts: `pose = [x, y, yaw]` (metres, radians) plus a uniform jitter
/// (`±jitter_m` in x and y, `±jitter_yaw_rad` in yaw) drawn from the seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Start {
    pub pose: [f64; 3],
    pub jitter_m: f64,
    pub jitter_yaw_rad: f64,
}

/// A building: the ground truth the simulator runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct World {
    pub name: String,
    /// Wall segments (the file's polylines expanded).
    pub walls: Vec<[P2; 2]>,
    /// The material of each wall segment, in the order of `walls` (a segment past its end is
    /// [`Material::Default`]; see [`World::wall_material`]).
    pub wall_materials: Vec<Material>,
    pub obstacles: Vec<Obstacle>,
    pub targets: Vec<Target>,
    pub people: Vec<Person>,
    pub start: Start,
    /// The search fails when this much simulated time has passed.
    pub time_limit_s: f64,
    /// Axis-aligned `[min, max]` of everything (walls, obstacles, every target position, people,
    /// start).
    pub bounds: [P2; 2],
}

/// Why a world file could not be loaded. `Display` is `FILE:LINE: problem` (`FILE: problem` for
/// I/O errors); lines are 1-based.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum WorldError {
    /// The file could not be read.
    Io { file: String, message: String },
    /// The text is not valid TOML.
    Syntax { file: String, line: usize, message: String },
    /// Valid TOML, but an unknown key, a missing key or a value of the wrong type.
    Schema { file: String, line: usize, message: String },
    /// Well-formed, but the values make no sense (NaN, negative size, overlapping target, ...).
    Invalid { file: String, line: usize, message: String },
}

impl WorldError {
    /// The file name given to the loader.
    pub fn file(&self) -> &str {
        self.parts().0
    }

    /// The 1-based line, if the error has one.
    pub fn line(&self) -> Option<usize> {
        self.parts().1
    }

    /// The problem, without file and line.
    pub fn message(&self) -> &str {
        self.parts().2
    }

    /// File, line and message, whatever the pass.
    fn parts(&self) -> (&str, Option<usize>, &str) {
        match self {
            WorldError::Io { file, message } => (file, None, message),
            WorldError::Syntax { file, line, message }
            | WorldError::Schema { file, line, message }
            | WorldError::Invalid { file, line, message } => (file, Some(*line), message),
        }
    }
}

impl fmt::Display for WorldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line() {
            Some(line) => write!(f, "{}:{}: {}", self.file(), line, self.message()),
            None => write!(f, "{}: {}", self.file(), self.message()),
        }
    }
}

impl std::error::Error for WorldError {}

impl World {
    /// A built-in world: `"apartment"`, `"office"` or `"hallway"` (see [`super::builtin`]).
    pub fn builtin(name: &str, scenario: Scenario) -> Option<World> {
        super::builtin::load(name, scenario)
    }

    /// Names accepted by [`World::builtin`].
    pub fn builtin_names() -> &'static [&'static str] {
        super::builtin::NAMES
    }

    /// Axis-aligned bounds of everything in the world.
    pub fn compute_bounds(&self) -> [P2; 2] {
        let mut pts: Vec<P2> = Vec::new();
        for w in &self.walls {
            pts.extend_from_slice(w);
        }
        for o in &self.obstacles {
            pts.extend_from_slice(&o.shape.aabb());
        }
        for t in &self.targets {
            for p in t.positions() {
                pts.extend_from_slice(&t.shape_at(p).aabb());
            }
        }
        for p in &self.people {
            for q in &p.path {
                pts.push([q[0] - p.radius_m, q[1] - p.radius_m]);
                pts.push([q[0] + p.radius_m, q[1] + p.radius_m]);
            }
        }
        pts.push([self.start.pose[0], self.start.pose[1]]);
        let b = super::geometry::aabb_of(&pts);
        if b[0][0].is_finite() {
            b
        } else {
            [[0.0; 2]; 2]
        }
    }

    /// The walls, the obstacles and the placed `targets` in a scene of 0.5 m cells, all of the
    /// default material (obstacle `i` owned by `i`, target `i` by `TARGET_OWNER_BASE + i`): the
    /// world without its people, as the reachability check, the oracle and `lives mapcheck` see
    /// it.
    pub fn static_scene(&self, targets: &[Shape]) -> Scene {
        let mut b = SceneBuilder::new();
        for w in &self.walls {
            b.wall(w[0], w[1]);
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            b.shape(&o.shape, o.kind, i as u32);
        }
        for (i, s) in targets.iter().enumerate() {
            b.shape(s, HitKind::Target, TARGET_OWNER_BASE + i as u32);
        }
        b.build(0.5)
    }

    /// A grid of `res`-metre cells over [`World::bounds`] and 0.5 m around them (at most 2000
    /// cells a side): its lower-left corner and its cells in x and in y.
    pub fn grid_over_bounds(&self, res: f64) -> (P2, usize, usize) {
        let origin = [self.bounds[0][0] - 0.5, self.bounds[0][1] - 0.5];
        let nx = (((self.bounds[1][0] - origin[0] + 0.5) / res).ceil() as usize).clamp(1, 2000);
        let ny = (((self.bounds[1][1] - origin[1] + 0.5) / res).ceil() as usize).clamp(1, 2000);
        (origin, nx, ny)
    }

    /// If `shape` overlaps a wall or an obstacle, say which.
    pub(crate) fn shape_clash(&self, shape: &Shape) -> Option<String> {
        for (i, w) in self.walls.iter().enumerate() {
            if shape.segment_distance(w[0], w[1]) <= 1e-6 {
                return Some(format!("wall segment {i} from {:?} to {:?}", w[0], w[1]));
            }
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            if shape.shape_distance(&o.shape) <= 1e-6 {
                return Some(obstacle_description(i, o));
            }
        }
        None
    }

    /// If a disc at `p` touches a wall, an obstacle or (optionally) a target at any of its
    /// positions, say which.
    pub fn disc_clash(&self, p: P2, r: f64, with_targets: bool) -> Option<String> {
        let disc = Shape::Circle { center: p, radius: r };
        for (i, w) in self.walls.iter().enumerate() {
            if disc.segment_distance(w[0], w[1]) <= 0.0 {
                return Some(format!("wall segment {i} from {:?} to {:?}", w[0], w[1]));
            }
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            if o.shape.distance_to(p) < r {
                return Some(obstacle_description(i, o));
            }
        }
        if with_targets {
            for t in &self.targets {
                for q in t.positions() {
                    if t.shape_at(q).distance_to(p) < r {
                        return Some(format!("target {:?} at {q:?}", t.name));
                    }
                }
            }
        }
        None
    }

    /// Is a disc of radius `r` at `p` clear of walls and obstacles (targets and people ignored)?
    pub fn disc_is_clear(&self, p: P2, r: f64) -> bool {
        self.disc_clash(p, r, false).is_none()
    }

    /// The material of wall segment `i` ([`Material::Default`] past the end of
    /// [`World::wall_materials`]).
    pub fn wall_material(&self, i: usize) -> Material {
        self.wall_materials.get(i).copied().unwrap_or_default()
    }
}

fn obstacle_description(i: usize, o: &Obstacle) -> String {
    if o.label.is_empty() {
        format!("obstacle {i}")
    } else {
        format!("obstacle {i} ({})", o.label)
    }
}

/// Points every `step` metres along a closed loop (its corners included).
pub(crate) fn person_path_samples(path: &[P2], step: f64) -> Vec<P2> {
    let n = path.len();
    if n <= 1 {
        return path.to_vec();
    }
    let mut out = Vec::new();
    for i in 0..n {
        let (a, b) = (path[i], path[(i + 1) % n]);
        let len = dist(a, b);
        let k = ((len / step).ceil() as usize).clamp(1, 100_000);
        for j in 0..k {
            let t = j as f64 / k as f64;
            out.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
        }
    }
    out
}

#[cfg(test)]
mod tests;
