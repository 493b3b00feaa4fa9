//! The serial link between the host bridge and the controller node.
//!
//! * [`Link`]: a byte stream with read timeouts and a way back after a failure — a real serial
//!   device or pseudo-terminal ([`SerialLink`], via `serialport`), or an in-memory duplex
//!   ([`mem_pair`]).
//! * [`FaultyLink`]: wraps a link and damages what it reads — corrupted bytes, dropped bytes,
//!   dropped frames, delays, a pulled cable — seeded and deterministic, with exact counts of what
//!   it did, so a test can check every damaged frame was rejected.
//! * [`run_node`]: the controller core as a process on a link (`lives node`).
//! * [`adapter`]: the base adapter, a versioned JSON-lines TCP interface through which a robot's
//!   own program supplies odometry, scans and detections and receives goals and stops
//!   (`docs/base-adapter.md`); [`run_robot`] runs the bridge on it.
//! * [`run_bridge`]: the host side (`lives bridge`): owns the simulator and its base, feeds the
//!   node, drives the base with the goals that come back, keeps link-health counters, stops the
//!   base when the link is lost and picks the search up again when it returns.
//!
//! The wire format and the node's two time modes (real time, lockstep) are described in
//! `docs/protocol.md` and `firmware::node`.

pub mod adapter;
pub mod bridge;
pub mod fault;
pub mod node;
pub mod record;
pub mod robot;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod sim_bridge;
pub mod source;

pub use bridge::{BridgeError, BridgeEvent, BridgeEventKind, BridgeOptions, BridgeResult, LinkStats};
pub use fault::{FaultConfig, FaultHandle, FaultStats, FaultyLink};
pub use firmware::node::TimeMode;
pub use node::{run_node, NodeOptions, NodeProcess, NodeReport};
pub use robot::{run_robot, LidarSource, RobotRun, RobotSpec};
pub use source::{run_bridge, Source};

use serialport::{SerialPort, TTYPort};
use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// A byte stream to the peer.
///
/// Errors mean the link is down (the device vanished, the peer hung up, the cable was pulled):
/// the caller backs off and calls [`Link::reconnect`] until it works again.
pub trait Link: Send {
    /// Waits up to `timeout` for bytes and reads what is there; `Ok(0)` if none arrived.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;
    /// Writes all of `bytes` (or fails: the bytes may then be partly sent).
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// One attempt to bring a failed link back (reopen the device). `Ok` when usable.
    fn reconnect(&mut self) -> io::Result<()>;
    /// For messages: the device path or what the link is.
    fn describe(&self) -> String;
}

impl<L: Link + ?Sized> Link for Box<L> {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        (**self).read(buf, timeout)
    }
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).write_all(bytes)
    }
    fn reconnect(&mut self) -> io::Result<()> {
        (**self).reconnect()
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}

/// Longest a write may wait for the peer to drain the line.
const WRITE_TIMEOUT: Duration = Duration::from_millis(500);

/// `TTYPort::pair` is not thread-safe: every pair in this process is made under this lock.
static PTY_LOCK: Mutex<()> = Mutex::new(());

/// A serial device or pseudo-terminal (raw mode, 8N1; the baud rate matters only on a real UART).
pub struct SerialLink {
    port: Option<TTYPort>,
    path: Option<PathBuf>,
    baud: u32,
    /// Bytes read while probing a pathless port in [`Link::reconnect`], handed out next.
    stash: Vec<u8>,
}

impl SerialLink {
    /// Opens `path` (e.g. `/dev/ttyUSB0`, `/dev/pts/3`) at `baud`.
    pub fn open(path: &Path, baud: u32) -> io::Result<Self> {
        let mut link = SerialLink { port: None, path: Some(path.to_path_buf()), baud, stash: Vec::new() };
        link.reconnect()?;
        Ok(link)
    }

    /// `path`, not opened yet: the first read fails and the caller's [`Link::reconnect`] opens it
    /// as soon as the device exists (a node or bridge started before the cable is plugged in).
    pub fn by_path(path: &Path, baud: u32) -> Self {
        SerialLink { port: None, path: Some(path.to_path_buf()), baud, stash: Vec::new() }
    }

