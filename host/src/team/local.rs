//! A team in one process: the coordinator and the robots exchange the same messages as over
//! DDS, by value, in lockstep (the evaluation's transport). Bytes are counted as their CDR
//! encodings, the payloads DDS would carry.

use super::coordinator::Coordinator;
use super::robot::TeamRobot;
use super::{codec, starts, Assignment, Status, TeamResult, TeamSpec};
use crate::run::TICK_US;

/// The coordinator of `spec` (its robot 0's controller configuration and map).
pub fn coordinator(spec: &TeamSpec) -> Result<Coordinator, String> {
    let base = &spec.base;
    let cfg = crate::run::controller_config(&base.controller, &base.world, base.planner.kind());
    Ok(Coordinator::new(cfg, base.prior_map.clone(), spec.speeds()?, TICK_US as f64 / 1e6, base.world.time_limit_s))
}

/// Runs `spec`'s team in this process.
pub fn run(spec: &TeamSpec) -> Result<TeamResult, String> {
    spec.check()?;
    let starts = starts(&spec.base, spec.robots)?;
    let mut robots = Vec::with_capacity(spec.robots);
    for (i, s) in starts.iter().enumerate() {
        robots.push(TeamRobot::new(i as u32, std::process::id(), &spec.member(i, *s)?, spec.robots > 1)?);
    }
    let mut coord = coordinator(spec)?;
    let hellos: Vec<Status> = robots.iter_mut().map(TeamRobot::hello).collect();
    let mut bytes = vec![[0u64; 2]; spec.robots];
    for (i, h) in hellos.iter().enumerate() {
        bytes[i][0] += codec::encode_status(h).len() as u64;
    }
    let mut pending: Vec<Assignment> = coord.start(&hellos)?;
    let tick_s = TICK_US as f64 / 1e6;
    let mut tick = 0u32;
    loop {
        let cut = |i: usize, k: u32| spec.kill.is_some_and(|(r, t)| r == i && k as f64 * tick_s >= t);
        for a in pending.drain(..) {
            let i = a.robot as usize;
            if !cut(i, tick) {
                bytes[i][1] += codec::encode_assignment(&a).len() as u64;
                robots[i].assign(&a);
            }
        }
        let order = coord.tick_msg(tick, false);
        let order_bytes = codec::encode_tick(&order).len() as u64;
        let mut statuses = Vec::with_capacity(spec.robots);
        for (i, r) in robots.iter_mut().enumerate() {
            if cut(i, tick) || !coord.alive(i) {
                statuses.push(None);
                continue;
            }
            bytes[i][1] += order_bytes;
            r.merge(&order.seen, &order.lidar);
            r.give_way(&order.goals, &order.positions);
            let s = r.step(tick);
            bytes[i][0] += codec::encode_status(&s).len() as u64;
            statuses.push(Some(s));
        }
        let d = coord.after_tick(tick, &statuses)?;
        pending = d.assignments;
        if d.stop {
            let stop_bytes = codec::encode_tick(&coord.tick_msg(tick + 1, true)).len() as u64;
            for (i, b) in bytes.iter_mut().enumerate() {
                if coord.alive(i) {
                    b[1] += stop_bytes;
                }
            }
            break;
        }
        tick += 1;
    }
    Ok(coord.result(spec, "in-process", &bytes))
}
