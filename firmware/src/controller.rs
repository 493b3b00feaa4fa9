//! The controller: a fixed-rate state machine, `tick(now_us, inputs) → outputs`.
//!
//! Each tick, in this order: commands → pose → scan (validated, resampled onto the beam grid) →
//! LiDAR-map, visual-map and non-map updates (when a new scan arrived with a pose) → detection →
//! watchdog → planning (when due) → outputs. Every stage reports its work in deterministic work
//! units (cells or points touched); a stage above its budget in [`crate::config::StageBudgets`]
//! is counted in [`Status::overruns`].
//!
//! Modes: [`Mode::Idle`] until `Start`; [`Mode::Exploring`]; [`Mode::TargetFound`] on a detection;
//! [`Mode::Exhausted`] when no reachable viewpoint is left; [`Mode::Stopped`] when the watchdog
//! fires (no pose or scan for `watchdog_us`), left again automatically when both flow again.
//! Every mode but `Exploring` asks the base to stop.
//!
//! The controller never reads a clock or a random source: time is `now_us`.

use crate::classifier::{Classifier, ClassifierConfig, LabelFeedback, ModelError, ModelView};
use crate::config::{Config, ConfigError};
use crate::frontier::FrontierSet;
use crate::grid::{GridGeometry, LidarGrid, VisualGrid};
use crate::knownmap::KnownMap;
use crate::matcher::{ScanMatcher, MATCH_WARMUP_SCANS};
use crate::nonmap::NonMapStore;
use crate::planner::{Goal, PlanInputs, Planner, Site};
use crate::rolling::memory::WindowMemory;
use crate::scan::{BeamScan, ScanError, ScanInput};
use crate::searchmap::SearchMap;

mod live;
use fixed_point::{hypot, BinaryAngle, Meters, Pose2};

/// Operator commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Command {
    /// Begin (or resume) the search.
    Start,
    /// Stop the robot and stay idle.
    Stop,
    /// Forget maps, points, blacklist and goal; stay idle.
    Reset,
}

/// A detection by the camera's target detector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Detection {
    /// Where the target was seen, if the detector localised it.
    pub position: Option<(Meters, Meters)>,
}

/// What the controller is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Waiting for `Start`.
    Idle,
    /// Searching.
    Exploring,
    /// The target was detected; the robot stops.
    TargetFound,
    /// No reachable viewpoint is left; the robot stops.
    Exhausted,
    /// The watchdog fired (no pose or no scan for too long); the robot stops.
    Stopped,
}

/// One tick's inputs. Everything is optional but the time.
#[derive(Clone, Copy, Debug, Default)]
pub struct Inputs<'a> {
    /// The robot's pose in the world frame, if a new one arrived.
    pub pose: Option<Pose2>,
    /// A new LiDAR scan, taken at `pose` (or at the last pose).
    pub scan: Option<ScanInput<'a>>,
    /// A detection of the target.
    pub detection: Option<Detection>,
    /// An operator command.
    pub command: Option<Command>,
    /// The base reports it cannot follow the path (an obstacle in the way).
    pub base_blocked: bool,
}

/// Work per stage in the last tick that ran it (work units: cells or points touched;
/// multiply-accumulates for the classifier). It crosses the wire as itself (`StageCostMsg`):
/// the field order is the wire's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct StageCost {
    /// Scan classification (int8 network).
    pub classify: u32,
    /// LiDAR-map update.
    pub lidar: u32,
    /// Visual-map update.
    pub visual: u32,
    /// Non-map store update and filters.
    pub nonmap: u32,
    /// Planning step (frontiers + planner).
    pub plan: u32,
    /// Choosing where to look while walking ([`crate::Config::gaze`]).
    pub gaze: u32,
}

