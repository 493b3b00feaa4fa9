//! Plane geometry for the simulator: shape outlines, ray casting and disc-collision queries.
//!
//! [`Scene`] holds the static part of a world (walls, obstacles and placed targets) as line
//! segments, circles and solid polygons, indexed by a uniform grid so that a ray or a disc query
//! only looks at the items in the cells it touches. People move, so they are not in the scene;
//! the simulator tests them separately.

use super::{HitKind, Material, Shape, P2};

/// Owner id of wall segments (obstacles own their index, targets `TARGET_OWNER_BASE + index`).
pub const WALL_OWNER: u32 = u32::MAX;
/// Owner ids at and above this are targets.
pub const TARGET_OWNER_BASE: u32 = 1 << 30;
/// An owner id no item has, for "ignore nothing".
pub const NO_OWNER: u32 = u32::MAX - 1;

#[inline]
pub fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
pub fn add(a: P2, b: P2) -> P2 {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline]
pub fn scale(a: P2, s: f64) -> P2 {
    [a[0] * s, a[1] * s]
}

#[inline]
pub fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

#[inline]
pub fn cross(a: P2, b: P2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[inline]
pub fn norm(a: P2) -> f64 {
    a[0].hypot(a[1])
}

#[inline]
pub fn dist(a: P2, b: P2) -> f64 {
    norm(sub(a, b))
}

/// `angle` wrapped to (−π, π].
pub fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::PI;
    let mut a = angle % (2.0 * PI);
    if a > PI {
        a -= 2.0 * PI;
    } else if a <= -PI {
        a += 2.0 * PI;
    }
    a
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: P2, a: P2, b: P2) -> f64 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 { (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    dist(p, add(a, scale(ab, t)))
}

/// Even-odd point-in-polygon test.
pub fn point_in_polygon(p: P2, poly: &[P2]) -> bool {
    let mut inside = false;
    let n = poly.len();
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Do the closed segments `a`–`b` and `c`–`d` intersect (touching counts)?
pub fn segments_intersect(a: P2, b: P2, c: P2, d: P2) -> bool {
    let d1 = cross(sub(b, a), sub(c, a));
    let d2 = cross(sub(b, a), sub(d, a));
    let d3 = cross(sub(d, c), sub(a, c));
    let d4 = cross(sub(d, c), sub(b, c));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |p: P2, q: P2, r: P2| {
        cross(sub(q, p), sub(r, p)).abs() <= 1e-12
            && r[0] >= p[0].min(q[0]) - 1e-12
            && r[0] <= p[0].max(q[0]) + 1e-12
            && r[1] >= p[1].min(q[1]) - 1e-12
            && r[1] <= p[1].max(q[1]) + 1e-12
    };
    on(a, b, c) || on(a, b, d) || on(c, d, a) || on(c, d, b)
}

/// Distance between two segments (0 if they intersect).
pub fn segment_segment_distance(a: P2, b: P2, c: P2, d: P2) -> f64 {
    if segments_intersect(a, b, c, d) {
        return 0.0;
    }
    point_segment_distance(a, c, d)
        .min(point_segment_distance(b, c, d))
        .min(point_segment_distance(c, a, b))
        .min(point_segment_distance(d, a, b))
}

/// Signed area of a polygon (positive for counter-clockwise).
pub fn polygon_area(points: &[P2]) -> f64 {
    let n = points.len();
    let mut s = 0.0;
    for i in 0..n {
        s += cross(points[i], points[(i + 1) % n]);
    }
    0.5 * s
}

impl Shape {
    /// The shape's reference point: the centre of a rectangle or circle, the vertex mean of a
    /// polygon.
    pub fn center(&self) -> P2 {
        match self {
            Shape::Rect { center, .. } | Shape::Circle { center, .. } => *center,
            Shape::Polygon { points } => {
                let n = points.len().max(1) as f64;
                let s = points.iter().fold([0.0, 0.0], |acc, p| add(acc, *p));
                scale(s, 1.0 / n)
            }
        }
    }

    /// The same shape moved so that [`Shape::center`] is at `c`.
    pub fn moved_to(&self, c: P2) -> Shape {
        let d = sub(c, self.center());
        match self {
            Shape::Rect { size, yaw, .. } => Shape::Rect { center: c, size: *size, yaw: *yaw },
            Shape::Circle { radius, .. } => Shape::Circle { center: c, radius: *radius },
            Shape::Polygon { points } => Shape::Polygon { points: points.iter().map(|p| add(*p, d)).collect() },
        }
    }

    /// Corner points of a rectangle or polygon; `None` for a circle.
    pub fn vertices(&self) -> Option<Vec<P2>> {
        match self {
            Shape::Rect { center, size, yaw } => {
                let (s, c) = yaw.sin_cos();
                let (hx, hy) = (size[0] / 2.0, size[1] / 2.0);
                Some(
                    [[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]]
                        .iter()
                        .map(|l| [center[0] + c * l[0] - s * l[1], center[1] + s * l[0] + c * l[1]])
                        .collect(),
                )
            }
            Shape::Circle { .. } => None,
            Shape::Polygon { points } => Some(points.clone()),
        }
    }

    /// A polygon approximation (a circle becomes a 32-gon through the circle).
    pub fn polygon(&self) -> Vec<P2> {
        match self {
            Shape::Circle { center, radius } => (0..32)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::TAU / 32.0;
                    [center[0] + radius * a.cos(), center[1] + radius * a.sin()]
                })
                .collect(),
            _ => self.vertices().unwrap_or_default(),
        }
    }

    /// Axis-aligned bounding box `[min, max]`.
    pub fn aabb(&self) -> [P2; 2] {
        match self {
            Shape::Circle { center, radius } => [[center[0] - radius, center[1] - radius], [center[0] + radius, center[1] + radius]],
            _ => aabb_of(&self.vertices().unwrap_or_default()),
        }
    }

    /// `n` points spread evenly along the outline.
    pub fn outline_samples(&self, n: usize) -> Vec<P2> {
        if n == 0 {
            return Vec::new();
        }
        match self {
            Shape::Circle { center, radius } => (0..n)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::TAU / n as f64;
                    [center[0] + radius * a.cos(), center[1] + radius * a.sin()]
                })
                .collect(),
            _ => {
                let v = self.vertices().unwrap_or_default();
                let m = v.len();
                if m == 0 {
                    return Vec::new();
                }
                let perimeter: f64 = (0..m).map(|i| dist(v[i], v[(i + 1) % m])).sum();
                let step = perimeter / n as f64;
                let mut out = Vec::with_capacity(n);
                let (mut edge, mut along) = (0usize, 0.0f64);
                for k in 0..n {
                    let target = (k as f64 + 0.5) * step;
                    let mut edge_len = dist(v[edge], v[(edge + 1) % m]);
                    while along + edge_len < target && edge + 1 < m {
                        along += edge_len;
                        edge += 1;
                        edge_len = dist(v[edge], v[(edge + 1) % m]);
                    }
                    let t = if edge_len > 0.0 { ((target - along) / edge_len).clamp(0.0, 1.0) } else { 0.0 };
                    let a = v[edge];
                    out.push(add(a, scale(sub(v[(edge + 1) % m], a), t)));
                }
                out
            }
        }
    }

    /// Is `p` inside (or on) the shape?
    pub fn contains(&self, p: P2) -> bool {
        match self {
            Shape::Circle { center, radius } => dist(p, *center) <= *radius,
            _ => point_in_polygon(p, &self.vertices().unwrap_or_default()),
        }
    }

    /// Distance from `p` to the shape (0 inside).
    pub fn distance_to(&self, p: P2) -> f64 {
        match self {
            Shape::Circle { center, radius } => (dist(p, *center) - radius).max(0.0),
            _ => {
                let v = self.vertices().unwrap_or_default();
                if point_in_polygon(p, &v) {
                    return 0.0;
                }
                let m = v.len();
                (0..m).map(|i| point_segment_distance(p, v[i], v[(i + 1) % m])).fold(f64::INFINITY, f64::min)
            }
        }
    }

    /// Distance from the segment `a`–`b` to the shape (0 when they touch or overlap).
    pub fn segment_distance(&self, a: P2, b: P2) -> f64 {
        match self {
            Shape::Circle { center, radius } => (point_segment_distance(*center, a, b) - radius).max(0.0),
            _ => {
                let v = self.vertices().unwrap_or_default();
                if point_in_polygon(a, &v) || point_in_polygon(b, &v) {
                    return 0.0;
                }
                let m = v.len();
                (0..m).map(|i| segment_segment_distance(a, b, v[i], v[(i + 1) % m])).fold(f64::INFINITY, f64::min)
            }
        }
    }

    /// Distance between two shapes (0 when they touch or overlap); circles are exact against
    /// circles and approximated by 32-gons against polygons.
    pub fn shape_distance(&self, other: &Shape) -> f64 {
        if let (Shape::Circle { center: c1, radius: r1 }, Shape::Circle { center: c2, radius: r2 }) = (self, other) {
            return (dist(*c1, *c2) - r1 - r2).max(0.0);
        }
        if let Shape::Circle { center, radius } = other {
            return (self.distance_to(*center) - radius).max(0.0);
        }
        if let Shape::Circle { center, radius } = self {
            return (other.distance_to(*center) - radius).max(0.0);
        }
        let v = other.polygon();
        let m = v.len();
        (0..m).map(|i| self.segment_distance(v[i], v[(i + 1) % m])).fold(f64::INFINITY, f64::min).min(match self.polygon().first() {
            // `self` entirely inside `other`.
            Some(&p) if other.contains(p) => 0.0,
            _ => f64::INFINITY,
        })
    }
}

