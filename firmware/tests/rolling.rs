//! Buildings larger than the grid (issue 27, item 6): the maps' window follows the robot
//! (`firmware::rolling`).

mod common;
use common::*;
use firmware::config::MAX_ORIGIN_M;
use firmware::frontier::FrontierSource;
use firmware::grid::{Cell, GridGeometry, LidarGrid, VisualGrid};
use firmware::planner::{Goal, Site, Viewpoint};
use firmware::rolling::memory::{WindowMemory, RESTORED_FREE, RESTORED_OCCUPIED};
use firmware::rolling::{self, Maps, WINDOW_SHIFT_CELLS};
use firmware::scan::BeamLabel;
use firmware::{BinaryAngle, Command, Config, Controller, FrontierSet, Inputs, Meters, NonMapStore, Planner, Pose2, Status};

const N: i32 = firmware::capacity::GRID_CELLS as i32;

/// A corridor 2.4 m wide and 100 m long along +x (inner faces at y = 20 and 22.4), closed at both
/// ends, with a pillar against the south wall every 4 m (landmarks).
fn corridor() -> Vec<Box2> {
    let mut w =
        vec![wall(-0.1, 19.9, 100.1, 20.0), wall(-0.1, 22.4, 100.1, 22.5), wall(-0.1, 19.9, 0.0, 22.5), wall(100.0, 19.9, 100.1, 22.5)];
    for k in 0..25 {
        let x = 2.0 + 4.0 * k as f64;
        w.push(wall(x, 20.0, x + 0.4, 20.4));
    }
    w
}

fn corridor_config() -> Config {
    // The window starts with the robot (x = 2 m) 22 m from its west edge.
    // The window's own behaviour, on exact poses: no scan matching.
    Config { origin_x_m: Config::mm(-20_000), origin_y_m: Config::mm(-4_000), scan_matching: false, ..Config::DEFAULT }
}

/// Drives the robot from x = 2 m to x = 82 m down the corridor's middle, a scan every 0.1 m, the
/// search started (so it plans, blacklists and keeps goals as it goes). Calls `each` after every
/// tick.
fn drive(ctl: &mut Controller, mut each: impl FnMut(&Controller, &Status)) -> Status {
    let mut last = Status::default();
    let world = corridor();
    for i in 0..=800 {
        let x = 2.0 + i as f64 * 0.1;
        let (ranges, labels) = scan_of(&world, (x, 21.2, 0.0), 720);
        let inputs = Inputs {
            pose: Some(pose(x, 21.2, 0.0)),
            scan: Some(scan_input(&ranges, Some(&labels))),
            command: (i == 0).then_some(Command::Start),
            ..Inputs::default()
        };
        last = ctl.tick(i as u64 * 100_000, &inputs).status;
        each(ctl, &last);
    }
    last
}

fn m(v: f64) -> Meters {
    fixed_point::meters_from_f64(v).unwrap()
}

