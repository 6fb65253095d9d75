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
//!   a robot or a moving puck comes within reach and wakes it (a robot's contacts are
//!   found first, and what they reach wakes before the pucks' contacts are found). A sleeper touched by a body that is
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
mod strips;

use std::collections::HashMap;

use rayon::prelude::*;

use crate::arena::Arena;
use crate::body::{Part, RobotGeometry};
use crate::config::SceneConfig;
use crate::grid::Grid;
use crate::types::{Pose, Vec2};

use shape::{collide, dist, norm, wall_contacts, Convex, Frame, Manifold};
use solver::{Contact, Soft};
use strips::Strips;

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
pub(crate) enum Kind {
    Wall,
    Robot,
    Puck,
}

/// Every body's state, one array per quantity.
#[derive(Debug, Default)]
pub(crate) struct Bodies {
    pos: Vec<Vec2>,
    /// Heading as (cos, sin).
    rot: Vec<(f64, f64)>,
    /// What the solver reads and writes, together (one cache line a body).
    state: Vec<State>,
    inv_mass: Vec<f64>,
    inv_inertia: Vec<f64>,
    friction: Vec<f64>,
    /// The share of linear and angular speed a body keeps each substep (floor friction).
    keep: Vec<(f64, f64)>,
    asleep: Vec<bool>,
    still_for: Vec<f64>,
}

/// A body's velocity, and how far it moved and turned since the physics step began (for
/// the contacts' separations).
#[derive(Debug, Clone, Copy)]
pub(crate) struct State {
    vel: Vec2,
    spin: f64,
    moved: Vec2,
    turned: (f64, f64),
}

impl State {
    const REST: State = State {
        vel: Vec2 { x: 0.0, y: 0.0 },
        spin: 0.0,
        moved: Vec2 { x: 0.0, y: 0.0 },
        turned: (1.0, 0.0),
    };
}