    /// Wraps an open port. If it has a device name it can be reopened by it after a failure.
    pub fn from_port(port: TTYPort, baud: u32) -> Self {
        let path = port.name().map(PathBuf::from);
        SerialLink { port: Some(port), path, baud, stash: Vec::new() }
    }

    /// A pseudo-terminal pair `(master, slave)`, as two ends of a line. The slave has a path
    /// (`/dev/pts/N`, see [`SerialLink::path`]) and can be closed and reopened by it; the master
    /// has none. Pairs are made one at a time (`TTYPort::pair` is not thread-safe).
    pub fn pty_pair() -> io::Result<(SerialLink, SerialLink)> {
        let _guard = PTY_LOCK.lock().unwrap_or_else(|e| e.into_inner());
        let (master, slave) = TTYPort::pair().map_err(io::Error::from)?;
        Ok((SerialLink::from_port(master, 921_600), SerialLink::from_port(slave, 921_600)))
    }

    /// The device path, if any.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Closes the port (a pulled plug); [`Link::reconnect`] reopens it by path.
    pub fn close(&mut self) {
        self.port = None;
    }
}

/// Moves a real-time loop's deadline `next` on by `period`; a loop that fell more than a period
/// behind `now` restarts from `now` instead of bursting to catch up. Returns true when it fell
/// behind (an overrun).
pub(crate) fn advance_deadline(next: &mut Instant, period: Duration, now: Instant) -> bool {
    *next += period;
    let behind = *next < now;
    if behind {
        *next = now + period;
    }
    behind
}

fn not_connected() -> io::Error {
    io::Error::new(io::ErrorKind::NotConnected, "link down")
}

impl Link for SerialLink {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let port = self.port.as_mut().ok_or_else(not_connected)?;
        if !self.stash.is_empty() {
            let n = buf.len().min(self.stash.len());
            buf[..n].copy_from_slice(&self.stash[..n]);
            self.stash.drain(..n);
            return Ok(n);
        }
        port.set_timeout(timeout).map_err(io::Error::from)?;
        match port.read(buf) {
            Ok(n) => Ok(n),
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock) => Ok(0),
            Err(e) => Err(e),
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        let port = self.port.as_mut().ok_or_else(not_connected)?;
        port.set_timeout(WRITE_TIMEOUT).map_err(io::Error::from)?;
        port.write_all(bytes)
    }

    fn reconnect(&mut self) -> io::Result<()> {
        let Some(path) = &self.path else {
            // A master end cannot be reopened: keep it and look whether the peer is back (a
            // hung-up peer fails a read at once; bytes read meanwhile are kept).
            let port = self.port.as_mut().ok_or_else(not_connected)?;
            port.set_timeout(Duration::ZERO).map_err(io::Error::from)?;
            let mut probe = [0u8; 4096];
            return match port.read(&mut probe) {
                Ok(n) => {
                    self.stash.extend_from_slice(&probe[..n]);
                    Ok(())
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock) => Ok(()),
                Err(e) => Err(e),
            };
        };
        self.port = None;
        let port =
            serialport::new(path.to_string_lossy(), self.baud).timeout(Duration::from_millis(10)).open_native().map_err(io::Error::from)?;
        self.port = Some(port);
        Ok(())
    }

    fn describe(&self) -> String {
        match &self.path {
            Some(p) => p.display().to_string(),
            None => "pty master".to_string(),
        }
    }
}

#[derive(Default)]
struct PipeState {
    bytes: VecDeque<u8>,
    closed: bool,
}

#[derive(Default)]
struct Pipe {
    state: Mutex<PipeState>,
    ready: Condvar,
}

/// One end of an in-memory duplex ([`mem_pair`]): unbounded, lossless, in order.
pub struct MemLink {
    rx: Arc<Pipe>,
    tx: Arc<Pipe>,
}

/// Two connected in-memory ends.
pub fn mem_pair() -> (MemLink, MemLink) {
    let a = Arc::new(Pipe::default());
    let b = Arc::new(Pipe::default());
    (MemLink { rx: a.clone(), tx: b.clone() }, MemLink { rx: b, tx: a })
}

