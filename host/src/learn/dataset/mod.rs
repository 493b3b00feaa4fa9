//! The scan-classification dataset: poses, scans and ground-truth labels at 5 Hz along
//! trajectories through procedurally generated buildings (see `docs/dataset.md`).
//!
//! [`generate`] builds `worlds` buildings with [`World::random`] (seeds `first_world_seed`,
//! `first_world_seed + 1`, …) and drives `episodes_per_world` episodes through each: the
//! controller core with one of the planners (`lives-gt`, `multisensor`, `nearest`, run in
//! lockstep as in [`crate::search::run`]) or a random waypoint walk, from a random reachable
//! start, for a random 60–120 s. People walk as the simulator moves them. Every tick the pose,
//! the scan, the labeller's labels ([`crate::learn::labeller`]) and the simulator's own per-beam truth
//! are written as one fixed-size little-endian record.
//!
//! **The built-in worlds are never in the dataset.** The only way a world enters it is
//! `World::random(seed)`; [`DatasetSpec`] has no field that takes a world, a name or a file, and
//! every generated building is also compared with the built-in ones before use
//! ([`DatasetError::BuiltinWorld`]). `apartment`, `office` and `hallway` stay unseen test
//! buildings.
//!
//! The split is by world: all of a world's episodes go to `val` when
//! `world_seed % val_modulus == 0`, else to `train`.
//!
//! The same spec gives byte-identical files, whatever the thread count: worlds are processed in
//! batches of `threads` (each world independently, in memory) and written in seed order.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::learn::labeller::{Agreement, GtLabel, LabellerConfig};
use crate::search::PlannerChoice;
use crate::sim::generate::DEFAULT_DENSITY;

mod episodes;
mod reader;
pub use episodes::*;
pub use reader::*;

/// `meta.json`'s `format`.
pub const FORMAT: &str = "lives-scan-dataset";
/// The on-disk format version this code writes and reads.
pub const VERSION: u32 = 1;
/// The first 8 bytes of every split file.
pub const MAGIC: [u8; 8] = *b"LIVESDS\0";
/// Split file header length.
pub const HEADER_BYTES: usize = 32;
/// Beams per scan.
pub const BEAMS: usize = 897;
/// Scans per second (one record per controller tick).
pub const SCAN_HZ: f64 = 5.0;
/// The classifier's history length (METHOD.md §1.2), recorded in `meta.json` as a hint.
pub const HISTORY_K: usize = 9;
/// The paper's test buildings: never in a dataset.
pub const EXCLUDED_WORLDS: [&str; 3] = ["apartment", "office", "hallway"];
/// Longest episode a spec may ask for.
pub const MAX_EPISODE_S: f64 = 3600.0;

/// Bytes of one record with `beams` beams: `u64 + 2 × u32 + 3 × f32 + beams × (f32 + 2 × u8)`,
/// padded to a multiple of 4.
pub const fn record_bytes(beams: usize) -> usize {
    let raw = 8 + 4 + 4 + 12 + 4 * beams + 2 * beams;
    raw.div_ceil(4) * 4
}

/// Where a world's episodes go.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    Train,
    Val,
}

impl Split {
    pub const ALL: [Split; 2] = [Split::Train, Split::Val];

    /// `train` or `val`.
    pub fn as_str(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
        }
    }

    /// `train.bin` or `val.bin`.
    pub fn file_name(self) -> &'static str {
        match self {
            Split::Train => "train.bin",
            Split::Val => "val.bin",
        }
    }

    /// The header's split code (0 train, 1 val).
    pub fn code(self) -> u32 {
        match self {
            Split::Train => 0,
            Split::Val => 1,
        }
    }

    /// The split of a world: `val` when `world_seed % val_modulus == 0`.
    pub fn of_world(world_seed: u64, val_modulus: u64) -> Split {
        if val_modulus > 0 && world_seed.is_multiple_of(val_modulus) {
            Split::Val
        } else {
            Split::Train
        }
    }
}

impl fmt::Display for Split {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for Split {
    type Err = String;
    fn from_str(s: &str) -> Result<Split, String> {
        match s {
            "train" => Ok(Split::Train),
            "val" | "validation" => Ok(Split::Val),
            _ => Err(format!("unknown split `{s}` (expected train or val)")),
        }
    }
}

/// How the robot moves in an episode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Trajectory {
    /// The controller core with this planner, in lockstep with the simulator; after it finds the
    /// target or runs out of frontiers the episode goes on as a random walk.
    Planner(PlannerChoice),
    /// Random waypoints over reachable free space (straight legs checked with [`Sim::collides`])
    /// and turns on the spot.
    RandomWalk,
}

