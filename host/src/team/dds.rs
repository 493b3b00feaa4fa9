//! A team over DDS (feature `ros2`): the coordinator in this process, each robot a process of
//! its own (`lives team … --as-robot I`), on loopback or a real network, speaking the messages of
//! [`super::codec`] on ROS 2 topics:
//!
//! | topic | type | QoS | from → to |
//! |---|---|---|---|
//! | `team/tick` | `lives_team/msg/Tick` | reliable, transient local, keep last 1 | coordinator → every robot |
//! | `team/robot_I/assignment` | `lives_team/msg/Assignment` | reliable, transient local, keep last 1 | coordinator → robot I |
//! | `team/robot_I/status` | `lives_team/msg/RobotStatus` | reliable, volatile, keep last 64 | robot I → coordinator |
//!
//! Each side re-sends its last message every [`RESEND`] while it waits (a message published
//! before the other side matched is not lost for good); a repeated message is recognised by its
//! tick or epoch and changes nothing.

use super::coordinator::Coordinator;
use super::robot::TeamRobot;
use super::{codec, Status, TeamResult, TeamSpec};
use crate::link::ros2::wire::{dds_topic, dds_type, Qos, Raw, RawCdr};
use rustdds::no_key::{DataReader, DataWriter};
use rustdds::{DomainParticipant, DomainParticipantBuilder, TopicKind};
use std::net::{IpAddr, Ipv4Addr};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How often a waiting side sends its last message again.
pub const RESEND: Duration = Duration::from_millis(200);
/// How long the coordinator waits for every robot to announce itself.
pub const JOIN_TIMEOUT: Duration = Duration::from_secs(60);
/// How long a robot waits for the coordinator's next order before it gives up.
pub const ORDER_TIMEOUT: Duration = Duration::from_secs(120);

/// How the team joins DDS.
#[derive(Clone, Debug)]
pub struct DdsOptions {
    /// DDS domain.
    pub domain: u16,
    /// Only the loopback interface.
    pub localhost_only: bool,
    /// A robot that has not answered a tick within this is lost.
    pub link_timeout: Duration,
}

pub(super) struct Bus {
    dp: DomainParticipant,
    publisher: rustdds::Publisher,
    subscriber: rustdds::Subscriber,
}

impl Bus {
    pub(super) fn join(o: &DdsOptions) -> Result<Bus, String> {
        let mut b = DomainParticipantBuilder::new(o.domain);
        if o.localhost_only {
            b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let dp = b.build().map_err(|e| format!("cannot join DDS domain {}: {e:?}", o.domain))?;
        let publisher = dp.create_publisher(&Qos::Reliable(64).policies()).map_err(|e| format!("DDS publisher: {e:?}"))?;
        let subscriber = dp.create_subscriber(&Qos::Reliable(64).policies()).map_err(|e| format!("DDS subscriber: {e:?}"))?;
        Ok(Bus { dp, publisher, subscriber })
    }

    fn topic(&self, name: &str, ty: &str, qos: Qos) -> Result<rustdds::Topic, String> {
        self.dp.create_topic(dds_topic(name), dds_type(ty), &qos.policies(), TopicKind::NoKey).map_err(|e| format!("topic {name}: {e:?}"))
    }

    pub(super) fn writer(&self, name: &str, ty: &str, qos: Qos) -> Result<DataWriter<Raw, RawCdr>, String> {
        let t = self.topic(name, ty, qos)?;
        self.publisher.create_datawriter_no_key::<Raw, RawCdr>(&t, Some(qos.policies())).map_err(|e| format!("writer {name}: {e:?}"))
    }

    pub(super) fn reader(&self, name: &str, ty: &str, qos: Qos) -> Result<DataReader<Raw, RawCdr>, String> {
        let t = self.topic(name, ty, qos)?;
        self.subscriber.create_datareader_no_key::<Raw, RawCdr>(&t, Some(qos.policies())).map_err(|e| format!("reader {name}: {e:?}"))
    }
}

pub(super) fn status_topic(i: usize) -> String {
    format!("team/robot_{i}/status")
}

pub(super) fn assignment_topic(i: usize) -> String {
    format!("team/robot_{i}/assignment")
}

const TICK_TOPIC: &str = "team/tick";
const STATUS_QOS: Qos = Qos::Reliable(64);

/// Every sample a reader holds, as bytes (a sample DDS could not hand over is skipped).
pub(super) fn take(r: &mut DataReader<Raw, RawCdr>) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    while let Ok(Some(s)) = r.take_next_sample() {
        out.push(s.into_value().0);
    }
    out
}

