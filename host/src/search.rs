//! One simulated search: the simulator and the controller core in lockstep, in-process — the run
//! loop ([`crate::run::drive`]) with [`SimSource`] as the source and [`InProcess`] as the brain.
//!
//! Virtual time advances one controller period (200 ms, the LiDAR's 5 Hz) per tick: the simulator
//! produces a scan, the pose and a detection; the core ticks; its goal path is handed to the base,
//! which then moves for one period in four 50 ms steps. Nothing reads a wall clock, so the same
//! world, planner and seed give the same run bit for bit. This module owns what a search is (the
//! planners, the spec, the result, [`SearchResult::simulated`] for the bridge's runs too) and the
//! `--trace` lines.

pub use crate::robot_model::{controller_model, default_sim, ideal_sim, Robot, CALIBRATED_CAMERA_RANGE_M, SHORT_CAMERA_RANGE_M};
pub mod picture;

use crate::run::{
    controller_config, count_labels, drive, round3, AfterAct, Answer, End, Ended, Frame, InProcess, LabelScore, Motion, SimSource,
};
use crate::sim::{Scenario, Sim, SimConfig, World};
use firmware::planner::Viewpoint;
use firmware::scan::BeamScan;
use firmware::{Config, Controller, Inputs, PlannerKind};
use serde::Serialize;
use std::fmt;
use std::str::FromStr;

/// The planners a search can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlannerChoice {
    /// LIVES with the classifier's labels (ground-truth labels until the classifier lands).
    Lives,
    /// LIVES with the simulator's ground-truth labels (the paper's "ground truth" column).
    LivesGt,
    /// The structured search without the non-map term (the ablation of `lives`).
    LivesNoNonMap,
    /// The paper's LIVES: the greedy four-term utility with the classifier's labels.
    LivesGreedy,
    /// LIVES without the non-map term (the paper's multisensor frontier baseline).
    Multisensor,
    /// Yamauchi's nearest frontier.
    Nearest,
    /// After ROS explore_lite: `3 · distance − 1 · frontier size`, its defaults.
    ExploreLite,
    /// A sampling-based explorer in the spirit of RRT exploration.
    Rrt,
    /// LIVE (known map, `--map`): LiDAR coverage route plus priority waypoints to inspection
    /// regions.
    Live,
    /// LIVE's "heuristic visual coverage" baseline (known map): a camera coverage route.
    VisualCpp,
    /// LIVE's "LiDAR coverage" baseline (known map): the LiDAR coverage route alone.
    LidarCpp,
}

impl PlannerChoice {
    /// All of them.
    pub const ALL: [PlannerChoice; 8] = [
        PlannerChoice::Lives,
        PlannerChoice::LivesGt,
        PlannerChoice::LivesNoNonMap,
        PlannerChoice::LivesGreedy,
        PlannerChoice::Multisensor,
        PlannerChoice::Nearest,
        PlannerChoice::ExploreLite,
        PlannerChoice::Rrt,
    ];

    /// The planners of a known building (`--map`): LIVE and its two baselines. Not in
    /// [`PlannerChoice::ALL`], the planners of an unknown building.
    pub const KNOWN_MAP: [PlannerChoice; 3] = [PlannerChoice::Live, PlannerChoice::VisualCpp, PlannerChoice::LidarCpp];

    /// The core's planner kind.
    pub fn kind(self) -> PlannerKind {
        match self {
            PlannerChoice::Lives | PlannerChoice::LivesGt => PlannerKind::Lives,
            PlannerChoice::LivesGreedy => PlannerKind::LivesGreedy,
            PlannerChoice::LivesNoNonMap => PlannerKind::LivesNoNonMap,
            PlannerChoice::Multisensor => PlannerKind::Multisensor,
            PlannerChoice::Nearest => PlannerKind::Nearest,
            PlannerChoice::ExploreLite => PlannerKind::ExploreLite,
            PlannerChoice::Rrt => PlannerKind::Rrt,
            PlannerChoice::Live => PlannerKind::Live,
            PlannerChoice::VisualCpp => PlannerKind::VisualCoverage,
            PlannerChoice::LidarCpp => PlannerKind::LidarCoverage,
        }
    }

    /// Runs the int8 classifier when a model is given (`lives`, `lives-greedy`).
    pub fn uses_classifier(self) -> bool {
        matches!(self, PlannerChoice::Lives | PlannerChoice::LivesGreedy)
    }