impl Trajectory {
    /// The rotation episodes cycle through.
    pub const ROTATION: [Trajectory; 4] = [
        Trajectory::Planner(PlannerChoice::LivesGt),
        Trajectory::Planner(PlannerChoice::Multisensor),
        Trajectory::Planner(PlannerChoice::Nearest),
        Trajectory::RandomWalk,
    ];

    /// Episode `episode` of world `world_seed` (with `episodes` per world): the rotation entry
    /// `(world_seed · episodes + episode) mod 4`, so consecutive worlds cover all four.
    pub fn for_episode(world_seed: u64, episode: u32, episodes: u32) -> Trajectory {
        let i = world_seed.wrapping_mul(episodes as u64).wrapping_add(episode as u64) % 4;
        Trajectory::ROTATION[i as usize]
    }

    /// `lives-gt`, `multisensor`, `nearest`, `random-walk`.
    pub fn name(self) -> String {
        match self {
            Trajectory::Planner(p) => p.to_string(),
            Trajectory::RandomWalk => "random-walk".to_string(),
        }
    }
}

/// Which worlds and episodes a dataset is made of, and how they are split (in [`DatasetSpec`], and
/// recorded as they are in `meta.json`'s `generator`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodePlan {
    /// World seeds are `first_world_seed .. first_world_seed + worlds`.
    pub first_world_seed: u64,
    /// Number of procedural worlds.
    pub worlds: u32,
    /// Episodes per world.
    pub episodes_per_world: u32,
    /// Each episode lasts a uniformly drawn time in `[episode_min_s, episode_max_s]` (whole ticks).
    pub episode_min_s: f64,
    pub episode_max_s: f64,
    /// A world is in `val` when `world_seed % val_modulus == 0` (at least 2).
    pub val_modulus: u64,
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct DatasetSpec {
    /// Output directory (created; `meta.json`, `train.bin`, `val.bin` in it are replaced).
    pub out_dir: PathBuf,
    /// The worlds, their episodes and the split.
    pub plan: EpisodePlan,
    /// The labeller's parameters.
    pub labeller: LabellerConfig,
    /// Worlds processed at once (1 = no threads). The output does not depend on it.
    pub threads: usize,
    /// The command line recorded in `meta.json`.
    pub command: String,
    /// Furniture and clutter density range `[lo, hi]` (each in `0..=1`): world `s` is
    /// `random_world_with_density(s, d)` with `d` drawn uniformly from the range by a hash of
    /// `s` ([`world_density`]). `[1, 1]` (the default) is exactly `World::random(s)`.
    pub density: [f64; 2],
}

impl DatasetSpec {
    /// Defaults: 60–120 s episodes, every fifth world seed in `val`, the default labeller, one
    /// thread.
    pub fn new(out_dir: impl Into<PathBuf>, first_world_seed: u64, worlds: u32, episodes_per_world: u32) -> DatasetSpec {
        DatasetSpec {
            out_dir: out_dir.into(),
            plan: EpisodePlan { first_world_seed, worlds, episodes_per_world, episode_min_s: 60.0, episode_max_s: 120.0, val_modulus: 5 },
            labeller: LabellerConfig::default(),
            threads: 1,
            density: [DEFAULT_DENSITY, DEFAULT_DENSITY],
            command: format!("lives dataset --worlds {worlds} --episodes-per-world {episodes_per_world} --seed {first_world_seed}"),
        }
    }

    fn validate(&self) -> Result<(), DatasetError> {
        let bad = |m: String| Err(DatasetError::InvalidSpec(m));
        if self.plan.worlds == 0 {
            return bad("at least one world is needed".into());
        }
        if self.plan.episodes_per_world == 0 {
            return bad("at least one episode per world is needed".into());
        }
        if self.plan.first_world_seed.checked_add(self.plan.worlds as u64 - 1).is_none() {
            return bad(format!("world seeds {} + {} overflow u64", self.plan.first_world_seed, self.plan.worlds));
        }
        let (lo, hi) = (self.plan.episode_min_s, self.plan.episode_max_s);
        if !(lo.is_finite() && hi.is_finite() && lo >= 1.0 / SCAN_HZ && lo <= hi && hi <= MAX_EPISODE_S) {
            return bad(format!("episode length {lo}–{hi} s: need 0.2 s ≤ min ≤ max ≤ {MAX_EPISODE_S} s"));
        }
        if self.plan.val_modulus < 2 {
            return bad(format!("val_modulus must be at least 2, got {}", self.plan.val_modulus));
        }
        let [dlo, dhi] = self.density;
        if !(0.0..=1.0).contains(&dlo) || !(0.0..=1.0).contains(&dhi) || dlo > dhi {
            return bad(format!("furniture density {dlo}–{dhi}: need 0 ≤ lo ≤ hi ≤ 1"));
        }
        Ok(())
    }
}

