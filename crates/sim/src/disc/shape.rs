//! The disc engine's shapes and the contacts between them.
//!
//! Every shape is a rounded convex polygon, [`Convex`]: a core of one point (a disc), two
//! (a capsule) or three to four (a polygon), grown by a radius. One pair of routines finds
//! the contacts of any two: [`collide`] between shapes and [`wall_contacts`] against the
//! arena's wall, a rounded rectangle seen from inside (convex, so a shape's deepest points
//! are among its core's vertices).
//!
//! Contacts are speculative: a pair closer than `margin` gets its contacts while still
//! apart, and the solver lets it close that gap in the step but not pass it.

use crate::arena::Arena;
use crate::types::Vec2;

/// Most vertices of a shape's core.
pub(crate) const MAX_VERTS: usize = 4;

pub(crate) fn dot(a: Vec2, b: Vec2) -> f64 {
    a.x * b.x + a.y * b.y
}

/// A vector's length, by `sqrt` alone: IEEE rounds it exactly, so every platform gets
/// the same bits (`hypot` comes from the platform's maths library).
pub(crate) fn norm(a: Vec2) -> f64 {
    (a.x * a.x + a.y * a.y).sqrt()
}

pub(crate) fn dist(a: Vec2, b: Vec2) -> f64 {
    norm(a - b)
}

pub(crate) fn cross(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// `a` turned a quarter clockwise: the outward normal of a counter-clockwise edge along `a`.
fn right(a: Vec2) -> Vec2 {
    Vec2::new(a.y, -a.x)
}

fn normalized(a: Vec2) -> Option<Vec2> {
    let l = norm(a);
    (l > 1e-12).then(|| Vec2::new(a.x / l, a.y / l))
}

/// A rotation and translation: a body's pose as its frame's axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Frame {
    pub origin: Vec2,
    pub cos: f64,
    pub sin: f64,
}

impl Frame {
    pub const IDENTITY: Frame = Frame {
        origin: Vec2 { x: 0.0, y: 0.0 },
        cos: 1.0,
        sin: 0.0,
    };

    pub fn apply(&self, p: Vec2) -> Vec2 {
        Vec2::new(
            self.origin.x + self.cos * p.x - self.sin * p.y,
            self.origin.y + self.sin * p.x + self.cos * p.y,
        )
    }

    pub fn rotate(&self, v: Vec2) -> Vec2 {
        Vec2::new(
            self.cos * v.x - self.sin * v.y,
            self.sin * v.x + self.cos * v.y,
        )
    }

    pub fn unapply(&self, p: Vec2) -> Vec2 {
        let d = p - self.origin;
        Vec2::new(
            self.cos * d.x + self.sin * d.y,
            -self.sin * d.x + self.cos * d.y,
        )
    }
}

/// A rounded convex polygon: the points within `radius` of its core.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Convex {
    pub verts: [Vec2; MAX_VERTS],
    /// Outward normal of the edge from vertex `i` to vertex `i + 1` (cores of 2 or more).
    pub normals: [Vec2; MAX_VERTS],
    pub count: usize,
    pub radius: f64,
    /// A circle that holds the whole shape.
    pub centre: Vec2,
    pub bound: f64,
}

impl Convex {
    pub fn disc(centre: Vec2, radius: f64) -> Convex {
        Convex::from_core(&[centre], radius)
    }

    pub fn capsule(a: Vec2, b: Vec2, radius: f64) -> Convex {
        Convex::from_core(&[a, b], radius)
    }

    /// A polygon from its corners in either winding (at most [`MAX_VERTS`] of them).
    pub fn polygon(points: &[Vec2]) -> Convex {
        let mut pts = points.to_vec();
        let area: f64 = (0..pts.len())
            .map(|i| cross(pts[i], pts[(i + 1) % pts.len()]))
            .sum();
        if area < 0.0 {
            pts.reverse();
        }
        Convex::from_core(&pts, 0.0)
    }