/// Axis-aligned bounding box of points (`[[inf, inf], [-inf, -inf]]` for none).
pub fn aabb_of(points: &[P2]) -> [P2; 2] {
    let mut b = [[f64::INFINITY; 2], [f64::NEG_INFINITY; 2]];
    for p in points {
        b[0][0] = b[0][0].min(p[0]);
        b[0][1] = b[0][1].min(p[1]);
        b[1][0] = b[1][0].max(p[0]);
        b[1][1] = b[1][1].max(p[1]);
    }
    b
}

/// Ray hits against a segment: the distance `t` along the unit direction `d`, if any.
#[inline]
fn ray_segment(o: P2, d: P2, a: P2, b: P2) -> Option<f64> {
    let e = sub(b, a);
    let denom = cross(d, e);
    if denom.abs() < 1e-15 {
        return None;
    }
    let ao = sub(a, o);
    let t = cross(ao, e) / denom;
    let u = cross(ao, d) / denom;
    if t >= 0.0 && (-1e-9..=1.0 + 1e-9).contains(&u) {
        Some(t)
    } else {
        None
    }
}

/// Ray hits against a circle: the first non-negative `t`, if any.
#[inline]
pub fn ray_circle(o: P2, d: P2, c: P2, r: f64) -> Option<f64> {
    let oc = sub(o, c);
    let b = dot(oc, d);
    let cc = dot(oc, oc) - r * r;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = -b - s;
    let t1 = -b + s;
    if t0 >= 0.0 {
        Some(t0)
    } else if t1 >= 0.0 {
        Some(t1)
    } else {
        None
    }
}

