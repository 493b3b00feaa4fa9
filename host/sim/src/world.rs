//! [`World`]: a floor plan with furniture, clutter, targets, people and a start, and its TOML
//! file format (documented with an example in `docs/world-format.md`).
//!
//! Loading is three passes, each with its own [`WorldError`] variant: TOML syntax, the schema
//! (unknown keys, wrong types, missing fields; `deny_unknown_fields` everywhere) and the meaning
//! (finite numbers, positive sizes, at least 3 polygon points, targets clear of furniture, a clear
//! start, everything within the 51 m × 51 m area the controller's grid covers). Every error names
//! the file and the 1-based line of the offending element. Loading never panics.

use std::fmt;
use std::ops::Range;
use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::geometry::{dist, polygon_area};
use super::{HitKind, Material, Scenario, Shape, P2};

/// Every coordinate of a world must lie in `[0, WORLD_LIMIT_M]` in x and y (the controller's
/// occupancy grid is 51.2 m square, anchored at the origin).
pub const WORLD_LIMIT_M: f64 = 51.0;

/// The longest time limit a world may set: an hour (the paper's longest is 300 s). A search
/// runs until it, so this bounds every run of a world file.
pub const MAX_TIME_LIMIT_S: f64 = 3600.0;

/// The largest world file [`World::load`] reads: 1 MiB, about 20 000 walls (a built-in world is
/// about 10 kB). Parsing holds the whole document in memory at several times its size.
pub const MAX_WORLD_FILE_BYTES: u64 = 1 << 20;

/// The start must be this far from everything, plus `jitter_m · √2` (the default robot radius).
pub const START_CLEARANCE_M: f64 = 0.3;

/// Default radius of a person when `radius_m` is not given.
pub const DEFAULT_PERSON_RADIUS_M: f64 = 0.25;

/// A furniture or clutter object: a non-map obstacle the LiDAR sees and the robot must avoid.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    pub shape: Shape,
    /// [`HitKind::Furniture`] or [`HitKind::Clutter`].
    pub kind: HitKind,
    /// Free text for people reading the file or a plot ("bed", "box"); may be empty.
    pub label: String,
    /// What its outline is made of, for the LiDAR.
    pub material: Material,
}

/// An object to be found. The simulator places it at one of [`Target::positions`], picked by
/// the seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    pub name: String,
    /// The shape at its default position.
    pub shape: Shape,
    /// Alternative positions for the shape's centre (in addition to the default).
    pub candidates: Vec<P2>,
}

impl Target {
    /// The default centre followed by the alternatives: the seed picks one of these.
    pub fn positions(&self) -> Vec<P2> {
        let mut v = vec![self.shape.center()];
        v.extend(self.candidates.iter().copied());
        v
    }

    /// The shape moved to centre `p`.
    pub fn shape_at(&self, p: P2) -> Shape {
        self.shape.moved_to(p)
    }
}

/// A person walking a closed loop at constant speed (they wait while the robot is in the way).
#[derive(Clone, Debug, PartialEq)]
pub struct Person {
    /// The loop's corners; the last point connects back to the first. One point: standing still.
    pub path: Vec<P2>,
    pub speed_mps: f64,
    pub radius_m: f64,
}

/// Where the robot starts: `pose = [x, y, yaw]` (metres, radians) plus a uniform jitter
/// (`±jitter_m` in x and y, `±jitter_yaw_rad` in yaw) drawn from the seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Start {
    pub pose: [f64; 3],
    pub jitter_m: f64,
    pub jitter_yaw_rad: f64,
}

/// A building: the ground truth the simulator runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct World {
    pub name: String,
    /// Wall segments (the file's polylines expanded).
    pub walls: Vec<[P2; 2]>,
    /// The material of each wall segment, in the order of `walls` (a segment past its end is
    /// [`Material::Default`]; see [`World::wall_material`]).
    pub wall_materials: Vec<Material>,
    pub obstacles: Vec<Obstacle>,
    pub targets: Vec<Target>,
    pub people: Vec<Person>,
    pub start: Start,
    /// The search fails when this much simulated time has passed.
    pub time_limit_s: f64,
    /// Axis-aligned `[min, max]` of everything (walls, obstacles, every target position, people,
    /// start).
    pub bounds: [P2; 2],
}

/// Why a world file could not be loaded. `Display` is `FILE:LINE: problem` (`FILE: problem` for
/// I/O errors); lines are 1-based.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum WorldError {
    /// The file could not be read.
    Io { file: String, message: String },
    /// The text is not valid TOML.
    Syntax { file: String, line: usize, message: String },
    /// Valid TOML, but an unknown key, a missing key or a value of the wrong type.
    Schema { file: String, line: usize, message: String },
    /// Well-formed, but the values make no sense (NaN, negative size, overlapping target, ...).
    Invalid { file: String, line: usize, message: String },
}