    /// Has non-map labels: the classifier's, or the simulator's without a model.
    pub fn uses_labels(self) -> bool {
        matches!(self, PlannerChoice::Lives | PlannerChoice::LivesGreedy | PlannerChoice::LivesGt)
    }

    /// Where this planner's labels come from, given whether a classifier model is installed.
    pub fn label_source(self, model: bool) -> &'static str {
        match self {
            PlannerChoice::Lives | PlannerChoice::LivesGreedy if model => "int8-classifier",
            // Without a model `lives` runs on simulator labels, like `lives-gt`.
            PlannerChoice::Lives | PlannerChoice::LivesGreedy | PlannerChoice::LivesGt => "ground-truth",
            PlannerChoice::Multisensor
            | PlannerChoice::Nearest
            | PlannerChoice::ExploreLite
            | PlannerChoice::Rrt
            | PlannerChoice::LivesNoNonMap
            | PlannerChoice::Live
            | PlannerChoice::VisualCpp
            | PlannerChoice::LidarCpp => "none",
        }
    }
}

impl fmt::Display for PlannerChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PlannerChoice::Lives => "lives",
            PlannerChoice::LivesGt => "lives-gt",
            PlannerChoice::Multisensor => "multisensor",
            PlannerChoice::Nearest => "nearest",
            PlannerChoice::ExploreLite => "explore-lite",
            PlannerChoice::Rrt => "rrt",
            PlannerChoice::LivesGreedy => "lives-greedy",
            PlannerChoice::LivesNoNonMap => "lives-no-nonmap",
            PlannerChoice::Live => "live",
            PlannerChoice::VisualCpp => "visual-cpp",
            PlannerChoice::LidarCpp => "lidar-cpp",
        })
    }
}

impl FromStr for PlannerChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let all = || PlannerChoice::ALL.into_iter().chain(PlannerChoice::KNOWN_MAP);
        all()
            .find(|p| p.to_string() == s)
            .ok_or_else(|| format!("unknown planner `{s}` (expected {})", all().map(|p| p.to_string()).collect::<Vec<_>>().join(", ")))
    }
}

/// What a search needs.
#[derive(Clone, Debug)]
pub struct SearchSpec {
    /// World name for reports (`apartment`, a file name, `random-7`).
    pub world_name: String,
    /// The world.
    pub world: World,
    /// Scenario for reports: `None` for a world file, which holds one scenario of its own.
    pub scenario: Option<Scenario>,
    /// Planner.
    pub planner: PlannerChoice,
    /// Seed of the simulator (start jitter, target placement, people, noise).
    pub seed: u64,
    /// Simulator settings.
    pub sim: SimConfig,
    /// Controller settings: the planner's own defaults ([`Config::with_planner`]), then `--set`
    /// and the robot's model (the grid origin is set by [`run`]).
    pub controller: Config,
    /// Print every new goal with its utility terms to stderr.
    pub trace: bool,
    /// With [`SearchSpec::trace`], also print this many of the best candidate viewpoints of each
    /// planning step that chose a new goal ([`candidate_lines`]); 0 prints none.
    pub trace_candidates: usize,
    /// The int8 classifier blob for `lives` (validated when the search starts). Without one,
    /// `lives` runs on the simulator's ground-truth labels.
    pub model: Option<&'static [u8]>,
    /// LIVE's known-map mode: the building's map on the controller's grid (row by row from the
    /// lowest y, `GRID_CELLS` square; `lives search --map`), which then labels the scans
    /// ([`firmware::knownmap`]), seeds the LiDAR grid and, for `live`, `visual-cpp` and
    /// `lidar-cpp`, gives the coverage route ([`crate::live`]).
    pub prior_map: Option<std::sync::Arc<Vec<crate::io::map_file::Cell3>>>,
}

impl SearchSpec {
    /// Defaults for `world` / `scenario` / `planner` / `seed`.
    pub fn new(world_name: &str, world: World, scenario: Scenario, planner: PlannerChoice, seed: u64) -> Self {
        let sim = default_sim();
        SearchSpec {
            world_name: world_name.to_string(),
            world,
            scenario: Some(scenario),
            planner,
            seed,
            // The planner's own defaults first: `--set` (applied to this later) overrides them.
            controller: controller_model(&Config::DEFAULT.with_planner(planner.kind()), &sim),
            sim,
            trace: false,
            trace_candidates: 0,
            model: None,
            prior_map: None,
        }
    }