/// A stage of a tick, as reported to a [`StageObserver`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Scan classification (int8 network).
    Classify,
    /// LiDAR-map update.
    Lidar,
    /// Visual-map update.
    Visual,
    /// Non-map store update and filters.
    NonMap,
    /// Planning step (frontiers + planner).
    Plan,
    /// Choosing where to look while walking ([`crate::Config::gaze`]).
    Gaze,
    /// Matching the scan against the LiDAR grid ([`crate::Config::scan_matching`]).
    Match,
}

impl Stage {
    /// The stages with a budget ([`crate::config::StageBudgets`]), in the order of
    /// [`Status::overruns`] (and of the wire).
    pub const BUDGETED: [Stage; 5] = [Stage::Lidar, Stage::Visual, Stage::NonMap, Stage::Plan, Stage::Classify];

    /// Its index in [`Status::overruns`] (`None`: it has no budget).
    pub fn overrun_index(self) -> Option<usize> {
        Self::BUDGETED.iter().position(|&s| s == self)
    }
}

impl crate::config::StageBudgets {
    /// The budget of `stage` (`None`: it has none). Here rather than beside the budgets so that
    /// the configuration does not depend on the controller.
    pub fn of(&self, stage: Stage) -> Option<u32> {
        match stage {
            Stage::Lidar => Some(self.lidar_cells),
            Stage::Visual => Some(self.visual_cells),
            Stage::NonMap => Some(self.nonmap_ops),
            Stage::Plan => Some(self.plan_ops),
            Stage::Classify => Some(self.classify_macs),
            Stage::Gaze | Stage::Match => None,
        }
    }
}

impl StageCost {
    /// The work of `stage` the last time it ran (`None`: not counted here, scan matching).
    pub fn of(&self, stage: Stage) -> Option<u32> {
        let mut c = *self;
        c.slot(stage).copied()
    }

    fn slot(&mut self, stage: Stage) -> Option<&mut u32> {
        match stage {
            Stage::Classify => Some(&mut self.classify),
            Stage::Lidar => Some(&mut self.lidar),
            Stage::Visual => Some(&mut self.visual),
            Stage::NonMap => Some(&mut self.nonmap),
            Stage::Plan => Some(&mut self.plan),
            Stage::Gaze => Some(&mut self.gaze),
            Stage::Match => None,
        }
    }
}

/// Told when each stage of a tick begins and ends (the MCU times stages with it). It sees no
/// data and cannot change the tick; `()` observes nothing and compiles away.
pub trait StageObserver {
    /// `stage` is about to run.
    fn begin(&mut self, stage: Stage);
    /// `stage` has run.
    fn end(&mut self, stage: Stage);
}

impl StageObserver for () {
    #[inline(always)]
    fn begin(&mut self, _: Stage) {}
    #[inline(always)]
    fn end(&mut self, _: Stage) {}
}

/// Counters and state, reported every tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Status {
    /// Current mode (`None` never occurs after the first tick).
    pub mode: Option<Mode>,
    /// Ticks run.
    pub ticks: u32,
    /// Scans integrated.
    pub scans: u32,
    /// Scans refused (see [`ScanError`]).
    pub scans_rejected: u32,
    /// Poses refused (outside the search area).
    pub poses_rejected: u32,
    /// The last scan error.
    pub last_scan_error: Option<ScanError>,
    /// Planning steps run.
    pub plans: u32,
    /// Goals issued (a new goal, not a re-issue of the same one).
    pub goals: u32,
    /// Goals blacklisted (blocked or no progress).
    pub blacklisted: u32,
    /// Reached LiDAR-frontier goals retired from further choice.
    pub retired: u32,
    /// Times the watchdog fired.
    pub watchdog_trips: u32,
    /// Work per stage, last time each ran.
    pub cost: StageCost,
    /// Stage runs above budget, in [`Stage::BUDGETED`]'s order (lidar, visual, nonmap, plan,
    /// classify): [`Status::overruns_of`].
    pub overruns: [u32; 5],
    /// Dijkstra open-list overflows, cumulative.
    pub heap_overflows: u32,
    /// Which way the camera should face now while walking to the goal (`None`: the direction of
    /// travel, or the goal's heading once near it). See [`crate::Config::gaze`].
    pub gaze: Option<BinaryAngle>,
    /// LIVE's search map: its entropy, bits (one per free cell of the prior map the camera has
    /// not seen; 0 without a prior map). See [`crate::searchmap`].
    pub search_entropy_bits: u32,
}

