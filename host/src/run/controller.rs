//! The brains that run in this process: the controller core ([`InProcess`]) and none
//! ([`Idle`], the source's walker drives).

use super::cycle::{Act, Answer, Brain, End, Frame};
use crate::sim::World;
use firmware::{Command, Config, Controller, Mode, Outputs, PlannerKind};
use std::convert::Infallible;

/// The controller core, ticked in this process.
pub struct InProcess {
    /// The controller.
    pub ctrl: Box<Controller>,
    out: Option<Outputs>,
    last_start: Option<u64>,
    /// `None`: a search, which ends when the target is found or nothing is left to explore.
    /// `Some(interval)`: the run does not end when nothing is left to explore: the search starts
    /// again when it is exhausted and `interval` has passed since the last start.
    restart_after_us: Option<u64>,
    /// Whether finding the target ends the run (not for a replay: a log goes on).
    end_on_found: bool,
}

impl InProcess {
    /// A search with `ctrl`: `Start` on the first tick, the run ends when it does.
    pub fn new(ctrl: Box<Controller>) -> Self {
        InProcess { ctrl, out: None, last_start: None, restart_after_us: None, end_on_found: true }
    }

    /// A replay with `ctrl`: it never ends the run, and starts again when exhausted (every
    /// `interval_us` at most).
    pub fn restarting(ctrl: Box<Controller>, interval_us: u64) -> Self {
        InProcess { restart_after_us: Some(interval_us), end_on_found: false, ..InProcess::new(ctrl) }
    }

    /// A team member's search with `ctrl`: it ends when the target is found, but not when
    /// nothing is left to explore: it waits and starts again (every `interval_us` at most), for
    /// a teammate's share of the work, a way that opens, or a region that appears.
    pub fn waiting(ctrl: Box<Controller>, interval_us: u64) -> Self {
        InProcess { restart_after_us: Some(interval_us), ..InProcess::new(ctrl) }
    }

    /// The outputs of the last tick (`None` before the first).
    pub fn outputs(&self) -> Option<&Outputs> {
        self.out.as_ref()
    }

    fn start(&mut self, now_us: u64) -> bool {
        let start = match (self.last_start, self.restart_after_us) {
            (None, _) => true,
            (Some(t), Some(interval)) => self.ctrl.mode() == Mode::Exhausted && now_us.saturating_sub(t) >= interval,
            (Some(_), None) => false,
        };
        if start {
            self.last_start = Some(now_us);
        }
        start
    }
}

impl Brain for InProcess {
    type Error = Infallible;

    fn think(&mut self, frame: &Frame) -> Result<Answer, Infallible> {
        let command = self.start(frame.t_us).then_some(Command::Start);
        let out = self.ctrl.tick(frame.t_us, &frame.inputs(command));
        let end = match out.status.mode {
            Some(Mode::TargetFound) if self.end_on_found => Some(End::Found),
            Some(Mode::Exhausted) if self.restart_after_us.is_none() => Some(End::Exhausted),
            _ => None,
        };
        let mut acts = Vec::new();
        if out.stop {
            acts.push(Act::Stop);
        } else if let (true, Some(g)) = (out.new_goal, &out.goal) {
            let path = g.path.iter().map(|w| [w.0.to_num::<f64>(), w.1.to_num::<f64>()]).collect();
            acts.push(Act::Path(path, Some(g.pose.theta.to_radians())));
        }
        acts.push(Act::Gaze(out.status.gaze.map(|h| h.to_radians())));
        self.out = Some(out);
        Ok(Answer { command, end, acts })
    }
}

/// No brain: every answer lets the source's walker drive.
pub struct Idle;

impl Brain for Idle {
    type Error = Infallible;

    fn think(&mut self, _frame: &Frame) -> Result<Answer, Infallible> {
        Ok(Answer { command: None, end: None, acts: vec![Act::Wander] })
    }
}