impl WorldError {
    /// The file name given to the loader.
    pub fn file(&self) -> &str {
        match self {
            WorldError::Io { file, .. }
            | WorldError::Syntax { file, .. }
            | WorldError::Schema { file, .. }
            | WorldError::Invalid { file, .. } => file,
        }
    }

    /// The 1-based line, if the error has one.
    pub fn line(&self) -> Option<usize> {
        match self {
            WorldError::Io { .. } => None,
            WorldError::Syntax { line, .. } | WorldError::Schema { line, .. } | WorldError::Invalid { line, .. } => Some(*line),
        }
    }

    /// The problem, without file and line.
    pub fn message(&self) -> &str {
        match self {
            WorldError::Io { message, .. }
            | WorldError::Syntax { message, .. }
            | WorldError::Schema { message, .. }
            | WorldError::Invalid { message, .. } => message,
        }
    }
}

impl fmt::Display for WorldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line() {
            Some(line) => write!(f, "{}:{}: {}", self.file(), line, self.message()),
            None => write!(f, "{}: {}", self.file(), self.message()),
        }
    }
}

impl std::error::Error for WorldError {}

// ---------------------------------------------------------------------------------------------
// The file format as serde sees it.

/// A point or a size, `[x, y]`: exactly two numbers (serde's `[f64; 2]` would ignore extra
/// elements of a TOML array).
#[derive(Clone, Copy)]
struct Xy([f64; 2]);

impl<'de> Deserialize<'de> for Xy {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        match v[..] {
            [x, y] => Ok(Xy([x, y])),
            _ => Err(serde::de::Error::custom(format!("expected two numbers [x, y], found {}", v.len()))),
        }
    }
}

