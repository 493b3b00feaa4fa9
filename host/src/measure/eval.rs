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
pub fn heldout_specs(
    n: u64,
    planners: &[PlannerChoice],
    model: &'static [u8],
    configure: impl Fn(&mut SearchSpec) -> Result<(), String>,
) -> Result<Vec<SearchSpec>, String> {
    if n > HELDOUT_MAX_WORLDS {
        return Err(format!("--heldout: at most {HELDOUT_MAX_WORLDS} worlds"));
    }
    let mut specs = Vec::new();
    for k in 0..n {
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

/// The specs of an evaluation: every planner × world × scenario × trial (seeds `1..=trials`).
/// `lives` runs the int8 classifier (`model`); the others their own label source.
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
        for &s in scenarios {
            let world = World::builtin(w, s)
                .ok_or_else(|| format!("unknown built-in world `{w}` (expected {})", World::builtin_names().join(", ")))?;
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
mod tests {
    use super::*;

    fn result(planner: &str, found: bool, t: f64) -> SearchResult {
        SearchResult {
            world: "apartment".into(),
            scenario: "easy".into(),
            planner: planner.into(),
            seed: 1,
            found,
            time_s: if found { t } else { 120.0 },
            path_m: 10.0,
            ticks: 1,
            time_limit_s: 120.0,
            outcome: if found { "found" } else { "time-limit" }.into(),
            goals: 1,
            blacklisted: 0,
            blocked: 0,
            collisions: 0,
            labels: "none".into(),
            targets: vec![],
            motion: None,
            lidar_saw_target_s: None,
            target_in_camera_reach_s: None,
            classifier: None,
            sim: None,
            oracle_s: None,
            live: None,
        }
    }

    #[test]
    fn failures_count_as_the_limit_and_the_ci_uses_students_t() {
        let mut rs = [result("a", true, 30.0), result("a", false, 0.0), result("a", true, 60.0), result("b", true, 10.0)];
        rs[0].lidar_saw_target_s = Some(5.0);
        rs[1].lidar_saw_target_s = Some(8.0);
        // Trial 2 failed with the target once within the camera's reach; trial 1 found it.
        rs[0].target_in_camera_reach_s = Some(20.0);
        rs[1].target_in_camera_reach_s = Some(9.0);
        // Two of `a`'s trials scored a classifier: 14 beams pooled, 9 right, 2 of 4 non-map found.
        rs[0].classifier = Some(LabelScore::from_confusion([[5, 1], [1, 1]]));
        rs[2].classifier = Some(LabelScore::from_confusion([[2, 2], [1, 1]]));
        let cells = summarise(&rs);
        assert_eq!(cells.len(), 2);
        let a = &cells[0];
        assert_eq!((a.trials, a.found), (3, 2));
        assert!((a.mean_time_s - 70.0).abs() < 1e-9);
        // sd of [30, 120, 60] = 45.83; t(2) = 4.303; 4.303 · 45.83 / √3 = 113.85
        assert!((a.ci95_s - 113.85).abs() < 0.05, "{}", a.ci95_s);
        assert_eq!(cells[1].ci95_s, 0.0);
        let md = markdown_table(&cells);
        assert!(md.contains("| apartment easy | 120 s | 70.0 (67 %) | 10.0 (100 %) |"), "{md}");
        assert!(csv(&cells).lines().nth(1).unwrap().starts_with("a,apartment,easy,3,2,0.6667,70.000"));
        // The LiDAR sighting: 2 of 3 trials, mean 6.5 s; none in `b`.
        assert_eq!((a.lidar_sighted, a.mean_lidar_sighting_s), (2, 6.5));
        assert_eq!((a.missed_in_reach, cells[1].missed_in_reach), (1, 0));
        assert!(md.contains("| 2 | 6.5 | 1 | 64.3 % / 50.0 % |") && md.contains("| 0 | — | 0 | — |"), "{md}");
        assert!(csv(&cells).lines().nth(1).unwrap().ends_with(",2,6.500,1,0.6429,0.5000,0,,,"));
        assert!(csv(&cells).lines().nth(2).unwrap().ends_with(",0,,0,,,0,,,"));
        assert!(!md.contains("oracle, mean"), "no oracle table without oracles");
        // The classifier's score pools the beams of the trials that have one.
        assert_eq!(a.labels.map(|l| l.beams), Some(14));
        assert_eq!(cells[1].labels, None);
    }

    #[test]
    fn the_oracle_ratio_counts_failures_at_the_limit_and_floors_the_oracle_at_a_tick() {
        let mut rs = [result("a", true, 30.0), result("a", false, 0.0), result("a", true, 1.0), result("b", true, 10.0)];
        rs[0].oracle_s = Some(10.0); // 30 / 10 = 3
        rs[1].oracle_s = Some(60.0); // a failure: the limit 120 / 60 = 2
        rs[2].oracle_s = Some(0.0); // seen from the start: 1 / 0.2 = 5
        let cells = summarise(&rs);
        let a = &cells[0];
        assert_eq!(a.oracle_trials, 3);
        assert!((a.oracle_ratio - 10.0 / 3.0).abs() < 1e-12, "{}", a.oracle_ratio);
        assert!((a.mean_oracle_s - 70.0 / 3.0).abs() < 1e-12);
        assert_eq!((cells[1].oracle_trials, cells[1].oracle_ratio.is_nan()), (0, true));
        let md = markdown_table(&cells);
        assert!(md.contains("| setting | oracle, mean | a | b |"), "{md}");
        assert!(md.contains("| apartment easy | 23.3 s | 3.33 ± "), "{md}");
        assert!(md.contains(" | — |\n"), "{md}");
        assert!(csv(&cells).lines().nth(1).unwrap().ends_with(",3,23.333,3.3333,3.7949"), "{}", csv(&cells));
    }

    #[test]
    fn oracles_are_computed_once_per_trial_and_shared_by_the_planners() {
        // Two planners, two seeds on one small world: four results, two oracles.
        let world = World::random_scenario(3, Scenario::Easy);
        let specs: Vec<SearchSpec> = [PlannerChoice::Nearest, PlannerChoice::Multisensor]
            .into_iter()
            .flat_map(|p| (1..=2).map(move |seed| (p, seed)))
            .map(|(p, seed)| SearchSpec::new("random-3", world.clone(), Scenario::Easy, p, seed))
            .collect();
        let mut rs: Vec<SearchResult> = specs.iter().map(|_| result("x", true, 5.0)).collect();
        attach_oracles(&specs, &mut rs, 2);
        let o: Vec<f64> = rs.iter().map(|r| r.oracle_s.expect("every trial has one")).collect();
        assert_eq!((o[0], o[1]), (o[2], o[3]), "the same trial, the same oracle, whatever the planner");
        let direct = crate::sim::oracle::oracle(&specs[1].world, &specs[1].sim, 2).unwrap().time_s;
        assert_eq!(o[1], direct);
        assert!(o.iter().all(|&t| t >= 0.0 && t < world.time_limit_s), "{o:?}");
    }

    #[test]
    fn heldout_seeds_are_disjoint_from_tunes_and_split_into_easy_and_hard() {
        // `lives tune` has used worlds 1-384 and refuses the held-out range (cli/tune.rs); the
        // datasets 1-1200.
        assert!(!overlaps_heldout(1, 384) && !overlaps_heldout(1, 1200));
        assert!(overlaps_heldout(1, HELDOUT_FIRST_SEED) && overlaps_heldout(HELDOUT_FIRST_SEED + 999, u64::MAX));
        assert!(!overlaps_heldout(HELDOUT_FIRST_SEED + HELDOUT_MAX_WORLDS, u64::MAX));
        // The default tune range (`--worlds 48 --first-world 1`) is outside.
        assert!(!overlaps_heldout(1, 48));
        let specs = heldout_specs(5, &[PlannerChoice::Nearest, PlannerChoice::Lives], firmware::classifier::EMBEDDED_GEO_MODEL, |_| Ok(()))
            .unwrap();
        assert_eq!(specs.len(), 10);
        let seeds: Vec<u64> = specs.iter().step_by(2).map(|s| s.seed).collect();
        assert_eq!(seeds, (HELDOUT_FIRST_SEED..HELDOUT_FIRST_SEED + 5).collect::<Vec<_>>());
        let scen: Vec<&str> = specs.iter().step_by(2).map(|s| s.scenario_label()).collect();
        assert_eq!(scen, ["easy", "hard", "easy", "hard", "easy"]);
        assert!(specs.iter().all(|s| s.world_name == HELDOUT_WORLD));
        assert_eq!(specs[0].world, World::random_scenario(HELDOUT_FIRST_SEED, Scenario::Easy));
        assert!(specs[1].model.is_some() && specs[0].model.is_none(), "lives runs the classifier");
        assert!(heldout_specs(HELDOUT_MAX_WORLDS + 1, &[PlannerChoice::Nearest], &[], |_| Ok(())).is_err());
    }

    #[test]
    fn tune_scores_the_defaults_and_pairs_every_assignment_with_them() {
        // `w_dist_per_m=1` is the default: the same searches, so a paired difference of exactly 0.
        let grid = vec![parse_grid_axis("w_dist_per_m=1,8").unwrap()];
        let scores =
            tune(&grid, &[PlannerChoice::Multisensor], &Scenario::ALL, 1..=2, 2, firmware::classifier::EMBEDDED_GEO_MODEL, |_, _| {})
                .unwrap();
        assert_eq!(scores.len(), 3, "the defaults and the two grid values");
        assert!(scores.iter().all(|s| s.searches == 4), "2 worlds × 2 scenarios × 1 planner");
        for s in &scores {
            assert_eq!(s.per_search.len(), 4);
            assert!((s.per_search.iter().sum::<f64>() / 4.0 - s.mean_normalised_time).abs() < 1e-12);
            assert!(s.per_search.iter().all(|x| (0.0..=1.0).contains(x)));
        }
        let find = |sets: &[&str]| scores.iter().find(|s| s.sets == sets).unwrap();
        let (base, same, far) = (find(&[]), find(&["w_dist_per_m=1"]), find(&["w_dist_per_m=8"]));
        assert_eq!((base.vs_defaults, base.vs_defaults_ci95), (0.0, 0.0));
        assert_eq!(same.mean_normalised_time, base.mean_normalised_time);
        assert_eq!((same.vs_defaults, same.vs_defaults_ci95), (0.0, 0.0));
        let d = far.mean_normalised_time - base.mean_normalised_time;
        assert!((far.vs_defaults - d).abs() < 1e-12, "the mean of the differences is the difference of the means");
        assert!(scores.windows(2).all(|w| w[0].mean_normalised_time <= w[1].mean_normalised_time), "best first");
    }

    #[test]
    fn the_claims_are_checked_per_trial_against_the_same_seeds() {
        let mk = |planner: &str, scenario: &str, seed: u64, found: bool, t: f64| {
            let mut r = result(planner, found, t);
            r.scenario = scenario.into();
            r.seed = seed;
            if !found {
                r.time_s = if scenario == "hard" { 180.0 } else { 120.0 };
            }
            r.time_limit_s = r.time_s.max(r.time_limit_s);
            r
        };
        let rs = vec![
            mk("multisensor", "hard", 1, true, 100.0),
            mk("multisensor", "hard", 2, true, 120.0),
            mk("lives", "hard", 1, true, 80.0),
            mk("lives", "hard", 2, false, 0.0),
            mk("nearest", "hard", 1, true, 90.0),
            mk("nearest", "hard", 2, true, 90.0),
        ];
        let md = claims(&rs).expect("lives and multisensor ran");
        // lives: 1 of 2 found; hard mean (80 + 180) / 2 = 130 vs 110: 1.182×; paired −20 and +60.
        assert!(md.contains("| 100 % success in every setting | no: apartment hard 1/2 |"), "{md}");
        assert!(md.contains("1.182× (130.0 s vs 110.0 s; paired Δ +20.0 ± "), "{md}");
        assert!(md.contains("over 2 trials"), "{md}");
        assert!(md.contains("no, 1 of 1: apartment hard vs nearest (130.0 ≥ 90.0 s)"), "{md}");
        assert!(claims(&rs[4..]).is_none(), "nothing to check without lives and multisensor");
    }

    #[test]
    fn grids_expand_to_every_combination() {
        let g = vec![parse_grid_axis("a=1,2").unwrap(), parse_grid_axis("b=x").unwrap()];
        assert_eq!(grid_assignments(&g), vec![vec!["a=1".to_string(), "b=x".into()], vec!["a=2".into(), "b=x".into()]]);
        assert!(parse_grid_axis("a").is_err());
        assert!(parse_grid_axis("a=").is_err());
    }

    #[test]
    fn a_batch_returns_results_in_spec_order_whatever_the_threads() {
        let world = World::random(3);
        let specs: Vec<SearchSpec> = (1..=4)
            .map(|seed| {
                let mut s = SearchSpec::new("random-3", world.clone(), Scenario::Easy, PlannerChoice::Nearest, seed);
                s.world.time_limit_s = 10.0;
                s
            })
            .collect();
        let one = run_batch(&specs, 1, |_| {}).unwrap();
        let two = run_batch(&specs, 2, |_| {}).unwrap();
        assert_eq!(one, two);
        assert_eq!(one.iter().map(|r| r.seed).collect::<Vec<_>>(), vec![1, 2, 3, 4]);
    }
}
