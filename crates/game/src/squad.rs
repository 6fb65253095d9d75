//! Server-side swarm intelligence (the paper's section 4.3): a squad
//! arbitrator per squad turns the player's command into a sequence command
//! for each robot.
//!
//! | priority | squad behaviour | wants control when |
//! |---|---|---|
//! | 30 | `shoot` | an enemy is within range of a member: members in range shoot, the rest hold |
//! | 20 | `avoid-squads` | another squad's predicted path comes within reach of this one's (Fig. 5): sidestep, then resume |
//! | 10 | `order` | the player's command (gather, goto, defend, attack, capture) is being carried out |
//! | 0 | `hold` | nothing to do |
//!
//! When `shoot` or `avoid-squads` hands control back, `order` replans from
//! where the robots are now, so the previous path is resumed.

use std::sync::Arc;

use colony_behave::{Arbitrator, Behaviour, Reason};
use colony_sim::Vec2;

use crate::formation::{along_path, assign, Formation};
use crate::nav::Nav;
use crate::path::{Mover, Replanner};
use crate::protocol::{Command, SquadState, Target, Verb};
use crate::rules::{KindRules, RobotKind};

/// A robot as the swarm intelligence sees it this tick.
#[derive(Debug, Clone, PartialEq)]
pub struct SeenRobot {
    /// Its id.
    pub id: u32,
    /// Its team.
    pub team: String,
    /// Its type.
    pub kind: RobotKind,
    /// Where it is, cm.
    pub at: Vec2,
    /// Not destroyed.
    pub alive: bool,
}

/// A squad's motion, for collision mitigation between squads.
#[derive(Debug, Clone, PartialEq)]
pub struct SquadMotion {
    /// Its team.
    pub team: String,
    /// Its name.
    pub name: String,
    /// The centroid of its living members, cm.
    pub centroid: Vec2,
    /// How fast the centroid moves, cm/s.
    pub velocity: Vec2,
    /// The farthest member from the centroid plus a body, cm.
    pub radius: f64,
}

/// The world as the swarm intelligence sees it this tick.
#[derive(Debug, Clone, Default)]
pub struct View {
    /// Game time, s.
    pub time: f64,
    /// Every robot, indexed by id.
    pub robots: Vec<SeenRobot>,
    /// Flags: team, where, carrier.
    pub flags: Vec<(String, Vec2, Option<u32>)>,
    /// Bases: team, where.
    pub bases: Vec<(String, Vec2)>,
    /// Every squad's motion.
    pub squads: Vec<SquadMotion>,
}

impl View {
    fn robot(&self, id: u32) -> Option<&SeenRobot> {
        self.robots.get(id as usize)
    }

    fn flag(&self, team: &str) -> Option<(Vec2, Option<u32>)> {
        self.flags.iter().find(|f| f.0 == team).map(|f| (f.1, f.2))
    }

    fn base(&self, team: &str) -> Option<Vec2> {
        self.bases.iter().find(|b| b.0 == team).map(|b| b.1)
    }
}

/// What the squad behaviours share.
pub struct SquadCtx {
    /// This tick's world.
    pub view: Arc<View>,
    /// The squad's team.
    pub team: String,
    /// The squad's name.
    pub name: String,
    /// Its robots' ids.
    pub members: Vec<u32>,
    /// Its formation.
    pub formation: Formation,
    /// Spacing between robots in formation (the paper's d), cm.
    pub spacing: f64,
    /// The player's command.
    pub verb: Option<Verb>,
    /// A new command arrived since the last tick.
    pub fresh: bool,
    /// A higher behaviour had control: the order must be replanned from here.
    replan: bool,
    /// Path finding.
    pub nav: Nav,
    /// Orders to send: robot, commands.
    pub out: Vec<(u32, Vec<Command>)>,
    /// The squad's planned path, cm.
    pub path: Vec<Vec2>,
}

impl SquadCtx {
    fn alive(&self) -> Vec<&SeenRobot> {
        self.members
            .iter()
            .filter_map(|&id| self.view.robot(id))
            .filter(|r| r.alive)
            .collect()
    }

