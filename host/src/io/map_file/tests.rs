use super::*;

const GOOD: &str =
    "image: m.pgm\nresolution: 0.05\norigin: [-1.0, 2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nextra_key: ignored\n";

fn meta(text: &str) -> Result<MapMeta, MapError> {
    MapMeta::parse(text, "m.yaml")
}

fn err(text: &str) -> String {
    let e = meta(text).expect_err(text).to_string();
    assert!(e.starts_with("m.yaml"), "{e}");
    e
}

#[test]
fn a_map_server_yaml_parses_with_its_defaults() {
    let m = meta(GOOD).unwrap();
    assert_eq!(m.image, "m.pgm");
    assert_eq!(m.resolution_m, 0.05);
    assert_eq!(m.origin, [-1.0, 2.0, 0.0]);
    assert!(!m.negate);
    assert_eq!(m.mode, Mode::Trinary);
    let m = meta("image: a.png\nresolution: 1\norigin: [0, 0, 0]\nnegate: true\nmode: scale\n").unwrap();
    assert!(m.negate);
    assert_eq!(m.mode, Mode::Scale);
    assert_eq!((m.occupied_thresh, m.free_thresh), (DEFAULT_OCCUPIED_THRESH, DEFAULT_FREE_THRESH));
}

#[test]
fn pixels_follow_map_servers_rule() {
    let m = meta(GOOD).unwrap();
    assert_eq!(m.classify(0), Cell3::Occupied);
    assert_eq!(m.classify(254), Cell3::Free);
    assert_eq!(m.classify(205), Cell3::Unknown);
    let n = MapMeta { negate: true, ..m };
    assert_eq!(n.classify(0), Cell3::Free);
    assert_eq!(n.classify(255), Cell3::Occupied);
}

#[test]
fn bad_yaml_is_an_error_naming_the_file_and_the_key() {
    let cases = [
        ("image: m.pgm\nresolution: -0.05\norigin: [0, 0, 0]\n", "m.yaml:2: `resolution`"),
        ("image: m.pgm\nresolution: 0\norigin: [0, 0, 0]\n", "`resolution`: 0 is not a positive"),
        ("image: m.pgm\nresolution: .inf\norigin: [0, 0, 0]\n", "`resolution`: inf"),
        ("image: m.pgm\nresolution: 0.1\norigin: [.nan, 0, 0]\n", "m.yaml:3: `origin`: x is NaN"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0]\n", "`origin`: expected [x, y, yaw]"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, .inf]\n", "`origin`: yaw is inf"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 1.5\n", "`occupied_thresh`: 1.5 is outside [0, 1]"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thresh: 0.7\n", "`free_thresh`: 0.7 is not below occupied_thresh 0.65"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nmode: raw\n", "`mode`: raw maps"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 2\n", "`negate`"),
        ("resolution: 0.1\norigin: [0, 0, 0]\n", "no `image` key"),
        ("image: m.pgm\norigin: [0, 0, 0]\n", "no `resolution` key"),
        ("image: m.pgm\nresolution: [\n", "not valid YAML"),
        ("just text", "not a map_server map file"),
    ];
    for (text, want) in cases {
        let e = err(text);
        assert!(e.contains(want), "{text:?}: {e}");
    }
}

fn pgm(w: usize, h: usize, px: &[u8]) -> Vec<u8> {
    let mut v = format!("P5\n# comment\n{w} {h}\n255\n").into_bytes();
    v.extend_from_slice(px);
    v
}

fn map_of(text: &str, image: &[u8]) -> Result<PriorMap, MapError> {
    PriorMap::from_meta(meta(text).unwrap(), image, "m.yaml", "m.pgm")
}

#[test]
fn the_images_top_row_is_the_maps_highest_y() {
    // Top row: occupied, free; bottom row: unknown, free.
    let m = map_of(GOOD, &pgm(2, 2, &[0, 254, 205, 254])).unwrap();
    assert_eq!((m.width, m.height), (2, 2));
    assert_eq!(m.get(0, 1), Some(Cell3::Occupied));
    assert_eq!(m.get(1, 1), Some(Cell3::Free));
    assert_eq!(m.get(0, 0), Some(Cell3::Unknown));
    assert_eq!(m.at([-1.0 + 0.01, 2.0 + 0.06]), Some(Cell3::Occupied));
    assert_eq!(m.at([-1.0 - 0.01, 2.0]), None);
    assert_eq!(m.counts(), CellCounts { occupied: 1, free: 2, unknown: 1 });
}

