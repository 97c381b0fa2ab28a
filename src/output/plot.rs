//! A small line-chart renderer into an 8-bit RGB buffer, for the `compare-seq` plot: no
//! plotting dependency, text from a built-in 5x7 bitmap font.
//!
//! The font has the digits, `.`, `%`, `-`, `+`, space and the capital letters
//! `A C D E F I K L M N O R S T X` (lower-case letters are drawn as capitals); any other
//! character is drawn as a blank cell.

use crate::{Error, Result};
use std::path::Path;

/// An 8-bit RGB image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Canvas {
    pub width: u32,
    pub height: u32,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
}

/// Width of a glyph cell (5 pixels and a 1-pixel gap) at scale 1.
pub const GLYPH_ADVANCE: u32 = 6;
/// Height of a glyph at scale 1.
pub const GLYPH_HEIGHT: u32 = 7;

/// The rows of a 5x7 glyph, top first; bit 4 is the leftmost column.
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        _ => [0; 7],
    }
}

/// Width in pixels of `text` drawn by [`Canvas::text`] at `scale` (no trailing gap).
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    (n * GLYPH_ADVANCE).saturating_sub(1) * scale
}

impl Canvas {
    /// A `width x height` canvas filled with `background`.
    pub fn new(width: u32, height: u32, background: [u8; 3]) -> Canvas {
        let rgb = background.repeat((width * height) as usize);
        Canvas { width, height, rgb }
    }

    /// The colour at (x, y), or `None` outside the canvas.
    pub fn get(&self, x: i64, y: i64) -> Option<[u8; 3]> {
        self.index(x, y)
            .map(|i| [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        (x >= 0 && y >= 0 && x < i64::from(self.width) && y < i64::from(self.height))
            .then(|| 3 * (y as usize * self.width as usize + x as usize))
    }

    /// Sets one pixel; points outside the canvas are ignored.
    pub fn set(&mut self, x: i64, y: i64, color: [u8; 3]) {
        if let Some(i) = self.index(x, y) {
            self.rgb[i..i + 3].copy_from_slice(&color);
        }
    }

    /// Fills the `w x h` rectangle whose top-left corner is (x, y), clipped.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: u32, h: u32, color: [u8; 3]) {
        for yy in y..y + i64::from(h) {
            for xx in x..x + i64::from(w) {
                self.set(xx, yy, color);
            }
        }
    }

    /// A 1-pixel line from (x0, y0) to (x1, y1), both ends included (Bresenham), clipped.
    pub fn line(&mut self, (x0, y0): (i64, i64), (x1, y1): (i64, i64), color: [u8; 3]) {
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
        let (mut x, mut y, mut err) = (x0, y0, dx + dy);
        loop {
            self.set(x, y, color);
            if x == x1 && y == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// Draws `text` with its top-left corner at (x, y), each font pixel `scale` x `scale`.
    pub fn text(&mut self, x: i64, y: i64, text: &str, scale: u32, color: [u8; 3]) {
        let s = i64::from(scale);
        for (k, c) in text.chars().enumerate() {
            let x0 = x + k as i64 * i64::from(GLYPH_ADVANCE) * s;
            for (row, bits) in glyph(c).iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        self.fill_rect(x0 + col * s, y + row as i64 * s, scale, scale, color);
                    }
                }
            }
        }
    }

    /// Writes the canvas as a PNG, atomically.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        super::write_png(path, self.width, self.height, &self.rgb)
    }
}

/// One curve of a [`line_chart`].
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text (see the module docs for the characters the font has).
    pub label: String,
    pub color: [u8; 3],
    /// One value per x position; `None` and non-finite values leave a gap.
    pub values: Vec<Option<f64>>,
    /// Tick labels as percentages (value × 100, with `%`).
    pub percent: bool,
}

const BACKGROUND: [u8; 3] = [255, 255, 255];
const AXIS: [u8; 3] = [40, 40, 40];
const TEXT_SCALE: u32 = 2;

/// Where a chart's plotting area lies: the rectangle inside the axes.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Layout {
    left: i64,
    right: i64,
    top: i64,
    bottom: i64,
}

impl Layout {
    const MARGIN_X: i64 = 90;
    const MARGIN_TOP: i64 = 40;
    const MARGIN_BOTTOM: i64 = 44;

    fn new(width: u32, height: u32) -> Layout {
        Layout {
            left: Self::MARGIN_X,
            right: i64::from(width) - 1 - Self::MARGIN_X,
            top: Self::MARGIN_TOP,
            bottom: i64::from(height) - 1 - Self::MARGIN_BOTTOM,
        }
    }