    fn centroid(&self) -> Option<Vec2> {
        let alive = self.alive();
        if alive.is_empty() {
            return None;
        }
        let sum = alive.iter().fold(Vec2::ZERO, |s, r| s + r.at);
        Some(sum * (1.0 / alive.len() as f64))
    }

    /// Land, unless every living member swims.
    fn mover(&self) -> Mover {
        if self.alive().iter().all(|r| r.kind.stats().amphibious) {
            Mover::Amphibious
        } else {
            Mover::Land
        }
    }

    fn slowest(&self) -> f64 {
        self.alive()
            .iter()
            .map(|r| r.kind.stats().speed_cm_s)
            .fold(f64::INFINITY, f64::min)
    }

    fn target(&self, t: &Target) -> Option<Vec2> {
        match t {
            Target::Robot(id) => self.view.robot(*id).filter(|r| r.alive).map(|r| r.at),
            Target::Flag(team) => self.view.flag(team).map(|f| f.0),
            Target::Base(team) => self.view.base(team),
            Target::Point(p) => Some(*p),
        }
    }

    /// Sends the squad along `path` (turn points, cm) in `formation`:
    /// gathering first when asked (each robot plans its own way to its slot
    /// at the start), then slot by slot along the path. With `pickup`, the
    /// robot whose last slot is nearest the flag goes on to take it.
    fn dispatch(
        &mut self,
        path: Vec<Vec2>,
        formation: Formation,
        gather: bool,
        pickup: Option<(String, Vec2)>,
    ) {
        let members: Vec<(u32, Vec2, RobotKind)> =
            self.alive().iter().map(|r| (r.id, r.at, r.kind)).collect();
        if members.is_empty() || path.is_empty() {
            return;
        }
        let mover = self.mover();
        let facing = match path.as_slice() {
            [a, b, ..] => (*b - *a).angle(),
            [a] => self.centroid().map_or(0.0, |c| (*a - c).angle()),
            [] => 0.0,
        };
        let nav = &self.nav;
        // Room for the widest member plus a margin, so no slot puts a robot
        // against a wall or the water's edge, where its reflexes would fight.
        let room = members
            .iter()
            .map(|m| m.2.stats().radius_cm)
            .fold(0.0, f64::max)
            + ROOM_MARGIN_CM;
        let slots = along_path(&path, formation, members.len(), self.spacing, facing, |p| {
            nav.has_room(p, mover, room)
        });
        let starts: Vec<Vec2> = slots.iter().map(|s| s[0]).collect();
        let positions: Vec<Vec2> = members.iter().map(|m| m.1).collect();
        let assigned = assign(&positions, &starts);
        let speed = self.slowest();
        let picker = pickup.as_ref().and_then(|(_, at)| {
            (0..members.len()).min_by(|&a, &b| {
                let la = slots[assigned[a]]
                    .last()
                    .map_or(f64::INFINITY, |p| p.distance(*at));
                let lb = slots[assigned[b]]
                    .last()
                    .map_or(f64::INFINITY, |p| p.distance(*at));
                la.total_cmp(&lb)
            })
        });
        for (k, &(id, at, kind)) in members.iter().enumerate() {
            let own = &slots[assigned[k]];
            let mut cmds = Vec::new();
            let robot_mover = if kind.stats().amphibious {
                Mover::Amphibious
            } else {
                Mover::Land
            };
            let first = own[0];
            if gather && !self.nav.line_of_sight(at, first, robot_mover) {
                if let Some(way) = self.nav.plan(at, first, robot_mover) {
                    cmds.extend(
                        way.into_iter()
                            .skip(1)
                            .map(|to| Command::GoTo { to, speed: None }),
                    );
                }
            }
            cmds.push(Command::GoTo {
                to: first,
                speed: if gather { None } else { Some(speed) },
            });
            // A slot beside the squad's path can see round a corner the
            // path itself clears: where the straight leg from one slot to the
            // next is blocked, the robot takes its own way round.
            for leg in own.windows(2) {
                let (a, b) = (leg[0], leg[1]);
                if !self.nav.line_of_sight(a, b, robot_mover) {
                    if let Some(way) = self.nav.plan(a, b, robot_mover) {
                        let inner = way.len().saturating_sub(1);
                        cmds.extend(way[1..inner].iter().map(|&to| Command::GoTo {
                            to,
                            speed: Some(speed),
                        }));
                    }
                }
                cmds.push(Command::GoTo {
                    to: b,
                    speed: Some(speed),
                });
            }
            if let (Some(p), Some((flag, at))) = (picker, &pickup) {
                if p == k {
                    cmds.push(Command::GoTo {
                        to: *at,
                        speed: None,
                    });
                    cmds.push(Command::PickUp { flag: flag.clone() });
                }
            }
            self.out.push((id, cmds));
        }
        self.path = path;
    }
}

