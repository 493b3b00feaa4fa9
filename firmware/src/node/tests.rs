extern crate std;

use super::*;
use crate::config::Config;
use crate::grid::Cell;
use crate::protocol::{
    AckReason, BaseStatus, ConfigMsg, GoalMsg, Hello, HostDecoder, PoseMsg, Role, ScanMsg, StatusMsg, WireCommand, WireMode, MAX_FRAME_LEN,
    PROTOCOL_VERSION,
};
use crate::scan::{BeamLabel, RANGE_NO_RETURN};
use std::boxed::Box;
use std::vec::Vec;

const T: u64 = 200_000;
/// The robot stands at (25.6 m, 25.6 m), the middle of a grid at the default origin.
const MID: i32 = 25 * 65_536 + 39_322;

fn frame(m: &HostToCore) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode(m, &mut buf).unwrap().to_vec()
}

/// Decodes everything a node sent.
fn parse(bytes: &[u8]) -> Vec<CoreToHost> {
    let mut d = HostDecoder::new();
    let out: Vec<CoreToHost> = d.feed(bytes).map(|r| r.expect("the node sends valid frames")).collect();
    assert_eq!(d.pending(), 0, "every frame is complete");
    out
}

/// A 720-beam scan of a round room of radius 3 m with a doorway (no return) to the east.
fn scan(t_us: u64, labels: bool) -> HostToCore {
    let n = 720;
    let mut s = ScanMsg { t_us, angle_min: i32::MIN, angle_increment: (u32::MAX / n as u32) as i32, ..Default::default() };
    for i in 0..n {
        let door = (350..370).contains(&i); // ±5° around 0 (beam 360 points forward)
        s.ranges_mm.push(if door { RANGE_NO_RETURN } else { 3000 }).unwrap();
    }
    if labels {
        s.labels = Some((0..n).map(|_| BeamLabel::Map).collect());
    }
    HostToCore::Scan(s)
}

fn pose(t_us: u64) -> HostToCore {
    HostToCore::Pose(PoseMsg { t_us, x: MID, y: MID, theta: 0 })
}

fn beat(t_us: u64, seq: u32) -> HostToCore {
    HostToCore::Heartbeat(Heartbeat { t_us, seq })
}

fn batch(t_us: u64, extra: &[HostToCore]) -> Vec<u8> {
    let mut b = Vec::new();
    for m in extra {
        b.extend(frame(m));
    }
    b.extend(frame(&pose(t_us)));
    b.extend(frame(&scan(t_us, true)));
    b.extend(frame(&beat(t_us, t_us as u32)));
    b
}

/// [`batch`] at `t_us` with a Start command.
fn start_batch(t_us: u64) -> Vec<u8> {
    batch(t_us, &[HostToCore::Command(WireCommand::Start)])
}

struct Rig {
    node: Node,
    ctl: Box<Controller>,
}

impl Rig {
    fn new(mode: TimeMode) -> Self {
        Rig { node: Node::new(NodeConfig::new(mode)), ctl: Box::new(Controller::new(Config::DEFAULT)) }
    }

    /// A node in `mode` after a simulator's accepted Hello (asking for labels or not).
    fn connected(mode: TimeMode, want_labels: bool) -> Self {
        let mut r = Rig::new(mode);
        r.hello(want_labels);
        r
    }

    fn rx(&mut self, bytes: &[u8]) -> (u32, Vec<CoreToHost>) {
        let mut out = Vec::new();
        let n = self.node.receive(bytes, &mut self.ctl, |f| out.extend_from_slice(f));
        (n, parse(&out))
    }

    fn tick(&mut self, now_us: u64) -> Vec<CoreToHost> {
        let mut out = Vec::new();
        self.node.tick(now_us, &mut self.ctl, |f| out.extend_from_slice(f));
        parse(&out)
    }

    fn hello(&mut self, want_labels: bool) {
        let (_, out) = self.rx(&frame(&HostToCore::Hello(Hello::new(Role::Simulator, want_labels))));
        assert!(matches!(out[..], [CoreToHost::HelloAck(a)] if a.accepted));
    }
}

fn statuses(out: &[CoreToHost]) -> Vec<StatusMsg> {
    out.iter().filter_map(|m| if let CoreToHost::Status(s) = m { Some(*s) } else { None }).collect()
}

fn goals(out: &[CoreToHost]) -> Vec<GoalMsg> {
    out.iter().filter_map(|m| if let CoreToHost::Goal(g) = m { Some(g.clone()) } else { None }).collect()
}