    fn from_core(core: &[Vec2], radius: f64) -> Convex {
        let count = core.len().clamp(1, MAX_VERTS);
        let mut verts = [Vec2::new(0.0, 0.0); MAX_VERTS];
        verts[..count].copy_from_slice(&core[..count]);
        let mut normals = [Vec2::new(0.0, 0.0); MAX_VERTS];
        if count >= 2 {
            for i in 0..count {
                let e = verts[(i + 1) % count] - verts[i];
                normals[i] = normalized(right(e)).unwrap_or(Vec2::new(0.0, 1.0));
            }
        }
        let centre = verts[..count]
            .iter()
            .fold(Vec2::new(0.0, 0.0), |s, &v| s + v)
            * (1.0 / count as f64);
        let bound = verts[..count]
            .iter()
            .map(|&v| dist(v, centre))
            .fold(0.0, f64::max)
            + radius;
        Convex {
            verts,
            normals,
            count,
            radius,
            centre,
            bound,
        }
    }

    /// The shape carried by `frame`.
    pub fn moved(&self, frame: &Frame) -> Convex {
        let mut out = *self;
        for i in 0..self.count {
            out.verts[i] = frame.apply(self.verts[i]);
            out.normals[i] = frame.rotate(self.normals[i]);
        }
        out.centre = frame.apply(self.centre);
        out
    }

    fn core(&self) -> &[Vec2] {
        &self.verts[..self.count]
    }
}

/// One point of contact: where, how far apart the surfaces are (negative when they
/// overlap), and which features touch (so a pair's impulses carry over to the next step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Point {
    pub at: Vec2,
    pub separation: f64,
    pub feature: u16,
}

/// The contacts of two shapes: a normal from the first to the second and up to two points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Manifold {
    pub normal: Vec2,
    pub points: [Point; 2],
    pub count: usize,
}

impl Manifold {
    fn one(normal: Vec2, at: Vec2, separation: f64, feature: u16) -> Manifold {
        let p = Point {
            at,
            separation,
            feature,
        };
        Manifold {
            normal,
            points: [p, p],
            count: 1,
        }
    }

    fn flipped(mut self) -> Manifold {
        self.normal = self.normal * -1.0;
        for p in &mut self.points {
            p.feature ^= 0x8000;
        }
        self
    }

    pub fn points(&self) -> &[Point] {
        &self.points[..self.count]
    }
}

/// The contacts of `a` and `b` (same frame) whose surfaces are less than `margin` apart.
pub(crate) fn collide(a: &Convex, b: &Convex, margin: f64) -> Option<Manifold> {
    if dist(a.centre, b.centre) > a.bound + b.bound + margin {
        return None;
    }
    match (a.count, b.count) {
        (1, 1) => discs(a.verts[0], a.radius, b.verts[0], b.radius, margin),
        (1, _) => disc_convex(a.verts[0], a.radius, b, margin).map(Manifold::flipped),
        (_, 1) => disc_convex(b.verts[0], b.radius, a, margin),
        _ => convexes(a, b, margin),
    }
}

fn discs(ca: Vec2, ra: f64, cb: Vec2, rb: f64, margin: f64) -> Option<Manifold> {
    let d = cb - ca;
    let gap = norm(d);
    let separation = gap - ra - rb;
    if separation > margin {
        return None;
    }
    let n = normalized(d).unwrap_or(Vec2::new(1.0, 0.0));
    let at = ca + n * (ra + separation / 2.0);
    Some(Manifold::one(n, at, separation, 0))
}

/// A disc (centre `c`, radius `r`) against a shape of two or more core points; the
/// normal points from the shape to the disc.
fn disc_convex(c: Vec2, r: f64, shape: &Convex, margin: f64) -> Option<Manifold> {
    let core = shape.core();
    let n_edges = core.len();
    // Deepest edge, for a centre inside the core polygon.
    let (mut best_edge, mut best_sep) = (0, f64::NEG_INFINITY);
    for (i, &v) in core.iter().enumerate() {
        let s = dot(shape.normals[i], c - v);
        if s > best_sep {
            best_sep = s;
            best_edge = i;
        }
    }
    let (normal, depth, feature) = if n_edges >= 3 && best_sep <= 0.0 {
        (shape.normals[best_edge], best_sep, best_edge as u16)
    } else {
        let (mut q, mut dq, mut edge) = (core[0], f64::INFINITY, 0);
        for i in 0..n_edges {
            let p = closest_on_segment(c, core[i], core[(i + 1) % n_edges]);
            let d = dist(p, c);
            if d < dq {
                (q, dq, edge) = (p, d, i);
            }
        }
        let n = normalized(c - q).unwrap_or(shape.normals[best_edge]);
        (n, dq, edge as u16)
    };
    let separation = depth - r - shape.radius;
    if separation > margin {
        return None;
    }
    // Halfway between the two surfaces.
    let at = c - normal * (r + separation / 2.0);
    Some(Manifold::one(normal, at, separation, feature))
}

