//! The base adapter: a versioned JSON-lines interface over a localhost TCP socket through which
//! the robot's own program (a Spot SDK script, a ROS 2 node, `clients/python/sim_robot.py`)
//! supplies odometry, scans and detections and receives goals, stops and status.
//!
//! This module owns the socket and the text protocol only: accepting one client, the `hello`
//! version check, splitting and bounding lines, parsing and validating every message, the
//! client watchdog (a session without valid odometry for `watchdog` is *stale*), and writing
//! `goal`, `stop`, `status` and `error` lines. It knows nothing about the serial link or the
//! controller: [`super::robot`] turns what arrives here into frames for the node and the node's
//! answers into calls on [`AdapterServer`]. It never reads the node's clock and stamps nothing:
//! [`Input`]s carry the [`Instant`] they were received, from which the bridge stamps frames.
//!
//! Every message, with an example line, is in `docs/base-adapter.md`. Bad input never panics and
//! never ends the session by itself: a line that is not JSON, an unknown `type`, a missing or
//! mistyped field, a non-finite or negative value, a line over [`AdapterConfig::max_line_bytes`]
//! is answered with one `error` line naming the cause and the line number, and dropped; what was
//! good before (the last odometry, scan, goal) is kept. Only a `hello` with another version ends
//! the connection (after an `error` and a `stop` with reason `client-error`), and a second client
//! while one is connected is told `busy` and closed.

use serde::Deserialize;
use serde_json::{json, Value};
use std::fmt;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

/// The interface version a client states in its `hello` (`"v": 1`).
pub const ADAPTER_VERSION: u64 = 1;

/// Most ranges in one `scan` message (a 0.1° scanner has 3 600).
pub const MAX_SCAN_RANGES: usize = 16_384;

/// Largest |x| or |y| of an odometry pose or a detection, metres (the core's Q16.16 holds ±32 768 m).
pub const MAX_COORD_M: f64 = 30_000.0;

/// Tunables of the adapter.
#[derive(Clone, Debug)]
pub struct AdapterConfig {
    /// Longest line accepted, bytes (newline excluded). A longer one is answered `line_too_long`
    /// and skipped up to its newline.
    pub max_line_bytes: usize,
    /// No valid `odometry` for this long: the session is stale (`stop` with reason `stale`, no
    /// goals forwarded) until odometry flows again.
    pub watchdog: Duration,
    /// A `status` line every this long while a client is greeted.
    pub status_interval: Duration,
    /// A write that cannot complete in this long loses the client.
    pub write_timeout: Duration,
}

impl Default for AdapterConfig {
    /// 256 KiB lines, 1 s watchdog, status every second, 500 ms write timeout.
    fn default() -> Self {
        AdapterConfig {
            max_line_bytes: 256 * 1024,
            watchdog: Duration::from_secs(1),
            status_interval: Duration::from_secs(1),
            write_timeout: Duration::from_millis(500),
        }
    }
}

/// The base's pose in the odometry (map) frame: REP-103, metres and radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Odometry {
    /// Metres.
    pub x: f64,
    /// Metres.
    pub y: f64,
    /// Radians, counter-clockwise from +x.
    pub yaw: f64,
    /// The base cannot follow its path (an obstacle, a person): the controller waits, then
    /// gives the goal up.
    pub blocked: bool,
}

/// A planar scan in the robot frame, shaped like ROS `sensor_msgs/LaserScan`. Ranges follow
/// REP-117: `NAN` an invalid reading, `+INFINITY` no return, `-INFINITY` too close.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserScan {
    /// Angle of the first range, radians.
    pub angle_min: f64,
    /// Angle between ranges, radians (negative for a clockwise sensor).
    pub angle_increment: f64,
    /// Readings below this are invalid, metres.
    pub range_min: f64,
    /// Readings above this are "no return", metres.
    pub range_max: f64,
    /// Metres.
    pub ranges: Vec<f32>,
}

