//! The base adapter (issue 8 part 4, `docs/base-adapter.md`): a robot's own program supplies
//! odometry, scans and detections over JSON lines on localhost TCP and receives goals and stops.
//!
//! * End to end: the controller node (in a thread, real time) and the `lives bridge --source
//!   robot` binary on the two ends of a pseudo-terminal pair, and the reference client's
//!   simulated robot (`clients/python/sim_robot.py`, a kinematic robot in a 12 m x 8 m room): the
//!   robot receives goals inside the room, walks them, sees the target and is told
//!   `stop` (`target-found`).
//! * The adapter alone: every kind of bad input gets its exact `error` reply and the session goes
//!   on with what was good; a wrong version is refused and the connection closed; a second
//!   client is told `busy`.
//! * The bridge's safety rules with an in-process node: a stale client gets `stop` and no goals
//!   until its odometry resumes; a client that disconnects leaves the node stopped by its
//!   watchdog, and the next client gets the goal again; a lost node link is `stop` (`link-lost`)
//!   within the watchdog period; a bridge shutting down says `stop` (`shutdown`).
//!
//! Needs `python3` (standard library only) on the PATH, or `LIVES_PYTHON` naming one.

use firmware::node::TimeMode;
use firmware::Config;
use host::link::adapter::{error_line, AdapterConfig, AdapterError, AdapterServer, Input, StopReason};
use host::link::{
    mem_pair, run_robot, BridgeOptions, FaultConfig, FaultHandle, FaultyLink, Link, NodeOptions, NodeProcess, RobotRun, RobotSpec,
    SerialLink,
};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

mod common;
use common::{lives, root};

/// Tests that run a node and a bridge in real time go one at a time (2-core machines).
static SERIAL: Mutex<()> = Mutex::new(());

/// python3 (standard library only), or a failure that says exactly what to install.
fn python() -> String {
    let py = std::env::var("LIVES_PYTHON").unwrap_or_else(|_| "python3".to_string());
    let ok = Command::new(&py).args(["-c", "import json, socket, select"]).status().is_ok_and(|s| s.success());
    assert!(
        ok,
        "`{py}` was not found or cannot import the standard library: install Python 3 (e.g. `apt-get install python3`) \
         or set LIVES_PYTHON=/path/to/python3; the reference client needs nothing else"
    );
    py
}

fn read_line(r: &mut BufReader<TcpStream>) -> String {
    let mut s = String::new();
    r.read_line(&mut s).expect("a line from the bridge");
    s
}

fn parse(line: &str) -> Value {
    serde_json::from_str(line).unwrap_or_else(|e| panic!("the bridge sent JSON: {e}: {line:?}"))
}

/// A client socket with a reader and a 5 s read timeout.
fn connect(addr: SocketAddr) -> (TcpStream, BufReader<TcpStream>) {
    let s = TcpStream::connect(addr).expect("connects");
    s.set_nodelay(true).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let r = BufReader::new(s.try_clone().unwrap());
    (s, r)
}

/// Polls `server` until it has answered (or `n` polls), collecting inputs.
fn pump(server: &mut AdapterServer, n: usize) -> Vec<Input> {
    let mut all = Vec::new();
    for _ in 0..n {
        all.extend(server.poll(Duration::from_millis(5)));
    }
    all
}