    /// Loads [`SearchSpec::prior_map`] into `ctrl`, whose grid it was drawn on, and, for a
    /// planner that follows a route, plans the route from the robot's `start` (world x, y) and
    /// gives it. Returns what LIVE's central server did (`None` without a map).
    pub fn load_prior(&self, ctrl: &mut Controller, start: [f64; 2]) -> Option<crate::live::LiveSummary> {
        let cells = self.prior_map.as_ref()?;
        crate::live::load(ctrl, cells);
        Some(crate::live::plan_and_give(ctrl, cells, start))
    }

    /// `easy` or `hard`; `file` for a world file (its own scenario).
    pub fn scenario_label(&self) -> &'static str {
        self.scenario.map_or("file", Scenario::as_str)
    }

    /// The controller labels the scans itself: the planner runs a classifier and a model is given.
    pub fn classifier(&self) -> bool {
        self.planner.uses_classifier() && self.model.is_some()
    }

    /// The simulator gives the brain its ground-truth labels (`lives-gt`, and `lives` without a
    /// model).
    pub fn sim_labels(&self) -> bool {
        !self.classifier() && self.planner.uses_labels()
    }

    /// This search's simulator as the run loop's source: lockstep, in the odometry frame, until
    /// the world's time limit, with the labels of [`SearchSpec::sim_labels`].
    pub fn sim_source(&self) -> SimSource {
        SimSource::new(Sim::new(self.world.clone(), self.sim.clone(), self.seed), self.sim_labels(), self.world.time_limit_s)
    }
}

impl Robot {
    /// Makes `spec`'s simulated robot this one: the simulator's camera and the controller's model
    /// of it (apply before `--sim` and `--set`, which may then change either).
    pub fn apply(self, spec: &mut SearchSpec) -> Result<(), String> {
        crate::overrides::apply_sim(&mut spec.sim, &mut spec.controller, &format!("camera_range_m={}", self.camera_range_m()))
    }
}

/// The simulated robot's settings, in a result only when they differ from the default robot's
/// (`--robot calibrated`; so that a result says what robot it was measured on).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimSettings {
    /// The LiDAR profile.
    pub lidar: String,
    /// The laser's pose on the base: x, y (metres), yaw (degrees).
    pub mount: [f64; 3],
    /// Odometry's scale error per metre driven.
    pub odom_slip_per_m: f64,
    /// Odometry's heading error per radian turned.
    pub odom_heading_drift_per_rad: f64,
    /// The base's top speed.
    pub speed_mps: f64,
    /// The base's top turn rate.
    pub turn_rate_rps: f64,
    /// LiDAR range noise (standard deviation).
    pub range_noise_std_m: f64,
    /// Probability that a beam returns nothing.
    pub dropout_prob: f64,
    /// LiDAR range.
    pub lidar_max_range_m: f64,
    /// How far the detector sees.
    pub camera_range_m: f64,
    /// The camera's field of view.
    pub camera_fov_deg: f64,
    /// Share of a target's outline that must be in view for a detection.
    pub detect_min_visible_fraction: f64,
    /// The body's radius for collisions.
    pub robot_radius_m: f64,
}

impl SimSettings {
    /// `Some` when `sim` differs from the default robot's ([`Robot::Calibrated`], what `lives
    /// search` and `lives eval` run unless told otherwise).
    pub fn changed(sim: &SimConfig) -> Option<Self> {
        (*sim != Robot::Calibrated.sim()).then(|| SimSettings {
            lidar: sim.lidar.as_str().to_string(),
            mount: [sim.mount[0], sim.mount[1], round3(sim.mount[2].to_degrees())],
            odom_slip_per_m: sim.odom_slip_per_m,
            odom_heading_drift_per_rad: sim.odom_heading_drift_per_rad,
            speed_mps: sim.speed_mps,
            turn_rate_rps: sim.turn_rate_rps,
            range_noise_std_m: sim.range_noise_std_m,
            dropout_prob: sim.dropout_prob,
            lidar_max_range_m: sim.lidar_max_range_m,
            camera_range_m: sim.camera_range_m,
            camera_fov_deg: round3(sim.camera_fov_rad.to_degrees()),
            detect_min_visible_fraction: sim.detect_min_visible_fraction,
            robot_radius_m: sim.robot_radius_m,
        })
    }
}

