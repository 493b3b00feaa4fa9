//! What `lives ros2` publishes: the answer to each scan (plan, goal, status), stops, and every map
//! period the grids and markers.

use super::wire::{self, marker, Marker};
use super::{Out, Ros2Source};
use crate::io::record::convert::cell_centre;
use crate::io::replay::cdr::{self, Transform};
use crate::run::{Act, Answer, End, Frame, InProcess};
use firmware::capacity::{CELLS_PER_METER, GRID_CELLS};
use firmware::nonmap::hit_point;
use firmware::scan::{BeamLabel, RANGE_INVALID, RANGE_NO_RETURN};
use firmware::{Controller, Mode};
use serde_json::json;

impl Ros2Source {
    /// Publishes a stop: an empty plan and a goal where the robot is.
    pub(super) fn publish_stop(&self, t_ns: u64, why: &str) {
        let root = self.root.borrow().clone();
        let h = wire::header_at(t_ns, &root);
        self.write(Out::Plan, wire::encode_path(&h, &[]));
        if let Some((p, _)) = self.pose.get() {
            self.write(Out::Goal, wire::encode_pose_stamped(&h, &Transform::planar(p[0], p[1], p[2])));
        }
        if self.driving.replace(false) {
            eprintln!("lives ros2: base stopped: {why}");
        }
    }

    /// Publishes a plan (`poses`, each facing the next) and its last pose as the goal.
    fn send_plan(&self, h: &cdr::Header, poses: &[Transform]) {
        self.write(Out::Plan, wire::encode_path(h, poses));
        if let Some(last) = poses.last() {
            self.write(Out::Goal, wire::encode_pose_stamped(h, last));
        }
        self.driving.set(true);
    }

    /// A stop the controller did not ask for (`reason`: `stale-odometry`, `shutdown`): the
    /// stop, and a status saying why.
    pub(super) fn announce_stop(&self, reason: &str, detail: &str) {
        let t_ns = self.pose.get().map_or(0, |(_, t)| t);
        self.publish_stop(t_ns, detail);
        let msg = json!({ "kind": "stop", "reason": reason, "detail": detail });
        self.write(Out::Status, wire::encode_string(&msg.to_string()));
    }

    /// What the controller answered to `frame`, on the graph: the plan and goal, the status, and
    /// (every map period and at the end) the grids and markers.
    pub fn publish(&self, frame: &Frame, answer: &Answer, brain: &InProcess) {
        let ctrl = &brain.ctrl;
        let t_ns = frame.t_us * 1000;
        let root = self.root.borrow().clone();
        let h = wire::header_at(t_ns, &root);
        let mut acts = Vec::new();
        let mut gaze = None;
        for a in &answer.acts {
            match a {
                Act::Path(path, yaw) if answer.end.is_none() => {
                    let poses = path_poses(path, *yaw);
                    self.send_plan(&h, &poses);
                    if let Some(p) = path.last() {
                        self.goals.borrow_mut().push([p[0], p[1], yaw.unwrap_or(0.0)]);
                    }
                    *self.last_plan.borrow_mut() = poses;
                    acts.push("path");
                }
                Act::Stop => {
                    self.publish_stop(t_ns, "the controller said stop");
                    acts.push("stop");
                }
                Act::Gaze(g) => gaze = *g,
                _ => {}
            }
        }
        if answer.end.is_some() && !acts.contains(&"stop") {
            self.publish_stop(t_ns, "the search ended");
            acts.push("stop");
        }
        // After a watchdog stop, the goal the controller still pursues goes out again with the
        // first answer once odometry comes again (the controller sends a path only when it
        // plans). A new path or a stop of the controller's own ends the hold.
        if !acts.is_empty() || answer.end.is_some() || ctrl.goal().is_none() {
            self.held.set(false);
        } else if self.held.get() && self.odometry_fresh() {
            let poses = self.last_plan.borrow().clone();
            self.held.set(false);
            if !poses.is_empty() {
                self.send_plan(&h, &poses);
                acts.push("path");
                acts.push("resent");
            }
        }
        let out = ctrl.goal().map(|g| {
            let (x, y, th) = g.pose.to_f64();
            [x, y, th]
        });
        let end = answer.end.map(|e| match e {
            End::Found => "found",
            End::Exhausted => "exhausted",
            End::Stopped | End::Source => "stopped",
        });
        let status = json!({
            "kind": "tick",
            "stamp_ns": t_ns,
            "tick": self.ticks.replace(self.ticks.get() + 1),
            "mode": mode_name(ctrl.mode()),
            "acts": acts,
            "gaze": gaze,
            "end": end,
            "goal": out,
            "goals": brain.outputs().map_or(0, |o| o.status.goals),
            "blacklisted": brain.outputs().map_or(0, |o| o.status.blacklisted),
            "received": *self.received.borrow(),
            "rejected": *self.rejected.borrow(),
        });
        self.write(Out::Status, wire::encode_string(&status.to_string()));
        if let Some(t) = self.arrived.get() {
            self.answer_us.borrow_mut().push(t.elapsed().as_secs_f64() * 1e6);
        }
        let due = self.last_map_ns.get().is_none_or(|t| t_ns >= t.saturating_add(self.opts.map_period_ns));
        if due || answer.end.is_some() {
            self.last_map_ns.set(Some(t_ns));
            self.publish_maps(&h, ctrl);
            self.publish_markers(&h, frame, ctrl);
        }
    }