/// Clearance kept around a formation slot beyond the robot's radius, cm.
const ROOM_MARGIN_CM: f64 = 4.0;

/// Automatic shooting: every member with an enemy in range shoots the
/// nearest one; the others hold their ground.
#[derive(Default)]
struct Shoot {
    /// Per member: the target it was told to shoot and where it was then.
    told: Vec<(u32, Option<(u32, Vec2)>)>,
}

impl Shoot {
    fn targets(ctx: &SquadCtx) -> Vec<(u32, Option<(u32, Vec2)>)> {
        ctx.alive()
            .iter()
            .map(|m| {
                let range = m.kind.stats().range_cm;
                let target = ctx
                    .view
                    .robots
                    .iter()
                    .filter(|e| e.alive && e.team != ctx.team)
                    .map(|e| (e, e.at.distance(m.at)))
                    .filter(|(_, d)| *d <= range)
                    .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.id.cmp(&b.0.id)))
                    .map(|(e, _)| (e.id, e.at));
                (m.id, target)
            })
            .collect()
    }
}

impl Behaviour<SquadCtx> for Shoot {
    fn name(&self) -> &str {
        "shoot"
    }

    fn wants_control(&mut self, ctx: &SquadCtx) -> Option<Reason> {
        let (m, t) = Self::targets(ctx)
            .into_iter()
            .find_map(|(m, t)| t.map(|t| (m, t.0)))?;
        Some(format!("enemy robot {t} in range of robot {m}").into())
    }

    fn act(&mut self, ctx: &mut SquadCtx) {
        for (member, target) in Self::targets(ctx) {
            let before = self
                .told
                .iter()
                .find(|t| t.0 == member)
                .and_then(|t| t.1.map(Some))
                .unwrap_or(None);
            let same = match (before, target) {
                (Some((a, pa)), Some((b, pb))) => a == b && pa.distance(pb) < 10.0,
                (None, None) => self.told.iter().any(|t| t.0 == member),
                _ => false,
            };
            if same {
                continue;
            }
            let cmd = match target {
                Some((target, at)) => Command::Shoot { target, at },
                None => Command::Stop,
            };
            ctx.out.push((member, vec![cmd]));
            self.told.retain(|t| t.0 != member);
            self.told.push((member, target));
        }
    }

    fn suppressed(&mut self, _ctx: &mut SquadCtx) {
        self.told.clear();
    }
}

/// How far ahead collisions between squads are predicted, s.
const HORIZON_S: f64 = 3.0;
/// Extra room kept between squads, cm.
const SQUAD_MARGIN: f64 = 10.0;
/// A sidestep is given up after this long, s.
const SIDESTEP_S: f64 = 3.0;
/// After a sidestep, none for this long, s.
const SIDESTEP_COOLDOWN_S: f64 = 6.0;

/// Fig. 5: check for inbound collisions with other squads; when one is
/// coming, sidestep perpendicular to the way we go, away from the other.
/// Of two squads on a collision course only one yields (the one whose
/// `team/name` sorts later), so they don't both dodge into each other.
#[derive(Default)]
struct AvoidSquads {
    until: Option<f64>,
    other: String,
    /// No new sidestep before this time: two squads bound for one place must
    /// not dodge each other forever.
    quiet_until: f64,
}

