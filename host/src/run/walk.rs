//! The random walker that drives a simulated base when no brain does (dataset episodes after the
//! controller hands over, unseen-world walks).

use crate::sim::geometry::dist;
use crate::sim::{BaseStatus, Sim, P2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Scans per second: a walker's deadlines are in ticks of this rate.
const TICKS_PER_S: f64 = 5.0;

/// Random waypoint walk: picks a reachable cell 1–8 m away with a clear straight line, or turns
/// on the spot; a new choice when the base arrives, is blocked for 1 s, or runs out of time.
pub struct Walker {
    rng: ChaCha8Rng,
    deadline_tick: u32,
    blocked_ticks: u32,
    /// At a waypoint, sometimes (30 %) turn to a random heading.
    turn_at_waypoints: bool,
}

impl Walker {
    /// A walker drawing from `seed`; `turn_at_waypoints`: see the field.
    pub fn new(seed: u64, turn_at_waypoints: bool) -> Walker {
        Walker { rng: ChaCha8Rng::seed_from_u64(seed), deadline_tick: 0, blocked_ticks: 0, turn_at_waypoints }
    }

    /// At tick `tick`, with the base `blocked` in the last period: a new waypoint among `free`,
    /// or a turn, when it is time for one.
    pub fn update(&mut self, sim: &mut Sim, free: &[P2], tick: u32, blocked: bool) {
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
                let yaw = (self.turn_at_waypoints && self.rng.gen_bool(0.3))
                    .then(|| self.rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI));
                sim.set_path(&[q], yaw);
                let speed = sim.config().speed_mps.max(0.05);
                self.deadline_tick = tick + ((d / speed + 10.0) * TICKS_PER_S) as u32;
                return;
            }
        }
        let yaw = self.rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
        sim.set_path(&[], Some(yaw));
        self.deadline_tick = tick + (8.0 * TICKS_PER_S) as u32;
    }
}

/// Is the straight line from `a` to `b` clear for the robot (sampled every 5 cm)?
pub fn line_clear(sim: &Sim, a: P2, b: P2) -> bool {
    let d = dist(a, b);
    let n = (d / 0.05).ceil().max(1.0) as usize;
    (1..=n).all(|i| {
        let t = i as f64 / n as f64;
        !sim.collides([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t])
    })
}