/// The target was seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detection {
    /// Where, in the map frame, if the client localised it.
    pub position: Option<[f64; 2]>,
}

/// Why the base is told to stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The controller found the target: the search is over.
    TargetFound,
    /// Nothing left to explore: the search is over.
    Exhausted,
    /// The serial link to the controller node was lost.
    LinkLost,
    /// The node stopped the base (its own watchdog: no pose or scan reached it).
    NodeStopped,
    /// The client sent no valid odometry for a watchdog period.
    Stale,
    /// The client's session was refused (wrong version).
    ClientError,
    /// The bridge is shutting down.
    Shutdown,
}

impl StopReason {
    /// The `reason` string on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::TargetFound => "target-found",
            StopReason::Exhausted => "exhausted",
            StopReason::LinkLost => "link-lost",
            StopReason::NodeStopped => "node-stopped",
            StopReason::Stale => "stale",
            StopReason::ClientError => "client-error",
            StopReason::Shutdown => "shutdown",
        }
    }
}

/// Why a client line was refused. [`AdapterError::code`] is the `code` of the `error` reply,
/// `Display` its `message`.
#[derive(Clone, Debug, PartialEq)]
pub enum AdapterError {
    /// Longer than the limit.
    LineTooLong {
        /// The limit, bytes.
        limit: usize,
    },
    /// Not JSON (serde_json's message).
    BadJson(String),
    /// JSON, but not an object with a string `type`.
    NotAMessage,
    /// A `type` this version does not know.
    UnknownType(String),
    /// A field missing or of the wrong type.
    BadField {
        /// The message type.
        msg: &'static str,
        /// serde_json's message.
        detail: String,
    },
    /// A value out of its domain (not finite, negative, zero increment, too many ranges).
    BadValue {
        /// `message.field`.
        field: String,
        /// What is wrong.
        detail: String,
    },
    /// A message before the `hello`.
    HelloRequired,
    /// A `hello` with another version.
    Version {
        /// The client's version.
        theirs: u64,
    },
    /// Another client is connected.
    Busy {
        /// Who.
        peer: SocketAddr,
    },
}

impl AdapterError {
    /// The `code` field of the `error` reply.
    pub fn code(&self) -> &'static str {
        match self {
            AdapterError::LineTooLong { .. } => "line_too_long",
            AdapterError::BadJson(_) => "bad_json",
            AdapterError::NotAMessage => "not_a_message",
            AdapterError::UnknownType(_) => "unknown_type",
            AdapterError::BadField { .. } => "bad_field",
            AdapterError::BadValue { .. } => "bad_value",
            AdapterError::HelloRequired => "hello_required",
            AdapterError::Version { .. } => "version",
            AdapterError::Busy { .. } => "busy",
        }
    }
}

impl fmt::Display for AdapterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdapterError::LineTooLong { limit } => write!(f, "line longer than {limit} bytes: skipped up to its newline"),
            AdapterError::BadJson(e) => {
                write!(f, "not JSON ({e}); JSON has no NaN or Infinity: send null for a NaN range, \"inf\" or \"-inf\" for infinities")
            }
            AdapterError::NotAMessage => f.write_str("expected a JSON object with a string field \"type\""),
            AdapterError::UnknownType(t) => {
                write!(f, "unknown message type \"{t}\" (v{ADAPTER_VERSION} knows hello, odometry, scan, detection)")
            }
            AdapterError::BadField { msg, detail } => write!(f, "{msg}: {detail}"),
            AdapterError::BadValue { field, detail } => write!(f, "{field} {detail}"),
            AdapterError::HelloRequired => f.write_str("send {\"type\":\"hello\",\"v\":1} first"),
            AdapterError::Version { theirs } => write!(
                f,
                "incompatible interface version: this bridge speaks v{ADAPTER_VERSION}, the client v{theirs}; use a client for v{ADAPTER_VERSION}"
            ),
            AdapterError::Busy { peer } => write!(f, "another client ({peer}) is connected; one client at a time"),
        }
    }
}

impl std::error::Error for AdapterError {}