impl AvoidSquads {
    fn inbound(ctx: &SquadCtx) -> Option<(Vec2, &SquadMotion, f64)> {
        let me = ctx
            .view
            .squads
            .iter()
            .find(|s| s.team == ctx.team && s.name == ctx.name)?;
        if me.velocity.length() < 2.0 {
            return None;
        }
        let mine = (ctx.team.as_str(), ctx.name.as_str());
        ctx.view
            .squads
            .iter()
            .filter(|o| (o.team.as_str(), o.name.as_str()) < mine)
            // A parked squad is a static obstacle for the path and the
            // robots' reflexes, not an inbound collision.
            .filter(|o| o.velocity.length() >= 2.0)
            .filter_map(|o| {
                let p = o.centroid - me.centroid;
                let v = o.velocity - me.velocity;
                let vv = v.x * v.x + v.y * v.y;
                if vv < 1e-6 {
                    return None;
                }
                let t = (-(p.x * v.x + p.y * v.y) / vv).clamp(0.0, HORIZON_S);
                let closest = p + v * t;
                let reach = me.radius + o.radius + SQUAD_MARGIN;
                (t > 0.0 && closest.length() < reach).then_some((
                    closest,
                    o,
                    reach - closest.length(),
                ))
            })
            .min_by(|a, b| a.0.length().total_cmp(&b.0.length()))
    }
}

impl Behaviour<SquadCtx> for AvoidSquads {
    fn name(&self) -> &str {
        "avoid-squads"
    }

    fn wants_control(&mut self, ctx: &SquadCtx) -> Option<Reason> {
        if let Some(until) = self.until {
            if ctx.view.time < until {
                return Some(format!("sidestepping squad {}", self.other).into());
            }
            self.until = None;
            self.quiet_until = ctx.view.time + SIDESTEP_COOLDOWN_S;
        }
        if ctx.view.time < self.quiet_until {
            return None;
        }
        let (_, other, _) = Self::inbound(ctx)?;
        Some(format!("inbound collision with squad {}/{}", other.team, other.name).into())
    }

    fn act(&mut self, ctx: &mut SquadCtx) {
        if self.until.is_some() {
            return;
        }
        let Some((closest, other, depth)) = Self::inbound(ctx) else {
            return;
        };
        let name = format!("{}/{}", other.team, other.name);
        let me = ctx
            .view
            .squads
            .iter()
            .find(|s| s.team == ctx.team && s.name == ctx.name)
            .map(|s| s.velocity)
            .unwrap_or(Vec2::ZERO);
        // Perpendicular to our heading, on the side away from the other squad.
        let len = me.length().max(1e-9);
        let mut side = Vec2::new(-me.y / len, me.x / len);
        if side.x * closest.x + side.y * closest.y > 0.0 {
            side = side * -1.0;
        }
        let step = side * (depth + SQUAD_MARGIN);
        let mover = ctx.mover();
        let moves: Vec<(u32, Vec2)> = ctx.alive().iter().map(|r| (r.id, r.at + step)).collect();
        if moves.iter().any(|(_, p)| !ctx.nav.is_free(*p, mover)) {
            // No room to sidestep: the robots' own reflexes will have to do.
            return;
        }
        for (id, to) in moves {
            ctx.out.push((id, vec![Command::GoTo { to, speed: None }]));
        }
        self.other = name;
        self.until = Some(ctx.view.time + SIDESTEP_S);
    }

    fn suppressed(&mut self, _ctx: &mut SquadCtx) {
        self.until = None;
    }
}

/// Where a multi-step order stands.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Going for the object.
    Going,
    /// Capture: the flag is ours, bringing it home.
    Returning,
    /// Nothing more to send.
    Done,
}

/// The player's command, carried out.
struct OrderBehaviour {
    phase: Phase,
    /// Where the last plan was made to.
    goal: Option<Vec2>,
    replanner: Option<Replanner>,
}

/// A squad this many cells (Chebyshev) from the replanner's root re-roots it.
const REROOT_CELLS: u32 = 3;

/// A moving target is followed once it has moved this many cells...
const FOLLOW_CELLS: f64 = 1.5;
/// ...and this fraction of the squad's distance to it. Every new plan sends
/// each robot to its slot at the head of the path again, so a squad told
/// anew each time a distant target stirs keeps re-forming and never sets
/// off; far away, a small move of the target changes only the end of the
/// path, which a later plan corrects as the squad closes in.
const FOLLOW_FRACTION: f64 = 0.25;

