//! The disc engine: colony's own contact engine for the arena's few shapes.
//!
//! rapier is general: any shape, joints, islands, a BVH. The arena needs little of that:
//! discs (pucks), one robot compound (a box, two jaws, four lip capsules and a bow disc)
//! and a rounded-rectangle wall seen from inside. This engine does just that, the way
//! Box2D v3 does it (BENCHMARKS.md, "Choosing the contact engine", for why and how fast):
//!
//! - **Bodies** in arrays, one per quantity (structure of arrays), index 0 the wall.
//! - **Broad phase**: two uniform grids rebuilt each physics step, one of pucks (cells a
//!   little wider than a puck), one of robots.
//! - **Sleep**: a puck that has barely moved for half a second sleeps. It is not moved,
//!   and pairs of sleepers are never looked at, so a resting pile costs nothing until
//!   something moving comes within reach and wakes it. A sleeper touched by a body that is
//!   awake but not moving stands in as a wall for it.
//! - **Narrow phase** ([`shape`]): speculative contacts between rounded convex shapes, a
//!   robot's against a puck found in the robot's own frame. Robots and awake pucks are
//!   handed out in fixed chunks on rayon's threads and the chunks' contacts joined in
//!   order, so the thread count never changes a result.
//! - **Solver** ([`solver`]): Box2D v3's soft step. Each physics step is cut into
//!   substeps; in each, contacts are warm started, solved as soft springs (Gauss-Seidel,
//!   in a fixed order), positions integrated, and the contacts relaxed without their
//!   push-out. Impulses carry over from step to step by contact feature.
//! - **Friction** is Coulomb's, the pair's coefficient the mean of the two (rapier's
//!   rule); a puck's floor friction is damping in Box2D's convention, as in the
//!   authors' simulator.

mod shape;
mod solver;

use std::collections::HashMap;

use rayon::prelude::*;

use crate::arena::Arena;
use crate::body::{Part, RobotGeometry};
use crate::config::SceneConfig;
use crate::grid::Grid;
use crate::types::{Pose, Vec2};

use shape::{collide, dist, norm, wall_contacts, Convex, Frame, Manifold};
use solver::{Contact, Soft};

/// Solver substeps per physics step (Box2D v3's default is 4 per 1/60 s; ours are 1/56 s).
const SUBSTEPS: u32 = 4;

/// Contacts are made this far ahead of touching, cm: more than two robots closing head on
/// move in a substep, so nothing passes unseen between two looks.
const MARGIN: f64 = 1.0;

/// A puck sleeps once it has moved slower than these for [`TIME_TO_SLEEP`].
const SLEEP_SPEED: f64 = 0.2;
const SLEEP_SPIN: f64 = 0.05;
const TIME_TO_SLEEP: f64 = 0.5;

/// Bodies handed to one thread at a time (a fixed size, so results never depend on threads).
const CHUNK: usize = 512;

/// The wall's body index.
const WALL: u32 = 0;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Wall,
    Robot,
    Puck,
}

/// Every body's state, one array per quantity.
#[derive(Debug, Default)]
pub(crate) struct Bodies {
    kind: Vec<Kind>,
    pos: Vec<Vec2>,
    /// Heading as (cos, sin).
    rot: Vec<(f64, f64)>,
    vel: Vec<Vec2>,
    spin: Vec<f64>,
    inv_mass: Vec<f64>,
    inv_inertia: Vec<f64>,
    friction: Vec<f64>,
    /// The share of linear and angular speed a body keeps each substep (floor friction).
    keep: Vec<(f64, f64)>,
    asleep: Vec<bool>,
    still_for: Vec<f64>,
    /// Moved and turned since the physics step began (for the contacts' separations).
    moved: Vec<Vec2>,
    turned: Vec<(f64, f64)>,
}

