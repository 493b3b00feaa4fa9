//! The team's messages in CDR (XCDR1, little endian), as ROS 2 messages of package
//! `lives_team` (`../../docs/team.md` gives their `.msg` definitions). Decoding checks every
//! length against the bytes left and names what is wrong; nothing here panics on bad bytes.

use super::{Assignment, Status, TickMsg, MAX_ROBOTS};
use crate::io::replay::cdr::{CdrError, CdrReader, CdrWriter};

/// ROS 2 type names.
pub const TICK_TYPE: &str = "lives_team/msg/Tick";
pub const ASSIGNMENT_TYPE: &str = "lives_team/msg/Assignment";
pub const STATUS_TYPE: &str = "lives_team/msg/RobotStatus";

/// Most waypoints in one assignment (the controller holds at most this many).
pub const MAX_WAYPOINTS: usize = firmware::capacity::MAX_ROUTE_WAYPOINTS;
/// Most cells one status reports seen (a 0.1 m grid's camera cone is far fewer per tick).
pub const MAX_SEEN: usize = 1 << 16;

fn put_u32s(w: &mut CdrWriter, v: impl ExactSizeIterator<Item = u32>) {
    w.put((v.len() as u32).to_le_bytes());
    for x in v {
        w.put(x.to_le_bytes());
    }
}

fn u32s(r: &mut CdrReader, what: &'static str, max: usize) -> Result<Vec<u32>, String> {
    let n = r.count(what, 4).map_err(|e| e.to_string())?;
    if n > max {
        return Err(format!("{what}: {n} elements, at most {max}"));
    }
    (0..n).map(|_| r.u32(what).map_err(|e| e.to_string())).collect()
}

/// Seen cells (sorted) as runs: `uint32[]` of pairs (first cell, run length), a run being
/// consecutive cells with the same [`super::SEEN_OCCUPIED`] flag. A camera cone crosses the grid's
/// rows in runs, so this is several times smaller than the cells one by one.
fn put_seen(w: &mut CdrWriter, seen: &[u32]) {
    let mut runs: Vec<u32> = Vec::new();
    for &c in seen {
        match runs.len() {
            n if n >= 2 && runs[n - 2].wrapping_add(runs[n - 1]) == c => runs[n - 1] += 1,
            _ => runs.extend([c, 1]),
        }
    }
    put_u32s(w, runs.into_iter());
}

fn seen(r: &mut CdrReader, what: &'static str) -> Result<Vec<u32>, String> {
    let runs = u32s(r, what, 2 * MAX_SEEN)?;
    if runs.len() % 2 != 0 {
        return Err(format!("{what}: {} numbers, not pairs", runs.len()));
    }
    let mut out: Vec<u32> = Vec::new();
    for p in runs.chunks(2) {
        let (first, len) = (p[0], p[1]);
        if out.len() + len as usize > MAX_SEEN {
            return Err(format!("{what}: more than {MAX_SEEN} cells"));
        }
        for k in 0..len {
            let c = first.checked_add(k).filter(|c| c & !super::SEEN_OCCUPIED == (first & !super::SEEN_OCCUPIED) + k);
            out.push(c.ok_or_else(|| format!("{what}: a run from {first} of {len} leaves the grid"))?);
        }
    }
    Ok(out)
}

/// Optional points as `uint32[] which` (indices present) and `float64[] xy`.
fn put_points(w: &mut CdrWriter, pts: &[Option<[f64; 2]>]) {
    put_u32s(w, pts.iter().enumerate().filter(|(_, p)| p.is_some()).map(|(i, _)| i as u32).collect::<Vec<_>>().into_iter());
    let xy: Vec<f64> = pts.iter().flatten().flatten().copied().collect();
    w.put((xy.len() as u32).to_le_bytes());
    for v in xy {
        w.put(v.to_le_bytes());
    }
}

fn points(r: &mut CdrReader, what: &'static str, n: usize, max: usize) -> Result<Vec<Option<[f64; 2]>>, String> {
    let which = u32s(r, what, max)?;
    let m = r.count(what, 8).map_err(cdr)?;
    if m != 2 * which.len() {
        return Err(format!("{what}: {m} coordinates for {} points", which.len()));
    }
    let mut out = vec![None; n];
    for &i in &which {
        let p = r.f64s::<2>(what).map_err(cdr)?;
        if p.iter().any(|v| !v.is_finite()) {
            return Err(format!("{what}: point {i} is not finite"));
        }
        let slot = out.get_mut(i as usize).ok_or_else(|| format!("{what}: point {i} beyond {n}"))?;
        *slot = Some(p);
    }
    Ok(out)
}

fn cdr(e: CdrError) -> String {
    e.to_string()
}

