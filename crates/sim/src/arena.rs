//! The arena's geometry: a rectangle with rounded corners, centred on the origin.

use crate::config::ArenaConfig;
use crate::types::Vec2;

/// Thickness of the wall boxes outside the arena, cm. Far more than anything moves
/// in one physics step (1.4 cm at full speed), so nothing tunnels through.
pub(crate) const WALL_THICKNESS: f64 = 10.0;

/// Longest chord used to approximate a rounded corner, cm. The chords' sagitta at
/// a 15 cm radius is under 0.02 cm.
pub(crate) const ARC_CHORD: f64 = 1.5;

/// Inner outline of the arena, with distance queries.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Arena {
    hw: f64,
    hh: f64,
    r: f64,
}

/// A wall piece: a box of `half_extents` centred at `centre`, rotated by `angle`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WallBox {
    pub centre: Vec2,
    pub half_extents: Vec2,
    pub angle: f64,
}

impl Arena {
    pub fn new(cfg: &ArenaConfig) -> Arena {
        Arena {
            hw: cfg.width / 2.0,
            hh: cfg.height / 2.0,
            r: cfg.corner_radius,
        }
    }

    pub fn half_width(&self) -> f64 {
        self.hw
    }

    pub fn half_height(&self) -> f64 {
        self.hh
    }

    pub fn corner_radius(&self) -> f64 {
        self.r
    }

    /// Signed distance to the inner wall surface: negative inside, positive outside.
    pub fn signed_distance(&self, p: Vec2) -> f64 {
        let qx = p.x.abs() - (self.hw - self.r);
        let qy = p.y.abs() - (self.hh - self.r);
        let outside = qx.max(0.0).hypot(qy.max(0.0));
        outside + qx.max(qy).min(0.0) - self.r
    }

    /// Whether a disc of radius `margin` around `p` lies wholly inside (never for a
    /// non-finite point).
    pub fn contains(&self, p: Vec2, margin: f64) -> bool {
        p.x.is_finite() && p.y.is_finite() && self.signed_distance(p) <= -margin
    }

    /// The nearest point at least `margin` inside the walls (`p` itself if it already is).
    pub fn clamp_inside(&self, p: Vec2, margin: f64) -> Vec2 {
        if self.contains(p, margin) {
            return p;
        }
        let ix = (self.hw - margin).max(0.0);
        let iy = (self.hh - margin).max(0.0);
        let r = (self.r - margin).max(0.0);
        let (cx, cy) = (ix - r, iy - r);
        let (ax, ay) = (p.x.abs(), p.y.abs());
        let (mut qx, mut qy) = (ax.min(ix), ay.min(iy));
        if ax > cx && ay > cy && r > 0.0 {
            // Corner region: project onto the inset corner circle.
            let (dx, dy) = (ax - cx, ay - cy);
            let d = dx.hypot(dy);
            if d > r {
                qx = cx + dx / d * r;
                qy = cy + dy / d * r;
            }
        }
        Vec2::new(qx.copysign(p.x), qy.copysign(p.y))
    }

    /// Boxes outside the arena whose inner faces form its walls.
    pub fn wall_boxes(&self) -> Vec<WallBox> {
        let t = WALL_THICKNESS;
        let mut boxes = vec![
            WallBox {
                centre: Vec2::new(0.0, self.hh + t / 2.0),
                half_extents: Vec2::new(self.hw + t, t / 2.0),
                angle: 0.0,
            },
            WallBox {
                centre: Vec2::new(0.0, -self.hh - t / 2.0),
                half_extents: Vec2::new(self.hw + t, t / 2.0),
                angle: 0.0,
            },
            WallBox {
                centre: Vec2::new(self.hw + t / 2.0, 0.0),
                half_extents: Vec2::new(t / 2.0, self.hh + t),
                angle: 0.0,
            },
            WallBox {
                centre: Vec2::new(-self.hw - t / 2.0, 0.0),
                half_extents: Vec2::new(t / 2.0, self.hh + t),
                angle: 0.0,
            },
        ];
        if self.r > 0.0 {
            let n = ((self.r * std::f64::consts::FRAC_PI_2) / ARC_CHORD)
                .ceil()
                .max(1.0) as usize;
            for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                let c = Vec2::new(sx * (self.hw - self.r), sy * (self.hh - self.r));
                let base = libm::atan2(sy, sx) - std::f64::consts::FRAC_PI_4;
                for k in 0..n {
                    let a0 = base + std::f64::consts::FRAC_PI_2 * k as f64 / n as f64;
                    let a1 = base + std::f64::consts::FRAC_PI_2 * (k + 1) as f64 / n as f64;
                    let p0 = c + polar(self.r, a0);
                    let p1 = c + polar(self.r, a1);
                    let mid = (p0 + p1) * 0.5;
                    let am = (a0 + a1) / 2.0;
                    let normal = polar(1.0, am);
                    let chord = p0.distance(p1);
                    boxes.push(WallBox {
                        centre: mid + normal * (t / 2.0),
                        // A little longer than the chord so neighbouring boxes overlap
                        // outside the arena and leave no gap.
                        half_extents: Vec2::new(chord / 2.0 + 0.2, t / 2.0),
                        angle: am + std::f64::consts::FRAC_PI_2,
                    });
                }
            }
        }
        boxes
    }

    /// Points on the inner wall surface, at most `spacing` apart, going round once.
    pub fn wall_points(&self, spacing: f64) -> Vec<Vec2> {
        let mut pts = Vec::new();
        let (sx, sy) = (self.hw - self.r, self.hh - self.r);
        // Straight sides, each from one corner's tangent point to the next.
        let sides = [
            (Vec2::new(sx, -self.hh), Vec2::new(-sx, -self.hh)),
            (Vec2::new(-self.hw, -sy), Vec2::new(-self.hw, sy)),
            (Vec2::new(-sx, self.hh), Vec2::new(sx, self.hh)),
            (Vec2::new(self.hw, sy), Vec2::new(self.hw, -sy)),
        ];
        for (a, b) in sides {
            let len = a.distance(b);
            let n = (len / spacing).ceil() as usize;
            for k in 0..n.max(1) {
                pts.push(a + (b - a) * (k as f64 / n.max(1) as f64));
            }
        }
        if self.r > 0.0 {
            let n = ((self.r * std::f64::consts::FRAC_PI_2) / spacing).ceil() as usize;
            for (cx, cy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                let c = Vec2::new(cx * sx, cy * sy);
                let base = libm::atan2(cy, cx) - std::f64::consts::FRAC_PI_4;
                // The arc's first point starts a side already; its last ends one, so keep it.
                for k in 1..=n {
                    let a = base + std::f64::consts::FRAC_PI_2 * k as f64 / n as f64;
                    pts.push(c + polar(self.r, a));
                }
            }
        }
        pts
    }
}

/// A vector of length `r` at angle `a`.
pub(crate) fn polar(r: f64, a: f64) -> Vec2 {
    let (s, c) = libm::sincos(a);
    Vec2::new(r * c, r * s)
}
