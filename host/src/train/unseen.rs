//! Episodes in the built-in worlds (never in the dataset): random walks for the unseen-world accuracy.

use super::*;
use crate::dataset::{self};
use crate::labeller::{Labeller, LabellerConfig};
use crate::range::encode_range;
use crate::search::TICK_US;
use crate::sim::reach::ReachMap;
use crate::sim::{BaseStatus, Scenario, Sim, World, P2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Drives a random walk (random reachable waypoints 1–8 m away on clear straight lines, or a turn
/// on the spot) through `world` for `seconds` at 5 Hz and labels every scan with the default
/// labeller — an evaluation episode in a world no dataset contains.
pub fn drive_random_walk(world: &World, name: &str, sim_seed: u64, seconds: f64) -> Result<Episode> {
    let cfg = dataset::sim_config();
    let min = crate::search::sim_limits(&cfg);
    let start = [world.start.pose[0], world.start.pose[1]];
    let reach = ReachMap::new(world, start, cfg.robot_radius_m + 0.1);
    let [lo, hi] = world.bounds;
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let free = reach.reached_near(centre, crate::sim::geometry::dist(lo, hi) / 2.0 + 1.0);
    let mut sim = Sim::new(world.clone(), cfg, sim_seed);
    let mut lab = Labeller::for_world(world, LabellerConfig::default());
    let mut rng = ChaCha8Rng::seed_from_u64(sim_seed ^ 0x554E_5345_454E);
    let ticks = (seconds * dataset::SCAN_HZ).round() as u32;
    let (mut deadline, mut blocked_ticks, mut blocked) = (0u32, 0u32, false);
    let mut steps = Vec::with_capacity(ticks as usize);
    const SUBSTEPS: u32 = 4;
    for tick in 0..ticks {
        let p = sim.pose();
        let scan = sim.scan();
        let labels = lab.label_scan(p, &scan);
        steps.push(Step {
            pose: pose_of(p)?,
            ranges_mm: scan.ranges_m.iter().map(|&r| encode_range(r as f64, &min)).collect(),
            labels: labels.iter().map(|l| l.code()).collect(),
        });
        blocked_ticks = if blocked { blocked_ticks + 1 } else { 0 };
        let idle = matches!(sim.base_status(), BaseStatus::Idle | BaseStatus::Arrived);
        if idle || blocked_ticks >= 5 || tick >= deadline {
            blocked_ticks = 0;
            let here: P2 = [p[0], p[1]];
            let mut chosen = false;
            if !free.is_empty() && rng.gen_bool(0.85) {
                for _ in 0..60 {
                    let q = free[rng.gen_range(0..free.len())];
                    let d = crate::sim::geometry::dist(here, q);
                    let n = (d / 0.05).ceil().max(1.0) as usize;
                    let clear = (1..=n).all(|i| {
                        let t = i as f64 / n as f64;
                        !sim.collides([here[0] + (q[0] - here[0]) * t, here[1] + (q[1] - here[1]) * t])
                    });
                    if (1.0..=8.0).contains(&d) && clear {
                        sim.set_path(&[q], None);
                        deadline = tick + ((d / sim.config().speed_mps.max(0.05) + 10.0) * dataset::SCAN_HZ) as u32;
                        chosen = true;
                        break;
                    }
                }
            }
            if !chosen {
                sim.set_path(&[], Some(rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI)));
                deadline = tick + (8.0 * dataset::SCAN_HZ) as u32;
            }
        }
        blocked = false;
        for _ in 0..SUBSTEPS {
            if sim.step(TICK_US as f64 / 1e6 / SUBSTEPS as f64) == BaseStatus::Blocked {
                blocked = true;
            }
        }
    }
    Ok(Episode { name: name.to_string(), steps })
}

/// One random-walk episode of `seconds` in each built-in world and scenario (apartment, office,
/// hallway × easy, hard), simulator seed `seed + i`. These worlds are never in a dataset.
pub fn unseen_episodes(seconds: f64, seed: u64) -> Result<Vec<Episode>> {
    let mut out = Vec::new();
    for name in World::builtin_names() {
        for sc in Scenario::ALL {
            let w = World::builtin(name, sc).ok_or_else(|| TrainError(format!("no built-in world {name} {sc}")))?;
            out.push(drive_random_walk(&w, &format!("{name}-{sc}"), seed + out.len() as u64, seconds)?);
        }
    }
    Ok(out)
}
