//! Drawing: the grids painted cell by cell, then the world, paths, people, candidates and the
//! legend drawn with plotters on the same buffer; PNG encoding.

use std::fmt;
use std::io::{BufWriter, Write};
use std::path::Path;

use super::*;
use plotters::prelude::{BitMapBackend, DrawingBackend, RGBColor};
use plotters::style::{Color, ShapeStyle, TextStyle};

/// Renders the picture into memory.
pub fn render_rgb(input: &RenderInput) -> Result<RgbImage, RenderError> {
    ensure_font();
    let lay = layout(input);
    let (w, h) = (lay.width, lay.height);
    let mut data = vec![255u8; w as usize * h as usize * 3];

    // 1. grid raster (occupied cells are remembered and painted in step 3,
    //    above the faint true walls).
    let occupied = paint_grid(&mut data, &lay, &input.grid);

    // 2. the true world, faint.
    {
        let mut be = BitMapBackend::with_buffer(&mut data, (w, h));
        let mut c = Canvas::new(&mut be, lay);
        c.truth(input)?;
        be.present().map_err(backend_err)?;
    }

    // 3. LiDAR-occupied cells.
    for (i, &occ) in occupied.iter().enumerate() {
        if occ {
            let px = lay.map_x0 as usize + i % lay.map_w as usize;
            let py = lay.map_y0 as usize + i / lay.map_w as usize;
            let j = 3 * (py * w as usize + px);
            data[j..j + 3].copy_from_slice(&palette::OCCUPIED);
        }
    }

    // 4. overlays, title and legend.
    {
        let mut be = BitMapBackend::with_buffer(&mut data, (w, h));
        let mut c = Canvas::new(&mut be, lay);
        c.overlays(input)?;
        c.title(&input.title);
        c.legend(input)?;
        be.present().map_err(backend_err)?;
    }
    Ok(RgbImage { width: w, height: h, data })
}

