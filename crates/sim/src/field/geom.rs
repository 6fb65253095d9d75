//! Plane geometry in `f64` for placement checks and sensors: rectangles at any
//! angle, discs, rays. Kept apart from rapier so sensing reads exactly the poses
//! the field reports, and so it needs no broad phase that is only refreshed by a step.

use crate::types::{Pose, Vec2};

/// A rectangle at any angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Obb {
    pub centre: Vec2,
    /// Unit vector along the rectangle's own x axis.
    pub axis: Vec2,
    pub half: Vec2,
}

fn dot(a: Vec2, b: Vec2) -> f64 {
    a.x * b.x + a.y * b.y
}

fn perp(a: Vec2) -> Vec2 {
    Vec2::new(-a.y, a.x)
}

/// The unit vector at angle `theta` from +x.
pub(crate) fn unit(theta: f64) -> Vec2 {
    let (s, c) = libm::sincos(theta);
    Vec2::new(c, s)
}

impl Obb {
    /// A box of half extents `half` centred on `pose`, its x axis along the heading.
    pub fn from_pose(pose: Pose, half: Vec2) -> Obb {
        Obb {
            centre: pose.position(),
            axis: unit(pose.theta),
            half,
        }
    }

    /// An axis-aligned rectangle between two corners.
    pub fn aligned(lo: Vec2, hi: Vec2) -> Obb {
        Obb {
            centre: (lo + hi) * 0.5,
            axis: Vec2::new(1.0, 0.0),
            half: (hi - lo) * 0.5,
        }
    }

    fn to_local(self, p: Vec2) -> Vec2 {
        let d = p - self.centre;
        Vec2::new(dot(d, self.axis), dot(d, perp(self.axis)))
    }

    fn to_world(self, l: Vec2) -> Vec2 {
        self.centre + self.axis * l.x + perp(self.axis) * l.y
    }

    /// The smallest axis-aligned box holding it: (lower-left, upper-right).
    pub fn bounds(&self) -> (Vec2, Vec2) {
        let ex = self.axis.x.abs() * self.half.x + self.axis.y.abs() * self.half.y;
        let ey = self.axis.y.abs() * self.half.x + self.axis.x.abs() * self.half.y;
        (
            Vec2::new(self.centre.x - ex, self.centre.y - ey),
            Vec2::new(self.centre.x + ex, self.centre.y + ey),
        )
    }

    /// The point of the rectangle (boundary or inside) nearest to `p`.
    pub fn closest_point(&self, p: Vec2) -> Vec2 {
        let l = self.to_local(p);
        self.to_world(Vec2::new(
            l.x.clamp(-self.half.x, self.half.x),
            l.y.clamp(-self.half.y, self.half.y),
        ))
    }

    /// Whether the interiors of two rectangles overlap (touching is not overlapping):
    /// the separating-axis test on the four edge normals.
    pub fn overlaps(&self, other: &Obb) -> bool {
        let d = other.centre - self.centre;
        for axis in [self.axis, perp(self.axis), other.axis, perp(other.axis)] {
            let r = |b: &Obb| {
                b.half.x * dot(b.axis, axis).abs() + b.half.y * dot(perp(b.axis), axis).abs()
            };
            if dot(d, axis).abs() >= r(self) + r(other) {
                return false;
            }
        }
        true
    }

    /// Whether the rectangle's interior meets an open disc.
    pub fn overlaps_disc(&self, centre: Vec2, radius: f64) -> bool {
        self.closest_point(centre).distance(centre) < radius
    }

    /// Where a ray from `origin` along unit `dir` first meets the rectangle, as the
    /// distance along the ray (0 when it starts inside); the slab method.
    pub fn ray_hit(&self, origin: Vec2, dir: Vec2) -> Option<f64> {
        let o = self.to_local(origin);
        let d = Vec2::new(dot(dir, self.axis), dot(dir, perp(self.axis)));
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for (o, d, h) in [(o.x, d.x, self.half.x), (o.y, d.y, self.half.y)] {
            if d == 0.0 {
                if o.abs() > h {
                    return None;
                }
                continue;
            }
            let (a, b) = ((-h - o) / d, (h - o) / d);
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return None;
            }
        }
        Some(t0)
    }
}

/// Where a ray from `origin` along unit `dir` first meets a disc (0 when it starts inside).
pub(crate) fn ray_disc(origin: Vec2, dir: Vec2, centre: Vec2, radius: f64) -> Option<f64> {
    let m = origin - centre;
    let c = dot(m, m) - radius * radius;
    if c <= 0.0 {
        return Some(0.0);
    }
    let b = dot(m, dir);
    if b > 0.0 {
        return None;
    }
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    Some(-b - disc.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_meet_rectangles_and_discs_where_expected() {
        let b = Obb::aligned(Vec2::new(10.0, -1.0), Vec2::new(12.0, 1.0));
        let x = Vec2::new(1.0, 0.0);
        assert_eq!(b.ray_hit(Vec2::ZERO, x), Some(10.0));
        assert_eq!(b.ray_hit(Vec2::ZERO, Vec2::new(-1.0, 0.0)), None);
        assert_eq!(b.ray_hit(Vec2::new(11.0, 0.0), x), Some(0.0));
        assert_eq!(b.ray_hit(Vec2::new(0.0, 2.0), x), None);
        assert_eq!(
            ray_disc(Vec2::ZERO, x, Vec2::new(10.0, 0.0), 2.0),
            Some(8.0)
        );
        assert_eq!(ray_disc(Vec2::ZERO, x, Vec2::new(-10.0, 0.0), 2.0), None);
        assert_eq!(ray_disc(Vec2::ZERO, x, Vec2::new(10.0, 3.0), 2.0), None);
        // A rotated box: a diamond of half-diagonal sqrt(2) round (10, 0).
        let d = Obb::from_pose(
            Pose {
                x: 10.0,
                y: 0.0,
                theta: std::f64::consts::FRAC_PI_4,
            },
            Vec2::new(1.0, 1.0),
        );
        let t = d.ray_hit(Vec2::ZERO, x).unwrap();
        assert!((t - (10.0 - 2f64.sqrt())).abs() < 1e-12, "{t}");
    }

    #[test]
    fn overlap_tests_allow_touching() {
        let a = Obb::aligned(Vec2::new(0.0, 0.0), Vec2::new(1.0, 1.0));
        let b = Obb::aligned(Vec2::new(1.0, 0.0), Vec2::new(2.0, 1.0));
        let c = Obb::aligned(Vec2::new(0.9, 0.5), Vec2::new(2.0, 1.0));
        assert!(!a.overlaps(&b));
        assert!(a.overlaps(&c));
        assert!(!a.overlaps_disc(Vec2::new(2.0, 0.5), 1.0));
        assert!(a.overlaps_disc(Vec2::new(1.9, 0.5), 1.0));
        assert_eq!(a.closest_point(Vec2::new(3.0, 3.0)), Vec2::new(1.0, 1.0));
        let (lo, hi) = Obb::from_pose(
            Pose {
                x: 0.0,
                y: 0.0,
                theta: std::f64::consts::FRAC_PI_2,
            },
            Vec2::new(2.0, 1.0),
        )
        .bounds();
        assert!((lo.x + 1.0).abs() < 1e-12 && (hi.y - 2.0).abs() < 1e-12);
    }
}
