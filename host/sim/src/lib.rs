//! `lives-sim`: the 2D indoor simulator, the "true world" the LIVES controller searches (re-exported
//! by `host` as `host::sim`).
//!
//! This module owns the ground truth and nothing else: floor plans ([`World`]), the robot's
//! sensors (a 360° 2D LiDAR, [`Sim::scan`], and a narrow camera with an oracle detector,
//! [`Sim::detect`]), the mobile base ([`Sim::set_path`], [`Sim::step`]) and the people who walk
//! through the building. It must not know anything about the controller: the controller sees the
//! world only through scans, detections and the pose.
//!
//! Everything here is `f64`, metres, radians and seconds, in the world frame (REP-103: x forward /
//! east, y left / north, yaw counter-clockwise from +x). Every random draw comes from a ChaCha RNG
//! seeded from the user's seed, so the same seed gives bit-identical runs.
//!
//! * [`world`]: the [`World`] type, its TOML format (see `docs/world-format.md`) and validation.
//! * [`builtin`]: the paper's worlds, `apartment`, `office`, `hallway`, each in an easy and a hard
//!   [`Scenario`], authored as TOML in `host/sim/src/worlds/`.
//! * [`generate`]: procedural buildings, [`World::random`].
//! * [`geometry`]: shapes, ray casting and collision queries with a uniform-grid broad phase.
//! * [`simulator`]: [`Sim`], [`SimConfig`], [`Scan`], [`BaseStatus`].
//! * [`reach`]: coarse reachability (0.1 m grid, robot-radius inflation) used by tests and the
//!   generator.

pub mod builtin;
pub mod generate;
pub mod geometry;
pub mod oracle;
pub mod reach;
pub mod simulator;
pub mod world;

use std::fmt;
use std::str::FromStr;

pub use simulator::{BaseStatus, LidarModel, Scan, Sim, SimConfig};
pub use world::{Obstacle, Person, Start, Target, World, WorldError};

/// The bytes of the file at `path` if it holds at most `max`; `Ok(None)` if it holds more, found
/// by reading one byte past `max`, so a huge file is refused without being read whole; a path
/// that is not a regular file (a pipe, `/dev/zero`) is an error before it is opened. For the
/// files users hand the program: world files, classifier blobs.
pub fn read_at_most(path: &std::path::Path, max: u64) -> std::io::Result<Option<Vec<u8>>> {
    use std::io::Read as _;
    // A pipe without a writer would block the open forever, a device never end: files only.
    if !std::fs::metadata(path)?.is_file() {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file (a pipe, a socket or a device)"));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(max.saturating_add(1)).read_to_end(&mut bytes)?;
    Ok((bytes.len() as u64 <= max).then_some(bytes))
}

/// A point or vector in the plane, `[x, y]` in metres.
pub type P2 = [f64; 2];

/// The outline of an obstacle or target. Angles in radians, lengths in metres.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A rectangle of `size = [length along its x axis, width]`, rotated by `yaw` about `center`.
    Rect { center: P2, size: P2, yaw: f64 },
    /// A disc.
    Circle { center: P2, radius: f64 },
    /// A simple polygon (at least 3 points, either winding), implicitly closed.
    Polygon { points: Vec<P2> },
}

/// Which of the paper's two difficulty settings a built-in world is loaded in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scenario {
    Easy,
    Hard,
}

impl Scenario {
    /// Both scenarios, easy first.
    pub const ALL: [Scenario; 2] = [Scenario::Easy, Scenario::Hard];

    /// `"easy"` or `"hard"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Scenario::Easy => "easy",
            Scenario::Hard => "hard",
        }
    }
}

impl fmt::Display for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The error of parsing a [`Scenario`] from anything but `easy` or `hard` (ASCII case ignored).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParseScenarioError(pub String);

impl fmt::Display for ParseScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown scenario {:?}, expected \"easy\" or \"hard\"", self.0)
    }
}

impl std::error::Error for ParseScenarioError {}

impl FromStr for Scenario {
    type Err = ParseScenarioError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "easy" => Ok(Scenario::Easy),
            "hard" => Ok(Scenario::Hard),
            _ => Err(ParseScenarioError(s.to_string())),
        }
    }
}

/// What a wall's or an obstacle's surface is made of, for the LiDAR (`material = "…"` in world
/// files; see `docs/world-format.md` and `docs/sim-sensors.md`). The camera and the base ignore it;
/// the `ideal` LiDAR profile ignores it too (every surface returns).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Material {
    /// Painted walls, wood, fabric: a diffuse surface of reflectance [`Material::reflectance`].
    #[default]
    Default,
    /// Dark, matt surfaces (black furniture, dark carpet on a wall): little light comes back.
    Dark,
    /// Windows, glass doors and partitions: the beam mostly passes through, returning from what
    /// lies behind or not at all; only near normal incidence does the pane itself return.
    Glass,
}

impl Material {
    /// Every material, in the order the docs list them.
    pub const ALL: [Material; 3] = [Material::Default, Material::Dark, Material::Glass];

    /// The name world files use.
    pub fn as_str(self) -> &'static str {
        match self {
            Material::Default => "default",
            Material::Dark => "dark",
            Material::Glass => "glass",
        }
    }

    /// The material of a world file's name (exact, lower case).
    pub fn from_name(name: &str) -> Option<Material> {
        Material::ALL.into_iter().find(|m| m.as_str() == name)
    }

    /// Diffuse reflectance at the LiDAR's near-infrared wavelength (0–1), for the no-return
    /// model: 0.5 for painted walls, 0.08 for dark surfaces (the datasheets' "black" target is
    /// about 0.1). Glass returns by its own rule, not by reflectance.
    pub fn reflectance(self) -> f64 {
        match self {
            Material::Default => 0.5,
            Material::Dark => 0.08,
            Material::Glass => 0.0,
        }
    }
}

/// What a LiDAR beam (or a line of sight) hit: the ground truth behind the map / non-map labels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HitKind {
    /// No usable return: nothing within the maximum range (range `+inf`), or a dropout or a
    /// return below the minimum range (range NaN).
    None,
    /// Permanent structure, the only "map" class.
    Wall,
    /// Large movable objects: beds, sofas, tables, shelves, desks.
    Furniture,
    /// Small objects: boxes, chairs, bins.
    Clutter,
    /// A walking person.
    Person,
    /// The object being searched for.
    Target,
}

impl HitKind {
    /// True only for [`HitKind::Wall`]: the ground truth of the map / non-map split.
    pub fn is_map(self) -> bool {
        matches!(self, HitKind::Wall)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenario_parses_and_displays() {
        assert_eq!("easy".parse::<Scenario>(), Ok(Scenario::Easy));
        assert_eq!("HARD".parse::<Scenario>(), Ok(Scenario::Hard));
        assert!("medium".parse::<Scenario>().is_err());
        for s in Scenario::ALL {
            assert_eq!(s.to_string().parse::<Scenario>(), Ok(s));
        }
    }

    #[test]
    fn only_walls_are_map() {
        assert!(HitKind::Wall.is_map());
        for k in [HitKind::None, HitKind::Furniture, HitKind::Clutter, HitKind::Person, HitKind::Target] {
            assert!(!k.is_map());
        }
    }
}
