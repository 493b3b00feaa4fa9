//! A run of `lives ros2` on the graph: joining and placing the grid on the first scan
//! ([`start`]), driving a brain with every answer published ([`Ros2Source::drive`]), and the
//! end ([`Ros2Source::end`]): what a single robot's run ([`run`]) and a team member's
//! (`crate::team::realtime::ros2_member`) share.

use super::{wire, Ros2Error, Ros2Options, Ros2Source};
use crate::run::{drive, Answer, End, Frame, InProcess, Source};
use firmware::{Config, Controller};
use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// A run's outcome.
pub struct Ros2Run {
    /// How it ended.
    pub end: End,
    /// Ticks answered.
    pub ticks: u32,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// Goals published, `[x, y, yaw]`.
    pub goals: Vec<[f64; 3]>,
    /// From a scan's arrival to its answer's publication, microseconds, every tick.
    pub answer_us: Vec<f64>,
    /// Messages received by topic.
    pub received: BTreeMap<&'static str, u64>,
    /// Rejections by name.
    pub rejected: BTreeMap<String, u64>,
}

/// What `lives ros2` runs besides its graph: the grid's origin, the classifier, a known map.
#[derive(Clone, Default)]
pub struct Ros2Brain {
    /// The grid's lower-left corner in the scans' root frame (`None`: centred on the first
    /// placed scan).
    pub origin: Option<[f64; 2]>,
    /// The classifier `lives` runs.
    pub model: Option<&'static [u8]>,
    /// LIVE's known-map mode: the building's map, in the scans' root frame. It seeds the grid
    /// and labels the scans; a route follower (`live`, `visual-cpp`, `lidar-cpp`) searching
    /// alone is given its coverage route from where the first scan was placed ([`run`]).
    pub map: Option<crate::io::map_file::PriorMap>,
}

/// The graph joined and the controller made: what a run on the graph starts from ([`start`]).
pub struct Ros2Started {
    /// The graph, holding the first placed scan as the first frame.
    pub source: Ros2Source,
    /// The controller: its grid placed, its classifier and known map loaded.
    pub ctrl: Box<Controller>,
    /// The known map on the controller's grid.
    pub cells: Option<Vec<crate::io::map_file::Cell3>>,
    /// Where the first scan was placed `[x, y, yaw]`.
    pub start: [f64; 3],
}

/// Joins the graph, waits for the first placed scan, places the grid (at `brain.origin`, or
/// centred on that scan) and makes the controller configured by `cfg` with `brain`'s classifier
/// and known map. `Err(run)`: the graph ended before a scan was placed (`run` says how).
pub fn start(opts: Ros2Options, cfg: Config, brain: &Ros2Brain, stop: Arc<AtomicBool>) -> Result<Result<Ros2Started, Ros2Run>, Ros2Error> {
    let mut source = Ros2Source::join(opts, stop)?;
    // The grid is placed once the first scan is: centred on it unless told where.
    let Some(first) = source.sense(0) else {
        return Ok(Err(source.finish(End::Source, 0)));
    };
    let [ox, oy] = brain.origin.unwrap_or_else(|| crate::run::centred_origin([first.base_pose[0], first.base_pose[1]]));
    let bad_origin = || Ros2Error(format!("the grid origin ({ox}, {oy}) is out of the controller's range"));
    let cfg = Config {
        origin_x_m: fixed_point::meters_from_f64(ox).ok_or_else(bad_origin)?,
        origin_y_m: fixed_point::meters_from_f64(oy).ok_or_else(bad_origin)?,
        ..cfg
    };
    eprintln!("lives ros2: first scan placed in `{}`; grid origin ({ox:.1}, {oy:.1})", source.root.borrow());
    let mut ctrl = Box::new(Controller::new(cfg));
    if let Some(blob) = brain.model {
        ctrl.set_model(blob).map_err(|e| Ros2Error(format!("the classifier model does not validate: {e}")))?;
    }
    let cells = match &brain.map {
        Some(map) => {
            // On the grid as the controller holds it (its origin in fixed point), as `lives
            // search` draws it.
            let grid_origin = [cfg.origin_x_m.to_num::<f64>(), cfg.origin_y_m.to_num::<f64>()];
            let cells = map.to_controller_grid(grid_origin).map_err(|e| Ros2Error(e.to_string()))?;
            crate::live::load(&mut ctrl, &cells);
            Some(cells)
        }
        None => None,
    };
    let root = source.root.borrow().clone();
    let start = first.base_pose;
    source.ready.push_front((first, root));
    Ok(Ok(Ros2Started { source, ctrl, cells, start }))
}

impl Ros2Source {
    /// Drives `brain` on the graph, publishing every answer (`inner`: the controller in it),
    /// until the run ends.
    pub fn drive<B: crate::run::Brain>(&mut self, brain: &mut B, inner: impl Fn(&B) -> &InProcess) -> Result<crate::run::Ended, B::Error> {
        let mut publish = |src: &Ros2Source, frame: &Frame, b: &B, answer: &Answer| src.publish(frame, answer, inner(b));
        drive(self, brain, &mut [&mut publish])
    }

    /// The end of a run that `ended` with `ctrl`: the final grids (latched: a late subscriber
    /// gets them too), the base stopped unless the search ended it, and the run's account.
    pub fn end(self, ended: crate::run::Ended, ctrl: &Controller) -> Ros2Run {
        let t_ns = self.pose.get().map_or(0, |(_, t)| t);
        self.publish_maps(&wire::header_at(t_ns, &self.root.borrow()), ctrl);
        if matches!(ended.end, End::Source | End::Stopped) {
            // Told to stop (by a signal, a team's coordinator) or out of time: the base stands.
            self.announce_stop("shutdown", "lives ros2 stopped");
        }
        self.finish(ended.end, ended.ticks)
    }

    /// The run could not go on (`why`): the base stands, and the participant leaves.
    pub fn abort(self, reason: &str, why: &str) {
        self.announce_stop(reason, why);
        let _ = self.finish(End::Stopped, 0);
    }
}

/// Runs the controller configured by `cfg` and `brain` on the graph until the target is found,
/// the search is exhausted, `stop` is set or `opts.max_wall` passes.
pub fn run(opts: Ros2Options, cfg: Config, brain: Ros2Brain, stop: Arc<AtomicBool>) -> Result<Ros2Run, Ros2Error> {
    let continuous = opts.continuous;
    let Ros2Started { mut source, mut ctrl, cells, start } = match start(opts, cfg, &brain, stop)? {
        Ok(s) => s,
        Err(run) => return Ok(run),
    };
    if let Some(cells) = &cells {
        let s = crate::live::plan_and_give(&mut ctrl, cells, [start[0], start[1]]);
        eprintln!("lives ros2: known map loaded; {} route waypoints", s.route_waypoints);
    }
    let interval = ctrl.config().replan_interval_us;
    let mut brain = if continuous { InProcess::restarting(ctrl, interval) } else { InProcess::new(ctrl) };
    let ended = source.drive(&mut brain, |b| b).unwrap_or_else(|e| match e {});
    Ok(source.end(ended, &brain.ctrl))
}

impl Ros2Source {
    /// Lets the last messages go out, and the run's account.
    pub fn finish(self, end: End, ticks: u32) -> Ros2Run {
        // Let reliable writers deliver the last messages before the participant goes.
        std::thread::sleep(Duration::from_millis(300));
        Ros2Run {
            end,
            ticks,
            wall_s: self.started.elapsed().as_secs_f64(),
            goals: self.goals.take(),
            answer_us: self.answer_us.take(),
            received: self.received(),
            rejected: self.rejected(),
        }
    }
}