impl Status {
    /// How many runs of `stage` were above its budget (0 for a stage without one).
    pub fn overruns_of(&self, stage: Stage) -> u32 {
        stage.overrun_index().map_or(0, |i| self.overruns[i])
    }
}

/// What the controller asks of the robot this tick.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outputs {
    /// The goal being pursued (present every tick while exploring).
    pub goal: Option<Goal>,
    /// True on the tick a different goal was chosen.
    pub new_goal: bool,
    /// Stop the base now.
    pub stop: bool,
    /// Status.
    pub status: Status,
}

/// The LIVES controller core with all its state. About 1 MiB: keep it in a `static` (MCU) or a
/// `Box` (host), never on a small stack.
pub struct Controller {
    cfg: Config,
    /// The LiDAR search map.
    pub lidar: LidarGrid,
    /// The visual search map.
    pub visual: VisualGrid,
    /// Non-map points.
    pub nonmap: NonMapStore,
    /// Frontiers of the last planning step.
    pub frontiers: FrontierSet,
    /// The planner.
    pub planner: Planner,
    /// The map-free scan classifier: labels scans that arrive without labels (once a model is
    /// installed with [`Controller::set_model`]).
    pub classifier: Classifier<'static>,
    /// The scan-to-map matcher ([`Config::scan_matching`]) and its counters.
    pub matcher: ScanMatcher,
    /// LIVE's known-map classification ([`crate::knownmap`]): once a prior map is loaded
    /// ([`Controller::prior_map_row`]) it labels every scan, before upstream labels and the
    /// classifier.
    pub known: KnownMap,
    /// LIVE's search map over the prior's free space ([`crate::searchmap`]).
    pub search: SearchMap,
    /// What has left the rolling window ([`crate::rolling::memory`]).
    pub memory: WindowMemory,
    /// The prior map has been seeded into the LiDAR grid as it is now (cleared by a new row,
    /// a reset and a move of the window).
    seeded: bool,
    beams: BeamScan,
    mode: Mode,
    /// The pose the maps are drawn at: the input pose corrected by `map_from_odom`.
    pose: Option<Pose2>,
    /// The last input pose (the odometry's, in its own frame).
    odom_pose: Option<Pose2>,
    /// The odometry pose of the last scan the matcher matched.
    last_scan_odom: Option<Pose2>,
    /// The correction from the odometry's frame to the map's ([`Config::scan_matching`]).
    map_from_odom: Pose2,
    last_pose_us: Option<u64>,
    last_scan_us: Option<u64>,
    last_plan_us: Option<u64>,
    /// The first half of a planning step ran on the last tick ([`Planner::prepare`]); this
    /// tick finishes it ([`Planner::select`]).
    plan_prepared: bool,
    goal: Option<Goal>,
    goal_best_dist: Meters,
    goal_progress_us: u64,
    blocked_since: Option<u64>,
    status: Status,
}