/// Encodes a picture as PNG (RGB8) into a writer.
pub fn encode_png<W: Write>(out: W, img: &RgbImage) -> Result<(), RenderError> {
    let mut enc = png::Encoder::new(out, img.width, img.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header()?;
    writer.write_image_data(&img.data)?;
    writer.finish()?;
    Ok(())
}

/// Renders the picture and writes it as a PNG file at `path` (whatever its
/// extension).
pub fn render_png(path: &Path, input: &RenderInput) -> Result<(), RenderError> {
    let img = render_rgb(input)?;
    let file = std::fs::File::create(path)?;
    let mut out = BufWriter::new(file);
    encode_png(&mut out, &img)?;
    out.flush()?;
    Ok(())
}

pub(super) fn backend_err<E: fmt::Display>(e: E) -> RenderError {
    RenderError::Backend(e.to_string())
}

/// Turns plotters' drawing errors (whose type plotters does not re-export)
/// into [`RenderError::Backend`].
pub(super) trait OrBackend<T> {
    fn be(self) -> Result<T, RenderError>;
}

impl<T, E: fmt::Display> OrBackend<T> for Result<T, E> {
    fn be(self) -> Result<T, RenderError> {
        self.map_err(backend_err)
    }
}

/// Paints the grid into the map area; returns the map-area mask of
/// occupied pixels.
pub(super) fn paint_grid(data: &mut [u8], lay: &Layout, grid: &GridView) -> Vec<bool> {
    let (mw, mh) = (lay.map_w as usize, lay.map_h as usize);
    let stride = lay.width as usize * 3;
    let mut occ = vec![false; mw * mh];
    let cell = grid_cell_m(grid);
    let origin_ok = finite(grid.origin);
    let to_cell = |v: f64, o: f64, n: usize| -> Option<usize> {
        let c = cell?;
        if !origin_ok {
            return None;
        }
        let k = ((v - o) / c).floor();
        (k >= 0.0 && k < n as f64).then_some(k as usize)
    };
    let cols: Vec<Option<usize>> = (0..mw)
        .map(|px| {
            let wx = lay.view_min[0] + (px as f64 + 0.5) / lay.px_per_m;
            to_cell(wx, grid.origin[0], grid.width)
        })
        .collect();
    let mut row_rgb: Vec<[u8; 3]> = vec![palette::UNKNOWN; mw];
    let mut row_occ: Vec<bool> = vec![false; mw];
    let mut cached: Option<Option<usize>> = None;
    for py in 0..mh {
        let wy = lay.view_max[1] - (py as f64 + 0.5) / lay.px_per_m;
        let cy = to_cell(wy, grid.origin[1], grid.height);
        if cached != Some(cy) {
            cached = Some(cy);
            let mut last: Option<(usize, [u8; 3], bool)> = None;
            for px in 0..mw {
                let (rgb, o) = match (cols[px], cy) {
                    (Some(cx), Some(cy)) => match last {
                        Some((lx, rgb, o)) if lx == cx => (rgb, o),
                        _ => {
                            let v = (grid.lidar)(cx, cy);
                            let (rgb, o) = if v >= 50 {
                                (palette::UNKNOWN, true)
                            } else if (grid.seen)(cx, cy) {
                                (palette::SEEN, false)
                            } else if v < 0 {
                                (palette::UNKNOWN, false)
                            } else {
                                (palette::FREE, false)
                            };
                            last = Some((cx, rgb, o));
                            (rgb, o)
                        }
                    },
                    _ => (palette::UNKNOWN, false),
                };
                row_rgb[px] = rgb;
                row_occ[px] = o;
            }
        }
        let y = lay.map_y0 as usize + py;
        let start = y * stride + lay.map_x0 as usize * 3;
        for (px, rgb) in row_rgb.iter().enumerate() {
            data[start + 3 * px..start + 3 * px + 3].copy_from_slice(rgb);
        }
        occ[py * mw..(py + 1) * mw].copy_from_slice(&row_occ);
    }
    occ
}

pub(super) type DResult = Result<(), RenderError>;

pub(super) fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

pub(super) fn stroke(c: [u8; 3], width: u32) -> ShapeStyle {
    ShapeStyle { color: rgb(c).to_rgba(), filled: false, stroke_width: width }
}

pub(super) fn stroke_a(c: [u8; 3], alpha: f64, width: u32) -> ShapeStyle {
    ShapeStyle { color: rgb(c).mix(alpha), filled: false, stroke_width: width }
}

pub(super) fn fill(c: [u8; 3]) -> ShapeStyle {
    ShapeStyle { color: rgb(c).to_rgba(), filled: true, stroke_width: 1 }
}

pub(super) fn fill_a(c: [u8; 3], alpha: f64) -> ShapeStyle {
    ShapeStyle { color: rgb(c).mix(alpha), filled: true, stroke_width: 1 }
}

/// Clips segment a-b (pixel coordinates) to rectangle [lo, hi]
/// (Liang-Barsky). Returns the clipped segment and whether `a` was kept.
pub(super) fn clip(a: [f64; 2], b: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> Option<([f64; 2], [f64; 2], bool)> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        for (p, q) in [(-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    if r > t1 {
                        return None;
                    }
                    t0 = t0.max(r);
                } else {
                    if r < t0 {
                        return None;
                    }
                    t1 = t1.min(r);
                }
            }
        }
    }
    let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1]];
    Some((at(t0), at(t1), t0 == 0.0))
}

pub(super) fn ipt(p: [f64; 2]) -> (i32, i32) {
    (p[0].round() as i32, p[1].round() as i32)
}

/// Drawing helpers in pixel space with clipping to the map area.
pub(super) struct Canvas<'b, 'a> {
    be: &'b mut BitMapBackend<'a>,
    lay: Layout,
    lo: [f64; 2],
    hi: [f64; 2],
}

impl<'b, 'a> Canvas<'b, 'a> {
    fn new(be: &'b mut BitMapBackend<'a>, lay: Layout) -> Self {
        let lo = [lay.map_x0 as f64 - 2.0, lay.map_y0 as f64 - 2.0];
        let hi = [(lay.map_x0 + lay.map_w) as f64 + 2.0, (lay.map_y0 + lay.map_h) as f64 + 2.0];
        Canvas { be, lay, lo, hi }
    }

    /// Pixel position of a world point, if finite.
    fn px(&self, p: P2) -> Option<[f64; 2]> {
        finite(p).then(|| self.lay.world_to_px(p))
    }

    /// Whether a pixel position is within `r` pixels of the map area.
    fn near_map(&self, q: [f64; 2], r: f64) -> bool {
        q[0] >= self.lo[0] - r && q[0] <= self.hi[0] + r && q[1] >= self.lo[1] - r && q[1] <= self.hi[1] + r
    }

