//! Tests of the parent module (`grid.rs`).

use super::*;
use crate::config::Config;

/// The camera marks what the LiDAR map holds as free along its rays, the first occupied cell
/// and nothing past it, and stops at a cell the LiDAR has not seen: a wall it has not mapped
/// may stand there, and the camera does not see through walls.
#[test]
fn the_camera_sees_only_what_the_lidar_map_holds_and_stops_at_walls_and_unknown_cells() {
    let geom = GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO };
    let mut lidar = LidarGrid::new(geom);
    let (rx, ry) = (100, 100);
    // Free east of the robot for 10 cells, a wall at 11 on row 100; on row 101 free for 5
    // cells, then unknown (never seen by the LiDAR), then free again beyond.
    for x in rx..=rx + 10 {
        lidar.grid.set(x, ry, Cell::Free);
    }
    lidar.grid.set(rx + 11, ry, Cell::Occupied);
    for x in rx + 12..rx + 30 {
        lidar.grid.set(x, ry, Cell::Free);
    }
    let (cx, cy) = geom.center_of(rx, ry);
    let pose = Pose2::new(cx, cy, BinaryAngle::ZERO);
    let mut visual = VisualGrid::new();
    // A narrow cone (1°) along row 100, 4 m (40 cells).
    visual.integrate(&lidar, &pose, BinaryAngle::from_fraction(1, 360), Config::mm(4_000));
    for x in rx..=rx + 10 {
        assert_eq!(visual.get(x, ry), Cell::Free, "cell {x}");
    }
    assert_eq!(visual.get(rx + 11, ry), Cell::Occupied, "the wall is seen");
    for x in rx + 12..rx + 30 {
        assert_eq!(visual.get(x, ry), Cell::Unknown, "cell {x} is behind the wall");
    }

    // The same with the wall's cell unknown to the LiDAR: the camera stops before it.
    lidar.grid.set(rx + 11, ry, Cell::Unknown);
    let mut visual = VisualGrid::new();
    visual.integrate(&lidar, &pose, BinaryAngle::from_fraction(1, 360), Config::mm(4_000));
    assert_eq!(visual.get(rx + 10, ry), Cell::Free);
    for x in rx + 11..rx + 30 {
        assert_eq!(visual.get(x, ry), Cell::Unknown, "cell {x} is past a cell the LiDAR has not seen");
    }
}