/// One parsed client message.
#[derive(Clone, Debug, PartialEq)]
pub enum ClientMsg {
    /// The client's version and name.
    Hello {
        /// Interface version.
        v: u64,
        /// Free text.
        client: String,
    },
    /// The base's pose.
    Odometry(Odometry),
    /// A planar scan.
    Scan(LaserScan),
    /// The target was seen.
    Detection(Detection),
}

#[derive(Deserialize)]
struct HelloIn {
    v: u64,
    #[serde(default)]
    client: String,
}

#[derive(Deserialize)]
struct OdometryIn {
    x: f64,
    y: f64,
    yaw: f64,
    #[serde(default)]
    blocked: bool,
}

#[derive(Deserialize)]
struct ScanIn {
    angle_min: f64,
    angle_increment: f64,
    range_min: f64,
    range_max: f64,
    ranges: Vec<Value>,
}

#[derive(Deserialize)]
struct DetectionIn {
    x: Option<f64>,
    y: Option<f64>,
}

fn field<T: for<'de> Deserialize<'de>>(msg: &'static str, v: Value) -> Result<T, AdapterError> {
    serde_json::from_value(v).map_err(|e| AdapterError::BadField { msg, detail: e.to_string() })
}

fn bad(field: &str, detail: impl Into<String>) -> AdapterError {
    AdapterError::BadValue { field: field.to_string(), detail: detail.into() }
}

fn coord(name: &str, v: f64) -> Result<f64, AdapterError> {
    if v.abs() > MAX_COORD_M {
        return Err(bad(name, format!("= {v} is out of range (|{}| <= {MAX_COORD_M} m)", &name[name.find('.').map_or(0, |i| i + 1)..])));
    }
    Ok(v)
}

/// Parses and validates one line (without its newline). Serde_json never yields a non-finite
/// number, so every `f64` here is finite; the checks below bound them.
pub fn parse_line(line: &[u8]) -> Result<ClientMsg, AdapterError> {
    let v: Value = serde_json::from_slice(line).map_err(|e| AdapterError::BadJson(e.to_string()))?;
    let Value::Object(mut obj) = v else { return Err(AdapterError::NotAMessage) };
    let Some(Value::String(ty)) = obj.remove("type") else { return Err(AdapterError::NotAMessage) };
    let rest = Value::Object(obj);
    match ty.as_str() {
        "hello" => {
            let h: HelloIn = field("hello", rest)?;
            Ok(ClientMsg::Hello { v: h.v, client: h.client })
        }
        "odometry" => {
            let o: OdometryIn = field("odometry", rest)?;
            let (x, y) = (coord("odometry.x", o.x)?, coord("odometry.y", o.y)?);
            if o.yaw.abs() > 1000.0 {
                return Err(bad("odometry.yaw", format!("= {} is out of range (|yaw| <= 1000 rad)", o.yaw)));
            }
            Ok(ClientMsg::Odometry(Odometry { x, y, yaw: o.yaw, blocked: o.blocked }))
        }
        "scan" => {
            let s: ScanIn = field("scan", rest)?;
            if s.angle_increment == 0.0 || s.angle_increment.abs() > std::f64::consts::PI {
                return Err(bad("scan.angle_increment", format!("= {} must be non-zero and at most pi", s.angle_increment)));
            }
            if s.angle_min.abs() > 4.0 * std::f64::consts::PI {
                return Err(bad("scan.angle_min", format!("= {} is out of range (|angle_min| <= 4 pi)", s.angle_min)));
            }
            if s.range_min < 0.0 {
                return Err(bad("scan.range_min", format!("= {} is negative", s.range_min)));
            }
            if s.range_max <= s.range_min {
                return Err(bad("scan.range_max", format!("= {} must exceed range_min ({})", s.range_max, s.range_min)));
            }
            if s.ranges.is_empty() || s.ranges.len() > MAX_SCAN_RANGES {
                return Err(bad("scan.ranges", format!("has {} values (1 to {MAX_SCAN_RANGES})", s.ranges.len())));
            }
            let mut ranges = Vec::with_capacity(s.ranges.len());
            for (i, r) in s.ranges.iter().enumerate() {
                let m = match r {
                    Value::Null => f32::NAN,
                    Value::Number(n) => match n.as_f64() {
                        Some(m) if m >= 0.0 => m as f32,
                        _ => return Err(bad(&format!("scan.ranges[{i}]"), format!("= {n} is negative"))),
                    },
                    Value::String(t) if t == "inf" || t == "+inf" => f32::INFINITY,
                    Value::String(t) if t == "-inf" => f32::NEG_INFINITY,
                    other => {
                        return Err(bad(&format!("scan.ranges[{i}]"), format!("= {other} is not a number, null, \"inf\" or \"-inf\"")))
                    }
                };
                ranges.push(m);
            }
            Ok(ClientMsg::Scan(LaserScan {
                angle_min: s.angle_min,
                angle_increment: s.angle_increment,
                range_min: s.range_min,
                range_max: s.range_max,
                ranges,
            }))
        }
        "detection" => {
            let d: DetectionIn = field("detection", rest)?;
            let position = match (d.x, d.y) {
                (Some(x), Some(y)) => Some([coord("detection.x", x)?, coord("detection.y", y)?]),
                (None, None) => None,
                _ => return Err(bad("detection", "needs both x and y, or neither")),
            };
            Ok(ClientMsg::Detection(Detection { position }))
        }
        _ => Err(AdapterError::UnknownType(ty)),
    }
}

