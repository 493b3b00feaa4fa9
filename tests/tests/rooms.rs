//! Room segmentation (`firmware::rooms`) on the simulator's built-in worlds: their walls are
//! rasterised into a LiDAR grid (0.1 m cells, one cell thick, everything inside the outer walls
//! free, furniture left out) and segmented.
//!
//! Expected, from reading `host/sim/src/worlds/*.toml` before running:
//! * **apartment** (20 × 30 m): six side rooms off the 2 m hallway (bedroom 1, bathroom,
//!   bedroom 2, main bedroom, study, dining room; doors 1.0–1.1 m) and one region for the
//!   hallway, the living room and the kitchen nook: the hallway opens into the living room at its
//!   full 2 m width, with no narrowing to cut at, and the nook is a 7 m wide bay. **7 rooms**,
//!   **7 doors** (six off the hallway, dining room – living room 1.2 m).
//! * **office** (25 × 45 m): six west rooms, conference, break room, open plan, copy room and
//!   the 2.5 m corridor: **11 rooms**; **11 doors** (six west, conference, break room, two into
//!   the open plan, the copy room's); the corridor is a corridor.
//!
//! Tolerance ±1 room and ±1 door: the 1.2 m doors and the 2 m hallway are within one 0.2 m
//! coarse cell of the core threshold's margins (a 1.2 m door has clearance 3 coarse cells, the
//! threshold is 4), so a wall end that rasterises one cell differently could join or split one
//! pair. The sample points below must all be in distinct rooms either way (except where noted).

use firmware::grid::{Cell, GridGeometry, LidarGrid};
use firmware::rooms::{RoomKind, Rooms, WORK_BOUND};
use fixed_point::Meters;
use host::sim::{Scenario, World};

fn rasterise(w: &World) -> Box<LidarGrid> {
    let mut g = Box::new(LidarGrid::new(GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO }));
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for s in &w.walls {
        for p in s {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    let cell = |v: f64| (v * 10.0).floor() as i32;
    for y in cell(lo[1])..=cell(hi[1]) {
        for x in cell(lo[0])..=cell(hi[0]) {
            g.grid.set(x, y, Cell::Free);
        }
    }
    for [a, b] in &w.walls {
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let n = (len / 0.01).ceil() as i32 + 1;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            g.grid.set(cell(a[0] + t * (b[0] - a[0])), cell(a[1] + t * (b[1] - a[1])), Cell::Occupied);
        }
    }
    g
}

fn segment(name: &str) -> Box<Rooms> {
    let w = World::builtin(name, Scenario::Easy).unwrap();
    let g = rasterise(&w);
    let mut r = Box::new(Rooms::new());
    let work = r.update(&g);
    assert!(work <= WORK_BOUND);
    println!("{name}: {} rooms, {} doors, work {work}, {:?}", r.rooms().len(), r.doors().len(), r.stats);
    for room in r.rooms() {
        println!("  {room:?}");
    }
    for d in r.doors() {
        println!("  {d:?}");
    }
    r
}

/// Every door of these worlds is 1.0–1.2 m wide; the estimate is in 0.2 m steps.
fn door_widths_plausible(r: &Rooms) {
    for d in r.doors() {
        assert!((1_000..=1_400).contains(&d.width_mm), "{d:?}");
    }
}

fn at(r: &Rooms, x: f64, y: f64) -> u8 {
    r.room_at((x * 10.0) as i32, (y * 10.0) as i32).unwrap_or_else(|| panic!("no room at ({x}, {y})"))
}

/// The rooms at `points` (x, y in metres), which must all be distinct.
fn distinct_rooms_at(r: &Rooms, points: &[(f64, f64)]) -> Vec<u8> {
    let ids: Vec<u8> = points.iter().map(|&(x, y)| at(r, x, y)).collect();
    let mut v = ids.clone();
    v.sort();
    v.dedup();
    assert_eq!(v.len(), ids.len(), "{ids:?}");
    ids
}

/// Segments the built-in world `name`, which must have `n` ± 1 rooms and `n` ± 1 doors, each
/// door of a plausible width.
fn segment_expecting(name: &str, n: usize) -> Box<Rooms> {
    let r = segment(name);
    assert!((n - 1..=n + 1).contains(&r.rooms().len()), "expected {n} ± 1 rooms");
    assert!((n - 1..=n + 1).contains(&r.doors().len()), "expected {n} ± 1 doors");
    door_widths_plausible(&r);
    r
}

#[test]
fn the_apartment_has_its_six_side_rooms_and_the_hallway_with_the_living_room() {
    let r = segment_expecting("apartment", 7);
    // Bedroom 1, bathroom, bedroom 2, main bedroom, study, dining, living room.
    let ids = distinct_rooms_at(&r, &[(5.0, 4.5), (5.0, 11.0), (5.0, 17.5), (16.0, 5.0), (16.0, 12.0), (16.0, 18.0), (10.0, 26.0)]);
    let hall = at(&r, 10.0, 8.0);
    assert!(!ids[..6].contains(&hall), "the hallway is in no side room");
    for id in &ids[..5] {
        assert!(r.neighbours(*id).any(|n| n == hall), "room {id} has a door to the hallway");
    }
}

#[test]
fn the_office_has_eleven_rooms_and_its_corridor_is_a_corridor() {
    let r = segment_expecting("office", 11);
    let corridor = at(&r, 12.25, 20.0);
    assert_eq!(r.room(corridor).unwrap().kind, RoomKind::Corridor);
    assert_eq!(at(&r, 12.25, 3.0), corridor);
    assert_eq!(at(&r, 12.25, 44.0), corridor);
    // W1..W6, conference, break room, open plan, copy room, corridor (the point `corridor` was found at).
    let ids = distinct_rooms_at(
        &r,
        &[
            (6.0, 4.5),
            (6.0, 12.0),
            (6.0, 20.0),
            (6.0, 27.0),
            (6.0, 35.0),
            (6.0, 42.0),
            (20.0, 7.0),
            (20.0, 18.0),
            (18.0, 35.0),
            (24.0, 25.5),
            (12.25, 20.0),
        ],
    );
    for id in &ids[..10] {
        assert_eq!(r.room(*id).unwrap().kind, RoomKind::Room, "room {id}");
        assert!(r.neighbours(*id).any(|n| n == corridor) || *id == ids[9], "room {id} opens on the corridor");
    }
}