#[test]
fn a_simulated_robot_behind_the_adapter_gets_goals_in_its_room_and_is_stopped_on_finding_the_target() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let py = python();
    let bin = lives();
    let (master, slave) = SerialLink::pty_pair().expect("a pseudo-terminal pair");
    let slave_path = slave.path().expect("the slave has a path").to_path_buf();
    drop(slave); // the bridge opens it by path
    let stop_node = std::sync::Arc::new(AtomicBool::new(false));
    let node = std::thread::spawn({
        let stop_node = stop_node.clone();
        move || {
            let mut master = master;
            let mut p = NodeProcess::new(Config::DEFAULT, NodeOptions::new(TimeMode::RealTime)).expect("no model");
            p.run(&mut master, &stop_node);
            p.report()
        }
    });
    let t0 = Instant::now();
    let mut bridge = Command::new(bin)
        .args(["bridge", "--source", "robot", "--base-listen", "127.0.0.1:0", "--json", "--port"])
        .arg(&slave_path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lives bridge starts");
    // The bridge says where the adapter listens (port 0: the system picked one).
    let mut err = BufReader::new(bridge.stderr.take().unwrap());
    let addr: SocketAddr = loop {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "the bridge ended before listening");
        if let Some(rest) = line.split("listening on ").nth(1) {
            break rest.split_whitespace().next().unwrap().parse().expect("an address");
        }
    };
    let stderr_rest = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let robot = Command::new(&py)
        .arg(root().join("clients/python/sim_robot.py"))
        .args(["--port", &addr.port().to_string(), "--timeout", "240"])
        .stderr(Stdio::inherit())
        .output()
        .expect("python3 runs sim_robot.py");
    let robot_s = t0.elapsed().as_secs_f64();
    let summary: Value = serde_json::from_slice(robot.stdout.trim_ascii())
        .unwrap_or_else(|e| panic!("sim_robot.py printed its summary: {e}: {}", String::from_utf8_lossy(&robot.stdout)));
    let bridge_out = bridge.wait_with_output().expect("the bridge ends");
    stop_node.store(true, Ordering::Relaxed);
    let node = node.join().expect("node thread");
    let bridge_err = stderr_rest.join().unwrap();
    let run: Value = serde_json::from_slice(bridge_out.stdout.trim_ascii())
        .unwrap_or_else(|e| panic!("the bridge printed JSON: {e}: {} / {bridge_err}", String::from_utf8_lossy(&bridge_out.stdout)));

    let goals = summary["goals"].as_array().expect("goals");
    eprintln!(
        "[adapter e2e] robot: {} after {:.1} s ({:.1} s wall incl. start-up), {} goals, {:.1} m driven, first detection at {} s, {} status lines, errors {}",
        summary["result"],
        summary["elapsed_s"].as_f64().unwrap_or(f64::NAN),
        robot_s,
        goals.len(),
        summary["driven_m"].as_f64().unwrap_or(f64::NAN),
        summary["first_detection_s"],
        summary["status"],
        summary["errors"]
    );
    eprintln!(
        "[adapter e2e] bridge: {} in {} s, {} ticks, node goals {}; first goal {} s after the first odometry; goal forwarding {} us; detection to stop(target-found) {} ms; adapter {}",
        run["result"]["outcome"],
        run["result"]["time_s"],
        run["result"]["ticks"],
        run["result"]["goals"],
        run["first_goal_s"],
        run["goal_forward_us"],
        run["detection_to_stop_ms"],
        run["adapter"]
    );
    eprintln!(
        "[adapter e2e] node: {} ticks, tick {:.2} ms mean / {:.2} ms max",
        node.counters.ticks,
        node.tick_us.mean / 1e3,
        node.tick_us.max / 1e3
    );
    // The run is a new mission: the node was reset once, before the configuration.
    assert_eq!(node.counters.resets, 1);
    assert_eq!(robot.status.code(), Some(0), "sim_robot.py exits 0 on stop(target-found): {summary}");
    assert_eq!(summary["result"], "target-found");
    assert_eq!(summary["stops"].as_array().and_then(|s| s.last()).map(|s| s["reason"].clone()), Some(Value::from("target-found")));
    assert!(goals.len() >= 2, "the robot was sent goals: {summary}");
    for g in goals {
        assert_eq!(g["inside"], true, "goal and path inside the 12 m x 8 m room: {g}");
        assert!(!g["path"].as_array().unwrap().is_empty());
    }
    assert!(summary["detections_sent"].as_u64().unwrap() >= 1);
    assert!(summary["errors"].as_array().unwrap().is_empty(), "no error replies: {summary}");
    assert_eq!(bridge_out.status.code(), Some(0), "the bridge exits 0 when found: {bridge_err}");
    assert_eq!(run["result"]["outcome"], "found");
    assert_eq!(run["adapter"]["errors"], 0);
    assert!(run["adapter"]["scans"].as_u64().unwrap() > 10);
    assert!(run["result"]["goals"].as_u64().unwrap() >= 2);
}