pub(super) fn send(w: &DataWriter<Raw, RawCdr>, bytes: &[u8], what: &str) -> Result<u64, String> {
    w.write(Raw(bytes.to_vec()), None).map_err(|e| format!("publishing {what}: {e:?}"))?;
    Ok(bytes.len() as u64)
}

/// The coordinator's side: spawns the robots (`robot_args(i)` are robot `i`'s arguments to
/// this program), runs the search, stops and reaps them.
pub fn run(spec: &TeamSpec, opts: &DdsOptions, robot_args: impl Fn(usize) -> Vec<String>) -> Result<TeamResult, String> {
    spec.check()?;
    let bus = Bus::join(opts)?;
    let tick_w = bus.writer(TICK_TOPIC, codec::TICK_TYPE, Qos::Latched)?;
    let mut assign_w = Vec::new();
    let mut status_r = Vec::new();
    for i in 0..spec.robots {
        assign_w.push(bus.writer(&assignment_topic(i), codec::ASSIGNMENT_TYPE, Qos::Latched)?);
        status_r.push(bus.reader(&status_topic(i), codec::STATUS_TYPE, STATUS_QOS)?);
    }
    let mut children = spawn(spec.robots, robot_args)?;
    let out = coordinate(spec, opts, &tick_w, &assign_w, &mut status_r, &mut children);
    stop_and_reap(&tick_w, &mut children);
    out
}

/// Starts robot processes `0..n`, robot `i` as this program with arguments `robot_args(i)`.
pub(super) fn spawn(n: usize, robot_args: impl Fn(usize) -> Vec<String>) -> Result<Vec<Option<Child>>, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find this program to start the robots: {e}"))?;
    let mut children: Vec<Option<Child>> = Vec::new();
    for i in 0..n {
        let child = Command::new(&exe)
            .args(robot_args(i))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start robot {i}: {e}"))?;
        children.push(Some(child));
    }
    Ok(children)
}