/// What the adapter reports to its owner from a [`AdapterServer::poll`].
#[derive(Clone, Debug, PartialEq)]
pub enum Input {
    /// A client said a compatible `hello`.
    Greeted {
        /// Its address.
        peer: SocketAddr,
        /// Its name.
        client: String,
    },
    /// Valid odometry.
    Odometry(Odometry, Instant),
    /// A valid scan.
    Scan(LaserScan, Instant),
    /// A detection.
    Detection(Detection, Instant),
    /// The session went stale (no valid odometry for the watchdog period); `stop` was sent.
    Stale,
    /// The connected client is gone (closed, reset, a write failed, or refused); its base is to
    /// be considered stopped.
    ClientGone {
        /// Why.
        cause: String,
    },
}

/// Counters of the adapter.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct AdapterStats {
    /// Connections accepted (busy ones included).
    pub connections: u32,
    /// Connections refused because another client was connected.
    pub busy_refused: u32,
    /// Lines received (all clients).
    pub lines: u64,
    /// Bytes received.
    pub bytes_in: u64,
    /// Lines written.
    pub lines_out: u64,
    /// Bytes written.
    pub bytes_out: u64,
    /// Valid messages by type.
    pub odometry: u64,
    /// Valid scans.
    pub scans: u64,
    /// Detections.
    pub detections: u64,
    /// `error` replies sent.
    pub errors: u64,
    /// `goal` lines sent.
    pub goals_sent: u64,
    /// `stop` lines sent.
    pub stops_sent: u64,
    /// `status` lines sent.
    pub status_sent: u64,
    /// Times the session went stale.
    pub stale: u32,
    /// Clients gone.
    pub disconnects: u32,
}

struct Client {
    stream: TcpStream,
    peer: SocketAddr,
    buf: Vec<u8>,
    /// Skipping the rest of an over-long line.
    discarding: bool,
    greeted: bool,
    line_no: u64,
    last_odometry: Option<Instant>,
    stale: bool,
    /// Leave after the pending writes (a refused session).
    closing: Option<String>,
}

/// The adapter's listening socket and its one client.
pub struct AdapterServer {
    listener: TcpListener,
    cfg: AdapterConfig,
    client: Option<Client>,
    last_status: Option<Instant>,
    /// Counters.
    pub stats: AdapterStats,
}