impl OrderBehaviour {
    fn start(&mut self, ctx: &mut SquadCtx, gather: bool) {
        let Some(verb) = ctx.verb.clone() else {
            return;
        };
        self.replanner = None;
        self.goal = None;
        let Some(centroid) = ctx.centroid() else {
            self.phase = Phase::Done;
            return;
        };
        let mover = ctx.mover();
        match verb {
            Verb::Stop => {
                for id in ctx.alive().iter().map(|r| r.id).collect::<Vec<_>>() {
                    ctx.out.push((id, vec![Command::Stop]));
                }
                ctx.path.clear();
                self.phase = Phase::Done;
            }
            Verb::Gather(at) => {
                let at = at.unwrap_or(centroid);
                let at = ctx.nav.nearest_free(at, mover).map(|c| ctx.nav.centre(c));
                if let Some(at) = at {
                    ctx.dispatch(vec![at], ctx.formation, true, None);
                }
                self.goal = at;
                self.phase = Phase::Going;
            }
            Verb::GoTo(to) => {
                if let Some(path) = ctx.nav.plan(centroid, to, mover) {
                    ctx.dispatch(path, ctx.formation, gather, None);
                }
                self.goal = Some(to);
                // Going until the squad is there, so a sidestep or a fight on
                // the way hands control back here and the path is resumed.
                self.phase = Phase::Going;
            }
            Verb::Defend(ref t) | Verb::Attack(ref t) => {
                let Some(to) = ctx.target(t) else {
                    self.phase = Phase::Done;
                    return;
                };
                let formation = match (&verb, t) {
                    (Verb::Defend(Target::Robot(_)), _) => Formation::HalfCircle,
                    (Verb::Defend(_), _) => Formation::Circle,
                    _ => Formation::HalfCircle,
                };
                self.replanner = ctx.nav.replanner(centroid, to, mover);
                let path = self
                    .replanner
                    .as_mut()
                    .and_then(|r| r.plan())
                    .map(|p| ctx.nav.points(&p, mover));
                if let Some(path) = path {
                    ctx.dispatch(path, formation, gather, None);
                }
                self.goal = Some(to);
                self.phase = Phase::Going;
            }
            Verb::Capture(ref flag) => {
                let Some((at, carrier)) = ctx.view.flag(flag) else {
                    self.phase = Phase::Done;
                    return;
                };
                if carrier.is_some_and(|c| ctx.members.contains(&c)) {
                    let home = ctx.view.base(&ctx.team).unwrap_or(centroid);
                    if let Some(path) = ctx.nav.plan(centroid, home, mover) {
                        ctx.dispatch(path, ctx.formation, false, None);
                    }
                    self.goal = Some(home);
                    self.phase = Phase::Returning;
                } else {
                    if let Some(path) = ctx.nav.plan(centroid, at, mover) {
                        ctx.dispatch(path, ctx.formation, gather, Some((flag.clone(), at)));
                    }
                    self.goal = Some(at);
                    self.phase = Phase::Going;
                }
            }
        }
    }

    /// Whether the object of the order, now at `to`, has moved far enough
    /// from where the last plan went to call for a new one.
    fn target_moved(&self, ctx: &SquadCtx, to: Vec2) -> bool {
        let far = ctx.centroid().map_or(0.0, |c| c.distance(to));
        let tolerance = (FOLLOW_CELLS * ctx.nav.field().cell_cm).max(FOLLOW_FRACTION * far);
        self.goal.is_none_or(|g| g.distance(to) > tolerance)
    }

    /// Follows a moving target with a partial replan from the earlier search.
    fn follow(&mut self, ctx: &mut SquadCtx, to: Vec2, formation: Formation) {
        let mover = ctx.mover();
        let (Some(cell), Some(from)) = (
            ctx.nav.nearest_free(to, mover),
            ctx.centroid().and_then(|c| ctx.nav.nearest_free(c, mover)),
        ) else {
            return;
        };
        let Some(r) = self.replanner.as_mut() else {
            return self.start(ctx, false);
        };
        // The paper's partial A*: the search stays rooted where the attack
        // began, so a moving target only re-keys the goal and the earlier
        // search is reused; the squad joins the new path at its cell nearest
        // to where the squad is. Only a squad that strayed from the old
        // search's root re-roots it (as costly as a fresh search).
        let root = r.start();
        let strayed = (root.x.abs_diff(from.x)).max(root.y.abs_diff(from.y)) > REROOT_CELLS;
        if strayed {
            r.set_start(from);
        }
        r.set_goal(cell);
        let path = r.plan().map(|mut p| {
            let join = p
                .cells
                .iter()
                .enumerate()
                .min_by_key(|(_, c)| {
                    let (dx, dy) = (c.x.abs_diff(from.x), c.y.abs_diff(from.y));
                    dx.max(dy)
                })
                .map_or(0, |(k, _)| k);
            p.cells.drain(..join);
            ctx.nav.points(&p, mover)
        });
        if let Some(path) = path {
            ctx.dispatch(path, formation, false, None);
        }
        self.goal = Some(to);
    }
}