impl Bodies {
    fn push(&mut self, kind: Kind, pos: Vec2, rot: (f64, f64), inv: (f64, f64), friction: f64) {
        self.kind.push(kind);
        self.pos.push(pos);
        self.rot.push(rot);
        self.vel.push(Vec2::new(0.0, 0.0));
        self.spin.push(0.0);
        self.inv_mass.push(inv.0);
        self.inv_inertia.push(inv.1);
        self.friction.push(friction);
        self.keep.push((1.0, 1.0));
        self.asleep.push(kind == Kind::Wall);
        self.still_for.push(0.0);
        self.moved.push(Vec2::new(0.0, 0.0));
        self.turned.push((1.0, 0.0));
    }

    fn frame(&self, i: usize) -> Frame {
        Frame {
            origin: self.pos[i],
            cos: self.rot[i].0,
            sin: self.rot[i].1,
        }
    }
}

/// The arena's bodies in the disc engine.
pub(crate) struct DiscEngine {
    arena: Arena,
    dt: f64,
    bodies: Bodies,
    robots: Vec<u32>,
    pucks: Vec<u32>,
    /// A robot's solid parts and its bow, robot frame.
    solid: Vec<Convex>,
    bow: Convex,
    robot_bound: f64,
    puck_radius: f64,
    puck_keep: (f64, f64),
    puck_grid: Grid,
    robot_grid: Grid,
    contacts: Vec<Contact>,
    /// Last step's impulses by contact key, to start this step's from.
    impulses: HashMap<u64, (f64, f64), solver::KeyHash>,
}

impl DiscEngine {
    pub fn new(cfg: &SceneConfig, arena: &Arena, geometry: &RobotGeometry) -> DiscEngine {
        let mut bodies = Bodies::default();
        bodies.push(
            Kind::Wall,
            Vec2::new(0.0, 0.0),
            (1.0, 0.0),
            (0.0, 0.0),
            cfg.robots.friction,
        );
        let solid: Vec<Convex> = geometry
            .parts()
            .into_iter()
            .map(|part| match part {
                Part::Rectangle { half_extents: h } => Convex::polygon(&[
                    Vec2::new(-h.x, -h.y),
                    Vec2::new(h.x, -h.y),
                    Vec2::new(h.x, h.y),
                    Vec2::new(-h.x, h.y),
                ]),
                Part::Capsule { a, b, radius } => Convex::capsule(a, b, radius),
                Part::Polygon(points) => Convex::polygon(&points),
            })
            .collect();
        let bow = Convex::disc(geometry.pocket, geometry.pocket_radius);
        let robot_bound = solid
            .iter()
            .chain([&bow])
            .map(|c| norm(c.centre) + c.bound)
            .fold(0.0, f64::max);
        let puck_radius = cfg.puck_radius();
        let keep = |c: f64| {
            let per_step = (1.0 - c * cfg.physics.dt).clamp(0.0, 1.0);
            libm::pow(per_step, 1.0 / SUBSTEPS as f64)
        };
        let half = Vec2::new(arena.half_width() + 1.0, arena.half_height() + 1.0);
        let side = 2.0 * half.x.max(half.y);
        let cell = |want: f64| want.max(side / 4096.0);
        DiscEngine {
            arena: *arena,
            dt: cfg.physics.dt,
            bodies,
            robots: Vec::new(),
            pucks: Vec::new(),
            solid,
            bow,
            robot_bound,
            puck_radius,
            puck_keep: (
                keep(cfg.pucks.linear_damping),
                keep(cfg.pucks.angular_damping),
            ),
            puck_grid: Grid::new(half, cell(2.0 * puck_radius + MARGIN)),
            robot_grid: Grid::new(half, cell(2.0 * robot_bound + MARGIN)),
            contacts: Vec::new(),
            impulses: HashMap::default(),
        }
    }