impl std::ops::Deref for Xy {
    type Target = [f64; 2];
    fn deref(&self) -> &[f64; 2] {
        &self.0
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    name: Option<String>,
    time_limit_s: Spanned<f64>,
    start: Spanned<RawStart>,
    #[serde(default)]
    walls: Vec<Spanned<RawWall>>,
    #[serde(default)]
    obstacles: Vec<Spanned<RawObstacle>>,
    #[serde(default)]
    targets: Vec<Spanned<RawTarget>>,
    #[serde(default)]
    people: Vec<Spanned<RawPerson>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStart {
    position: Xy,
    yaw_rad: Option<f64>,
    yaw_deg: Option<f64>,
    jitter_m: Option<f64>,
    jitter_yaw_rad: Option<f64>,
    jitter_yaw_deg: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWall {
    points: Vec<Xy>,
    #[serde(default)]
    closed: bool,
    material: Option<Spanned<String>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawKind {
    Furniture,
    Clutter,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRect {
    center: Xy,
    size: Xy,
    yaw_rad: Option<f64>,
    yaw_deg: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCircle {
    center: Xy,
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObstacle {
    kind: RawKind,
    label: Option<String>,
    material: Option<Spanned<String>>,
    rect: Option<Spanned<RawRect>>,
    circle: Option<Spanned<RawCircle>>,
    polygon: Option<Spanned<Vec<Xy>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTarget {
    name: Option<String>,
    rect: Option<Spanned<RawRect>>,
    circle: Option<Spanned<RawCircle>>,
    polygon: Option<Spanned<Vec<Xy>>>,
    candidates: Option<Spanned<Vec<Xy>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPerson {
    path: Vec<Xy>,
    speed_mps: f64,
    radius_m: Option<f64>,
}

// ---------------------------------------------------------------------------------------------
// Loading.

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// A toml message on one line.
fn one_line(message: &str) -> String {
    message.split('\n').map(str::trim).filter(|s| !s.is_empty()).collect::<Vec<_>>().join("; ")
}

/// What a value must hold, in the world format's words, for what serde calls it (`struct
/// RawRect`, `f64`, `a sequence`, ...).
fn expected_in_format_words(expected: &str) -> String {
    let e = expected.trim();
    // `struct RawRect with 4 elements`: serde's wording when an array stands for a table.
    let e = e.split(" with ").next().unwrap_or(e);
    let words = match e {
        "struct RawRect" => "a rectangle: an inline table `{ center = [x, y], size = [width, height] }`, optionally with `yaw_deg` or `yaw_rad`",
        "struct RawCircle" => "a circle: an inline table `{ center = [x, y], radius = r }`",
        "struct RawStart" => "a table `[start]` with `position = [x, y]`, optionally `yaw_deg` or `yaw_rad`, `jitter_m`, `jitter_yaw_deg` or `jitter_yaw_rad`",
        "struct RawWall" => "a table `[[walls]]` with `points = [[x, y], ...]`, optionally `closed = true` and `material`",
        "struct RawObstacle" => "a table `[[obstacles]]` with `kind` and one shape: `rect`, `circle` or `polygon`",
        "struct RawTarget" => "a table `[[targets]]` with one shape (`rect`, `circle` or `polygon`), optionally `name` and `candidates`",
        "struct RawPerson" => "a table `[[people]]` with `path = [[x, y], ...]` and `speed_mps`, optionally `radius_m`",
        "struct RawWorld" => "a world file: `time_limit_s`, `[start]`, `[[walls]]`, `[[obstacles]]`, `[[targets]]`, `[[people]]`",
        "enum RawKind" => "`furniture` or `clutter`",
        "f64" | "f32" | "a float" => "a number",
        "i64" | "u64" | "usize" | "u32" | "i32" | "an integer" => "a whole number",
        "a sequence" | "a seq" => "an array",
        "a map" => "a table",
        "any valid TOML value" => "a TOML value",
        other => return other.to_string(),
    };
    words.to_string()
}

/// What serde says was found (`floating point `50.9``, `integer `3``, `sequence`, `map`), in
/// the format's words.
fn found_in_format_words(found: &str) -> String {
    let f = found.trim();
    let quoted = |prefix: &str| f.strip_prefix(prefix).map(|v| v.trim().trim_matches('`').to_string());
    if let Some(v) = quoted("floating point").or_else(|| quoted("integer")) {
        return format!("the number {v}");
    }
    if let Some(v) = quoted("boolean") {
        return format!("the boolean {v}");
    }
    if let Some(v) = f.strip_prefix("string ") {
        return format!("the string {v}");
    }
    match f {
        "sequence" => "an array".to_string(),
        "map" => "a table".to_string(),
        other => other.to_string(),
    }
}

/// The key whose value starts at byte `at` of `text` (the last `key =` before it on its line, or
/// the table header it is in), and the table it is in (`[[obstacles]]`), if any.
fn key_at(text: &str, at: usize) -> (Option<String>, Option<String>) {
    let (at, line_start) = line_at(text, at);
    let before = &text[line_start..at];
    let key_char = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    let key = before.rfind('=').and_then(|eq| {
        let k: String = before[..eq].trim_end().chars().rev().take_while(|&c| key_char(c)).collect::<Vec<_>>().into_iter().rev().collect();
        (!k.is_empty()).then_some(k)
    });
    let table = text[..line_start]
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('['))
        .map(|l| l.split('#').next().unwrap_or(l).trim().to_string());
    // A value that starts a line is a table header's (`[[walls]]` given as something else).
    let header = text[line_start..].lines().next().map(str::trim).filter(|l| l.starts_with('[') && key.is_none());
    match header {
        Some(h) => (Some(h.trim_matches(|c| c == '[' || c == ']').to_string()), None),
        None => (key, table),
    }
}

/// Byte `at` of `text` moved back to a character boundary, and the start of its line.
fn line_at(text: &str, at: usize) -> (usize, usize) {
    let at = (0..=at.min(text.len())).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
    (at, text[..at].rfind('\n').map(|i| i + 1).unwrap_or(0))
}

/// A toml or serde message (`invalid type: floating point `50.9`, expected struct RawRect`,
/// `invalid length 0, expected struct RawRect with 4 elements`, `invalid value: integer `…` as
/// i128, expected any valid TOML value`) in the world format's words: which key, what it must
/// hold, what it holds. Messages that already speak the format's words pass unchanged.
fn in_format_words(message: &str, text: &str, at: usize) -> String {
    // A table header with the wrong number of brackets: serde reads `[[start]]`'s array as the
    // fields of `[start]` in order and complains about the first field, backwards ("must be an
    // array, found a table"); say what the header should be.
    let (_, line_start) = line_at(text, at);
    let line = text[line_start..].lines().next().unwrap_or("").split('#').next().unwrap_or("").trim();
    const ONE_TABLE: [&str; 1] = ["start"];
    const ARRAYS_OF_TABLES: [&str; 4] = ["walls", "obstacles", "targets", "people"];
    if let Some(name) = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")).map(str::trim) {
        if ONE_TABLE.contains(&name) {
            return format!("`[[{name}]]`: `{name}` is one table, written `[{name}]`, not an array of tables");
        }
    } else if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')).map(str::trim) {
        if ARRAYS_OF_TABLES.contains(&name) {
            return format!("`[{name}]`: `{name}` is an array of tables, each written `[[{name}]]`");
        }
    }
    let (key, table) = key_at(text, at);
    let whose = match (&key, &table) {
        (Some(k), Some(t)) => format!("`{k}` (in {t})"),
        (Some(k), None) => format!("`{k}`"),
        (None, Some(t)) => format!("this value (in {t})"),
        (None, None) => "this value".to_string(),
    };
    let (head, expected) = match message.split_once(", expected ") {
        Some((h, e)) => (h, Some(e)),
        None => (message, None),
    };
    // An integer beyond i64, which toml hands to serde as an i128.
    if let Some(v) = head.strip_suffix("as i128").and_then(|h| h.split('`').nth(1)) {
        return format!(
            "{whose} holds the integer {v}, beyond TOML's 64-bit integers (−9223372036854775808 to 9223372036854775807); write a float (1e20) for a large number"
        );
    }
    if let (Some(found), Some(exp)) = (head.strip_prefix("invalid type:"), expected) {
        return format!("{whose} must be {}, found {}", expected_in_format_words(exp), found_in_format_words(found));
    }
    if let (Some(n), Some(exp)) = (head.strip_prefix("invalid length "), expected) {
        let exp_words = expected_in_format_words(exp);
        let n = n.trim();
        return match exp.contains(" with ") || exp.starts_with("struct ") {
            true => format!("{whose} must be {exp_words}, found an array of {n} elements"),
            false => format!("{whose} must be {exp_words}, found {n} elements"),
        };
    }
    if let (Some(v), Some(exp)) = (head.strip_prefix("invalid value:"), expected) {
        return format!("{whose} must be {}, found {}", expected_in_format_words(exp), found_in_format_words(v));
    }
    // An enum given a number or an array: toml's own words.
    if message.contains("wanted string or table") && key.as_deref() == Some("kind") {
        return format!("{whose} must be `furniture` or `clutter`");
    }
    // `missing field`, `unknown field`, `unknown variant`, `expected two numbers [x, y]`, ...:
    // serde's own words are the format's; the internal names go.
    let mut out = message.to_string();
    for (from, to) in [
        ("struct RawWorld", "the world file"),
        ("struct RawStart", "[start]"),
        ("struct RawWall", "[[walls]]"),
        ("struct RawObstacle", "[[obstacles]]"),
        ("struct RawTarget", "[[targets]]"),
        ("struct RawPerson", "[[people]]"),
        ("struct RawRect", "a rect"),
        ("struct RawCircle", "a circle"),
    ] {
        out = out.replace(from, to);
    }
    match key {
        Some(k) if !out.contains(&format!("`{k}`")) && !out.starts_with("missing field") && !out.starts_with("unknown field") => {
            format!("{whose}: {out}")
        }
        _ => out,
    }
}

struct Ctx<'a> {
    text: &'a str,
    file: &'a str,
}

impl Ctx<'_> {
    /// A `material = "…"` key: one of [`Material::ALL`]'s names, [`Material::Default`] if absent.
    fn material(&self, m: Option<Spanned<String>>) -> Result<Material, WorldError> {
        let Some(m) = m else { return Ok(Material::Default) };
        Material::from_name(m.get_ref()).ok_or_else(|| {
            let names: Vec<String> = Material::ALL.iter().map(|m| format!("`{}`", m.as_str())).collect();
            self.invalid(&m.span(), format!("unknown material {:?} in `material`, expected one of {}", m.get_ref(), names.join(", ")))
        })
    }

    fn invalid(&self, span: &Range<usize>, message: String) -> WorldError {
        WorldError::Invalid { file: self.file.to_string(), line: line_of(self.text, span.start), message }
    }

    fn finite_point(&self, span: &Range<usize>, what: &str, p: P2) -> Result<P2, WorldError> {
        if p[0].is_finite() && p[1].is_finite() {
            Ok(p)
        } else {
            Err(self.invalid(span, format!("{what} must be finite, got {p:?}")))
        }
    }

    fn in_area(&self, span: &Range<usize>, what: &str, p: P2) -> Result<(), WorldError> {
        let ok = |v: f64| (0.0..=WORLD_LIMIT_M).contains(&v);
        if ok(p[0]) && ok(p[1]) {
            Ok(())
        } else {
            Err(self.invalid(
                span,
                format!(
                    "{what} {p:?} is outside the world area: every coordinate must lie within \
                     [0, {WORLD_LIMIT_M}] m in x and y (worlds are at most {WORLD_LIMIT_M} m wide)"
                ),
            ))
        }
    }

    /// One of `rad` / `deg` (or neither: `default`).
    fn angle(&self, span: &Range<usize>, what: &str, rad: Option<f64>, deg: Option<f64>) -> Result<f64, WorldError> {
        let a = match (rad, deg) {
            (Some(_), Some(_)) => {
                return Err(
                    self.invalid(span, format!("give {what} either in radians (`{what}_rad`) or in degrees (`{what}_deg`), not both"))
                )
            }
            (Some(r), None) => r,
            (None, Some(d)) => d.to_radians(),
            (None, None) => 0.0,
        };
        if a.is_finite() {
            Ok(a)
        } else {
            Err(self.invalid(span, format!("{what} must be finite, got {a:?}")))
        }
    }

    fn shape(
        &self,
        owner_span: &Range<usize>,
        rect: Option<Spanned<RawRect>>,
        circle: Option<Spanned<RawCircle>>,
        polygon: Option<Spanned<Vec<Xy>>>,
    ) -> Result<Shape, WorldError> {
        let count = rect.is_some() as u8 + circle.is_some() as u8 + polygon.is_some() as u8;
        if count != 1 {
            return Err(self.invalid(owner_span, format!("give exactly one shape (`rect`, `circle` or `polygon`), got {count}")));
        }
        if let Some(r) = rect {
            let span = r.span();
            let r = r.into_inner();
            let center = self.finite_point(&span, "rectangle center", *r.center)?;
            if !(r.size[0] > 0.0 && r.size[1] > 0.0 && r.size[0].is_finite() && r.size[1].is_finite()) {
                return Err(self.invalid(&span, format!("rectangle size must be positive, got {:?}", *r.size)));
            }
            let yaw = self.angle(&span, "yaw", r.yaw_rad, r.yaw_deg)?;
            return Ok(Shape::Rect { center, size: *r.size, yaw });
        }
        if let Some(c) = circle {
            let span = c.span();
            let c = c.into_inner();
            let center = self.finite_point(&span, "circle center", *c.center)?;
            if !(c.radius > 0.0 && c.radius.is_finite()) {
                return Err(self.invalid(&span, format!("circle radius must be positive, got {:?}", c.radius)));
            }
            return Ok(Shape::Circle { center, radius: c.radius });
        }
        let p = polygon.expect("exactly one shape");
        let span = p.span();
        let points: Vec<P2> = p.into_inner().into_iter().map(|q| q.0).collect();
        if points.len() < 3 {
            return Err(self.invalid(&span, format!("a polygon needs at least 3 points, got {}", points.len())));
        }
        for q in &points {
            self.finite_point(&span, "polygon point", *q)?;
        }
        if polygon_area(&points).abs() < 1e-9 {
            return Err(self.invalid(&span, "polygon has zero area".to_string()));
        }
        Ok(Shape::Polygon { points })
    }

    fn shape_in_area(&self, span: &Range<usize>, what: &str, shape: &Shape) -> Result<(), WorldError> {
        let bb = shape.aabb();
        self.in_area(span, what, bb[0])?;
        self.in_area(span, what, bb[1])
    }
}

impl World {
    /// Parse a world from TOML text. `file_name` is used in error messages and as the default
    /// name.
    pub fn from_toml_str(text: &str, file_name: &str) -> Result<World, WorldError> {
        let ctx = Ctx { text, file: file_name };
        // Pass 1: syntax.
        if let Err(e) = text.parse::<toml::Table>() {
            let at = e.span().map(|s| s.start).unwrap_or(0);
            return Err(WorldError::Syntax {
                file: file_name.to_string(),
                line: line_of(text, at),
                message: in_format_words(&one_line(e.message()), text, at),
            });
        }
        // Pass 2: schema.
        let raw: RawWorld = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| s.start).unwrap_or(0);
            WorldError::Schema {
                file: file_name.to_string(),
                line: line_of(text, at),
                message: in_format_words(&one_line(e.message()), text, at),
            }
        })?;
        // Pass 3: meaning.
        let name = raw.name.map(|n| n.trim().to_string()).filter(|n| !n.is_empty()).unwrap_or_else(|| {
            Path::new(file_name).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| file_name.to_string())
        });

        let tl_span = raw.time_limit_s.span();
        let time_limit_s = *raw.time_limit_s.get_ref();
        if !(time_limit_s > 0.0 && time_limit_s <= MAX_TIME_LIMIT_S) {
            return Err(ctx.invalid(
                &tl_span,
                format!("time limit must be a positive number of seconds up to {MAX_TIME_LIMIT_S}, got {time_limit_s:?}"),
            ));
        }

        let start_span = raw.start.span();
        let rs = raw.start.into_inner();
        let position = ctx.finite_point(&start_span, "start position", *rs.position)?;
        ctx.in_area(&start_span, "start position", position)?;
        let yaw = ctx.angle(&start_span, "yaw", rs.yaw_rad, rs.yaw_deg)?;
        let jitter_m = rs.jitter_m.unwrap_or(0.0);
        if !(jitter_m >= 0.0 && jitter_m.is_finite()) {
            return Err(ctx.invalid(&start_span, format!("jitter_m must be a non-negative number of metres, got {jitter_m:?}")));
        }
        let jitter_yaw_rad = ctx.angle(&start_span, "jitter_yaw", rs.jitter_yaw_rad, rs.jitter_yaw_deg)?;
        if jitter_yaw_rad < 0.0 {
            return Err(ctx.invalid(&start_span, format!("the yaw jitter must not be negative, got {jitter_yaw_rad:?} rad")));
        }
        let start = Start { pose: [position[0], position[1], yaw], jitter_m, jitter_yaw_rad };

        let mut walls: Vec<[P2; 2]> = Vec::new();
        let mut wall_materials = Vec::new();
        for w in raw.walls {
            let span = w.span();
            let w = w.into_inner();
            let material = ctx.material(w.material)?;
            let (points, closed): (Vec<P2>, bool) = (w.points.iter().map(|q| q.0).collect(), w.closed);
            if points.len() < 2 {
                return Err(ctx.invalid(&span, format!("a wall needs at least 2 points, got {}", points.len())));
            }
            if closed && points.len() < 3 {
                return Err(ctx.invalid(&span, format!("a closed wall needs at least 3 points, got {}", points.len())));
            }
            for p in &points {
                ctx.finite_point(&span, "wall point", *p)?;
                ctx.in_area(&span, "wall point", *p)?;
            }
            let n = points.len();
            let count = if closed { n } else { n - 1 };
            for i in 0..count {
                let (a, b) = (points[i], points[(i + 1) % n]);
                if dist(a, b) < 1e-9 {
                    return Err(ctx.invalid(&span, format!("wall segment from {a:?} to {b:?} has zero length")));
                }
                walls.push([a, b]);
                wall_materials.push(material);
            }
        }

        let mut obstacles = Vec::new();
        let mut obstacle_spans = Vec::new();
        for o in raw.obstacles {
            let span = o.span();
            let o = o.into_inner();
            let material = ctx.material(o.material)?;
            let shape = ctx.shape(&span, o.rect, o.circle, o.polygon)?;
            ctx.shape_in_area(&span, "obstacle corner", &shape)?;
            let kind = match o.kind {
                RawKind::Furniture => HitKind::Furniture,
                RawKind::Clutter => HitKind::Clutter,
            };
            obstacles.push(Obstacle { shape, kind, label: o.label.unwrap_or_default(), material });
            obstacle_spans.push(span);
        }

        let mut targets = Vec::new();
        let mut target_spans = Vec::new();
        for (i, t) in raw.targets.into_iter().enumerate() {
            let span = t.span();
            let t = t.into_inner();
            let shape = ctx.shape(&span, t.rect, t.circle, t.polygon)?;
            let mut candidates = Vec::new();
            if let Some(c) = t.candidates {
                let cspan = c.span();
                for p in c.into_inner() {
                    candidates.push(ctx.finite_point(&cspan, "target candidate", p.0)?);
                }
            }
            let target =
                Target { name: t.name.filter(|n| !n.trim().is_empty()).unwrap_or_else(|| format!("target {i}")), shape, candidates };
            for p in target.positions() {
                ctx.shape_in_area(&span, "target corner", &target.shape_at(p))?;
            }
            targets.push(target);
            target_spans.push(span);
        }
        if targets.is_empty() {
            return Err(ctx.invalid(&(0..0), "the world has no [[targets]]".to_string()));
        }

        let mut people = Vec::new();
        let mut people_spans = Vec::new();
        for p in raw.people {
            let span = p.span();
            let p = p.into_inner();
            if p.path.is_empty() {
                return Err(ctx.invalid(&span, "a person's path needs at least 1 point".to_string()));
            }
            for q in &p.path {
                ctx.finite_point(&span, "person path point", q.0)?;
            }
            if !(p.speed_mps >= 0.0 && p.speed_mps.is_finite()) {
                return Err(ctx.invalid(&span, format!("speed_mps must be a non-negative number, got {:?}", p.speed_mps)));
            }
            let radius_m = p.radius_m.unwrap_or(DEFAULT_PERSON_RADIUS_M);
            if !(radius_m > 0.0 && radius_m <= 2.0) {
                return Err(ctx.invalid(&span, format!("radius_m must be in (0, 2] m, got {radius_m:?}")));
            }
            for q in &p.path {
                ctx.in_area(&span, "person path point", [q[0] - radius_m, q[1] - radius_m])?;
                ctx.in_area(&span, "person path point", [q[0] + radius_m, q[1] + radius_m])?;
            }
            people.push(Person { path: p.path.iter().map(|q| q.0).collect(), speed_mps: p.speed_mps, radius_m });
            people_spans.push(span);
        }

        let mut world = World { name, walls, wall_materials, obstacles, targets, people, start, time_limit_s, bounds: [[0.0; 2]; 2] };
        world.bounds = world.compute_bounds();

        // Cross checks: targets clear of walls and obstacles; start clear; people clear.
        for (ti, t) in world.targets.iter().enumerate() {
            for p in t.positions() {
                let s = t.shape_at(p);
                if let Some(problem) = world.shape_clash(&s) {
                    return Err(ctx.invalid(&target_spans[ti], format!("target {:?} at {p:?} overlaps {problem}", t.name)));
                }
            }
        }
        let need = START_CLEARANCE_M + world.start.jitter_m * std::f64::consts::SQRT_2;
        let sp = [world.start.pose[0], world.start.pose[1]];
        if let Some(problem) = world.disc_clash(sp, need, true) {
            return Err(ctx.invalid(
                &start_span,
                format!(
                    "start position {sp:?} is within {need:.2} m (robot clearance {START_CLEARANCE_M} m \
                     + jitter) of {problem}"
                ),
            ));
        }
        for (pi, person) in world.people.iter().enumerate() {
            for q in person_path_samples(&person.path, 0.05) {
                if let Some(problem) = world.disc_clash(q, person.radius_m, true) {
                    return Err(ctx.invalid(&people_spans[pi], format!("person path passes through {problem} at {q:?}")));
                }
            }
        }
        Ok(world)
    }