    /// Pixel column of point `i` of `n`.
    fn x(&self, i: usize, n: usize) -> i64 {
        if n <= 1 {
            return (self.left + self.right) / 2;
        }
        self.left + ((self.right - self.left) as f64 * i as f64 / (n - 1) as f64).round() as i64
    }

    /// Pixel row of `v` on the scale `lo..hi`.
    fn y(&self, v: f64, (lo, hi): (f64, f64)) -> i64 {
        let t = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
        self.bottom - ((self.bottom - self.top) as f64 * t).round() as i64
    }
}

/// The y scale of a series: from min(0, smallest value) to the largest value (an empty or
/// flat series gets a scale one unit high).
fn scale_of(values: &[Option<f64>]) -> (f64, f64) {
    let finite = values.iter().flatten().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((0.0f64, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if hi > lo { (lo, hi) } else { (lo, lo + 1.0) }
}

/// A compact tick label: 3 significant digits, as a percentage when `percent`.
fn tick_label(v: f64, percent: bool) -> String {
    let v = if percent { v * 100.0 } else { v };
    let a = v.abs();
    let digits = if a >= 100.0 || a == 0.0 {
        0
    } else if a >= 10.0 {
        1
    } else if a >= 1.0 {
        2
    } else if a >= 0.01 {
        3
    } else {
        return format!("{v:.1e}{}", if percent { "%" } else { "" })
            .replace("e-", "E-")
            .replace('e', "E");
    };
    format!("{v:.digits$}{}", if percent { "%" } else { "" })
}

/// Draws a line chart: x runs over the points `first_x, first_x + 1, …` (one per value),
/// with the first and last x as tick labels and "FRAME" below. The first series is
/// measured on the left axis, the second (optional) on the right axis, each from
/// min(0, its smallest value) to its largest value, with those two values as tick labels
/// in the series' colour. A legend of coloured boxes with the series' labels runs along
/// the top. Errors when there is not one or two series, or the canvas is smaller than
/// 320x200.
pub fn line_chart(width: u32, height: u32, first_x: u32, series: &[Series]) -> Result<Canvas> {
    if series.is_empty() || series.len() > 2 {
        return Err(Error::Usage(format!(
            "a line chart takes one or two series, not {}",
            series.len()
        )));
    }
    if width < 320 || height < 200 {
        return Err(Error::Usage(format!(
            "a line chart needs at least 320x200 pixels, not {width}x{height}"
        )));
    }
    let mut canvas = Canvas::new(width, height, BACKGROUND);
    let layout = Layout::new(width, height);
    let glyph_h = i64::from(GLYPH_HEIGHT * TEXT_SCALE);
    let n = series.iter().map(|s| s.values.len()).max().unwrap_or(0);

    // Axes: left, right (when there is a second series) and bottom.
    let (l, r, t, b) = (layout.left, layout.right, layout.top, layout.bottom);
    canvas.line((l, t), (l, b), AXIS);
    canvas.line((l, b), (r, b), AXIS);
    if series.len() == 2 {
        canvas.line((r, t), (r, b), AXIS);
    }

    // x ticks: first and last point.
    let last_x = first_x.saturating_add(n.saturating_sub(1) as u32);
    let x_ticks: &[(usize, u32)] = if n > 1 {
        &[(0, first_x), (n - 1, last_x)]
    } else {
        &[(0, first_x)]
    };
    for &(i, label) in x_ticks {
        let x = layout.x(i, n);
        canvas.line((x, b), (x, b + 4), AXIS);
        let text = label.to_string();
        let w = i64::from(text_width(&text, TEXT_SCALE));
        canvas.text(x - w / 2, b + 8, &text, TEXT_SCALE, AXIS);
    }
    let title = "FRAME";
    let w = i64::from(text_width(title, TEXT_SCALE));
    canvas.text((l + r - w) / 2, b + 8, title, TEXT_SCALE, AXIS);

    let mut legend_x = l;
    for (k, s) in series.iter().enumerate() {
        let scale = scale_of(&s.values);
        // y ticks at the scale's ends, on the series' own axis.
        let axis_x = if k == 0 { l } else { r };
        for v in [scale.0, scale.1] {
            let y = layout.y(v, scale);
            let text = tick_label(v, s.percent);
            let w = i64::from(text_width(&text, TEXT_SCALE));
            let (tick_end, text_x) = if k == 0 {
                (axis_x - 4, axis_x - 8 - w)
            } else {
                (axis_x + 4, axis_x + 8)
            };
            canvas.line((axis_x, y), (tick_end, y), AXIS);
            canvas.text(text_x, y - glyph_h / 2, &text, TEXT_SCALE, s.color);
        }
        // The curve: segments between consecutive finite points, a dot for lone points.
        let point = |i: usize| {
            s.values
                .get(i)
                .copied()
                .flatten()
                .filter(|v| v.is_finite())
                .map(|v| (layout.x(i, n), layout.y(v, scale)))
        };
        for i in 0..s.values.len() {
            match (point(i), i.checked_sub(1).and_then(point)) {
                (Some(p), Some(prev)) => {
                    canvas.line(prev, p, s.color);
                    canvas.line((prev.0, prev.1 - 1), (p.0, p.1 - 1), s.color);
                }
                (Some(p), None) => canvas.fill_rect(p.0 - 1, p.1 - 1, 3, 3, s.color),
                _ => {}
            }
        }
        // Legend: a coloured box and the label.
        let box_y = (t - glyph_h) / 2;
        canvas.fill_rect(legend_x, box_y, glyph_h as u32, glyph_h as u32, s.color);
        canvas.text(legend_x + glyph_h + 6, box_y, &s.label, TEXT_SCALE, s.color);
        legend_x += glyph_h + 6 + i64::from(text_width(&s.label, TEXT_SCALE)) + 24;
    }
    Ok(canvas)
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: [u8; 3] = [255, 0, 0];

    #[test]
    fn lines_set_the_bresenham_pixels() {
        let mut c = Canvas::new(8, 6, [0; 3]);
        c.line((0, 0), (4, 2), RED);
        let set: Vec<(i64, i64)> = (0..6)
            .flat_map(|y| (0..8).map(move |x| (x, y)))
            .filter(|&(x, y)| c.get(x, y) == Some(RED))
            .collect();
        assert_eq!(set, vec![(0, 0), (1, 1), (2, 1), (3, 2), (4, 2)]);
        // Clipped, not a panic.
        c.line((-5, -5), (20, 20), RED);
        assert_eq!(c.get(5, 5), Some(RED));
        assert_eq!(c.get(8, 0), None);
    }

    #[test]
    fn glyphs_draw_their_bits() {
        let mut c = Canvas::new(12, 7, [0; 3]);
        c.text(0, 0, "1-", 1, RED);
        let lit = |x0: i64| {
            (0..7)
                .flat_map(|y| (x0..x0 + 6).map(move |x| (x, y)))
                .filter(|&(x, y)| c.get(x, y) == Some(RED))
                .count()
        };
        assert_eq!(lit(0), 10, "'1' has 10 pixels");
        assert_eq!(lit(6), 5, "'-' has 5 pixels");
        assert_eq!(c.get(6, 3), Some(RED));
        assert_eq!(text_width("12%", 2), (3 * 6 - 1) * 2);
    }

    #[test]
    fn a_flat_polyline_lands_on_the_expected_rows() {
        let (w, h) = (400, 240);
        let s = Series {
            label: "REL RMSE".into(),
            color: RED,
            values: vec![Some(0.5), Some(1.0), Some(0.5)],
            percent: true,
        };
        let c = line_chart(w, h, 1, &[s]).expect("chart");
        assert_eq!(
            (c.width, c.height, c.rgb.len()),
            (w, h, (w * h * 3) as usize)
        );
        let layout = Layout::new(w, h);
        // Scale 0..1: 0.5 is half way up, 1.0 at the top of the plot area.
        // The plot area is x 90..=309, y 40..=195 (margins 90, 40 and 44).
        assert_eq!(
            (layout.left, layout.right, layout.top, layout.bottom),
            (90, 309, 40, 195)
        );
        assert_eq!(
            (layout.x(0, 3), layout.x(1, 3), layout.x(2, 3)),
            (90, 200, 309)
        );
        let mid = layout.y(0.5, (0.0, 1.0));
        assert_eq!(mid, 195 - 78); // 155 / 2 = 77.5 rounds to 78
        assert_eq!(c.get(layout.x(0, 3), mid), Some(RED));
        assert_eq!(c.get(layout.x(1, 3), layout.top), Some(RED));
        assert_eq!(c.get(layout.x(2, 3), mid), Some(RED));
        // Nothing drawn in the middle of the empty space below the curve.
        assert_eq!(c.get(layout.x(1, 3), layout.bottom - 5), Some(BACKGROUND));
        assert!(line_chart(100, 100, 0, &[]).is_err());
    }

    #[test]
    fn tick_labels() {
        assert_eq!(tick_label(0.0, true), "0%");
        assert_eq!(tick_label(0.1234, true), "12.3%");
        assert_eq!(tick_label(0.05, true), "5.00%");
        assert_eq!(tick_label(0.00005, true), "5.0E-3%");
        assert_eq!(tick_label(2.0, false), "2.00");
        assert_eq!(tick_label(1e-6, false), "1.0E-6");
    }
}
