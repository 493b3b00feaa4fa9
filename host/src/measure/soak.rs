//! `lives soak`: does the controller stay up? (issue 29; `docs/reliability.md`).
//!
//! Two parts, one after the other:
//!
//! 1. **Real time, on a pseudo-terminal**: `lives node` as its own process (real-time mode, its
//!    own 200 ms clock) at the slave end of a pty pair; the bridge here at the master end, running
//!    searches back to back (worlds with people walking, a new seed each) in real time. The line
//!    is noisy both ways (every byte replaced by a random one, `0x00` included, with probability
//!    `noise`), and every `pull_every` the link is taken away for `pull_for`, mid-search:
//!    alternately *silent* (every byte lost both ways, the ports stay: the node's and the
//!    bridge's watchdogs must notice) and *unplugged* (the bridge's port fails). Every
//!    `sample_every` it records the node process's resident memory (`VmRSS`) and open file
//!    descriptors (`/proc/PID/fd`), and its own.
//! 2. **Simulated**: the node (lockstep, in a thread) and the bridge over an in-memory line with
//!    the same noise, searching back to back until `sim_hours` of simulated time have passed;
//!    this process's memory and descriptors sampled after each search.
//!
//! It fails ([`SoakReport::failures`]) on: the node process dying or panicking; memory growing
//! (the highest RSS of the last third of the samples above the highest of the first third, after
//! a warm-up, by more than [`SoakOptions::growth_kib`]); file descriptors growing; a pull not
//! answered by the bridge declaring the link lost (the base stopped) within one watchdog period
//! (1 s, plus [`STOP_SLACK`] for the scheduler of a loaded machine) of the pull, or no session
//! reopened after the link came back; a search that errs.
//!
//! Overruns (real-time ticks that came late), link losses and recoveries, retries and rejected
//! frames are recorded and reported, not failed on.

use crate::link::{
    mem_pair, run_bridge, BridgeEvent, BridgeEventKind, BridgeOptions, FaultConfig, FaultHandle, FaultyLink, Link, NodeOptions,
    NodeProcess, SerialLink, Source, TimeMode,
};
use crate::search::{PlannerChoice, SearchSpec};
use crate::sim::{Scenario, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The node's and the bridge's watchdog period.
pub const WATCHDOG: Duration = Duration::from_secs(1);
/// Allowed on top of [`WATCHDOG`] between a pull and the bridge's stop (the serial tests'
/// slack for a loaded two-core machine).
pub const STOP_SLACK: Duration = Duration::from_millis(500);

/// What to run.
#[derive(Clone, Debug)]
pub struct SoakOptions {
    /// Wall time of the real-time part.
    pub wall: Duration,
    /// Simulated time of the lockstep part, hours.
    pub sim_hours: f64,
    /// Time between link pulls (real-time part).
    pub pull_every: Duration,
    /// How long each pull lasts.
    pub pull_for: Duration,
    /// Probability that a byte on the line is replaced by a random one, each direction.
    pub noise: f64,
    /// Time between memory samples (real-time part).
    pub sample_every: Duration,
    /// The `lives` program that runs the node process.
    pub lives: PathBuf,
    /// Seeds the noise and the searches.
    pub seed: u64,
    /// Memory growth allowed, KiB.
    pub growth_kib: u64,
}

impl SoakOptions {
    /// The long soak: 30 minutes real time, 8 hours simulated, a pull every 3 minutes.
    pub fn long(lives: PathBuf) -> Self {
        SoakOptions {
            wall: Duration::from_secs(30 * 60),
            sim_hours: 8.0,
            pull_every: Duration::from_secs(180),
            pull_for: Duration::from_millis(2500),
            noise: 2e-5,
            sample_every: Duration::from_secs(5),
            lives,
            seed: 1,
            growth_kib: 2048,
        }
    }
}

/// One memory and descriptor sample.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Sample {
    /// Seconds since the part started (wall time; simulated time in the simulated part).
    pub t_s: f64,
    /// Resident set, KiB.
    pub rss_kib: u64,
    /// Open file descriptors.
    pub fds: u32,
}

/// One link pull and how it was answered.
#[derive(Clone, Debug, Serialize)]
pub struct Pull {
    /// `silent` or `unplugged`.
    pub kind: &'static str,
    /// Seconds since the start of the real-time part.
    pub at_s: f64,
    /// The bridge declared the link lost (and stopped the base) this long after the pull, ms.
    pub stopped_after_ms: Option<f64>,
    /// A session reopened this long after the link came back, ms.
    pub resumed_after_ms: Option<f64>,
    /// The search ended while the link was away (nothing left to stop or resume).
    pub search_ended_during: bool,
}

