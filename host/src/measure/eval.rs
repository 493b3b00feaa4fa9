//! `lives eval` and `lives tune`: many simulated searches run in parallel and summarised.
//!
//! * [`run_batch`] runs a list of [`SearchSpec`]s on a fixed number of worker threads; the
//!   results come back in the order of the list, whatever the threads did, so a batch's output
//!   depends only on its specs.
//! * [`summarise`] groups results by planner, world and scenario: success rate, mean time to
//!   find with a failure counted as the time limit (as in the paper's Table I), its 95 %
//!   confidence interval (Student's t), and the mean path length.
//! * [`markdown_table`] lays the summary out like the paper's Table I (one row per setting, one
//!   column per planner, `mean s (success %)`); [`csv`] and the JSON form are for tools.
//! * [`tune`] scores parameter assignments on procedurally generated worlds only (never the
//!   built-in ones, which are the evaluation's unseen buildings).

use crate::run::LabelScore;
use crate::search::{self, PlannerChoice, SearchResult, SearchSpec};
use crate::sim::{Scenario, World};
use serde::Serialize;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Runs every spec (each to detection, exhaustion or its time limit) on `threads` workers.
/// `done` is called after each finished search with the number finished so far. A spec whose
/// model blob does not validate is an error naming it.
pub fn run_batch(specs: &[SearchSpec], threads: usize, done: impl Fn(usize) + Sync) -> Result<Vec<SearchResult>, String> {
    in_parallel(specs, threads, done, |spec| {
        search::try_run(spec, |_| {}).map(|run| run.result).map_err(|e| {
            format!("{} {} {} seed {}: the model does not validate: {e}", spec.world_name, spec.scenario_label(), spec.planner, spec.seed)
        })
    })
}

/// `run` on every job, `threads` at a time, the results in the jobs' order; `done` gets how
/// many have finished. The first error (in the jobs' order) is the result.
pub fn in_parallel<J: Sync, R: Send + Clone>(
    jobs: &[J],
    threads: usize,
    done: impl Fn(usize) + Sync,
    run: impl Fn(&J) -> Result<R, String> + Sync,
) -> Result<Vec<R>, String> {
    let next = AtomicUsize::new(0);
    let finished = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<Result<R, String>>>> = Mutex::new(vec![None; jobs.len()]);
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, jobs.len().max(1)) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(job) = jobs.get(i) else { break };
                let r = run(job);
                if let Ok(mut v) = slots.lock() {
                    v[i] = Some(r);
                }
                done(finished.fetch_add(1, Ordering::Relaxed) + 1);
            });
        }
    });
    let slots = slots.into_inner().map_err(|_| "a worker thread panicked".to_string())?;
    slots.into_iter().map(|r| r.unwrap_or_else(|| Err("a worker thread panicked".into()))).collect()
}

/// One planner in one setting, over its trials.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CellSummary {
    /// Planner name.
    pub planner: String,
    /// World name.
    pub world: String,
    /// `easy` or `hard`.
    pub scenario: String,
    /// Trials run.
    pub trials: usize,
    /// Trials that found the target.
    pub found: usize,
    /// `found / trials`.
    pub success_rate: f64,
    /// Mean time to find, a failure counted as the time limit (s).
    pub mean_time_s: f64,
    /// Half-width of the 95 % confidence interval of the mean (Student's t; 0 for one trial).
    pub ci95_s: f64,
    /// Mean distance driven (m).
    pub mean_path_m: f64,
    /// The setting's time limit (s).
    pub time_limit_s: f64,
    /// Trials in which the LiDAR saw a target ([`SearchResult::lidar_saw_target_s`]).
    pub lidar_sighted: usize,
    /// Mean time of the LiDAR's first sighting over those trials (s; NaN if none).
    pub mean_lidar_sighting_s: f64,
    /// Failed trials in which a target had been within the camera's reach
    /// ([`SearchResult::target_in_camera_reach_s`]): the camera did not look that way then (or
    /// saw too little of it). The other failures never came that close (the route's fault).
    pub missed_in_reach: usize,
    /// Every trial's time (s), in seed order (for plots).
    pub times_s: Vec<f64>,
    /// Trials with an oracle ([`SearchResult::oracle_s`]).
    pub oracle_trials: usize,
    /// Mean oracle time over them (s; NaN if none).
    pub mean_oracle_s: f64,
    /// Mean over them of time / oracle (a failure counted at the time limit; an oracle under one
    /// controller period counted as one period): 1 is the physical limit of the search.
    pub oracle_ratio: f64,
    /// Its 95 % confidence half-width.
    pub oracle_ratio_ci95: f64,
    /// The classifier's labels against the simulator's truth, pooled over the trials
    /// (`lives` on a classifier only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub labels: Option<LabelScore>,
}