    /// Read and parse a world file.
    pub fn load(path: &Path) -> Result<World, WorldError> {
        let file = path.display().to_string();
        let bytes = super::read_at_most(path, MAX_WORLD_FILE_BYTES)
            .map_err(|e| WorldError::Io { file: file.clone(), message: format!("cannot read: {e}") })?;
        let Some(bytes) = bytes else {
            return Err(WorldError::Io { file, message: format!("larger than a world file may be ({MAX_WORLD_FILE_BYTES} bytes)") });
        };
        let text = String::from_utf8(bytes).map_err(|e| WorldError::Io {
            file: file.clone(),
            message: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        })?;
        World::from_toml_str(&text, &file)
    }

    /// A built-in world: `"apartment"`, `"office"` or `"hallway"` (see [`super::builtin`]).
    pub fn builtin(name: &str, scenario: Scenario) -> Option<World> {
        super::builtin::load(name, scenario)
    }

    /// Names accepted by [`World::builtin`].
    pub fn builtin_names() -> &'static [&'static str] {
        super::builtin::NAMES
    }

    /// Axis-aligned bounds of everything in the world.
    pub fn compute_bounds(&self) -> [P2; 2] {
        let mut pts: Vec<P2> = Vec::new();
        for w in &self.walls {
            pts.extend_from_slice(w);
        }
        for o in &self.obstacles {
            pts.extend_from_slice(&o.shape.aabb());
        }
        for t in &self.targets {
            for p in t.positions() {
                pts.extend_from_slice(&t.shape_at(p).aabb());
            }
        }
        for p in &self.people {
            for q in &p.path {
                pts.push([q[0] - p.radius_m, q[1] - p.radius_m]);
                pts.push([q[0] + p.radius_m, q[1] + p.radius_m]);
            }
        }
        pts.push([self.start.pose[0], self.start.pose[1]]);
        let b = super::geometry::aabb_of(&pts);
        if b[0][0].is_finite() {
            b
        } else {
            [[0.0; 2]; 2]
        }
    }

    /// If `shape` overlaps a wall or an obstacle, say which.
    pub(crate) fn shape_clash(&self, shape: &Shape) -> Option<String> {
        for (i, w) in self.walls.iter().enumerate() {
            if shape.segment_distance(w[0], w[1]) <= 1e-6 {
                return Some(format!("wall segment {i} from {:?} to {:?}", w[0], w[1]));
            }
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            if shape.shape_distance(&o.shape) <= 1e-6 {
                return Some(obstacle_description(i, o));
            }
        }
        None
    }

    /// If a disc at `p` touches a wall, an obstacle or (optionally) a target at any of its
    /// positions, say which.
    pub fn disc_clash(&self, p: P2, r: f64, with_targets: bool) -> Option<String> {
        let disc = Shape::Circle { center: p, radius: r };
        for (i, w) in self.walls.iter().enumerate() {
            if disc.segment_distance(w[0], w[1]) <= 0.0 {
                return Some(format!("wall segment {i} from {:?} to {:?}", w[0], w[1]));
            }
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            if o.shape.distance_to(p) < r {
                return Some(obstacle_description(i, o));
            }
        }
        if with_targets {
            for t in &self.targets {
                for q in t.positions() {
                    if t.shape_at(q).distance_to(p) < r {
                        return Some(format!("target {:?} at {q:?}", t.name));
                    }
                }
            }
        }
        None
    }

    /// Is a disc of radius `r` at `p` clear of walls and obstacles (targets and people ignored)?
    pub fn disc_is_clear(&self, p: P2, r: f64) -> bool {
        self.disc_clash(p, r, false).is_none()
    }

    /// The material of wall segment `i` ([`Material::Default`] past the end of
    /// [`World::wall_materials`]).
    pub fn wall_material(&self, i: usize) -> Material {
        self.wall_materials.get(i).copied().unwrap_or_default()
    }

    /// The world as a complete, standalone TOML file that [`World::from_toml_str`] reads back to
    /// an equal world (walls are re-chained into polylines; angles are written in radians).
    pub fn to_toml_string(&self) -> String {
        let mut s = String::new();
        s.push_str("# LIVES simulator world (see docs/world-format.md). Metres, radians, seconds.\n");
        s.push_str(&format!("name = {}\n", toml_str(&self.name)));
        s.push_str(&format!("time_limit_s = {}\n\n", num(self.time_limit_s)));
        s.push_str("[start]\n");
        s.push_str(&format!(
            "position = {}\nyaw_rad = {}\njitter_m = {}\njitter_yaw_rad = {}\n",
            pt(&[self.start.pose[0], self.start.pose[1]]),
            num(self.start.pose[2]),
            num(self.start.jitter_m),
            num(self.start.jitter_yaw_rad)
        ));
        // Chain consecutive connected segments into polylines.
        let mut i = 0;
        while i < self.walls.len() {
            let mut points = vec![self.walls[i][0], self.walls[i][1]];
            let mut j = i + 1;
            let material = self.wall_material(i);
            while j < self.walls.len() && self.walls[j][0] == *points.last().expect("non-empty") && self.wall_material(j) == material {
                points.push(self.walls[j][1]);
                j += 1;
            }
            let closed = points.len() >= 4 && points.first() == points.last();
            if closed {
                points.pop();
            }
            s.push_str("\n[[walls]]\n");
            s.push_str(&format!("points = {}\n", pts(&points)));
            if closed {
                s.push_str("closed = true\n");
            }
            if material != Material::Default {
                s.push_str(&format!("material = \"{}\"\n", material.as_str()));
            }
            i = j;
        }
        for o in &self.obstacles {
            s.push_str("\n[[obstacles]]\n");
            let kind = if o.kind == HitKind::Clutter { "clutter" } else { "furniture" };
            s.push_str(&format!("kind = \"{kind}\"\n"));
            if !o.label.is_empty() {
                s.push_str(&format!("label = {}\n", toml_str(&o.label)));
            }
            if o.material != Material::Default {
                s.push_str(&format!("material = \"{}\"\n", o.material.as_str()));
            }
            s.push_str(&shape_toml(&o.shape));
        }
        for t in &self.targets {
            s.push_str("\n[[targets]]\n");
            s.push_str(&format!("name = {}\n", toml_str(&t.name)));
            s.push_str(&shape_toml(&t.shape));
            if !t.candidates.is_empty() {
                s.push_str(&format!("candidates = {}\n", pts(&t.candidates)));
            }
        }
        for p in &self.people {
            s.push_str("\n[[people]]\n");
            s.push_str(&format!("path = {}\nspeed_mps = {}\nradius_m = {}\n", pts(&p.path), num(p.speed_mps), num(p.radius_m)));
        }
        s
    }
}

