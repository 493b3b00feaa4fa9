//! Episodes in the built-in worlds (never in the dataset): random walks for the unseen-world accuracy.

use super::*;
use crate::learn::dataset;
use crate::learn::labeller::{Labeller, LabellerConfig};
use crate::run::range::encode_range;
use crate::run::{drive, Answer, Frame, Idle, SimSource, Walker};
use crate::sim::reach::ReachMap;
use crate::sim::{Scenario, Sim, World};

/// Drives a random walk (random reachable waypoints 1–8 m away on clear straight lines, or a turn
/// on the spot) through `world` for `seconds` at 5 Hz and labels every scan with the default
/// labeller — an evaluation episode in a world no dataset contains.
pub fn drive_random_walk(world: &World, name: &str, sim_seed: u64, seconds: f64) -> Result<Episode> {
    let cfg = dataset::sim_config();
    let min = crate::run::sim_limits(&cfg);
    let start = [world.start.pose[0], world.start.pose[1]];
    let reach = ReachMap::new(world, start, cfg.robot_radius_m + 0.1);
    let [lo, hi] = world.bounds;
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let free = reach.reached_near(centre, crate::sim::geometry::dist(lo, hi) / 2.0 + 1.0);
    let ticks = (seconds * dataset::SCAN_HZ).round() as u32;
    let walker = Walker::new(sim_seed ^ 0x554E_5345_454E, false);
    let mut source = SimSource::episode(Sim::new(world.clone(), cfg, sim_seed), ticks, false, false, walker, free);
    let mut lab = Labeller::for_world(world, LabellerConfig::default());
    let mut steps: Result<Vec<Step>> = Ok(Vec::with_capacity(ticks as usize));
    let mut watch = |src: &SimSource, _: &Frame, _: &Idle, _: &Answer| {
        let (Ok(v), Some(scan)) = (&mut steps, &src.scan) else { return };
        let labels = lab.label_scan(src.pose, scan);
        match pose_of(src.pose) {
            Ok(pose) => v.push(Step {
                pose,
                ranges_mm: scan.ranges_m.iter().map(|&r| encode_range(r as f64, &min)).collect(),
                labels: labels.iter().map(|l| l.code()).collect(),
            }),
            Err(e) => steps = Err(e),
        }
    };
    let Ok(_) = drive(&mut source, &mut Idle, &mut [&mut watch]);
    let steps = steps?;
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