/// The two-sided 97.5 % quantile of Student's t with `dof` degrees of freedom.
pub fn t975(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101,
        2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::NAN,
        1..=30 => T[dof - 1],
        31..=60 => 2.00,
        61..=120 => 1.98,
        _ => 1.96,
    }
}

/// Mean and 95 % confidence half-width of `xs` (half-width 0 for fewer than two values).
pub fn mean_ci(xs: &[f64]) -> (f64, f64) {
    let n = xs.len();
    if n == 0 {
        return (f64::NAN, 0.0);
    }
    let mean = xs.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, 0.0);
    }
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
    (mean, t975(n - 1) * (var / n as f64).sqrt())
}

/// Groups `results` by (planner, world, scenario), in order of first appearance.
pub fn summarise(results: &[SearchResult]) -> Vec<CellSummary> {
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for r in results {
        let k = (r.planner.clone(), r.world.clone(), r.scenario.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(planner, world, scenario)| {
            let rs: Vec<&SearchResult> =
                results.iter().filter(|r| r.planner == planner && r.world == world && r.scenario == scenario).collect();
            let times: Vec<f64> = rs.iter().map(|r| if r.found { r.time_s } else { r.time_limit_s }).collect();
            let (mean, ci) = mean_ci(&times);
            let found = rs.iter().filter(|r| r.found).count();
            let sightings: Vec<f64> = rs.iter().filter_map(|r| r.lidar_saw_target_s).collect();
            let scored: Vec<&LabelScore> = rs.iter().filter_map(|r| r.classifier.as_ref()).collect();
            let oracles: Vec<f64> = rs.iter().filter_map(|r| r.oracle_s).collect();
            let ratios: Vec<f64> = rs.iter().filter_map(|r| oracle_ratio(r)).collect();
            let (oracle_ratio, oracle_ratio_ci95) = mean_ci(&ratios);
            CellSummary {
                oracle_trials: oracles.len(),
                mean_oracle_s: mean_ci(&oracles).0,
                oracle_ratio,
                oracle_ratio_ci95,
                labels: (!scored.is_empty()).then(|| LabelScore::pooled(scored)),
                missed_in_reach: rs.iter().filter(|r| !r.found && r.target_in_camera_reach_s.is_some()).count(),
                lidar_sighted: sightings.len(),
                mean_lidar_sighting_s: mean_ci(&sightings).0,
                trials: rs.len(),
                found,
                success_rate: found as f64 / rs.len() as f64,
                mean_time_s: mean,
                ci95_s: ci,
                mean_path_m: rs.iter().map(|r| r.path_m).sum::<f64>() / rs.len() as f64,
                time_limit_s: rs.first().map_or(f64::NAN, |r| r.time_limit_s),
                times_s: times,
                planner,
                world,
                scenario,
            }
        })
        .collect()
}

/// A trial's time / its oracle: the time to find, a failure counted as the time limit, over the
/// oracle's time, at least one controller period (the first detection can come no sooner).
/// `None` without an oracle.
pub fn oracle_ratio(r: &SearchResult) -> Option<f64> {
    let tick = crate::run::TICK_US as f64 / 1e6;
    let t = if r.found { r.time_s } else { r.time_limit_s };
    r.oracle_s.map(|o| t / o.max(tick))
}

/// Fills in every result's [`SearchResult::oracle_s`] (`results[i]` is the run of `specs[i]`):
/// the oracle of its world, robot and seed ([`crate::sim::oracle::oracle`]), computed once for
/// all the planners that ran the same trial, on `threads` workers.
pub fn attach_oracles(specs: &[SearchSpec], results: &mut [SearchResult], threads: usize) {
    // The distinct trials: the oracle depends on the world, the simulated robot and the seed.
    let mut trials: Vec<usize> = Vec::new();
    let mut of: Vec<usize> = Vec::with_capacity(specs.len());
    for (i, s) in specs.iter().enumerate() {
        let same = |&j: &usize| {
            let t: &SearchSpec = &specs[j];
            t.seed == s.seed && t.world_name == s.world_name && t.scenario == s.scenario && t.sim == s.sim && t.world == s.world
        };
        match trials.iter().position(same) {
            Some(k) => of.push(k),
            None => {
                of.push(trials.len());
                trials.push(i);
            }
        }
    }
    let next = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<f64>>> = Mutex::new(vec![None; trials.len()]);
    std::thread::scope(|sc| {
        for _ in 0..threads.clamp(1, trials.len().max(1)) {
            sc.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&i) = trials.get(k) else { break };
                let o = crate::sim::oracle::oracle(&specs[i].world, &specs[i].sim, specs[i].seed).map(|o| o.time_s);
                if let Ok(mut v) = slots.lock() {
                    v[k] = o;
                }
            });
        }
    });
    let slots = slots.into_inner().unwrap_or_default();
    for (r, k) in results.iter_mut().zip(of) {
        r.oracle_s = slots.get(k).copied().flatten();
    }
}