/// The real-time part.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RealTimeReport {
    /// Wall time, s.
    pub wall_s: f64,
    /// Searches run, found.
    pub searches: u32,
    /// Searches that found the target.
    pub found: u32,
    /// The node process's memory over time.
    pub node: Vec<Sample>,
    /// This process's (the bridge's and simulator's).
    pub bridge: Vec<Sample>,
    /// The pulls.
    pub pulls: Vec<Pull>,
    /// Link losses the bridge saw (pulls and noise).
    pub link_losses: u32,
    /// Sessions reopened after a loss.
    pub recoveries: u32,
    /// Frames the bridge rejected (noise) and batches it retried.
    pub bridge_rejected: u64,
    /// Batches retried.
    pub retries: u64,
    /// The node's own report (`lives node --seconds`' JSON: ticks, overruns, rejected frames,
    /// reconnects).
    pub node_report: Option<serde_json::Value>,
}

/// The simulated part.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SimReport {
    /// Simulated time, s.
    pub sim_s: f64,
    /// Wall time, s.
    pub wall_s: f64,
    /// Searches run.
    pub searches: u32,
    /// Searches that found the target.
    pub found: u32,
    /// This process's memory after each search (`t_s`: simulated time so far).
    pub samples: Vec<Sample>,
    /// Frames the node and the bridge rejected (noise).
    pub rejected: u64,
    /// The node's overruns (none in lockstep) and ticks.
    pub node_ticks: u64,
}

/// Everything.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SoakReport {
    /// The real-time part.
    pub real_time: RealTimeReport,
    /// The simulated part.
    pub simulated: SimReport,
    /// Why the soak failed; empty when it passed.
    pub failures: Vec<String>,
}

/// `VmRSS` (KiB) and the number of open descriptors of process `pid` (`None`: this process).
pub fn sample_process(pid: Option<u32>) -> io::Result<(u64, u32)> {
    let dir = match pid {
        Some(p) => PathBuf::from(format!("/proc/{p}")),
        None => PathBuf::from("/proc/self"),
    };
    let status = std::fs::read_to_string(dir.join("status"))?;
    let rss = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidData, "no VmRSS"))?;
    let fds = std::fs::read_dir(dir.join("fd"))?.count() as u32;
    Ok((rss, fds))
}

/// Growth of a series of samples: the highest RSS of the last third above the highest of the
/// first third, after dropping the first `warmup` samples (KiB, 0 if none), and the same for
/// descriptors.
pub fn growth(samples: &[Sample], warmup: usize) -> (u64, u32) {
    let s = &samples[warmup.min(samples.len())..];
    if s.len() < 3 {
        return (0, 0);
    }
    let third = s.len() / 3;
    let (first, last) = (&s[..third], &s[s.len() - third..]);
    let max_rss = |x: &[Sample]| x.iter().map(|s| s.rss_kib).max().unwrap_or(0);
    let max_fds = |x: &[Sample]| x.iter().map(|s| s.fds).max().unwrap_or(0);
    (max_rss(last).saturating_sub(max_rss(first)), max_fds(last).saturating_sub(max_fds(first)))
}

/// The searches of the soak, in turn: worlds with people walking (`hard`: three people), a new
/// seed each time.
fn soak_spec(k: u32, seed: u64) -> SearchSpec {
    let (world, scenario) =
        [("apartment", Scenario::Hard), ("office", Scenario::Easy), ("hallway", Scenario::Hard), ("office", Scenario::Hard)]
            [k as usize % 4];
    let w = World::builtin(world, scenario).expect("a built-in world");
    SearchSpec::new(world, w, scenario, PlannerChoice::LivesGt, seed.wrapping_mul(1000).wrapping_add(k as u64))
}

/// The bridge's end of the pty: line noise on what it writes (what it reads is damaged by the
/// [`FaultyLink`] inside), and a *silent* pull that loses what it writes.
struct NoisyEnd<L: Link> {
    inner: L,
    noise: f64,
    rng: ChaCha8Rng,
    silent: Arc<AtomicBool>,
}