impl Behaviour<SquadCtx> for OrderBehaviour {
    fn name(&self) -> &str {
        "order"
    }

    fn wants_control(&mut self, ctx: &SquadCtx) -> Option<Reason> {
        let verb = ctx.verb.as_ref()?;
        if ctx.fresh || ctx.replan || self.phase != Phase::Done {
            Some(verb.to_string().into())
        } else {
            None
        }
    }

    fn act(&mut self, ctx: &mut SquadCtx) {
        if ctx.fresh || ctx.replan {
            let gather = ctx.fresh;
            ctx.fresh = false;
            ctx.replan = false;
            self.phase = Phase::Done;
            return self.start(ctx, gather);
        }
        let cell = ctx.nav.field().cell_cm;
        match ctx.verb.clone() {
            Some(Verb::Attack(t)) | Some(Verb::Defend(t)) => {
                let Some(to) = ctx.target(&t) else {
                    // The target is gone (destroyed): the order is done.
                    self.phase = Phase::Done;
                    return;
                };
                if self.target_moved(ctx, to) {
                    let formation = if matches!(
                        ctx.verb,
                        Some(Verb::Defend(
                            Target::Flag(_) | Target::Base(_) | Target::Point(_)
                        ))
                    ) {
                        Formation::Circle
                    } else {
                        Formation::HalfCircle
                    };
                    self.follow(ctx, to, formation);
                }
            }
            Some(Verb::Capture(flag)) => {
                let Some((at, carrier)) = ctx.view.flag(&flag) else {
                    self.phase = Phase::Done;
                    return;
                };
                let ours = carrier.is_some_and(|c| ctx.members.contains(&c));
                let restart = match self.phase {
                    Phase::Going => ours || self.target_moved(ctx, at),
                    // Dropped (the carrier was destroyed) or captured and home again.
                    Phase::Returning => !ours,
                    Phase::Done => true,
                };
                if restart {
                    self.start(ctx, false);
                }
            }
            Some(Verb::GoTo(_) | Verb::Gather(_)) => {
                let n = ctx.alive().len() as f64;
                let near = cell + n * ctx.spacing;
                if let (Some(c), Some(g)) = (ctx.centroid(), self.goal) {
                    if c.distance(g) <= near {
                        self.phase = Phase::Done;
                    }
                }
            }
            _ => self.phase = Phase::Done,
        }
    }

    fn suppressed(&mut self, ctx: &mut SquadCtx) {
        ctx.replan = true;
    }
}

/// Nothing to do: the robots finish what they were told.
struct Hold;

impl Behaviour<SquadCtx> for Hold {
    fn name(&self) -> &str {
        "hold"
    }
    fn wants_control(&mut self, _ctx: &SquadCtx) -> Option<Reason> {
        Some("no order".into())
    }
    fn act(&mut self, _ctx: &mut SquadCtx) {}
}

/// One squad's arbitrator and what it knows.
pub struct Squad {
    arbitrator: Arbitrator<SquadCtx>,
    ctx: SquadCtx,
    order_text: String,
}