fn obstacle_description(i: usize, o: &Obstacle) -> String {
    if o.label.is_empty() {
        format!("obstacle {i}")
    } else {
        format!("obstacle {i} ({})", o.label)
    }
}

/// Points every `step` metres along a closed loop (its corners included).
pub(crate) fn person_path_samples(path: &[P2], step: f64) -> Vec<P2> {
    let n = path.len();
    if n <= 1 {
        return path.to_vec();
    }
    let mut out = Vec::new();
    for i in 0..n {
        let (a, b) = (path[i], path[(i + 1) % n]);
        let len = dist(a, b);
        let k = ((len / step).ceil() as usize).clamp(1, 100_000);
        for j in 0..k {
            let t = j as f64 / k as f64;
            out.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
        }
    }
    out
}

/// A number in TOML syntax that reads back to the same bits.
fn num(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

fn pt(p: &P2) -> String {
    format!("[{}, {}]", num(p[0]), num(p[1]))
}

fn pts(points: &[P2]) -> String {
    let inner: Vec<String> = points.iter().map(pt).collect();
    format!("[{}]", inner.join(", "))
}

fn shape_toml(shape: &Shape) -> String {
    match shape {
        Shape::Rect { center, size, yaw } => {
            format!("rect = {{ center = {}, size = {}, yaw_rad = {} }}\n", pt(center), pt(size), num(*yaw))
        }
        Shape::Circle { center, radius } => {
            format!("circle = {{ center = {}, radius = {} }}\n", pt(center), num(*radius))
        }
        Shape::Polygon { points } => format!("polygon = {}\n", pts(points)),
    }
}

/// A TOML basic string.
fn toml_str(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if (c as u32) < 0x20 || c as u32 == 0x7f => out.push_str(&format!("\\u{:04X}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const TINY: &str = r#"# a tiny world
name = "tiny"
time_limit_s = 60

[start]
position = [1.0, 1.0]
yaw_deg = 90

[[walls]]
points = [[0, 0], [6, 0], [6, 4], [0, 4]]
closed = true

[[obstacles]]
kind = "furniture"
label = "table"
rect = { center = [4.0, 2.0], size = [1.2, 0.8], yaw_deg = 10 }

[[obstacles]]
kind = "clutter"
circle = { center = [2.0, 3.0], radius = 0.2 }

[[obstacles]]
kind = "clutter"
polygon = [[5.0, 0.5], [5.5, 0.5], [5.2, 1.0]]

[[targets]]
name = "suitcase"
rect = { center = [2.5, 1.0], size = [0.5, 0.35] }
candidates = [[1.0, 3.0]]

[[people]]
path = [[1.0, 2.2], [5.0, 3.5]]
speed_mps = 0.5
"#;

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
            assert!(
                e.to_string().starts_with(&format!("bad.toml:{line}: {expect}")),
                "{to}:\n  got  {e}\n  want bad.toml:{line}: {expect}"
            );
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
}