    pub(super) fn publish_maps(&self, h: &cdr::Header, ctrl: &Controller) {
        let geom = ctrl.lidar.geom;
        let n = GRID_CELLS as u32;
        let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
        for (w, grid) in [(Out::LidarMap, &ctrl.lidar.grid), (Out::CameraMap, &ctrl.visual.grid)] {
            let mut data = Vec::with_capacity((n * n) as usize);
            for y in 0..n as i32 {
                for x in 0..n as i32 {
                    data.push(grid.get(x, y).to_ros());
                }
            }
            self.write(w, wire::encode_occupancy_grid(h, 1.0 / CELLS_PER_METER as f32, n, n, origin, &data));
        }
    }

    fn publish_markers(&self, h: &cdr::Header, frame: &Frame, ctrl: &Controller) {
        let geom = ctrl.lidar.geom;
        let centre = |c: (i32, i32)| cell_centre(&geom, c);
        let (mut points, mut colors) = (Vec::new(), Vec::new());
        let beams = ctrl.beams();
        let pose = frame.pose.unwrap_or_default();
        for (b, (&r, &label)) in beams.ranges_mm.iter().zip(beams.labels.iter()).enumerate() {
            if r == RANGE_INVALID || r == RANGE_NO_RETURN {
                continue;
            }
            let (x, y) = hit_point(&pose, b, r);
            points.push([x.to_num::<f64>(), y.to_num::<f64>()]);
            colors.push(match label {
                BeamLabel::Map => [0.35, 0.47, 0.78, 1.0],
                BeamLabel::NonMap => [1.0, 0.55, 0.0, 1.0],
                BeamLabel::Unlabelled => [0.63, 0.63, 0.63, 1.0],
            });
        }
        let mut markers = vec![
            Marker { action: marker::DELETE_ALL, ..Marker::default() },
            Marker {
                ns: "scan".into(),
                kind: marker::POINTS,
                scale: [0.05, 0.05, 0.0],
                color: [1.0; 4],
                points,
                colors,
                ..Marker::default()
            },
        ];
        let (mut lidar, mut camera) = (Vec::new(), Vec::new());
        for f in ctrl.frontiers.frontiers() {
            let p = centre(f.anchor);
            if f.source == firmware::frontier::FrontierSource::Lidar {
                lidar.push(p)
            } else {
                camera.push(p)
            }
        }
        markers.push(Marker {
            ns: "frontiers/lidar".into(),
            kind: marker::SPHERE_LIST,
            scale: [0.3; 3],
            color: [0.0, 0.8, 0.9, 0.8],
            points: lidar,
            ..Marker::default()
        });
        markers.push(Marker {
            ns: "frontiers/camera".into(),
            id: 1,
            kind: marker::SPHERE_LIST,
            scale: [0.3; 3],
            color: [0.8, 0.2, 0.9, 0.8],
            points: camera,
            ..Marker::default()
        });
        for (i, v) in ctrl.planner.candidates.iter().enumerate() {
            let [x, y] = centre(v.cell);
            markers.push(Marker {
                ns: "candidates".into(),
                id: i as i32,
                kind: marker::ARROW,
                pose: Some(Transform::planar(x, y, v.heading.to_radians())),
                scale: [0.5, 0.08, 0.08],
                color: [0.2, 0.8, 0.2, 0.9],
                ..Marker::default()
            });
        }
        self.write(Out::Markers, wire::encode_marker_array(h, &markers));
    }
}

/// A path's poses: each facing the next point, the last facing `yaw` (the goal's heading).
fn path_poses(path: &[[f64; 2]], yaw: Option<f64>) -> Vec<Transform> {
    let n = path.len();
    (0..n)
        .map(|i| {
            let heading = if i + 1 < n {
                (path[i + 1][1] - path[i][1]).atan2(path[i + 1][0] - path[i][0])
            } else {
                yaw.unwrap_or_else(|| if n > 1 { (path[n - 1][1] - path[n - 2][1]).atan2(path[n - 1][0] - path[n - 2][0]) } else { 0.0 })
            };
            Transform::planar(path[i][0], path[i][1], heading)
        })
        .collect()
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Idle => "idle",
        Mode::Exploring => "exploring",
        Mode::TargetFound => "target-found",
        Mode::Exhausted => "exhausted",
        Mode::Stopped => "stopped",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_faces_along_itself_and_ends_at_the_goal_heading() {
        let p = path_poses(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], Some(3.0));
        let yaw = |t: &Transform| 2.0 * t.rotation[2].atan2(t.rotation[3]);
        assert!((yaw(&p[0]) - 0.0).abs() < 1e-12);
        assert!((yaw(&p[1]) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((yaw(&p[2]) - 3.0).abs() < 1e-12);
    }
}