    /// Adds a robot; its centre of mass is the body rectangle's centre.
    pub fn add_robot(&mut self, cfg: &SceneConfig, pose: Pose) -> usize {
        let m = cfg.robots.mass;
        let (l, w) = (cfg.robots.length, cfg.robots.width);
        let inertia = m * (l * l + w * w) / 12.0;
        let (s, c) = libm::sincos(pose.theta);
        let i = self.bodies.kind.len();
        self.bodies.push(
            Kind::Robot,
            pose.position(),
            (c, s),
            (1.0 / m, 1.0 / inertia),
            cfg.robots.friction,
        );
        self.robots.push(i as u32);
        i
    }

    /// Adds a puck, a disc whose floor friction is damping.
    pub fn add_puck(&mut self, cfg: &SceneConfig, pos: Vec2) -> usize {
        let m = cfg.pucks.mass;
        let r = self.puck_radius;
        let i = self.bodies.kind.len();
        self.bodies.push(
            Kind::Puck,
            pos,
            (1.0, 0.0),
            (1.0 / m, 2.0 / (m * r * r)),
            cfg.pucks.friction,
        );
        self.bodies.keep[i] = self.puck_keep;
        self.pucks.push(i as u32);
        i
    }

    /// Moves a body to a new place at rest, awake.
    pub fn teleport(&mut self, i: usize, pos: Vec2) {
        let b = &mut self.bodies;
        b.pos[i] = pos;
        b.vel[i] = Vec2::new(0.0, 0.0);
        b.spin[i] = 0.0;
        b.asleep[i] = false;
        b.still_for[i] = 0.0;
    }

    /// Sets a robot's velocity for the next physics step: `speed` along its heading, `turn`.
    pub fn drive(&mut self, i: usize, speed: f64, turn: f64) {
        let (c, s) = self.bodies.rot[i];
        self.bodies.vel[i] = Vec2::new(c * speed, s * speed);
        self.bodies.spin[i] = turn;
    }

    /// A body's position and heading as (cos, sin).
    pub fn pose_of(&self, i: usize) -> (Vec2, f64, f64) {
        let (c, s) = self.bodies.rot[i];
        (self.bodies.pos[i], c, s)
    }

    /// Contacts in the last physics step (for benchmarks and tests).
    pub fn contact_count(&self) -> usize {
        self.contacts.len()
    }

    /// Pucks asleep now.
    pub fn sleeping_pucks(&self) -> usize {
        self.pucks
            .iter()
            .filter(|&&p| self.bodies.asleep[p as usize])
            .count()
    }

    /// One physics step.
    pub fn step(&mut self) {
        self.rebuild_grids();
        self.wake_touched();
        self.find_contacts();
        let h = self.dt / SUBSTEPS as f64;
        let soft = Soft::new(h);
        solver::prepare(&mut self.contacts, &self.bodies, &self.impulses);
        for _ in 0..SUBSTEPS {
            self.damp();
            solver::warm_start(&self.contacts, &mut self.bodies);
            solver::solve(&mut self.contacts, &mut self.bodies, &soft, true);
            self.integrate(h);
            solver::solve(&mut self.contacts, &mut self.bodies, &soft, false);
        }
        self.impulses.clear();
        self.impulses.extend(
            self.contacts
                .iter()
                .map(|c| (c.key, (c.normal_impulse, c.tangent_impulse))),
        );
        self.settle();
    }

    fn rebuild_grids(&mut self) {
        let pos = &self.bodies.pos;
        self.puck_grid
            .rebuild(self.pucks.iter().map(|&p| pos[p as usize]));
        self.robot_grid
            .rebuild(self.robots.iter().map(|&r| pos[r as usize]));
    }