#[test]
fn a_client_still_writing_when_the_session_ends_reads_its_stop_before_its_writes_fail() {
    // A robot streams odometry without waiting for the bridge. When the search ends the bridge
    // sends `stop` and closes; the close must not reset the connection under the client's feet
    // (a write failing before the client has read the `stop` loses the reason it stopped).
    let mut server = AdapterServer::bind("127.0.0.1:0".parse().unwrap(), AdapterConfig::default()).unwrap();
    let (mut c, mut r) = connect(server.local_addr().unwrap());
    c.write_all(b"{\"type\":\"hello\",\"v\":1,\"client\":\"test\"}\n").unwrap();
    assert!(matches!(&pump(&mut server, 4)[..], [Input::Greeted { .. }]));
    assert_eq!(parse(&read_line(&mut r))["type"], "hello");
    let stop_read = std::sync::Arc::new(AtomicBool::new(false));
    let writer = std::thread::spawn({
        let mut c = c.try_clone().unwrap();
        let stop_read = stop_read.clone();
        move || {
            let line = b"{\"type\":\"odometry\",\"x\":1,\"y\":2,\"yaw\":0}\n";
            let t0 = Instant::now();
            while t0.elapsed() < Duration::from_secs(5) {
                if c.write_all(line).is_err() {
                    return Some(stop_read.load(Ordering::SeqCst));
                }
                std::thread::sleep(Duration::from_micros(500));
            }
            None
        }
    });
    // Unread odometry piles up in the server's socket, as it does behind a busy bridge.
    std::thread::sleep(Duration::from_millis(50));
    assert!(server.send_stop(StopReason::TargetFound, "test"));
    let reader = std::thread::spawn({
        let stop_read = stop_read.clone();
        move || {
            let line = read_line(&mut r);
            stop_read.store(parse(&line)["type"] == "stop", Ordering::SeqCst);
            let mut rest = Vec::new();
            let end = r.read_to_end(&mut rest);
            (parse(&line), end.map(|_| rest.len()).map_err(|e| e.to_string()))
        }
    });
    server.close();
    let (stop, end) = reader.join().unwrap();
    assert_eq!((stop["type"].as_str(), stop["reason"].as_str()), (Some("stop"), Some("target-found")), "{stop}");
    assert_eq!(end, Ok(0), "then the stream ends cleanly");
    // The client closes after reading the stop (as sim_robot.py does); its writes had not failed
    // before it read it.
    drop(c);
    if let Some(had_read) = writer.join().unwrap() {
        assert!(had_read, "a write failed before the client could read its stop");
    }
}