impl<L: Link> Link for NoisyEnd<L> {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.inner.read(buf, timeout)
    }
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.silent.load(Ordering::Relaxed) {
            return Ok(());
        }
        if self.noise <= 0.0 {
            return self.inner.write_all(bytes);
        }
        let mut b = bytes.to_vec();
        for x in b.iter_mut() {
            if self.rng.gen_bool(self.noise) {
                *x = self.rng.gen();
            }
        }
        self.inner.write_all(&b)
    }
    fn reconnect(&mut self) -> io::Result<()> {
        self.inner.reconnect()
    }
    fn describe(&self) -> String {
        format!("noisy({})", self.inner.describe())
    }
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// Matches each pull with the bridge's events: the first link loss at or after the pull, and
/// the first session opened after the link came back.
fn answer_pulls(pulls: &mut [(Pull, Instant, Instant)], events: &[BridgeEvent], search_ends: &[Instant]) {
    for (p, at, back) in pulls.iter_mut() {
        let ended = search_ends.iter().any(|e| *e >= *at && *e <= *back + WATCHDOG);
        let lost = events.iter().find(|e| matches!(e.kind, BridgeEventKind::LinkLost { .. }) && e.at >= *at);
        p.stopped_after_ms = lost.filter(|e| e.at <= *back + WATCHDOG * 2).map(|e| secs(e.at - *at) * 1e3);
        let opened = events.iter().find(|e| e.kind == BridgeEventKind::SessionOpened && e.at >= *back);
        p.resumed_after_ms = opened.map(|e| secs(e.at - *back) * 1e3);
        p.search_ended_during = ended;
    }
}