/// The world name of the held-out procedural set's rows.
pub const HELDOUT_WORLD: &str = "heldout";
/// The first seed of the held-out procedural worlds. Seeds
/// `HELDOUT_FIRST_SEED..HELDOUT_FIRST_SEED + HELDOUT_MAX_WORLDS` are reserved for `lives eval
/// --heldout` and refused by `lives tune` and `lives dataset`: no parameter or classifier is
/// chosen on them. (Tuning has used worlds 1–384, the datasets 1–1200.)
pub const HELDOUT_FIRST_SEED: u64 = 1_000_001;
/// How many held-out worlds there can be.
pub const HELDOUT_MAX_WORLDS: u64 = 1000;

/// Does the seed range `first..=last` overlap the held-out seeds?
pub fn overlaps_heldout(first: u64, last: u64) -> bool {
    first < HELDOUT_FIRST_SEED + HELDOUT_MAX_WORLDS && last >= HELDOUT_FIRST_SEED
}

/// The specs of the held-out set: `n` procedural worlds, seeds `HELDOUT_FIRST_SEED..+n`, one
/// trial each (simulator seed = world seed), every planner. World `k` (from 0) is generated in
/// `easy` for even `k` and `hard` for odd `k` (`World::random_scenario`), so the set gives two
/// rows, `heldout easy` and `heldout hard`, of `n / 2` worlds each (the extra one easy).
/// `from` skips the first `from` worlds (a second held-out set, never looked at by a run of the
/// first: worlds `from..from + n`, each the same world and scenario whatever `from` is).
pub fn heldout_specs(
    from: u64,
    n: u64,
    planners: &[PlannerChoice],
    model: &'static [u8],
    configure: impl Fn(&mut SearchSpec) -> Result<(), String>,
) -> Result<Vec<SearchSpec>, String> {
    if from.checked_add(n).is_none_or(|end| end > HELDOUT_MAX_WORLDS) {
        return Err(format!("--heldout-from {from} --heldout {n}: the held-out worlds are the first {HELDOUT_MAX_WORLDS}"));
    }
    let mut specs = Vec::new();
    for k in from..from + n {
        let seed = HELDOUT_FIRST_SEED + k;
        let scenario = if k % 2 == 0 { Scenario::Easy } else { Scenario::Hard };
        let world = World::random_scenario(seed, scenario);
        for &p in planners {
            let mut spec = planner_spec(HELDOUT_WORLD, &world, scenario, p, seed, model);
            configure(&mut spec)?;
            specs.push(spec);
        }
    }
    Ok(specs)
}

