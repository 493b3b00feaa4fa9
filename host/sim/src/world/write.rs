//! Writing a world back as a TOML file ([`World::to_toml_string`]).

use super::*;
use crate::{HitKind, Material, Shape, P2};

impl World {
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

/// A number in TOML syntax that reads back to the same bits.
pub(super) fn num(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

pub(super) fn pt(p: &P2) -> String {
    format!("[{}, {}]", num(p[0]), num(p[1]))
}

pub(super) fn pts(points: &[P2]) -> String {
    let inner: Vec<String> = points.iter().map(pt).collect();
    format!("[{}]", inner.join(", "))
}

pub(super) fn shape_toml(shape: &Shape) -> String {
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
pub(super) fn toml_str(s: &str) -> String {
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