    /// Wakes the sleeping pucks within reach of a robot or a moving puck.
    fn wake_touched(&mut self) {
        let b = &self.bodies;
        let reach_robot = self.robot_bound + self.puck_radius + MARGIN;
        let reach_puck = 2.0 * self.puck_radius + MARGIN;
        let movers: Vec<u32> = self
            .robots
            .iter()
            .copied()
            .chain(self.pucks.iter().copied().filter(|&p| {
                let p = p as usize;
                !b.asleep[p] && moving(b, p)
            }))
            .collect();
        let woken: Vec<u32> = movers
            .par_chunks(CHUNK)
            .flat_map_iter(|chunk| {
                let mut out = Vec::new();
                for &m in chunk {
                    let m = m as usize;
                    let reach = if b.kind[m] == Kind::Robot {
                        reach_robot
                    } else {
                        reach_puck
                    };
                    let c = b.pos[m];
                    let r = Vec2::new(reach, reach);
                    self.puck_grid.query(c - r, c + r, |j| {
                        let p = self.pucks[j as usize];
                        if b.asleep[p as usize] && dist(b.pos[p as usize], c) < reach {
                            out.push(p);
                        }
                    });
                }
                out
            })
            .collect();
        for p in woken {
            self.bodies.asleep[p as usize] = false;
            self.bodies.still_for[p as usize] = 0.0;
        }
    }

    fn find_contacts(&mut self) {
        let awake: Vec<u32> = self
            .pucks
            .iter()
            .copied()
            .filter(|&p| !self.bodies.asleep[p as usize])
            .collect();
        let this = &*self;
        let robot_contacts: Vec<Vec<Contact>> = this
            .robots
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut out = Vec::new();
                for &r in chunk {
                    this.robot_contacts(r as usize, &mut out);
                }
                out
            })
            .collect();
        let puck_contacts: Vec<Vec<Contact>> = awake
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut out = Vec::new();
                for &p in chunk {
                    this.puck_contacts(p as usize, &mut out);
                }
                out
            })
            .collect();
        self.contacts.clear();
        for part in robot_contacts.into_iter().chain(puck_contacts) {
            self.contacts.extend(part);
        }
    }

    /// A robot's contacts with pucks, later robots and the wall.
    fn robot_contacts(&self, i: usize, out: &mut Vec<Contact>) {
        let b = &self.bodies;
        let frame = b.frame(i);
        let c = b.pos[i];
        let reach = self.robot_bound + self.puck_radius + MARGIN;
        let r = Vec2::new(reach, reach);
        self.puck_grid.query(c - r, c + r, |j| {
            let p = self.pucks[j as usize] as usize;
            let local = frame.unapply(b.pos[p]);
            if norm(local) > reach {
                return;
            }
            let disc = Convex::disc(local, self.puck_radius);
            for (k, part) in self.solid.iter().enumerate() {
                if let Some(m) = collide(part, &disc, MARGIN) {
                    push(out, i, p, k, 0, &m, &frame);
                }
            }
        });
        let reach = 2.0 * self.robot_bound + MARGIN;
        let r = Vec2::new(reach, reach);
        self.robot_grid.query(c - r, c + r, |j| {
            let o = self.robots[j as usize] as usize;
            if o <= i || dist(b.pos[o], c) > reach {
                return;
            }
            // The other robot's parts in this robot's frame.
            let other = b.frame(o);
            let rel = Frame {
                origin: frame.unapply(other.origin),
                cos: frame.cos * other.cos + frame.sin * other.sin,
                sin: frame.cos * other.sin - frame.sin * other.cos,
            };
            for (k, mine) in self.solid.iter().chain([&self.bow]).enumerate() {
                for (l, theirs) in self.solid.iter().chain([&self.bow]).enumerate() {
                    if let Some(m) = collide(mine, &theirs.moved(&rel), MARGIN) {
                        push(out, i, o, k, l, &m, &frame);
                    }
                }
            }
        });
        if -self.arena.signed_distance(c) - self.robot_bound > MARGIN {
            return;
        }
        for (k, part) in self.solid.iter().chain([&self.bow]).enumerate() {
            wall_contacts(&self.arena, &part.moved(&frame), MARGIN, |n, p| {
                let m = Manifold {
                    normal: n,
                    points: [p, p],
                    count: 1,
                };
                push(out, i, WALL as usize, k, 0, &m, &Frame::IDENTITY);
            });
        }
    }

    /// An awake puck's contacts with later or sleeping pucks and the wall.
    fn puck_contacts(&self, i: usize, out: &mut Vec<Contact>) {
        let b = &self.bodies;
        let c = b.pos[i];
        let rp = self.puck_radius;
        let reach = 2.0 * rp + MARGIN;
        let r = Vec2::new(reach, reach);
        let disc = Convex::disc(c, rp);
        self.puck_grid.query(c - r, c + r, |j| {
            let o = self.pucks[j as usize] as usize;
            if o == i || (o < i && !b.asleep[o]) {
                return;
            }
            if let Some(m) = collide(&disc, &Convex::disc(b.pos[o], rp), MARGIN) {
                push(out, i, o, 0, 0, &m, &Frame::IDENTITY);
            }
        });
        wall_contacts(&self.arena, &disc, MARGIN, |n, p| {
            let m = Manifold {
                normal: n,
                points: [p, p],
                count: 1,
            };
            push(out, i, WALL as usize, 0, 0, &m, &Frame::IDENTITY);
        });
    }

    /// Floor friction on the awake pucks (robots' speeds are set each physics step).
    fn damp(&mut self) {
        let b = &mut self.bodies;
        for &p in &self.pucks {
            let p = p as usize;
            if !b.asleep[p] {
                let (lin, ang) = b.keep[p];
                b.vel[p] = b.vel[p] * lin;
                b.spin[p] *= ang;
            }
        }
    }

    /// Moves every awake body by its velocity for `h`.
    fn integrate(&mut self, h: f64) {
        let b = &mut self.bodies;
        for i in 1..b.kind.len() {
            if b.asleep[i] {
                continue;
            }
            let d = b.vel[i] * h;
            b.pos[i] = b.pos[i] + d;
            b.moved[i] = b.moved[i] + d;
            let a = b.spin[i] * h;
            b.rot[i] = turn(b.rot[i], a);
            b.turned[i] = turn(b.turned[i], a);
        }
    }

    /// Ends a physics step: resets the step's displacements and puts still pucks to sleep.
    fn settle(&mut self) {
        let b = &mut self.bodies;
        for i in 0..b.kind.len() {
            b.moved[i] = Vec2::new(0.0, 0.0);
            b.turned[i] = (1.0, 0.0);
        }
        for &p in &self.pucks {
            let p = p as usize;
            if b.asleep[p] {
                continue;
            }
            if moving(b, p) {
                b.still_for[p] = 0.0;
            } else {
                b.still_for[p] += self.dt;
                if b.still_for[p] >= TIME_TO_SLEEP {
                    b.asleep[p] = true;
                    b.vel[p] = Vec2::new(0.0, 0.0);
                    b.spin[p] = 0.0;
                }
            }
        }
    }
}

