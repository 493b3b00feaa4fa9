use super::*;
use std::path::Path;

use std::time::Instant;

fn tmp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("lives-render-{}-{name}.png", std::process::id()))
}

/// Set LIVES_KEEP_RENDER=1 to keep the test pictures for a look.
fn keep_or_remove(path: &Path) {
    if std::env::var_os("LIVES_KEEP_RENDER").is_none() {
        std::fs::remove_file(path).ok();
    } else {
        eprintln!("kept {}", path.display());
    }
}

fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.len() > 33, "PNG too short");
    assert_eq!(&bytes[..8], &[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a], "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    assert_eq!(&bytes[bytes.len() - 8..bytes.len() - 4], b"IEND");
    (w, h)
}

/// Grid 100 x 100 at origin (0, 0): x < 4.0 m free, 4.0..4.2 m occupied,
/// beyond unknown; the camera has seen free cells with x < 2.0 m.
fn lidar(x: usize, _y: usize) -> i8 {
    match x {
        0..=39 => 0,
        40..=41 => 100,
        _ => -1,
    }
}
fn seen(x: usize, _y: usize) -> bool {
    x < 20
}

fn has_colour_near(img: &RgbImage, (x, y): (u32, u32), r: i32, c: [u8; 3]) -> bool {
    (-r..=r).any(|dy| {
        (-r..=r).any(|dx| {
            let (xx, yy) = (x as i32 + dx, y as i32 + dy);
            xx >= 0 && yy >= 0 && (xx as u32) < img.width && (yy as u32) < img.height && img.pixel(xx as u32, yy as u32) == c
        })
    })
}

struct Data {
    walls: Vec<[P2; 2]>,
    obstacles: Vec<Vec<P2>>,
    people: Vec<P2>,
    targets: Vec<Vec<P2>>,
    nonmap: Vec<P2>,
    frontier: Vec<P2>,
    viewpoints: Vec<(P2, f64)>,
    traj: Vec<P2>,
    goal_path: Vec<P2>,
}

fn data() -> Data {
    Data {
        walls: vec![[[0.0, 0.0], [8.0, 0.0]], [[0.0, 6.0], [8.0, 6.0]], [[0.0, 0.0], [0.0, 6.0]]],
        obstacles: vec![vec![[6.0, 4.0], [7.0, 4.0], [7.0, 5.0], [6.0, 5.0]]],
        people: vec![[6.5, 2.0]],
        targets: vec![vec![[7.0, 1.0], [7.5, 1.0], [7.5, 1.3], [7.0, 1.3]]],
        nonmap: vec![[2.0, 5.0], [2.5, 5.0]],
        frontier: vec![[3.95, 2.0], [3.95, 2.1]],
        viewpoints: vec![([5.0, 5.0], 0.5)],
        traj: vec![[1.0, 1.0], [3.0, 1.0], [3.0, 2.5]],
        goal_path: vec![[3.0, 2.5], [5.0, 3.0]],
    }
}

fn input<'a>(d: &'a Data, found: Option<P2>) -> RenderInput<'a> {
    RenderInput {
        title: "test world · lives-gt · seed 1 · FOUND in 42.6 s · path 18.3 m".into(),
        bounds: [[0.0, 0.0], [8.0, 6.0]],
        walls: &d.walls,
        obstacles: &d.obstacles,
        people: &d.people,
        targets: &d.targets,
        grid: GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 100, height: 100, lidar: &lidar, seen: &seen },
        nonmap_points: &d.nonmap,
        frontier_cells: &d.frontier,
        viewpoints: &d.viewpoints,
        trajectory: &d.traj,
        start: ([1.0, 1.0], 0.0),
        robot: ([3.0, 2.5], 1.0),
        goal: Some(([5.0, 3.0], 0.0)),
        goal_path: &d.goal_path,
        found_at: found,
        camera_fov_rad: std::f64::consts::FRAC_PI_2,
        camera_range_m: 4.0,
    }
}

#[test]
fn the_legend_lists_non_map_points_and_frontiers_only_when_the_picture_has_them() {
    let d = data();
    let labels = |inp: &RenderInput| legend_rows(inp).iter().map(|r| r.label).collect::<Vec<_>>();
    let full = labels(&input(&d, None));
    assert!(full.contains(&"Non-map points") && full.contains(&"Frontier cells"), "{full:?}");
    let mut inp = input(&d, None);
    inp.nonmap_points = &[];
    inp.frontier_cells = &[];
    let bare = labels(&inp);
    assert!(!bare.contains(&"Non-map points") && !bare.contains(&"Frontier cells"), "{bare:?}");
    assert_eq!(bare.len() + 2, full.len());
    // The legend's height follows its rows.
    assert!(layout(&inp).height <= layout(&input(&d, None)).height);
}