/// Part 1. `say` gets a line of progress now and then.
pub fn real_time(opts: &SoakOptions, failures: &mut Vec<String>, say: &mut dyn FnMut(String)) -> io::Result<RealTimeReport> {
    let mut rep = RealTimeReport::default();
    let (master, slave) = SerialLink::pty_pair()?;
    let path = slave.path().map(Path::to_path_buf).ok_or_else(|| io::Error::other("the pty slave has no path"))?;
    let node_seconds = secs(opts.wall).ceil() as u64 + 3;
    let mut child = std::process::Command::new(&opts.lives)
        .args(["node", "--port"])
        .arg(&path)
        .args(["--seconds", &node_seconds.to_string()])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", opts.lives.display())))?;
    let pid = child.id();
    // Let the node open the slave before this process lets go of it.
    std::thread::sleep(Duration::from_millis(500));
    drop(slave);

    let cable = FaultHandle::new();
    let faults = FaultConfig { corrupt_byte_prob: opts.noise, line_noise: true, ..FaultConfig::default() };
    let silent = Arc::new(AtomicBool::new(false));
    let mut link = NoisyEnd {
        inner: FaultyLink::new(master, faults, opts.seed).with_handle(cable.clone()),
        noise: opts.noise,
        rng: ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed),
        silent: silent.clone(),
    };
    let start = Instant::now();
    let deadline = start + opts.wall;
    let progress = Arc::new(AtomicU32::new(0));
    let pulling = Arc::new(AtomicBool::new(false));
    // A search is under way (the puller pulls only mid-search, never between two).
    let searching = Arc::new(AtomicBool::new(false));
    let over = Arc::new(AtomicBool::new(false));
    let pulls: Arc<Mutex<Vec<(Pull, Instant, Instant)>>> = Arc::default();
    let samples: Arc<Mutex<(Vec<Sample>, Vec<Sample>)>> = Arc::default();
    let mut events = Vec::new();
    let mut search_ends = Vec::new();
    std::thread::scope(|s| {
        // The puller: mid-search (10 ticks in), every `pull_every`.
        s.spawn(|| {
            let mut next = start + opts.pull_every;
            let mut k = 0;
            while !over.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(20));
                if Instant::now() < next || !searching.load(Ordering::SeqCst) || progress.load(Ordering::SeqCst) < 10 {
                    continue;
                }
                if Instant::now() + opts.pull_for + WATCHDOG * 2 > deadline {
                    break;
                }
                pulling.store(true, Ordering::SeqCst);
                let kind = if k % 2 == 0 { "silent" } else { "unplugged" };
                let at = Instant::now();
                match kind {
                    "silent" => {
                        silent.store(true, Ordering::SeqCst);
                        cable.blackhole(true);
                    }
                    _ => cable.disconnect(),
                }
                std::thread::sleep(opts.pull_for);
                let back = Instant::now();
                match kind {
                    "silent" => {
                        cable.blackhole(false);
                        silent.store(false, Ordering::SeqCst);
                    }
                    _ => cable.reconnect(),
                }
                pulling.store(false, Ordering::SeqCst);
                let pull =
                    Pull { kind, at_s: secs(at - start), stopped_after_ms: None, resumed_after_ms: None, search_ended_during: false };
                pulls.lock().unwrap().push((pull, at, back));
                k += 1;
                next = back + opts.pull_every;
            }
        });
        // The sampler.
        s.spawn(|| {
            while !over.load(Ordering::Relaxed) {
                let t_s = secs(start.elapsed());
                let mut g = samples.lock().unwrap();
                if let Ok((rss_kib, fds)) = sample_process(Some(pid)) {
                    g.0.push(Sample { t_s, rss_kib, fds });
                }
                if let Ok((rss_kib, fds)) = sample_process(None) {
                    g.1.push(Sample { t_s, rss_kib, fds });
                }
                drop(g);
                let until = Instant::now() + opts.sample_every;
                while Instant::now() < until && !over.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(50));
                }
            }
        });
        // The bridge: searches back to back until the deadline.
        let stop = AtomicBool::new(false);
        let mut k = 0u32;
        while Instant::now() + Duration::from_secs(3) < deadline {
            while pulling.load(Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(20));
            }
            progress.store(0, Ordering::SeqCst);
            searching.store(true, Ordering::SeqCst);
            let sp = soak_spec(k, opts.seed);
            let bopts = BridgeOptions {
                max_wall: Some(deadline.saturating_duration_since(Instant::now())),
                progress: Some(progress.clone()),
                scan_segment_beams: 128,
                ..BridgeOptions::new(TimeMode::RealTime)
            };
            let result = run_bridge(&mut link, Source::Sim(sp.clone()), &bopts, &stop);
            searching.store(false, Ordering::SeqCst);
            match result {
                Ok(r) => {
                    rep.searches += 1;
                    rep.found += r.result.found as u32;
                    rep.link_losses += r.stats.link_losses;
                    rep.bridge_rejected += r.stats.decoder.dropped() as u64;
                    rep.retries += r.stats.retries;
                    rep.recoveries += r.events.iter().filter(|e| e.kind == BridgeEventKind::SessionOpened).count().saturating_sub(1) as u32;
                    say(format!(
                        "real time {:>5.0} s: search {} ({} {}, seed {}) {} at {:.1} s simulated ({:.1} s wall), {} link losses",
                        secs(start.elapsed()),
                        k + 1,
                        sp.world_name,
                        sp.scenario.map_or("-", |s| s.as_str()),
                        sp.seed,
                        if r.result.found { "found" } else { "not found" },
                        r.result.time_s,
                        r.wall_s,
                        r.stats.link_losses
                    ));
                    events.extend(r.events);
                }
                Err(e) => failures.push(format!("real time: search {} failed: {e}", k + 1)),
            }
            search_ends.push(Instant::now());
            k += 1;
            if let Ok(Some(status)) = child.try_wait() {
                failures.push(format!("the node process ended early: {status}"));
                break;
            }
        }
        over.store(true, Ordering::Relaxed);
    });
    rep.wall_s = secs(start.elapsed());
    // The node stops by itself (`--seconds`) and prints its report.
    let out = wait_with_deadline(child, Duration::from_secs(node_seconds + 30))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        failures.push(format!("the node process exited with {}: {}", out.status, stderr.trim()));
    }
    if stderr.contains("panicked") {
        failures.push(format!("the node process panicked: {}", stderr.trim()));
    }
    rep.node_report = String::from_utf8_lossy(&out.stdout).lines().rev().find_map(|l| serde_json::from_str(l).ok());
    let (node_samples, bridge_samples) = std::mem::take(&mut *samples.lock().unwrap());
    rep.node = node_samples;
    rep.bridge = bridge_samples;
    let mut pulls = std::mem::take(&mut *pulls.lock().unwrap());
    answer_pulls(&mut pulls, &events, &search_ends);
    for (p, _, _) in &pulls {
        if p.search_ended_during {
            continue;
        }
        match p.stopped_after_ms {
            Some(ms) if ms <= secs(WATCHDOG + STOP_SLACK) * 1e3 => {}
            Some(ms) => failures.push(format!("{} pull at {:.1} s: the base stopped only {ms:.0} ms after it", p.kind, p.at_s)),
            None => failures.push(format!("{} pull at {:.1} s: no stop (the bridge never declared the link lost)", p.kind, p.at_s)),
        }
        if p.resumed_after_ms.is_none() {
            failures.push(format!("{} pull at {:.1} s: no session reopened after the link came back", p.kind, p.at_s));
        }
    }
    rep.pulls = pulls.into_iter().map(|(p, _, _)| p).collect();
    let warmup = (rep.node.len() / 5).max(2);
    for (who, s) in [("node process", &rep.node), ("bridge process", &rep.bridge)] {
        let (rss, fds) = growth(s, warmup);
        if rss > opts.growth_kib {
            failures.push(format!("real time: the {who}'s memory grew by {rss} KiB (more than {} KiB)", opts.growth_kib));
        }
        if fds > 0 {
            failures.push(format!("real time: the {who}'s open file descriptors grew by {fds}"));
        }
    }
    if rep.node.len() < 3 {
        failures.push(format!("real time: only {} samples of the node process", rep.node.len()));
    }
    Ok(rep)
}