/// 80 m down a corridor in a 51.2 m window: the window follows, every pose is used, the map
/// around the robot is there at the end (the walls and pillars in the right cells), the goal's
/// cell always matches its world pose, and the shifts are counted in the LiDAR stage's work.
#[test]
fn the_window_follows_a_robot_down_an_80_m_corridor() {
    let mut ctl = controller(corridor_config());
    let origin0 = ctl.lidar.geom;
    let mut shift_ticks = 0;
    let mut last_shifts = 0;
    let mut goals_checked = 0;
    let status = drive(&mut ctl, |c, status| {
        let st = c.lidar.window;
        if st.shifts != last_shifts {
            last_shifts = st.shifts;
            shift_ticks += 1;
            assert!(status.cost.lidar >= st.last_work, "the shift's work is in the LiDAR stage of its tick");
            assert!(st.last_work >= 6 * 512 * 512, "six cell arrays are moved: {}", st.last_work);
        }
        if let Some(g) = c.goal() {
            assert_eq!(c.lidar.geom.cell_of(g.pose.x, g.pose.y), g.viewpoint.cell, "the goal's cell moves with the window");
            goals_checked += 1;
        }
        for &b in c.planner.blacklisted() {
            assert!(firmware::grid::PackedGrid::in_bounds(b.0, b.1));
        }
    });
    let st = ctl.lidar.window;
    assert_eq!(status.poses_rejected, 0, "no pose fell outside the window");
    assert_eq!(status.scans, 801);
    assert_eq!(st.refused, 0);
    // 80 m at one shift per 16 m once the robot is 3 m from the edge: x = 28.2, 44.2, 60.2, 76.2.
    assert_eq!(st.shifts, 4, "{st:?}");
    assert_eq!(shift_ticks, 4);
    assert_eq!(st.moved_cells, (4 * WINDOW_SHIFT_CELLS, 0));
    assert_eq!(ctl.lidar.geom.origin_x.to_bits(), origin0.origin_x.to_bits() + 4 * 16 * 65_536, "16 m a shift, exactly");
    assert_eq!(ctl.lidar.geom.origin_y, origin0.origin_y);
    assert!(goals_checked > 100, "the search ran with a goal most of the way ({goals_checked} ticks)");

    // The map around the robot (x = 82 m): the window is [44, 95.2) m. The corridor's walls and
    // the pillars the robot has passed since 46 m are in their cells; its middle is free.
    let g = ctl.lidar.geom;
    let robot = g.cell_of(ctl.pose().unwrap().x, ctl.pose().unwrap().y);
    assert!((379..=380).contains(&robot.0) && (251..=252).contains(&robot.1), "{robot:?}");
    for k in 11..=19 {
        let px = 2.0 + 4.0 * k as f64 + 0.2;
        let (cx, cy) = g.cell_of(m(px), m(20.35));
        assert_eq!(ctl.lidar.get(cx, cy), Cell::Occupied, "pillar's face at x = {px} m");
        let (cx, cy) = g.cell_of(m(px + 2.0), m(21.2));
        assert_eq!(ctl.lidar.get(cx, cy), Cell::Free, "corridor at x = {} m", px + 2.0);
        let (cx, cy) = g.cell_of(m(px + 2.0), m(22.45));
        assert_eq!(ctl.lidar.get(cx, cy), Cell::Occupied, "north wall at x = {} m", px + 2.0);
    }
    // What left the window is out of the grid: the cells that hold the corridor now hold no
    // trace of where it was before (the whole grid has its walls only along the corridor's
    // rows); it is in the window's memory, tile by tile, until the window comes back.
    for y in 0..N {
        for x in 0..N {
            if ctl.lidar.get(x, y) == Cell::Occupied {
                let (_, wy) = g.center_of(x, y);
                let wy = wy.to_num::<f64>();
                assert!((19.8..22.6).contains(&wy), "an occupied cell off the corridor at ({x}, {y})");
            }
        }
    }
    let kept = ctl.memory.stats;
    assert!(kept.kept > 0 && ctl.memory.tiles() == kept.kept as usize, "{kept:?}");
    assert_eq!((kept.restored, kept.dropped), (0, 0), "the robot never came back; everything fitted");
    // A reset (a new search) forgets the memory with the maps.
    ctl.tick(90_000_000, &Inputs { command: Some(Command::Reset), ..Inputs::default() });
    assert_eq!((ctl.memory.tiles(), ctl.memory.stats.kept), (0, 0));
}

/// The same drive twice gives the same window, maps and goal, bit for bit (integer arithmetic
/// only: the same holds on the Cortex-M).
#[test]
fn the_window_moves_deterministically() {
    let run = || {
        let mut ctl = controller(corridor_config());
        let st = drive(&mut ctl, |_, _| {});
        (ctl, st)
    };
    let ((a, sa), (b, sb)) = (run(), run());
    assert_eq!(a.lidar.geom, b.lidar.geom);
    assert_eq!(a.lidar.window, b.lidar.window);
    assert!(a.lidar.grid.as_bytes() == b.lidar.grid.as_bytes());
    assert!(a.visual.grid.as_bytes() == b.visual.grid.as_bytes());
    assert_eq!(a.goal(), b.goal());
    assert_eq!(a.planner.blacklisted().collect::<Vec<_>>(), b.planner.blacklisted().collect::<Vec<_>>());
    assert_eq!(sa, sb);
}

