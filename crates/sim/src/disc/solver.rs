//! Box2D v3's soft step for contacts: each contact a stiff, heavily damped spring that
//! pushes overlapping bodies apart at a bounded speed, with Coulomb friction, solved
//! Gauss-Seidel in a fixed order.
//!
//! A contact's anchors are fixed at the start of the physics step; its separation in a
//! substep follows from how far its two bodies have moved and turned since (so contacts
//! are found once per physics step, not once per substep).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use super::shape::{cross, dot};
use super::strips::STATIC;
use super::{Bodies, State};
use crate::types::Vec2;

/// Stiffness of a contact's spring, Hz, at most (Box2D: 30, and a quarter of the substep rate).
const CONTACT_HERTZ: f64 = 30.0;
/// Its damping ratio (Box2D's).
const DAMPING_RATIO: f64 = 10.0;
/// Fastest push apart of overlapping bodies, cm/s.
const MAX_PUSH: f64 = 30.0;

/// One point of contact between bodies `a` and `b`, the normal from `a` to `b`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Contact {
    pub a: u32,
    pub b: u32,
    /// The bodies' places among the step's moving bodies (`strips::STATIC` for the wall
    /// and for sleepers).
    pub sa: u32,
    pub sb: u32,
    pub key: u64,
    normal: Vec2,
    /// The contact point's offsets from each body's centre at the step's start.
    ra: Vec2,
    rb: Vec2,
    /// The separation at the step's start, less what the anchors account for.
    base: f64,
    point: Vec2,
    separation: f64,
    /// Each body's inverse mass and inverse moment of inertia (zero for the wall and
    /// for a sleeper, which stands still).
    inv_a: (f64, f64),
    inv_b: (f64, f64),
    normal_mass: f64,
    tangent_mass: f64,
    friction: f64,
    pub normal_impulse: f64,
    pub tangent_impulse: f64,
}

impl Contact {
    pub fn new(a: u32, b: u32, key: u64, normal: Vec2, point: Vec2, separation: f64) -> Contact {
        let zero = Vec2::new(0.0, 0.0);
        Contact {
            a,
            b,
            sa: STATIC,
            sb: STATIC,
            key,
            normal,
            ra: zero,
            rb: zero,
            base: 0.0,
            point,
            separation,
            inv_a: (0.0, 0.0),
            inv_b: (0.0, 0.0),
            normal_mass: 0.0,
            tangent_mass: 0.0,
            friction: 0.0,
            normal_impulse: 0.0,
            tangent_impulse: 0.0,
        }
    }
}

/// A key naming a contact by its bodies, their parts and the touching features.
pub(crate) fn key(a: usize, b: usize, part_a: usize, part_b: usize, feature: u16) -> u64 {
    const BODY: u64 = (1 << 21) - 1;
    (a as u64 & BODY) << 43
        | (b as u64 & BODY) << 22
        | (part_a as u64 & 7) << 19
        | (part_b as u64 & 7) << 16
        | feature as u64
}