impl Drop for MemLink {
    fn drop(&mut self) {
        // The peer reads what is left, then an error.
        if let Ok(mut s) = self.tx.state.lock() {
            s.closed = true;
        }
        self.tx.ready.notify_all();
    }
}

impl Link for MemLink {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let deadline = Instant::now() + timeout;
        let mut s = self.rx.state.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if !s.bytes.is_empty() {
                let n = buf.len().min(s.bytes.len());
                for (d, b) in buf.iter_mut().zip(s.bytes.drain(..n)) {
                    *d = b;
                }
                return Ok(n);
            }
            if s.closed {
                return Err(io::Error::new(io::ErrorKind::BrokenPipe, "peer closed"));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(0);
            }
            s = self.rx.ready.wait_timeout(s, deadline - now).unwrap_or_else(|e| e.into_inner()).0;
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut s = self.tx.state.lock().unwrap_or_else(|e| e.into_inner());
        s.bytes.extend(bytes);
        drop(s);
        self.tx.ready.notify_all();
        Ok(())
    }

    fn reconnect(&mut self) -> io::Result<()> {
        Ok(())
    }

    fn describe(&self) -> String {
        "in-memory".to_string()
    }
}

/// Summary statistics live with the run loop; the link reports its timings with them.
pub use crate::run::Summary;

/// Timings of a process that runs for days, in bounded memory: count, minimum, maximum and mean
/// of every sample exactly, the percentiles from a systematic sample of at most
/// [`Timings::KEPT`] of them spread over the whole run (every `stride`-th; the stride doubles
/// whenever the sample fills). The node kept every tick's time before, 8 bytes a tick without end:
/// 3.5 MB a day at 5 Hz (`lives soak`'s memory check found it, docs/reliability.md).
#[derive(Clone, Debug)]
pub struct Timings {
    kept: Vec<f64>,
    stride: u64,
    n: u64,
    min: f64,
    max: f64,
    sum: f64,
}

impl Default for Timings {
    fn default() -> Self {
        Timings { kept: Vec::new(), stride: 1, n: 0, min: f64::INFINITY, max: f64::NEG_INFINITY, sum: 0.0 }
    }
}

impl Timings {
    /// Most samples kept for the percentiles.
    pub const KEPT: usize = 8192;

    /// Adds one.
    pub fn push(&mut self, v: f64) {
        self.n += 1;
        self.min = self.min.min(v);
        self.max = self.max.max(v);
        self.sum += v;
        if self.n.is_multiple_of(self.stride) {
            self.kept.push(v);
            if self.kept.len() >= Self::KEPT {
                let halved: Vec<f64> = self.kept.iter().skip(1).step_by(2).copied().collect();
                self.kept = halved;
                self.stride *= 2;
            }
        }
    }

