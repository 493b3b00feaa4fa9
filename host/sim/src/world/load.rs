//! Loading: TOML syntax, schema and meaning checked in turn, every error worded in the file's
//! terms with its line ([`World::from_toml_str`], [`World::load`]).

use std::ops::Range;
use std::path::Path;

use toml::Spanned;

use super::*;
use crate::geometry::{dist, polygon_area};
use crate::{HitKind, Material, Shape, P2};

/// 1-based line of a byte offset.
pub(super) fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// A toml message on one line.
pub(super) fn one_line(message: &str) -> String {
    message.split('\n').map(str::trim).filter(|s| !s.is_empty()).collect::<Vec<_>>().join("; ")
}

/// What a value must hold, in the world format's words, for what serde calls it (`struct
/// RawRect`, `f64`, `a sequence`, ...).
pub(super) fn expected_in_format_words(expected: &str) -> String {
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
pub(super) fn found_in_format_words(found: &str) -> String {
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
pub(super) fn key_at(text: &str, at: usize) -> (Option<String>, Option<String>) {
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
pub(super) fn line_at(text: &str, at: usize) -> (usize, usize) {
    let at = (0..=at.min(text.len())).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
    (at, text[..at].rfind('\n').map(|i| i + 1).unwrap_or(0))
}

/// A toml or serde message (`invalid type: floating point `50.9`, expected struct RawRect`,
/// `invalid length 0, expected struct RawRect with 4 elements`, `invalid value: integer `…` as
/// i128, expected any valid TOML value`) in the world format's words: which key, what it must
/// hold, what it holds. Messages that already speak the format's words pass unchanged.
pub(super) fn in_format_words(message: &str, text: &str, at: usize) -> String {
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

pub(super) struct Ctx<'a> {
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

    /// A closed `width` × `height` m room (corner at the origin) named `name`, read as the world
    /// file `file_name`: the robot starts at `start`, and `extra` (TOML tables: targets, furniture,
    /// people …) is in it. For tests, here and in the host; panics if the text does not read.
    #[doc(hidden)]
    pub fn closed_room(name: &str, file_name: &str, [width, height]: [u32; 2], [x, y]: [f64; 2], extra: &str) -> World {
        let text = format!(
            r#"name = "{name}"
time_limit_s = 60
[start]
position = [{x:?}, {y:?}]
[[walls]]
points = [[0, 0], [{width}, 0], [{width}, {height}], [0, {height}]]
closed = true
{extra}"#
        );
        World::from_toml_str(&text, file_name).unwrap()
    }

    /// Read and parse a world file.
    pub fn load(path: &Path) -> Result<World, WorldError> {
        let file = path.display().to_string();
        let bytes = crate::read_at_most(path, MAX_WORLD_FILE_BYTES)
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
}