/// The maps `rolling::shift` moves, on their own (not in a controller).
struct OwnedMaps {
    lidar: Box<LidarGrid>,
    visual: Box<VisualGrid>,
    nonmap: Box<NonMapStore>,
    frontiers: Box<FrontierSet>,
    planner: Box<Planner>,
    goal: Option<Goal>,
    memory: Box<WindowMemory>,
}

impl OwnedMaps {
    /// Empty maps, no goal, the window at `geom`.
    fn new(geom: GridGeometry) -> Self {
        OwnedMaps {
            lidar: Box::new(LidarGrid::new(geom)),
            visual: Box::new(VisualGrid::new()),
            nonmap: Box::new(NonMapStore::new()),
            frontiers: Box::new(FrontierSet::new()),
            planner: Box::new(Planner::new()),
            goal: None,
            memory: Box::new(WindowMemory::new()),
        }
    }

    /// `rolling::shift` of all of them by (`sx`, `sy`) cells.
    fn shift(&mut self, sx: i32, sy: i32, pool_radius: Meters) -> Option<u32> {
        let OwnedMaps { lidar, visual, nonmap, frontiers, planner, goal, memory } = self;
        rolling::shift(Maps { lidar, visual, nonmap, frontiers, planner, goal, memory }, sx, sy, pool_radius)
    }
}

