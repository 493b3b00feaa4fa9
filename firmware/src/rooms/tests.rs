extern crate std;
use super::*;
use crate::grid::GridGeometry;
use fixed_point::Meters;
use std::boxed::Box;
use std::vec::Vec;

fn grid() -> Box<LidarGrid> {
    Box::new(LidarGrid::new(GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO }))
}

/// Sets every cell of `[x0, x1) × [y0, y1)`.
fn rect(g: &mut LidarGrid, x0: i32, y0: i32, x1: i32, y1: i32, c: Cell) {
    for y in y0..y1 {
        for x in x0..x1 {
            g.grid.set(x, y, c);
        }
    }
}

/// A free room `[x0, x1) × [y0, y1)` inside a one-cell wall.
fn room(g: &mut LidarGrid, x0: i32, y0: i32, x1: i32, y1: i32) {
    rect(g, x0 - 1, y0 - 1, x1 + 1, y1 + 1, Cell::Occupied);
    rect(g, x0, y0, x1, y1, Cell::Free);
}

fn segment(g: &LidarGrid) -> Box<Rooms> {
    let mut r = Box::new(Rooms::new());
    let w = r.update(g);
    assert!(w <= WORK_BOUND, "work {w}");
    r
}

fn near(a: (i32, i32), b: (i32, i32), d: i32) -> bool {
    (a.0 - b.0).abs() <= d && (a.1 - b.1).abs() <= d
}

#[test]
fn two_rooms_joined_by_a_0_9_m_door_are_two_rooms_with_one_door_in_the_doorway() {
    let mut g = grid();
    room(&mut g, 20, 20, 60, 60);
    room(&mut g, 61, 20, 101, 60);
    rect(&mut g, 60, 36, 61, 45, Cell::Free); // the door: y 36..45, 0.9 m
    let r = segment(&g);
    assert_eq!(r.rooms().len(), 2, "{:?}", r.rooms());
    assert_eq!(r.doors().len(), 1, "{:?}", r.doors());
    let d = r.doors()[0];
    assert!(near(d.cell, (60, 40), 4), "{d:?}");
    assert!((600..=1200).contains(&d.width_mm), "{d:?}");
    let (a, b) = (r.room_at(30, 40).unwrap(), r.room_at(90, 40).unwrap());
    assert_ne!(a, b);
    assert_eq!(d.rooms, (a.min(b), a.max(b)));
    assert!(r.rooms().iter().all(|x| x.kind == RoomKind::Room && x.doors == 1));
    assert_eq!(r.neighbours(a).collect::<Vec<_>>(), [b]);
    assert_eq!(r.room_at(60, 30), None, "a wall is in no room");
    let ra = r.room(a).unwrap();
    assert!(near(ra.centroid, (40, 40), 3) && near(ra.view, (40, 40), 4), "{ra:?}");
    // Coarse granularity: the region may take the doorway's coarse cells (x 60..62).
    assert!(ra.bbox.0 == 20 && ra.bbox.1 == 20 && (59..=61).contains(&ra.bbox.2) && ra.bbox.3 == 59, "{ra:?}");
    assert!((40 * 40..=40 * 40 + 2 * 10).contains(&ra.area_cells), "{ra:?}");
}

/// A 1.6 m × 20 m corridor with three 4 × 4 m rooms off it through 1.0 m doors.
fn corridor_world(g: &mut LidarGrid) {
    room(g, 50, 100, 250, 116);
    for x0 in [60, 110, 160] {
        room(g, x0, 117, x0 + 40, 157);
        rect(g, x0 + 16, 116, x0 + 26, 117, Cell::Free);
    }
}