    /// The summary: exact count, extremes and mean; percentiles of the kept sample.
    pub fn summary(&self) -> Summary {
        if self.n == 0 {
            return Summary::default();
        }
        let kept = Summary::of(&self.kept);
        Summary { n: self.n as usize, min: self.min, p50: kept.p50, p95: kept.p95, max: self.max, mean: self.sum / self.n as f64 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Serialises the tests that make pseudo-terminals.
    pub(crate) static PTY_TESTS: Mutex<()> = Mutex::new(());

    #[test]
    fn timings_stay_bounded_and_summarise_the_whole_run() {
        let mut t = Timings::default();
        for i in 0..1_000_000u32 {
            t.push((i % 1000) as f64);
        }
        assert!(t.kept.len() < Timings::KEPT && t.kept.capacity() <= 2 * Timings::KEPT, "{}", t.kept.len());
        let s = t.summary();
        assert_eq!((s.n, s.min, s.max), (1_000_000, 0.0, 999.0));
        assert!((s.mean - 499.5).abs() < 1e-9, "{}", s.mean);
        assert!((s.p50 - 500.0).abs() <= 10.0 && (s.p95 - 950.0).abs() <= 10.0, "{s:?}");
        // Few samples: all kept, exact.
        let mut t = Timings::default();
        for v in [3.0, 1.0, 2.0] {
            t.push(v);
        }
        assert_eq!(t.summary(), Summary::of(&[1.0, 2.0, 3.0]));
    }

    #[test]
    fn a_pty_pair_carries_bytes_both_ways_and_the_slave_reopens_by_path() {
        let _g = PTY_TESTS.lock().unwrap_or_else(|e| e.into_inner());
        let (mut m, mut s) = SerialLink::pty_pair().unwrap();
        let path = s.path().expect("the slave has a path").to_path_buf();
        m.write_all(b"hello\0").unwrap();
        let mut buf = [0u8; 64];
        let mut got = Vec::new();
        while got.len() < 6 {
            let n = s.read(&mut buf, Duration::from_millis(200)).unwrap();
            assert!(n > 0, "timed out");
            got.extend_from_slice(&buf[..n]);
        }
        assert_eq!(got, b"hello\0");
        // Nothing there: a timeout, not an error.
        assert_eq!(s.read(&mut buf, Duration::from_millis(5)).unwrap(), 0);

        // Pull the slave: the master sees an error (a timeout would be `Ok(0)`).
        s.close();
        assert!(m.read(&mut buf, Duration::from_millis(500)).is_err());
        assert!(m.reconnect().is_err(), "the master sees the peer is gone");
        // Plug it back by path: bytes flow again.
        let mut s2 = SerialLink::open(&path, 921_600).unwrap();
        assert!(m.reconnect().is_ok(), "the master sees the peer is back");
        s2.write_all(b"back\0").unwrap();
        let mut got = Vec::new();
        let t0 = Instant::now();
        while got.len() < 5 && t0.elapsed() < Duration::from_secs(2) {
            match m.read(&mut buf, Duration::from_millis(50)) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(_) => std::thread::sleep(Duration::from_millis(10)),
            }
        }
        assert_eq!(got, b"back\0");
    }

    #[test]
    fn a_device_that_disappears_and_comes_back_is_reopened() {
        let _g = PTY_TESTS.lock().unwrap_or_else(|e| e.into_inner());
        // A stable name (like /dev/serial/by-id/...) pointing at whichever pty is current.
        let dir = std::env::temp_dir().join(format!("lives-link-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let name = dir.join("tty");
        let (m1, s1) = SerialLink::pty_pair().unwrap();
        let _ = std::fs::remove_file(&name);
        std::os::unix::fs::symlink(s1.path().unwrap(), &name).unwrap();
        drop(s1);
        let mut bridge = SerialLink::open(&name, 921_600).unwrap();
        drop(m1); // the device disappears
        let mut buf = [0u8; 16];
        assert!(bridge.read(&mut buf, Duration::from_millis(100)).is_err() || bridge.write_all(b"x").is_err());
        let (mut m2, s2) = SerialLink::pty_pair().unwrap();
        std::fs::remove_file(&name).unwrap();
        std::os::unix::fs::symlink(s2.path().unwrap(), &name).unwrap();
        drop(s2);
        // It comes back under the same name: reconnect reopens it.
        bridge.reconnect().unwrap();
        bridge.write_all(b"again\0").unwrap();
        let mut got = Vec::new();
        let t0 = Instant::now();
        while got.len() < 6 && t0.elapsed() < Duration::from_secs(2) {
            let n = m2.read(&mut buf, Duration::from_millis(50)).unwrap_or(0);
            got.extend_from_slice(&buf[..n]);
        }
        assert_eq!(got, b"again\0");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_in_memory_duplex_is_ordered_and_reports_a_closed_peer() {
        let (mut a, mut b) = mem_pair();
        a.write_all(&[1, 2, 3]).unwrap();
        a.write_all(&[4]).unwrap();
        let mut buf = [0u8; 8];
        assert_eq!(b.read(&mut buf, Duration::ZERO).unwrap(), 4);
        assert_eq!(&buf[..4], &[1, 2, 3, 4]);
        assert_eq!(b.read(&mut buf, Duration::from_millis(1)).unwrap(), 0);
        drop(a);
        assert!(b.read(&mut buf, Duration::from_millis(1)).is_err());
    }
}