/// The machine-readable result (`--json`). The default is empty: what a run off the simulator
/// (the real robot) leaves out.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SearchResult {
    /// World name.
    pub world: String,
    /// Scenario.
    pub scenario: String,
    /// Planner.
    pub planner: String,
    /// Seed.
    pub seed: u64,
    /// Whether the target was detected within the time limit.
    pub found: bool,
    /// Virtual time to detection, or the time limit on failure (as the paper counts failures).
    pub time_s: f64,
    /// Distance the base drove.
    pub path_m: f64,
    /// Controller ticks run.
    pub ticks: u32,
    /// The world's time limit.
    pub time_limit_s: f64,
    /// How the run ended: `found`, `time-limit`, `exhausted`.
    pub outcome: String,
    /// Goals the controller issued.
    pub goals: u32,
    /// Goals blacklisted (blocked or no progress).
    pub blacklisted: u32,
    /// Times the base reported it was blocked.
    pub blocked: u32,
    /// Ticks at whose end the robot overlapped an obstacle, wall or person (must stay 0).
    pub collisions: u32,
    /// Where the planner's labels came from.
    pub labels: String,
    /// Where the target(s) were placed (this seed's draw).
    pub targets: Vec<[f64; 2]>,
    /// Where the time went (simulated runs; absent on the real robot).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<Motion>,
    /// When the LiDAR first had a target in view ([`LIDAR_SIGHTING_BEAMS`] beams on it in one
    /// scan), `None` if never (or on the real robot): with `time_s` it shows how long the camera
    /// took to look where the LiDAR had already seen something.
    pub lidar_saw_target_s: Option<f64>,
    /// When a target was first within the camera's reach: [`LIDAR_SIGHTING_BEAMS`] beams of one
    /// scan on it, none farther than the camera's range. The camera would have seen it had it
    /// faced that way, so a gap to `time_s` is time lost to where the camera looked (not to the
    /// route). `None` if never (or on the real robot).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_in_camera_reach_s: Option<f64>,
    /// How the classifier's labels compared with the simulator's per-beam truth over the run
    /// (`lives` on a classifier only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub classifier: Option<LabelScore>,
    /// The simulated robot, when `--sim` changed it (absent on the defaults and the real robot).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sim: Option<SimSettings>,
    /// The trial's oracle ([`crate::sim::oracle`]): the least time in which the target could have
    /// been detected, driving the shortest path to the nearest pose from which the camera sees it
    /// and turning to face it. Filled in by `lives eval` (absent elsewhere).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oracle_s: Option<f64>,
    /// LIVE's known-map search: the route, the waypoint manager and the search map's entropy
    /// (`--map` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub live: Option<crate::live::LiveSummary>,
}

/// Everything a picture or a test may want after a run.
pub struct SearchRun {
    /// The result.
    pub result: SearchResult,
    /// The controller at the end (maps, points, frontiers, candidates).
    pub controller: Box<Controller>,
    /// The simulator at the end.
    pub sim: Sim,
    /// Robot positions, one per tick.
    pub trajectory: Vec<[f64; 2]>,
    /// Start pose.
    pub start: [f64; 3],
    /// Robot position when the target was detected.
    pub found_at: Option<[f64; 2]>,
    /// Every goal issued, in order (cell and heading index) — the run's decisions.
    pub goals: Vec<((i32, i32), firmware::BinaryAngle)>,
}

/// The `n` best candidate viewpoints of the controller's last planning step, best first (ties in
/// the planner's own order), one line each: rank, where the robot would stand (world metres) and
/// look, the site kind, the utility and its terms. The goal the step chose is marked `*` (the
/// best candidate, unless the current goal was kept by hysteresis). This is what `lives search
/// --trace-candidates N` prints under each new goal: it answers "why did it go there and not
/// here".
pub fn candidate_lines(ctrl: &Controller, n: usize) -> Vec<String> {
    let mut cands: Vec<&Viewpoint> = ctrl.planner.candidates.iter().collect();
    // A stable sort: equal utilities keep the planner's order, whose first wins the argmax.
    cands.sort_by_key(|v| std::cmp::Reverse(v.utility));
    // The goal is the first candidate with its cell and heading (two sites can offer the same
    // spot and heading: a frontier's viewpoint and a non-map cluster's).
    let chosen = ctrl.goal().and_then(|g| cands.iter().position(|v| (v.cell, v.heading) == (g.viewpoint.cell, g.viewpoint.heading)));
    cands
        .iter()
        .take(n)
        .enumerate()
        .map(|(i, v)| {
            let (x, y) = ctrl.lidar.geom.center_of(v.cell.0, v.cell.1);
            format!(
                "    {}{:>2} ({:5.1},{:5.1}) {:>4.0}° {:<14} {}",
                if chosen == Some(i) { '*' } else { ' ' },
                i + 1,
                x.to_num::<f64>(),
                y.to_num::<f64>(),
                v.heading.to_radians().to_degrees(),
                format!("{:?}", v.source),
                utility_terms(v),
            )
        })
        .collect()
}