/// A hasher for contact keys (already well mixed in their high bits: one multiply spreads them).
#[derive(Default)]
pub(crate) struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }

    fn write_u64(&mut self, k: u64) {
        self.0 = (k ^ (k >> 29)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

pub(crate) type KeyHash = BuildHasherDefault<KeyHasher>;

/// A substep's soft-constraint coefficients.
pub(crate) struct Soft {
    inv_h: f64,
    bias_rate: f64,
    mass_scale: f64,
    impulse_scale: f64,
}

impl Soft {
    pub fn new(h: f64) -> Soft {
        let hertz = CONTACT_HERTZ;
        let omega = 2.0 * std::f64::consts::PI * hertz;
        let a1 = 2.0 * DAMPING_RATIO + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Soft {
            inv_h: 1.0 / h,
            bias_rate: omega / a1,
            mass_scale: a2 * a3,
            impulse_scale: a3,
        }
    }
}

fn masses(b: &Bodies, i: usize) -> (f64, f64) {
    if b.asleep[i] {
        (0.0, 0.0)
    } else {
        (b.inv_mass[i], b.inv_inertia[i])
    }
}

/// Fills in each contact's anchors and masses, and starts it from last step's impulses.
pub(crate) fn prepare(
    contacts: &mut [Contact],
    b: &Bodies,
    last: &HashMap<u64, (f64, f64), KeyHash>,
) {
    for c in contacts {
        let (a, bb) = (c.a as usize, c.b as usize);
        let (ma, ia) = masses(b, a);
        let (mb, ib) = masses(b, bb);
        c.inv_a = (ma, ia);
        c.inv_b = (mb, ib);
        c.ra = c.point - b.pos[a];
        c.rb = c.point - b.pos[bb];
        c.base = c.separation - dot(c.rb - c.ra, c.normal);
        let n = c.normal;
        let t = Vec2::new(n.y, -n.x);
        let (rna, rnb) = (cross(c.ra, n), cross(c.rb, n));
        let k = ma + mb + ia * rna * rna + ib * rnb * rnb;
        c.normal_mass = if k > 0.0 { 1.0 / k } else { 0.0 };
        let (rta, rtb) = (cross(c.ra, t), cross(c.rb, t));
        let k = ma + mb + ia * rta * rta + ib * rtb * rtb;
        c.tangent_mass = if k > 0.0 { 1.0 / k } else { 0.0 };
        c.friction = 0.5 * (b.friction[a] + b.friction[bb]);
        let (ni, ti) = last.get(&c.key).copied().unwrap_or((0.0, 0.0));
        c.normal_impulse = ni;
        c.tangent_impulse = ti;
    }
}

fn rotate((c, s): (f64, f64), v: Vec2) -> Vec2 {
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// `w x r` for a spin `w`.
fn spin_cross(w: f64, r: Vec2) -> Vec2 {
    Vec2::new(-w * r.y, w * r.x)
}

/// A body's state, read from the slice that begins at place `offset` (a still body's is rest).
fn read(s: &[State], place: u32, offset: usize) -> State {
    if place == STATIC {
        State::REST
    } else {
        s[place as usize - offset]
    }
}

fn apply(s: &mut [State], offset: usize, c: &Contact, impulse: Vec2) {
    let (ma, ia) = c.inv_a;
    let (mb, ib) = c.inv_b;
    if c.sa != STATIC {
        let a = &mut s[c.sa as usize - offset];
        a.vel = a.vel - impulse * ma;
        a.spin -= ia * cross(c.ra, impulse);
    }
    if c.sb != STATIC {
        let b = &mut s[c.sb as usize - offset];
        b.vel = b.vel + impulse * mb;
        b.spin += ib * cross(c.rb, impulse);
    }
}

/// Applies each contact's impulses so far (a substep starts from where the last left off).
pub(crate) fn warm_start(contacts: &[Contact], s: &mut [State], offset: usize) {
    for c in contacts {
        let n = c.normal;
        let t = Vec2::new(n.y, -n.x);
        apply(s, offset, c, n * c.normal_impulse + t * c.tangent_impulse);
    }
}

/// One pass over the contacts: with `push`, overlaps are pushed apart; without, the pass
/// only takes out the speed that push put in (Box2D's relax).
pub(crate) fn solve(
    contacts: &mut [Contact],
    b: &mut [State],
    offset: usize,
    soft: &Soft,
    push: bool,
) {
    for c in contacts {
        let n = c.normal;
        let (sa, sb) = (read(b, c.sa, offset), read(b, c.sb, offset));
        let d = (sb.moved - sa.moved) + (rotate(sb.turned, c.rb) - rotate(sa.turned, c.ra));
        let s = dot(d, n) + c.base;
        let (bias, mass_scale, impulse_scale) = if s > 0.0 {
            // Apart: close at most the gap in this substep.
            (s * soft.inv_h, 1.0, 0.0)
        } else if push {
            (
                (soft.bias_rate * s).max(-MAX_PUSH),
                soft.mass_scale,
                soft.impulse_scale,
            )
        } else {
            (0.0, 1.0, 0.0)
        };
        let dv = (sb.vel + spin_cross(sb.spin, c.rb)) - (sa.vel + spin_cross(sa.spin, c.ra));
        let vn = dot(dv, n);
        let impulse = -c.normal_mass * mass_scale * (vn + bias) - impulse_scale * c.normal_impulse;
        let total = (c.normal_impulse + impulse).max(0.0);
        let impulse = total - c.normal_impulse;
        c.normal_impulse = total;
        apply(b, offset, c, n * impulse);

        let t = Vec2::new(n.y, -n.x);
        let (sa, sb) = (read(b, c.sa, offset), read(b, c.sb, offset));
        let dv = (sb.vel + spin_cross(sb.spin, c.rb)) - (sa.vel + spin_cross(sa.spin, c.ra));
        let vt = dot(dv, t);
        let limit = c.friction * c.normal_impulse;
        let total = (c.tangent_impulse - c.tangent_mass * vt).clamp(-limit, limit);
        let impulse = total - c.tangent_impulse;
        c.tangent_impulse = total;
        apply(b, offset, c, t * impulse);
    }
}