#[test]
fn a_corridor_with_three_rooms_off_it_is_a_corridor_three_rooms_and_three_doors() {
    let mut g = grid();
    corridor_world(&mut g);
    let r = segment(&g);
    assert_eq!(r.rooms().len(), 4, "{:?}", r.rooms());
    assert_eq!(r.doors().len(), 3, "{:?}", r.doors());
    let c = r.room_at(150, 108).unwrap();
    assert_eq!(r.room(c).unwrap().kind, RoomKind::Corridor);
    assert_eq!(r.room(c).unwrap().doors, 3);
    for x0 in [60, 110, 160] {
        let id = r.room_at(x0 + 20, 137).unwrap();
        assert_ne!(id, c);
        assert_eq!(r.room(id).unwrap().kind, RoomKind::Room);
        let d: Vec<_> = r.doors_of(id).collect();
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].rooms, (id.min(c), id.max(c)));
        assert!(near(d[0].cell, (x0 + 21, 116), 5), "{:?}", d[0]);
    }
}

#[test]
fn an_open_8_m_hall_is_one_room() {
    let mut g = grid();
    room(&mut g, 100, 100, 180, 180);
    let r = segment(&g);
    assert_eq!(r.rooms().len(), 1);
    assert!(r.doors().is_empty());
    assert_eq!(r.rooms()[0].kind, RoomKind::Room);
    assert!(near(r.rooms()[0].view, (140, 140), 2));
    assert!((3_600..=4_200).contains(&r.rooms()[0].clearance_mm), "{:?}", r.rooms()[0]);
}

#[test]
fn unknown_space_beyond_a_frontier_makes_no_door_but_walls_do() {
    // Two seen 4 × 4 m patches joined by a 0.8 m wide seen strip, all else unknown.
    let mut g = grid();
    rect(&mut g, 100, 100, 140, 140, Cell::Free);
    rect(&mut g, 160, 100, 200, 140, Cell::Free);
    rect(&mut g, 140, 116, 160, 124, Cell::Free);
    let r = segment(&g);
    assert_eq!(r.rooms().len(), 1, "{:?}", r.rooms());
    assert!(r.doors().is_empty());
    // The same strip between walls is a doorway.
    rect(&mut g, 140, 115, 160, 116, Cell::Occupied);
    rect(&mut g, 140, 124, 160, 125, Cell::Occupied);
    rect(&mut g, 139, 95, 140, 116, Cell::Occupied);
    rect(&mut g, 139, 124, 140, 145, Cell::Occupied);
    rect(&mut g, 160, 95, 161, 116, Cell::Occupied);
    rect(&mut g, 160, 124, 161, 145, Cell::Occupied);
    let r = segment(&g);
    assert_eq!(r.rooms().len(), 2, "{:?}", r.rooms());
    assert_eq!(r.doors().len(), 1);
}

#[test]
fn ids_are_kept_as_a_room_grows_and_when_a_room_appears_earlier_in_raster_order() {
    let mut g = grid();
    // First only the east room (and a bit of the west one, through the door) is seen.
    room(&mut g, 150, 50, 200, 100);
    rect(&mut g, 149, 70, 150, 80, Cell::Free);
    let mut r = Box::new(Rooms::new());
    r.update(&g);
    assert_eq!(r.rooms().len(), 1);
    let east = r.room_at(175, 75).unwrap();
    // Then the west room, lower in raster order, half of it.
    rect(&mut g, 120, 49, 149, 101, Cell::Occupied);
    rect(&mut g, 120, 50, 149, 100, Cell::Free);
    rect(&mut g, 149, 70, 150, 80, Cell::Free);
    r.update(&g);
    assert_eq!(r.rooms().len(), 2, "{:?}", r.rooms());
    assert_eq!(r.room_at(175, 75), Some(east));
    let west = r.room_at(135, 75).unwrap();
    assert_ne!(west, east);
    // The whole west room: both keep their ids.
    room(&mut g, 90, 50, 149, 100);
    rect(&mut g, 149, 70, 150, 80, Cell::Free);
    r.update(&g);
    assert_eq!(r.rooms().len(), 2, "{:?}", r.rooms());
    assert_eq!(r.room_at(175, 75), Some(east));
    assert_eq!(r.room_at(100, 75), Some(west));
    assert_eq!(r.doors().len(), 1);
}

