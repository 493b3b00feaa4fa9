//! `lives eval --robots 1,2,3`: teams of each size over the same settings and seeds, in
//! process ([`super::local`]), and the table of their times against one robot's.

use super::{local, TeamResult, TeamSpec};
use crate::search::SearchSpec;
use serde::Serialize;

/// Runs a team of each size in `robots` on every spec, `threads` at a time.
pub fn run_batch(specs: &[SearchSpec], robots: &[usize], threads: usize, done: impl Fn(usize) + Sync) -> Result<Vec<TeamResult>, String> {
    let jobs: Vec<TeamSpec> = specs.iter().flat_map(|s| robots.iter().map(|&n| TeamSpec::new(s.clone(), n))).collect();
    crate::measure::eval::in_parallel(&jobs, threads, done, |job| {
        local::run(job).map_err(|e| format!("{} {} seed {}: {e}", job.base.world_name, job.base.scenario_label(), job.base.seed))
    })
}

/// One team size in one setting, over its trials.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TeamCell {
    pub world: String,
    pub scenario: String,
    pub planner: String,
    pub map: String,
    pub robots: usize,
    pub trials: usize,
    pub found: usize,
    /// Mean time to find, a failure counted as the limit, seconds.
    pub mean_time_s: f64,
    /// That over one robot's in the same setting (same seeds).
    pub vs_one: Option<f64>,
    /// Mean path per robot, metres.
    pub path_per_robot_m: f64,
    /// Mean payload bytes per robot and simulated second, up (statuses) and down (orders,
    /// assignments).
    pub up_bps: f64,
    pub down_bps: f64,
    pub stale_goals: u32,
}

/// The cells of `results`, in the order met.
pub fn summarise(results: &[TeamResult]) -> Vec<TeamCell> {
    let key = |r: &TeamResult| (r.world.clone(), r.scenario.clone(), r.planner.clone(), r.map.clone(), r.robots);
    let mut keys: Vec<_> = Vec::new();
    for r in results {
        if !keys.contains(&key(r)) {
            keys.push(key(r));
        }
    }
    let mut cells: Vec<TeamCell> = keys
        .iter()
        .map(|k| {
            let rs: Vec<&TeamResult> = results.iter().filter(|r| key(r) == *k).collect();
            let n = rs.len().max(1) as f64;
            let per_robot = |f: &dyn Fn(&super::RobotReport) -> f64| {
                rs.iter().map(|r| r.per_robot.iter().map(f).sum::<f64>() / r.per_robot.len().max(1) as f64).sum::<f64>() / n
            };
            TeamCell {
                world: k.0.clone(),
                scenario: k.1.clone(),
                planner: k.2.clone(),
                map: k.3.clone(),
                robots: k.4,
                trials: rs.len(),
                found: rs.iter().filter(|r| r.found).count(),
                mean_time_s: crate::run::round3(rs.iter().map(|r| r.time_s).sum::<f64>() / n),
                vs_one: None,
                path_per_robot_m: crate::run::round3(per_robot(&|p| p.path_m)),
                up_bps: crate::run::round3(per_robot(&|p| p.up_bps)),
                down_bps: crate::run::round3(per_robot(&|p| p.down_bps)),
                stale_goals: rs.iter().map(|r| r.stale_goals).sum(),
            }
        })
        .collect();
    let ones: Vec<TeamCell> = cells.iter().filter(|c| c.robots == 1).cloned().collect();
    for c in &mut cells {
        if let Some(one) = ones.iter().find(|o| o.world == c.world && o.scenario == c.scenario && o.planner == c.planner && o.map == c.map)
        {
            c.vs_one = (one.mean_time_s > 0.0).then(|| crate::run::round3(c.mean_time_s / one.mean_time_s));
        }
    }
    cells
}

/// The Markdown table of `cells`, then a line per planner and team size pooled over the
/// settings (mean time over the pooled trials against one robot's).
pub fn markdown_table(cells: &[TeamCell]) -> String {
    let mut s = String::from(
        "| world | scenario | planner | map | robots | found | mean time (s) | × one robot | path per robot (m) | up (B/s per robot) | down (B/s per robot) | stale goals |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for c in cells {
        s += &format!(
            "| {} | {} | {} | {} | {} | {}/{} | {:.1} | {} | {:.1} | {:.0} | {:.0} | {} |\n",
            c.world,
            c.scenario,
            c.planner,
            c.map,
            c.robots,
            c.found,
            c.trials,
            c.mean_time_s,
            c.vs_one.map_or("—".to_string(), |v| format!("{v:.2}")),
            c.path_per_robot_m,
            c.up_bps,
            c.down_bps,
            c.stale_goals
        );
    }
    s += "\nPooled over the settings (mean time, a failure counted as the limit):\n\n| planner | map | robots | found | mean time (s) | × one robot |\n|---|---|---|---|---|---|\n";
    let mut groups: Vec<(String, String, usize)> = Vec::new();
    for c in cells {
        let g = (c.planner.clone(), c.map.clone(), c.robots);
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    let pooled = |g: &(String, String, usize)| {
        let cs: Vec<&TeamCell> = cells.iter().filter(|c| c.planner == g.0 && c.map == g.1 && c.robots == g.2).collect();
        let trials: usize = cs.iter().map(|c| c.trials).sum();
        let found: usize = cs.iter().map(|c| c.found).sum();
        let mean = cs.iter().map(|c| c.mean_time_s * c.trials as f64).sum::<f64>() / trials.max(1) as f64;
        (trials, found, mean)
    };
    for g in &groups {
        let (trials, found, mean) = pooled(g);
        let one = pooled(&(g.0.clone(), g.1.clone(), 1));
        let vs = if one.0 > 0 && one.2 > 0.0 { format!("{:.2}", mean / one.2) } else { "—".into() };
        s += &format!("| {} | {} | {} | {found}/{trials} | {mean:.1} | {vs} |\n", g.0, g.1, g.2);
    }
    s
}