/// `Tick`: `uint32 tick`, `bool stop`, `uint32[] epochs`, `goals` and `positions` (points:
/// `uint32[]` which robots, `float64[]` their x, y), `uint32[] seen` (runs), `uint32[]
/// lidar` (runs).
pub fn encode_tick(m: &TickMsg) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.put(m.tick.to_le_bytes());
    w.put([m.stop as u8]);
    put_u32s(&mut w, m.epochs.iter().copied());
    put_points(&mut w, &m.goals);
    put_points(&mut w, &m.positions);
    put_seen(&mut w, &m.seen);
    put_seen(&mut w, &m.lidar);
    w.finish()
}

pub fn decode_tick(buf: &[u8]) -> Result<TickMsg, String> {
    let mut r = CdrReader::new(buf).map_err(cdr)?;
    let tick = r.u32("tick").map_err(cdr)?;
    let stop = r.u8("stop").map_err(cdr)? != 0;
    let epochs = u32s(&mut r, "epochs", MAX_ROBOTS)?;
    let goals = points(&mut r, "goals", epochs.len(), MAX_ROBOTS)?;
    let positions = points(&mut r, "positions", epochs.len(), MAX_ROBOTS)?;
    let seen_cells = seen(&mut r, "seen")?;
    let lidar = seen(&mut r, "lidar")?;
    Ok(TickMsg { tick, stop, epochs, goals, positions, seen: seen_cells, lidar })
}

/// `Assignment`: `uint32 robot`, `uint32 epoch`, `float64[] waypoints` (x, y, heading each).
pub fn encode_assignment(m: &Assignment) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.put(m.robot.to_le_bytes());
    w.put(m.epoch.to_le_bytes());
    w.put((m.waypoints.len() as u32 * 3).to_le_bytes());
    for v in m.waypoints.iter().flatten() {
        w.put(v.to_le_bytes());
    }
    w.finish()
}

pub fn decode_assignment(buf: &[u8]) -> Result<Assignment, String> {
    let mut r = CdrReader::new(buf).map_err(cdr)?;
    let robot = r.u32("robot").map_err(cdr)?;
    let epoch = r.u32("epoch").map_err(cdr)?;
    let n = r.count("waypoints", 8).map_err(cdr)?;
    if n % 3 != 0 || n / 3 > MAX_WAYPOINTS {
        return Err(format!("waypoints: {n} numbers, not 3 a waypoint for at most {MAX_WAYPOINTS}"));
    }
    let mut waypoints = Vec::with_capacity(n / 3);
    for _ in 0..n / 3 {
        let w = r.f64s::<3>("waypoints").map_err(cdr)?;
        if w.iter().any(|v| !v.is_finite()) {
            return Err(format!("waypoint {} is not finite", waypoints.len()));
        }
        waypoints.push(w);
    }
    Ok(Assignment { robot, epoch, waypoints })
}

/// `RobotStatus`: `uint32 robot`, `uint32 instance`, `int64 tick` (−1: joining), `float64[3]
/// pose`, `bool found`, `bool idle`, `uint32 epoch`, `int64 goal_epoch` (−1: no goal),
/// `uint16[] done` (as `uint32[]`), `goal` (points), `uint32[] seen` (runs), `uint32[] lidar` (runs), `float64
/// path_m`.
pub fn encode_status(m: &Status) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.put(m.robot.to_le_bytes());
    w.put(m.instance.to_le_bytes());
    w.put(m.tick.map_or(-1i64, i64::from).to_le_bytes());
    for v in m.pose {
        w.put(v.to_le_bytes());
    }
    w.put([m.found as u8]);
    w.put([m.idle as u8]);
    w.put(m.epoch.to_le_bytes());
    w.put(m.goal_epoch.map_or(-1i64, i64::from).to_le_bytes());
    put_u32s(&mut w, m.done.iter().map(|&d| d as u32));
    put_points(&mut w, &[m.goal]);
    put_seen(&mut w, &m.seen);
    put_seen(&mut w, &m.lidar);
    w.put(m.path_m.to_le_bytes());
    w.finish()
}

