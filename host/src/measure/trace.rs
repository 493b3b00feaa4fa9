//! `lives trace`: golden traces of the serial link (format and replay: `firmware::mcu::trace`).
//!
//! [`record`] runs a simulated search through the real link code, `run_bridge` on one end of an
//! in-memory line and a lockstep node process on the other, and keeps every write of the bridge
//! (with the time of its last heartbeat) until the batch of the last wanted tick was written.
//! [`replay`] feeds a trace to a fresh node and controller and returns the per-record digests
//! of what the node answered; the MCU image `mcu-trace` prints the same digests (docs/mcu.md).
//! A damaged trace (cut off, a bad record) replays as far as its records are good, and says
//! where it stopped.

use crate::link::{mem_pair, run_bridge, BridgeOptions, Link, MemLink, NodeOptions, NodeProcess, Source, TimeMode};
use crate::run::TICK_US;
use crate::search::SearchSpec;
use firmware::classifier::EMBEDDED_MODEL;
use firmware::mcu::trace::{self, Digest, Trace, FLAG_EMBEDDED_MODEL, MAX_RECORD};
use firmware::node::{Node, NodeConfig};
use firmware::protocol::{CoreDecoder, CoreToHost, HostDecoder, HostToCore};
use firmware::{Config, Controller};
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// What the recorder kept: (time of the last heartbeat, bytes) per write.
type Records = Arc<Mutex<Vec<(u64, Vec<u8>)>>>;

/// The bridge's end of the line, keeping a copy of every write.
struct Recorder {
    inner: MemLink,
    dec: CoreDecoder,
    last_t: u64,
    records: Records,
    /// Set once the batch for `until_t` was written (the bridge then stops).
    done: Arc<AtomicBool>,
    until_t: u64,
}

impl Link for Recorder {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.inner.read(buf, timeout)
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.done.load(Ordering::Acquire) {
            return self.inner.write_all(bytes);
        }
        let mut batch_t = None;
        let mut has_pose = false;
        for m in self.dec.feed(bytes).flatten() {
            match m {
                HostToCore::Heartbeat(h) => {
                    self.last_t = h.t_us;
                    batch_t = Some(h.t_us);
                }
                HostToCore::Pose(_) => has_pose = true,
                _ => {}
            }
        }
        let mut recs = self.records.lock().unwrap_or_else(|e| e.into_inner());
        for chunk in bytes.chunks(MAX_RECORD) {
            recs.push((self.last_t, chunk.to_vec()));
        }
        if has_pose && batch_t == Some(self.until_t) {
            self.done.store(true, Ordering::Release);
        }
        self.inner.write_all(bytes)
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.inner.reconnect()
    }

    fn describe(&self) -> String {
        "recorder".to_string()
    }
}

/// Records the first `ticks` lockstep batches of the search `spec` (with the classifier if
/// `spec.model` is set: the scans then carry no labels and the replay installs the embedded
/// model, so `spec.model` must be [`EMBEDDED_MODEL`]). Returns the trace file's bytes.
pub fn record(spec: SearchSpec, ticks: u32) -> Result<Vec<u8>, String> {
    if ticks == 0 {
        return Err("a trace needs at least one tick".to_string());
    }
    let classifier = spec.model.is_some();
    if classifier && spec.model != Some(EMBEDDED_MODEL) {
        return Err("a trace with the classifier must use the embedded model (the replay installs it)".to_string());
    }
    let (node_end, bridge_end) = mem_pair();
    let records: Records = Arc::new(Mutex::new(Vec::new()));
    let done = Arc::new(AtomicBool::new(false));
    let mut link = Recorder {
        inner: bridge_end,
        dec: CoreDecoder::new(),
        last_t: 0,
        records: records.clone(),
        done: done.clone(),
        until_t: u64::from(ticks - 1) * TICK_US,
    };
    let node_stop = Arc::new(AtomicBool::new(false));
    let node = {
        let stop = node_stop.clone();
        let opts = NodeOptions { model: classifier.then_some(EMBEDDED_MODEL), ..NodeOptions::new(TimeMode::Lockstep) };
        std::thread::Builder::new()
            .name("trace-node".into())
            .stack_size(32 << 20)
            .spawn(move || -> Result<(), String> {
                let mut node_end = node_end;
                let mut p = NodeProcess::new(Config::DEFAULT, opts).map_err(|e| format!("the model: {e:?}"))?;
                p.run(&mut node_end, &stop);
                Ok(())
            })
            .map_err(|e| e.to_string())?
    };
    // Generous timeouts: a slow (debug) node must not cause retries, though a retry would be
    // recorded and replayed faithfully.
    let opts = BridgeOptions {
        retry_timeout: Duration::from_secs(30),
        watchdog: Duration::from_secs(60),
        setup_probes: 3,
        ..BridgeOptions::new(TimeMode::Lockstep)
    };
    let run = run_bridge(&mut link, Source::Sim(spec), &opts, &done);
    node_stop.store(true, Ordering::Release);
    node.join().map_err(|_| "the node thread panicked".to_string())??;
    let run = run.map_err(|e| e.to_string())?;
    if !done.load(Ordering::Acquire) {
        return Err(format!("the search ended ({}) after {} of {ticks} ticks", run.result.outcome, run.result.ticks));
    }
    let recs = records.lock().unwrap_or_else(|e| e.into_inner());
    let mut out = Vec::new();
    trace::write_header(if classifier { FLAG_EMBEDDED_MODEL } else { 0 }, recs.len() as u32, |b| out.extend_from_slice(b));
    for (t, bytes) in recs.iter() {
        trace::write_record(*t, bytes, |b| out.extend_from_slice(b));
    }
    Ok(out)
}