#[test]
fn the_node_is_small() {
    // Decoder (one largest frame), inbox (one largest scan), one outgoing frame, last outputs.
    let size = core::mem::size_of::<Node>();
    assert!(size < 10 * 1024, "{size} bytes");
}

#[test]
fn nothing_but_hello_is_acted_on_before_the_handshake() {
    let mut r = Rig::new(TimeMode::Lockstep);
    let (ticks, out) = r.rx(&start_batch(0));
    assert_eq!(ticks, 0);
    // One error per heartbeat period, not one per message.
    assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::HandshakeRequired })]);
    assert_eq!(r.node.link_counters().ignored, 4);
    assert_eq!(r.ctl.mode(), Mode::Idle);

    // A host of another version is told why.
    let old = Hello { version: PROTOCOL_VERSION + 1, role: Role::Robot, want_labels: false };
    let (_, out) = r.rx(&frame(&HostToCore::Hello(old)));
    assert!(matches!(out[..], [CoreToHost::HelloAck(a)] if !a.accepted && a.reason == AckReason::VersionMismatch));
    let (_, out) = r.rx(&frame(&beat(0, 1)));
    assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::VersionMismatch { peer: PROTOCOL_VERSION + 1 } })]);
}

#[test]
fn reset_starts_a_new_search_at_once_and_lockstep_time_again() {
    let mut r = Rig::connected(TimeMode::Lockstep, false);
    assert_eq!(r.rx(&start_batch(0)).0, 1);
    assert_eq!(r.rx(&batch(T, &[])).0, 1);
    // An earlier time is ignored (stale) ...
    assert_eq!(r.rx(&start_batch(0)).0, 0);
    assert_eq!(r.node.counters().lockstep_stale, 1);
    // ... until a Reset: applied on arrival (the controller idle and empty, a configuration
    // accepted again), and time starts over.
    let (ticks, out) = r.rx(&frame(&HostToCore::Command(WireCommand::Reset)));
    assert_eq!((ticks, out.len()), (0, 0));
    assert_eq!(r.ctl.mode(), Mode::Idle);
    assert_eq!(r.node.counters().resets, 1);
    let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&Config::DEFAULT))));
    assert!(out.is_empty(), "{out:?}");
    assert_eq!(r.node.counters().configs_applied, 1);
    let (ticks, out) = r.rx(&start_batch(0));
    assert_eq!(ticks, 1);
    let s = statuses(&out);
    assert_eq!((s[0].t_us, s[0].ticks, s[0].mode), (0, 1, WireMode::Exploring), "a new search: its first tick");
    // Its first goal on its second tick (a planning step spans two).
    let (_, out) = r.rx(&batch(T, &[]));
    assert_eq!(goals(&out)[0].seq, 1);
}

#[test]
fn lockstep_ticks_on_the_heartbeat_closing_a_complete_batch() {
    let mut r = Rig::connected(TimeMode::Lockstep, false);
    let (ticks, out) = r.rx(&start_batch(0));
    assert_eq!(ticks, 1);
    assert_eq!(r.ctl.mode(), Mode::Exploring);
    // A planning step spans two ticks: the first finds the path distances, no goal yet.
    assert!(goals(&out).is_empty(), "{out:?}");
    assert_eq!(statuses(&out)[0].t_us, 0);
    assert_eq!(statuses(&out)[0].mode, WireMode::Exploring);
    assert_eq!(out.last(), Some(&CoreToHost::Heartbeat(Heartbeat { t_us: 0, seq: 0 })));
    // The second: Goal, Status(T), then the echo last.
    let (ticks, out) = r.rx(&batch(T, &[]));
    assert_eq!(ticks, 1);
    let g = goals(&out);
    assert_eq!(g.len(), 1, "{out:?}");
    assert_eq!(g[0].seq, 1);
    assert_eq!(statuses(&out)[0].t_us, T);
    assert_eq!(out.last(), Some(&CoreToHost::Heartbeat(Heartbeat { t_us: T, seq: T as u32 })));

    // The same goal is not sent again on the next tick.
    let (ticks, out) = r.rx(&batch(2 * T, &[]));
    assert_eq!(ticks, 1);
    assert!(goals(&out).is_empty(), "{out:?}");
    assert_eq!(statuses(&out)[0].t_us, 2 * T);

    // A batch that lost its scan is not ticked: echo only, so the host retries.
    let mut b = frame(&pose(3 * T));
    b.extend(frame(&beat(3 * T, 7)));
    let (ticks, out) = r.rx(&b);
    assert_eq!(ticks, 0);
    assert_eq!(out, [CoreToHost::Heartbeat(Heartbeat { t_us: 3 * T, seq: 7 })]);
    assert_eq!(r.node.counters().lockstep_incomplete, 1);
    // The retry ticks.
    let (ticks, out) = r.rx(&batch(3 * T, &[]));
    assert_eq!(ticks, 1);
    assert_eq!(statuses(&out)[0].t_us, 3 * T);

    // A retry of a batch already ticked (its answer was lost): nothing ticks, the outputs,
    // goal included, come again.
    let ticks_before = r.ctl_ticks();
    let (ticks, out) = r.rx(&batch(3 * T, &[]));
    assert_eq!(ticks, 0);
    assert_eq!(r.ctl_ticks(), ticks_before);
    assert_eq!(goals(&out).len(), 1);
    assert_eq!(statuses(&out)[0].t_us, 3 * T);
    assert_eq!(r.node.counters().lockstep_repeats, 1);
    // An old heartbeat is ignored (echoed only).
    let (_, out) = r.rx(&frame(&beat(T, 9)));
    assert_eq!(out.len(), 1);
    assert_eq!(r.node.counters().lockstep_stale, 1);
}

