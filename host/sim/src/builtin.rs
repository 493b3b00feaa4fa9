//! The paper's worlds, authored as TOML in `sim/worlds/` and embedded in the binary.
//!
//! Each world has one file for its floor plan (`NAME.toml`: walls, furniture) and one per
//! scenario (`NAME_easy.toml`, `NAME_hard.toml`: name, time limit, start, targets, people and
//! the scenario's extra clutter). A built-in world is the scenario file followed by the plan
//! file, parsed as one TOML document: the plan file holds only `[[walls]]` and `[[obstacles]]`
//! tables, so the concatenation is valid TOML and the obstacle lists simply add up.
//! [`World::to_toml_string`] of a built-in world gives a single standalone file.
//!
//! | world | size | easy | hard | time limit (easy / hard) |
//! |---|---|---|---|---|
//! | `apartment` | 20 × 30 m | start in bedroom 2 facing away from its door, target 5.5–7.5 m away in view from that door (the hallway, the dining room's doorway), little clutter | start in the living room, target in a far bedroom, more clutter, two people | 120 / 180 s |
//! | `office` | 25 × 45 m | target in the southern half, where the robot starts | target in the northern half | 180 / 300 s |
//! | `hallway` | 15 × 38 m | target behind the start, in the trunk's rooms | target up one of the two branches of the fork | 240 / 240 s |
//!
//! All three are offset by 1 m from the origin so that everything lies inside the controller's
//! 51.2 m grid with a margin.

use super::{Scenario, World};

/// Names accepted by [`World::builtin`].
pub const NAMES: &[&str] = &["apartment", "office", "hallway"];

/// `(plan, easy, hard)` file names and texts of a built-in world.
struct Files {
    plan: (&'static str, &'static str),
    easy: (&'static str, &'static str),
    hard: (&'static str, &'static str),
}

fn files(name: &str) -> Option<Files> {
    macro_rules! world {
        ($n:literal) => {
            Files {
                plan: (concat!($n, ".toml"), include_str!(concat!("worlds/", $n, ".toml"))),
                easy: (concat!($n, "_easy.toml"), include_str!(concat!("worlds/", $n, "_easy.toml"))),
                hard: (concat!($n, "_hard.toml"), include_str!(concat!("worlds/", $n, "_hard.toml"))),
            }
        };
    }
    match name {
        "apartment" => Some(world!("apartment")),
        "office" => Some(world!("office")),
        "hallway" => Some(world!("hallway")),
        _ => None,
    }
}

/// The TOML text of a built-in world (scenario file + plan file) and a name for messages.
pub fn source(name: &str, scenario: Scenario) -> Option<(String, String)> {
    let f = files(name)?;
    let (sname, stext) = match scenario {
        Scenario::Easy => f.easy,
        Scenario::Hard => f.hard,
    };
    Some((format!("{sname}+{}", f.plan.0), format!("{stext}\n{}", f.plan.1)))
}