#[derive(Clone, Debug)]
struct Seg {
    a: P2,
    b: P2,
    kind: HitKind,
    owner: u32,
    material: Material,
}

#[derive(Clone, Debug)]
struct Circ {
    c: P2,
    r: f64,
    kind: HitKind,
    owner: u32,
    material: Material,
}

/// Largest grid side, in cells.
const MAX_GRID_CELLS: usize = 512;
const TAG_SHIFT: u32 = 30;
const TAG_SEG: u32 = 0;
const TAG_CIRC: u32 = 1;
const TAG_POLY: u32 = 2;
const INDEX_MASK: u32 = (1 << TAG_SHIFT) - 1;

/// The first thing a ray meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    pub t: f64,
    pub kind: HitKind,
    pub owner: u32,
    /// What the surface is made of.
    pub material: Material,
    /// The surface's unit normal at the hit (either side): `|d · normal|` is the cosine of the
    /// angle of incidence.
    pub normal: P2,
}

/// How to find a surface's normal once the hit point is known.
#[derive(Clone, Copy)]
enum Normal {
    Segment(P2, P2),
    Circle(P2),
}

impl Normal {
    fn at(self, p: P2) -> P2 {
        let v = match self {
            Normal::Segment(a, b) => [a[1] - b[1], b[0] - a[0]],
            Normal::Circle(c) => sub(p, c),
        };
        let n = norm(v);
        if n > 0.0 {
            [v[0] / n, v[1] / n]
        } else {
            [1.0, 0.0]
        }
    }
}

