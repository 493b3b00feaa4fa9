//! `lives node`: the controller core as a process at one end of a serial line.
//!
//! A loop around [`firmware::node::Node`]: read what the line brings (short timeouts), hand it to
//! the node, write what the node answers. In [`TimeMode::RealTime`] it also ticks the node every
//! `period` on this process's monotonic clock (`Instant`; the core never reads a clock). When the
//! port fails (unplugged, peer gone) it drops the partial frame, backs off and reopens it; the
//! controller keeps its maps and goal, so a replugged cable resumes the search.

use super::{Link, Summary, Timings};
use firmware::classifier::ModelError;
use firmware::config::ConfigError;
use firmware::node::{Node, NodeConfig, NodeCounters, TimeMode};
use firmware::protocol::{CoreToHost, GoalMsg, HostDecoder, LinkCounters};
use firmware::{Config, Controller, Mode};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How the node process runs.
#[derive(Clone, Debug)]
pub struct NodeOptions {
    /// Real time (ticks on this process's clock) or lockstep (ticks on the host's batches).
    pub mode: TimeMode,
    /// Tick period in real time.
    pub period: Duration,
    /// Keep a copy of every goal sent (for tests: "no goal from a corrupted frame").
    pub record_goals: bool,
    /// Back-off between reconnection attempts.
    pub reconnect_every: Duration,
    /// The classifier's int8 model blob, installed at start (for `lives` without labels).
    pub model: Option<&'static [u8]>,
    /// Lockstep: a batch whose segmented scan is still incomplete ticks on this many-th heartbeat
    /// closing it ([`NodeConfig::lockstep_partial_after`]).
    pub lockstep_partial_after: u8,
}

impl NodeOptions {
    /// 200 ms ticks (the LiDAR's 5 Hz), no recording.
    pub fn new(mode: TimeMode) -> Self {
        NodeOptions {
            mode,
            period: Duration::from_millis(200),
            record_goals: false,
            reconnect_every: Duration::from_millis(100),
            model: None,
            lockstep_partial_after: NodeConfig::new(mode).lockstep_partial_after,
        }
    }
}

/// What a node process did.
#[derive(Clone, Debug)]
pub struct NodeReport {
    /// The node's counters.
    pub counters: NodeCounters,
    /// Receive counters (frames decoded, dropped by cause, ignored before the handshake).
    pub link: LinkCounters,
    /// The controller's mode at the end.
    pub mode: Mode,
    /// Why the last configuration refused as out of range was refused
    /// ([`NodeCounters::configs_invalid`]).
    pub config_error: Option<ConfigError>,
    /// Every goal sent, in order (if recorded).
    pub goals_sent: Vec<GoalMsg>,
    /// Wall time spent in controller ticks, µs per tick.
    pub tick_us: Summary,
    /// Real time: ticks that started more than a period late.
    pub overruns: u32,
    /// Read or write failures (port gone).
    pub io_errors: u32,
    /// Successful reopenings after a failure.
    pub reconnects: u32,
    /// Wall time the loop ran.
    pub wall_s: f64,
}

/// A node process's state, kept across links (a replugged cable, a reopened port).
pub struct NodeProcess {
    /// The link end.
    pub node: Box<Node>,
    /// The controller (about 1 MiB).
    pub ctl: Box<Controller>,
    opts: NodeOptions,
    start: Instant,
    tx: Vec<u8>,
    tx_log: HostDecoder,
    goals_sent: Vec<GoalMsg>,
    tick_us: Timings,
    overruns: u32,
    io_errors: u32,
    reconnects: u32,
    wall_s: f64,
}