/// The summary shaped like the paper's Table I: a row per setting, a column per planner, each
/// entry `mean s (success %)`; then the same cells in detail (CI and path length).
pub fn markdown_table(cells: &[CellSummary]) -> String {
    let mut planners: Vec<&str> = Vec::new();
    for c in cells {
        if !planners.contains(&c.planner.as_str()) {
            planners.push(&c.planner);
        }
    }
    let settings = settings_of(cells);
    let find = |p: &str, w: &str, s: &str| cells.iter().find(|c| c.planner == p && c.world == w && c.scenario == s);
    let mut out = String::new();
    out.push_str(&format!("| setting | limit | {} |\n", planners.join(" | ")));
    out.push_str(&format!("|---|---|{}\n", "---|".repeat(planners.len())));
    for (w, s, limit) in &settings {
        let entries: Vec<String> = planners
            .iter()
            .map(|p| match find(p, w, s) {
                Some(c) => format!("{:.1} ({:.0} %)", c.mean_time_s, 100.0 * c.success_rate),
                None => "—".into(),
            })
            .collect();
        let limit = if *w == HELDOUT_WORLD { "per world".to_string() } else { format!("{limit:.0} s") };
        out.push_str(&format!("| {w} {s} | {limit} | {} |\n", entries.join(" | ")));
    }
    out.push_str("\nMean time to find in seconds (a failure counts as the time limit) and success rate.\n");
    if cells.iter().any(|c| c.oracle_trials > 0) {
        out.push_str(&format!("\n| setting | oracle, mean | {} |\n", planners.join(" | ")));
        out.push_str(&format!("|---|---|{}\n", "---|".repeat(planners.len())));
        for (w, s, _) in &settings {
            let oracle = planners.iter().find_map(|p| find(p, w, s)).filter(|c| c.oracle_trials > 0).map(|c| c.mean_oracle_s);
            let entries: Vec<String> = planners
                .iter()
                .map(|p| match find(p, w, s) {
                    Some(c) if c.oracle_trials > 0 => format!("{:.2} ± {:.2}", c.oracle_ratio, c.oracle_ratio_ci95),
                    _ => "—".into(),
                })
                .collect();
            let oracle = oracle.map_or("—".into(), |o| format!("{o:.1} s"));
            out.push_str(&format!("| {w} {s} | {oracle} | {} |\n", entries.join(" | ")));
        }
        out.push_str(
            "\nMean time to find over the oracle's time (± its 95 % CI), per trial: the oracle walks the shortest path on the true \
             world's free space (inflated by the body's radius) to the nearest pose from which the simulator's detector sees the \
             target, at the robot's top speed, turning to face it at its top turn rate on the way (the longer of the two; \
             `host/sim/src/oracle.rs`). A failure counts at the time limit. 1 is the physical limit of the search.\n",
        );
    }
    out.push('\n');
    out.push_str(
        "| planner | setting | trials | found | mean time (s) | 95 % CI (s) | mean path (m) | LiDAR saw the target | its first sighting, mean (s) | missed within camera reach | classifier: right / non-map found | time / oracle |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for c in cells {
        let sighting = if c.lidar_sighted > 0 { format!("{:.1}", c.mean_lidar_sighting_s) } else { "—".into() };
        let labels = c.labels.map_or("—".into(), |l| format!("{:.1} % / {:.1} %", 100.0 * l.accuracy, 100.0 * l.nonmap_recall));
        let ratio = if c.oracle_trials > 0 { format!("{:.2}", c.oracle_ratio) } else { "—".into() };
        out.push_str(&format!(
            "| {} | {} {} | {} | {} | {:.1} | ± {:.1} | {:.1} | {} | {} | {} | {labels} | {ratio} |\n",
            c.planner,
            c.world,
            c.scenario,
            c.trials,
            c.found,
            c.mean_time_s,
            c.ci95_s,
            c.mean_path_m,
            c.lidar_sighted,
            sighting,
            c.missed_in_reach
        ));
    }
    out.push_str(
        "\nThe three columns after the mean path: in how many trials the LiDAR had a target in view (3 or more beams on it in one scan) and, over \
         those, when it first did (the camera's detection came at the mean time, or never); and how many failed trials had the \
         target within the camera's reach at some time (3 or more beams on it, none farther than the camera's range): the \
         camera did not look that way then, or saw too little of it. The other failures never came that close. The last: for \
         `lives` on its classifier, the share of beams it labelled as the simulator's truth does, and the share of the true \
         non-map beams it labelled non-map, over every scan of every trial.\n",
    );
    out
}

/// The (world, scenario, time limit) settings of `cells`, in order of first appearance.
fn settings_of(cells: &[CellSummary]) -> Vec<(&str, &str, f64)> {
    let mut settings: Vec<(&str, &str, f64)> = Vec::new();
    for c in cells {
        if !settings.iter().any(|s| s.0 == c.world && s.1 == c.scenario) {
            settings.push((&c.world, &c.scenario, c.time_limit_s));
        }
    }
    settings
}