impl Controller {
    /// A controller with `cfg`, idle, all maps unknown. `cfg` must pass [`Config::validate`]
    /// (`new` is `const`, so that a `static` can hold a controller, and cannot check it): a
    /// configuration from outside goes through [`Controller::set_config`], which does.
    pub const fn new(cfg: Config) -> Self {
        let geom = GridGeometry { origin_x: cfg.origin_x_m, origin_y: cfg.origin_y_m };
        Self {
            cfg,
            lidar: LidarGrid::new(geom),
            visual: VisualGrid::new(),
            nonmap: NonMapStore::new(),
            frontiers: FrontierSet::new(),
            planner: Planner::new(),
            classifier: Classifier::new(ClassifierConfig { feedback: LabelFeedback::Raw }),
            matcher: ScanMatcher::new(),
            known: KnownMap::new(),
            search: SearchMap::new(),
            memory: WindowMemory::new(),
            seeded: false,
            beams: BeamScan::new(),
            mode: Mode::Idle,
            pose: None,
            odom_pose: None,
            last_scan_odom: None,
            map_from_odom: Pose2::IDENTITY,
            last_pose_us: None,
            last_scan_us: None,
            last_plan_us: None,
            plan_prepared: false,
            goal: None,
            goal_best_dist: Meters::MAX,
            goal_progress_us: 0,
            blocked_since: None,
            status: Status {
                mode: Some(Mode::Idle),
                ticks: 0,
                scans: 0,
                scans_rejected: 0,
                poses_rejected: 0,
                last_scan_error: None,
                plans: 0,
                goals: 0,
                blacklisted: 0,
                retired: 0,
                watchdog_trips: 0,
                cost: StageCost { classify: 0, lidar: 0, visual: 0, nonmap: 0, plan: 0, gaze: 0 },
                overruns: [0; 5],
                heap_overflows: 0,
                gaze: None,
                search_entropy_bits: 0,
            },
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The last accepted pose, in the map's frame: with [`Config::scan_matching`], the input
    /// (odometry) pose corrected by [`Controller::map_from_odom`] and by the last scan's match.
    pub fn pose(&self) -> Option<Pose2> {
        self.pose
    }

    /// The correction from the odometry's frame (the input poses') to the map's (the maps',
    /// the goals' and [`Controller::pose`]'s): identity without [`Config::scan_matching`]. A
    /// goal `g` in the odometry's frame is `map_from_odom().inverse().compose(&g)`.
    pub fn map_from_odom(&self) -> Pose2 {
        self.map_from_odom
    }

    /// The goal being pursued.
    pub fn goal(&self) -> Option<&Goal> {
        self.goal.as_ref()
    }

    /// The latest resampled scan, with the labels the core used for it (the upstream labels, or
    /// the classifier's once it labels scans).
    pub fn beams(&self) -> &BeamScan {
        &self.beams
    }

    /// Installs the classifier's int8 model blob after validating it (magic, version, shapes,
    /// checksum): a `LabelPoseNet` blob (`docs/model-format.md`) or a geometric one (magic `LVGM`,
    /// [`crate::classifier::geo`]). The bytes are read in place (flash on the MCU); a blob that fails validation is
    /// refused and the previous model, if any, stays.
    pub fn set_model(&mut self, blob: &'static [u8]) -> Result<(), ModelError> {
        if crate::classifier::geo::GeoView::is_geo(blob) {
            self.classifier.set_geo_model(crate::classifier::geo::GeoView::parse(blob)?);
        } else {
            self.classifier.set_model(ModelView::parse(blob)?);
        }
        Ok(())
    }

    /// Applies a new configuration from the next tick on, if it passes [`Config::validate`];
    /// otherwise refuses it with the field out of range, and the configuration in use stays. If
    /// the grid origin changes, the maps, points, blacklist and goal no longer line up with the
    /// world: they are forgotten as by [`Controller::reset`] (idle). Otherwise everything learnt
    /// so far is kept.
    pub fn set_config(&mut self, cfg: Config) -> Result<(), ConfigError> {
        cfg.validate()?;
        let moved = cfg.origin_x_m != self.cfg.origin_x_m || cfg.origin_y_m != self.cfg.origin_y_m;
        self.cfg = cfg;
        if moved {
            self.lidar.geom = GridGeometry { origin_x: cfg.origin_x_m, origin_y: cfg.origin_y_m };
            self.reset();
        }
        Ok(())
    }

    /// Forgets everything but the configuration and the model, the status counters included
    /// (a new search); idle.
    pub fn reset(&mut self) {
        self.status = Status { mode: Some(Mode::Idle), ..Status::default() };
        self.goal_best_dist = Meters::MAX;
        self.goal_progress_us = 0;
        self.blocked_since = None;
        self.classifier.reset();
        self.known.forget_history();
        self.seeded = false;
        self.lidar.clear();
        self.visual.grid.clear();
        self.memory.clear();
        self.nonmap.clear();
        self.planner.clear();
        self.mode = Mode::Idle;
        self.pose = None;
        self.odom_pose = None;
        self.last_scan_odom = None;
        self.map_from_odom = Pose2::IDENTITY;
        self.matcher.reset();
        self.last_pose_us = None;
        self.last_scan_us = None;
        self.last_plan_us = None;
        self.plan_prepared = false;
        self.goal = None;
    }

    /// `stage` did `work`: its cost, and an overrun if that is above its budget.
    fn spent(&mut self, stage: Stage, work: u32) {
        if let Some(cost) = self.status.cost.slot(stage) {
            *cost = work;
        }
        if let (Some(i), Some(budget)) = (stage.overrun_index(), self.cfg.budgets.of(stage)) {
            if work > budget {
                self.status.overruns[i] += 1;
            }
        }
    }

    /// Runs one tick at time `now_us` (microseconds, monotonic, supplied by the caller).
    pub fn tick(&mut self, now_us: u64, inputs: &Inputs<'_>) -> Outputs {
        self.tick_observed(now_us, inputs, &mut ())
    }

    /// [`Controller::tick`], telling `obs` where each stage begins and ends.
    pub fn tick_observed(&mut self, now_us: u64, inputs: &Inputs<'_>, obs: &mut impl StageObserver) -> Outputs {
        self.status.ticks = self.status.ticks.wrapping_add(1);
        let mut new_goal = false;

        match inputs.command {
            Some(Command::Start) if matches!(self.mode, Mode::Idle | Mode::Exhausted) => {
                self.mode = Mode::Exploring;
                self.last_plan_us = None;
                self.plan_prepared = false;
            }
            Some(Command::Stop) => {
                self.mode = Mode::Idle;
                self.goal = None;
            }
            Some(Command::Reset) => self.reset(),
            _ => {}
        }

        // A scan that comes with a refused pose is not drawn at the last good pose either.
        let mut pose_refused = false;
        if let Some(odom) = inputs.pose {
            let p = if self.cfg.scan_matching { self.map_from_odom.compose(&odom) } else { odom };
            let (cx, cy) = self.lidar.geom.cell_of(p.x, p.y);
            if crate::grid::PackedGrid::in_bounds(cx, cy) {
                self.pose = Some(p);
                self.odom_pose = Some(odom);
                self.last_pose_us = Some(now_us);
                // Buildings larger than the grid: the window follows the robot (`crate::rolling`).
                let maps = crate::rolling::Maps {
                    lidar: &mut self.lidar,
                    visual: &mut self.visual,
                    nonmap: &mut self.nonmap,
                    frontiers: &mut self.frontiers,
                    planner: &mut self.planner,
                    goal: &mut self.goal,
                    memory: &mut self.memory,
                };
                if crate::rolling::follow(maps, &p, self.cfg.nonmap_pool_radius_m) {
                    self.last_plan_us = None;
                    self.plan_prepared = false;
                    self.seeded = false;
                }
            } else {
                self.status.poses_rejected += 1;
                pose_refused = true;
            }
        }

        self.seed_from_prior();

        if let (Some(scan), Some(predicted), false) = (inputs.scan, self.pose, pose_refused) {
            // The robot's own body: readings below the configured minimum are invalid too.
            let body_mm = ((self.cfg.lidar_min_range_m.to_bits() as i64 * 1000) >> 16).clamp(0, u16::MAX as i64) as u16;
            let scan = ScanInput { range_min_mm: scan.range_min_mm.max(body_mm), ..scan };
            match self.beams.resample(&scan) {
                Ok(_) => {
                    self.last_scan_us = Some(now_us);
                    self.status.scans += 1;
                    obs.begin(Stage::Match);
                    let pose = self.match_scan(&predicted);
                    obs.end(Stage::Match);
                    if self.known.prior.rows_received() > 0 {
                        // A known building: its map labels the scan (LTF map, STF and DF non-map).
                        obs.begin(Stage::Classify);
                        self.known.classify(&pose, &mut self.beams);
                        obs.end(Stage::Classify);
                        self.spent(Stage::Classify, crate::capacity::BEAMS as u32);
                    } else if scan.labels.is_none() {
                        // No labels from upstream: the int8 network labels the scan (every beam
                        // stays unlabelled until a model is installed).
                        obs.begin(Stage::Classify);
                        let w = self.classifier.label_scan(&pose, &mut self.beams);
                        obs.end(Stage::Classify);
                        self.spent(Stage::Classify, w);
                    }
                    obs.begin(Stage::Lidar);
                    let w = self.lidar.integrate(&pose, &self.beams, self.cfg.lidar_max_range_m).work;
                    obs.end(Stage::Lidar);
                    self.spent(Stage::Lidar, w);
                    obs.begin(Stage::Visual);
                    let w = self.integrate_visual(&pose);
                    obs.end(Stage::Visual);
                    self.spent(Stage::Visual, w);
                    let geom = self.lidar.geom;
                    obs.begin(Stage::NonMap);
                    let mut w = self.nonmap.integrate(
                        &geom,
                        &self.visual,
                        &pose,
                        &self.beams,
                        self.cfg.nonmap_pool_radius_m,
                        self.cfg.nonmap_wall_clearance_m,
                    );
                    w += self.nonmap.filter(
                        &geom,
                        &self.lidar,
                        &self.visual,
                        self.cfg.nonmap_pool_radius_m,
                        self.cfg.nonmap_wall_clearance_m,
                        self.cfg.nonmap_drop_vacated,
                    );
                    obs.end(Stage::NonMap);
                    self.spent(Stage::NonMap, w);
                }
                Err(e) => {
                    self.status.scans_rejected += 1;
                    self.status.last_scan_error = Some(e);
                }
            }
        }

        if inputs.detection.is_some() && matches!(self.mode, Mode::Exploring | Mode::Stopped) {
            self.mode = Mode::TargetFound;
            self.goal = None;
        }

        // Watchdog: stale pose or scan stops the robot; fresh data resumes the search.
        let stale = |t: Option<u64>| t.is_none_or(|t| now_us.saturating_sub(t) > self.cfg.watchdog_us);
        let data_stale = stale(self.last_pose_us) || stale(self.last_scan_us);
        match self.mode {
            Mode::Exploring if data_stale => {
                self.mode = Mode::Stopped;
                self.status.watchdog_trips += 1;
            }
            Mode::Stopped if !data_stale => {
                self.mode = Mode::Exploring;
                self.last_plan_us = None;
                self.plan_prepared = false;
            }
            _ => {}
        }

        if self.mode == Mode::Exploring {
            if let Some(pose) = self.pose {
                new_goal = self.maybe_plan(now_us, &pose, inputs.base_blocked, obs);
            }
        }

        // Look while walking (see [`Config::gaze`]): scored every tick from where the robot is.
        let last_gaze = self.status.gaze.take();
        if self.mode == Mode::Exploring && self.cfg.gaze {
            if let (Some(pose), Some(g)) = (self.pose, &self.goal) {
                if hypot(g.pose.x - pose.x, g.pose.y - pose.y) > crate::planner::GAZE_HANDOVER_M {
                    obs.begin(Stage::Gaze);
                    let (gaze, work) = self.planner.gaze(&self.cfg, &self.lidar, &self.visual, &self.nonmap, &pose, last_gaze);
                    obs.end(Stage::Gaze);
                    self.status.gaze = gaze.map(|(h, _)| h);
                    self.spent(Stage::Gaze, work);
                }
            }
        }

        self.status.mode = Some(self.mode);
        self.status.search_entropy_bits = self.search.entropy_bits();
        let exploring = self.mode == Mode::Exploring;
        // The goal goes out in the frame the poses come in (the odometry's): the base follows it
        // there. Inside, the controller plans in its map frame (`Controller::goal`).
        let goal = match (&self.goal, exploring) {
            (Some(g), true) if self.map_from_odom != Pose2::IDENTITY => Some(g.transformed(&self.map_from_odom.inverse())),
            (Some(g), true) => Some(g.clone()),
            _ => None,
        };
        Outputs { goal, new_goal, stop: !exploring, status: self.status }
    }

    /// With [`Config::scan_matching`], once [`MATCH_WARMUP_SCANS`] scans are in the map: matches
    /// the new scan (in `self.beams`) taken at `predicted` against the LiDAR grid and, if the
    /// match is accepted, moves the pose there and updates `map_from_odom`. Returns the pose to
    /// draw the scan at.
    fn match_scan(&mut self, predicted: &Pose2) -> Pose2 {
        let Some(odom) = self.odom_pose.filter(|_| self.cfg.scan_matching && self.status.scans > MATCH_WARMUP_SCANS) else {
            return *predicted;
        };
        let geom = self.lidar.geom;
        // The odometry's motion since the last match: how much the prediction can be off. A
        // motion filter (as Cartographer's): a robot that has not moved is not matched again,
        // or the match's own noise would walk a standing robot's pose.
        let motion = self.last_scan_odom.map_or(crate::matcher::Motion::UNKNOWN, |last| {
            let step = last.inverse().compose(&odom);
            crate::matcher::Motion::of_step(step.x, step.y, step.theta)
        });
        if motion.dist_mm < crate::matcher::MATCH_MIN_MOTION.dist_mm && motion.turn_mdeg < crate::matcher::MATCH_MIN_MOTION.turn_mdeg {
            return *predicted;
        }
        self.last_scan_odom = Some(odom);
        self.matcher.field = self.cfg.scan_match_field;
        match self.matcher.match_scan(&self.lidar, &geom, predicted, &self.beams, self.cfg.lidar_max_range_m, motion) {
            Ok(m) => {
                let (cx, cy) = geom.cell_of(m.pose.x, m.pose.y);
                if !crate::grid::PackedGrid::in_bounds(cx, cy) {
                    return *predicted;
                }
                self.map_from_odom = m.pose.compose(&odom.inverse());
                self.pose = Some(m.pose);
                m.pose
            }
            Err(_) => *predicted,
        }
    }

    /// Plans when due; returns true if a different goal was chosen.
    fn maybe_plan(&mut self, now_us: u64, pose: &Pose2, base_blocked: bool, obs: &mut impl StageObserver) -> bool {
        // A block that clears (a person passing) is not the goal's fault; one that persists is.
        self.blocked_since = if base_blocked { Some(self.blocked_since.unwrap_or(now_us)) } else { None };
        let mut force = self.goal.is_none() || self.last_plan_us.is_none();
        if let Some(g) = &self.goal {
            let d = hypot(g.pose.x - pose.x, g.pose.y - pose.y);
            let heading_err = (g.pose.theta - pose.theta).unsigned_abs();
            if d <= self.cfg.goal_tolerance_m && heading_err <= self.cfg.goal_heading_tolerance.unsigned_abs() {
                // Reached: whatever it offered has been looked at. A LiDAR frontier still there
                // once the robot stands on it is one the sensor cannot resolve (a shadow under
                // furniture, a glass pane): retire the spot so it is not chosen again. The
                // baselines and the tour retire every reached goal: what is still there was not
                // resolved by standing there, and a tour would come back to it.
                if g.viewpoint.source == Site::LidarFrontier || self.cfg.planner.is_baseline() || self.cfg.planner.is_structured() {
                    let cell = g.viewpoint.cell;
                    self.planner.blacklist(cell);
                    self.status.retired += 1;
                }
                self.goal = None;
                force = true;
            } else if self.blocked_since.is_some_and(|t| now_us.saturating_sub(t) >= self.cfg.blocked_timeout_us)
                || now_us.saturating_sub(self.goal_progress_us) > self.cfg.goal_timeout_us
            {
                let cell = g.viewpoint.cell;
                self.planner.blacklist(cell);
                self.status.blacklisted += 1;
                self.goal = None;
                self.blocked_since = None;
                force = true;
            } else if d.saturating_add(self.cfg.progress_m) <= self.goal_best_dist {
                self.goal_best_dist = d;
                self.goal_progress_us = now_us;
            }
        }
        let due = self.last_plan_us.is_none_or(|t| now_us.saturating_sub(t) >= self.cfg.replan_interval_us);
        if !self.plan_prepared && !force && !due {
            return false;
        }
        if !self.plan_prepared && !force && self.cfg.planner == crate::PlannerKind::Rrt {
            // The `rrt` baseline's assigner gives only an idle robot a new goal; its trees keep
            // growing meanwhile.
            self.last_plan_us = Some(now_us);
            obs.begin(Stage::Plan);
            let robot = self.lidar.geom.cell_of(pose.x, pose.y);
            let work = self.planner.rrt.grow(&self.lidar, &self.visual, robot);
            obs.end(Stage::Plan);
            self.status.cost.plan = work;
            return false;
        }
        if !self.plan_prepared {
            // A planning step is spread over two ticks (issue 28, real time): this one finds
            // the frontiers and the path distances, the next chooses on them.
            self.last_plan_us = Some(now_us);
            obs.begin(Stage::Plan);
            let work = self.frontiers.compute(&self.lidar, &self.visual, self.cfg.min_frontier_cells)
                + self.planner.prepare(&self.cfg, &self.lidar, pose);
            obs.end(Stage::Plan);
            self.plan_prepared = true;
            self.spent(Stage::Plan, work);
            return false;
        }
        self.plan_prepared = false;
        obs.begin(Stage::Plan);
        let current = self.goal.as_ref().map(|g| (g.viewpoint.cell, g.viewpoint.heading));
        let inputs = PlanInputs {
            cfg: &self.cfg,
            lidar: &self.lidar,
            visual: &self.visual,
            frontiers: &self.frontiers,
            nonmap: &self.nonmap,
            pose,
            now_us,
        };
        let (best, current_utility) = self.planner.select(inputs, current);
        obs.end(Stage::Plan);
        let work = self.planner.stats.work;
        self.status.plans += 1;
        self.status.heap_overflows += self.planner.stats.heap_overflows;
        self.spent(Stage::Plan, work);
        match best {
            None if self.goal.is_none() => {
                self.mode = Mode::Exhausted;
                false
            }
            None => false,
            Some(b) => {
                let keep = match (&self.goal, current_utility) {
                    (Some(_), Some(cu)) => b.viewpoint.utility <= cu.saturating_add(self.cfg.switch_margin.to_bits() as i64),
                    _ => false,
                };
                if keep {
                    return false;
                }
                let same =
                    self.goal.as_ref().is_some_and(|g| g.viewpoint.cell == b.viewpoint.cell && g.viewpoint.heading == b.viewpoint.heading);
                // A route follower re-chooses its waypoint every step: the same goal keeps its
                // progress clock, or a waypoint the base cannot reach would never time out.
                if !(same && self.cfg.planner.is_coverage()) {
                    self.goal_best_dist = hypot(b.pose.x - pose.x, b.pose.y - pose.y);
                    self.goal_progress_us = now_us;
                }
                self.goal = Some(b);
                if !same {
                    self.status.goals += 1;
                }
                !same
            }
        }
    }
}