/// Tells every robot to stop (on `orders`, the topic the robots take their orders from), then
/// reaps the robot processes: those still running after 5 s are killed. The stop is sent again
/// every [`RESEND`] meanwhile; with no processes of its own to wait for (robots started
/// elsewhere) it lingers [`STOP_LINGER`], so that the stop reaches robots before this
/// participant leaves.
pub(super) fn stop_and_reap(orders: &DataWriter<Raw, RawCdr>, children: &mut [Option<Child>]) {
    let stop = codec::encode_tick(&super::TickMsg {
        tick: u32::MAX,
        stop: true,
        epochs: Vec::new(),
        goals: Vec::new(),
        positions: Vec::new(),
        seen: Vec::new(),
        lidar: Vec::new(),
    });
    let started = Instant::now();
    let deadline = started + Duration::from_secs(5);
    let mut sent: Option<Instant> = None;
    loop {
        if sent.is_none_or(|t| t.elapsed() >= RESEND) {
            let _ = send(orders, &stop, "the stop");
            sent = Some(Instant::now());
        }
        let running = children.iter_mut().flatten().any(|c| matches!(c.try_wait(), Ok(None)));
        let lingering = children.is_empty() && started.elapsed() < STOP_LINGER;
        if !(running || lingering) || Instant::now() >= deadline {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    for c in children.iter_mut().flatten() {
        let _ = c.kill();
        let _ = c.wait();
    }
}

/// How long a coordinator of robots started elsewhere keeps sending its stop.
pub const STOP_LINGER: Duration = Duration::from_secs(2);

fn coordinate(
    spec: &TeamSpec,
    opts: &DdsOptions,
    tick_w: &DataWriter<Raw, RawCdr>,
    assign_w: &[DataWriter<Raw, RawCdr>],
    status_r: &mut [DataReader<Raw, RawCdr>],
    children: &mut [Option<Child>],
) -> Result<TeamResult, String> {
    let n = spec.robots;
    let mut inbox = Inbox::new(status_r);
    let hellos = inbox.join(children)?;
    let mut coord = super::local::coordinator(spec)?;
    let mut pending = coord.start(&hellos)?;
    let tick_s = crate::run::TICK_US as f64 / 1e6;
    let mut tick = 0u32;
    loop {
        if let Some((r, t)) = spec.kill {
            if tick as f64 * tick_s >= t {
                if let Some(mut c) = children[r].take() {
                    // The link is cut: the robot's process dies without a word.
                    let _ = c.kill();
                    let _ = c.wait();
                }
            }
        }
        for a in pending.drain(..) {
            let i = a.robot as usize;
            inbox.bytes[i][1] += send(&assign_w[i], &codec::encode_assignment(&a), "an assignment")?;
        }
        let order = codec::encode_tick(&coord.tick_msg(tick, false));
        let mut statuses: Vec<Option<Status>> = vec![None; n];
        let waiting =
            |statuses: &[Option<Status>], coord: &Coordinator| (0..n).filter(|&i| coord.alive(i) && statuses[i].is_none()).count();
        let started = Instant::now();
        let mut last_sent: Option<Instant> = None;
        while waiting(&statuses, &coord) > 0 && started.elapsed() < opts.link_timeout {
            if last_sent.is_none_or(|t| t.elapsed() >= RESEND) {
                let b = send(tick_w, &order, "a tick")?;
                for (i, c) in inbox.bytes.iter_mut().enumerate() {
                    if coord.alive(i) {
                        c[1] += b;
                    }
                }
                last_sent = Some(Instant::now());
            }
            for (i, slot) in statuses.iter_mut().enumerate() {
                for s in inbox.read(i)? {
                    if s.tick == Some(tick) && coord.alive(i) {
                        *slot = Some(s);
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        let d = coord.after_tick(tick, &statuses)?;
        pending = d.assignments;
        if d.stop {
            break;
        }
        tick += 1;
    }
    Ok(coord.result(spec, "dds", &inbox.bytes))
}

/// The coordinator's side of the robots' status topics: every status read is decoded, checked
/// to be from the robot whose topic it came on and from one process only, and counted.
pub(super) struct Inbox<'a> {
    readers: &'a mut [DataReader<Raw, RawCdr>],
    instance: Vec<Option<u32>>,
    /// Payload bytes per robot: `[received from it, sent to it]`.
    pub bytes: Vec<[u64; 2]>,
}

impl<'a> Inbox<'a> {
    pub(super) fn new(readers: &'a mut [DataReader<Raw, RawCdr>]) -> Self {
        let n = readers.len();
        Inbox { readers, instance: vec![None; n], bytes: vec![[0; 2]; n] }
    }

    /// Every status robot `i` has sent since the last call, in order.
    pub(super) fn read(&mut self, i: usize) -> Result<Vec<Status>, String> {
        let mut got = Vec::new();
        for b in take(&mut self.readers[i]) {
            self.bytes[i][0] += b.len() as u64;
            let s = codec::decode_status(&b).map_err(|e| format!("robot {i}'s status: {e}"))?;
            if s.robot as usize != i {
                return Err(format!("robot {} reports on robot {i}'s topic", s.robot));
            }
            // One robot, one process: a second process announcing it is an error.
            match self.instance[i] {
                None => self.instance[i] = Some(s.instance),
                Some(p) if p != s.instance => {
                    return Err(format!("robot {i} is announced twice: by process {p} and by process {}", s.instance))
                }
                _ => {}
            }
            got.push(s);
        }
        Ok(got)
    }

    /// Waits until every robot has announced itself (or one of `children`, the robots this
    /// process started, has exited, or [`JOIN_TIMEOUT`] has passed): their announcements, in
    /// robot order.
    pub(super) fn join(&mut self, children: &mut [Option<Child>]) -> Result<Vec<Status>, String> {
        let n = self.readers.len();
        let mut hellos: Vec<Option<Status>> = vec![None; n];
        let t0 = Instant::now();
        while hellos.iter().any(Option::is_none) {
            for (i, h) in hellos.iter_mut().enumerate() {
                if let Some(s) = self.read(i)?.into_iter().rev().find(|s| s.tick.is_none()) {
                    *h = Some(s);
                }
            }
            for (i, c) in children.iter_mut().enumerate() {
                if let Some(Ok(Some(code))) = c.as_mut().map(Child::try_wait) {
                    return Err(format!("robot {i} exited before it joined ({code})"));
                }
            }
            if t0.elapsed() > JOIN_TIMEOUT {
                let missing: Vec<String> = (0..n).filter(|&i| hellos[i].is_none()).map(|i| i.to_string()).collect();
                return Err(format!("robots {} did not join within {} s", missing.join(", "), JOIN_TIMEOUT.as_secs()));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        Ok(hellos.into_iter().flatten().collect())
    }
}

/// Robot `id`'s side (a process of its own): joins, announces itself, steps every tick the
/// coordinator orders once it holds the assignment that tick names, reports, and ends on a stop.
pub fn robot(spec: &TeamSpec, id: usize, opts: &DdsOptions) -> Result<(), String> {
    let mut robot = TeamRobot::of_team(spec, id)?;
    let bus = Bus::join(opts)?;
    let status_w = bus.writer(&status_topic(id), codec::STATUS_TYPE, STATUS_QOS)?;
    let mut tick_r = bus.reader(TICK_TOPIC, codec::TICK_TYPE, Qos::Latched)?;
    let mut assign_r = bus.reader(&assignment_topic(id), codec::ASSIGNMENT_TYPE, Qos::Latched)?;
    let mut last = codec::encode_status(&robot.hello());
    let mut last_sent: Option<Instant> = None;
    let mut next = 0u32;
    let mut heard = Instant::now();
    loop {
        for b in take(&mut assign_r) {
            match codec::decode_assignment(&b) {
                Ok(a) => robot.assign(&a),
                Err(e) => eprintln!("robot {id}: an assignment refused: {e}"),
            }
        }
        let mut order = None;
        for b in take(&mut tick_r) {
            match codec::decode_tick(&b) {
                Ok(t) if t.stop => return Ok(()),
                Ok(t) if t.tick == next => order = Some(t),
                Ok(t) if t.tick > next && t.tick != u32::MAX => {
                    return Err(format!("robot {id}: dropped by the coordinator (ordered tick {} while at {next})", t.tick))
                }
                Ok(_) => {}
                Err(e) => eprintln!("robot {id}: an order refused: {e}"),
            }
        }
        if let Some(t) = order {
            heard = Instant::now();
            let want = t.epochs.get(id).copied().unwrap_or(0);
            // Step only on the assignment the order names (it may still be on its way).
            while robot.epoch() < want {
                for b in take(&mut assign_r) {
                    if let Ok(a) = codec::decode_assignment(&b) {
                        robot.assign(&a);
                    }
                }
                if heard.elapsed() > ORDER_TIMEOUT {
                    return Err(format!("robot {id}: assignment {want} never came"));
                }
                std::thread::sleep(Duration::from_millis(1));
            }
            robot.merge(&t.seen, &t.lidar);
            robot.give_way(&t.goals, &t.positions);
            last = codec::encode_status(&robot.step(t.tick));
            next = t.tick + 1;
            last_sent = None;
        }
        if last_sent.is_none_or(|t| t.elapsed() >= RESEND) {
            send(&status_w, &last, "a status")?;
            last_sent = Some(Instant::now());
        }
        if heard.elapsed() > ORDER_TIMEOUT {
            return Err(format!("robot {id}: no order from the coordinator for {} s", ORDER_TIMEOUT.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}