impl Rig {
    fn ctl_ticks(&self) -> u32 {
        self.node.last_out.as_ref().map_or(0, |o| o.status.ticks)
    }
}

/// A batch with its scan cut into segments of `per` beams, leaving out the segments `lose`.
fn segmented_batch(t_us: u64, extra: &[HostToCore], per: usize, lose: &[usize]) -> Vec<u8> {
    let mut b = Vec::new();
    for m in extra {
        b.extend(frame(m));
    }
    b.extend(frame(&pose(t_us)));
    let HostToCore::Scan(s) = scan(t_us, true) else { unreachable!() };
    for (i, seg) in s.segments(per).enumerate() {
        if !lose.contains(&i) {
            b.extend(frame(&HostToCore::ScanSegment(seg)));
        }
    }
    b.extend(frame(&beat(t_us, t_us as u32)));
    b
}

#[test]
fn a_scan_in_segments_ticks_exactly_like_the_whole_scan() {
    let mut whole = Rig::new(TimeMode::Lockstep);
    let mut split = Rig::new(TimeMode::Lockstep);
    whole.hello(false);
    split.hello(false);
    for k in 0..6u64 {
        let extra: &[HostToCore] = if k == 0 { &[HostToCore::Command(WireCommand::Start)] } else { &[] };
        let (tw, ow) = whole.rx(&batch(k * T, extra));
        let (ts, os) = split.rx(&segmented_batch(k * T, extra, 16, &[]));
        assert_eq!((tw, ts), (1, 1), "a complete segmented scan ticks at once");
        // Same goals and statuses (the link counters aside: more frames came in).
        assert_eq!(goals(&ow), goals(&os));
        let strip = |v: Vec<StatusMsg>| v.into_iter().map(|s| StatusMsg { link: LinkCounters::default(), ..s }).collect::<Vec<_>>();
        assert_eq!(strip(statuses(&ow)), strip(statuses(&os)));
    }
    assert_eq!(whole.ctl.lidar.grid.count(Cell::Free), split.ctl.lidar.grid.count(Cell::Free));
    assert_eq!(split.node.counters().lockstep_partial, 0);
    assert_eq!(split.node.inbox().segments_accepted, 6 * 45);
}