/// A deterministic pattern of evidence and camera cells over the whole grid, a wall mask,
/// blacklist entries, frontiers, `rrt` nodes and a goal; then one shift. Every cell is the old
/// one `(x + sx, y + sy)` or unknown, every stored coordinate moved by exactly the shift (or was
/// dropped when it left), and a world point falls in the cell it fell in before, less the shift.
#[test]
fn a_shift_moves_every_cell_and_every_stored_coordinate_exactly() {
    let geom = GridGeometry { origin_x: m(-3.2), origin_y: m(7.5) };
    let mut w = OwnedMaps::new(geom);
    let mut rng = 0x1234_5678u32;
    for y in 0..N {
        for x in 0..N {
            let r = firmware::rrt::xorshift32(&mut rng);
            for _ in 0..(r & 7) {
                w.lidar.evidence.add(x, y, if r & 8 != 0 { 2 } else { -1 });
            }
            if r & 7 != 0 {
                w.lidar.grid.set(x, y, firmware::grid::cell_of_evidence(w.lidar.evidence.get(x, y)));
            }
            w.visual.grid.set(x, y, [Cell::Unknown, Cell::Free, Cell::Occupied, Cell::Free][(r >> 4) as usize & 3]);
            w.nonmap.walls.put(x, y, r & 0x100 != 0);
        }
    }
    let before_lidar = w.lidar.clone();
    let before_visual = w.visual.clone();
    let before_walls: Vec<bool> = (0..N * N).map(|i| w.nonmap.walls.get(i % N, i / N)).collect();
    let blacklist = [(400, 30), (100, 300), (170, 500), (10, 10)];
    for &c in &blacklist {
        w.planner.blacklist(c);
    }
    // A frontier step on the pattern, and the `rrt` trees grown on it.
    w.frontiers.compute(&w.lidar, &w.visual, 1);
    let fr_before: Vec<_> = w.frontiers.frontiers().to_vec();
    w.planner.rrt.grow(&w.lidar, &w.visual, (300, 100));
    let rrt_before: Vec<_> = w.planner.rrt.points().copied().collect();
    let vp = Viewpoint {
        cell: (350, 90),
        heading: BinaryAngle::ZERO,
        source: Site::LidarFrontier,
        utility: 0,
        path_units: 0,
        unseen: 0,
        surface: 0,
        frontier_near_path: 0,
        nonmap: 0,
    };
    let (gx, gy) = geom.center_of(350, 90);
    w.goal =
        Some(Goal { pose: Pose2::new(gx, gy, BinaryAngle::ZERO), viewpoint: vp, path: heapless::Vec::new(), path_length_m: Meters::ZERO });

    let (sx, sy) = (160, -320);
    let work = w.shift(sx, sy, Config::DEFAULT.nonmap_pool_radius_m).expect("a valid shift");
    assert!(work >= 6 * (N * N) as u32);
    assert_eq!(w.lidar.window.last_work, work);

    for y in 0..N {
        for x in 0..N {
            let (ox, oy) = (x + sx, y + sy);
            let inside = (0..N).contains(&ox) && (0..N).contains(&oy);
            let want = |c: Cell| if inside { c } else { Cell::Unknown };
            assert_eq!(w.lidar.get(x, y), want(before_lidar.get(ox, oy)), "lidar ({x}, {y})");
            assert_eq!(w.lidar.evidence.get(x, y), if inside { before_lidar.evidence.get(ox, oy) } else { None });
            assert_eq!(w.visual.get(x, y), want(before_visual.get(ox, oy)), "visual ({x}, {y})");
            assert_eq!(w.nonmap.walls.get(x, y), inside && before_walls[(oy * N + ox) as usize], "walls ({x}, {y})");
            assert!(w.planner.distance(x, y) == firmware::planner::UNREACHABLE || inside);
        }
    }
    // The geometry: exactly 16 m east and 32 m south; every world point keeps its cell, less the shift.
    assert_eq!(w.lidar.geom.origin_x, m(12.8));
    assert_eq!(w.lidar.geom.origin_y, m(-24.5));
    let mut rng = 99u32;
    for _ in 0..10_000 {
        let wx = Meters::from_bits((firmware::rrt::xorshift32(&mut rng) % (80 << 16)) as i32 - (20 << 16));
        let wy = Meters::from_bits((firmware::rrt::xorshift32(&mut rng) % (80 << 16)) as i32 - (30 << 16));
        let (a, b) = (geom.cell_of(wx, wy), w.lidar.geom.cell_of(wx, wy));
        assert_eq!((a.0 - sx, a.1 - sy), b);
        if firmware::grid::PackedGrid::in_bounds(a.0, a.1) && firmware::grid::PackedGrid::in_bounds(b.0, b.1) {
            assert_eq!(w.lidar.geom.center_of(b.0, b.1), geom.center_of(a.0, a.1));
        }
    }
    // Stored coordinates: moved, or dropped if they left.
    let moved = |c: (i32, i32)| {
        let n = (c.0 - sx, c.1 - sy);
        ((0..N).contains(&n.0) && (0..N).contains(&n.1)).then_some(n)
    };
    let bl: Vec<_> = w.planner.blacklisted().copied().collect();
    assert_eq!(bl, blacklist.iter().filter_map(|&c| moved(c)).collect::<Vec<_>>());
    assert_eq!(bl, vec![(240, 350)]);
    assert_eq!(w.goal.as_ref().map(|g| g.viewpoint.cell), Some((190, 410)));
    let g = w.goal.as_ref().unwrap();
    assert_eq!(w.lidar.geom.cell_of(g.pose.x, g.pose.y), g.viewpoint.cell);
    let fr_after: Vec<_> = w.frontiers.frontiers().to_vec();
    let fr_want: Vec<_> = fr_before
        .iter()
        .filter_map(|f| {
            let (a, c) = (moved(f.anchor)?, moved(f.centroid)?);
            Some(firmware::Frontier { anchor: a, centroid: c, ..*f })
        })
        .collect();
    assert_eq!(fr_after, fr_want);
    assert!(!fr_before.is_empty() && fr_after.len() < fr_before.len(), "some frontiers left, some stayed");
    let rrt_after: Vec<_> = w.planner.rrt.points().copied().collect();
    let rrt_want: Vec<_> =
        rrt_before.iter().filter_map(|p| Some(firmware::rrt::RrtPoint { cell: moved(p.cell)?, source: p.source })).collect();
    assert_eq!(rrt_after, rrt_want);
    assert!(rrt_after.iter().all(|p| matches!(p.source, FrontierSource::Lidar | FrontierSource::Visual)));
    // A goal that leaves the window is dropped.
    w.shift(0, -160, Config::DEFAULT.nonmap_pool_radius_m).unwrap();
    assert!(w.goal.is_none(), "{:?}", w.goal);
    assert_eq!(w.lidar.window.shifts, 2);
}