/// What a trace gave: one item per good record, and the damage after them.
#[derive(Clone, Debug, PartialEq)]
pub struct Replayed<T> {
    /// Per good record, in order.
    pub records: Vec<T>,
    /// Where the trace stopped being good (`trace record 23 is cut off…`), if it did.
    pub error: Option<String>,
}

/// The good records of `bytes` and the error after them; `Err` when its header is bad.
fn parse_prefix(bytes: &[u8]) -> Result<(Trace<'_>, Option<String>), String> {
    let (t, bad) = Trace::parse_prefix(bytes).map_err(|e| e.to_string())?;
    Ok((t, bad.map(|e| if t.is_empty() { e.to_string() } else { format!("{e} (the {} records before it were replayed)", t.len()) })))
}

/// Replays `bytes` (a trace file) through a fresh lockstep node and controller, as far as its
/// records are good.
pub fn replay(bytes: &[u8]) -> Result<Replayed<Digest>, String> {
    let (t, error) = parse_prefix(bytes)?;
    let mut ctl = Box::new(Controller::new(Config::DEFAULT));
    let mut node = Box::new(Node::new(NodeConfig::new(TimeMode::Lockstep)));
    let mut out = Vec::with_capacity(t.len() as usize);
    t.replay(&mut node, &mut ctl, |d| out.push(*d)).map_err(|e| e.to_string())?;
    Ok(Replayed { records: out, error })
}

/// The replay in words: per record its digest line, the messages in it (`>`) and the node's
/// answers (`<`), scans shortened to their size; as far as the records are good.
pub fn decode(bytes: &[u8]) -> Result<Replayed<String>, String> {
    let (t, error) = parse_prefix(bytes)?;
    let mut ctl = Box::new(Controller::new(Config::DEFAULT));
    let mut node = Box::new(Node::new(NodeConfig::new(TimeMode::Lockstep)));
    if t.flags() & FLAG_EMBEDDED_MODEL != 0 {
        ctl.set_model(EMBEDDED_MODEL).map_err(|e| format!("the embedded model: {e:?}"))?;
    }
    let (mut din, mut dout) = (CoreDecoder::new(), HostDecoder::new());
    let mut lines = Vec::new();
    for (i, r) in t.records().enumerate() {
        lines.push(format!("record {i} t_us {}", r.t_us));
        for m in din.feed(r.bytes) {
            lines.push(match m {
                Ok(HostToCore::Scan(s)) => format!("> Scan t_us {} beams {} labels {}", s.t_us, s.ranges_mm.len(), s.labels.is_some()),
                Ok(m) => format!("> {m:?}"),
                Err(e) => format!("> bad frame: {e}"),
            });
        }
        let mut sent = Vec::new();
        node.receive(r.bytes, &mut ctl, |f| sent.extend_from_slice(f));
        for m in dout.feed(&sent) {
            lines.push(match m {
                Ok(CoreToHost::Goal(g)) => format!("< Goal seq {} at ({}, {}) waypoints {}", g.seq, g.x, g.y, g.waypoints().count()),
                Ok(m) => format!("< {m:?}"),
                Err(e) => format!("< bad frame: {e}"),
            });
        }
    }
    Ok(Replayed { records: lines, error })
}

/// A digest as `mcu-trace` prints it (`R record t_us ticks len crc`, without the timings).
pub fn digest_line(d: &Digest) -> String {
    format!("R {} {} {} {} {:08x}", d.record, d.t_us, d.ticks, d.len, d.crc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::PlannerChoice;
    use crate::sim::{Scenario, World};

    #[test]
    fn a_recorded_trace_replays_with_one_tick_per_batch_and_the_same_digests_twice() {
        let w = World::builtin("apartment", Scenario::Easy).unwrap();
        let spec = SearchSpec::new("apartment", w, Scenario::Easy, PlannerChoice::Lives, 1);
        let bytes = record(spec, 4).unwrap();
        let a = replay(&bytes).unwrap();
        assert_eq!(a.error, None);
        assert_eq!(a.records.iter().map(|d| d.ticks).sum::<u32>(), 4);
        assert_eq!(a.records.last().unwrap().t_us, 3 * TICK_US);
        assert_eq!(a, replay(&bytes).unwrap());
        // Cut off in its last record: the others replay as before, and the error says so.
        let n = a.records.len();
        let cut = replay(&bytes[..bytes.len() - 1]).unwrap();
        assert_eq!(cut.records[..], a.records[..n - 1]);
        let e = cut.error.unwrap();
        assert!(
            e.contains(&format!("trace record {} is cut off", n - 1)) && e.contains(&format!("the {} records before it", n - 1)),
            "{e}"
        );
        let lines = decode(&bytes[..bytes.len() - 1]).unwrap();
        assert_eq!(lines.records.iter().filter(|l| l.starts_with("record ")).count(), n - 1);
        assert!(lines.error.is_some());
        // A bad header reads nothing.
        assert!(replay(&bytes[..10]).unwrap_err().contains("shorter than"));
    }
}