impl Bodies {
    fn push(&mut self, kind: Kind, pos: Vec2, rot: (f64, f64), inv: (f64, f64), friction: f64) {
        self.pos.push(pos);
        self.rot.push(rot);
        self.state.push(State::REST);
        self.inv_mass.push(inv.0);
        self.inv_inertia.push(inv.1);
        self.friction.push(friction);
        self.keep.push((1.0, 1.0));
        self.asleep.push(kind == Kind::Wall);
        self.still_for.push(0.0);
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
    /// The pucks awake in this physics step, in id order (found once the robots' touch
    /// has woken theirs).
    awake: Vec<u32>,
    /// A robot's solid parts and its bow, robot frame.
    solid: Vec<Convex>,
    bow: Convex,
    robot_bound: f64,
    puck_radius: f64,
    puck_keep: (f64, f64),
    puck_grid: Grid,
    robot_grid: Grid,
    contacts: Vec<Contact>,
    strips: Strips,
    /// Last step's impulses by contact key, to start this step's from.
    impulses: HashMap<u64, (f64, f64), solver::KeyHash>,
    /// Seconds spent in each stage since the engine was made (see [`STAGES`]).
    stage_seconds: [f64; STAGES.len()],
}

/// The stages of a physics step, in order, as [`DiscEngine::stage_seconds`] names them.
pub(crate) const STAGES: [&str; 5] = ["grids", "wake", "contacts", "solver", "sleep"];

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
            awake: Vec::new(),
            solid,
            bow,
            robot_bound,
            puck_radius,
            puck_keep: (
                keep(cfg.pucks.linear_damping),
                keep(cfg.pucks.angular_damping),
            ),
            // Cells two pucks wide: fewer cells to clear and sum each step, at a few more
            // pucks per query (BENCHMARKS.md, "Choosing the contact engine").
            puck_grid: Grid::new(half, cell(2.0 * (2.0 * puck_radius + MARGIN))),
            robot_grid: Grid::new(half, cell(2.0 * robot_bound + MARGIN)),
            contacts: Vec::new(),
            strips: Strips::new(arena.half_width()),
            impulses: HashMap::default(),
            stage_seconds: [0.0; STAGES.len()],
        }
    }

    /// Adds a robot; its centre of mass is the body rectangle's centre.
    pub fn add_robot(&mut self, cfg: &SceneConfig, pose: Pose) -> usize {
        let m = cfg.robots.mass;
        let (l, w) = (cfg.robots.length, cfg.robots.width);
        let inertia = m * (l * l + w * w) / 12.0;
        let (s, c) = libm::sincos(pose.theta);
        let i = self.bodies.pos.len();
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
        let i = self.bodies.pos.len();
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
        b.state[i] = State::REST;
        b.asleep[i] = false;
        b.still_for[i] = 0.0;
    }

    /// Sets a robot's velocity for the next physics step: `speed` along its heading, `turn`.
    pub fn drive(&mut self, i: usize, speed: f64, turn: f64) {
        let (c, s) = self.bodies.rot[i];
        self.bodies.state[i].vel = Vec2::new(c * speed, s * speed);
        self.bodies.state[i].spin = turn;
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

    /// Seconds spent in each of [`STAGES`] since the engine was made.
    pub fn stage_seconds(&self) -> [f64; STAGES.len()] {
        self.stage_seconds
    }

    /// One physics step.
    pub fn step(&mut self) {
        let mut clock = std::time::Instant::now();
        let mut lap = |engine: &mut DiscEngine, stage: usize| {
            let now = std::time::Instant::now();
            engine.stage_seconds[stage] += (now - clock).as_secs_f64();
            clock = now;
        };
        self.rebuild_grids();
        lap(self, 0);
        let touched = self.find_robot_contacts();
        lap(self, 2);
        self.wake(touched);
        lap(self, 1);
        self.find_puck_contacts();
        lap(self, 2);
        self.solve();
        lap(self, 3);
        self.settle();
        lap(self, 4);
    }

    fn solve(&mut self) {
        let h = self.dt / SUBSTEPS as f64;
        let soft = Soft::new(h);
        solver::prepare(&mut self.contacts, &self.bodies, &self.impulses);
        let moving: Vec<u32> = self.robots.iter().chain(&self.awake).copied().collect();
        self.strips
            .arrange(&self.bodies, &moving, &mut self.contacts);
        let strips = &self.strips;
        let mut states = strips.gather(&self.bodies);
        let keep: Vec<(f64, f64)> = strips
            .order
            .iter()
            .map(|&i| self.bodies.keep[i as usize])
            .collect();
        for _ in 0..SUBSTEPS {
            // Floor friction (a robot keeps all: its speed is set each physics step).
            for (st, &(lin, ang)) in states.iter_mut().zip(&keep) {
                st.vel = st.vel * lin;
                st.spin *= ang;
            }
            strips.run(&mut self.contacts, &mut states, &|c, s, o| {
                solver::warm_start(c, s, o)
            });
            strips.run(&mut self.contacts, &mut states, &|c, s, o| {
                solver::solve(c, s, o, &soft, true)
            });
            for st in &mut states {
                st.moved = st.moved + st.vel * h;
                st.turned = turn(st.turned, st.spin * h);
            }
            strips.run(&mut self.contacts, &mut states, &|c, s, o| {
                solver::solve(c, s, o, &soft, false)
            });
        }
        let b = &mut self.bodies;
        for (&i, st) in strips.order.iter().zip(&states) {
            let i = i as usize;
            b.pos[i] = b.pos[i] + st.moved;
            let ((c1, s1), (c0, s0)) = (st.turned, b.rot[i]);
            b.rot[i] = turn((c1 * c0 - s1 * s0, s1 * c0 + c1 * s0), 0.0);
            b.state[i] = *st;
        }
        self.impulses.clear();
        self.impulses.extend(
            self.contacts
                .iter()
                .map(|c| (c.key, (c.normal_impulse, c.tangent_impulse))),
        );
    }

    fn rebuild_grids(&mut self) {
        let pos = &self.bodies.pos;
        self.puck_grid
            .rebuild(self.pucks.iter().map(|&p| pos[p as usize]));
        self.robot_grid
            .rebuild(self.robots.iter().map(|&r| pos[r as usize]));
    }

    /// Every robot's contacts (the first of the step's), and the sleeping pucks within
    /// their reach, which wake.
    fn find_robot_contacts(&mut self) -> Vec<u32> {
        let this = &*self;
        let found: Vec<(Vec<Contact>, Vec<u32>)> = this
            .robots
            .par_chunks(CHUNK)
            .map(|chunk| {
                let (mut out, mut woken) = (Vec::new(), Vec::new());
                for &r in chunk {
                    this.robot_contacts(r as usize, &mut out, &mut woken);
                }
                (out, woken)
            })
            .collect();
        self.contacts.clear();
        let mut woken = Vec::new();
        for (contacts, touched) in found {
            self.contacts.extend(contacts);
            woken.extend(touched);
        }
        woken
    }

    /// Wakes `touched` and the sleeping pucks within reach of a moving puck.
    fn wake(&mut self, mut touched: Vec<u32>) {
        let b = &self.bodies;
        let reach = 2.0 * self.puck_radius + MARGIN;
        let movers: Vec<u32> = self
            .pucks
            .iter()
            .copied()
            .filter(|&p| !b.asleep[p as usize] && moving(b, p as usize))
            .collect();
        let near_movers: Vec<u32> = movers
            .par_chunks(CHUNK)
            .flat_map_iter(|chunk| {
                let mut out = Vec::new();
                for &m in chunk {
                    let c = b.pos[m as usize];
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
        touched.extend(near_movers);
        for p in touched {
            self.bodies.asleep[p as usize] = false;
            self.bodies.still_for[p as usize] = 0.0;
        }
    }

    /// Every awake puck's contacts with later or sleeping pucks and the wall, after the
    /// robots'.
    fn find_puck_contacts(&mut self) {
        let asleep = &self.bodies.asleep;
        self.awake.clear();
        self.awake
            .extend(self.pucks.iter().copied().filter(|&p| !asleep[p as usize]));
        let this = &*self;
        let found: Vec<Vec<Contact>> = this
            .awake
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut out = Vec::new();
                for &p in chunk {
                    this.puck_contacts(p as usize, &mut out);
                }
                out
            })
            .collect();
        for part in found {
            self.contacts.extend(part);
        }
    }

    /// A robot's contacts with pucks, later robots and the wall; the sleeping pucks it
    /// could touch go to `woken`.
    fn robot_contacts(&self, i: usize, out: &mut Vec<Contact>, woken: &mut Vec<u32>) {
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
            if b.asleep[p] {
                woken.push(p as u32);
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
        if shape::wall_gap(&self.arena, c).0 - self.robot_bound > MARGIN {
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

    /// Ends a physics step: resets the step's displacements and puts still pucks to sleep.
    fn settle(&mut self) {
        let b = &mut self.bodies;
        for &i in self.robots.iter().chain(&self.awake) {
            let st = &mut b.state[i as usize];
            st.moved = Vec2::new(0.0, 0.0);
            st.turned = (1.0, 0.0);
        }
        for &p in &self.awake {
            let p = p as usize;
            if moving(b, p) {
                b.still_for[p] = 0.0;
            } else {
                b.still_for[p] += self.dt;
                if b.still_for[p] >= TIME_TO_SLEEP {
                    b.asleep[p] = true;
                    b.state[p] = State::REST;
                }
            }
        }
    }
}

fn moving(b: &Bodies, i: usize) -> bool {
    let State { vel: v, spin, .. } = b.state[i];
    v.x * v.x + v.y * v.y > SLEEP_SPEED * SLEEP_SPEED || spin.abs() > SLEEP_SPIN
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