#[test]
fn a_partial_scan_waits_for_retries_then_ticks_with_what_arrived() {
    let mut r = Rig::new(TimeMode::Lockstep);
    r.node.cfg.lockstep_partial_after = 3;
    r.hello(false);
    let start = [HostToCore::Command(WireCommand::Start)];
    // Segments 3 and 7 lost: no tick on the first two heartbeats (the host retries) ...
    let (ticks, out) = r.rx(&segmented_batch(0, &start, 16, &[3, 7]));
    assert_eq!(ticks, 0);
    assert_eq!(out, [CoreToHost::Heartbeat(Heartbeat { t_us: 0, seq: 0 })]);
    // ... the retry brings segment 3 but loses 7 again ...
    let (ticks, _) = r.rx(&segmented_batch(0, &[], 16, &[7]));
    assert_eq!(ticks, 0);
    assert_eq!(r.node.counters().lockstep_incomplete, 2);
    assert_eq!(r.node.inbox().scan_beams(), Some((720 - 16, 720)), "segment 3 filled in across the attempts");
    // ... and the third heartbeat ticks with the 704 beams that arrived.
    let (ticks, out) = r.rx(&segmented_batch(0, &[], 16, &[7]));
    assert_eq!(ticks, 1);
    assert_eq!(statuses(&out)[0].t_us, 0);
    assert_eq!(statuses(&out)[0].scans, 1);
    assert_eq!(r.node.counters().lockstep_partial, 1);
    assert_eq!(r.ctl.mode(), Mode::Exploring, "the Start of the first attempt was kept");
    // A batch whose retry completes the scan ticks at once, on its second heartbeat.
    let (ticks, _) = r.rx(&segmented_batch(T, &[], 16, &[0]));
    assert_eq!(ticks, 0);
    let (ticks, _) = r.rx(&segmented_batch(T, &[], 16, &[5]));
    assert_eq!(ticks, 1);
    assert_eq!(r.node.counters().lockstep_partial, 1);
    // A heartbeat without the pose never ticks, however often.
    for _ in 0..5 {
        let mut b = Vec::new();
        let HostToCore::Scan(s) = scan(2 * T, true) else { unreachable!() };
        for seg in s.segments(16) {
            b.extend(frame(&HostToCore::ScanSegment(seg)));
        }
        b.extend(frame(&beat(2 * T, 1)));
        assert_eq!(r.rx(&b).0, 0);
    }
}

#[test]
fn real_time_ticks_on_the_callers_clock_with_heartbeats_and_goal_refresh() {
    let mut r = Rig::connected(TimeMode::RealTime, true);
    // Messages never tick in real time; the heartbeat is echoed at once.
    let (ticks, out) = r.rx(&start_batch(123));
    assert_eq!(ticks, 0);
    assert_eq!(out, [CoreToHost::Heartbeat(Heartbeat { t_us: 123, seq: 123 })]);

    let mut all = Vec::new();
    let mut t = 0;
    for k in 0..16 {
        t = 5_000_000 + k * T;
        if k < 8 {
            r.rx(&frame(&pose(0)));
            r.rx(&frame(&scan(0, true)));
        }
        all.push(r.tick(t));
    }
    let flat: Vec<CoreToHost> = all.iter().flatten().cloned().collect();
    // Labels after each integrated scan, as asked.
    assert_eq!(flat.iter().filter(|m| matches!(m, CoreToHost::Labels(_))).count(), 8);
    // One goal first, then again only after a second (goal_refresh_us), not every tick.
    let g = goals(&flat);
    assert!((1..=3).contains(&g.len()), "{} goals in 8 ticks", g.len());
    // (A planning step spans two ticks: the first goal comes on the second.)
    assert!(goals(&all[0]).is_empty() && goals(&all[1]).len() == 1 && goals(&all[2]).is_empty());
    // Own heartbeat about once a second (the echo counted as the first).
    let beats = flat.iter().filter(|m| matches!(m, CoreToHost::Heartbeat(_))).count();
    assert!((2..=4).contains(&beats), "{beats} heartbeats in 3.2 s");
    // The watchdog: no pose or scan for over a second stops the robot.
    let last = statuses(all.last().unwrap())[0];
    assert_eq!(last.mode, WireMode::Stopped);
    assert!(all.last().unwrap().iter().any(|m| matches!(m, CoreToHost::Stop(s) if s.mode == WireMode::Stopped)));
    assert_eq!(last.t_us, t);
}

#[test]
fn a_configuration_is_applied_only_when_idle() {
    let mut r = Rig::connected(TimeMode::Lockstep, false);
    let mut cfg = Config::DEFAULT;
    cfg.origin_x_m = Config::mm(1_000);
    cfg.watchdog_us = 2_000_000;
    let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&cfg))));
    assert!(out.is_empty());
    assert_eq!(r.ctl.config().watchdog_us, 2_000_000);
    assert_eq!(r.ctl.lidar.geom.origin_x, Config::mm(1_000), "the maps moved with the origin");
    r.rx(&start_batch(0));
    assert_eq!(r.ctl.mode(), Mode::Exploring);

    let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&Config::DEFAULT))));
    assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigRefused })]);
    assert_eq!(r.ctl.config().watchdog_us, 2_000_000);
    assert_eq!(r.node.counters().configs_refused, 1);
}