/// Non-map points are world points: they stay where they are, those now outside the window are
/// dropped, and the pooling index is rebuilt (a point pools with its old neighbour after the
/// shift as before it).
#[test]
fn non_map_points_survive_a_shift_and_still_pool() {
    let geom = GridGeometry { origin_x: m(0.0), origin_y: m(0.0) };
    let r = Config::DEFAULT.nonmap_pool_radius_m;
    let mut w = OwnedMaps::new(geom);
    w.nonmap.insert(&geom, m(20.05), m(10.0), r);
    w.nonmap.insert(&geom, m(3.0), m(10.0), r);
    w.nonmap.insert(&geom, m(40.0), m(40.0), r);
    w.shift(160, 0, r).unwrap();
    let pts: Vec<_> = w.nonmap.points().iter().map(|p| (p.x, p.y)).collect();
    assert_eq!(pts.len(), 2, "the point at x = 3 m left the window [16, 67.2) m");
    assert!(pts.contains(&(m(20.05), m(10.0))) && pts.contains(&(m(40.0), m(40.0))));
    assert_eq!(w.nonmap.stats.dropped_outside, 1);
    w.nonmap.insert(&w.lidar.geom, m(20.0), m(10.02), r);
    assert_eq!(w.nonmap.points().len(), 2, "pooled with its neighbour through the rebuilt index");
    assert_eq!(w.nonmap.stats.pooled, 1);
}

/// A building that fits: a closed room whose east wall stands 1.1 m inside the window's east edge.
/// The robot walks to 2.5 m from that edge, within the 3 m margin, and the window stays (the map
/// does not reach the edge); only a robot within 1 m of the edge moves it whatever the map holds.
#[test]
fn a_building_that_fits_never_moves_the_window() {
    let world =
        vec![wall(30.0, 10.0, 50.1, 10.1), wall(30.0, 20.0, 50.1, 20.1), wall(30.0, 10.0, 30.1, 20.1), wall(50.0, 10.0, 50.1, 20.1)];
    let mut ctl = controller(Config { scan_matching: false, ..Config::DEFAULT });
    for i in 0..=177 {
        let x = 31.0 + i as f64 * 0.1; // to 48.7 m: 2.5 m from the edge at 51.2 m
        let (ranges, labels) = scan_of(&world, (x, 15.0, 0.0), 720);
        ctl.tick(
            i * 100_000,
            &Inputs { pose: Some(pose(x, 15.0, 0.0)), scan: Some(scan_input(&ranges, Some(&labels))), ..Inputs::default() },
        );
    }
    assert_eq!(ctl.lidar.window.shifts, 0);
    assert_eq!(ctl.lidar.geom, GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO });
    assert_eq!(ctl.lidar.get(511, 150), Cell::Unknown, "the map does not reach the edge");
    assert_eq!(ctl.lidar.get(500, 150), Cell::Occupied, "the east wall");
    // A pose 0.9 m from the edge (no scan): the window moves, whatever the map.
    ctl.tick(20_000_000, &Inputs { pose: Some(pose(50.3, 15.0, 0.0)), ..Inputs::default() });
    assert_eq!(ctl.lidar.window.shifts, 1);
    // Cell 503 is 24.7 m east of the middle: two quanta (32 m) bring it nearest the middle.
    assert_eq!(ctl.lidar.window.last_shift, (2 * WINDOW_SHIFT_CELLS, 0));
    assert_eq!(ctl.lidar.geom.origin_x, m(32.0));
    assert_eq!(ctl.lidar.geom.cell_of(m(50.3), m(15.0)), (183, 150));
}