/// Static geometry with a uniform-grid broad phase.
#[derive(Clone, Debug)]
pub struct Scene {
    segs: Vec<Seg>,
    circs: Vec<Circ>,
    polys: Vec<Vec<P2>>,
    origin: P2,
    cell: f64,
    nx: usize,
    ny: usize,
    /// CSR: items of cell `i` are `items[start[i]..start[i + 1]]`, tagged by type.
    start: Vec<u32>,
    items: Vec<u32>,
}

/// Builder for a [`Scene`].
#[derive(Default)]
pub struct SceneBuilder {
    segs: Vec<Seg>,
    circs: Vec<Circ>,
    polys: Vec<Vec<P2>>,
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn wall(&mut self, a: P2, b: P2) {
        self.wall_of(a, b, Material::Default);
    }

    /// A wall segment of `material`.
    pub fn wall_of(&mut self, a: P2, b: P2, material: Material) {
        self.segs.push(Seg { a, b, kind: HitKind::Wall, owner: WALL_OWNER, material });
    }

    /// A solid shape: its outline for rays, its interior for collisions.
    pub fn shape(&mut self, shape: &Shape, kind: HitKind, owner: u32) {
        self.shape_of(shape, kind, owner, Material::Default);
    }

    /// A solid shape whose outline is of `material`.
    pub fn shape_of(&mut self, shape: &Shape, kind: HitKind, owner: u32, material: Material) {
        match shape {
            Shape::Circle { center, radius } => {
                self.circs.push(Circ { c: *center, r: *radius, kind, owner, material });
            }
            _ => {
                let v = shape.vertices().unwrap_or_default();
                let m = v.len();
                for i in 0..m {
                    self.segs.push(Seg { a: v[i], b: v[(i + 1) % m], kind, owner, material });
                }
                if m >= 3 {
                    self.polys.push(v);
                }
            }
        }
    }

    /// Build the grid with `cell_m` cells over everything plus a margin.
    pub fn build(self, cell_m: f64) -> Scene {
        let mut pts: Vec<P2> = Vec::new();
        for s in &self.segs {
            pts.push(s.a);
            pts.push(s.b);
        }
        for c in &self.circs {
            pts.push([c.c[0] - c.r, c.c[1] - c.r]);
            pts.push([c.c[0] + c.r, c.c[1] + c.r]);
        }
        pts.retain(|p| p[0].is_finite() && p[1].is_finite());
        let mut bb = aabb_of(&pts);
        if !bb[0][0].is_finite() || !bb[1][0].is_finite() {
            bb = [[0.0, 0.0], [1.0, 1.0]];
        }
        // Validated worlds are at most 51 m wide; for anything larger the cells grow so that the
        // grid stays at most MAX_GRID_CELLS a side.
        let extent = (bb[1][0] - bb[0][0]).max(bb[1][1] - bb[0][1]);
        let cell = if cell_m.is_finite() && cell_m > 0.0 { cell_m } else { 0.5 }.max(extent / MAX_GRID_CELLS as f64);
        let margin = cell;
        let origin = [bb[0][0] - margin, bb[0][1] - margin];
        let nx = (((bb[1][0] - origin[0] + margin) / cell).ceil() as usize).clamp(1, MAX_GRID_CELLS + 2);
        let ny = (((bb[1][1] - origin[1] + margin) / cell).ceil() as usize).clamp(1, MAX_GRID_CELLS + 2);
        let mut scene =
            Scene { segs: self.segs, circs: self.circs, polys: self.polys, origin, cell, nx, ny, start: Vec::new(), items: Vec::new() };
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for (i, s) in scene.segs.iter().enumerate() {
            let tag = (TAG_SEG << TAG_SHIFT) | i as u32;
            scene.cells_of_segment(s.a, s.b, |c| pairs.push((c, tag)));
        }
        for (i, c) in scene.circs.iter().enumerate() {
            let tag = (TAG_CIRC << TAG_SHIFT) | i as u32;
            let bb = [[c.c[0] - c.r, c.c[1] - c.r], [c.c[0] + c.r, c.c[1] + c.r]];
            scene.cells_of_box(bb, |cell| pairs.push((cell, tag)));
        }
        for (i, p) in scene.polys.iter().enumerate() {
            let tag = (TAG_POLY << TAG_SHIFT) | i as u32;
            scene.cells_of_box(aabb_of(p), |cell| pairs.push((cell, tag)));
        }
        pairs.sort_unstable();
        pairs.dedup();
        let ncells = nx * ny;
        let mut start = vec![0u32; ncells + 1];
        for &(c, _) in &pairs {
            start[c as usize + 1] += 1;
        }
        for i in 0..ncells {
            start[i + 1] += start[i];
        }
        scene.items = pairs.iter().map(|&(_, t)| t).collect();
        scene.start = start;
        scene
    }
}