impl AdapterServer {
    /// Listens on `addr` (e.g. `127.0.0.1:7100`; port 0 picks one, see [`AdapterServer::local_addr`]).
    pub fn bind(addr: SocketAddr, cfg: AdapterConfig) -> io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        Ok(AdapterServer { listener, cfg, client: None, last_status: None, stats: AdapterStats::default() })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// The configuration.
    pub fn config(&self) -> &AdapterConfig {
        &self.cfg
    }

    /// A client is connected and said `hello`.
    pub fn greeted(&self) -> bool {
        self.client.as_ref().is_some_and(|c| c.greeted)
    }

    /// A greeted client whose odometry is fresh (within the watchdog): goals may be forwarded.
    pub fn live(&self) -> bool {
        self.client.as_ref().is_some_and(|c| c.greeted && !c.stale && c.last_odometry.is_some_and(|t| t.elapsed() < self.cfg.watchdog))
    }

    /// The connected client's address.
    pub fn peer(&self) -> Option<SocketAddr> {
        self.client.as_ref().map(|c| c.peer)
    }

    /// Accepts a client if none is connected (others are told `busy`), reads what the client sent
    /// for up to `wait`, answers bad lines, and checks the watchdog.
    pub fn poll(&mut self, wait: Duration) -> Vec<Input> {
        let mut out = Vec::new();
        self.accept();
        if self.client.is_none() {
            std::thread::sleep(wait);
            return out;
        }
        let mut chunk = [0u8; 65536];
        let read = {
            let c = self.client.as_mut().expect("checked above");
            let _ = c.stream.set_read_timeout(Some(wait.max(Duration::from_micros(100))));
            c.stream.read(&mut chunk)
        };
        match read {
            Ok(0) => self.drop_client("the client closed the connection".to_string(), &mut out),
            Ok(n) => {
                self.stats.bytes_in += n as u64;
                self.feed(&chunk[..n], &mut out);
            }
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {}
            Err(e) => self.drop_client(format!("read failed: {e}"), &mut out),
        }
        if let Some(cause) = self.client.as_ref().and_then(|c| c.closing.clone()) {
            self.drop_client(cause, &mut out);
        }
        let watchdog = self.cfg.watchdog;
        let stale = self.client.as_mut().is_some_and(|c| {
            let silent = c.last_odometry.is_none_or(|t| t.elapsed() >= watchdog);
            // Greeted but silent for a watchdog period (from the hello if no odometry yet).
            let due = c.greeted && !c.stale && silent && c.last_odometry.is_some();
            if due {
                c.stale = true;
            }
            due
        });
        if stale {
            self.stats.stale += 1;
            self.send_stop(StopReason::Stale, &format!("no valid odometry for {:.1} s", watchdog.as_secs_f64()));
            out.push(Input::Stale);
        }
        out
    }

    fn accept(&mut self) {
        loop {
            match self.listener.accept() {
                Ok((stream, peer)) => {
                    self.stats.connections += 1;
                    let _ = stream.set_nodelay(true);
                    let _ = stream.set_nonblocking(false);
                    let _ = stream.set_write_timeout(Some(self.cfg.write_timeout));
                    if let Some(c) = &self.client {
                        self.stats.busy_refused += 1;
                        let mut s = stream;
                        let line = error_line(&AdapterError::Busy { peer: c.peer }, None);
                        let _ = s.write_all(line.as_bytes());
                        continue;
                    }
                    self.client = Some(Client {
                        stream,
                        peer,
                        buf: Vec::new(),
                        discarding: false,
                        greeted: false,
                        line_no: 0,
                        last_odometry: None,
                        stale: false,
                        closing: None,
                    });
                }
                Err(_) => return,
            }
        }
    }

    fn drop_client(&mut self, cause: String, out: &mut Vec<Input>) {
        if self.client.take().is_some() {
            self.stats.disconnects += 1;
            out.push(Input::ClientGone { cause });
        }
    }