/// Poses far outside the window — 30 000 m away, or past the fixed-point range the origin can
/// take — are refused and change nothing; a robot at the very edge of the coordinate range
/// never panics, and the window stops where its origin would leave the range.
#[test]
fn absurd_poses_are_refused_and_the_window_stops_at_the_coordinate_range() {
    let mut ctl = controller(corridor_config());
    let rejected = drive(&mut ctl, |_, _| {}).poses_rejected;
    let geom = ctl.lidar.geom;
    let mut last = Status::default();
    for (x, y) in [(30_000.0, 21.2), (-30_000.0, -30_000.0), (82.0, 30_000.0), (32_767.0, 32_767.0), (-32_767.0, 21.2)] {
        let (ranges, labels) = scan_of(&corridor(), (82.0, 21.2, 0.0), 720);
        last = ctl
            .tick(90_000_000, &Inputs { pose: Some(pose(x, y, 0.0)), scan: Some(scan_input(&ranges, Some(&labels))), ..Inputs::default() })
            .status;
    }
    assert_eq!(last.poses_rejected, rejected + 5);
    assert_eq!(ctl.lidar.geom, geom, "the window did not move");
    assert_eq!(ctl.pose().map(|p| p.x), Some(m(82.0)), "the last good pose stays");

    // The window at the top of the range: the origin can go no farther east than MAX_ORIGIN_M.
    let mut ctl = controller(Config { origin_x_m: MAX_ORIGIN_M, origin_y_m: MAX_ORIGIN_M, scan_matching: false, ..Config::DEFAULT });
    ctl.tick(0, &Inputs { command: Some(Command::Start), ..Inputs::default() });
    let mut t = 0;
    for i in 0..600 {
        let v = MAX_ORIGIN_M.to_num::<f64>() + 20.0 + i as f64 * 0.1;
        let p = Pose2::from_f64(v.min(32_767.0), v.min(32_767.0), 0.0).unwrap();
        let ranges = [5_000u16; 360];
        let labels = [BeamLabel::Map; 360];
        t += 100_000;
        ctl.tick(t, &Inputs { pose: Some(p), scan: Some(scan_input(&ranges, Some(&labels))), ..Inputs::default() });
    }
    assert_eq!(ctl.lidar.window.shifts, 0);
    assert!(ctl.lidar.window.refused > 0);
    assert_eq!(ctl.lidar.geom.origin_x, MAX_ORIGIN_M);
    // And at the bottom: the origin can go no farther west than Meters::MIN.
    let mut ctl = controller(Config { origin_x_m: Meters::MIN, origin_y_m: Meters::MIN, scan_matching: false, ..Config::DEFAULT });
    for i in 0..300 {
        let p = Pose2::from_f64(-32_767.0 + i as f64 * 0.01, -32_760.0, 0.0).unwrap();
        ctl.tick(i * 100_000, &Inputs { pose: Some(p), ..Inputs::default() });
    }
    assert_eq!(ctl.lidar.geom.origin_x, Meters::MIN);
    assert_eq!(ctl.lidar.window.shifts, 0);
}