/// The paper's claims for LIVES (issue 7's acceptance), checked on `results` for `lives` and
/// `lives-gt`: 100 % success in every setting; mean time over the hard settings against
/// `multisensor` (the ratio of the averages, and the paired difference over the same trials:
/// same world, scenario and seed, so the same start, target, people and noise); and faster than
/// `nearest` and `explore-lite` in every setting. `None` unless `multisensor` and at least one
/// of the two LIVES planners were run.
pub fn claims(results: &[SearchResult]) -> Option<String> {
    // The paper's claims are about its buildings: the held-out procedural rows are reported, not
    // checked here.
    let builtin: Vec<SearchResult> = results.iter().filter(|r| r.world != HELDOUT_WORLD).cloned().collect();
    let results = &builtin[..];
    let cells = summarise(results);
    let has = |p: &str| results.iter().any(|r| r.planner == p);
    let subjects: Vec<&str> = ["lives", "lives-gt"].into_iter().filter(|p| has(p)).collect();
    if subjects.is_empty() || !has("multisensor") {
        return None;
    }
    let settings: Vec<(&str, &str)> = settings_of(&cells).into_iter().map(|(w, s, _)| (w, s)).collect();
    let cell = |p: &str, w: &str, s: &str| cells.iter().find(|c| c.planner == p && c.world == w && c.scenario == s);
    let hard: Vec<(&str, &str)> = settings.iter().copied().filter(|s| s.1 == "hard").collect();
    let mut rows: [Vec<String>; 3] = Default::default();
    for &p in &subjects {
        let short: Vec<String> = settings
            .iter()
            .filter_map(|&(w, s)| cell(p, w, s).filter(|c| c.found < c.trials).map(|c| format!("{w} {s} {}/{}", c.found, c.trials)))
            .collect();
        rows[0].push(if short.is_empty() { "yes".into() } else { format!("no: {}", short.join(", ")) });
        // Over the hard settings: ratio of the averaged means, and the paired difference per trial.
        let avg = |q: &str| {
            let v: Vec<f64> = hard.iter().filter_map(|&(w, s)| cell(q, w, s).map(|c| c.mean_time_s)).collect();
            (v.len() == hard.len() && !v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        let diffs: Vec<f64> = results
            .iter()
            .filter(|r| r.planner == p && r.scenario == "hard")
            .filter_map(|r| {
                results
                    .iter()
                    .find(|m| m.planner == "multisensor" && m.world == r.world && m.scenario == r.scenario && m.seed == r.seed)
                    .map(|m| r.time_s - m.time_s)
            })
            .collect();
        rows[1].push(match (avg(p), avg("multisensor")) {
            (Some(a), Some(b)) if b > 0.0 => {
                let (d, ci) = mean_ci(&diffs);
                format!("{:.3}× ({a:.1} s vs {b:.1} s; paired Δ {d:+.1} ± {ci:.1} s over {} trials)", a / b, diffs.len())
            }
            _ => "— (no hard settings run)".into(),
        });
        let mut behind = Vec::new();
        let mut compared = 0;
        for &(w, s) in &settings {
            let Some(me) = cell(p, w, s) else { continue };
            for base in ["nearest", "explore-lite"] {
                if let Some(b) = cell(base, w, s) {
                    compared += 1;
                    if me.mean_time_s >= b.mean_time_s {
                        behind.push(format!("{w} {s} vs {base} ({:.1} ≥ {:.1} s)", me.mean_time_s, b.mean_time_s));
                    }
                }
            }
        }
        rows[2].push(match (compared, behind.is_empty()) {
            (0, _) => "— (nearest and explore-lite not run)".into(),
            (_, true) => "yes".into(),
            (_, false) => format!("no, {} of {compared}: {}", behind.len(), behind.join("; ")),
        });
    }
    let mut out = String::from("\n## Against the paper's claims for LIVES\n\n");
    out.push_str(&format!("| claim | {} |\n|---|{}\n", subjects.join(" | "), "---|".repeat(subjects.len())));
    let names = [
        "100 % success in every setting",
        "mean time over the hard settings vs `multisensor` (the claim: at most 0.85×)",
        "faster than `nearest` and `explore-lite` in every setting",
    ];
    for (name, row) in names.iter().zip(&rows) {
        out.push_str(&format!("| {name} | {} |\n", row.join(" | ")));
    }
    Some(out)
}

/// The summary as CSV (one line per planner and setting).
pub fn csv(cells: &[CellSummary]) -> String {
    let mut out = String::from(
        "planner,world,scenario,trials,found,success_rate,mean_time_s,ci95_s,mean_path_m,time_limit_s,lidar_sighted,mean_lidar_sighting_s,missed_in_reach,classifier_accuracy,classifier_nonmap_recall,oracle_trials,mean_oracle_s,oracle_ratio,oracle_ratio_ci95\n",
    );
    for c in cells {
        let sighting = if c.lidar_sighted > 0 { format!("{:.3}", c.mean_lidar_sighting_s) } else { String::new() };
        let (acc, recall) =
            c.labels.map_or((String::new(), String::new()), |l| (format!("{:.4}", l.accuracy), format!("{:.4}", l.nonmap_recall)));
        let oracle = if c.oracle_trials > 0 {
            format!("{},{:.3},{:.4},{:.4}", c.oracle_trials, c.mean_oracle_s, c.oracle_ratio, c.oracle_ratio_ci95)
        } else {
            "0,,,".into()
        };
        out.push_str(&format!(
            "{},{},{},{},{},{:.4},{:.3},{:.3},{:.3},{:.1},{},{},{},{acc},{recall},{oracle}\n",
            c.planner,
            c.world,
            c.scenario,
            c.trials,
            c.found,
            c.success_rate,
            c.mean_time_s,
            c.ci95_s,
            c.mean_path_m,
            c.time_limit_s,
            c.lidar_sighted,
            sighting,
            c.missed_in_reach
        ));
    }
    out
}

/// The specs of an evaluation: every planner × world × scenario × trial (seeds `1..=trials`);
/// a world file (`.toml`, or any path that exists) is one setting of its own, whatever the
/// scenarios (it holds its own). `lives` runs the int8 classifier (`model`); the others their own label source.
pub fn eval_specs(
    worlds: &[String],
    scenarios: &[Scenario],
    planners: &[PlannerChoice],
    trials: u64,
    model: &'static [u8],
    configure: impl Fn(&mut SearchSpec) -> Result<(), String>,
) -> Result<Vec<SearchSpec>, String> {
    let mut specs = Vec::new();
    for w in worlds {
        let builtin = World::builtin_names().contains(&w.as_str());
        if !builtin && (w.ends_with(".toml") || std::path::Path::new(w).exists()) {
            // A world file holds its own scenario: one setting, named as the file names it.
            let world = World::load(std::path::Path::new(w)).map_err(|e| e.to_string())?;
            for &p in planners {
                for seed in 1..=trials {
                    let mut spec = planner_spec(&world.name, &world, Scenario::Easy, p, seed, model);
                    spec.scenario = None;
                    configure(&mut spec)?;
                    specs.push(spec);
                }
            }
            continue;
        }
        for &s in scenarios {
            let world = World::builtin(w, s).ok_or_else(|| {
                format!("unknown built-in world `{w}` (expected {}, or a world file .toml)", World::builtin_names().join(", "))
            })?;
            for &p in planners {
                for seed in 1..=trials {
                    let mut spec = planner_spec(w, &world, s, p, seed, model);
                    configure(&mut spec)?;
                    specs.push(spec);
                }
            }
        }
    }
    Ok(specs)
}

/// Planner `p`'s search of `world` (named `name`, loaded in `scenario`) with `seed`, on the
/// classifier `model` when `p` runs one.
fn planner_spec(name: &str, world: &World, scenario: Scenario, p: PlannerChoice, seed: u64, model: &'static [u8]) -> SearchSpec {
    let mut spec = SearchSpec::new(name, world.clone(), scenario, p, seed);
    if p.uses_classifier() {
        spec.model = Some(model);
    }
    spec
}

/// One parameter assignment's score in [`tune`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TuneScore {
    /// The `--set` assignments.
    pub sets: Vec<String>,
    /// Mean over worlds (and planners) of time to find / time limit (failures count 1).
    pub mean_normalised_time: f64,
    /// Its 95 % confidence half-width.
    pub ci95: f64,
    /// Fraction of searches that found the target.
    pub success_rate: f64,
    /// Searches run.
    pub searches: usize,
    /// Mean over the same searches of (this assignment's normalised time − the defaults'): a
    /// paired difference, negative when this assignment is faster. Pairing removes the spread
    /// between worlds, so it resolves differences the unpaired [`TuneScore::ci95`] cannot.
    pub vs_defaults: f64,
    /// Its 95 % confidence half-width (Student's t over the paired differences).
    pub vs_defaults_ci95: f64,
    /// Every search's time to find / limit (failures 1), in the order seed, scenario, planner:
    /// for pairing with another `lives tune` run over the same worlds.
    pub per_search: Vec<f64>,
}

/// Every combination of the grid's values: `[("a", ["1","2"]), ("b", ["x"])]` →
/// `[["a=1","b=x"], ["a=2","b=x"]]`.
pub fn grid_assignments(grid: &[(String, Vec<String>)]) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = vec![Vec::new()];
    for (name, values) in grid {
        out = out.iter().flat_map(|prefix| values.iter().map(move |v| [prefix.clone(), vec![format!("{name}={v}")]].concat())).collect();
    }
    out
}

