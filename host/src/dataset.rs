//! The scan-classification dataset: poses, scans and ground-truth labels at 5 Hz along
//! trajectories through procedurally generated buildings (see `docs/dataset.md`).
//!
//! [`generate`] builds `worlds` buildings with [`World::random`] (seeds `first_world_seed`,
//! `first_world_seed + 1`, …) and drives `episodes_per_world` episodes through each: the
//! controller core with one of the planners (`lives-gt`, `multisensor`, `nearest`, run in
//! lockstep as in [`crate::search::run`]) or a random waypoint walk, from a random reachable
//! start, for a random 60–120 s. People walk as the simulator moves them. Every tick the pose,
//! the scan, the labeller's labels ([`crate::labeller`]) and the simulator's own per-beam truth
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
use std::fs::{self, File};
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::labeller::{hit_code, Agreement, GtLabel, Labeller, LabellerConfig};
use crate::search::{controller_config, encode_sim_scan, PlannerChoice, TICK_US};
use crate::sim::generate::{random_world_with_density, DEFAULT_DENSITY, GENERATOR_ROBOT_RADIUS_M};
use crate::sim::geometry::dist;
use crate::sim::reach::ReachMap;
use crate::sim::{BaseStatus, Scan, Scenario, Sim, SimConfig, World, P2};
use firmware::{Command, Config, Controller, Detection, Inputs, Mode, Pose2};

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

/// Base sub-steps per tick (as in [`crate::search`]).
const SUBSTEPS: u32 = 4;

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

