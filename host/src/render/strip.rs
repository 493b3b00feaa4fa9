//! Strip plots: one panel per series over time (`write_strip_plot`).

use std::io::{BufWriter, Write};
use std::path::Path;

use super::*;
use plotters::prelude::{BitMapBackend, DrawingBackend};
use plotters::style::TextStyle;

/// One panel of a strip plot: a title, the y-axis limit, and named columns of values.
pub struct StripPanel<'a> {
    /// Panel title (the setting, e.g. `apartment easy`).
    pub title: String,
    /// The y axis runs from 0 to this (the time limit).
    pub y_max: f64,
    /// Columns: a label (the planner) and its values (one dot each; the mean is a bar).
    pub columns: Vec<(&'a str, Vec<f64>)>,
}

/// Writes strip plots (one panel per entry, two panels per row) as a PNG: each value a dot, each
/// column's mean a bar, the y axis from 0 to the panel's `y_max` with the unit `y_label`.
pub fn write_strip_plot(path: &Path, title: &str, y_label: &str, panels: &[StripPanel]) -> Result<(), RenderError> {
    ensure_font();
    const PW: u32 = 460;
    const PH: u32 = 300;
    const TOP: u32 = 36;
    let cols = panels.len().clamp(1, 2) as u32;
    let rows = (panels.len() as u32).div_ceil(cols).max(1);
    let (w, h) = (PW * cols, TOP + PH * rows);
    let mut data = vec![255u8; (w * h * 3) as usize];
    {
        let mut be = BitMapBackend::with_buffer(&mut data, (w, h));
        let black = [0, 0, 0];
        let text = |be: &mut BitMapBackend, s: &str, pos: (i32, i32), size: f64| {
            let colour = rgb(black);
            let _ = be.draw_text(s, &TextStyle::from(font(size)).color(&colour), pos);
        };
        text(&mut be, title, (10, 8), TITLE_FONT_PX);
        for (k, p) in panels.iter().enumerate() {
            let (ox, oy) = ((k as u32 % cols * PW) as i32, (TOP + k as u32 / cols * PH) as i32);
            let (x0, x1, y0, y1) = (ox + 60, ox + PW as i32 - 15, oy + 28, oy + PH as i32 - 40);
            text(&mut be, &p.title, (ox + 60, oy + 6), LEGEND_FONT_PX + 1.0);
            be.draw_rect((x0, y0), (x1, y1), &stroke([120, 120, 120], 1), false).be()?;
            let y_max = if p.y_max.is_finite() && p.y_max > 0.0 { p.y_max } else { 1.0 };
            let ypx = |v: f64| y1 - ((v.clamp(0.0, y_max) / y_max) * (y1 - y0) as f64).round() as i32;
            for i in 0..=4 {
                let v = y_max * i as f64 / 4.0;
                let y = ypx(v);
                be.draw_line((x0 - 4, y), (x0, y), &stroke([120, 120, 120], 1)).be()?;
                text(&mut be, &format!("{v:.0}"), (ox + 22, y - 7), LEGEND_FONT_PX - 1.0);
            }
            text(&mut be, y_label, (ox + 4, oy + 6), LEGEND_FONT_PX - 2.0);
            let n = p.columns.len().max(1) as i32;
            let slot = (x1 - x0) / n;
            for (j, (label, values)) in p.columns.iter().enumerate() {
                let cx = x0 + slot * j as i32 + slot / 2;
                let colour = palette::SERIES[j % palette::SERIES.len()];
                for (i, &v) in values.iter().enumerate() {
                    if !v.is_finite() {
                        continue;
                    }
                    let jitter = ((i as i32 * 7) % 11 - 5) * 2;
                    be.draw_circle((cx + jitter, ypx(v)), 3, &fill_a(colour, 0.7), true).be()?;
                }
                let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
                if !finite.is_empty() {
                    let m = finite.iter().sum::<f64>() / finite.len() as f64;
                    be.draw_line((cx - slot / 3, ypx(m)), (cx + slot / 3, ypx(m)), &stroke(colour, 3)).be()?;
                }
                text(&mut be, label, (cx - 6 * label.len() as i32 / 2 - 4, y1 + 8), LEGEND_FONT_PX - 1.0);
            }
        }
        be.present().map_err(backend_err)?;
    }
    let img = RgbImage { width: w, height: h, data };
    let mut out = BufWriter::new(std::fs::File::create(path)?);
    encode_png(&mut out, &img)?;
    out.flush()?;
    Ok(())
}