#[test]
fn a_configuration_out_of_range_is_refused_naming_the_field_and_the_controller_keeps_its_own() {
    let mut r = Rig::connected(TimeMode::Lockstep, false);
    let mut cfg = Config::DEFAULT;
    cfg.watchdog_us = 2_000_000;
    r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&cfg))));
    assert_eq!(*r.ctl.config(), cfg);
    // What once stopped the node (overflow at planner.rs:270 on the first plan): a 5 km robot.
    let bad = Config { robot_radius_m: Config::mm(5_000_000), origin_x_m: Config::mm(2_000), ..cfg };
    let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&bad))));
    let field = ConfigMsg::field_index("robot_radius_m").unwrap();
    assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigInvalid { field } })]);
    assert_eq!(ConfigMsg::FIELDS[field as usize], "robot_radius_m");
    assert_eq!(*r.ctl.config(), cfg, "the configuration in use stays, origin included");
    assert_eq!(r.node.last_config_error().map(|e| e.field), Some("robot_radius_m"));
    let c = r.node.counters();
    assert_eq!((c.configs_applied, c.configs_invalid, c.configs_refused), (1, 1, 0));
    // And the node searches on with it (its first goal on the second tick).
    let (ticks, _) = r.rx(&start_batch(0));
    assert_eq!(ticks, 1);
    assert_eq!(r.ctl.mode(), Mode::Exploring);
    let (_, out) = r.rx(&batch(T, &[]));
    assert_eq!(goals(&out).len(), 1);
}

#[test]
fn set_config_keeps_the_maps_unless_the_origin_moves() {
    let mut ctl = Box::new(Controller::new(Config::DEFAULT));
    let mut node = Node::new(NodeConfig::new(TimeMode::Lockstep));
    node.receive(&frame(&HostToCore::Hello(Hello::new(Role::Simulator, false))), &mut ctl, |_| {});
    node.receive(&start_batch(0), &mut ctl, |_| {});
    node.receive(&frame(&HostToCore::Command(WireCommand::Stop)), &mut ctl, |_| {});
    node.receive(&batch(T, &[]), &mut ctl, |_| {});
    assert_eq!(ctl.mode(), Mode::Idle);
    let known = |c: &Controller| c.lidar.grid.count(Cell::Free);
    let before = known(&ctl);
    assert!(before > 0);
    let mut cfg = Config::DEFAULT;
    cfg.switch_margin = Config::weight_milli(1_000);
    ctl.set_config(cfg).unwrap();
    assert_eq!(known(&ctl), before, "same origin: the map stays");
    cfg.origin_y_m = Config::mm(-500);
    ctl.set_config(cfg).unwrap();
    assert_eq!(known(&ctl), 0, "new origin: the map is forgotten");
    assert_eq!(*ctl.config(), cfg);
}

#[test]
fn base_status_and_commands_flow_through() {
    let mut r = Rig::connected(TimeMode::Lockstep, false);
    r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start), HostToCore::BaseStatus(BaseStatus { blocked: true })]));
    assert!(r.node.inbox().inputs().base_blocked);
    let (_, out) = r.rx(&batch(T, &[HostToCore::Command(WireCommand::Stop)]));
    assert_eq!(statuses(&out)[0].mode, WireMode::Idle);
    assert!(out.iter().any(|m| matches!(m, CoreToHost::Stop(s) if s.mode == WireMode::Idle)));
}

#[test]
fn garbage_is_counted_and_never_reaches_the_controller() {
    let mut r = Rig::connected(TimeMode::Lockstep, false);
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut junk = Vec::new();
    for _ in 0..200_000 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        junk.push((seed >> 24) as u8);
    }
    let good = start_batch(0);
    // Damage each byte of the Start frame in turn (the delimiter kept): every copy is dropped.
    let first = good.iter().position(|&x| x == 0).unwrap();
    for i in 0..first {
        let mut b = good[..=first].to_vec();
        b[i] ^= 0x5A;
        if b[i] == 0 {
            b[i] = 1;
        }
        junk.push(0);
        junk.extend_from_slice(&b);
    }
    let (ticks, _) = r.rx(&junk);
    assert_eq!(ticks, 0);
    assert_eq!(r.ctl.mode(), Mode::Idle);
    let c = r.node.link_counters();
    assert!(c.dropped() > first as u32, "{c:?}");
    assert_eq!(c.frames_ok, 1, "only the Hello");
    // And the node still works.
    let (ticks, _) = r.rx(&[&[0u8][..], &good[..]].concat());
    assert_eq!(ticks, 1);
    assert_eq!(r.ctl.mode(), Mode::Exploring);
}