    /// A polyline in pixel space (non-finite points break it), clipped.
    fn path_px(&mut self, pts: &[[f64; 2]], style: &ShapeStyle) -> DResult {
        let mut run: Vec<(i32, i32)> = Vec::new();
        let mut prev: Option<[f64; 2]> = None;
        for &q in pts {
            if !(q[0].is_finite() && q[1].is_finite()) {
                self.flush(&mut run, style)?;
                prev = None;
                continue;
            }
            if let Some(p) = prev {
                match clip(p, q, self.lo, self.hi) {
                    Some((a, b, kept_a)) => {
                        if !kept_a || run.is_empty() {
                            self.flush(&mut run, style)?;
                            run.push(ipt(a));
                        }
                        run.push(ipt(b));
                        if b != q {
                            self.flush(&mut run, style)?;
                        }
                    }
                    None => self.flush(&mut run, style)?,
                }
            }
            prev = Some(q);
        }
        self.flush(&mut run, style)
    }

    fn flush(&mut self, run: &mut Vec<(i32, i32)>, style: &ShapeStyle) -> DResult {
        if run.len() >= 2 {
            self.be.draw_path(run.drain(..), style).be()?;
        }
        run.clear();
        Ok(())
    }

    /// A polyline of world points.
    fn path(&mut self, pts: &[P2], style: &ShapeStyle) -> DResult {
        let px: Vec<[f64; 2]> = pts.iter().map(|&p| self.px(p).unwrap_or([f64::NAN, f64::NAN])).collect();
        self.path_px(&px, style)
    }

    /// A closed outline of world points.
    fn outline(&mut self, pts: &[P2], style: &ShapeStyle) -> DResult {
        if let Some(&first) = pts.first() {
            let mut closed = pts.to_vec();
            closed.push(first);
            self.path(&closed, style)?;
        }
        Ok(())
    }

    /// A dashed polyline of world points.
    fn dashed(&mut self, pts: &[P2], style: &ShapeStyle, on: f64, off: f64) -> DResult {
        let mut phase = 0.0; // distance into the current on+off period
        let period = on + off;
        let mut prev: Option<[f64; 2]> = None;
        for &p in pts {
            let Some(q) = self.px(p) else {
                prev = None;
                continue;
            };
            if let Some(a) = prev {
                let len = ((q[0] - a[0]).powi(2) + (q[1] - a[1]).powi(2)).sqrt();
                if !(len.is_finite()) || len > 1e5 {
                    // Absurdly long: draw it solid (clipped) instead of dashing.
                    self.path_px(&[a, q], style)?;
                } else {
                    // Bounded: every iteration ends a dash or a gap (steps of at least 1e-6 px,
                    // and the phase snaps to the boundary it reached, so rounding cannot stall).
                    let mut s = 0.0;
                    let max_iter = 2 * (len / period.max(1e-6)).ceil() as usize + 4;
                    for _ in 0..max_iter {
                        if s >= len {
                            break;
                        }
                        let in_on = phase < on;
                        let step = (if in_on { on - phase } else { period - phase }).max(1e-6);
                        let e = (s + step).min(len);
                        if in_on {
                            let at = |t: f64| [a[0] + (q[0] - a[0]) * t / len, a[1] + (q[1] - a[1]) * t / len];
                            self.path_px(&[at(s), at(e)], style)?;
                        }
                        phase = if e - s >= step {
                            if in_on {
                                on
                            } else {
                                0.0
                            }
                        } else {
                            (phase + (e - s)) % period
                        };
                        s = e;
                    }
                }
            }
            prev = Some(q);
        }
        Ok(())
    }

    fn circle(&mut self, p: P2, r: f64, style: &ShapeStyle) -> DResult {
        if let Some(q) = self.px(p) {
            if self.near_map(q, r) {
                self.be.draw_circle(ipt(q), r.round().max(1.0) as u32, style, style.filled).be()?;
            }
        }
        Ok(())
    }

    fn polygon_px(&mut self, pts: &[[f64; 2]], style: &ShapeStyle) -> DResult {
        if pts.iter().all(|q| self.near_map(*q, 0.0)) {
            if style.filled {
                self.be.fill_polygon(pts.iter().map(|&q| ipt(q)), style).be()?;
            } else {
                let mut closed = pts.to_vec();
                closed.push(pts[0]);
                self.path_px(&closed, style)?;
            }
        }
        Ok(())
    }

