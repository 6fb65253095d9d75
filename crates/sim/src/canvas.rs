//! A small RGB raster for pictures of a world: filled discs, rectangles and
//! thick lines, with a [`View`] from world centimetres to pixels.
//!
//! The Python environments' `render_mode="rgb_array"` draws an arena or a
//! battlefield many times a second; this does it in a few hundred
//! microseconds with no font or backend behind it. Shapes are covered by
//! pixel centres (no anti-aliasing), which keeps a picture a pure function of
//! the world: the same state gives the same bytes.

use crate::Vec2;

/// An RGB8 picture, row-major, top row first.
#[derive(Debug, Clone)]
pub struct Canvas {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

impl Canvas {
    /// A canvas filled with `background`. A side of zero gives an empty picture.
    pub fn new(width: usize, height: usize, background: [u8; 3]) -> Canvas {
        let mut rgb = Vec::with_capacity(width.saturating_mul(height).saturating_mul(3));
        for _ in 0..width.saturating_mul(height) {
            rgb.extend_from_slice(&background);
        }
        Canvas { width, height, rgb }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The colour at a pixel, if it is on the canvas.
    pub fn pixel(&self, x: usize, y: usize) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y * self.width + x) * 3;
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    /// The pixels, three bytes each, row-major.
    pub fn into_rgb(self) -> Vec<u8> {
        self.rgb
    }

    /// Colours every pixel whose centre lies in the rectangle (pixel coordinates,
    /// corners in any order).
    pub fn fill_rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, color: [u8; 3]) {
        let (xs, xe) = self.span(x0.min(x1), x0.max(x1), self.width);
        let (ys, ye) = self.span(y0.min(y1), y0.max(y1), self.height);
        for y in ys..ye {
            for x in xs..xe {
                self.put(x, y, color);
            }
        }
    }

    /// Colours every pixel whose centre lies in the disc.
    pub fn fill_disc(&mut self, cx: f64, cy: f64, r: f64, color: [u8; 3]) {
        if r.is_nan() || r <= 0.0 {
            return;
        }
        let (ys, ye) = self.span(cy - r, cy + r, self.height);
        for y in ys..ye {
            let dy = y as f64 + 0.5 - cy;
            let half = (r * r - dy * dy).max(0.0).sqrt();
            let (xs, xe) = self.span(cx - half, cx + half, self.width);
            for x in xs..xe {
                self.put(x, y, color);
            }
        }
    }