impl NodeProcess {
    /// A fresh controller with `config` (and the model of `opts`, if it validates), no session.
    pub fn new(config: Config, opts: NodeOptions) -> Result<Self, ModelError> {
        let mut ctl = Box::new(Controller::new(config));
        if let Some(blob) = opts.model {
            ctl.set_model(blob)?;
        }
        Ok(NodeProcess {
            node: Box::new(Node::new(NodeConfig { lockstep_partial_after: opts.lockstep_partial_after, ..NodeConfig::new(opts.mode) })),
            ctl,
            opts,
            start: Instant::now(),
            tx: Vec::with_capacity(8192),
            tx_log: HostDecoder::new(),
            goals_sent: Vec::new(),
            tick_us: Timings::default(),
            overruns: 0,
            io_errors: 0,
            reconnects: 0,
            wall_s: 0.0,
        })
    }

    fn flush(&mut self, link: &mut dyn Link) -> bool {
        if self.tx.is_empty() {
            return true;
        }
        if self.opts.record_goals {
            for m in self.tx_log.feed(&self.tx).flatten() {
                if let CoreToHost::Goal(g) = m {
                    self.goals_sent.push(g);
                }
            }
        }
        let ok = link.write_all(&self.tx).is_ok();
        self.tx.clear();
        ok
    }

    /// Runs on `link` until `stop` is set. Can be called again with another link.
    pub fn run(&mut self, link: &mut dyn Link, stop: &AtomicBool) {
        let t0 = Instant::now();
        let period = self.opts.period;
        let mut next_tick = Instant::now() + period;
        let mut buf = vec![0u8; 8192];
        let mut down = false;
        while !stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            if self.opts.mode == TimeMode::RealTime && now >= next_tick {
                let now_us = (now - self.start).as_micros() as u64;
                let tx = &mut self.tx;
                let t = Instant::now();
                self.node.tick(now_us, &mut self.ctl, |f| tx.extend_from_slice(f));
                self.tick_us.push(t.elapsed().as_secs_f64() * 1e6);
                if super::advance_deadline(&mut next_tick, period, now) {
                    self.overruns += 1;
                }
            }
            if !down && !self.flush(link) {
                self.io_errors += 1;
                down = true;
            }
            if down {
                std::thread::sleep(self.opts.reconnect_every);
                if link.reconnect().is_ok() {
                    self.node.link_reset();
                    self.reconnects += 1;
                    down = false;
                }
                continue;
            }
            let wait = match self.opts.mode {
                TimeMode::RealTime => next_tick.saturating_duration_since(Instant::now()).min(Duration::from_millis(20)),
                TimeMode::Lockstep => Duration::from_millis(20),
            };
            match link.read(&mut buf, wait) {
                Ok(0) => {}
                Ok(n) => {
                    let tx = &mut self.tx;
                    let t = Instant::now();
                    let ticks = self.node.receive(&buf[..n], &mut self.ctl, |f| tx.extend_from_slice(f));
                    if ticks > 0 {
                        self.tick_us.push(t.elapsed().as_secs_f64() * 1e6 / ticks as f64);
                    }
                }
                Err(_) => {
                    self.io_errors += 1;
                    self.tx.clear();
                    down = true;
                }
            }
        }
        let _ = self.flush(link);
        self.wall_s += t0.elapsed().as_secs_f64();
    }

    /// What happened so far.
    pub fn report(&self) -> NodeReport {
        NodeReport {
            counters: self.node.counters(),
            link: self.node.link_counters(),
            mode: self.ctl.mode(),
            config_error: self.node.last_config_error(),
            goals_sent: self.goals_sent.clone(),
            tick_us: self.tick_us.summary(),
            overruns: self.overruns,
            io_errors: self.io_errors,
            reconnects: self.reconnects,
            wall_s: self.wall_s,
        }
    }
}

/// Runs the controller with `config` as a node on `link` until `stop` is set. Fails only if the
/// model blob of `opts` does not validate.
pub fn run_node(link: &mut dyn Link, config: Config, opts: NodeOptions, stop: &AtomicBool) -> Result<NodeReport, ModelError> {
    let mut p = NodeProcess::new(config, opts)?;
    p.run(link, stop);
    Ok(p.report())
}