/// A shift is not a configuration change: the same configuration again keeps the maps; a
/// configured origin that changes re-places the window there and forgets them, as before; a
/// reset forgets the maps but keeps the window where the robot is.
#[test]
fn a_shift_is_not_a_configuration_change() {
    let mut ctl = controller(corridor_config());
    drive(&mut ctl, |_, _| {});
    let geom = ctl.lidar.geom;
    let free = ctl.lidar.grid.count(Cell::Free);
    assert!(free > 0);
    ctl.set_config(corridor_config()).unwrap();
    assert_eq!(ctl.lidar.geom, geom);
    assert_eq!(ctl.lidar.grid.count(Cell::Free), free, "the same configuration keeps the maps");
    ctl.tick(100_000_000, &Inputs { command: Some(Command::Reset), ..Inputs::default() });
    assert_eq!(ctl.lidar.geom, geom, "a reset keeps the window around the robot");
    assert_eq!(ctl.lidar.grid.count(Cell::Free), 0);
    assert_eq!(ctl.lidar.window.shifts, 0);
    let cfg = Config { origin_x_m: Config::mm(-1_000), ..corridor_config() };
    ctl.set_config(cfg).unwrap();
    assert_eq!(ctl.lidar.geom, GridGeometry { origin_x: cfg.origin_x_m, origin_y: cfg.origin_y_m });
}

/// A map-like pattern: walls on a 4 m lattice (with 1 m doorways), free space between them over
/// the western two thirds, unknown beyond; the camera has searched the south-west quarter.
fn rooms_pattern(w: &mut OwnedMaps) {
    for y in 0..N {
        for x in 0..N {
            let wall = (x % 40 == 0 || y % 40 == 0) && !(x % 40 > 15 && x % 40 < 25) && !(y % 40 > 15 && y % 40 < 25);
            if x < 2 * N / 3 {
                let delta = if wall { 6 } else { -4 };
                w.lidar.evidence.add(x, y, delta);
                w.lidar.grid.set(x, y, firmware::grid::cell_of_evidence(w.lidar.evidence.get(x, y)));
                if x < N / 2 && y < N / 2 {
                    w.visual.grid.set(x, y, if wall { Cell::Occupied } else { Cell::Free });
                }
            }
        }
    }
}

/// What leaves the window is kept and comes back when the window does: out 16 m east and 32 m
/// south, then back. Every cell's state (LiDAR and camera) is as before; the cells that left get
/// the middle evidence of their side, the others keep theirs; every tile kept was restored.
#[test]
fn what_leaves_the_window_comes_back_with_it() {
    let geom = GridGeometry { origin_x: m(-3.2), origin_y: m(7.5) };
    let mut w = OwnedMaps::new(geom);
    rooms_pattern(&mut w);
    let before_lidar = w.lidar.clone();
    let before_visual = w.visual.clone();
    let r = Config::DEFAULT.nonmap_pool_radius_m;
    w.shift(160, -320, r).unwrap();
    let kept = w.memory.stats.kept;
    // Tiles that left: x in [0, 5) tiles (all), or y in [6, 16) tiles; observed: x < 341 cells.
    // Leaving: columns 0..5 (16 rows each) and rows 6..16 of columns 5..16; observed columns 0..=10.
    assert_eq!(kept, 5 * 16 + 10 * 6, "every tile that left with something observed in it");
    assert_eq!((w.memory.stats.dropped, w.memory.tiles()), (0, kept as usize));
    assert!(w.memory.bytes_used() <= firmware::capacity::MEMORY_BYTES);
    // Before it comes back, the cells are not in the window.
    assert_eq!(w.lidar.get(0, 0), Cell::Unknown);
    w.shift(-160, 320, r).unwrap();
    assert_eq!(w.lidar.geom, geom);
    assert_eq!(w.memory.stats.restored, kept);
    assert_eq!(w.memory.tiles(), 0);
    for y in 0..N {
        for x in 0..N {
            assert_eq!(w.lidar.get(x, y), before_lidar.get(x, y), "lidar ({x}, {y})");
            assert_eq!(w.visual.get(x, y), before_visual.get(x, y), "visual ({x}, {y})");
            let stayed = x >= 160 && y < 192;
            let want = match (stayed, before_lidar.get(x, y)) {
                (true, _) => before_lidar.evidence.get(x, y),
                (false, Cell::Occupied) => Some(RESTORED_OCCUPIED),
                (false, Cell::Free) => Some(RESTORED_FREE),
                (false, Cell::Unknown) => None,
            };
            assert_eq!(w.lidar.evidence.get(x, y), want, "evidence ({x}, {y})");
        }
    }
}