#[test]
fn synthetic_input_writes_png_with_expected_size_and_colours() {
    let d = data();
    let inp = input(&d, Some([3.0, 2.5]));
    let lay = layout(&inp);
    // 8 m x 6 m plus 1 m margins at 20 px/m.
    assert_eq!((lay.map_w, lay.map_h), (200, 160));
    assert_eq!(lay.map_y0, TITLE_H);
    assert_eq!(lay.height, TITLE_H + 160u32.max(lay.legend_h));
    assert!(lay.width >= 200 + LEGEND_W);

    let path = tmp("synthetic");
    render_png(&path, &inp).expect("render");
    let bytes = std::fs::read(&path).unwrap();
    keep_or_remove(&path);
    assert_eq!(png_size(&bytes), (lay.width, lay.height));

    let img = render_rgb(&inp).unwrap();
    assert_eq!((img.width, img.height), (lay.width, lay.height));
    let at = |p: P2| img.pixel(lay.pixel_of(p).unwrap().0, lay.pixel_of(p).unwrap().1);
    assert_eq!(at([1.03, 3.53]), palette::SEEN, "camera-seen free cell");
    assert_eq!(at([3.03, 4.53]), palette::FREE, "LiDAR free cell");
    assert_eq!(at([4.13, 3.53]), palette::OCCUPIED, "LiDAR occupied cell");
    assert_eq!(at([5.53, 1.03]), palette::UNKNOWN, "LiDAR unknown cell");
    assert_eq!(at([-0.47, 3.03]), palette::UNKNOWN, "outside the grid");
    assert_eq!(at([2.0, 5.0]), palette::NONMAP, "non-map point");
    assert_eq!(at([3.95, 2.05]), palette::FRONTIER, "frontier cell");
    assert!(has_colour_near(&img, lay.pixel_of([2.0, 1.0]).unwrap(), 1, palette::TRAJECTORY));
    assert!(has_colour_near(&img, lay.pixel_of([3.0, 2.5]).unwrap(), 7, palette::FOUND));
    assert!(has_colour_near(&img, lay.pixel_of([7.25, 1.0]).unwrap(), 1, palette::TARGET));
    assert!(has_colour_near(&img, lay.pixel_of([4.0, 0.0]).unwrap(), 1, palette::WALL));
    assert!(has_colour_near(&img, lay.pixel_of([1.0, 1.0]).unwrap(), 2, palette::START));
    // The title was drawn: dark pixels in the title strip.
    let dark =
        (0..lay.width).flat_map(|x| (0..TITLE_H).map(move |y| (x, y))).filter(|&(x, y)| img.pixel(x, y).iter().all(|&c| c < 100)).count();
    assert!(dark > 100, "title text missing ({dark} dark pixels)");
    // The legend was drawn: swatches of the palette right of the map.
    let legend_has = |c: [u8; 3]| (lay.map_w..lay.width).any(|x| (TITLE_H..lay.height).any(|y| img.pixel(x, y) == c));
    for c in [palette::SEEN, palette::OCCUPIED, palette::NONMAP, palette::FRONTIER, palette::GOAL] {
        assert!(legend_has(c), "legend lacks {c:?}");
    }
}

#[test]
fn not_found_run_renders() {
    let d = data();
    let img = render_rgb(&input(&d, None)).unwrap();
    assert!(img.width > 0 && img.height > 0);
}

#[test]
fn long_title_widens_the_picture() {
    let d = data();
    let mut inp = input(&d, None);
    inp.title = "x".repeat(300);
    let lay = layout(&inp);
    assert!(lay.width > 200 + LEGEND_W);
    assert_eq!(render_rgb(&inp).unwrap().width, lay.width);
}