    fn feed(&mut self, bytes: &[u8], out: &mut Vec<Input>) {
        let limit = self.cfg.max_line_bytes;
        let mut rest = bytes;
        while !rest.is_empty() {
            let Some(c) = self.client.as_mut() else { return };
            if c.closing.is_some() {
                return;
            }
            let (part, newline) = match rest.iter().position(|&b| b == b'\n') {
                Some(i) => (&rest[..i], true),
                None => (rest, false),
            };
            rest = if newline { &rest[part.len() + 1..] } else { &[] };
            if c.discarding {
                if newline {
                    c.discarding = false;
                }
                continue;
            }
            if c.buf.len() + part.len() > limit {
                c.buf.clear();
                c.line_no += 1;
                c.discarding = !newline;
                let n = c.line_no;
                self.stats.lines += 1;
                self.reply_error(&AdapterError::LineTooLong { limit }, Some(n));
                continue;
            }
            c.buf.extend_from_slice(part);
            if newline {
                let mut line = std::mem::take(&mut c.buf);
                if line.last() == Some(&b'\r') {
                    line.pop();
                }
                if line.iter().all(|b| b.is_ascii_whitespace()) {
                    continue;
                }
                c.line_no += 1;
                self.stats.lines += 1;
                let n = c.line_no;
                self.line(&line, n, out);
            }
        }
    }

    fn line(&mut self, line: &[u8], n: u64, out: &mut Vec<Input>) {
        let now = Instant::now();
        let msg = match parse_line(line) {
            Ok(m) => m,
            Err(e) => return self.reply_error(&e, Some(n)),
        };
        let greeted = self.client.as_ref().is_some_and(|c| c.greeted);
        match msg {
            ClientMsg::Hello { v, client } => {
                if v != ADAPTER_VERSION {
                    self.reply_error(&AdapterError::Version { theirs: v }, Some(n));
                    self.send_stop(StopReason::ClientError, "incompatible interface version");
                    if let Some(c) = self.client.as_mut() {
                        c.closing = Some(format!("refused: the client speaks v{v}"));
                    }
                    return;
                }
                let hello = json!({
                    "type": "hello",
                    "v": ADAPTER_VERSION,
                    "server": "lives-bridge",
                    "version": env!("CARGO_PKG_VERSION"),
                    "watchdog_s": self.cfg.watchdog.as_secs_f64(),
                    "max_line_bytes": self.cfg.max_line_bytes,
                });
                self.write_line(&hello);
                if let Some(c) = self.client.as_mut() {
                    if !c.greeted {
                        c.greeted = true;
                        out.push(Input::Greeted { peer: c.peer, client });
                    }
                }
            }
            _ if !greeted => self.reply_error(&AdapterError::HelloRequired, Some(n)),
            ClientMsg::Odometry(o) => {
                self.stats.odometry += 1;
                if let Some(c) = self.client.as_mut() {
                    c.last_odometry = Some(now);
                    c.stale = false;
                }
                out.push(Input::Odometry(o, now));
            }
            ClientMsg::Scan(s) => {
                self.stats.scans += 1;
                out.push(Input::Scan(s, now));
            }
            ClientMsg::Detection(d) => {
                self.stats.detections += 1;
                out.push(Input::Detection(d, now));
            }
        }
    }

    fn reply_error(&mut self, e: &AdapterError, line: Option<u64>) {
        self.stats.errors += 1;
        let text = error_line(e, line);
        self.write_raw(text);
    }

    /// Writes one JSON value as a line. A failed write loses the client (reported by the next
    /// [`AdapterServer::poll`]).
    pub fn write_line(&mut self, v: &Value) -> bool {
        let mut text = v.to_string();
        text.push('\n');
        self.write_raw(text)
    }

    fn write_raw(&mut self, text: String) -> bool {
        let Some(c) = self.client.as_mut() else { return false };
        match c.stream.write_all(text.as_bytes()) {
            Ok(()) => {
                self.stats.lines_out += 1;
                self.stats.bytes_out += text.len() as u64;
                true
            }
            Err(e) => {
                c.closing = Some(format!("write failed: {e}"));
                false
            }
        }
    }

