use super::load::line_of;
use super::*;
use std::path::Path;

/// A small world using every kind of table and shape; the errors below are made by editing it.
const TINY: &str = include_str!("tiny.toml");

fn err(text: &str) -> WorldError {
    World::from_toml_str(text, "bad.toml").expect_err("should fail")
}

/// Replace the first occurrence of `from` in TINY by `to`.
fn tiny_with(from: &str, to: &str) -> String {
    assert!(TINY.contains(from), "{from}");
    TINY.replacen(from, to, 1)
}

fn line_of_str(text: &str, needle: &str) -> usize {
    line_of(text, text.find(needle).expect("needle"))
}

#[test]
fn tiny_world_loads() {
    let w = World::from_toml_str(TINY, "tiny.toml").unwrap();
    assert_eq!(w.name, "tiny");
    assert_eq!(w.walls.len(), 4);
    assert_eq!(w.obstacles.len(), 3);
    assert_eq!(w.obstacles[0].kind, HitKind::Furniture);
    assert_eq!(w.obstacles[0].label, "table");
    assert_eq!(w.targets[0].positions(), vec![[2.5, 1.0], [1.0, 3.0]]);
    assert_eq!(w.people[0].radius_m, DEFAULT_PERSON_RADIUS_M);
    assert!((w.start.pose[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert_eq!(w.bounds, [[0.0, 0.0], [6.0, 4.0]]);
}

#[test]
fn round_trips_through_toml() {
    let w = World::from_toml_str(TINY, "tiny.toml").unwrap();
    let text = w.to_toml_string();
    let back = World::from_toml_str(&text, "again.toml").unwrap();
    assert_eq!(w, back, "{text}");
}

#[test]
fn syntax_error_names_file_and_line() {
    let text = tiny_with("closed = true", "closed = = true");
    let e = err(&text);
    assert!(matches!(e, WorldError::Syntax { .. }), "{e}");
    let line = line_of_str(&text, "closed = = true");
    assert!(e.to_string().starts_with(&format!("bad.toml:{line}: ")), "{e}");
}

#[test]
fn negative_size_names_line_and_values() {
    let text = tiny_with("size = [1.2, 0.8]", "size = [-1.0, 2.0]");
    let e = err(&text);
    let line = line_of_str(&text, "size = [-1.0, 2.0]");
    assert!(matches!(e, WorldError::Invalid { .. }));
    assert_eq!(e.to_string(), format!("bad.toml:{line}: rectangle size must be positive, got [-1.0, 2.0]"));
}

#[test]
fn nan_is_rejected() {
    let text = tiny_with("radius = 0.2", "radius = nan");
    let e = err(&text);
    let line = line_of_str(&text, "radius = nan");
    assert_eq!(e.to_string(), format!("bad.toml:{line}: circle radius must be positive, got NaN"));
    let text = tiny_with("center = [4.0, 2.0]", "center = [inf, 2.0]");
    let e = err(&text);
    assert!(e.to_string().contains("must be finite"), "{e}");
    assert_eq!(e.line(), Some(line_of_str(&text, "center = [inf")));
}

#[test]
fn unknown_key_is_a_schema_error() {
    let text = tiny_with("label = \"table\"", "colour = \"red\"");
    let e = err(&text);
    assert!(matches!(e, WorldError::Schema { .. }), "{e}");
    assert!(e.to_string().contains("unknown field `colour`"), "{e}");
    assert_eq!(e.line(), Some(line_of_str(&text, "colour")), "{e}");
}

#[test]
fn polygon_with_two_points() {
    let text = tiny_with("[[5.0, 0.5], [5.5, 0.5], [5.2, 1.0]]", "[[5.0, 0.5], [5.5, 0.5]]");
    let e = err(&text);
    let line = line_of_str(&text, "polygon = ");
    assert_eq!(e.to_string(), format!("bad.toml:{line}: a polygon needs at least 3 points, got 2"));
}

#[test]
fn other_semantic_errors() {
    let cases: &[(&str, &str, &str)] = &[
        ("time_limit_s = 60", "time_limit_s = 0", "time limit must be a positive"),
        ("time_limit_s = 60", "time_limit_s = -inf", "time limit must be a positive"),
        ("time_limit_s = 60", "time_limit_s = 1e308", "up to 3600"),
        ("position = [1.0, 1.0]", "position = [1.0, 1.0, 7.0]", "expected two numbers [x, y], found 3"),
        ("center = [2.5, 1.0]", "center = [2.5]", "expected two numbers [x, y], found 1"),
        ("points = [[0, 0], [6, 0], [6, 4], [0, 4]]", "points = [[0, 0], [6, 0, 1], [6, 4]]", "found 3"),
        (
            "path = [[1.0, 2.2], [5.0, 3.5]]",
            "path = [[1.0, 2.2], [5.0, 3.5, \"junk\"]]",
            "`path` (in [[people]]) must be a number, found the string \"junk\"",
        ),
        ("points = [[0, 0], [6, 0], [6, 4], [0, 4]]", "points = []", "at least 2 points, got 0"),
        ("points = [[0, 0], [6, 0], [6, 4], [0, 4]]", "points = [[0, 0], [0, 0], [6, 4]]", "zero length"),
        ("points = [[0, 0], [6, 0], [6, 4], [0, 4]]", "points = [[0, 0], [60, 0], [6, 4]]", "outside the world area"),
        (
            "circle = { center = [2.0, 3.0], radius = 0.2 }",
            "circle = { center = [2.0, 3.0], radius = 0.2 }\nrect = { center = [1, 1], size = [1, 1] }",
            "exactly one shape",
        ),
        ("center = [2.5, 1.0]", "center = [4.0, 2.0]", "overlaps obstacle 0 (table)"),
        ("position = [1.0, 1.0]", "position = [0.1, 1.0]", "start position"),
        ("yaw_deg = 90", "yaw_deg = 90\nyaw_rad = 1.0", "not both"),
        ("speed_mps = 0.5", "speed_mps = -1", "speed_mps must be"),
        ("path = [[1.0, 2.2], [5.0, 3.5]]", "path = [[1.0, 2.2], [4.0, 2.0]]", "person path passes through obstacle 0"),
        ("kind = \"clutter\"", "kind = \"lamp\"", "unknown variant `lamp`"),
    ];
    for (from, to, expect) in cases {
        let text = tiny_with(from, to);
        let e = err(&text);
        let s = e.to_string();
        assert!(s.starts_with("bad.toml:"), "{s}");
        assert!(s.contains(expect), "{to}: {s}");
        assert!(e.line().unwrap() >= 1);
    }
}

#[test]
fn missing_start_and_no_targets() {
    let start = TINY.find("[start]").unwrap();
    let walls = TINY.find("[[walls]]").unwrap();
    let text = format!("{}{}", &TINY[..start], &TINY[walls..]);
    let e = err(&text);
    assert!(e.to_string().contains("missing field `start`"), "{e}");
    let t = TINY.find("[[targets]]").unwrap();
    let p = TINY.find("[[people]]").unwrap();
    let text = format!("{}{}", &TINY[..t], &TINY[p..]);
    assert!(err(&text).to_string().contains("no [[targets]]"));
}

#[test]
fn an_oversized_file_is_refused_unread() {
    let dir = std::env::temp_dir().join(format!("lives-world-size-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let big = dir.join("big.toml");
    // A valid file padded with a comment past the limit.
    let mut text = TINY.to_string();
    text.push('#');
    text.push_str(&"x".repeat(MAX_WORLD_FILE_BYTES as usize));
    std::fs::write(&big, &text).unwrap();
    let e = World::load(&big).unwrap_err();
    assert!(e.to_string().contains("larger than a world file may be"), "{e}");
    std::fs::write(&big, &text[..TINY.len()]).unwrap();
    assert!(World::load(&big).is_ok());
    std::fs::write(&big, b"name = \"\xff\"").unwrap();
    assert!(World::load(&big).unwrap_err().to_string().contains("not UTF-8 text (byte 8)"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 29: world-file errors quoted serde's internal names ("invalid type: floating point
/// `50.99999`, expected struct RawRect", "invalid length 0, expected struct RawRect with 4
/// elements", "... as i128, expected any valid TOML value"). Every key of the tiny world given
/// each wrong kind of value: the message names the key (or its table) and the line, in the
/// format's words.
#[test]
fn schema_errors_speak_the_format_not_the_code() {
    let cases: &[(&str, &str, &str)] = &[
        ("rect = { center = [4.0, 2.0], size = [1.2, 0.8], yaw_deg = 10 }", "rect = 50.99999", "`rect` (in [[obstacles]]) must be a rectangle: an inline table `{ center = [x, y], size = [width, height] }`, optionally with `yaw_deg` or `yaw_rad`, found the number 50.99999"),
        ("rect = { center = [4.0, 2.0], size = [1.2, 0.8], yaw_deg = 10 }", "rect = []", "`rect` (in [[obstacles]]) must be a rectangle: an inline table `{ center = [x, y], size = [width, height] }`, optionally with `yaw_deg` or `yaw_rad`, found an array of 0 elements"),
        ("time_limit_s = 60", "time_limit_s = 99999999999999999999", "`time_limit_s` holds the integer 99999999999999999999, beyond TOML's 64-bit integers"),
        ("circle = { center = [2.0, 3.0], radius = 0.2 }", "circle = \"round\"", "`circle` (in [[obstacles]]) must be a circle: an inline table `{ center = [x, y], radius = r }`, found the string \"round\""),
        ("speed_mps = 0.5", "speed_mps = \"fast\"", "`speed_mps` (in [[people]]) must be a number, found the string \"fast\""),
        ("closed = true", "closed = 1", "`closed` (in [[walls]]) must be a boolean, found the number 1"),
        ("points = [[0, 0], [6, 0], [6, 4], [0, 4]]", "points = 3", "`points` (in [[walls]]) must be an array, found the number 3"),
        ("kind = \"clutter\"", "kind = 3", "`kind` (in [[obstacles]]) must be `furniture` or `clutter`"),
        ("[start]", "[[start]]", "`[[start]]`: `start` is one table, written `[start]`, not an array of tables"),
        ("[[walls]]", "[walls]", "`[walls]`: `walls` is an array of tables, each written `[[walls]]`"),
        ("[[targets]]", "[targets]", "`[targets]`: `targets` is an array of tables, each written `[[targets]]`"),
        ("[[people]]", "[people]", "`[people]`: `people` is an array of tables, each written `[[people]]`"),
    ];
    for (from, to, expect) in cases {
        let text = tiny_with(from, to);
        let e = err(&text);
        let line = line_of_str(&text, to.lines().next().unwrap());
        assert!(e.to_string().starts_with(&format!("bad.toml:{line}: {expect}")), "{to}:\n  got  {e}\n  want bad.toml:{line}: {expect}");
    }
    // Every value of every key replaced by each kind of wrong value: no internal names.
    let wrong = ["50.99999", "[]", "[1, 2, 3, 4]", "\"x\"", "true", "{}", "{ a = 1 }", "99999999999999999999", "-1", "[[1, \"a\"]]"];
    let mut n = 0;
    for (i, line) in TINY.lines().enumerate() {
        let Some((key, _)) = line.split_once(" = ") else { continue };
        for w in wrong {
            let mut lines: Vec<String> = TINY.lines().map(String::from).collect();
            lines[i] = format!("{key} = {w}");
            let text = lines.join("\n");
            let Err(e) = World::from_toml_str(&text, "bad.toml") else { continue };
            let s = e.to_string();
            for internal in ["Raw", "struct ", "i128", "f64", "sequence", " map", "Xy"] {
                assert!(!s.contains(internal), "{key} = {w}: {s}");
            }
            assert!(s.starts_with("bad.toml:"), "{s}");
            n += 1;
        }
    }
    assert!(n > 100, "{n} errors checked");
}

#[test]
fn garbage_never_panics() {
    let inputs = [
        "",
        "\u{0}",
        "[[walls]]\npoints = 3",
        "time_limit_s = 1e400",
        "[start]\nposition = [1]",
        "time_limit_s = 5\n[start]\nposition = [1e308, -1e308]\n",
        "time_limit_s = 5\n[start]\nposition = [1, 1]\n[[targets]]\npolygon = [[1,1],[1,1],[1,1]]",
        "time_limit_s = 5\n[start]\nposition = [1, 1]\n[[targets]]\ncircle = {center=[3,3], radius=1e300}",
        "time_limit_s = 5\n[start]\nposition = [1, 1]\n[[people]]\npath = []\nspeed_mps = 1",
    ];
    for text in inputs {
        let _ = World::from_toml_str(text, "x.toml");
    }
    // Every prefix of a valid file.
    for end in (0..TINY.len()).filter(|&i| TINY.is_char_boundary(i)) {
        let _ = World::from_toml_str(&TINY[..end], "x.toml");
    }
}

#[test]
fn io_error_names_file() {
    let e = World::load(Path::new("/nonexistent/w.toml")).unwrap_err();
    assert!(matches!(e, WorldError::Io { .. }));
    assert!(e.to_string().starts_with("/nonexistent/w.toml: cannot read"), "{e}");
}

#[test]
fn a_device_or_a_pipe_is_refused_before_it_is_opened() {
    let e = World::load(std::path::Path::new("/dev/zero")).unwrap_err().to_string();
    assert!(e.starts_with("/dev/zero: ") && e.contains("not a regular file"), "{e}");
}