/// A viewpoint's utility and its terms as `--trace` prints them, for a goal and a candidate alike.
fn utility_terms(v: &Viewpoint) -> String {
    format!(
        "U={:7.2} path={:5.1}m unseen={:4} surface={:2} frontier={:4} nonmap={:3}",
        v.utility as f64 / 65536.0,
        v.path_length_m().to_num::<f64>(),
        v.unseen,
        v.surface,
        v.frontier_near_path,
        v.nonmap
    )
}

/// What an observer of [`try_run_observed`] sees right after each controller tick (for
/// recordings, `host::io::record`). It reads; it cannot change the run.
pub struct TickView<'a> {
    /// The tick's time, microseconds.
    pub t_us: u64,
    /// What the controller was given.
    pub inputs: &'a Inputs<'a>,
    /// What it answered.
    pub outputs: &'a firmware::Outputs,
    /// The controller after the tick (maps, points, frontiers, candidates, goal).
    pub controller: &'a Controller,
}

/// Runs one search to detection, exhaustion or the time limit. `progress` gets the virtual time.
/// Fails only if the spec's model blob does not validate.
pub fn try_run(spec: &SearchSpec, progress: impl FnMut(f64)) -> Result<SearchRun, firmware::classifier::ModelError> {
    try_run_observed(spec, progress, |_| {})
}