fn closest_on_segment(p: Vec2, a: Vec2, b: Vec2) -> Vec2 {
    let e = b - a;
    let l2 = dot(e, e);
    if l2 <= 0.0 {
        return a;
    }
    let t = (dot(p - a, e) / l2).clamp(0.0, 1.0);
    a + e * t
}

/// Closest points of segments `p1 q1` and `p2 q2`.
fn closest_between_segments(p1: Vec2, q1: Vec2, p2: Vec2, q2: Vec2) -> (Vec2, Vec2) {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let (s, t);
    if a <= 1e-18 && e <= 1e-18 {
        return (p1, p2);
    }
    if a <= 1e-18 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = dot(d1, r);
        if e <= 1e-18 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = dot(d1, d2);
            let denom = a * e - b * b;
            let s0 = if denom > 1e-18 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    (p1 + d1 * s, p2 + d2 * t)
}

/// The edge of `a` that best separates it from `b`'s core, and by how much.
fn max_separation(a: &Convex, b: &Convex) -> (usize, f64) {
    let (mut edge, mut best) = (0, f64::NEG_INFINITY);
    for i in 0..a.count {
        let n = a.normals[i];
        let v = a.verts[i];
        let s = b
            .core()
            .iter()
            .map(|&w| dot(n, w - v))
            .fold(f64::INFINITY, f64::min);
        if s > best {
            best = s;
            edge = i;
        }
    }
    (edge, best)
}

/// Two shapes of two or more core points: the separating axis of their cores picks a
/// reference edge; the other's most opposed edge, clipped to it, gives up to two points.
fn convexes(a: &Convex, b: &Convex, margin: f64) -> Option<Manifold> {
    let (edge_a, sep_a) = max_separation(a, b);
    let (edge_b, sep_b) = max_separation(b, a);
    let radii = a.radius + b.radius;
    if sep_a.max(sep_b) - radii > margin {
        return None;
    }
    // Prefer `a` as the reference unless `b` separates clearly better (stable features).
    let flip = sep_b > sep_a + 1e-4;
    let (reference, incident, edge) = if flip { (b, a, edge_b) } else { (a, b, edge_a) };
    let m = reference_contacts(reference, incident, edge, margin)?;
    Some(if flip { m.flipped() } else { m })
}

fn reference_contacts(
    reference: &Convex,
    incident: &Convex,
    edge: usize,
    margin: f64,
) -> Option<Manifold> {
    let n = reference.normals[edge];
    let v1 = reference.verts[edge];
    let v2 = reference.verts[(edge + 1) % reference.count];
    // The incident edge: the one facing the reference normal most.
    let (mut inc, mut most) = (0, f64::INFINITY);
    for j in 0..incident.count {
        let d = dot(incident.normals[j], n);
        if d < most {
            most = d;
            inc = j;
        }
    }
    let w1 = incident.verts[inc];
    let w2 = incident.verts[(inc + 1) % incident.count];
    let radii = reference.radius + incident.radius;
    let (r_ref, r_inc) = (reference.radius, incident.radius);
    let core_sep = dot(n, w1 - v1).min(dot(n, w2 - v1));
    let tangent = normalized(v2 - v1)?;
    let (lo, hi) = (dot(tangent, v1), dot(tangent, v2));
    let (t1, t2) = (dot(tangent, w1), dot(tangent, w2));
    // Face to face only where the incident edge runs along the reference edge's extent.
    let overlap = t1.max(t2).min(hi) - t1.min(t2).max(lo);
    let face_to_face = most < -0.995 && overlap > 1e-6;
    if core_sep > 1e-3 && !face_to_face {
        // Cores apart and not face to face: one point, between the closest features.
        let (p, q) = closest_between_segments(v1, v2, w1, w2);
        let d = q - p;
        let gap = norm(d);
        let separation = gap - radii;
        if separation > margin {
            return None;
        }
        let normal = normalized(d).unwrap_or(n);
        let at = p + normal * (r_ref + separation / 2.0);
        let feature = (edge as u16) << 8 | inc as u16;
        return Some(Manifold::one(normal, at, separation, feature));
    }
    // Clip the incident edge to the reference edge's extent.
    let mut pts: [(Vec2, u16); 2] = [(w1, 0), (w2, 1)];
    if (t2 - t1).abs() > 1e-12 {
        let clip = |t: f64| w1 + (w2 - w1) * ((t - t1) / (t2 - t1));
        for (p, _) in pts.iter_mut() {
            let t = dot(tangent, *p);
            if t < lo {
                *p = clip(lo);
            } else if t > hi {
                *p = clip(hi);
            }
        }
    }
    let mut out = Manifold::one(n, v1, 0.0, 0);
    out.count = 0;
    for (p, id) in pts {
        let depth = dot(n, p - v1);
        let separation = depth - radii;
        if separation > margin {
            continue;
        }
        let on_ref = p - n * depth + n * r_ref;
        let on_inc = p - n * r_inc;
        let at = (on_ref + on_inc) * 0.5;
        out.points[out.count] = Point {
            at,
            separation,
            feature: (edge as u16) << 8 | (inc as u16) << 4 | id,
        };
        out.count += 1;
    }
    (out.count > 0).then_some(out)
}