/// The controller configuration for a world: the grid (51.2 m square) placed so the world's
/// bounds sit inside it with a margin — the operator's "search area".
pub fn controller_config(base: &Config, world: &World, planner: PlannerKind) -> Config {
    let [min, max] = world.bounds;
    // Centred on the world (a world up to 51 m across fits).
    let [x, y] = centred_origin([(min[0] + max[0]) / 2.0, (min[1] + max[1]) / 2.0]);
    // The planner's own defaults (explore-lite's) come from the core.
    let base = base.with_planner(planner);
    Config {
        origin_x_m: fixed_point::meters_from_f64(x).unwrap_or_default(),
        origin_y_m: fixed_point::meters_from_f64(y).unwrap_or_default(),
        ..base
    }
}

/// The lower-left corner of the grid (51.2 m square) centred on `centre`, on the 0.1 m lattice.
pub fn centred_origin(centre: [f64; 2]) -> [f64; 2] {
    let half = firmware::capacity::GRID_CELLS as f64 / firmware::capacity::CELLS_PER_METER as f64 / 2.0;
    centre.map(|c| ((c - half) * 10.0).round() / 10.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::range::EncodedScan;
    use firmware::{BinaryAngle, Meters, Pose2};

    /// A tick at `t_us` of a robot at (5, 5) m inside a round wall 1 m away (nothing to explore
    /// once the wall is mapped), the camera detecting the target if `detection`.
    fn enclosed(t_us: u64, detection: bool) -> Frame {
        Frame {
            t_us,
            pose: Some(Pose2::new(Meters::from_num(5), Meters::from_num(5), BinaryAngle::ZERO)),
            base_pose: [5.0, 5.0, 0.0],
            time_s: t_us as f64 / 1e6,
            scan: EncodedScan {
                angle_min: BinaryAngle::ZERO,
                angle_increment: BinaryAngle::from_fraction(1, 360),
                ranges_mm: vec![1_000; 360],
                range_min_mm: 100,
                range_max_mm: 10_000,
                labels: Vec::new(),
                combined: 1,
            },
            labels: false,
            detection,
            base_blocked: false,
        }
    }

    /// The ends and starts of `brain` over `ticks` ticks of 0.2 s.
    fn run(brain: &mut InProcess, ticks: u64, detection_at: Option<u64>) -> (Vec<End>, usize) {
        let (mut ends, mut starts) = (Vec::new(), 0);
        for k in 0..ticks {
            let Ok(a) = brain.think(&enclosed(k * 200_000, detection_at == Some(k)));
            ends.extend(a.end);
            starts += a.command.is_some() as usize;
        }
        (ends, starts)
    }

    fn ctrl() -> Box<Controller> {
        Box::new(Controller::new(Config::DEFAULT))
    }

    #[test]
    fn a_search_ends_when_exhausted_a_waiting_one_starts_again_and_a_replay_never_ends() {
        // A search: exhausted within the first seconds, and that ends it.
        let (ends, starts) = run(&mut InProcess::new(ctrl()), 50, None);
        assert!(ends.contains(&End::Exhausted), "{ends:?}");
        assert_eq!(starts, 1);
        // A team member: never ends for it, and starts again (every 1 s at most).
        let (ends, starts) = run(&mut InProcess::waiting(ctrl(), 1_000_000), 50, None);
        assert!(ends.is_empty(), "{ends:?}");
        assert!((3..=10).contains(&starts), "{starts} starts in 10 s");
        // It does end on a find; a replay does not.
        let (ends, _) = run(&mut InProcess::waiting(ctrl(), 1_000_000), 50, Some(30));
        assert_eq!(ends.first(), Some(&End::Found), "{ends:?}");
        let (ends, _) = run(&mut InProcess::restarting(ctrl(), 1_000_000), 50, Some(30));
        assert!(ends.is_empty(), "{ends:?}");
    }
}