#[test]
fn empty_and_nan_inputs_do_not_panic() {
    let never = |_: usize, _: usize| -> i8 { panic!("grid has no cells") };
    let no = |_: usize, _: usize| false;
    let empty = RenderInput {
        title: String::new(),
        bounds: [[f64::NAN, 0.0], [1.0, f64::INFINITY]],
        walls: &[],
        obstacles: &[],
        people: &[],
        targets: &[],
        grid: GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 0, height: 0, lidar: &never, seen: &no },
        nonmap_points: &[],
        frontier_cells: &[],
        viewpoints: &[],
        trajectory: &[],
        start: ([f64::NAN, f64::NAN], f64::NAN),
        robot: ([f64::NAN, 1.0], f64::NAN),
        goal: None,
        goal_path: &[],
        found_at: None,
        camera_fov_rad: f64::NAN,
        camera_range_m: f64::NAN,
    };
    let path = tmp("empty");
    render_png(&path, &empty).expect("empty input renders");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_file(&path).ok();
    let lay = layout(&empty);
    assert_eq!(png_size(&bytes), (lay.width, lay.height));

    let nan = [f64::NAN, f64::NAN];
    let inf = [f64::INFINITY, 0.0];
    let huge = [1e300, -1e300];
    let walls = vec![[nan, [1.0, 1.0]], [[0.0, 0.0], huge], [inf, [0.0, 0.0]]];
    let obstacles = vec![vec![nan, [1.0, 1.0], huge], vec![]];
    let pts = vec![nan, inf, huge, [1.0, 1.0], [-1e12, 5.0]];
    let vps = vec![(nan, 0.0), ([1.0, 1.0], f64::NAN), (huge, 1.0)];
    let lid = |_: usize, _: usize| -> i8 { 0 };
    let bad = RenderInput {
        title: "NaN everywhere".into(),
        bounds: [[0.0, 0.0], [5.0, 5.0]],
        walls: &walls,
        obstacles: &obstacles,
        people: &pts,
        targets: &obstacles,
        grid: GridView { origin: nan, cell_m: f64::NAN, width: 10, height: 10, lidar: &lid, seen: &no },
        nonmap_points: &pts,
        frontier_cells: &pts,
        viewpoints: &vps,
        trajectory: &pts,
        start: (huge, 0.0),
        robot: ([1.0, 1.0], 0.3),
        goal: Some((nan, 0.0)),
        goal_path: &pts,
        found_at: Some(nan),
        camera_fov_rad: 1.0,
        camera_range_m: 1e300,
    };
    let img = render_rgb(&bad).expect("NaN input renders");
    assert_eq!((img.width, img.height), (layout(&bad).width, layout(&bad).height));

    // Zero-size and inverted bounds with a valid grid fall back to the grid.
    let mut inv = bad;
    inv.bounds = [[5.0, 5.0], [0.0, 0.0]];
    inv.grid = GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 30, height: 20, lidar: &lid, seen: &no };
    let lay = layout(&inv);
    assert_eq!((lay.map_w, lay.map_h), (100, 80));
    render_rgb(&inv).expect("inverted bounds render");
}

#[test]
fn huge_bounds_are_scaled_down() {
    let d = data();
    let mut inp = input(&d, None);
    inp.bounds = [[0.0, 0.0], [1e6, 10.0]];
    let lay = layout(&inp);
    assert!(lay.map_w as f64 <= MAX_MAP_PX + 1.0);
    assert!(lay.px_per_m > 0.0);
}

#[test]
fn unwritable_path_is_an_io_error() {
    let d = data();
    let path = std::env::temp_dir().join("lives-render-no-such-dir").join("x").join("out.png");
    match render_png(&path, &input(&d, None)) {
        Err(RenderError::Io(_)) => {}
        other => panic!("expected Io error, got {other:?}"),
    }
}

#[test]
fn full_size_grid_renders() {
    // 512 x 512 cells, 51.2 m square world, walls every 5 m.
    let lid = |x: usize, y: usize| -> i8 {
        if x.is_multiple_of(50) || y.is_multiple_of(50) {
            100
        } else if (x + y).is_multiple_of(7) || x > 400 {
            -1
        } else {
            0
        }
    };
    let sn = |x: usize, y: usize| (x / 30 + y / 30).is_multiple_of(2);
    let walls: Vec<[P2; 2]> = (0..=10)
        .flat_map(|k| {
            let v = k as f64 * 5.0;
            [[[v, 0.0], [v, 51.2]], [[0.0, v], [51.2, v]]]
        })
        .collect();
    let traj: Vec<P2> = (0..5000)
        .map(|i| {
            let t = i as f64 * 0.01;
            [25.0 + 20.0 * t.cos() * (t / 50.0), 25.0 + 20.0 * t.sin() * (t / 50.0)]
        })
        .collect();
    let nonmap: Vec<P2> = (0..2000).map(|i| [(i % 50) as f64, (i / 50) as f64]).collect();
    let frontier: Vec<P2> = (0..3000).map(|i| [40.05, i as f64 * 0.017]).collect();
    let inp = RenderInput {
        title: "big world · lives-gt · seed 7 · NOT FOUND · path 120.0 m".into(),
        bounds: [[0.0, 0.0], [51.2, 51.2]],
        walls: &walls,
        obstacles: &[],
        people: &[[10.0, 10.0]],
        targets: &[],
        grid: GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 512, height: 512, lidar: &lid, seen: &sn },
        nonmap_points: &nonmap,
        frontier_cells: &frontier,
        viewpoints: &[],
        trajectory: &traj,
        start: ([25.0, 25.0], 0.0),
        robot: ([30.0, 30.0], 2.0),
        goal: Some(([35.0, 35.0], 1.0)),
        goal_path: &[[30.0, 30.0], [35.0, 35.0]],
        found_at: None,
        camera_fov_rad: std::f64::consts::FRAC_PI_2,
        camera_range_m: 4.0,
    };
    let t = Instant::now();
    let path = tmp("big");
    render_png(&path, &inp).expect("render");
    let dt = t.elapsed();
    let bytes = std::fs::read(&path).unwrap();
    keep_or_remove(&path);
    let lay = layout(&inp);
    assert_eq!((lay.map_w, lay.map_h), (1064, 1064));
    assert_eq!(png_size(&bytes), (lay.width, lay.height));
    eprintln!("512x512-cell render + PNG write: {:.1} ms", dt.as_secs_f64() * 1e3);
}