    /// Colours every pixel whose centre is within `width / 2` of the segment.
    pub fn line(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, width: f64, color: [u8; 3]) {
        let r = width / 2.0;
        if r.is_nan() || r <= 0.0 {
            return;
        }
        let (dx, dy) = (x1 - x0, y1 - y0);
        let len2 = dx * dx + dy * dy;
        let (xs, xe) = self.span(x0.min(x1) - r, x0.max(x1) + r, self.width);
        let (ys, ye) = self.span(y0.min(y1) - r, y0.max(y1) + r, self.height);
        for y in ys..ye {
            let py = y as f64 + 0.5;
            for x in xs..xe {
                let px = x as f64 + 0.5;
                let t = if len2 > 0.0 {
                    (((px - x0) * dx + (py - y0) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (px - (x0 + t * dx), py - (y0 + t * dy));
                if ex * ex + ey * ey <= r * r {
                    self.put(x, y, color);
                }
            }
        }
    }

    /// The pixel indices whose centres lie in `[lo, hi]`, cut to `0..limit`.
    /// Non-finite bounds cover nothing, so a body that left the world is not drawn.
    fn span(&self, lo: f64, hi: f64, limit: usize) -> (usize, usize) {
        if !(lo.is_finite() && hi.is_finite()) || hi < lo {
            return (0, 0);
        }
        // A centre at i + 0.5 is covered when lo <= i + 0.5 <= hi.
        let start = (lo - 0.5).ceil().max(0.0);
        let end = ((hi - 0.5).floor() + 1.0).min(limit as f64);
        if end <= start {
            return (0, 0);
        }
        (start as usize, end as usize)
    }

    fn put(&mut self, x: usize, y: usize, color: [u8; 3]) {
        let i = (y * self.width + x) * 3;
        self.rgb[i..i + 3].copy_from_slice(&color);
    }
}

/// Maps a world rectangle (centimetres, y up) onto a picture (pixels, y down),
/// keeping the aspect ratio and centring what is left over.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    scale: f64,
    origin: Vec2,
    offset: (f64, f64),
    height: f64,
}

impl View {
    /// The largest view of `world_min..world_max` that fits `width` x `height`.
    /// A degenerate or non-finite rectangle gives a scale of zero: everything lands
    /// on one point rather than a division by zero.
    pub fn fit(world_min: Vec2, world_max: Vec2, width: usize, height: usize) -> View {
        let (w, h) = (world_max.x - world_min.x, world_max.y - world_min.y);
        let scale = (width as f64 / w).min(height as f64 / h);
        let scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            0.0
        };
        let offset = (
            (width as f64 - w * scale) / 2.0,
            (height as f64 - h * scale) / 2.0,
        );
        View {
            scale,
            origin: world_min,
            offset: if offset.0.is_finite() && offset.1.is_finite() {
                offset
            } else {
                (0.0, 0.0)
            },
            height: height as f64,
        }
    }

    /// Pixels per centimetre.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// A world point in pixel coordinates.
    pub fn to_pixel(&self, p: Vec2) -> (f64, f64) {
        let x = self.offset.0 + (p.x - self.origin.x) * self.scale;
        let y = self.height - (self.offset.1 + (p.y - self.origin.y) * self.scale);
        (x, y)
    }

    /// A world length in pixels.
    pub fn length(&self, cm: f64) -> f64 {
        cm * self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: [u8; 3] = [255, 0, 0];

    fn count(c: &Canvas, color: [u8; 3]) -> usize {
        (0..c.height())
            .flat_map(|y| (0..c.width()).map(move |x| (x, y)))
            .filter(|&(x, y)| c.pixel(x, y) == Some(color))
            .count()
    }

    #[test]
    fn a_disc_covers_about_its_area_and_stays_on_the_canvas() {
        let mut c = Canvas::new(40, 30, [0; 3]);
        c.fill_disc(20.0, 15.0, 10.0, RED);
        let area = count(&c, RED) as f64;
        assert!((area - std::f64::consts::PI * 100.0).abs() < 20.0, "{area}");
        // Half off the canvas: drawn where it overlaps, nothing out of bounds.
        c.fill_disc(-5.0, 29.0, 10.0, [0, 255, 0]);
        assert!(count(&c, [0, 255, 0]) > 0);
        assert_eq!(c.clone().into_rgb().len(), 40 * 30 * 3);
    }

    #[test]
    fn shapes_with_non_finite_or_empty_geometry_draw_nothing_and_do_not_panic() {
        let mut c = Canvas::new(10, 10, [0; 3]);
        c.fill_disc(f64::NAN, 5.0, 3.0, RED);
        c.fill_disc(5.0, 5.0, f64::NAN, RED);
        c.fill_disc(5.0, 5.0, -1.0, RED);
        c.fill_rect(f64::NEG_INFINITY, 0.0, 5.0, f64::INFINITY, RED);
        c.line(0.0, 0.0, f64::NAN, 3.0, 2.0, RED);
        c.line(0.0, 0.0, 9.0, 9.0, f64::INFINITY, RED);
        assert_eq!(count(&c, RED), 0);
        let mut empty = Canvas::new(0, 7, [1, 2, 3]);
        empty.fill_rect(0.0, 0.0, 100.0, 100.0, RED);
        assert!(empty.into_rgb().is_empty());
    }

    #[test]
    fn a_rectangle_and_a_line_cover_the_pixels_whose_centres_they_hold() {
        let mut c = Canvas::new(10, 10, [0; 3]);
        c.fill_rect(7.0, 8.0, 2.0, 3.0, RED);
        assert_eq!(count(&c, RED), 25);
        assert_eq!(c.pixel(2, 3), Some(RED));
        assert_eq!(c.pixel(7, 8), Some([0; 3]));
        let mut l = Canvas::new(10, 10, [0; 3]);
        l.line(0.0, 5.5, 10.0, 5.5, 1.0, RED);
        assert_eq!(count(&l, RED), 10, "one row of a horizontal line 1 px wide");
        // A segment of zero length is a dot.
        l.line(2.5, 2.5, 2.5, 2.5, 1.0, [0, 0, 255]);
        assert_eq!(l.pixel(2, 2), Some([0, 0, 255]));
    }

    #[test]
    fn a_view_keeps_the_aspect_ratio_centres_the_world_and_puts_y_up() {
        let v = View::fit(
            Vec2 { x: -50.0, y: -25.0 },
            Vec2 { x: 50.0, y: 25.0 },
            200,
            200,
        );
        assert_eq!(v.scale(), 2.0);
        assert_eq!(v.to_pixel(Vec2 { x: 0.0, y: 0.0 }), (100.0, 100.0));
        assert_eq!(v.to_pixel(Vec2 { x: -50.0, y: 25.0 }), (0.0, 50.0));
        assert_eq!(v.length(3.0), 6.0);
        let flat = View::fit(Vec2 { x: 0.0, y: 0.0 }, Vec2 { x: 0.0, y: 0.0 }, 10, 10);
        assert_eq!(flat.scale(), 0.0);
        assert!(flat.to_pixel(Vec2 { x: 3.0, y: 4.0 }).0.is_finite());
    }
}