/// [`try_run`], showing every tick to `observe` (which cannot change the run).
pub fn try_run_observed(
    spec: &SearchSpec,
    progress: impl FnMut(f64),
    observe: impl FnMut(&TickView<'_>),
) -> Result<SearchRun, firmware::classifier::ModelError> {
    let cfg = controller_config(&spec.controller, &spec.world, spec.planner.kind());
    let mut ctrl = Box::new(Controller::new(cfg));
    if let (true, Some(blob)) = (spec.classifier(), spec.model) {
        ctrl.set_model(blob)?;
    }
    Ok(run_with(spec, ctrl, progress, observe))
}

/// [`try_run`] for specs without a model (ground-truth or no labels): cannot fail.
pub fn run(spec: &SearchSpec, progress: impl FnMut(f64)) -> SearchRun {
    let spec = SearchSpec { model: None, ..spec.clone() };
    let cfg = controller_config(&spec.controller, &spec.world, spec.planner.kind());
    run_with(&spec, Box::new(Controller::new(cfg)), progress, |_| {})
}

fn run_with(
    spec: &SearchSpec,
    mut ctrl: Box<Controller>,
    mut progress: impl FnMut(f64),
    mut observe: impl FnMut(&TickView<'_>),
) -> SearchRun {
    // The labels the core used are scored against the truth: the classifier's or the map's.
    let classifier = spec.classifier() || spec.prior_map.is_some();
    let mut source = spec.sim_source();
    let start = source.sim.pose();
    let mut live = spec.load_prior(&mut ctrl, [start[0], start[1]]);
    let mut brain = InProcess::new(ctrl);
    let mut goals = Vec::new();
    let mut confusion = [[0u64; 2]; 2];
    let mut watch = |src: &SimSource, frame: &Frame, brain: &InProcess, answer: &Answer| {
        let (ctrl, Some(out)) = (&brain.ctrl, brain.outputs()) else { return };
        if classifier {
            // The truth on the core's beam grid, to score the labels the core used.
            let mut truth = BeamScan::new();
            if truth.resample(&frame.scan.input(true)).is_ok() {
                count_labels(&mut confusion, &truth, ctrl.beams());
            }
        }
        observe(&TickView { t_us: frame.t_us, inputs: &frame.inputs(answer.command), outputs: out, controller: ctrl });
        if let Some(l) = live.as_mut() {
            // The search map's entropy, every few seconds (the first sample once it is counted).
            let t = frame.t_us as f64 / 1e6;
            if l.entropy.last().is_none_or(|p| t >= p[0] + crate::live::ENTROPY_EVERY_S) && ctrl.search.cells() > 0 {
                if l.entropy.is_empty() {
                    l.entropy_start_bits = ctrl.search.entropy_bits();
                }
                l.entropy.push([round3(t), ctrl.search.entropy_bits() as f64]);
            }
        }
        if answer.end.is_some() || out.stop {
            return;
        }
        if let (true, Some(g)) = (out.new_goal, &out.goal) {
            // As the bridge records a goal from the wire: its pose's cell (the configured grid)
            // and heading, in the frame the base follows (`Outputs::goal`).
            let initial = firmware::grid::GridGeometry { origin_x: ctrl.config().origin_x_m, origin_y: ctrl.config().origin_y_m };
            goals.push((initial.cell_of(g.pose.x, g.pose.y), g.pose.theta));
            if spec.trace {
                trace_goal(spec, src.sim.time_s(), src.pose, goals.len(), ctrl, g);
            }
        }
    };
    let mut progress = AfterAct(|src: &SimSource| progress(src.sim.time_s()));
    let Ok(ended) = drive(&mut source, &mut brain, &mut [&mut watch, &mut progress]);
    let status = brain.outputs().map(|o| o.status).unwrap_or_default();
    let found_at = (ended.end == End::Found).then_some([source.pose[0], source.pose[1]]);
    let score = classifier.then(|| LabelScore::from_confusion(confusion));
    let mut result = SearchResult::simulated(spec, &source, ended, status.goals, status.blacklisted, classifier, score);
    if let Some(mut l) = live {
        crate::live::finish(&mut l, &brain.ctrl);
        result.live = Some(l);
    }
    let SimSource { sim, trajectory, start, .. } = source;
    SearchRun { result, controller: brain.ctrl, sim, trajectory, start, found_at, goals }
}

/// Prints a new goal with its utility terms (`--trace`), and the step's best candidates.
fn trace_goal(spec: &SearchSpec, t_s: f64, p: [f64; 3], n: usize, ctrl: &Controller, g: &firmware::Goal) {
    let v = &g.viewpoint;
    eprintln!(
        "t={:6.1}s robot ({:5.1},{:5.1}) goal #{:<3} ({:5.1},{:5.1}) {:>4.0}° {:?} {} cands={} {:?}{}",
        t_s,
        p[0],
        p[1],
        n,
        g.pose.x.to_num::<f64>(),
        g.pose.y.to_num::<f64>(),
        g.pose.theta.to_radians().to_degrees(),
        v.source,
        utility_terms(v),
        ctrl.planner.stats.candidates,
        ctrl.planner.stats,
        if spec.planner.kind().is_structured() { format!(" {:?}", ctrl.planner.sched) } else { String::new() }
    );
    for line in candidate_lines(ctrl, spec.trace_candidates) {
        eprintln!("{line}");
    }
}

impl SearchResult {
    /// The result of a simulated search (in process or through the node) that ended as `ended`;
    /// `goals` and `blacklisted` are the controller's counts, `classifier` whether it labelled
    /// the scans, `score` how its labels compared with the truth.
    pub fn simulated(
        spec: &SearchSpec,
        src: &SimSource,
        ended: Ended,
        goals: u32,
        blacklisted: u32,
        classifier: bool,
        score: Option<LabelScore>,
    ) -> Self {
        let outcome = match ended.end {
            End::Found => "found",
            End::Exhausted => "exhausted",
            End::Stopped => "stopped",
            End::Source => "time-limit",
        };
        let found = ended.end == End::Found;
        let limit = spec.world.time_limit_s;
        SearchResult {
            world: spec.world_name.clone(),
            scenario: spec.scenario_label().to_string(),
            planner: spec.planner.to_string(),
            seed: spec.seed,
            found,
            time_s: if found { round3(src.sim.time_s()) } else { limit },
            path_m: round3(src.sim.path_length_m()),
            ticks: ended.ticks,
            time_limit_s: limit,
            outcome: outcome.to_string(),
            goals,
            blacklisted,
            blocked: src.blocked,
            collisions: src.collisions,
            labels: if spec.prior_map.is_some() { "known-map" } else { spec.planner.label_source(classifier) }.to_string(),
            targets: src.sim.target_positions().iter().map(|p| [round3(p[0]), round3(p[1])]).collect(),
            motion: Some(src.tally.motion()),
            lidar_saw_target_s: src.tally.lidar_saw_target_s(),
            target_in_camera_reach_s: src.tally.target_in_camera_reach_s(),
            classifier: score,
            sim: SimSettings::changed(&spec.sim),
            oracle_s: None,
            live: None,
        }
    }
}

/// Runs a search, recording every tick into `rec` if there is one
/// ([`try_run_observed`] with [`Recorder::record_controller_tick`]). The run is the
/// same as without recording; a recording error stops the recording (not the run) and comes back
/// beside the run.
pub fn record_search(
    spec: &SearchSpec,
    mut rec: Option<&mut crate::io::record::Recorder>,
    progress: impl FnMut(f64),
) -> Result<(SearchRun, Result<(), crate::io::record::RecordError>), firmware::classifier::ModelError> {
    let mut recorded: Result<(), crate::io::record::RecordError> = Ok(());
    let run = try_run_observed(spec, progress, |t| {
        if let (Some(rec), true) = (rec.as_deref_mut(), recorded.is_ok()) {
            recorded = rec.record_controller_tick(t.t_us, t.inputs, t.outputs, t.controller);
        }
    })?;
    Ok((run, recorded))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `explore-lite` brings its own `min_frontier_cells` (5), goal timeout (30 s) and switch
    /// margin (0); a `--set` of any of them is what the controller runs, not the planner's
    /// default (before: silently replaced when the search started).
    #[test]
    fn a_set_parameter_overrides_the_planners_own_default() {
        let w = World::builtin("apartment", Scenario::Easy).unwrap();
        let mut spec = SearchSpec::new("apartment", w.clone(), Scenario::Easy, PlannerChoice::ExploreLite, 1);
        let plain = crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind());
        assert_eq!((plain.min_frontier_cells, plain.goal_timeout_us), (5, 30_000_000), "the planner's defaults");
        for a in ["min_frontier_cells=8", "goal_timeout_s=5", "switch_margin=6"] {
            crate::overrides::apply(&mut spec.controller, a).unwrap();
        }
        let cfg = crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind());
        assert_eq!((cfg.min_frontier_cells, cfg.goal_timeout_us, cfg.switch_margin), (8, 5_000_000, firmware::config::Weight::from_num(6)));
        // A route follower's gaze likewise.
        let mut spec = SearchSpec::new("apartment", w, Scenario::Easy, PlannerChoice::Live, 1);
        assert!(!crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind()).gaze);
        crate::overrides::apply(&mut spec.controller, "gaze=true").unwrap();
        assert!(crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind()).gaze);
    }

    #[test]
    fn a_named_robot_sets_the_simulated_camera_and_the_controllers_model_of_it() {
        assert_eq!("calibrated".parse::<Robot>(), Ok(Robot::Calibrated));
        assert_eq!("short".parse::<Robot>(), Ok(Robot::Short));
        assert!("long".parse::<Robot>().unwrap_err().contains("calibrated or short"));
        for r in Robot::ALL {
            assert_eq!(r.to_string().parse::<Robot>(), Ok(r));
        }
        assert_eq!(Robot::Short.camera_range_m(), 4.0);
        assert_ne!(Robot::Calibrated.camera_range_m(), Robot::Short.camera_range_m());
        let w = World::builtin("apartment", Scenario::Easy).unwrap();
        for r in Robot::ALL {
            let mut spec = SearchSpec::new("apartment", w.clone(), Scenario::Easy, PlannerChoice::Multisensor, 1);
            r.apply(&mut spec).unwrap();
            assert_eq!(spec.sim.camera_range_m, r.camera_range_m(), "{r}");
            assert_eq!(spec.controller.camera_range_m.to_num::<f64>(), r.camera_range_m(), "{r}: the controller follows");
            // Nothing else changes: the rest is the default robot.
            assert_eq!(SimConfig { camera_range_m: default_sim().camera_range_m, ..spec.sim.clone() }, default_sim());
        }
        // The short robot is the simulator's default (the 4 m of before), the calibrated one is not.
        let mut spec = SearchSpec::new("apartment", w, Scenario::Easy, PlannerChoice::Multisensor, 1);
        Robot::Short.apply(&mut spec).unwrap();
        assert_eq!(spec.sim, default_sim());
        assert_eq!(spec.controller, controller_model(&Config::DEFAULT.with_planner(firmware::PlannerKind::Multisensor), &default_sim()));
    }

    /// The utility a candidate line prints, parsed back.
    fn printed_utility(line: &str) -> f64 {
        let u = line.split("U=").nth(1).unwrap_or_else(|| panic!("no utility in {line:?}"));
        u.split_whitespace().next().unwrap().parse().unwrap()
    }

    #[test]
    fn candidate_lines_rank_the_step_best_first_and_mark_the_chosen_goal() {
        let w = World::builtin("apartment", Scenario::Hard).unwrap();
        let spec = SearchSpec::new("apartment", w, Scenario::Hard, PlannerChoice::LivesGt, 3);
        let (mut steps, mut marked) = (0, 0);
        let mut observe = |v: &TickView<'_>| {
            if !v.outputs.new_goal || steps >= 4 {
                return;
            }
            steps += 1;
            let ctrl = v.controller;
            let n = ctrl.planner.candidates.len();
            assert!(n > 5, "a planning step of the apartment has many candidates, got {n}");
            let lines = candidate_lines(ctrl, 5);
            assert_eq!(lines.len(), 5);
            assert_eq!(candidate_lines(ctrl, n + 10).len(), n, "never more lines than candidates");
            assert!(candidate_lines(ctrl, 0).is_empty());
            let us: Vec<f64> = lines.iter().map(|l| printed_utility(l)).collect();
            assert!(us.windows(2).all(|p| p[0] >= p[1]), "best first: {us:?}");
            let best = ctrl.planner.candidates.iter().map(|c| c.utility).max().unwrap() as f64 / 65536.0;
            assert!((us[0] - best).abs() < 0.006, "the first line is the step's best: {} vs {best}", us[0]);
            // A new goal is the step's argmax (hysteresis keeps the old one, never picks another).
            let g = ctrl.goal().unwrap();
            if g.viewpoint.source != firmware::planner::Site::Current {
                assert!(lines[0].trim_start().starts_with("* 1 "), "the chosen goal is marked: {}", lines[0]);
                marked += 1;
            }
            assert!(lines.iter().filter(|l| l.trim_start().starts_with('*')).count() <= 1);
        };
        try_run_observed(&spec, |_| {}, &mut observe).unwrap();
        assert_eq!(steps, 4, "the search chose at least four goals");
        assert!(marked > 0);
    }
}

