//! One robot of a team: its simulator and its own controller core, stepped one tick at a time
//! on the coordinator's order.

use super::member::TeamMember;
use super::{Assignment, Status};
use crate::run::{Answer, Brain, End, InProcess, SimSource, Source};
use crate::search::SearchSpec;
use firmware::Controller;

/// A team robot.
pub struct TeamRobot {
    /// Its team state.
    pub member: TeamMember,
    /// Its simulator.
    pub source: SimSource,
    /// Its controller.
    pub brain: InProcess,
    /// How its run ended (it then idles).
    pub ended: Option<End>,
}

impl TeamRobot {
    /// Robot `id` of a team, searching `spec` (already started where it stands,
    /// [`super::TeamSpec::member`]); the known map, if any, is loaded but no route given (the
    /// coordinator assigns it). With `teammates`, running out of work does not end its run: it
    /// waits, re-planning every `replan_interval`, for a share of what the others have left (a
    /// team of one ends as the single-robot search does). Fails if the spec's model does not
    /// validate.
    pub fn new(id: u32, instance: u32, spec: &SearchSpec, teammates: bool) -> Result<Self, String> {
        let cfg = crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind());
        let mut ctrl = Box::new(Controller::new(cfg));
        if let (true, Some(blob)) = (spec.classifier(), spec.model) {
            ctrl.set_model(blob).map_err(|e| format!("robot {id}: {e}"))?;
        }
        if let Some(cells) = &spec.prior_map {
            crate::live::load(&mut ctrl, cells);
        }
        Ok(TeamRobot {
            member: TeamMember::new(id, instance, spec.prior_map.is_some()),
            source: spec.sim_source(),
            brain: if teammates { InProcess::waiting(ctrl, cfg.replan_interval_us) } else { InProcess::new(ctrl) },
            ended: None,
        })
    }

    /// Robot `id` of `spec`'s team as a process of its own: started where [`super::starts`]
    /// puts it, reporting as this process.
    pub fn of_team(spec: &super::TeamSpec, id: usize) -> Result<Self, String> {
        spec.check()?;
        if id >= spec.robots {
            return Err(format!("--as-robot {id}: the team has robots 0..{}", spec.robots - 1));
        }
        let start = super::starts(&spec.base, spec.robots)?[id];
        TeamRobot::new(id as u32, std::process::id(), &spec.member(id, start)?, spec.robots > 1)
    }

    /// Its index in the team.
    pub fn id(&self) -> u32 {
        self.member.id
    }

    /// The epoch of the assignment it follows (0: none yet).
    pub fn epoch(&self) -> u32 {
        self.member.epoch
    }

    /// Takes an assignment ([`TeamMember::assign`]).
    pub fn assign(&mut self, a: &Assignment) {
        self.member.assign(&mut self.brain.ctrl, a);
    }

    /// Takes what the team saw ([`TeamMember::merge`]).
    pub fn merge(&mut self, seen: &[u32], lidar: &[u32]) {
        self.member.merge(&mut self.brain.ctrl, seen, lidar);
    }

    /// Leaves teammates their goals ([`TeamMember::give_way`]).
    pub fn give_way(&mut self, goals: &[Option<[f64; 2]>], positions: &[Option<[f64; 2]>]) {
        self.member.give_way(&mut self.brain.ctrl, goals, positions);
    }

    /// Its announcement.
    pub fn hello(&mut self) -> Status {
        self.status(None)
    }

    /// Steps tick `tick` (sense, think, act) and reports.
    pub fn step(&mut self, tick: u32) -> Status {
        if self.ended.is_none() {
            match self.source.sense(tick) {
                None => self.ended = Some(End::Source),
                Some(frame) => {
                    let Ok(answer) = self.brain.think(&frame);
                    self.member.answered(self.brain.outputs(), answer.end.is_some());
                    if let Some(end) = answer.end {
                        self.ended = Some(end);
                        self.source.act(&Answer { acts: vec![crate::run::Act::Stop], ..Answer::default() });
                    } else if !self.source.act(&answer) {
                        self.ended = Some(End::Source);
                    }
                }
            }
        } else {
            self.stand();
        }
        self.status(Some(tick))
    }

    /// Stands still for a tick without thinking (idle, or holding for an assignment on its
    /// way): the simulator's time goes on, to its limit.
    fn stand(&mut self) {
        if !self.source.act(&Answer { acts: vec![crate::run::Act::Stop], ..Answer::default() }) && self.ended.is_none() {
            self.ended = Some(End::Source);
        }
    }

    /// Holds still through tick `tick` (its goal dropped) and reports: the coordinator has
    /// named an assignment it does not hold yet.
    pub fn hold(&mut self, tick: u32) -> Status {
        self.member.drop_goal();
        self.stand();
        self.status(Some(tick))
    }

    fn status(&mut self, tick: Option<u32>) -> Status {
        let path_m = self.source.sim.path_length_m();
        self.member.report(
            &self.brain.ctrl,
            self.brain.outputs(),
            tick,
            self.source.start,
            self.ended == Some(End::Found),
            self.ended.is_some(),
            path_m,
        )
    }

    /// The controller (read only).
    pub fn controller(&self) -> &Controller {
        &self.brain.ctrl
    }
}