/// The store is bounded: random tiles (the worst coding) fill it; a tile that does not fit is not
/// kept and counted, earlier ones are; tiles restored leave holes that a compaction closes for new
/// ones; every tile restored is exactly the one kept; a reset forgets all.
#[test]
fn the_window_memory_is_bounded_and_compacts() {
    let geom = GridGeometry { origin_x: m(0.0), origin_y: m(0.0) };
    let mut src = OwnedMaps::new(geom);
    let mut rng = 0xC0FF_EE11u32;
    for y in 0..N {
        for x in 0..N {
            let r = firmware::rrt::xorshift32(&mut rng);
            // Runs of 1–8 cells: 1 byte a code.
            let c = [Cell::Unknown, Cell::Free, Cell::Occupied][(r % 3) as usize];
            let e = match c {
                Cell::Occupied => Some(3),
                Cell::Free => Some(-2),
                Cell::Unknown => None,
            };
            if let Some(e) = e {
                src.lidar.seed(x, y, e);
            }
            src.visual.grid.set(x, y, [Cell::Unknown, Cell::Free][(r >> 8) as usize & 1]);
        }
    }
    let mut mem = Box::new(WindowMemory::new());
    let tiles: Vec<(i32, i32)> = (0..16).flat_map(|j| (0..16).map(move |i| (i, j))).collect();
    let mut held = Vec::new();
    for &t in &tiles {
        let before = mem.stats;
        mem.keep(&src.lidar, &src.visual, (t.0 * 32, t.1 * 32), t);
        if mem.stats.kept > before.kept {
            assert_eq!(mem.stats.dropped, 0, "nothing is kept after the first drop");
            held.push(t);
        }
    }
    assert!(mem.stats.dropped > 0 && !held.is_empty(), "random tiles overflow the store: {:?}", mem.stats);
    assert_eq!(held, tiles[..held.len()].to_vec(), "what left first stays");
    assert!(mem.bytes_used() <= firmware::capacity::MEMORY_BYTES);
    let check = |mem: &mut WindowMemory, t: (i32, i32)| {
        let mut dst = OwnedMaps::new(geom);
        assert!(mem.holds(t));
        mem.restore(&mut dst.lidar, &mut dst.visual, (t.0 * 32, t.1 * 32), t);
        assert!(!mem.holds(t));
        for y in t.1 * 32..t.1 * 32 + 32 {
            for x in t.0 * 32..t.0 * 32 + 32 {
                assert_eq!(dst.lidar.get(x, y), src.lidar.get(x, y), "tile {t:?} lidar ({x}, {y})");
                assert_eq!(dst.visual.get(x, y), src.visual.get(x, y), "tile {t:?} visual ({x}, {y})");
            }
        }
    };
    // Restore every other tile; the holes make room for new ones only after a compaction.
    for &t in held.iter().step_by(2) {
        check(&mut mem, t);
    }
    let dropped = mem.stats.dropped;
    let next = tiles[held.len()];
    mem.keep(&src.lidar, &src.visual, (next.0 * 32, next.1 * 32), next);
    assert_eq!(mem.stats.compactions, 1);
    assert_eq!(mem.stats.dropped, dropped, "the compacted store has room");
    for &t in held.iter().skip(1).step_by(2).chain([next].iter()) {
        check(&mut mem, t);
    }
    assert_eq!(mem.tiles(), 0);
    // An unobserved tile is not kept.
    let empty = OwnedMaps::new(geom);
    mem.keep(&empty.lidar, &empty.visual, (0, 0), (0, 0));
    assert_eq!(mem.tiles(), 0);
    mem.keep(&src.lidar, &src.visual, (0, 0), (7, 7));
    mem.clear();
    assert_eq!((mem.tiles(), mem.stats), (0, Default::default()));
}
