//! A map's image as 8-bit grey levels: PGM (`P5` binary, `P2` ASCII; any maxval up to 255,
//! rescaled to 0–255) or PNG (any colour type; colour channels averaged, alpha ignored, 16-bit
//! samples cut to 8). The format is recognised by its first bytes, not by the file's name.

use super::MAX_PIXELS;

/// Grey levels, row by row from the image's top.
pub struct Gray {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<u8>,
}

/// Decodes `data`; the error is the problem, without the file's name.
pub fn decode(data: &[u8]) -> Result<Gray, String> {
    match data {
        [b'P', b'5', ..] => pgm(data, true),
        [b'P', b'2', ..] => pgm(data, false),
        [0x89, b'P', b'N', b'G', ..] => png(data),
        [b'P', d, ..] if d.is_ascii_digit() => {
            Err(format!("a P{} PNM image: only greyscale PGM (P5 binary or P2 ASCII) and PNG maps are read", *d as char))
        }
        [] => Err("the image is empty".into()),
        _ => Err("not a PGM (P5 or P2) or PNG image".into()),
    }
}

fn check_size(width: usize, height: usize) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("the image is {width} x {height} pixels: a map needs at least one"));
    }
    if width.checked_mul(height).is_none_or(|n| n > MAX_PIXELS) {
        return Err(format!("the image is {width} x {height} pixels, more than the {MAX_PIXELS} a map may have"));
    }
    Ok(())
}

/// Reads PGM header tokens: whitespace-separated, `#` comments to the end of the line.
struct Header<'a> {
    data: &'a [u8],
    pos: usize,
}

impl Header<'_> {
    fn skip_space(&mut self) {
        while let Some(&b) = self.data.get(self.pos) {
            if b == b'#' {
                while self.data.get(self.pos).is_some_and(|&b| b != b'\n' && b != b'\r') {
                    self.pos += 1;
                }
            } else if b.is_ascii_whitespace() {
                self.pos += 1;
            } else {
                break;
            }
        }
    }

    /// The next unsigned decimal number; `what` names it in the error.
    fn number(&mut self, what: &str) -> Result<usize, String> {
        self.skip_space();
        let start = self.pos;
        let mut v: usize = 0;
        while let Some(&b) = self.data.get(self.pos).filter(|b| b.is_ascii_digit()) {
            v = v
                .checked_mul(10)
                .and_then(|v| v.checked_add((b - b'0') as usize))
                .ok_or_else(|| format!("the PGM's {what} is too large"))?;
            self.pos += 1;
        }
        if self.pos == start {
            return Err(match self.data.get(self.pos) {
                None => format!("the PGM ends before its {what}"),
                Some(b) => format!("the PGM's {what} is not a number (byte {:#04x} at offset {})", b, self.pos),
            });
        }
        Ok(v)
    }
}

fn pgm(data: &[u8], binary: bool) -> Result<Gray, String> {
    let mut h = Header { data, pos: 2 };
    if !data.get(2).is_some_and(|b| b.is_ascii_whitespace() || *b == b'#') {
        return Err("not a PGM image: no whitespace after the magic number".into());
    }
    let width = h.number("width")?;
    let height = h.number("height")?;
    let maxval = h.number("maximum value")?;
    check_size(width, height)?;
    if maxval == 0 || maxval > 65535 {
        return Err(format!("the PGM's maximum value {maxval} is outside 1..65535"));
    }
    if maxval > 255 {
        return Err(format!("a 16-bit PGM (maximum value {maxval}): map images are 8-bit"));
    }
    let n = width * height;
    let scale = |v: usize| if maxval == 255 { v as u8 } else { ((v.min(maxval) * 255 + maxval / 2) / maxval) as u8 };
    let mut pixels = Vec::with_capacity(n);
    if binary {
        // Exactly one whitespace byte ends the header.
        if !h.data.get(h.pos).is_some_and(|b| b.is_ascii_whitespace()) {
            return Err("the PGM's header does not end with whitespace after the maximum value".into());
        }
        let body = &data[h.pos + 1..];
        if body.len() < n {
            return Err(format!("the PGM is truncated: {} of its {width} x {height} = {n} pixels", body.len()));
        }
        pixels.extend(body[..n].iter().map(|&v| scale(v as usize)));
    } else {
        for k in 0..n {
            let v = h.number("pixels").map_err(|e| {
                if h.pos >= data.len() {
                    format!("the PGM is truncated: {k} of its {width} x {height} = {n} pixels")
                } else {
                    format!("{e} (pixel {k})")
                }
            })?;
            if v > maxval {
                return Err(format!("the PGM's pixel {k} is {v}, above its maximum value {maxval}"));
            }
            pixels.push(scale(v));
        }
    }
    Ok(Gray { width, height, pixels })
}

fn png(data: &[u8]) -> Result<Gray, String> {
    let bad = |e: png::DecodingError| format!("not a readable PNG image: {e}");
    let mut dec = png::Decoder::new_with_limits(data, png::Limits { bytes: 4 * MAX_PIXELS });
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(bad)?;
    let (w, h) = (reader.info().width as usize, reader.info().height as usize);
    check_size(w, h)?;
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let out = reader.next_frame(&mut buf).map_err(bad)?;
    let (width, height) = (out.width as usize, out.height as usize);
    check_size(width, height)?;
    let (channels, colour) = match out.color_type {
        png::ColorType::Grayscale => (1, 1),
        png::ColorType::GrayscaleAlpha => (2, 1),
        png::ColorType::Rgb => (3, 3),
        png::ColorType::Rgba => (4, 3),
        // normalize_to_color8 expands palettes; should one remain, say so.
        png::ColorType::Indexed => return Err("a palette PNG the decoder did not expand".into()),
    };
    if out.bit_depth != png::BitDepth::Eight || out.line_size < width * channels || buf.len() < out.line_size * height {
        return Err(format!("a PNG the decoder gave as {:?} {:?} samples: expected 8-bit", out.color_type, out.bit_depth));
    }
    let mut pixels = Vec::with_capacity(width * height);
    for row in buf.chunks(out.line_size).take(height) {
        for px in row[..width * channels].chunks_exact(channels) {
            let sum: usize = px[..colour].iter().map(|&v| v as usize).sum();
            // Truncated, as map_server averages.
            pixels.push((sum / colour) as u8);
        }
    }
    Ok(Gray { width, height, pixels })
}
