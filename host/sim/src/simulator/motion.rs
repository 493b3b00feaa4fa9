//! How the base and the people move: paths, gaze, the turn-then-drive law with obstacle sliding,
//! and people who wait and turn round.

use super::*;
use crate::geometry::{dist, norm, sub, wrap_angle, Scene};
use crate::P2;

impl Sim {
    /// Walls, obstacles and the placed targets (no people).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Puts the robot at `pose` (world frame) without driving there: for tests that check what
    /// the sensors report from a given pose. Odometry, the path and the clock are left as they
    /// are.
    pub fn place_robot(&mut self, pose: [f64; 3]) {
        self.pose = [pose[0], pose[1], wrap_angle(pose[2])];
    }

    /// The target the camera sees now: inside the cone (field of view, range) along the robot's
    /// heading, with at least `detect_min_visible_fraction` of its outline sample points in
    /// line of sight (walls, obstacles, other targets and people block; the target itself does
    /// not). The best-visible target wins; `None` if none qualifies.
    pub fn detect(&self) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for i in 0..self.target_shapes.len() {
            let f = self.visible_fraction(i);
            if f > 0.0 && f >= self.config.detect_min_visible_fraction && best.is_none_or(|(_, bf)| f > bf) {
                best = Some((i, f));
            }
        }
        best.map(|(i, _)| i)
    }

    /// Replace the path. Non-finite waypoints are dropped; a non-finite final yaw is ignored.
    pub fn set_path(&mut self, waypoints: &[P2], final_yaw: Option<f64>) {
        self.goal = None;
        self.path = waypoints.iter().copied().filter(|p| p[0].is_finite() && p[1].is_finite()).collect();
        self.final_yaw = final_yaw.filter(|y| y.is_finite()).map(wrap_angle);
        self.status = if self.path.is_empty() && self.final_yaw.is_none() { BaseStatus::Arrived } else { BaseStatus::Moving };
    }

    /// Which way the body (and camera) should face while walking the path: `Some(yaw)` walks
    /// holonomically (Spot can walk one way and face another) turning towards `yaw`; `None`
    /// faces the direction of travel. A non-finite yaw counts as `None`. At the end of the path
    /// the final yaw of [`Sim::set_path`] applies either way.
    pub fn set_gaze(&mut self, yaw: Option<f64>) {
        if let Some(g) = &mut self.goal {
            g.gaze = None;
        }
        self.gaze = yaw.filter(|y| y.is_finite()).map(wrap_angle);
    }

    /// Drop the path and stand still.
    pub fn stop_base(&mut self) {
        self.goal = None;
        self.path.clear();
        self.final_yaw = None;
        self.status = BaseStatus::Idle;
    }

    /// Distance the base has driven.
    pub fn path_length_m(&self) -> f64 {
        self.driven_m
    }

    /// Does the robot disc at `p` touch a wall, obstacle, target or person (as they are now)?
    pub fn collides(&self, p: P2) -> bool {
        let r = self.config.robot_radius_m;
        self.scene.disc_collides(p, r) || self.walkers.iter().any(|w| dist(w.position(), p) < w.radius + r)
    }

    /// Advance virtual time by `dt_s` in sub-steps of at most [`MAX_SUBSTEP_S`]: people walk, the
    /// base follows its path. Returns the base status after the last sub-step. A non-positive or
    /// non-finite `dt_s` changes nothing.
    pub fn step(&mut self, dt_s: f64) -> BaseStatus {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return self.status;
        }
        let n = ((dt_s / MAX_SUBSTEP_S).ceil() as usize).clamp(1, 10_000_000);
        let h = dt_s / n as f64;
        for _ in 0..n {
            self.walk_people(h);
            if matches!(self.status, BaseStatus::Moving | BaseStatus::Blocked) {
                let before = self.pose;
                self.goal_to_base();
                self.drive(h);
                self.goal_progress();
                self.integrate_odom(before);
            }
        }
        self.time_s += dt_s;
        self.status
    }

    fn walk_people(&mut self, h: f64) {
        let robot = [self.pose[0], self.pose[1]];
        let r = self.config.robot_radius_m;
        for w in &mut self.walkers {
            let len = w.length();
            if len.is_nan() || len <= 0.0 || w.speed == 0.0 {
                continue;
            }
            let next = (w.s + w.dir * w.speed * h).rem_euclid(len);
            let (now_d, next_d) = (dist(w.position(), robot), dist(w.position_at(next), robot));
            // Wait rather than walk into the robot (always allowed to move away); after
            // PERSON_PATIENCE_S of waiting, turn round.
            if next_d < w.radius + r && next_d < now_d {
                w.waited_s += h;
                if w.waited_s >= PERSON_PATIENCE_S {
                    w.dir = -w.dir;
                    w.waited_s = 0.0;
                }
                continue;
            }
            w.waited_s = 0.0;
            w.s = next;
        }
    }

    /// Would the robot disc at `to` (coming from `from`) touch anything? People only block
    /// motion that brings the robot closer to them.
    fn motion_blocked(&self, from: P2, to: P2) -> bool {
        let r = self.config.robot_radius_m;
        self.scene.disc_collides(to, r)
            || self.walkers.iter().any(|w| {
                let c = w.position();
                dist(c, to) < w.radius + r && dist(c, to) < dist(c, from)
            })
    }

    /// Take a sub-step the base found clear: stand at `to` facing `yaw`, count the distance.
    fn move_to(&mut self, to: P2, yaw: f64) {
        self.driven_m += dist([self.pose[0], self.pose[1]], to);
        self.pose = [to[0], to[1], yaw];
        self.status = BaseStatus::Moving;
    }

    /// The sub-step the base takes when it means to go from `p` to `to`: `to` itself if that
    /// touches nothing, else the same step turned by up to [`AVOID_MAX_RAD`] (in
    /// [`AVOID_STEP_RAD`] steps, left before right), as Spot's own obstacle avoidance slides
    /// along what it grazes; `None` (blocked) when every one of them touches something.
    fn avoid(&self, p: P2, to: P2) -> Option<P2> {
        let v = sub(to, p);
        if norm(v) == 0.0 || !self.motion_blocked(p, to) {
            return Some(to);
        }
        let turns = (AVOID_MAX_RAD / AVOID_STEP_RAD).round() as i32;
        (1..=turns)
            .flat_map(|k| [k, -k])
            .map(|k| {
                let (s, c) = (k as f64 * AVOID_STEP_RAD).sin_cos();
                [p[0] + c * v[0] - s * v[1], p[1] + s * v[0] + c * v[1]]
            })
            .find(|&q| !self.motion_blocked(p, q))
    }

    fn drive(&mut self, h: f64) {
        let c = &self.config;
        let (speed, turn) = (c.speed_mps.max(0.0), c.turn_rate_rps.max(0.0));
        let p = [self.pose[0], self.pose[1]];
        while let Some(w) = self.path.front() {
            let tol = if self.path.len() > 1 { WAYPOINT_TOLERANCE_M } else { GOAL_TOLERANCE_M };
            if dist(*w, p) < tol {
                self.path.pop_front();
            } else {
                break;
            }
        }
        if let (Some(&w), Some(g)) = (self.path.front(), self.gaze) {
            // Holonomic: walk towards the waypoint whichever way the body faces, turning
            // towards the gaze heading at the turn rate.
            let v = sub(w, p);
            let d = norm(v);
            let e = wrap_angle(g - self.pose[2]);
            let yaw = wrap_angle(self.pose[2] + e.clamp(-turn * h, turn * h));
            let step = (speed * h).min(d);
            let to = if d > 0.0 { [p[0] + step * v[0] / d, p[1] + step * v[1] / d] } else { p };
            let Some(to) = self.avoid(p, to) else {
                self.pose[2] = yaw;
                self.status = BaseStatus::Blocked;
                return;
            };
            self.move_to(to, yaw);
        } else if let Some(&w) = self.path.front() {
            let v = sub(w, p);
            let d = norm(v);
            let e = wrap_angle(v[1].atan2(v[0]) - self.pose[2]);
            let dyaw = e.clamp(-turn * h, turn * h);
            let yaw = wrap_angle(self.pose[2] + dyaw);
            let e_after = e - dyaw;
            let step = if e_after.abs() < DRIVE_WHILE_TURNING_RAD { (speed * e_after.cos() * h).min(d) } else { 0.0 };
            let to = [p[0] + step * yaw.cos(), p[1] + step * yaw.sin()];
            let Some(to) = self.avoid(p, to) else {
                self.status = BaseStatus::Blocked;
                return;
            };
            self.move_to(to, yaw);
        } else if let Some(fy) = self.final_yaw {
            let e = wrap_angle(fy - self.pose[2]);
            if e.abs() <= YAW_TOLERANCE_RAD {
                self.pose[2] = fy;
                self.final_yaw = None;
                self.status = BaseStatus::Arrived;
            } else {
                self.pose[2] = wrap_angle(self.pose[2] + e.clamp(-turn * h, turn * h));
                self.status = BaseStatus::Moving;
            }
        } else {
            self.status = BaseStatus::Arrived;
        }
    }
}