/// Parses `name=v1,v2,...`.
pub fn parse_grid_axis(s: &str) -> Result<(String, Vec<String>), String> {
    let (name, values) = s.split_once('=').ok_or_else(|| format!("`--grid {s}`: expected name=v1,v2,..."))?;
    let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).filter(|v| !v.is_empty()).collect();
    if values.is_empty() {
        return Err(format!("`--grid {s}`: no values"));
    }
    Ok((name.trim().to_string(), values))
}

/// Scores every assignment of `grid` with `planners` on procedurally generated worlds
/// (`World::random_scenario(seed, s)` for `seeds` × `scenarios`), best (lowest mean normalised
/// time) first. The defaults (no `--set`, sets empty) are always scored as well, first in the
/// run, and every score carries its paired difference to them. `lives` runs on `model` (the
/// classifier's blob), as in [`eval_specs`].
#[allow(clippy::too_many_arguments)]
pub fn tune(
    grid: &[(String, Vec<String>)],
    planners: &[PlannerChoice],
    scenarios: &[Scenario],
    seeds: std::ops::RangeInclusive<u64>,
    threads: usize,
    model: &'static [u8],
    done: impl Fn(usize, usize) + Sync,
) -> Result<Vec<TuneScore>, String> {
    let mut assignments = grid_assignments(grid);
    assignments.insert(0, Vec::new());
    let mut specs = Vec::new();
    for sets in &assignments {
        for seed in seeds.clone() {
            for &scenario in scenarios {
                let world = World::random_scenario(seed, scenario);
                for &p in planners {
                    let mut spec = planner_spec(&format!("random-{seed}"), &world, scenario, p, seed, model);
                    for a in sets {
                        crate::overrides::apply(&mut spec.controller, a)?;
                    }
                    specs.push(spec);
                }
            }
        }
    }
    let total = specs.len();
    let results = run_batch(&specs, threads, |n| done(n, total))?;
    let per = results.len() / assignments.len().max(1);
    let normalised =
        |rs: &[SearchResult]| -> Vec<f64> { rs.iter().map(|r| if r.found { r.time_s / r.time_limit_s } else { 1.0 }).collect() };
    let base = normalised(&results[..per.min(results.len())]);
    let mut scores: Vec<TuneScore> = assignments
        .into_iter()
        .zip(results.chunks(per.max(1)))
        .map(|(sets, rs)| {
            let xs = normalised(rs);
            let (m, ci) = mean_ci(&xs);
            let diffs: Vec<f64> = xs.iter().zip(&base).map(|(x, b)| x - b).collect();
            let (d, dci) = mean_ci(&diffs);
            TuneScore {
                sets,
                mean_normalised_time: m,
                ci95: ci,
                success_rate: rs.iter().filter(|r| r.found).count() as f64 / rs.len() as f64,
                searches: rs.len(),
                vs_defaults: d,
                vs_defaults_ci95: dci,
                per_search: xs,
            }
        })
        .collect();
    scores.sort_by(|a, b| a.mean_normalised_time.total_cmp(&b.mean_normalised_time));
    Ok(scores)
}

/// Gives every spec its world's true map (computed once per world; `lives eval --known-map`).
pub fn give_true_maps(specs: &mut [SearchSpec]) -> Result<(), String> {
    let mut cache: Vec<(World, std::sync::Arc<Vec<crate::io::map_file::Cell3>>)> = Vec::new();
    for spec in specs.iter_mut() {
        let cells = match cache.iter().find(|(w, _)| *w == spec.world) {
            Some((_, c)) => c.clone(),
            None => {
                let cfg = crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind());
                let c = std::sync::Arc::new(crate::live::true_map_cells(&spec.world, &cfg)?);
                cache.push((spec.world.clone(), c.clone()));
                c
            }
        };
        spec.prior_map = Some(cells);
    }
    Ok(())
}

#[cfg(test)]
mod tests;