/// What to generate.
#[derive(Clone, Debug)]
pub struct DatasetSpec {
    /// Output directory (created; `meta.json`, `train.bin`, `val.bin` in it are replaced).
    pub out_dir: PathBuf,
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
            first_world_seed,
            worlds,
            episodes_per_world,
            episode_min_s: 60.0,
            episode_max_s: 120.0,
            val_modulus: 5,
            labeller: LabellerConfig::default(),
            threads: 1,
            density: [DEFAULT_DENSITY, DEFAULT_DENSITY],
            command: format!("lives dataset --worlds {worlds} --episodes-per-world {episodes_per_world} --seed {first_world_seed}"),
        }
    }

    fn validate(&self) -> Result<(), DatasetError> {
        let bad = |m: String| Err(DatasetError::InvalidSpec(m));
        if self.worlds == 0 {
            return bad("at least one world is needed".into());
        }
        if self.episodes_per_world == 0 {
            return bad("at least one episode per world is needed".into());
        }
        if self.first_world_seed.checked_add(self.worlds as u64 - 1).is_none() {
            return bad(format!("world seeds {} + {} overflow u64", self.first_world_seed, self.worlds));
        }
        let (lo, hi) = (self.episode_min_s, self.episode_max_s);
        if !(lo.is_finite() && hi.is_finite() && lo >= 1.0 / SCAN_HZ && lo <= hi && hi <= MAX_EPISODE_S) {
            return bad(format!("episode length {lo}–{hi} s: need 0.2 s ≤ min ≤ max ≤ {MAX_EPISODE_S} s"));
        }
        if self.val_modulus < 2 {
            return bad(format!("val_modulus must be at least 2, got {}", self.val_modulus));
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
    pub first_world_seed: u64,
    pub worlds: u32,
    pub episodes_per_world: u32,
    pub episode_min_s: f64,
    pub episode_max_s: f64,
    pub val_modulus: u64,
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

// ---------------------------------------------------------------------------------------------
// Episodes.

/// SplitMix64: derives independent seeds from (world seed, episode).
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The furniture density of world `world_seed` under the range `[lo, hi]`: `lo` when they are
/// equal, else uniform in the range by a hash of the seed (independent of the thread count).
pub fn world_density(world_seed: u64, [lo, hi]: [f64; 2]) -> f64 {
    if lo >= hi {
        return lo;
    }
    let u = (mix(world_seed ^ 0x6465_6e73_6974_7921) >> 11) as f64 / (1u64 << 53) as f64;
    lo + (hi - lo) * u
}

/// The world of `world_seed` in a dataset with furniture density range `density`.
pub fn dataset_world(world_seed: u64, density: [f64; 2]) -> World {
    if density == default_density() {
        World::random(world_seed)
    } else {
        random_world_with_density(world_seed, world_density(world_seed, density))
    }
}

/// The simulator seed of an episode.
pub fn episode_seed(world_seed: u64, episode: u32) -> u64 {
    mix(mix(world_seed) ^ (episode as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93))
}

/// The simulator settings used for the dataset: the clean robot the shipped classifier was
/// trained on (`lives search`'s robot before the LiDAR profiles; the labeller takes the base's
/// true pose as the laser's, so no mount and no drift here).
pub fn sim_config() -> SimConfig {
    crate::search::ideal_sim()
}

/// A world with its reachable free cells (for starts and random waypoints).
struct WorldContext {
    world: World,
    free: Vec<P2>,
}

impl WorldContext {
    fn new(world: World) -> WorldContext {
        let start = [world.start.pose[0], world.start.pose[1]];
        let reach = ReachMap::new(&world, start, GENERATOR_ROBOT_RADIUS_M);
        let [lo, hi] = world.bounds;
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let radius = dist(lo, hi) / 2.0 + 1.0;
        let free = reach.reached_near(centre, radius);
        WorldContext { world, free }
    }

    /// A copy of the world whose start is a random reachable spot clear of everything (no
    /// jitter), facing a random way; the world's own start if none is found.
    fn with_random_start(&self, rng: &mut ChaCha8Rng) -> World {
        let mut w = self.world.clone();
        let need = crate::sim::world::START_CLEARANCE_M.max(GENERATOR_ROBOT_RADIUS_M) + 0.05;
        if !self.free.is_empty() {
            for _ in 0..200 {
                let p = self.free[rng.gen_range(0..self.free.len())];
                if w.disc_clash(p, need, true).is_none() {
                    let yaw = rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
                    w.start.pose = [p[0], p[1], yaw];
                    w.start.jitter_m = 0.0;
                    w.start.jitter_yaw_rad = 0.0;
                    break;
                }
            }
        }
        w
    }
}

/// Random waypoint walk: picks a reachable cell 1–8 m away with a clear straight line, or turns
/// on the spot; a new choice when the base arrives, is blocked for 1 s, or runs out of time.
struct RandomWalker {
    rng: ChaCha8Rng,
    deadline_tick: u32,
    blocked_ticks: u32,
}

impl RandomWalker {
    fn new(seed: u64) -> RandomWalker {
        RandomWalker { rng: ChaCha8Rng::seed_from_u64(seed), deadline_tick: 0, blocked_ticks: 0 }
    }

    fn update(&mut self, sim: &mut Sim, free: &[P2], tick: u32, blocked: bool) {
        self.blocked_ticks = if blocked { self.blocked_ticks + 1 } else { 0 };
        let idle = matches!(sim.base_status(), BaseStatus::Idle | BaseStatus::Arrived);
        if !(idle || self.blocked_ticks >= 5 || tick >= self.deadline_tick) {
            return;
        }
        self.blocked_ticks = 0;
        let p = sim.pose();
        let here = [p[0], p[1]];
        if !free.is_empty() && self.rng.gen_bool(0.85) {
            for _ in 0..60 {
                let q = free[self.rng.gen_range(0..free.len())];
                let d = dist(here, q);
                if !(1.0..=8.0).contains(&d) || !line_clear(sim, here, q) {
                    continue;
                }
                let yaw = self.rng.gen_bool(0.3).then(|| self.rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI));
                sim.set_path(&[q], yaw);
                let speed = sim.config().speed_mps.max(0.05);
                self.deadline_tick = tick + ((d / speed + 10.0) * SCAN_HZ) as u32;
                return;
            }
        }
        let yaw = self.rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
        sim.set_path(&[], Some(yaw));
        self.deadline_tick = tick + (8.0 * SCAN_HZ) as u32;
    }
}

/// Is the straight line from `a` to `b` clear for the robot (sampled every 5 cm)?
fn line_clear(sim: &Sim, a: P2, b: P2) -> bool {
    let d = dist(a, b);
    let n = (d / 0.05).ceil().max(1.0) as usize;
    (1..=n).all(|i| {
        let t = i as f64 / n as f64;
        !sim.collides([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t])
    })
}

/// The result of driving one episode.
struct EpisodeRun {
    start: [f64; 3],
    path_m: f64,
    controller_outcome: &'static str,
}

/// Drive one episode of `ticks` ticks through `world` and call `on_tick(tick, pose, scan)` at
/// every tick, before the robot moves. `free` holds reachable cells for the random walk.
fn drive_episode(
    world: &World,
    free: &[P2],
    trajectory: Trajectory,
    sim_seed: u64,
    ticks: u32,
    mut on_tick: impl FnMut(u32, [f64; 3], &Scan),
) -> EpisodeRun {
    let cfg = sim_config();
    let mut sim = Sim::new(world.clone(), cfg.clone(), sim_seed);
    let start = sim.pose();
    let mut ctrl = match trajectory {
        Trajectory::Planner(p) => Some((Box::new(Controller::new(controller_config(&Config::DEFAULT, world, p))), p)),
        Trajectory::RandomWalk => None,
    };
    let mut outcome = if ctrl.is_some() { "running" } else { "walk" };
    let mut walker = RandomWalker::new(mix(sim_seed ^ 0x5741_4C4B));
    let mut base_blocked = false;
    for tick in 0..ticks {
        let p = sim.pose();
        let scan = sim.scan();
        on_tick(tick, p, &scan);
        let mut handed_over = false;
        if let Some((c, planner)) = ctrl.as_mut() {
            let use_labels = planner.uses_labels();
            let encoded = encode_sim_scan(&scan);
            let inputs = Inputs {
                pose: Pose2::from_f64(p[0], p[1], p[2]),
                scan: Some(encoded.input(use_labels)),
                detection: sim.detect().map(|_| Detection { position: None }),
                command: (tick == 0).then_some(Command::Start),
                base_blocked,
            };
            let out = c.tick(tick as u64 * TICK_US, &inputs);
            match out.status.mode {
                Some(Mode::TargetFound) => {
                    outcome = "found";
                    handed_over = true;
                }
                Some(Mode::Exhausted) => {
                    outcome = "exhausted";
                    handed_over = true;
                }
                _ => {
                    if out.stop {
                        sim.stop_base();
                    } else if let (true, Some(g)) = (out.new_goal, &out.goal) {
                        let path: Vec<[f64; 2]> = g.path.iter().map(|w| [w.0.to_num::<f64>(), w.1.to_num::<f64>()]).collect();
                        sim.set_path(&path, Some(g.pose.theta.to_radians()));
                    }
                }
            }
        }
        if handed_over {
            ctrl = None;
            sim.stop_base();
        }
        if ctrl.is_none() {
            walker.update(&mut sim, free, tick, base_blocked);
        }
        base_blocked = false;
        for _ in 0..SUBSTEPS {
            if sim.step(TICK_US as f64 / 1e6 / SUBSTEPS as f64) == BaseStatus::Blocked {
                base_blocked = true;
            }
        }
    }
    EpisodeRun { start, path_m: (sim.path_length_m() * 1000.0).round() / 1000.0, controller_outcome: outcome }
}

/// Drive `trajectory` through `world` for `duration_s` (simulator seed `sim_seed`, the world's own
/// start) and tally the labeller against the simulator's truth. Writes nothing: this is how the
/// labeller is measured, on any world (the built-in ones included).
pub fn measure_agreement(world: &World, trajectory: Trajectory, sim_seed: u64, duration_s: f64, labeller: &LabellerConfig) -> Agreement {
    let ctx = WorldContext::new(world.clone());
    let mut lab = Labeller::for_world(world, labeller.clone());
    let mut agreement = Agreement::default();
    let ticks = (duration_s.max(0.0) * SCAN_HZ).round() as u32;
    drive_episode(world, &ctx.free, trajectory, sim_seed, ticks, |_, pose, scan| {
        let labels = lab.label_scan(pose, scan);
        agreement.add(&labels, &scan.hits);
    });
    agreement
}

/// Everything one world contributes.
struct WorldOutput {
    world_seed: u64,
    split: Split,
    bytes: Vec<u8>,
    records: u64,
    episodes: Vec<EpisodeMeta>,
    agreement: Agreement,
}

fn builtin_walls() -> Vec<(String, Vec<[P2; 2]>)> {
    let mut v = Vec::new();
    for name in World::builtin_names() {
        for sc in Scenario::ALL {
            if let Some(w) = World::builtin(name, sc) {
                v.push((name.to_string(), w.walls));
            }
        }
    }
    v
}

fn world_output(spec: &DatasetSpec, world_seed: u64, builtins: &[(String, Vec<[P2; 2]>)]) -> Result<WorldOutput, DatasetError> {
    // The only source of worlds: `World::random(seed)`, or the same generator thinned.
    let world = dataset_world(world_seed, spec.density);
    if let Some((name, _)) = builtins.iter().find(|(_, walls)| *walls == world.walls) {
        return Err(DatasetError::BuiltinWorld { world_seed, builtin: name.clone() });
    }
    if EXCLUDED_WORLDS.contains(&world.name.as_str()) {
        return Err(DatasetError::BuiltinWorld { world_seed, builtin: world.name.clone() });
    }
    let split = Split::of_world(world_seed, spec.val_modulus);
    let ctx = WorldContext::new(world);
    let mut lab = Labeller::for_world(&ctx.world, spec.labeller.clone());
    let mut out = WorldOutput { world_seed, split, bytes: Vec::new(), records: 0, episodes: Vec::new(), agreement: Agreement::default() };
    let (lo_t, hi_t) = ((spec.episode_min_s * SCAN_HZ).round() as u32, (spec.episode_max_s * SCAN_HZ).round() as u32);
    for episode in 0..spec.episodes_per_world {
        let seed = episode_seed(world_seed, episode);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let ticks = rng.gen_range(lo_t.max(1)..=hi_t.max(lo_t.max(1)));
        let world = ctx.with_random_start(&mut rng);
        let trajectory = Trajectory::for_episode(world_seed, episode, spec.episodes_per_world);
        lab.reset();
        let mut rec = Record {
            world_seed,
            episode,
            tick: 0,
            pose: [0.0; 3],
            ranges: Vec::with_capacity(BEAMS),
            labels: Vec::with_capacity(BEAMS),
            truth: Vec::with_capacity(BEAMS),
        };
        let mut count = 0u32;
        let run = drive_episode(&world, &ctx.free, trajectory, seed, ticks, |tick, pose, scan| {
            let labels = lab.label_scan(pose, scan);
            out.agreement.add(&labels, &scan.hits);
            rec.tick = tick;
            rec.pose = [pose[0] as f32, pose[1] as f32, pose[2] as f32];
            rec.ranges.clear();
            rec.ranges.extend_from_slice(&scan.ranges_m);
            rec.labels.clear();
            rec.labels.extend(labels.iter().map(|l| l.code()));
            rec.truth.clear();
            rec.truth.extend(scan.hits.iter().map(|&h| hit_code(h)));
            debug_assert_eq!(rec.ranges.len(), BEAMS);
            rec.encode(&mut out.bytes);
            count += 1;
        });
        out.records += count as u64;
        out.episodes.push(EpisodeMeta {
            world_seed,
            world_name: world.name.clone(),
            split,
            episode,
            trajectory: trajectory.name(),
            sim_seed: seed,
            ticks: count,
            start: run.start,
            path_m: run.path_m,
            controller_outcome: run.controller_outcome.to_string(),
        });
    }
    Ok(out)
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Generate a dataset (see the module docs and `docs/dataset.md`).
pub fn generate(spec: &DatasetSpec) -> Result<DatasetSummary, DatasetError> {
    generate_with(spec, |_| {})
}

/// [`generate`], calling `progress` after each batch of worlds.
pub fn generate_with(spec: &DatasetSpec, mut progress: impl FnMut(Progress)) -> Result<DatasetSummary, DatasetError> {
    spec.validate()?;
    let sim = sim_config();
    if sim.beams != BEAMS {
        return Err(DatasetError::InvalidSpec(format!("the simulator has {} beams, the format {BEAMS}", sim.beams)));
    }
    let dir = &spec.out_dir;
    fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
    let meta_path = dir.join("meta.json");
    // meta.json is written last: without it the directory is not a dataset.
    if meta_path.exists() {
        fs::remove_file(&meta_path).map_err(|e| io_err(&meta_path, e))?;
    }
    let mut writers = Vec::new();
    for split in Split::ALL {
        let path = dir.join(split.file_name());
        let f = File::create(&path).map_err(|e| io_err(&path, e))?;
        let mut w = BufWriter::with_capacity(1 << 20, f);
        w.write_all(&header_bytes(split, BEAMS)).map_err(|e| io_err(&path, e))?;
        writers.push((path, w, 0u64, Vec::<u64>::new()));
    }
    let builtins = builtin_walls();
    let seeds: Vec<u64> = (0..spec.worlds as u64).map(|i| spec.first_world_seed + i).collect();
    let threads = spec.threads.clamp(1, 64);
    let mut episodes = Vec::new();
    let mut agreement = Agreement::default();
    let mut done = 0u32;
    let mut total_records = 0u64;
    for batch in seeds.chunks(threads) {
        let outputs: Vec<Result<WorldOutput, DatasetError>> = if batch.len() == 1 {
            vec![world_output(spec, batch[0], &builtins)]
        } else {
            std::thread::scope(|s| {
                let builtins = &builtins;
                let handles: Vec<_> = batch.iter().map(|&seed| s.spawn(move || world_output(spec, seed, builtins))).collect();
                handles
                    .into_iter()
                    .map(|h| h.join().unwrap_or_else(|_| Err(DatasetError::InvalidSpec("a generator thread panicked".into()))))
                    .collect()
            })
        };
        for o in outputs {
            let o = o?;
            let (path, w, records, worlds) = &mut writers[o.split.code() as usize];
            w.write_all(&o.bytes).map_err(|e| io_err(path, e))?;
            *records += o.records;
            worlds.push(o.world_seed);
            total_records += o.records;
            agreement.merge(&o.agreement);
            episodes.extend(o.episodes);
            done += 1;
        }
        progress(Progress { worlds_done: done, worlds: spec.worlds, records: total_records });
    }
    let mut splits = BTreeMap::new();
    let mut sizes = [0u64; 2];
    for (i, (path, mut w, records, worlds)) in writers.into_iter().enumerate() {
        w.flush().map_err(|e| io_err(&path, e))?;
        let f = w.into_inner().map_err(|e| io_err(&path, e.error()))?;
        f.sync_all().map_err(|e| io_err(&path, e))?;
        let bytes = HEADER_BYTES as u64 + records * record_bytes(BEAMS) as u64;
        sizes[i] = bytes;
        let split = Split::ALL[i];
        splits.insert(split.as_str().to_string(), SplitMeta { file: split.file_name().to_string(), records, bytes, world_seeds: worlds });
    }
    let meta = build_meta(spec, &sim, splits, &agreement, episodes);
    let json = serde_json::to_string_pretty(&meta).map_err(|e| io_err(&meta_path, e))?;
    fs::write(&meta_path, json + "\n").map_err(|e| io_err(&meta_path, e))?;
    let s = |k: &str| meta.splits.get(k).cloned().unwrap_or(SplitMeta { file: String::new(), records: 0, bytes: 0, world_seeds: vec![] });
    let (train, val) = (s("train"), s("val"));
    Ok(DatasetSummary {
        out_dir: dir.clone(),
        train_records: train.records,
        val_records: val.records,
        train_worlds: train.world_seeds,
        val_worlds: val.world_seeds,
        episodes: meta.episodes.len(),
        train_bytes: sizes[0],
        val_bytes: sizes[1],
        simulated_s: total_records as f64 / SCAN_HZ,
        agreement,
    })
}

fn build_meta(
    spec: &DatasetSpec,
    sim: &SimConfig,
    splits: BTreeMap<String, SplitMeta>,
    agreement: &Agreement,
    episodes: Vec<EpisodeMeta>,
) -> Meta {
    let beams = BEAMS;
    let field = |name: &str, dtype: &str, count: usize, offset: usize| FieldMeta { name: name.into(), dtype: dtype.into(), count, offset };
    let layout = vec![
        field("world_seed", "u64", 1, 0),
        field("episode", "u32", 1, 8),
        field("tick", "u32", 1, 12),
        field("pose", "f32", 3, 16),
        field("ranges", "f32", beams, 28),
        field("labels", "u8", beams, 28 + 4 * beams),
        field("truth", "u8", beams, 28 + 5 * beams),
        field("padding", "u8", record_bytes(beams) - (28 + 6 * beams), 28 + 6 * beams),
    ];
    let codes = |v: &[(&str, &str)]| v.iter().map(|(k, d)| (k.to_string(), d.to_string())).collect::<BTreeMap<_, _>>();
    Meta {
        format: FORMAT.into(),
        version: VERSION,
        magic: String::from_utf8_lossy(&MAGIC[..7]).into_owned() + "\\0",
        header_bytes: HEADER_BYTES,
        record_bytes: record_bytes(beams),
        endianness: "little".into(),
        beams,
        angle_min_rad: -std::f64::consts::PI,
        angle_increment_rad: 2.0 * std::f64::consts::PI / beams as f64,
        scan_hz: SCAN_HZ,
        history_k: HISTORY_K,
        record_layout: layout,
        label_codes: codes(&[("0", "none (no return)"), ("1", "LTF: map"), ("2", "STF: non-map, static"), ("3", "DF: non-map, dynamic")]),
        truth_codes: codes(&[
            ("0", "none (no return)"),
            ("1", "wall: map"),
            ("2", "furniture: non-map"),
            ("3", "clutter: non-map"),
            ("4", "person: non-map"),
            ("5", "target: non-map"),
        ]),
        label_convention: "training target +1 for map (label 1, LTF), -1 for non-map (labels 2 STF and 3 DF); the network's output >= 0 means map. Label 0 (no return) has no class: mask it out of the loss (or treat it as non-map, as the controller ignores such beams anyway).".into(),
        normalisation: NormalisationMeta {
            lidar_min_range_m: sim.lidar_min_range_m,
            lidar_max_range_m: sim.lidar_max_range_m,
            range_noise_std_m: sim.range_noise_std_m,
            non_finite_ranges: "+inf = nothing within the max range, NaN = dropout or below the min range; stored as they are".into(),
            pose_xy_range_m: [0.0, crate::sim::world::WORLD_LIMIT_M],
            yaw: "radians in (-pi, pi]".into(),
            suggested: "ranges: replace +inf and NaN by 0 (or the max range) and divide by the max range; poses: make them relative to the newest pose of the history window (x, y in metres / 10, yaw wrapped)".into(),
        },
        excluded_worlds: EXCLUDED_WORLDS.iter().map(|s| s.to_string()).collect(),
        splits,
        generator: GeneratorMeta {
            command: spec.command.clone(),
            first_world_seed: spec.first_world_seed,
            worlds: spec.worlds,
            episodes_per_world: spec.episodes_per_world,
            episode_min_s: spec.episode_min_s,
            episode_max_s: spec.episode_max_s,
            val_modulus: spec.val_modulus,
            split_rule: format!("world_seed % {} == 0 -> val, else train (all of a world's episodes in one split)", spec.val_modulus),
            trajectories: Trajectory::ROTATION.iter().map(|t| t.name()).collect(),
            robot_radius_m: sim.robot_radius_m,
            labeller: spec.labeller.clone(),
            furniture_density: spec.density,
        },
        agreement: AgreementMeta {
            counts: agreement.counts,
            map_accuracy: finite(agreement.map_accuracy()),
            wall_labelled_ltf: finite(agreement.map_recall()),
            non_map_labelled_stf_or_df: finite(agreement.non_map_recall()),
        },
        episodes,
    }
}

// ---------------------------------------------------------------------------------------------
// Reading.

/// Read `meta.json` from a dataset directory and check its format and version.
pub fn read_meta(dir: &Path) -> Result<Meta, DatasetError> {
    let path = dir.join("meta.json");
    let text = fs::read_to_string(&path).map_err(|e| DatasetError::Meta { path: path.clone(), message: format!("cannot read: {e}") })?;
    // Check format and version before the full schema, so an old or new file says so.
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| DatasetError::Meta { path: path.clone(), message: format!("not JSON: {e}") })?;
    if v.get("format").and_then(|f| f.as_str()) != Some(FORMAT) {
        return Err(DatasetError::Meta { path, message: format!("`format` is not {FORMAT:?}") });
    }
    let version = v.get("version").and_then(|f| f.as_u64()).unwrap_or(0);
    if version != VERSION as u64 {
        return Err(DatasetError::UnsupportedVersion { path, found: version.min(u32::MAX as u64) as u32, supported: VERSION });
    }
    let meta: Meta = serde_json::from_value(v).map_err(|e| DatasetError::Meta { path: path.clone(), message: e.to_string() })?;
    if meta.beams == 0 || meta.record_bytes != record_bytes(meta.beams) || meta.header_bytes != HEADER_BYTES {
        return Err(DatasetError::Meta { path, message: "beams / record_bytes / header_bytes inconsistent".into() });
    }
    Ok(meta)
}

/// Reads one split of a dataset: random access ([`DatasetReader::get`]) and sequential
/// iteration (`Iterator<Item = Result<Record, DatasetError>>`). A file cut inside a record (or
/// holding fewer records than `meta.json` lists) opens fine: the complete records are readable,
/// [`DatasetReader::truncation`] describes the damage and the iterator yields it as its last item.
pub struct DatasetReader {
    path: PathBuf,
    meta: Meta,
    split: Split,
    file: BufReader<File>,
    beams: usize,
    record_bytes: usize,
    records: u64,
    truncation: Option<DatasetError>,
    /// Next record the iterator returns.
    next: u64,
    /// Record the file position is at.
    at: u64,
    reported: bool,
    buf: Vec<u8>,
}

impl DatasetReader {
    /// Open split `split` of the dataset in `dir`.
    pub fn open(dir: impl AsRef<Path>, split: Split) -> Result<DatasetReader, DatasetError> {
        let dir = dir.as_ref();
        let meta = read_meta(dir)?;
        let sm = meta
            .splits
            .get(split.as_str())
            .cloned()
            .ok_or_else(|| DatasetError::Meta { path: dir.join("meta.json"), message: format!("no `{split}` split listed") })?;
        let path = dir.join(&sm.file);
        let f = File::open(&path).map_err(|e| io_err(&path, e))?;
        let len = f.metadata().map_err(|e| io_err(&path, e))?.len();
        let mut file = BufReader::with_capacity(1 << 16, f);
        let mut h = [0u8; HEADER_BYTES];
        let got = read_full(&mut file, &mut h).map_err(|e| io_err(&path, e))?;
        if got < MAGIC.len() || h[..8] != MAGIC {
            return Err(DatasetError::BadMagic { path, found: h[..got.min(8)].to_vec() });
        }
        if got < HEADER_BYTES {
            return Err(DatasetError::BadHeader { path, message: format!("header is {got} bytes, expected {HEADER_BYTES}") });
        }
        let u32_at = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
        let version = u32_at(8);
        if version != VERSION {
            return Err(DatasetError::UnsupportedVersion { path, found: version, supported: VERSION });
        }
        let (beams, rb, code) = (u32_at(12) as usize, u32_at(16) as usize, u32_at(20));
        if beams != meta.beams || rb != record_bytes(beams) || code != split.code() {
            return Err(DatasetError::BadHeader {
                path,
                message: format!(
                    "beams {beams}, record bytes {rb}, split code {code}; meta.json says beams {}, record bytes {}, split code {}",
                    meta.beams,
                    record_bytes(meta.beams),
                    split.code()
                ),
            });
        }
        let body = len - HEADER_BYTES as u64;
        let records = body / rb as u64;
        let trailing = body % rb as u64;
        let truncation = (trailing != 0 || records < sm.records).then(|| DatasetError::Truncated {
            path: path.clone(),
            complete_records: records,
            trailing_bytes: trailing,
            expected_records: sm.records,
        });
        Ok(DatasetReader {
            path,
            meta,
            split,
            file,
            beams,
            record_bytes: rb,
            records,
            truncation,
            next: 0,
            at: 0,
            reported: false,
            buf: vec![0u8; rb],
        })
    }

    /// The dataset's `meta.json`.
    pub fn meta(&self) -> &Meta {
        &self.meta
    }

    pub fn split(&self) -> Split {
        self.split
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Complete records in the file.
    pub fn len(&self) -> u64 {
        self.records
    }

    pub fn is_empty(&self) -> bool {
        self.records == 0
    }

    /// `Some(DatasetError::Truncated { .. })` when the file was cut short.
    pub fn truncation(&self) -> Option<&DatasetError> {
        self.truncation.as_ref()
    }

    /// Record `index` (random access).
    pub fn get(&mut self, index: u64) -> Result<Record, DatasetError> {
        if index >= self.records {
            return Err(DatasetError::OutOfRange { index, len: self.records });
        }
        if self.at != index {
            let off = HEADER_BYTES as u64 + index * self.record_bytes as u64;
            self.file.seek(SeekFrom::Start(off)).map_err(|e| io_err(&self.path, e))?;
            self.at = index;
        }
        let got = read_full(&mut self.file, &mut self.buf).map_err(|e| io_err(&self.path, e))?;
        if got != self.record_bytes {
            // The file shrank under us.
            self.at = u64::MAX;
            return Err(DatasetError::Truncated {
                path: self.path.clone(),
                complete_records: index,
                trailing_bytes: got as u64,
                expected_records: self.records,
            });
        }
        self.at = index + 1;
        Record::decode(&self.buf, self.beams)
            .ok_or_else(|| DatasetError::BadHeader { path: self.path.clone(), message: "record size mismatch".into() })
    }

    /// Restart the iteration at record `index`.
    pub fn rewind_to(&mut self, index: u64) {
        self.next = index;
        self.reported = false;
    }
}

impl Iterator for DatasetReader {
    type Item = Result<Record, DatasetError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.next < self.records {
            let r = self.get(self.next);
            self.next += 1;
            return Some(r);
        }
        if !self.reported {
            self.reported = true;
            if let Some(t) = &self.truncation {
                return Some(Err(t.clone()));
            }
        }
        None
    }
}

/// Read until `buf` is full or the file ends; the number of bytes read.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lives-dataset-test-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    /// Two worlds (seeds 10 → val, 11 → train), two short episodes each.
    fn small_spec(dir: &Path) -> DatasetSpec {
        let mut s = DatasetSpec::new(dir, 10, 2, 2);
        s.episode_min_s = 3.0;
        s.episode_max_s = 5.0;
        s
    }

    #[test]
    fn record_layout() {
        assert_eq!(record_bytes(BEAMS), 5412);
        let r = Record {
            world_seed: u64::MAX - 3,
            episode: 7,
            tick: 9,
            pose: [1.5, -2.25, 3.0],
            ranges: (0..BEAMS)
                .map(|i| {
                    if i % 3 == 0 {
                        f32::INFINITY
                    } else if i % 5 == 0 {
                        f32::NAN
                    } else {
                        i as f32 * 0.01
                    }
                })
                .collect(),
            labels: (0..BEAMS).map(|i| (i % 4) as u8).collect(),
            truth: (0..BEAMS).map(|i| (i % 6) as u8).collect(),
        };
        let mut b = Vec::new();
        r.encode(&mut b);
        assert_eq!(b.len(), record_bytes(BEAMS));
        let back = Record::decode(&b, BEAMS).unwrap();
        let bits = |r: &Record| r.ranges.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&r));
        assert_eq!((back.world_seed, back.episode, back.tick, back.pose), (r.world_seed, r.episode, r.tick, r.pose));
        assert_eq!(back.labels, r.labels);
        assert_eq!(back.truth, r.truth);
    }

    #[test]
    fn round_trip_split_by_world_no_builtins() {
        let dir = tmp_dir("roundtrip");
        let spec = small_spec(&dir);
        let sum = generate(&spec).unwrap();
        assert_eq!(sum.val_worlds, vec![10]);
        assert_eq!(sum.train_worlds, vec![11]);
        assert_eq!(sum.episodes, 4);
        assert!(sum.train_records >= 2 * 15 && sum.train_records <= 2 * 25, "{}", sum.train_records);
        let meta = read_meta(&dir).unwrap();
        assert_eq!(meta.version, VERSION);
        assert_eq!(meta.excluded_worlds, EXCLUDED_WORLDS.map(String::from).to_vec());
        for e in &meta.episodes {
            assert!(e.world_name.starts_with("random-"), "{}", e.world_name);
            assert!(!EXCLUDED_WORLDS.contains(&e.world_name.as_str()));
        }
        let builtins = builtin_walls();
        for split in Split::ALL {
            let mut r = DatasetReader::open(&dir, split).unwrap();
            assert!(r.truncation().is_none());
            let n = r.len();
            assert_eq!(n, if split == Split::Train { sum.train_records } else { sum.val_records });
            let mut count = 0;
            let mut last: Option<(u32, u32)> = None;
            for rec in r.by_ref() {
                let rec = rec.unwrap();
                assert_eq!(Split::of_world(rec.world_seed, 5), split);
                assert_eq!(rec.ranges.len(), BEAMS);
                // Ticks count up within an episode.
                if let Some((e, t)) = last {
                    if e == rec.episode {
                        assert_eq!(rec.tick, t + 1);
                    } else {
                        assert_eq!(rec.tick, 0);
                    }
                }
                last = Some((rec.episode, rec.tick));
                // Labels and truth agree on "no return" and match the ranges.
                for i in 0..BEAMS {
                    assert_eq!(rec.labels[i] == 0, rec.truth[i] == 0);
                    assert_eq!(rec.truth[i] == 0, !rec.ranges[i].is_finite());
                }
                let w = World::random(rec.world_seed);
                assert!(builtins.iter().all(|(_, walls)| *walls != w.walls));
                count += 1;
            }
            assert_eq!(count, n);
            // Random access agrees with the iteration.
            let a = r.get(n - 1).unwrap();
            let b = r.get(0).unwrap();
            assert_eq!(b.tick, 0);
            assert_eq!(a.world_seed, b.world_seed);
            assert!(matches!(r.get(n), Err(DatasetError::OutOfRange { .. })));
        }
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn deterministic_and_thread_independent() {
        let (a, b) = (tmp_dir("det-a"), tmp_dir("det-b"));
        let sa = small_spec(&a);
        let mut sb = small_spec(&b);
        sb.threads = 2;
        generate(&sa).unwrap();
        generate(&sb).unwrap();
        for f in ["meta.json", "train.bin", "val.bin"] {
            let (x, y) = (fs::read(a.join(f)).unwrap(), fs::read(b.join(f)).unwrap());
            assert!(x == y, "{f} differs");
        }
        let _ = fs::remove_dir_all(&a);
        let _ = fs::remove_dir_all(&b);
    }

    #[test]
    fn truncated_and_corrupt_files_give_clear_errors() {
        let dir = tmp_dir("trunc");
        let mut spec = small_spec(&dir);
        spec.worlds = 1;
        spec.first_world_seed = 11; // train only
        spec.episodes_per_world = 1;
        let sum = generate(&spec).unwrap();
        let n = sum.train_records;
        assert!(n >= 3);
        let path = dir.join("train.bin");
        let full = fs::read(&path).unwrap();
        // Cut the last record in half.
        let cut = full.len() - record_bytes(BEAMS) / 2;
        fs::write(&path, &full[..cut]).unwrap();
        let mut r = DatasetReader::open(&dir, Split::Train).unwrap();
        assert_eq!(r.len(), n - 1);
        assert!(matches!(r.truncation(), Some(DatasetError::Truncated { complete_records, trailing_bytes, expected_records, .. })
            if *complete_records == n - 1 && *trailing_bytes == (record_bytes(BEAMS) - record_bytes(BEAMS) / 2) as u64 && *expected_records == n));
        let items: Vec<_> = r.by_ref().collect();
        assert_eq!(items.len() as u64, n);
        assert!(items[..(n - 1) as usize].iter().all(|r| r.is_ok()));
        let last = items.last().unwrap().as_ref().unwrap_err();
        assert!(last.to_string().contains("truncated"), "{last}");
        // A whole record missing is also reported (meta.json lists more).
        fs::write(&path, &full[..full.len() - record_bytes(BEAMS)]).unwrap();
        let r = DatasetReader::open(&dir, Split::Train).unwrap();
        assert!(matches!(r.truncation(), Some(DatasetError::Truncated { trailing_bytes: 0, .. })));
        // Bad magic.
        let mut bad = full.clone();
        bad[0] = b'X';
        fs::write(&path, &bad).unwrap();
        assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::BadMagic { .. })));
        // Shorter than a header.
        fs::write(&path, &full[..12]).unwrap();
        assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::BadHeader { .. })));
        fs::write(&path, &full[..3]).unwrap();
        assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::BadMagic { .. })));
        // Another version in the file header.
        let mut v2 = full.clone();
        v2[8..12].copy_from_slice(&2u32.to_le_bytes());
        fs::write(&path, &v2).unwrap();
        assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::UnsupportedVersion { found: 2, .. })));
        fs::write(&path, &full).unwrap();
        assert_eq!(DatasetReader::open(&dir, Split::Train).unwrap().len(), n);
        // Another version, or garbage, in meta.json.
        let meta_path = dir.join("meta.json");
        let text = fs::read_to_string(&meta_path).unwrap();
        fs::write(&meta_path, text.replacen("\"version\": 1", "\"version\": 9", 1)).unwrap();
        assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::UnsupportedVersion { found: 9, .. })));
        fs::write(&meta_path, "{ not json").unwrap();
        assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::Meta { .. })));
        fs::remove_file(&meta_path).unwrap();
        let e = DatasetReader::open(&dir, Split::Train).err().unwrap();
        assert!(matches!(e, DatasetError::Meta { .. }), "{e}");
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_specs_are_refused() {
        let dir = tmp_dir("bad");
        let mut s = small_spec(&dir);
        s.worlds = 0;
        assert!(matches!(generate(&s), Err(DatasetError::InvalidSpec(_))));
        let mut s = small_spec(&dir);
        s.episode_min_s = 10.0;
        s.episode_max_s = 5.0;
        assert!(matches!(generate(&s), Err(DatasetError::InvalidSpec(_))));
        let mut s = small_spec(&dir);
        s.first_world_seed = u64::MAX;
        assert!(matches!(generate(&s), Err(DatasetError::InvalidSpec(_))));
        for bad in [[0.5, 0.2], [-0.1, 1.0], [0.0, 1.5]] {
            let mut s = small_spec(&dir);
            s.density = bad;
            assert!(matches!(generate(&s), Err(DatasetError::InvalidSpec(_))), "{bad:?}");
        }
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn furniture_density_default_is_world_random_and_range_is_respected() {
        for seed in [1, 5, 12] {
            assert_eq!(dataset_world(seed, [1.0, 1.0]), World::random(seed));
            let d = world_density(seed, [0.2, 0.6]);
            assert!((0.2..=0.6).contains(&d), "{d}");
            assert_eq!(d, world_density(seed, [0.2, 0.6]));
            assert_eq!(world_density(seed, [0.3, 0.3]), 0.3);
            assert!(dataset_world(seed, [0.0, 0.0]).obstacles.is_empty());
        }
        // The default range is not written to meta.json, so default datasets stay byte-identical.
        let dir = tmp_dir("density-meta");
        let meta = build_meta(&small_spec(&dir), &sim_config(), BTreeMap::new(), &Agreement::default(), Vec::new());
        assert!(!serde_json::to_string(&meta).unwrap().contains("furniture_density"));
    }

    #[test]
    fn trajectories_rotate_and_seeds_differ() {
        let kinds: Vec<_> = (0..4u64).map(|w| Trajectory::for_episode(w, 0, 1)).collect();
        assert_eq!(kinds, Trajectory::ROTATION.to_vec());
        assert_ne!(episode_seed(1, 0), episode_seed(1, 1));
        assert_ne!(episode_seed(1, 0), episode_seed(2, 0));
    }
}
