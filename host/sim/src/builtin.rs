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
//! | `apartment` | 20 × 30 m | hard's start (the living room, facing north), fewer objects (2 of hard's 20 clutter objects, 1 of its 2 people), the target next to the start room (dining room, kitchen nook, bedroom 2, hallway), 9.9–13.7 m by path | start in the living room, target in a far room (bathroom, bedroom 1, main bedroom), 14.8–29.5 m by path, 20 clutter objects, two people | 120 / 180 s |
//! | `office` | 25 × 45 m | target in the southern half (y < 23.5, the middle of the bounds), where the robot starts | target in the northern half | 180 / 300 s |
//! | `hallway` | 15 × 38 m | target behind the start, in the trunk's rooms | target up one of the two branches of the fork | 240 / 240 s |
//!
//! The apartment and office scenarios follow the paper's words and nothing else (Sec. IV-B:
//! apartment easy has "fewer objects in the environment and the search target being closer to
//! the robot"; office easy and hard have "the search target being in the same or different half
//! of the environment as the robot starting position"); `scenarios_differ_as_the_paper_says`
//! asserts the rules. They are not to be reshaped after measuring planners on them.
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
        // Apartment: easy is hard with fewer objects and the target closer. The same start.
        assert_eq!(a_easy.start, a_hard.start);
        // Fewer objects: every clutter object and person of easy is one of hard's, and fewer.
        let clutter_of = |w: &World| w.obstacles.iter().filter(|o| o.kind == HitKind::Clutter).cloned().collect::<Vec<_>>();
        let (ce, ch) = (clutter_of(&a_easy), clutter_of(&a_hard));
        assert!(ce.iter().all(|o| ch.contains(o)) && ce.len() < ch.len());
        assert!(a_easy.people.iter().all(|p| a_hard.people.contains(p)) && a_easy.people.len() < a_hard.people.len());
        // The same furniture (the plan's).
        let furniture = |w: &World| w.obstacles.iter().filter(|o| o.kind == HitKind::Furniture).cloned().collect::<Vec<_>>();
        assert_eq!(furniture(&a_easy), furniture(&a_hard));
        // Closer: every easy place is nearer the start by the shortest drivable path (to within
        // 1 m of it) than every hard place.
        let r = SimConfig::default().robot_radius_m;
        let start = [a_easy.start.pose[0], a_easy.start.pose[1]];
        let paths = |w: &World| -> Vec<f64> {
            w.targets[0]
                .positions()
                .into_iter()
                .map(|p| crate::oracle::shortest_path_m(w, start, p, r, crate::reach::REACH_STANDOFF_M).expect("reachable"))
                .collect()
        };
        let (pe, ph) = (paths(&a_easy), paths(&a_hard));
        let easy_max = pe.iter().copied().fold(0.0, f64::max);
        let hard_min = ph.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(easy_max < hard_min, "easy paths {pe:?}, hard paths {ph:?}");
        // Still a search: no place of either is in line of sight from the start.
        for w in [&a_easy, &a_hard] {
            let mut b = crate::geometry::SceneBuilder::new();
            for wall in &w.walls {
                b.wall(wall[0], wall[1]);
            }
            for (i, o) in w.obstacles.iter().enumerate() {
                b.shape(&o.shape, o.kind, i as u32);
            }
            let scene = b.build(0.5);
            for p in w.targets[0].positions() {
                let v = [p[0] - start[0], p[1] - start[1]];
                let d = v[0].hypot(v[1]);
                let hit = scene.raycast(start, [v[0] / d, v[1] / d], d, crate::geometry::NO_OWNER);
                assert!(hit.is_some(), "{}: {p:?} is in line of sight from the start", w.name);
            }
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