pub fn decode_status(buf: &[u8]) -> Result<Status, String> {
    let mut r = CdrReader::new(buf).map_err(cdr)?;
    let robot = r.u32("robot").map_err(cdr)?;
    let instance = r.u32("instance").map_err(cdr)?;
    let tick = i64::from_le_bytes(r.f64("tick").map_err(cdr)?.to_le_bytes());
    let tick = match tick {
        -1 => None,
        t if (0..=u32::MAX as i64).contains(&t) => Some(t as u32),
        t => return Err(format!("tick {t} out of range")),
    };
    let pose = r.f64s::<3>("pose").map_err(cdr)?;
    if pose.iter().any(|v| !v.is_finite()) {
        return Err("pose is not finite".into());
    }
    let found = r.u8("found").map_err(cdr)? != 0;
    let idle = r.u8("idle").map_err(cdr)? != 0;
    let epoch = r.u32("epoch").map_err(cdr)?;
    let goal_epoch = match i64::from_le_bytes(r.f64("goal_epoch").map_err(cdr)?.to_le_bytes()) {
        -1 => None,
        e if (0..=u32::MAX as i64).contains(&e) => Some(e as u32),
        e => return Err(format!("goal_epoch {e} out of range")),
    };
    let done = u32s(&mut r, "done", MAX_WAYPOINTS)?;
    if let Some(d) = done.iter().find(|&&d| d as usize >= MAX_WAYPOINTS) {
        return Err(format!("done: waypoint {d} beyond {MAX_WAYPOINTS}"));
    }
    let goal = points(&mut r, "goal", 1, 1)?[0];
    let seen_cells = seen(&mut r, "seen")?;
    let lidar = seen(&mut r, "lidar")?;
    let path_m = r.f64("path_m").map_err(cdr)?;
    Ok(Status {
        robot,
        instance,
        tick,
        pose,
        found,
        idle,
        epoch,
        goal_epoch,
        done: done.into_iter().map(|d| d as u16).collect(),
        goal,
        seen: seen_cells,
        lidar,
        path_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status() -> Status {
        Status {
            robot: 2,
            instance: 4242,
            tick: Some(17),
            pose: [1.5, -2.25, 0.5],
            found: false,
            idle: true,
            epoch: 3,
            goal_epoch: Some(3),
            done: vec![0, 1, 5],
            seen: vec![10, 11, 12 | crate::team::SEEN_OCCUPIED, 262_143],
            lidar: vec![3, 4 | crate::team::SEEN_OCCUPIED],
            goal: Some([4.0, 5.0]),
            path_m: 12.5,
        }
    }

    #[test]
    fn messages_round_trip_and_every_cut_is_an_error() {
        let t = TickMsg {
            tick: 9,
            stop: true,
            epochs: vec![1, 2, 0],
            goals: vec![Some([1.0, 2.0]), None, Some([-3.5, 0.25])],
            positions: vec![Some([0.0, 0.5]), Some([1.5, 2.5]), None],
            seen: vec![5, 6, 7, 7 | crate::team::SEEN_OCCUPIED, 100],
            lidar: vec![1, 2],
        };
        let a = Assignment { robot: 1, epoch: 2, waypoints: vec![[1.0, 2.0, 0.5], [3.0, -4.0, -1.0]] };
        let s = status();
        let joining = Status { tick: None, goal_epoch: None, done: vec![], seen: vec![], lidar: vec![], goal: None, ..status() };
        assert_eq!(decode_tick(&encode_tick(&t)).unwrap(), t);
        assert_eq!(decode_assignment(&encode_assignment(&a)).unwrap(), a);
        assert_eq!(decode_status(&encode_status(&s)).unwrap(), s);
        assert_eq!(decode_status(&encode_status(&joining)).unwrap(), joining);
        for buf in [encode_tick(&t), encode_assignment(&a), encode_status(&s)] {
            for cut in 0..buf.len() {
                let b = &buf[..cut];
                assert!(decode_tick(b).is_err() || decode_assignment(b).is_err() || decode_status(b).is_err());
            }
        }
        for cut in 0..encode_status(&s).len() {
            assert!(decode_status(&encode_status(&s)[..cut]).is_err(), "status cut at {cut}");
        }
        for cut in 0..encode_assignment(&a).len() {
            assert!(decode_assignment(&encode_assignment(&a)[..cut]).is_err(), "assignment cut at {cut}");
        }
    }

    #[test]
    fn hostile_lengths_and_values_are_named() {
        let mut a = encode_assignment(&Assignment { robot: 0, epoch: 1, waypoints: vec![[f64::NAN, 0.0, 0.0]] });
        assert!(decode_assignment(&a).unwrap_err().contains("not finite"));
        // A count of 2^31 waypoint numbers in a short message.
        a[12..16].copy_from_slice(&(1u32 << 31).to_le_bytes());
        assert!(decode_assignment(&a).is_err());
        let mut s = encode_status(&status());
        // pose.x = inf
        s[20..28].copy_from_slice(&f64::INFINITY.to_le_bytes());
        assert!(decode_status(&s).unwrap_err().contains("pose"));
        // A goal for robot 5 in a tick of 3 robots.
        let t = TickMsg {
            tick: 1,
            stop: false,
            epochs: vec![0; 3],
            goals: vec![None, None, Some([1.0, 1.0])],
            positions: vec![None; 3],
            seen: vec![],
            lidar: vec![],
        };
        let mut b = encode_tick(&t);
        // Header 4, tick 4, stop 1 + 3, epochs 4 + 12, `which` count 4: its element at 32.
        assert_eq!(b[32..36], 2u32.to_le_bytes());
        b[32..36].copy_from_slice(&5u32.to_le_bytes());
        assert!(decode_tick(&b).unwrap_err().contains("beyond"), "{:?}", decode_tick(&b));
    }
}
