//! Episodes: the worlds, the planner-driven and random-walk trajectories through them, and the
//! writing of each world's records in seed order ([`generate`]).

use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io::{BufWriter, Write};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::learn::labeller::{hit_code, Agreement, Labeller, LabellerConfig};
use crate::run::{controller_config, drive, Act, Answer, Brain, End, Frame, Idle, InProcess, SimSource, Walker};
use crate::sim::generate::{random_world_with_density, GENERATOR_ROBOT_RADIUS_M};
use crate::sim::geometry::dist;
use crate::sim::reach::ReachMap;
use crate::sim::{Scan, Scenario, Sim, SimConfig, World, P2};
use firmware::{Config, Controller};
use std::convert::Infallible;

/// SplitMix64: derives independent seeds from (world seed, episode).
pub(super) fn mix(mut z: u64) -> u64 {
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
pub(super) struct WorldContext {
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

/// The result of driving one episode.
pub(super) struct EpisodeRun {
    start: [f64; 3],
    path_m: f64,
    controller_outcome: &'static str,
}

/// The brain of an episode: a planner's controller until it hands over (target found, search
/// exhausted), then the source's random walker; the walker alone for a random walk.
struct HandOver {
    ctrl: Option<InProcess>,
    outcome: &'static str,
}

impl Brain for HandOver {
    type Error = Infallible;

    fn think(&mut self, frame: &Frame) -> Result<Answer, Infallible> {
        let Some(c) = &mut self.ctrl else { return Idle.think(frame) };
        let Ok(mut answer) = c.think(frame);
        // The dataset's base looks ahead: no gaze.
        answer.acts.retain(|a| !matches!(a, Act::Gaze(_)));
        if let Some(end) = answer.end.take() {
            self.outcome = if end == End::Found { "found" } else { "exhausted" };
            self.ctrl = None;
            answer.acts = vec![Act::Stop, Act::Wander];
        }
        Ok(answer)
    }
}

/// Drive one episode of `ticks` ticks through `world` and call `on_tick(tick, pose, scan)` at
/// every tick, before the robot moves. `free` holds reachable cells for the random walk.
pub(super) fn drive_episode(
    world: &World,
    free: &[P2],
    trajectory: Trajectory,
    sim_seed: u64,
    ticks: u32,
    mut on_tick: impl FnMut(u32, [f64; 3], &Scan),
) -> EpisodeRun {
    let sim = Sim::new(world.clone(), sim_config(), sim_seed);
    let walker = Walker::new(mix(sim_seed ^ 0x5741_4C4B), true);
    let (ctrl, labels) = match trajectory {
        Trajectory::Planner(p) => {
            (Some(InProcess::new(Box::new(Controller::new(controller_config(&Config::DEFAULT, world, p.kind()))))), p.uses_labels())
        }
        Trajectory::RandomWalk => (None, false),
    };
    let mut source = SimSource::episode(sim, ticks, labels, ctrl.is_some(), walker, free.to_vec());
    let mut brain = HandOver { outcome: if ctrl.is_some() { "running" } else { "walk" }, ctrl };
    let mut tick = 0;
    let mut watch = |src: &SimSource, _: &Frame, _: &HandOver, _: &Answer| {
        if let Some(scan) = &src.scan {
            on_tick(tick, src.pose, scan);
        }
        tick += 1;
    };
    let Ok(_) = drive(&mut source, &mut brain, &mut [&mut watch]);
    EpisodeRun { start: source.start, path_m: (source.sim.path_length_m() * 1000.0).round() / 1000.0, controller_outcome: brain.outcome }
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
pub(super) struct WorldOutput {
    world_seed: u64,
    split: Split,
    bytes: Vec<u8>,
    records: u64,
    episodes: Vec<EpisodeMeta>,
    agreement: Agreement,
}

pub(super) fn builtin_walls() -> Vec<(String, Vec<[P2; 2]>)> {
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

pub(super) fn world_output(spec: &DatasetSpec, world_seed: u64, builtins: &[(String, Vec<[P2; 2]>)]) -> Result<WorldOutput, DatasetError> {
    // The only source of worlds: `World::random(seed)`, or the same generator thinned.
    let world = dataset_world(world_seed, spec.density);
    if let Some((name, _)) = builtins.iter().find(|(_, walls)| *walls == world.walls) {
        return Err(DatasetError::BuiltinWorld { world_seed, builtin: name.clone() });
    }
    if EXCLUDED_WORLDS.contains(&world.name.as_str()) {
        return Err(DatasetError::BuiltinWorld { world_seed, builtin: world.name.clone() });
    }
    let split = Split::of_world(world_seed, spec.plan.val_modulus);
    let ctx = WorldContext::new(world);
    let mut lab = Labeller::for_world(&ctx.world, spec.labeller.clone());
    let mut out = WorldOutput { world_seed, split, bytes: Vec::new(), records: 0, episodes: Vec::new(), agreement: Agreement::default() };
    let (lo_t, hi_t) = ((spec.plan.episode_min_s * SCAN_HZ).round() as u32, (spec.plan.episode_max_s * SCAN_HZ).round() as u32);
    for episode in 0..spec.plan.episodes_per_world {
        let seed = episode_seed(world_seed, episode);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let ticks = rng.gen_range(lo_t.max(1)..=hi_t.max(lo_t.max(1)));
        let world = ctx.with_random_start(&mut rng);
        let trajectory = Trajectory::for_episode(world_seed, episode, spec.plan.episodes_per_world);
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

pub(super) fn finite(v: f64) -> Option<f64> {
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
    let seeds: Vec<u64> = (0..spec.plan.worlds as u64).map(|i| spec.plan.first_world_seed + i).collect();
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
        progress(Progress { worlds_done: done, worlds: spec.plan.worlds, records: total_records });
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

pub(super) fn build_meta(
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
            plan: spec.plan.clone(),
            split_rule: format!("world_seed % {} == 0 -> val, else train (all of a world's episodes in one split)", spec.plan.val_modulus),
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