#[test]
fn a_shift_moves_the_labels_and_keeps_the_ids() {
    // The east room is seen first, so it has id 1 and the west room id 2: the reverse of
    // what a fresh segmentation (raster order) gives, so kept ids are not luck.
    let mut g = grid();
    room(&mut g, 401, 100, 450, 150);
    let mut r = Box::new(Rooms::new());
    r.update(&g);
    room(&mut g, 350, 100, 400, 150);
    rect(&mut g, 400, 120, 401, 130, Cell::Free);
    r.update(&g);
    let (w, e) = (r.room_at(375, 125).unwrap(), r.room_at(425, 125).unwrap());
    assert_eq!((w, e), (2, 1));
    // The same rooms after the window moved 160 cells east.
    let mut s = grid();
    room(&mut s, 190, 100, 240, 150);
    room(&mut s, 241, 100, 290, 150);
    rect(&mut s, 240, 120, 241, 130, Cell::Free);
    assert_eq!(segment(&s).room_at(215, 125), Some(1), "fresh: raster order");
    r.shift(160, 0);
    assert!(r.stale() && r.rooms().is_empty());
    assert_eq!(r.room_at(215, 125), Some(w));
    assert_eq!(r.room_at(265, 125), Some(e));
    r.update(&s);
    assert!(!r.stale());
    assert_eq!(r.room_at(215, 125), Some(w));
    assert_eq!(r.room_at(265, 125), Some(e));
    assert_eq!(r.doors().len(), 1);
    // Rooms leaving the window are forgotten; an odd shift forgets the labels.
    r.shift(-160, 480);
    assert!((0..512).all(|x| r.room_at(x, 125).is_none()));
    r.update(&s);
    r.shift(1, 0);
    assert!((0..512).all(|x| r.room_at(x, 125).is_none()));
}

#[test]
fn overflowing_rooms_and_doors_are_counted() {
    // 10 × 10 rooms of 2 m, walls 0.2 m, two 0.6 m doors in every inner wall.
    let mut g = grid();
    let p = 22;
    rect(&mut g, 18, 18, 20 + 10 * p, 20 + 10 * p, Cell::Occupied);
    for j in 0..10 {
        for i in 0..10 {
            let (x0, y0) = (20 + i * p, 20 + j * p);
            rect(&mut g, x0, y0, x0 + 20, y0 + 20, Cell::Free);
            if i < 9 {
                rect(&mut g, x0 + 20, y0 + 2, x0 + 22, y0 + 8, Cell::Free);
                rect(&mut g, x0 + 20, y0 + 12, x0 + 22, y0 + 18, Cell::Free);
            }
            if j < 9 {
                rect(&mut g, x0 + 2, y0 + 20, x0 + 8, y0 + 22, Cell::Free);
                rect(&mut g, x0 + 12, y0 + 20, x0 + 18, y0 + 22, Cell::Free);
            }
        }
    }
    let r = segment(&g);
    assert_eq!(r.rooms().len(), MAX_ROOMS);
    assert_eq!(r.stats.rooms_dropped, 100 - MAX_ROOMS as u32);
    assert_eq!(r.doors().len(), MAX_DOORS);
    assert!(r.stats.doors_dropped > 0, "{:?}", r.stats);
    let ids: Vec<u8> = r.rooms().iter().map(|x| x.id).collect();
    assert_eq!(ids, (1..=MAX_ROOMS as u8).collect::<Vec<_>>());
}

#[test]
fn the_struct_size_and_the_work_bound_are_as_documented() {
    assert_eq!(core::mem::size_of::<Rooms>(), 173_960);
    let g = grid();
    let mut r = Box::new(Rooms::new());
    assert!(r.update(&g) <= WORK_BOUND);
    assert!(r.rooms().is_empty() && r.doors().is_empty());
    let mut g = grid();
    corridor_world(&mut g);
    let w = r.update(&g);
    assert!(w <= WORK_BOUND && w > 10 * COARSE_AREA as u32, "{w}");
}