impl Squad {
    /// A squad of `members` of `team`, navigating with `nav`.
    pub fn new(team: &str, name: &str, members: Vec<u32>, spacing: f64, nav: Nav) -> Squad {
        let mut arbitrator = Arbitrator::new();
        arbitrator.add(30, Shoot::default());
        arbitrator.add(20, AvoidSquads::default());
        arbitrator.add(
            10,
            OrderBehaviour {
                phase: Phase::Done,
                goal: None,
                replanner: None,
            },
        );
        arbitrator.add(0, Hold);
        Squad {
            arbitrator,
            ctx: SquadCtx {
                view: Arc::new(View::default()),
                team: team.to_string(),
                name: name.to_string(),
                members,
                formation: Formation::Wedge,
                spacing,
                verb: None,
                fresh: false,
                replan: false,
                nav,
                out: Vec::new(),
                path: Vec::new(),
            },
            order_text: "none".to_string(),
        }
    }

    /// Its team.
    pub fn team(&self) -> &str {
        &self.ctx.team
    }

    /// Its name.
    pub fn name(&self) -> &str {
        &self.ctx.name
    }

    /// Its robots.
    pub fn members(&self) -> &[u32] {
        &self.ctx.members
    }

    /// Takes a player's command (already checked by the caller).
    pub fn command(&mut self, verb: Verb, formation: Option<Formation>) {
        if let Some(f) = formation {
            self.ctx.formation = f;
        }
        self.order_text = verb.to_string();
        self.ctx.verb = Some(verb);
        self.ctx.fresh = true;
    }

    /// One tick of the squad arbitrator on this view; returns the orders to
    /// send (robot, commands).
    pub fn tick(&mut self, view: Arc<View>) -> Vec<(u32, Vec<Command>)> {
        self.ctx.view = view;
        self.arbitrator.step(&mut self.ctx);
        std::mem::take(&mut self.ctx.out)
    }

    /// What the player sees of the squad.
    pub fn state(&self) -> SquadState {
        let active = self.arbitrator.active();
        SquadState {
            team: self.ctx.team.clone(),
            name: self.ctx.name.clone(),
            formation: self.ctx.formation,
            order: self.order_text.clone(),
            behaviour: active.map_or(String::new(), |d| format!("{}: {}", d.name, d.reason)),
            path: self.ctx.path.clone(),
        }
    }