/// How far `p` is inside the arena's wall (negative outside) and the wall's outward
/// normal nearest it: the arena's signed distance and its gradient, by `sqrt` alone.
pub(crate) fn wall_gap(arena: &Arena, p: Vec2) -> (f64, Vec2) {
    let (hw, hh, r) = (
        arena.half_width(),
        arena.half_height(),
        arena.corner_radius(),
    );
    let qx = p.x.abs() - (hw - r);
    let qy = p.y.abs() - (hh - r);
    let (gap, n) = if qx > 0.0 && qy > 0.0 {
        let l = (qx * qx + qy * qy).sqrt();
        (r - l, Vec2::new(qx / l, qy / l))
    } else if qx > qy {
        (r - qx, Vec2::new(1.0, 0.0))
    } else {
        (r - qy, Vec2::new(0.0, 1.0))
    };
    (gap, Vec2::new(n.x.copysign(p.x), n.y.copysign(p.y)))
}

/// The contacts of a shape (world frame) with the arena's wall, the normal pointing into
/// the wall; calls `f` for each core point closer to the wall than `margin`.
pub(crate) fn wall_contacts(
    arena: &Arena,
    shape: &Convex,
    margin: f64,
    mut f: impl FnMut(Vec2, Point),
) {
    if wall_gap(arena, shape.centre).0 - shape.bound > margin {
        return;
    }
    for (i, &v) in shape.core().iter().enumerate() {
        let (gap, n) = wall_gap(arena, v);
        let separation = gap - shape.radius;
        if separation > margin {
            continue;
        }
        let at = v + n * (shape.radius + separation / 2.0);
        f(
            n,
            Point {
                at,
                separation,
                feature: i as u16,
            },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ArenaConfig;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn discs_touch_along_their_centres() {
        let a = Convex::disc(Vec2::new(0.0, 0.0), 1.0);
        let b = Convex::disc(Vec2::new(3.0, 0.0), 1.5);
        let m = collide(&a, &b, 1.0).unwrap();
        assert_eq!(m.count, 1);
        assert!(close(m.normal.x, 1.0) && close(m.normal.y, 0.0));
        assert!(close(m.points[0].separation, 0.5));
        assert!(close(m.points[0].at.x, 1.25));
        assert!(collide(&a, &b, 0.4).is_none(), "beyond the margin");
    }

    #[test]
    fn a_disc_in_a_box_is_pushed_out_through_the_nearest_face() {
        let square = Convex::polygon(&[
            Vec2::new(-1.0, -1.0),
            Vec2::new(1.0, -1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(-1.0, 1.0),
        ]);
        let disc = Convex::disc(Vec2::new(0.8, 0.1), 0.5);
        let m = collide(&square, &disc, 0.1).unwrap();
        assert!(close(m.normal.x, 1.0), "{m:?}");
        assert!(close(m.points[0].separation, -0.2 - 0.5));
        // The other way round the normal turns.
        let m = collide(&disc, &square, 0.1).unwrap();
        assert!(close(m.normal.x, -1.0), "{m:?}");
        // Off a corner, the normal runs from the corner to the centre.
        let disc = Convex::disc(Vec2::new(1.3, 1.4), 0.6);
        let m = collide(&square, &disc, 0.1).unwrap();
        assert!(close(m.normal.x, 0.6) && close(m.normal.y, 0.8), "{m:?}");
        assert!(close(m.points[0].separation, -0.1));
    }

    #[test]
    fn a_disc_meets_a_capsule_on_its_side_and_its_end() {
        let cap = Convex::capsule(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0), 0.5);
        let side = collide(&cap, &Convex::disc(Vec2::new(2.0, 1.2), 1.0), 0.0).unwrap();
        assert!(close(side.normal.y, 1.0) && close(side.points[0].separation, -0.3));
        let end = collide(&cap, &Convex::disc(Vec2::new(5.0, 0.0), 1.0), 0.0).unwrap();
        assert!(close(end.normal.x, 1.0) && close(end.points[0].separation, -0.5));
    }

    #[test]
    fn boxes_face_to_face_touch_at_two_points() {
        let square = |cx: f64, cy: f64| {
            Convex::polygon(&[
                Vec2::new(cx - 1.0, cy - 1.0),
                Vec2::new(cx + 1.0, cy - 1.0),
                Vec2::new(cx + 1.0, cy + 1.0),
                Vec2::new(cx - 1.0, cy + 1.0),
            ])
        };
        let m = collide(&square(0.0, 0.0), &square(1.9, 0.5), 0.1).unwrap();
        assert_eq!(m.count, 2, "{m:?}");
        assert!(close(m.normal.x, 1.0), "{m:?}");
        for p in m.points() {
            assert!(close(p.separation, -0.1), "{m:?}");
        }
        // Apart by more than the margin: nothing.
        assert!(collide(&square(0.0, 0.0), &square(2.5, 0.0), 0.1).is_none());
        // Corner to corner, apart: one point along the gap.
        let m = collide(&square(0.0, 0.0), &square(2.05, 2.05), 0.2).unwrap();
        assert_eq!(m.count, 1);
        assert!(close(m.points[0].separation, 0.05 * 2f64.sqrt()), "{m:?}");
    }

    #[test]
    fn a_capsule_lying_on_a_box_touches_at_both_ends() {
        let slab = Convex::polygon(&[
            Vec2::new(-5.0, -1.0),
            Vec2::new(5.0, -1.0),
            Vec2::new(5.0, 0.0),
            Vec2::new(-5.0, 0.0),
        ]);
        let cap = Convex::capsule(Vec2::new(-1.0, 0.4), Vec2::new(1.0, 0.4), 0.5);
        let m = collide(&slab, &cap, 0.1).unwrap();
        assert_eq!(m.count, 2, "{m:?}");
        assert!(close(m.normal.y, 1.0));
        assert!(m.points().iter().all(|p| close(p.separation, -0.1)));
    }

    #[test]
    fn the_wall_pushes_on_the_points_past_it() {
        let arena = Arena::new(&ArenaConfig {
            width: 100.0,
            height: 100.0,
            corner_radius: 10.0,
        });
        let disc = Convex::disc(Vec2::new(49.0, 0.0), 2.0);
        let mut got = Vec::new();
        wall_contacts(&arena, &disc, 0.5, |n, p| got.push((n, p)));
        assert_eq!(got.len(), 1);
        assert!(close(got[0].0.x, 1.0) && close(got[0].1.separation, -1.0));
        // Into a rounded corner, along the corner's radius.
        let c = 40.0 + 10.0 / 2f64.sqrt();
        let disc = Convex::disc(Vec2::new(c - 0.5, c - 0.5), 1.0);
        let mut got = Vec::new();
        wall_contacts(&arena, &disc, 0.0, |n, p| got.push((n, p)));
        assert_eq!(got.len(), 1);
        let n = got[0].0;
        assert!(close(n.x, 1.0 / 2f64.sqrt()) && close(n.y, n.x), "{n:?}");
        // Far from every wall: nothing.
        let mut none = 0;
        wall_contacts(
            &arena,
            &Convex::disc(Vec2::new(0.0, 0.0), 2.0),
            1.0,
            |_, _| none += 1,
        );
        assert_eq!(none, 0);
    }
}