#[cfg(test)]
mod ideal_sensor_digest {
    use super::*;

    /// FNV-1a over bytes.
    fn fnv(h: &mut u64, bytes: &[u8]) {
        for &b in bytes {
            *h ^= b as u64;
            *h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }

    /// The digest of what the controller was given (pose, ranges, labels) over the first `n`
    /// ticks of `apartment easy`, seed 1, lives-gt, on `sim`.
    pub(super) fn digest(sim: SimConfig, n: u64) -> u64 {
        let w = World::builtin("apartment", Scenario::Easy).unwrap();
        let mut spec = SearchSpec::new("apartment", w, Scenario::Easy, PlannerChoice::LivesGt, 1);
        spec.sim = sim;
        spec.world.time_limit_s = n as f64 * crate::run::TICK_US as f64 / 1e6;
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut observe = |v: &TickView<'_>| {
            let p = v.inputs.pose.unwrap_or_default();
            fnv(&mut h, &p.x.to_bits().to_le_bytes());
            fnv(&mut h, &p.y.to_bits().to_le_bytes());
            fnv(&mut h, &p.theta.0.to_le_bytes());
            if let Some(s) = &v.inputs.scan {
                for r in s.ranges_mm {
                    fnv(&mut h, &r.to_le_bytes());
                }
                for l in s.labels.unwrap_or(&[]) {
                    fnv(&mut h, &[*l as u8]);
                }
            }
        };
        try_run_observed(&spec, |_| {}, &mut observe).unwrap();
        h
    }

    /// The default robot gives the controller other scans and poses than the clean sensor it
    /// replaced. (That the ideal profile still gives exactly the old scans is pinned where no
    /// controller decision enters: `lives_sim`'s `IDEAL_APARTMENT_DIGEST` over 40 raw scans. A
    /// digest over a whole search here also depends on where the controller sends the robot,
    /// which issue 27 changed with the evidence grid and the scan matcher.)
    #[test]
    fn the_default_robot_is_another_sensor_than_the_ideal_one() {
        assert_ne!(digest(default_sim(), 150), digest(ideal_sim(), 150));
        assert_eq!(digest(ideal_sim(), 150), digest(ideal_sim(), 150), "deterministic");
    }
}

#[cfg(test)]
mod record_tests;