#[test]
fn ascii_pgm_and_png_read_as_binary_pgm() {
    let binary = map_of(GOOD, &pgm(3, 1, &[0, 205, 254])).unwrap();
    // maxval 15: 0 → 0, 12 → 204 (p = 0.2, unknown), 15 → 255.
    let ascii = map_of(GOOD, b"P2\n3 1\n# c\n15\n0 12\n15\n").unwrap();
    assert_eq!(ascii.cells, vec![Cell3::Occupied, Cell3::Unknown, Cell3::Free]);
    let mut png_bytes = Vec::new();
    {
        let mut e = png::Encoder::new(&mut png_bytes, 3, 1);
        e.set_color(png::ColorType::Rgb);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().unwrap();
        w.write_image_data(&[0, 0, 0, 205, 205, 205, 254, 254, 254]).unwrap();
    }
    let png = map_of(GOOD, &png_bytes).unwrap();
    assert_eq!(png.cells, binary.cells);
}

#[test]
fn bad_images_are_errors_naming_the_image() {
    let cases: [(&[u8], &str); 8] = [
        (b"", "empty"),
        (b"GIF89a", "not a PGM (P5 or P2) or PNG"),
        (b"P6\n1 1\n255\n\0\0\0", "a P6 PNM image"),
        (b"P5\n0 3\n255\n", "0 x 3 pixels"),
        (b"P5\n4 4\n255\n\0\0\0", "truncated: 3 of its 4 x 4 = 16 pixels"),
        (b"P5\n4 x\n255\n", "height is not a number"),
        (b"P5\n2 1\n65535\n\0\0\0\0", "16-bit"),
        (b"P2\n2 1\n255\n7", "truncated: 1 of its"),
    ];
    for (data, want) in cases {
        let e = map_of(GOOD, data).expect_err(want).to_string();
        assert!(e.starts_with("m.pgm: ") && e.contains(want), "{want}: {e}");
    }
    let e = map_of(GOOD, b"P5\n99999999999 99999999999\n255\n").unwrap_err().to_string();
    assert!(e.contains("more than"), "{e}");
}

#[test]
fn resampling_keeps_a_fine_maps_walls_and_spreads_a_coarse_maps_cells() {
    // 0.05 m map, 4 x 4, one occupied pixel at map cell (1, 2) (centre (-0.925, 2.125)).
    let mut px = vec![254u8; 16];
    px[4 + 1] = 0; // row 4 - 1 - 2 from the top, column 1
    let m = map_of(GOOD, &pgm(4, 4, &px)).unwrap();
    let g = m.to_grid(10.0, 8, [-1.2, 1.8]).unwrap();
    let at = |x: usize, y: usize| g[y * 8 + x];
    // (-0.925, 2.125) is in grid cell (2, 3).
    assert_eq!(at(2, 3), Cell3::Occupied);
    assert_eq!(at(3, 3), Cell3::Free);
    assert_eq!(at(0, 0), Cell3::Unknown);
    assert_eq!(g.iter().filter(|c| **c == Cell3::Occupied).count(), 1);
    // A 0.2 m map: one pixel covers 2 x 2 grid cells.
    let coarse = map_of("image: m.pgm\nresolution: 0.2\norigin: [0, 0, 0]\n", &pgm(1, 1, &[0])).unwrap();
    let g = coarse.to_grid(10.0, 4, [0.0, 0.0]).unwrap();
    assert_eq!(g.iter().filter(|c| **c == Cell3::Occupied).count(), 4);
}

