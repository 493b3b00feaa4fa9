//! Garbage in never panics the core: random poses (inside and outside the search area), scans of
//! random shapes (empty, oversized, zero increment, mismatched labels, any range values),
//! commands, detections, blocked flags, and time that jumps or runs backwards. Every tick keeps
//! the invariants a robot relies on.

mod common;
use common::*;
use firmware::scan::BeamLabel;
use firmware::{BinaryAngle, Command, Config, Inputs, Mode, Pose2, ScanInput};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

#[test]
fn random_inputs_never_panic_and_keep_the_invariants() {
    for seed in [2024, 7, 99] {
        random_run(seed, 400);
    }
}

fn random_run(seed: u64, ticks: u32) {
    let mut rng = Rng(seed);
    let mut c = controller(Config::DEFAULT);
    let world = room_world();
    let mut now: u64 = 0;
    let mut modes = std::collections::HashSet::new();
    let mut rejected = 0;
    for tick in 0..ticks {
        // Time: mostly forward by one period, sometimes a jump, sometimes backwards.
        now = match rng.below(20) {
            0 => now.saturating_sub(rng.below(5_000_000)),
            1 => now + rng.below(10_000_000),
            _ => now + 200_000,
        };
        let good_pose = (4.0 + rng.below(600) as f64 / 100.0, 3.0 + rng.below(500) as f64 / 100.0, rng.below(628) as f64 / 100.0);
        let pose = match rng.below(10) {
            0 => Some(Pose2::new(
                fixed_point::Meters::from_bits(rng.next() as i32),
                fixed_point::Meters::from_bits(rng.next() as i32),
                BinaryAngle(rng.next() as i32),
            )),
            1 => None,
            _ => Some(pose(good_pose.0, good_pose.1, good_pose.2)),
        };
        let (mut ranges, mut labels) = scan_of(&world, good_pose, 897);
        match rng.below(8) {
            0 => ranges = (0..rng.below(3000)).map(|_| rng.next() as u16).collect(),
            1 => ranges.clear(),
            2 => labels.truncate(rng.below(897) as usize),
            _ => {}
        }
        let increment = match rng.below(10) {
            0 => BinaryAngle(0),
            1 => BinaryAngle(rng.next() as i32),
            _ => BinaryAngle::from_fraction(1, ranges.len().max(1) as i64),
        };
        let with_labels = rng.below(2) == 0;
        let scan = (rng.below(6) != 0).then(|| ScanInput {
            angle_min: BinaryAngle(rng.next() as i32),
            angle_increment: increment,
            ranges_mm: &ranges,
            labels: with_labels.then_some(&labels[..]),
        });
        let command = match rng.below(30) {
            0 => Some(Command::Stop),
            1 => Some(Command::Reset),
            2..=5 => Some(Command::Start),
            _ => None,
        };
        let inputs = Inputs {
            pose,
            scan,
            detection: (rng.below(200) == 0).then_some(firmware::Detection { position: None }),
            command,
            base_blocked: rng.below(5) == 0,
        };
        let out = c.tick(now, &inputs);
        let mode = out.status.mode.expect("a mode every tick");
        rejected = out.status.scans_rejected;
        modes.insert(format!("{mode:?}"));
        assert_eq!(out.stop, mode != Mode::Exploring, "tick {tick}: stop iff not exploring");
        if let Some(g) = &out.goal {
            assert!(!g.path.is_empty() && g.path.len() <= firmware::capacity::MAX_PATH_WAYPOINTS);
            assert_eq!(*g.path.last().unwrap(), (g.pose.x, g.pose.y), "the path ends at the goal");
        }
        assert!(c.nonmap.points().len() <= firmware::capacity::MAX_NONMAP_POINTS);
        let _ = BeamLabel::Map;
    }
    assert!(modes.len() >= 3, "the run visited several modes: {modes:?}");
    assert!(rejected > 0, "bad scans were refused and counted");
}