/// Load a built-in world; `None` for an unknown name.
pub fn load(name: &str, scenario: Scenario) -> Option<World> {
    let (file, text) = source(name, scenario)?;
    match World::from_toml_str(&text, &file) {
        Ok(w) => Some(w),
        // The tests load every built-in world, so this cannot happen in a tested build.
        Err(e) => panic!("built-in world {file} is invalid: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::dist;
    use crate::P2;
    use crate::{HitKind, SimConfig};

    fn all() -> Vec<(String, Scenario, World)> {
        let mut v = Vec::new();
        for name in NAMES {
            for sc in Scenario::ALL {
                let (file, text) = source(name, sc).unwrap();
                let w = World::from_toml_str(&text, &file).unwrap_or_else(|e| panic!("{e}"));
                v.push((name.to_string(), sc, w));
            }
        }
        v
    }

    #[test]
    fn every_builtin_loads_and_fits() {
        for (name, sc, w) in all() {
            let size = [w.bounds[1][0] - w.bounds[0][0], w.bounds[1][1] - w.bounds[0][1]];
            let expect = match name.as_str() {
                "apartment" => [20.0, 30.0],
                "office" => [25.0, 45.0],
                _ => [15.0, 38.0],
            };
            assert!((size[0] - expect[0]).abs() < 1e-9 && (size[1] - expect[1]).abs() < 1e-9, "{name} {sc}: {size:?}");
            assert!(w.bounds[0][0] >= 0.0 && w.bounds[1][0] <= 51.0 && w.bounds[1][1] <= 51.0);
            let limit = match (name.as_str(), sc) {
                ("apartment", Scenario::Easy) => 120.0,
                ("apartment", Scenario::Hard) => 180.0,
                ("office", Scenario::Easy) => 180.0,
                ("office", Scenario::Hard) => 300.0,
                _ => 240.0,
            };
            assert_eq!(w.time_limit_s, limit, "{name} {sc}");
            assert!(!w.people.is_empty() && w.people.len() <= 2, "{name} {sc}");
            for t in &w.targets {
                let n = t.positions().len();
                assert!((3..=5).contains(&n), "{name} {sc}: {n} target positions");
            }
            assert!(w.obstacles.iter().any(|o| o.kind == HitKind::Clutter));
            assert!(w.obstacles.iter().any(|o| o.kind == HitKind::Furniture));
            // The plan round-trips.
            let back = World::from_toml_str(&w.to_toml_string(), "x.toml").unwrap();
            assert_eq!(back, w);
            assert_eq!(World::builtin(&name, sc).unwrap(), w);
        }
        assert!(World::builtin("castle", Scenario::Easy).is_none());
        assert_eq!(World::builtin_names(), NAMES);
    }

    #[test]
    fn every_target_reachable_and_start_clear() {
        let r = SimConfig::default().robot_radius_m;
        for (name, sc, w) in all() {
            let bad = w.unreachable_targets(r);
            assert!(bad.is_empty(), "{name} {sc}: unreachable {bad:?}");
            // The whole jitter square (plus the robot) is clear.
            let need = r + w.start.jitter_m * std::f64::consts::SQRT_2;
            assert!(w.disc_clash([w.start.pose[0], w.start.pose[1]], need, true).is_none(), "{name} {sc}");
        }
    }

    #[test]
    fn scenarios_differ_as_the_paper_says() {
        let mean_target_distance = |w: &World| {
            let s = [w.start.pose[0], w.start.pose[1]];
            let ps: Vec<_> = w.targets.iter().flat_map(|t| t.positions()).collect();
            ps.iter().map(|p| dist(*p, s)).sum::<f64>() / ps.len() as f64
        };
        let clutter = |w: &World| w.obstacles.iter().filter(|o| o.kind == HitKind::Clutter).count();
        let a_easy = World::builtin("apartment", Scenario::Easy).unwrap();
        let a_hard = World::builtin("apartment", Scenario::Hard).unwrap();
        assert!(mean_target_distance(&a_hard) > mean_target_distance(&a_easy) + 3.0);
        assert!(clutter(&a_hard) > clutter(&a_easy) + 5);
        // Apartment easy: the robot starts in a room with one door (bedroom 2's, x = 9,
        // y 17-18), and every place is outside the room, within the camera's 4 m of the doorway
        // and in line of sight from it through no wall.
        let door = [9.0, 17.5];
        let in_room = |p: P2| (1.0..9.0).contains(&p[0]) && (14.0..21.0).contains(&p[1]);
        assert!(in_room([a_easy.start.pose[0], a_easy.start.pose[1]]));
        for p in a_easy.targets[0].positions() {
            assert!(!in_room(p) && dist(p, door) <= 4.0, "apartment easy: {p:?}");
            let seg = |w: &[P2; 2]| crate::geometry::segments_intersect(door, p, w[0], w[1]);
            assert!(!a_easy.walls.iter().any(seg), "apartment easy: a wall between the door and {p:?}");
        }
        // Office: easy targets in the start's half (split at the middle of y), hard in the other.
        for (sc, same) in [(Scenario::Easy, true), (Scenario::Hard, false)] {
            let w = World::builtin("office", sc).unwrap();
            let mid = (w.bounds[0][1] + w.bounds[1][1]) / 2.0;
            let start_north = w.start.pose[1] > mid;
            for t in &w.targets {
                for p in t.positions() {
                    assert_eq!((p[1] > mid) == start_north, same, "office {sc}: {p:?}");
                }
            }
        }
        // Hallway easy: targets behind the start (the robot faces +y).
        let h = World::builtin("hallway", Scenario::Easy).unwrap();
        for t in &h.targets {
            for p in t.positions() {
                assert!(p[1] < h.start.pose[1], "hallway easy: {p:?}");
            }
        }
    }
}