/// Waits for `child` at most `limit`, then kills it.
fn wait_with_deadline(mut child: std::process::Child, limit: Duration) -> io::Result<std::process::Output> {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        if child.try_wait()?.is_some() {
            return child.wait_with_output();
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill()?;
    child.wait_with_output()
}

/// Part 2.
pub fn simulated(opts: &SoakOptions, failures: &mut Vec<String>, say: &mut dyn FnMut(String)) -> SimReport {
    let mut rep = SimReport::default();
    let (a, b) = mem_pair();
    let faults = FaultConfig { corrupt_byte_prob: opts.noise, line_noise: true, ..FaultConfig::default() };
    let mut node_end = FaultyLink::new(a, faults.clone(), opts.seed ^ 21);
    let mut bridge_end = FaultyLink::new(b, faults, opts.seed ^ 22);
    let start = Instant::now();
    let target_s = opts.sim_hours * 3600.0;
    let stop_node = AtomicBool::new(false);
    let node_ticks = std::thread::scope(|s| {
        let node = s.spawn(|| {
            let mut p = NodeProcess::new(firmware::Config::DEFAULT, NodeOptions::new(TimeMode::Lockstep)).expect("no model");
            p.run(&mut node_end, &stop_node);
            let r = p.report();
            (r.counters.ticks, r.link.dropped() as u64)
        });
        let stop = AtomicBool::new(false);
        let mut k = 0u32;
        while rep.sim_s < target_s {
            let sp = soak_spec(k, opts.seed ^ 0x51);
            let bopts = BridgeOptions {
                max_wall: Some(Duration::from_secs(600)),
                retry_timeout: Duration::from_millis(5),
                scan_segment_beams: 128,
                ..BridgeOptions::new(TimeMode::Lockstep)
            };
            match run_bridge(&mut bridge_end, Source::Sim(sp.clone()), &bopts, &stop) {
                Ok(r) => {
                    rep.searches += 1;
                    rep.found += r.result.found as u32;
                    rep.sim_s += r.result.time_s;
                    rep.rejected += r.stats.decoder.dropped() as u64;
                }
                Err(e) => {
                    failures.push(format!("simulated: search {} failed: {e}", k + 1));
                    break;
                }
            }
            if let Ok((rss_kib, fds)) = sample_process(None) {
                rep.samples.push(Sample { t_s: rep.sim_s, rss_kib, fds });
            }
            if k % 20 == 19 {
                say(format!(
                    "simulated {:>6.2} h of {:.2} h: {} searches, {:.0} s wall",
                    rep.sim_s / 3600.0,
                    opts.sim_hours,
                    rep.searches,
                    secs(start.elapsed())
                ));
            }
            k += 1;
        }
        std::thread::sleep(Duration::from_millis(100));
        stop_node.store(true, Ordering::Relaxed);
        node.join()
    });
    match node_ticks {
        Ok((ticks, rejected)) => {
            rep.node_ticks = ticks as u64;
            rep.rejected += rejected;
        }
        Err(_) => failures.push("simulated: the node thread panicked".to_string()),
    }
    rep.wall_s = secs(start.elapsed());
    let warmup = (rep.samples.len() / 5).max(2);
    let (rss, fds) = growth(&rep.samples, warmup);
    if rss > opts.growth_kib {
        failures.push(format!("simulated: memory grew by {rss} KiB (more than {} KiB)", opts.growth_kib));
    }
    if fds > 0 {
        failures.push(format!("simulated: open file descriptors grew by {fds}"));
    }
    rep
}

/// Both parts.
pub fn run(opts: &SoakOptions, say: &mut dyn FnMut(String)) -> io::Result<SoakReport> {
    let mut failures = Vec::new();
    let real_time = real_time(opts, &mut failures, say)?;
    let simulated = simulated(opts, &mut failures, say);
    Ok(SoakReport { real_time, simulated, failures })
}

/// The figures of a soak, a few lines for a person (and `docs/reliability.md`).
pub fn summary(r: &SoakReport) -> String {
    let rt = &r.real_time;
    let range = |s: &[Sample]| {
        let lo = s.iter().map(|s| s.rss_kib).min().unwrap_or(0);
        let hi = s.iter().map(|s| s.rss_kib).max().unwrap_or(0);
        let (f0, f1) = (s.iter().map(|s| s.fds).min().unwrap_or(0), s.iter().map(|s| s.fds).max().unwrap_or(0));
        format!("RSS {lo}-{hi} KiB over {} samples, {f0}-{f1} fds", s.len())
    };
    let stops: Vec<f64> = rt.pulls.iter().filter_map(|p| p.stopped_after_ms).collect();
    let resumes: Vec<f64> = rt.pulls.iter().filter_map(|p| p.resumed_after_ms).collect();
    let span = |v: &[f64]| match v.is_empty() {
        true => "-".to_string(),
        false => format!("{:.0}-{:.0} ms", v.iter().cloned().fold(f64::INFINITY, f64::min), v.iter().cloned().fold(0.0, f64::max)),
    };
    let node = rt.node_report.as_ref();
    let field = |k: &str| node.and_then(|n| n.get(k)).map(|v| v.to_string()).unwrap_or_else(|| "-".into());
    let sim = &r.simulated;
    let (g_node, g_bridge, g_sim) = (
        growth(&rt.node, (rt.node.len() / 5).max(2)),
        growth(&rt.bridge, (rt.bridge.len() / 5).max(2)),
        growth(&sim.samples, (sim.samples.len() / 5).max(2)),
    );
    format!(
        "real time: {:.0} s wall, {} searches ({} found), {} pulls (stopped after {}, resumed after {}), {} link losses, {} recoveries, {} frames rejected, {} retries\n\
         \x20 node process: {}; growth last vs first third {} KiB, {} fds; ticks {}, overruns {}, reconnects {}, frames rejected {}\n\
         \x20 bridge process: {}; growth {} KiB, {} fds\n\
         simulated: {:.2} h in {:.0} s wall, {} searches ({} found), {} node ticks, {} frames rejected; {}; growth {} KiB, {} fds\n\
         {}",
        rt.wall_s,
        rt.searches,
        rt.found,
        rt.pulls.len(),
        span(&stops),
        span(&resumes),
        rt.link_losses,
        rt.recoveries,
        rt.bridge_rejected,
        rt.retries,
        range(&rt.node),
        g_node.0,
        g_node.1,
        field("ticks"),
        field("overruns"),
        field("reconnects"),
        field("rejected"),
        range(&rt.bridge),
        g_bridge.0,
        g_bridge.1,
        sim.sim_s / 3600.0,
        sim.wall_s,
        sim.searches,
        sim.found,
        sim.node_ticks,
        sim.rejected,
        range(&sim.samples),
        g_sim.0,
        g_sim.1,
        if r.failures.is_empty() { "PASS".to_string() } else { format!("FAIL: {}", r.failures.join("; ")) }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(rss_kib: u64, fds: u32) -> Sample {
        Sample { t_s: 0.0, rss_kib, fds }
    }

    #[test]
    fn growth_compares_the_last_third_with_the_first_after_the_warm_up() {
        let flat: Vec<Sample> = [900, 100, 100, 120, 90, 110, 100, 105, 100].iter().map(|&r| s(r, 7)).collect();
        assert_eq!(growth(&flat, 1), (5, 0));
        let leak: Vec<Sample> = (0..30).map(|i| s(1000 + i * 100, 7 + (i / 10) as u32)).collect();
        assert_eq!(growth(&leak, 3), (1800, 1));
        assert_eq!(growth(&leak[..4], 3), (0, 0), "too few samples");
    }

    #[test]
    fn this_process_can_be_sampled() {
        let (rss, fds) = sample_process(None).unwrap();
        assert!(rss > 100 && fds >= 3, "{rss} KiB, {fds} fds");
    }
}