impl Scene {
    #[inline]
    fn cell_coord(&self, p: P2) -> (isize, isize) {
        (((p[0] - self.origin[0]) / self.cell).floor() as isize, ((p[1] - self.origin[1]) / self.cell).floor() as isize)
    }

    fn cells_of_box(&self, bb: [P2; 2], mut f: impl FnMut(u32)) {
        let (x0, y0) = self.cell_coord(bb[0]);
        let (x1, y1) = self.cell_coord(bb[1]);
        let x0 = x0.max(0) as usize;
        let y0 = y0.max(0) as usize;
        let x1 = (x1.max(-1) as usize).min(self.nx - 1);
        let y1 = (y1.max(-1) as usize).min(self.ny - 1);
        if bb[1][0] < self.origin[0] || bb[1][1] < self.origin[1] {
            return;
        }
        for y in y0..=y1 {
            for x in x0..=x1 {
                f((y * self.nx + x) as u32);
            }
        }
    }

    /// Cells a segment passes through (conservatively: cells whose box is within a hair of it).
    fn cells_of_segment(&self, a: P2, b: P2, mut f: impl FnMut(u32)) {
        let bb = aabb_of(&[a, b]);
        let half = self.cell * 0.5;
        let reach = half * std::f64::consts::SQRT_2 + 1e-9;
        let (x0, y0) = self.cell_coord(bb[0]);
        let (x1, y1) = self.cell_coord(bb[1]);
        for y in y0.max(0)..=y1.min(self.ny as isize - 1) {
            for x in x0.max(0)..=x1.min(self.nx as isize - 1) {
                let c = [self.origin[0] + (x as f64 + 0.5) * self.cell, self.origin[1] + (y as f64 + 0.5) * self.cell];
                if point_segment_distance(c, a, b) <= reach {
                    f((y as usize * self.nx + x as usize) as u32);
                }
            }
        }
    }