    /// A filled triangle pointing along `heading` (world radians) centred at `q`.
    fn triangle_px(&mut self, q: [f64; 2], heading: f64, len: f64, style: &ShapeStyle) -> DResult {
        let h = if heading.is_finite() { heading } else { std::f64::consts::FRAC_PI_2 };
        let (c, s) = (h.cos(), -h.sin());
        let tip = [q[0] + c * len * 0.6, q[1] + s * len * 0.6];
        let back = [q[0] - c * len * 0.4, q[1] - s * len * 0.4];
        let (nx, ny) = (-s * len * 0.4, c * len * 0.4);
        let tri = [tip, [back[0] + nx, back[1] + ny], [back[0] - nx, back[1] - ny]];
        self.polygon_px(&tri, style)
    }

    /// An arrow from `q` along `heading` of `len` pixels with a filled head.
    fn arrow_px(&mut self, q: [f64; 2], heading: f64, len: f64, colour: [u8; 3], width: u32) -> DResult {
        if !heading.is_finite() {
            return Ok(());
        }
        let (c, s) = (heading.cos(), -heading.sin());
        let tip = [q[0] + c * len, q[1] + s * len];
        let head = (len * 0.45).max(4.0);
        let base = [tip[0] - c * head, tip[1] - s * head];
        self.path_px(&[q, base], &stroke(colour, width))?;
        let (nx, ny) = (-s * head * 0.5, c * head * 0.5);
        self.polygon_px(&[tip, [base[0] + nx, base[1] + ny], [base[0] - nx, base[1] - ny]], &fill(colour))
    }

    fn star_px(&mut self, q: [f64; 2], r: f64, colour: [u8; 3], edge: [u8; 3]) -> DResult {
        let pts: Vec<[f64; 2]> = (0..10)
            .map(|i| {
                let a = std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / 5.0;
                let rr = if i % 2 == 0 { r } else { r * 0.45 };
                [q[0] + rr * a.cos(), q[1] - rr * a.sin()]
            })
            .collect();
        self.polygon_px(&pts, &fill(colour))?;
        self.polygon_px(&pts, &stroke(edge, 1))
    }

    fn text(&mut self, s: &str, pos: (i32, i32), size: f64, colour: [u8; 3]) {
        let colour = rgb(colour);
        let style = TextStyle::from(font(size)).color(&colour);
        // Text is decoration: a font problem must not lose the picture.
        let _ = self.be.draw_text(s, &style, pos);
    }

    /// Layer 2: the true world, faint.
    fn truth(&mut self, input: &RenderInput) -> DResult {
        for o in input.obstacles {
            self.outline(o, &stroke_a(palette::OBSTACLE, 0.9, 1))?;
        }
        let wall = stroke(palette::WALL, 2);
        for w in input.walls {
            self.path(&w[..], &wall)?;
        }
        Ok(())
    }

    /// Layer 4: everything the run produced.
    fn overlays(&mut self, input: &RenderInput) -> DResult {
        let ppm = self.lay.px_per_m;
        let cell_px = grid_cell_m(&input.grid).unwrap_or(FALLBACK_CELL_M) * ppm;

        // Frontier cells: squares of one cell (at least 2 px).
        let side = cell_px.max(2.0);
        for &f in input.frontier_cells {
            if let Some(q) = self.px(f) {
                if self.near_map(q, 0.0) {
                    let a = [q[0] - side / 2.0, q[1] - side / 2.0];
                    let ul = (a[0].round() as i32, a[1].round() as i32);
                    let br = (ul.0 + side.round() as i32, ul.1 + side.round() as i32);
                    self.be.draw_rect(ul, br, &fill(palette::FRONTIER), true).be()?;
                }
            }
        }

        // Final camera cone.
        let (rp, rh) = input.robot;
        if let Some(q) = self.px(rp) {
            let (fov, range) = (input.camera_fov_rad, input.camera_range_m);
            if rh.is_finite() && fov.is_finite() && range.is_finite() && fov > 0.0 && range > 0.0 {
                let fov = fov.min(2.0 * std::f64::consts::PI);
                let n = 32;
                let mut pts = vec![q];
                for i in 0..=n {
                    let a = rh - fov / 2.0 + fov * i as f64 / n as f64;
                    pts.push([q[0] + range * ppm * a.cos(), q[1] - range * ppm * a.sin()]);
                }
                pts.push(q);
                self.path_px(&pts, &stroke(palette::CONE, 1))?;
            }
        }

        // Non-map points.
        for &p in input.nonmap_points {
            self.circle(p, 2.0, &fill(palette::NONMAP))?;
        }

        // Candidate viewpoints.
        for &(p, h) in input.viewpoints {
            if let Some(q) = self.px(p) {
                if self.near_map(q, 10.0) {
                    self.arrow_px(q, h, 9.0, palette::VIEWPOINT, 1)?;
                }
            }
        }

        // People.
        let pr = (PERSON_RADIUS_M * ppm).max(2.0);
        for &p in input.people {
            self.circle(p, pr, &fill_a(palette::PERSON, 0.35))?;
            self.circle(p, pr, &stroke(palette::PERSON, 1))?;
        }

        // Targets.
        for t in input.targets {
            self.outline(t, &stroke(palette::TARGET, 2))?;
        }

        // Planned path (dashed) and driven path.
        self.dashed(input.goal_path, &stroke(palette::GOAL, 2), 6.0, 4.0)?;
        self.path(input.trajectory, &stroke(palette::TRAJECTORY, 2))?;

        // Start pose.
        let (sp, sh) = input.start;
        if let Some(q) = self.px(sp) {
            if self.near_map(q, 12.0) {
                self.triangle_px(q, sh, 16.0, &fill(palette::START))?;
                self.triangle_px(q, sh, 16.0, &stroke([0, 90, 30], 1))?;
            }
        }

        // Where the target was detected.
        if let Some(fp) = input.found_at {
            if let Some(q) = self.px(fp) {
                if self.near_map(q, 10.0) {
                    self.star_px(q, 10.0, palette::FOUND, [120, 0, 0])?;
                    let (x, y) = ipt(q);
                    let pos = (x + 11, y - 16);
                    for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                        let halo = (pos.0 + dx, pos.1 + dy);
                        self.text("found", halo, LEGEND_FONT_PX + 1.0, palette::BACKGROUND);
                    }
                    self.text("found", pos, LEGEND_FONT_PX + 1.0, palette::FOUND);
                }
            }
        }