/// One episode, as listed in `meta.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeMeta {
    pub world_seed: u64,
    pub world_name: String,
    pub split: Split,
    pub episode: u32,
    /// `lives-gt`, `multisensor`, `nearest` or `random-walk`.
    pub trajectory: String,
    /// The simulator seed (noise, people's phases).
    pub sim_seed: u64,
    /// Records (ticks) written.
    pub ticks: u32,
    /// Start pose `[x, y, yaw]`.
    pub start: [f64; 3],
    /// Distance the base drove, metres (rounded to mm).
    pub path_m: f64,
    /// How a planner episode's controller ended before the walk took over (`found`,
    /// `exhausted`), or `running` / `walk`.
    pub controller_outcome: String,
}

/// One split file, as listed in `meta.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SplitMeta {
    pub file: String,
    pub records: u64,
    pub bytes: u64,
    pub world_seeds: Vec<u64>,
}

/// One field of a record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldMeta {
    pub name: String,
    pub dtype: String,
    pub count: usize,
    pub offset: usize,
}

/// Hints for feeding the data to a network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NormalisationMeta {
    pub lidar_min_range_m: f64,
    pub lidar_max_range_m: f64,
    pub range_noise_std_m: f64,
    pub non_finite_ranges: String,
    pub pose_xy_range_m: [f64; 2],
    pub yaw: String,
    pub suggested: String,
}

/// The generator's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeneratorMeta {
    pub command: String,
    #[serde(flatten)]
    pub plan: EpisodePlan,
    pub split_rule: String,
    pub trajectories: Vec<String>,
    pub robot_radius_m: f64,
    pub labeller: LabellerConfig,
    /// Furniture and clutter density range (absent = `[1, 1]`, the fully furnished default).
    #[serde(default = "default_density", skip_serializing_if = "is_default_density")]
    pub furniture_density: [f64; 2],
}

fn default_density() -> [f64; 2] {
    [DEFAULT_DENSITY, DEFAULT_DENSITY]
}

fn is_default_density(d: &[f64; 2]) -> bool {
    *d == default_density()
}

/// The labeller against the simulator's truth over the whole dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AgreementMeta {
    /// `counts[label code][truth code]`.
    pub counts: [[u64; 6]; 4],
    pub map_accuracy: Option<f64>,
    pub wall_labelled_ltf: Option<f64>,
    pub non_map_labelled_stf_or_df: Option<f64>,
}

/// `meta.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    pub format: String,
    pub version: u32,
    pub magic: String,
    pub header_bytes: usize,
    pub record_bytes: usize,
    pub endianness: String,
    pub beams: usize,
    pub angle_min_rad: f64,
    pub angle_increment_rad: f64,
    pub scan_hz: f64,
    pub history_k: usize,
    pub record_layout: Vec<FieldMeta>,
    pub label_codes: BTreeMap<String, String>,
    pub truth_codes: BTreeMap<String, String>,
    pub label_convention: String,
    pub normalisation: NormalisationMeta,
    pub excluded_worlds: Vec<String>,
    pub splits: BTreeMap<String, SplitMeta>,
    pub generator: GeneratorMeta,
    pub agreement: AgreementMeta,
    pub episodes: Vec<EpisodeMeta>,
}

/// What [`generate`] did.
#[derive(Clone, Debug)]
pub struct DatasetSummary {
    pub out_dir: PathBuf,
    pub train_records: u64,
    pub val_records: u64,
    pub train_worlds: Vec<u64>,
    pub val_worlds: Vec<u64>,
    pub episodes: usize,
    pub train_bytes: u64,
    pub val_bytes: u64,
    /// The labeller against the simulator's truth over all records.
    pub agreement: Agreement,
    /// Simulated seconds recorded.
    pub simulated_s: f64,
}

/// Progress of [`generate_with`].
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub worlds_done: u32,
    pub worlds: u32,
    pub records: u64,
}

/// Why a dataset could not be written or read.
#[derive(Clone, Debug, PartialEq)]
pub enum DatasetError {
    /// The spec asks for something impossible.
    InvalidSpec(String),
    /// A generated world equals a built-in test building (never expected; refused).
    BuiltinWorld { world_seed: u64, builtin: String },
    /// Reading or writing a file failed.
    Io { path: PathBuf, message: String },
    /// `meta.json` is missing, not JSON, of another format, or inconsistent.
    Meta { path: PathBuf, message: String },
    /// A split file does not start with [`MAGIC`].
    BadMagic { path: PathBuf, found: Vec<u8> },
    /// A format version this code does not read.
    UnsupportedVersion { path: PathBuf, found: u32, supported: u32 },
    /// The header disagrees with `meta.json` or with itself.
    BadHeader { path: PathBuf, message: String },
    /// The file ends inside a record, or holds fewer records than `meta.json` lists. The
    /// `complete_records` before the cut are readable.
    Truncated { path: PathBuf, complete_records: u64, trailing_bytes: u64, expected_records: u64 },
    /// A record index past the end.
    OutOfRange { index: u64, len: u64 },
}