    /// The behaviour in control after the last tick.
    pub fn active(&self) -> Option<&str> {
        self.arbitrator.active().map(|d| d.name.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::Battlefield;

    /// 40 x 20 cells of open ground inside a wall, 25 cm cells.
    fn nav() -> Nav {
        let mut text = format!(
            "type octile\nheight 20\nwidth 40\nmap\n{}\n",
            "@".repeat(40)
        );
        for _ in 0..18 {
            text.push_str(&format!("@{}@\n", ".".repeat(38)));
        }
        text.push_str(&"@".repeat(40));
        text.push_str("\ncell 25\nteam red base 2 2 flag 2 3 spawn 3 3\nteam blue base 37 17 flag 37 16 spawn 36 16\n");
        Nav::new(Arc::new(Battlefield::parse(&text).unwrap()))
    }

    fn robot(id: u32, team: &str, kind: RobotKind, x: f64, y: f64) -> SeenRobot {
        SeenRobot {
            id,
            team: team.into(),
            kind,
            at: Vec2::new(x, y),
            alive: true,
        }
    }

    fn last_goto(cmds: &[Command]) -> Option<Vec2> {
        cmds.iter().rev().find_map(|c| match c {
            Command::GoTo { to, .. } => Some(*to),
            _ => None,
        })
    }

    #[test]
    fn a_goto_sends_every_member_a_sequence_ending_in_formation_at_the_goal() {
        let mut squad = Squad::new("red", "a", vec![0, 1, 2], 22.0, nav());
        let view = View {
            robots: vec![
                robot(0, "red", RobotKind::Tank, 100.0, 100.0),
                robot(1, "red", RobotKind::Infantry, 130.0, 100.0),
                robot(2, "red", RobotKind::Infantry, 100.0, 130.0),
            ],
            ..View::default()
        };
        // A cell's centre: plans end on cell centres.
        let goal = Vec2::new(812.5, 362.5);
        squad.command(Verb::GoTo(goal), Some(Formation::Line));
        let orders = squad.tick(Arc::new(view));
        assert_eq!(squad.active(), Some("order"));
        assert_eq!(orders.len(), 3);
        let ends: Vec<Vec2> = orders.iter().map(|(_, c)| last_goto(c).unwrap()).collect();
        for e in &ends {
            assert!(
                e.distance(goal) <= 23.0,
                "{e:?} is off the line through {goal:?}"
            );
        }
        // A line of three, d apart: the ends are 22 and 44 cm from each other.
        let mut gaps: Vec<f64> = vec![
            ends[0].distance(ends[1]),
            ends[1].distance(ends[2]),
            ends[0].distance(ends[2]),
        ];
        gaps.sort_by(f64::total_cmp);
        assert!(
            (gaps[0] - 22.0).abs() < 0.5 && (gaps[2] - 44.0).abs() < 0.5,
            "{gaps:?}"
        );
        assert!(!squad.state().path.is_empty());
    }

    #[test]
    fn members_with_an_enemy_in_range_shoot_and_the_rest_hold() {
        let mut squad = Squad::new("red", "a", vec![0, 1], 22.0, nav());
        let view = View {
            robots: vec![
                robot(0, "red", RobotKind::Tank, 100.0, 100.0),
                robot(1, "red", RobotKind::Scout, 400.0, 100.0),
                robot(2, "blue", RobotKind::Scout, 180.0, 100.0),
            ],
            ..View::default()
        };
        squad.command(Verb::GoTo(Vec2::new(800.0, 300.0)), None);
        let orders = squad.tick(Arc::new(view.clone()));
        assert_eq!(squad.active(), Some("shoot"));
        assert!(squad
            .state()
            .behaviour
            .contains("enemy robot 2 in range of robot 0"));
        assert!(orders.contains(&(
            0,
            vec![Command::Shoot {
                target: 2,
                at: Vec2::new(180.0, 100.0)
            }]
        )));
        assert!(orders.contains(&(1, vec![Command::Stop])));
        // Nothing changed: nothing is sent again.
        assert!(squad.tick(Arc::new(view.clone())).is_empty());
        // The enemy is destroyed: the order takes over and replans.
        let mut calm = view;
        calm.robots[2].alive = false;
        let orders = squad.tick(Arc::new(calm));
        assert_eq!(squad.active(), Some("order"));
        assert_eq!(orders.len(), 2, "both robots get the path again");
    }

    fn motion(name: &str, c: Vec2, v: Vec2) -> SquadMotion {
        SquadMotion {
            team: "red".into(),
            name: name.into(),
            centroid: c,
            velocity: v,
            radius: 30.0,
        }
    }

    #[test]
    fn of_two_squads_on_a_collision_course_the_later_named_sidesteps() {
        let robots = vec![
            robot(0, "red", RobotKind::Infantry, 300.0, 250.0),
            robot(1, "red", RobotKind::Infantry, 450.0, 250.0),
        ];
        let head_on = vec![
            motion("a", Vec2::new(450.0, 250.0), Vec2::new(-20.0, 0.0)),
            motion("b", Vec2::new(300.0, 250.0), Vec2::new(20.0, 0.0)),
        ];
        let view = |squads| {
            Arc::new(View {
                time: 10.0,
                robots: robots.clone(),
                squads,
                ..View::default()
            })
        };
        let mut b = Squad::new("red", "b", vec![0], 22.0, nav());
        let orders = b.tick(view(head_on.clone()));
        assert_eq!(b.active(), Some("avoid-squads"));
        let to = last_goto(&orders[0].1).unwrap();
        assert!(
            (to.x - 300.0).abs() < 1e-9 && (to.y - 250.0).abs() > 30.0,
            "sidestep sideways: {to:?}"
        );
        let mut a = Squad::new("red", "a", vec![1], 22.0, nav());
        a.tick(view(head_on));
        assert_ne!(
            a.active(),
            Some("avoid-squads"),
            "the earlier-named squad keeps going"
        );
        // A parked squad ahead is an obstacle for the path, not an inbound collision.
        let parked = vec![
            motion("a", Vec2::new(450.0, 250.0), Vec2::ZERO),
            motion("b", Vec2::new(300.0, 250.0), Vec2::new(20.0, 0.0)),
        ];
        let mut b = Squad::new("red", "b", vec![0], 22.0, nav());
        b.tick(view(parked));
        assert_ne!(b.active(), Some("avoid-squads"));
    }
}