    #[inline]
    fn cell_items(&self, cx: usize, cy: usize) -> &[u32] {
        let i = cy * self.nx + cx;
        &self.items[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// The first item a ray from `o` along unit `d` meets within `max_t`, ignoring items owned
    /// by `ignore_owner`.
    pub fn raycast(&self, o: P2, d: P2, max_t: f64, ignore_owner: u32) -> Option<RayHit> {
        self.raycast_beyond(o, d, f64::NEG_INFINITY, max_t, ignore_owner)
    }

    /// [`Scene::raycast`] counting only hits farther than `min_t` (a beam that went through a
    /// pane of glass at `min_t` goes on).
    pub fn raycast_beyond(&self, o: P2, d: P2, min_t: f64, max_t: f64, ignore_owner: u32) -> Option<RayHit> {
        if max_t.is_nan() || max_t <= 0.0 || !o[0].is_finite() || !o[1].is_finite() {
            return None;
        }
        // Clip the ray to the grid box.
        let lo = self.origin;
        let hi = [self.origin[0] + self.nx as f64 * self.cell, self.origin[1] + self.ny as f64 * self.cell];
        let mut t_enter = 0.0f64;
        let mut t_leave = max_t;
        for k in 0..2 {
            if d[k].abs() < 1e-300 {
                if o[k] < lo[k] || o[k] > hi[k] {
                    return None;
                }
            } else {
                let ta = (lo[k] - o[k]) / d[k];
                let tb = (hi[k] - o[k]) / d[k];
                t_enter = t_enter.max(ta.min(tb));
                t_leave = t_leave.min(ta.max(tb));
            }
        }
        if t_enter > t_leave {
            return None;
        }
        let p = add(o, scale(d, t_enter));
        let (mut cx, mut cy) = self.cell_coord(p);
        cx = cx.clamp(0, self.nx as isize - 1);
        cy = cy.clamp(0, self.ny as isize - 1);
        let step_x: isize = if d[0] > 0.0 { 1 } else { -1 };
        let step_y: isize = if d[1] > 0.0 { 1 } else { -1 };
        let next_boundary = |c: isize, k: usize, step: isize| {
            let edge = if step > 0 { c + 1 } else { c };
            self.origin[k] + edge as f64 * self.cell
        };
        let mut t_max_x = if d[0].abs() > 1e-300 { (next_boundary(cx, 0, step_x) - o[0]) / d[0] } else { f64::INFINITY };
        let mut t_max_y = if d[1].abs() > 1e-300 { (next_boundary(cy, 1, step_y) - o[1]) / d[1] } else { f64::INFINITY };
        let t_delta_x = if d[0].abs() > 1e-300 { self.cell / d[0].abs() } else { f64::INFINITY };
        let t_delta_y = if d[1].abs() > 1e-300 { self.cell / d[1].abs() } else { f64::INFINITY };
        let mut best: Option<RayHit> = None;
        loop {
            for &item in self.cell_items(cx as usize, cy as usize) {
                let idx = (item & INDEX_MASK) as usize;
                let (t, kind, owner, material, normal) = match item >> TAG_SHIFT {
                    TAG_SEG => {
                        let s = &self.segs[idx];
                        if s.owner == ignore_owner {
                            continue;
                        }
                        match ray_segment(o, d, s.a, s.b) {
                            Some(t) => (t, s.kind, s.owner, s.material, Normal::Segment(s.a, s.b)),
                            None => continue,
                        }
                    }
                    TAG_CIRC => {
                        let c = &self.circs[idx];
                        if c.owner == ignore_owner {
                            continue;
                        }
                        match ray_circle(o, d, c.c, c.r) {
                            Some(t) => (t, c.kind, c.owner, c.material, Normal::Circle(c.c)),
                            None => continue,
                        }
                    }
                    _ => continue,
                };
                if t > min_t && t <= max_t && best.is_none_or(|b| t < b.t) {
                    best = Some(RayHit { t, kind, owner, material, normal: normal.at(add(o, scale(d, t))) });
                }
            }
            let t_exit = t_max_x.min(t_max_y);
            if let Some(b) = best {
                if b.t <= t_exit {
                    return best;
                }
            }
            if t_exit > t_leave {
                return best;
            }
            if t_max_x < t_max_y {
                cx += step_x;
                t_max_x += t_delta_x;
                if cx < 0 || cx >= self.nx as isize {
                    return best;
                }
            } else {
                cy += step_y;
                t_max_y += t_delta_y;
                if cy < 0 || cy >= self.ny as isize {
                    return best;
                }
            }
        }
    }

    /// Does a disc of radius `r` at `p` touch anything (segments, circles, or lie inside a solid)?
    pub fn disc_collides(&self, p: P2, r: f64) -> bool {
        if !p[0].is_finite() || !p[1].is_finite() {
            return true;
        }
        let bb = [[p[0] - r, p[1] - r], [p[0] + r, p[1] + r]];
        let (x0, y0) = self.cell_coord(bb[0]);
        let (x1, y1) = self.cell_coord(bb[1]);
        for y in y0.max(0)..=y1.min(self.ny as isize - 1) {
            for x in x0.max(0)..=x1.min(self.nx as isize - 1) {
                for &item in self.cell_items(x as usize, y as usize) {
                    let idx = (item & INDEX_MASK) as usize;
                    let hit = match item >> TAG_SHIFT {
                        TAG_SEG => {
                            let s = &self.segs[idx];
                            point_segment_distance(p, s.a, s.b) < r
                        }
                        TAG_CIRC => {
                            let c = &self.circs[idx];
                            dist(p, c.c) < r + c.r
                        }
                        TAG_POLY => point_in_polygon(p, &self.polys[idx]),
                        _ => false,
                    };
                    if hit {
                        return true;
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests;