#[test]
fn a_rotated_origin_turns_the_image_about_its_lower_left_corner() {
    // 3 x 1 cells of 0.1 m, the first occupied, yaw 90°: the row runs up the y axis from
    // (1, 2), so the occupied cell's centre is at (1 - 0.05, 2.05) and the last cell's at
    // (0.95, 2.25).
    let m = map_of("image: m.pgm\nresolution: 0.1\norigin: [1.0, 2.0, 1.5707963267948966]\n", &pgm(3, 1, &[0, 254, 254])).unwrap();
    assert_eq!(m.at([0.95, 2.05]), Some(Cell3::Occupied));
    assert_eq!(m.at([0.95, 2.25]), Some(Cell3::Free));
    assert_eq!(m.at([1.05, 2.05]), None, "east of the origin is outside the turned map");
    assert_eq!(m.cell_at([0.95, 2.15]), Some((1, 0)));
    let w = m.world(m.local([0.3, -0.7]));
    assert!((w[0] - 0.3).abs() < 1e-12 && (w[1] + 0.7).abs() < 1e-12);
    let b = m.known_bounds().unwrap();
    assert!(
        (b[0][0] - 0.9).abs() < 1e-9 && (b[1][0] - 1.0).abs() < 1e-9 && (b[0][1] - 2.0).abs() < 1e-9 && (b[1][1] - 2.3).abs() < 1e-9,
        "{b:?}"
    );
    // On a grid of 0.1 m from (0.5, 1.5): the occupied cell is grid cell (4, 5), the free ones
    // (4, 6) and (4, 7), nothing else.
    let g = m.to_grid(10.0, 8, [0.5, 1.5]).unwrap();
    let at = |x: usize, y: usize| g[y * 8 + x];
    assert_eq!((at(4, 5), at(4, 6), at(4, 7)), (Cell3::Occupied, Cell3::Free, Cell3::Free));
    assert_eq!(g.iter().filter(|c| **c != Cell3::Unknown).count(), 3);
    // At 30°, a 0.05 m map's wall lands in the grid cells its centres fall in.
    let m = map_of("image: m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.5235987755982988]\n", &pgm(20, 1, &[0; 20])).unwrap();
    let g = m.to_grid(10.0, 16, [-0.4, -0.4]).unwrap();
    for i in 0..20 {
        let p = m.world([(i as f64 + 0.5) * 0.05, 0.025]);
        let (x, y) = (((p[0] + 0.4) * 10.0).floor() as usize, ((p[1] + 0.4) * 10.0).floor() as usize);
        assert_eq!(g[y * 16 + x], Cell3::Occupied, "map cell {i} at {p:?}");
    }
}

#[test]
fn a_map_larger_than_the_grid_is_an_error() {
    // 600 free cells at 0.1 m: 60 m, more than the 51.2 m grid.
    let m = map_of("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", &pgm(600, 1, &[254; 600])).unwrap();
    let e = m.to_controller_grid(m.centred_grid_origin()).unwrap_err().to_string();
    assert!(e.starts_with("m.yaml: the map is larger than the controller's grid"), "{e}");
    assert!(e.contains("60.0 x 0.1 m"), "{e}");
    // Unknown cells beyond the grid do not matter.
    let mut px = vec![205u8; 600];
    px[10] = 254;
    let m = map_of("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", &pgm(600, 1, &px)).unwrap();
    assert!(m.to_controller_grid(m.centred_grid_origin()).is_ok());
    assert!(m.to_grid(f64::NAN, 8, [0.0, 0.0]).is_err());
}

#[test]
fn random_bytes_as_yaml_and_as_image_never_panic() {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let good = meta(GOOD).unwrap();
    for k in 0..3000 {
        let len = (next() % 64) as usize;
        let mut bytes: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        // Half of them start like the real thing.
        if k % 2 == 0 {
            let head: &[u8] = [&b"P5\n"[..], b"P2\n", b"image: m.pgm\nresolution: ", b"\x89PNG\r\n\x1a\n"][k / 2 % 4];
            bytes.splice(0..0, head.iter().copied());
        }
        let _ = MapMeta::parse(&String::from_utf8_lossy(&bytes), "m.yaml");
        if let Ok(m) = PriorMap::from_meta(good.clone(), &bytes, "m.yaml", "m.pgm") {
            let _ = m.to_grid(10.0, 16, [-1.0, 2.0]);
        }
    }
}