        // Goal pose.
        if let Some((gp, gh)) = input.goal {
            if let Some(q) = self.px(gp) {
                if self.near_map(q, 16.0) {
                    self.be.draw_circle(ipt(q), 4, &stroke(palette::GOAL, 2), false).be()?;
                    self.arrow_px(q, gh, 14.0, palette::GOAL, 2)?;
                }
            }
        }

        // Final robot pose.
        if let Some(q) = self.px(rp) {
            if self.near_map(q, 10.0) {
                let r = (0.2 * ppm).max(4.0);
                self.be.draw_circle(ipt(q), r.round() as u32, &fill(palette::TRAJECTORY), true).be()?;
                self.be.draw_circle(ipt(q), r.round() as u32, &stroke([0, 30, 110], 1), false).be()?;
                if rh.is_finite() {
                    let tip = [q[0] + rh.cos() * r, q[1] - rh.sin() * r];
                    self.path_px(&[q, tip], &stroke([255, 255, 255], 2))?;
                }
            }
        }

        // Frame around the map.
        let l = self.lay;
        self.be
            .draw_rect(
                (l.map_x0 as i32, l.map_y0 as i32),
                ((l.map_x0 + l.map_w) as i32 - 1, (l.map_y0 + l.map_h) as i32 - 1),
                &stroke(palette::FRAME, 1),
                false,
            )
            .be()?;
        Ok(())
    }

    fn title(&mut self, title: &str) {
        self.text(title, (LEGEND_PAD as i32, 8), TITLE_FONT_PX, palette::TEXT);
    }

    fn legend(&mut self, input: &RenderInput) -> DResult {
        let l = self.lay;
        // The legend is outside the map area: clip to the whole image.
        self.lo = [0.0, 0.0];
        self.hi = [l.width as f64, l.height as f64];
        let x0 = (l.map_x0 + l.map_w + LEGEND_PAD) as i32;
        let mut y = (l.map_y0 + LEGEND_PAD) as i32;
        let sw = 26; // swatch width
        let frame = stroke(palette::FRAME, 1);
        for row in legend_rows(input) {
            let cy = y + LEGEND_ROW_H as i32 / 2;
            let (ul, br) = ((x0, cy - 6), (x0 + sw, cy + 6));
            match row.swatch {
                Swatch::Fill(c) => {
                    self.be.draw_rect(ul, br, &fill(c), true).be()?;
                    self.be.draw_rect(ul, br, &frame, false).be()?;
                }
                Swatch::Outline(c) => {
                    self.be.draw_rect((ul.0 + 2, ul.1 + 1), (br.0 - 2, br.1 - 1), &stroke(c, 2), false).be()?;
                }
                Swatch::Line(c) => {
                    self.be.draw_path([(x0, cy + 3), (x0 + 9, cy - 3), (x0 + 17, cy + 2), (x0 + sw, cy - 3)], &stroke(c, 2)).be()?;
                }
                Swatch::Dots(c) => {
                    for (dx, dy) in [(4, -3), (12, 3), (20, -2)] {
                        self.be.draw_circle((x0 + dx, cy + dy), 2, &fill(c), true).be()?;
                    }
                }
                Swatch::Squares(c) => {
                    for k in 0..6 {
                        let (px, py) = (x0 + 2 + 4 * k, cy + if k % 2 == 0 { -1 } else { 1 });
                        self.be.draw_rect((px, py), (px + 3, py + 3), &fill(c), true).be()?;
                    }
                }
                Swatch::Circle(c) => {
                    let centre = (x0 + sw / 2, cy);
                    self.be.draw_circle(centre, 5, &fill_a(c, 0.35), true).be()?;
                    self.be.draw_circle(centre, 5, &stroke(c, 1), false).be()?;
                }
                Swatch::Arrow(c) => {
                    self.arrow_px([x0 as f64 + 4.0, cy as f64], 0.0, 18.0, c, 1)?;
                }
                Swatch::Triangle(c) => {
                    self.be.fill_polygon([(x0 + 20, cy), (x0 + 6, cy - 6), (x0 + 6, cy + 6)], &fill(c)).be()?;
                }
                Swatch::Robot => {
                    let apex = (x0 + 5, cy);
                    self.be.draw_path([(x0 + sw, cy - 7), apex, (x0 + sw, cy + 7)], &stroke(palette::CONE, 1)).be()?;
                    self.be.draw_circle(apex, 4, &fill(palette::TRAJECTORY), true).be()?;
                }
                Swatch::Goal => {
                    self.be.draw_line((x0, cy + 4), (x0 + 5, cy + 4), &stroke(palette::GOAL, 2)).be()?;
                    self.be.draw_line((x0 + 9, cy + 4), (x0 + 14, cy + 4), &stroke(palette::GOAL, 2)).be()?;
                    self.arrow_px([x0 as f64 + 16.0, cy as f64 + 4.0], 0.8, 12.0, palette::GOAL, 2)?;
                }
                Swatch::Star => {
                    self.star_px([(x0 + sw / 2) as f64, cy as f64], 8.0, palette::FOUND, [120, 0, 0])?;
                }
            }
            self.text(row.label, (x0 + sw + 8, cy - 5), LEGEND_FONT_PX, palette::TEXT);
            y += LEGEND_ROW_H as i32;
        }

        // Outcome (a simulated world only).
        y += 6;
        let status = match input.found_at {
            Some(p) if finite(p) => format!("Target FOUND at ({:.1}, {:.1})", p[0], p[1]),
            Some(_) => "Target FOUND".to_string(),
            None if has_world(input) => "Target NOT found".to_string(),
            None => String::new(),
        };
        let colour = if input.found_at.is_some() { palette::FOUND } else { [90, 90, 90] };
        self.text(&status, (x0, y + 5), LEGEND_FONT_PX + 1.0, colour);
        y += LEGEND_ROW_H as i32 + 4;

        // Scale bar: the largest "nice" length that fits in 150 px.
        let ppm = l.px_per_m;
        let metres = [100.0, 50.0, 20.0, 10.0, 5.0, 2.0, 1.0, 0.5, 0.2, 0.1].into_iter().find(|m| m * ppm <= 150.0).unwrap_or(0.1);
        let bar = (metres * ppm).round().max(1.0) as i32;
        let cy = y + 8;
        let ink = stroke(palette::TEXT, 1);
        self.be.draw_rect((x0, cy - 1), (x0 + bar, cy + 2), &fill(palette::TEXT), true).be()?;
        self.be.draw_line((x0, cy - 5), (x0, cy + 5), &ink).be()?;
        self.be.draw_line((x0 + bar, cy - 5), (x0 + bar, cy + 5), &ink).be()?;
        let label = if metres >= 1.0 { format!("{metres:.0} m") } else { format!("{metres:.1} m") };
        self.text(&label, (x0 + bar + 6, cy - 5), LEGEND_FONT_PX, palette::TEXT);
        y += LEGEND_ROW_H as i32;

        let cell = grid_cell_m(&input.grid).unwrap_or(FALLBACK_CELL_M);
        let note = format!("grid cell {cell:.2} m · north up");
        self.text(&note, (x0, y + 6), LEGEND_FONT_PX - 1.0, [90, 90, 90]);
        Ok(())
    }
}