#[test]
fn bad_lines_get_their_exact_error_and_the_session_keeps_what_was_good() {
    let cfg = AdapterConfig { max_line_bytes: 1000, ..AdapterConfig::default() };
    let mut server = AdapterServer::bind("127.0.0.1:0".parse().unwrap(), cfg).unwrap();
    let (mut c, mut r) = connect(server.local_addr().unwrap());
    let exchange = |c: &mut TcpStream, server: &mut AdapterServer, line: &[u8]| {
        c.write_all(line).unwrap();
        pump(server, 4)
    };

    // Before the hello: refused, not applied.
    let got = exchange(&mut c, &mut server, b"{\"type\":\"odometry\",\"x\":1,\"y\":2,\"yaw\":0}\n");
    assert!(got.is_empty());
    assert_eq!(
        read_line(&mut r),
        "{\"code\":\"hello_required\",\"line\":1,\"message\":\"send {\\\"type\\\":\\\"hello\\\",\\\"v\\\":1} first\",\"type\":\"error\"}\n"
    );
    let got = exchange(&mut c, &mut server, b"{\"type\":\"hello\",\"v\":1,\"client\":\"test\"}\n");
    assert!(matches!(&got[..], [Input::Greeted { client, .. }] if client == "test"), "{got:?}");
    let hello = parse(&read_line(&mut r));
    assert_eq!((hello["type"].as_str(), hello["v"].as_u64(), hello["watchdog_s"].as_f64()), (Some("hello"), Some(1), Some(1.0)));

    let good = exchange(&mut c, &mut server, b"{\"type\":\"odometry\",\"x\":1.5,\"y\":-2,\"yaw\":0.25}\r\n");
    assert!(matches!(good[..], [Input::Odometry(o, _)] if (o.x, o.y, o.yaw, o.blocked) == (1.5, -2.0, 0.25, false)), "{good:?}");
    assert!(server.live());

    // (line sent, exact reply): every cause, each with the number of the line it refers to.
    let cases: Vec<(&[u8], String)> = vec![
        (b"this is not json\n", r#"{"code":"bad_json","line":4,"message":"not JSON (expected ident at line 1 column 2); JSON has no NaN or Infinity: send null for a NaN range, \"inf\" or \"-inf\" for infinities","type":"error"}"#.into()),
        (b"{\"type\":\"odometry\",\"x\":NaN,\"y\":0,\"yaw\":0}\n", r#"{"code":"bad_json","line":5,"message":"not JSON (expected value at line 1 column 24); JSON has no NaN or Infinity: send null for a NaN range, \"inf\" or \"-inf\" for infinities","type":"error"}"#.into()),
        (b"{\"type\":\"odometry\",\"x\":null,\"y\":0,\"yaw\":0}\n", r#"{"code":"bad_field","line":6,"message":"odometry: invalid type: null, expected f64","type":"error"}"#.into()),
        (b"{\"type\":\"odometry\",\"x\":1,\"yaw\":0}\n", r#"{"code":"bad_field","line":7,"message":"odometry: missing field `y`","type":"error"}"#.into()),
        (b"{\"type\":\"odometry\",\"x\":-1e9,\"y\":0,\"yaw\":0}\n", r#"{"code":"bad_value","line":8,"message":"odometry.x = -1000000000 is out of range (|x| <= 30000 m)","type":"error"}"#.into()),
        (b"{\"type\":\"teleport\",\"x\":1}\n", r#"{"code":"unknown_type","line":9,"message":"unknown message type \"teleport\" (v1 knows hello, odometry, scan, detection)","type":"error"}"#.into()),
        (b"[1,2,3]\n", r#"{"code":"not_a_message","line":10,"message":"expected a JSON object with a string field \"type\"","type":"error"}"#.into()),
        (b"{\"type\":\"scan\",\"angle_min\":0,\"angle_increment\":0.1,\"range_min\":0.1,\"range_max\":30,\"ranges\":[1.0,-0.5]}\n", r#"{"code":"bad_value","line":11,"message":"scan.ranges[1] = -0.5 is negative","type":"error"}"#.into()),
        (b"{\"type\":\"scan\",\"angle_min\":0,\"angle_increment\":0,\"range_min\":0.1,\"range_max\":30,\"ranges\":[1.0]}\n", r#"{"code":"bad_value","line":12,"message":"scan.angle_increment = 0 must be non-zero and at most pi","type":"error"}"#.into()),
        (b"{\"type\":\"scan\",\"angle_min\":0,\"angle_increment\":0.1,\"range_min\":-1,\"range_max\":30,\"ranges\":[1.0]}\n", r#"{"code":"bad_value","line":13,"message":"scan.range_min = -1 is negative","type":"error"}"#.into()),
        (b"{\"type\":\"scan\",\"angle_min\":0,\"angle_increment\":0.1,\"range_min\":0.1,\"range_max\":30,\"ranges\":[1.0,\"far\"]}\n", r#"{"code":"bad_value","line":14,"message":"scan.ranges[1] = \"far\" is not a number, null, \"inf\" or \"-inf\"","type":"error"}"#.into()),
        (b"{\"type\":\"detection\",\"x\":3}\n", r#"{"code":"bad_value","line":15,"message":"detection needs both x and y, or neither","type":"error"}"#.into()),
    ];
    for (line, want) in &cases {
        let got = exchange(&mut c, &mut server, line);
        assert!(got.is_empty(), "a bad line is not applied: {got:?}");
        assert_eq!(read_line(&mut r).trim_end(), want, "reply to {}", String::from_utf8_lossy(line).trim_end());
    }
    // An over-long line, sent in pieces: one error, skipped to its newline, then the session goes on.
    let mut long = b"{\"type\":\"scan\",\"ranges\":[".to_vec();
    long.extend(std::iter::repeat_n(b"1.0,".as_slice(), 600).flatten());
    c.write_all(&long[..1500]).unwrap();
    pump(&mut server, 3);
    c.write_all(&long[1500..]).unwrap();
    c.write_all(b"1.0]}\n").unwrap();
    let got = exchange(&mut c, &mut server, b"{\"type\":\"odometry\",\"x\":2,\"y\":3,\"yaw\":-1}\n");
    assert_eq!(
        read_line(&mut r).trim_end(),
        r#"{"code":"line_too_long","line":16,"message":"line longer than 1000 bytes: skipped up to its newline","type":"error"}"#
    );
    assert!(matches!(got[..], [Input::Odometry(o, _)] if (o.x, o.y, o.yaw) == (2.0, 3.0, -1.0)), "the next line is read: {got:?}");
    // A scan with ROS's special values is accepted.
    let got = exchange(
        &mut c,
        &mut server,
        b"{\"type\":\"scan\",\"angle_min\":-3.14159,\"angle_increment\":0.5,\"range_min\":0.1,\"range_max\":30,\"ranges\":[1.0,null,\"inf\",\"-inf\",0.0]}\n",
    );
    let [Input::Scan(s, _)] = &got[..] else { panic!("a scan: {got:?}") };
    assert_eq!(s.ranges.len(), 5);
    assert!(s.ranges[1].is_nan() && s.ranges[2] == f32::INFINITY && s.ranges[3] == f32::NEG_INFINITY);
    assert_eq!(server.stats.errors, 14);
    assert_eq!(server.stats.odometry, 2);
    assert!(server.live(), "errors did not end the session");
    // Nothing else was sent.
    c.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    let mut rest = String::new();
    assert!(r.read_line(&mut rest).is_err() && rest.is_empty(), "unexpected: {rest}");
}

#[test]
fn a_wrong_version_is_refused_clearly_and_a_second_client_is_told_busy() {
    let mut server = AdapterServer::bind("127.0.0.1:0".parse().unwrap(), AdapterConfig::default()).unwrap();
    let addr = server.local_addr().unwrap();
    let (mut c, mut r) = connect(addr);
    c.write_all(b"{\"type\":\"hello\",\"v\":2,\"client\":\"future\"}\n").unwrap();
    let got = pump(&mut server, 4);
    assert_eq!(
        read_line(&mut r).trim_end(),
        r#"{"code":"version","line":1,"message":"incompatible interface version: this bridge speaks v1, the client v2; use a client for v1","type":"error"}"#
    );
    assert_eq!(read_line(&mut r).trim_end(), r#"{"detail":"incompatible interface version","reason":"client-error","type":"stop"}"#);
    assert_eq!(read_line(&mut r), "", "then the connection is closed");
    assert!(matches!(&got[..], [Input::ClientGone { cause }] if cause == "refused: the client speaks v2"), "{got:?}");

    // One client at a time: the second is told who is connected, and closed.
    let (mut c1, mut r1) = connect(addr);
    c1.write_all(b"{\"type\":\"hello\",\"v\":1}\n").unwrap();
    pump(&mut server, 3);
    assert_eq!(parse(&read_line(&mut r1))["type"], "hello");
    let (_c2, mut r2) = connect(addr);
    pump(&mut server, 3);
    let peer = server.peer().unwrap();
    assert_eq!(read_line(&mut r2), error_line(&AdapterError::Busy { peer }, None));
    assert_eq!(
        error_line(&AdapterError::Busy { peer }, None),
        format!("{{\"code\":\"busy\",\"message\":\"another client ({peer}) is connected; one client at a time\",\"type\":\"error\"}}\n")
    );
    assert_eq!(read_line(&mut r2), "", "closed");
    assert_eq!(server.stats.busy_refused, 1);
    assert!(server.greeted(), "the first client is still served");
}

/// A minimal robot client in Rust for the safety tests: an empty 10 m room around the origin.
struct TestClient {
    s: TcpStream,
    r: BufReader<TcpStream>,
}

impl TestClient {
    fn connect(addr: SocketAddr) -> Self {
        let (mut s, mut r) = connect(addr);
        s.write_all(b"{\"type\":\"hello\",\"v\":1,\"client\":\"rust-test\"}\n").unwrap();
        assert_eq!(parse(&read_line(&mut r))["type"], "hello");
        s.set_nonblocking(false).unwrap();
        r.get_ref().set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        TestClient { s, r }
    }

    /// Sends odometry (and a scan of a 10 m square room) and collects what arrives for `dur`.
    fn drive(&mut self, dur: Duration, send: bool) -> Vec<Value> {
        self.drive_timed(dur, send).into_iter().map(|(_, v)| v).collect()
    }

    /// [`TestClient::drive`], with the time each message arrived.
    fn drive_timed(&mut self, dur: Duration, send: bool) -> Vec<(Instant, Value)> {
        let t0 = Instant::now();
        let mut got = Vec::new();
        let mut k = 0;
        while t0.elapsed() < dur {
            if send {
                let _ = self.s.write_all(b"{\"type\":\"odometry\",\"x\":0,\"y\":0,\"yaw\":0}\n");
                if k % 4 == 0 {
                    let ranges: Vec<String> = (0..360)
                        .map(|i| {
                            let a = -std::f64::consts::PI + i as f64 * std::f64::consts::TAU / 360.0;
                            format!("{:.3}", 5.0 / a.cos().abs().max(a.sin().abs()))
                        })
                        .collect();
                    let line = format!(
                        "{{\"type\":\"scan\",\"angle_min\":{},\"angle_increment\":{},\"range_min\":0.1,\"range_max\":30,\"ranges\":[{}]}}\n",
                        -std::f64::consts::PI,
                        std::f64::consts::TAU / 360.0,
                        ranges.join(",")
                    );
                    let _ = self.s.write_all(line.as_bytes());
                }
                k += 1;
            }
            let mut line = String::new();
            match self.r.read_line(&mut line) {
                Ok(n) if n > 0 => got.push((Instant::now(), parse(&line))),
                Ok(_) => break,
                Err(_) => {}
            }
            std::thread::sleep(Duration::from_millis(30));
        }
        got
    }
}

fn of_type<'a>(msgs: &'a [Value], t: &str) -> Vec<&'a Value> {
    msgs.iter().filter(|m| m["type"] == t).collect()
}

#[test]
fn stale_gone_and_lost_clients_are_stopped_and_the_goal_comes_back_when_data_flows() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (node_end, bridge_end) = mem_pair();
    let cable = FaultHandle::new();
    let mut bridge_end = FaultyLink::new(bridge_end, FaultConfig::default(), 1).with_handle(cable.clone());
    let stop_node = AtomicBool::new(false);
    let stop_bridge = AtomicBool::new(false);
    let (tx, rx) = std::sync::mpsc::sync_channel(1);
    let spec = RobotSpec { on_listen: Some(tx), ..RobotSpec::new("127.0.0.1:0".parse().unwrap()) };
    let opts = BridgeOptions::new(TimeMode::RealTime);
    let _hung = common::hang_guard("stale_gone_and_lost_clients", Duration::from_secs(180));
    std::thread::scope(|s| {
        let _stop = common::StopOnDrop(&[&stop_node, &stop_bridge]);
        let node = s.spawn(|| {
            let mut link: Box<dyn Link> = Box::new(node_end);
            let mut p = NodeProcess::new(Config::DEFAULT, NodeOptions::new(TimeMode::RealTime)).expect("no model");
            p.run(&mut *link, &stop_node);
        });
        let bridge = s.spawn(|| run_robot(&mut bridge_end, spec, &opts, &stop_bridge).expect("a run"));
        let addr = rx.recv_timeout(Duration::from_secs(5)).expect("the adapter listens");

        // 1. A live client gets a goal.
        let mut c = TestClient::connect(addr);
        let got = c.drive(Duration::from_secs(4), true);
        let goals = of_type(&got, "goal");
        assert!(!goals.is_empty(), "a goal within 4 s: {got:?}");
        let seq = goals[0]["seq"].as_u64().unwrap();
        eprintln!("[adapter safety] a goal line: {}", goals[0]);
        eprintln!("[adapter safety] a status line: {}", of_type(&got, "status").last().unwrap());
        assert!(!of_type(&got, "status").is_empty(), "status lines every second");

        // 2. Silent (connected, no odometry): stop(stale) after the 1 s watchdog, and no goal
        // once stale (the node, fed nothing, stops too). A goal the node planned from the last
        // data may still arrive inside the watchdog period: the client is not stale yet.
        let t_quiet = Instant::now();
        let timed = c.drive_timed(Duration::from_millis(2500), false);
        let stale_at = timed.iter().find(|(_, m)| m["reason"] == "stale").map(|(t, _)| t.duration_since(t_quiet));
        let got: Vec<Value> = timed.into_iter().map(|(_, v)| v).collect();
        let stops = of_type(&got, "stop");
        assert_eq!(stops.first().map(|s| s["reason"].clone()), Some(Value::from("stale")), "{got:?}");
        let first_stale = got.iter().position(|m| m["reason"] == "stale").expect("stop(stale)");
        assert!(got[first_stale..].iter().all(|m| m["type"] != "goal"), "no goal to a stale client: {got:?}");
        assert!(stops.iter().any(|s| s["reason"] == "node-stopped"), "the node's watchdog stopped it too: {got:?}");
        let stale_at = stale_at.expect("stop(stale)");
        eprintln!("[adapter safety] stale client: stop(stale) {:.0} ms after the last odometry", stale_at.as_secs_f64() * 1e3);
        assert!(stale_at >= Duration::from_millis(900) && stale_at <= Duration::from_millis(1500), "{stale_at:?}");

        // 3. Data again: the goal comes back.
        let got = c.drive(Duration::from_secs(3), true);
        assert!(of_type(&got, "goal").iter().any(|g| g["seq"].as_u64() >= Some(seq)), "the goal is sent again: {got:?}");

        // 4. The client disconnects: a new client is served and gets the current goal.
        drop(c);
        std::thread::sleep(Duration::from_millis(1500));
        let mut c = TestClient::connect(addr);
        let got = c.drive(Duration::from_secs(4), true);
        assert!(!of_type(&got, "goal").is_empty(), "the new client gets the goal: {got:?}");

        // 5. The node link goes silent: stop(link-lost) within the link watchdog.
        let t_cut = Instant::now();
        cable.blackhole(true);
        let timed = c.drive_timed(Duration::from_millis(2000), true);
        let lost_at = timed.iter().position(|(_, m)| m["type"] == "stop" && m["reason"] == "link-lost").expect("stop(link-lost)");
        assert!(timed[lost_at..].iter().all(|(_, m)| m["type"] != "goal"), "no goal after the loss");
        let lost_after = timed[lost_at].0.duration_since(t_cut);
        eprintln!("[adapter safety] node link silent: stop(link-lost) {:.0} ms after the cut", lost_after.as_secs_f64() * 1e3);
        // One link watchdog period (1 s) after the node's last frame, which came at most one
        // 200 ms tick before the cut; + slack for a loaded machine.
        assert!(lost_after <= Duration::from_millis(1700), "{lost_after:?}");
        cable.blackhole(false);
        let got = c.drive(Duration::from_secs(4), true);
        assert!(!of_type(&got, "goal").is_empty(), "the goal after the link came back: {got:?}");

        // 6. The bridge shuts down: stop(shutdown), then the connection closes.
        stop_bridge.store(true, Ordering::Relaxed);
        let got = c.drive(Duration::from_millis(600), false);
        assert_eq!(got.last().map(|m| (m["type"].clone(), m["reason"].clone())), Some(("stop".into(), "shutdown".into())), "{got:?}");
        let run: RobotRun = bridge.join().expect("bridge thread");
        stop_node.store(true, Ordering::Relaxed);
        node.join().unwrap();
        eprintln!(
            "[adapter safety] {} ticks, adapter {:?}; goal forwarding {:?} us; log {:?}",
            run.bridge.result.ticks, run.adapter, run.goal_forward_us, run.log
        );
        assert_eq!(run.bridge.result.outcome, "stopped");
        assert!(run.log.iter().any(|(_, e)| e.contains("client gone")), "{:?}", run.log);
        assert!(run.log.iter().any(|(_, e)| e.contains("stale")), "{:?}", run.log);
        assert_eq!(run.adapter.disconnects, 1);
        assert!(run.bridge.stats.link_losses >= 1);
    });
}

#[test]
fn a_vlp16_on_udp_feeds_the_node_through_the_robot_source() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let capture = host::io::sensors::vlp16::default_recording();
    let bytes = std::fs::read(&capture).unwrap_or_else(|e| panic!("the VLP-16 recording {} ({e})", capture.display()));
    assert_eq!(bytes.len() % 1206, 0, "raw 1206-byte payloads");
    // A free UDP port for the sensor (bound and released: nothing else runs here).
    let lidar_addr = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let (node_end, mut bridge_end) = mem_pair();
    let stop_node = AtomicBool::new(false);
    let stop_bridge = AtomicBool::new(false);
    let (tx, rx) = std::sync::mpsc::sync_channel(1);
    let spec = RobotSpec {
        on_listen: Some(tx),
        lidar: host::link::robot::parse_lidar(&format!("vlp16-udp={lidar_addr}")).unwrap(),
        ..RobotSpec::new("127.0.0.1:0".parse().unwrap())
    };
    let opts = BridgeOptions::new(TimeMode::RealTime);
    let stop_sensor = AtomicBool::new(false);
    let _hung = common::hang_guard("a_vlp16_on_udp_feeds_the_node", Duration::from_secs(180));
    std::thread::scope(|s| {
        let _stop = common::StopOnDrop(&[&stop_node, &stop_bridge, &stop_sensor]);
        s.spawn(|| {
            let mut link: Box<dyn Link> = Box::new(node_end);
            let mut p = NodeProcess::new(Config::DEFAULT, NodeOptions::new(TimeMode::RealTime)).expect("no model");
            p.run(&mut *link, &stop_node);
        });
        let bridge = s.spawn(|| run_robot(&mut bridge_end, spec, &opts, &stop_bridge).expect("a run"));
        let addr = rx.recv_timeout(Duration::from_secs(5)).expect("the adapter listens");
        // The sensor: the recording's packets at the VLP-16's rate (754 packets/s at 600 rpm),
        // over and over.
        let sensor = s.spawn(|| {
            let sock = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
            let (mut sent, t0) = (0u64, Instant::now());
            while !stop_sensor.load(Ordering::Relaxed) {
                for p in bytes.chunks(1206) {
                    sock.send_to(p, lidar_addr).unwrap();
                    sent += 1;
                    let due = t0 + Duration::from_micros(sent * 1_000_000 / 754);
                    std::thread::sleep(due.saturating_duration_since(Instant::now()));
                }
            }
            sent
        });
        // The client sends odometry only: its scans would be ignored anyway.
        let mut c = TestClient::connect(addr);
        let t0 = Instant::now();
        let mut got = Vec::new();
        while t0.elapsed() < Duration::from_secs(4) {
            let _ = c.s.write_all(b"{\"type\":\"odometry\",\"x\":0,\"y\":0,\"yaw\":0}\n");
            let mut line = String::new();
            if c.r.read_line(&mut line).is_ok_and(|n| n > 0) {
                got.push(parse(&line));
            }
            std::thread::sleep(Duration::from_millis(40));
        }
        stop_sensor.store(true, Ordering::Relaxed);
        stop_bridge.store(true, Ordering::Relaxed);
        let run = bridge.join().unwrap();
        stop_node.store(true, Ordering::Relaxed);
        let packets = sensor.join().unwrap();
        let status = of_type(&got, "status");
        let last = status.last().expect("status lines");
        eprintln!("[adapter vlp16] {packets} packets sent; last status {last}; {} goals", of_type(&got, "goal").len());
        let node = run.bridge.stats.node_status.expect("the node's status");
        assert!(node.scans >= 10, "the node integrated VLP-16 scans: {node:?}");
        assert_eq!(node.scans_rejected, 0);
        assert!(run.bridge.stats.scan_frame_bytes > 1000, "whole scans on the wire: {}", run.bridge.stats.scan_frame_bytes);
        assert!(!of_type(&got, "goal").is_empty(), "a goal from the VLP-16's map: {got:?}");
    });
}