impl Frame {
    const IDENTITY: Frame = Frame {
        origin: Vec2 { x: 0.0, y: 0.0 },
        cos: 1.0,
        sin: 0.0,
    };
}

fn moving(b: &Bodies, i: usize) -> bool {
    let v = b.vel[i];
    v.x * v.x + v.y * v.y > SLEEP_SPEED * SLEEP_SPEED || b.spin[i].abs() > SLEEP_SPIN
}

/// A rotation `(cos, sin)` turned by the small angle `a`, kept a unit vector.
fn turn((c, s): (f64, f64), a: f64) -> (f64, f64) {
    let (c2, s2) = (c - a * s, s + a * c);
    let n = (c2 * c2 + s2 * s2).sqrt();
    (c2 / n, s2 / n)
}

/// Adds a manifold found in `frame` between part `k` of body `a` and part `l` of body `b`.
fn push(
    out: &mut Vec<Contact>,
    a: usize,
    b: usize,
    k: usize,
    l: usize,
    m: &Manifold,
    frame: &Frame,
) {
    let normal = frame.rotate(m.normal);
    for p in m.points() {
        out.push(Contact::new(
            a as u32,
            b as u32,
            solver::key(a, b, k, l, p.feature),
            normal,
            frame.apply(p.at),
            p.separation,
        ));
    }
}