impl fmt::Display for DatasetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DatasetError::InvalidSpec(m) => write!(f, "invalid dataset spec: {m}"),
            DatasetError::BuiltinWorld { world_seed, builtin } => {
                write!(f, "random world {world_seed} equals the built-in test world `{builtin}`; refusing to put it in a dataset")
            }
            DatasetError::Io { path, message } => write!(f, "{}: {message}", path.display()),
            DatasetError::Meta { path, message } => write!(f, "{}: bad dataset metadata: {message}", path.display()),
            DatasetError::BadMagic { path, found } => {
                write!(f, "{}: not a LIVES dataset file (magic {:?}, expected {:?})", path.display(), found, MAGIC)
            }
            DatasetError::UnsupportedVersion { path, found, supported } => {
                write!(f, "{}: dataset format version {found}, this program reads version {supported}", path.display())
            }
            DatasetError::BadHeader { path, message } => write!(f, "{}: bad header: {message}", path.display()),
            DatasetError::Truncated { path, complete_records, trailing_bytes, expected_records } => write!(
                f,
                "{}: truncated: {complete_records} complete records (meta.json lists {expected_records}) and {trailing_bytes} bytes of a partial record",
                path.display()
            ),
            DatasetError::OutOfRange { index, len } => write!(f, "record {index} out of range (0..{len})"),
        }
    }
}

impl std::error::Error for DatasetError {}

fn io_err(path: &Path, e: impl fmt::Display) -> DatasetError {
    DatasetError::Io { path: path.to_path_buf(), message: e.to_string() }
}

/// One record: a scan with its pose and labels.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    pub world_seed: u64,
    pub episode: u32,
    /// Tick within the episode (0.2 s each).
    pub tick: u32,
    /// `[x, y, yaw]` in the world frame (metres, radians in (−π, π]) when the scan was taken.
    pub pose: [f32; 3],
    /// Ranges in metres, beam `i` at `yaw − π + i · 2π/897`; `+inf` no return, NaN invalid.
    pub ranges: Vec<f32>,
    /// The labeller's label codes (0 none, 1 LTF/map, 2 STF, 3 DF).
    pub labels: Vec<u8>,
    /// The simulator's truth codes (0 none, 1 wall, 2 furniture, 3 clutter, 4 person, 5 target).
    pub truth: Vec<u8>,
}

impl Record {
    /// The labeller's label of beam `i`.
    pub fn label(&self, i: usize) -> Option<GtLabel> {
        self.labels.get(i).and_then(|&c| GtLabel::from_code(c))
    }

    /// Append the record's bytes (see `docs/dataset.md`).
    pub fn encode(&self, out: &mut Vec<u8>) {
        let start = out.len();
        out.extend_from_slice(&self.world_seed.to_le_bytes());
        out.extend_from_slice(&self.episode.to_le_bytes());
        out.extend_from_slice(&self.tick.to_le_bytes());
        for v in self.pose {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for r in &self.ranges {
            out.extend_from_slice(&r.to_le_bytes());
        }
        out.extend_from_slice(&self.labels);
        out.extend_from_slice(&self.truth);
        let n = self.ranges.len();
        out.resize(start + record_bytes(n), 0);
    }

    /// Parse a record of `beams` beams from exactly [`record_bytes`]`(beams)` bytes.
    pub fn decode(b: &[u8], beams: usize) -> Option<Record> {
        if b.len() != record_bytes(beams) {
            return None;
        }
        let u32_at = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        let f32_at = |o: usize| f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        let mut seed = [0u8; 8];
        seed.copy_from_slice(&b[0..8]);
        let r0 = 28;
        let l0 = r0 + 4 * beams;
        let t0 = l0 + beams;
        Some(Record {
            world_seed: u64::from_le_bytes(seed),
            episode: u32_at(8),
            tick: u32_at(12),
            pose: [f32_at(16), f32_at(20), f32_at(24)],
            ranges: (0..beams).map(|i| f32_at(r0 + 4 * i)).collect(),
            labels: b[l0..l0 + beams].to_vec(),
            truth: b[t0..t0 + beams].to_vec(),
        })
    }
}

/// A split file's 32-byte header.
fn header_bytes(split: Split, beams: usize) -> [u8; HEADER_BYTES] {
    let mut h = [0u8; HEADER_BYTES];
    h[0..8].copy_from_slice(&MAGIC);
    h[8..12].copy_from_slice(&VERSION.to_le_bytes());
    h[12..16].copy_from_slice(&(beams as u32).to_le_bytes());
    h[16..20].copy_from_slice(&(record_bytes(beams) as u32).to_le_bytes());
    h[20..24].copy_from_slice(&split.code().to_le_bytes());
    h
}

#[cfg(test)]
mod tests;