    /// Sends `goal` (pose and path in the map frame, metres and radians) to a greeted client.
    /// Metres are rounded to 0.1 mm and radians to 1 µrad (the core's Q16.16 metres step by
    /// 0.015 mm: the rounding only drops digits that mean nothing).
    pub fn send_goal(&mut self, seq: u32, pose: [f64; 3], path: &[[f64; 2]], path_length_m: f64) -> bool {
        if !self.greeted() {
            return false;
        }
        let path: Vec<[f64; 2]> = path.iter().map(|p| [round_to(p[0], 1e4), round_to(p[1], 1e4)]).collect();
        let ok = self.write_line(&json!({
            "type": "goal", "seq": seq, "x": round_to(pose[0], 1e4), "y": round_to(pose[1], 1e4), "yaw": round_to(pose[2], 1e6),
            "path": path, "path_length": round_to(path_length_m, 1e4),
        }));
        self.stats.goals_sent += ok as u64;
        ok
    }

    /// Sends `stop` with `reason` to a greeted client.
    pub fn send_stop(&mut self, reason: StopReason, detail: &str) -> bool {
        if self.client.is_none() {
            return false;
        }
        let ok = self.write_line(&json!({ "type": "stop", "reason": reason.as_str(), "detail": detail }));
        self.stats.stops_sent += ok as u64;
        ok
    }

    /// Sends `status` (the object's fields after `"type":"status"`) if one is due.
    pub fn status_due(&self) -> bool {
        self.greeted() && self.last_status.is_none_or(|t| t.elapsed() >= self.cfg.status_interval)
    }

    /// Sends a `status` line with these fields.
    pub fn send_status(&mut self, fields: serde_json::Map<String, Value>) -> bool {
        let mut obj = serde_json::Map::new();
        obj.insert("type".into(), Value::from("status"));
        obj.extend(fields);
        self.last_status = Some(Instant::now());
        let ok = self.write_line(&Value::Object(obj));
        self.stats.status_sent += ok as u64;
        ok
    }

    /// Closes the client's connection (after a final `stop`, which the caller sends), gracefully:
    /// our side is shut for writing first, so the `stop` and then the end of the stream reach
    /// the client in order, and what the client still sends meanwhile (odometry, scans) is read
    /// and dropped until it closes too, or [`CLOSE_LINGER`] passes. Closing with unread input
    /// makes the kernel reset the connection, and a client that was still writing would then
    /// get a broken pipe and could lose the `stop` it had not read yet.
    pub fn close(&mut self) {
        if let Some(mut c) = self.client.take() {
            let _ = c.stream.shutdown(std::net::Shutdown::Write);
            let _ = c.stream.set_nonblocking(false);
            let _ = c.stream.set_read_timeout(Some(Duration::from_millis(50)));
            let deadline = Instant::now() + CLOSE_LINGER;
            let mut sink = [0u8; 4096];
            while Instant::now() < deadline {
                match c.stream.read(&mut sink) {
                    Ok(0) => break,
                    Ok(_) => {}
                    Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {}
                    Err(_) => break,
                }
            }
            let _ = c.stream.shutdown(std::net::Shutdown::Both);
        }
    }
}

/// How long [`AdapterServer::close`] waits for the client to close after the final `stop`.
pub const CLOSE_LINGER: Duration = Duration::from_secs(1);

/// `v` rounded to `1 / per` (e.g. `per = 1e4`: 0.1 mm).
pub fn round_to(v: f64, per: f64) -> f64 {
    (v * per).round() / per
}

/// The `error` line for `e` about the client's line `line` (1-based), newline included.
pub fn error_line(e: &AdapterError, line: Option<u64>) -> String {
    let mut v = json!({ "type": "error", "code": e.code(), "message": e.to_string() });
    if let Some(n) = line {
        v["line"] = Value::from(n);
    }
    let mut s = v.to_string();
    s.push('\n');
    s
}

#[cfg(test)]
mod tests;
