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
//!
//! This module holds what the behaviours share (the [`View`] of the world, the [`SquadCtx`]) and
//! the [`Squad`] that arbitrates them; each behaviour but `hold` has its own file.

use std::sync::Arc;

use colony_behave::{Arbitrator, Behaviour, Reason};
use colony_sim::Vec2;

use self::avoid::AvoidSquads;
use self::order::OrderBehaviour;
use self::shoot::Shoot;
use crate::formation::{along_path, assign, Formation};
use crate::nav::Nav;
use crate::path::Mover;
use crate::protocol::{Command, SquadState, Target, Verb};
use crate::rules::{KindRules, RobotKind};

mod avoid;
mod order;
mod shoot;

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
    /// Driven by its player directly: no squad gives it orders.
    pub driven: bool,
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
    /// The squad's members changed (or one came back from its player): the command goes on
    /// from where it stands, not from its start.
    pub(super) refreshed: bool,
    /// A higher behaviour had control: the order must be replanned from here.
    replan: bool,
    /// Path finding.
    pub nav: Nav,
    /// Orders to send: robot, commands.
    pub out: Vec<(u32, Vec<Command>)>,
    /// The squad's planned path, cm.
    pub path: Vec<Vec2>,
}

/// Clearance kept around a formation slot beyond the robot's radius, cm.
const ROOM_MARGIN_CM: f64 = 4.0;

impl SquadCtx {
    /// The members the squad commands: alive and not driven by the player.
    fn alive(&self) -> Vec<&SeenRobot> {
        self.members
            .iter()
            .filter_map(|&id| self.view.robot(id))
            .filter(|r| r.alive && !r.driven)
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
                        // Its turn points between the two ends; none when both ends snap to
                        // one cell (a plan of a single point).
                        let inner = way.get(1..way.len().saturating_sub(1)).unwrap_or_default();
                        cmds.extend(inner.iter().map(|&to| Command::GoTo {
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
        arbitrator.add(10, OrderBehaviour::idle());
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
                refreshed: false,
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

    /// Its formation.
    pub fn formation(&self) -> Formation {
        self.ctx.formation
    }

    /// Takes a formation for its next command.
    pub fn set_formation(&mut self, formation: Formation) {
        self.ctx.formation = formation;
    }

    /// The player's command it carries out.
    pub fn verb(&self) -> Option<&Verb> {
        self.ctx.verb.as_ref()
    }

    /// Robots join the squad.
    pub fn add_members(&mut self, ids: &[u32]) {
        for &id in ids {
            if !self.ctx.members.contains(&id) {
                self.ctx.members.push(id);
            }
        }
    }

    /// Robots leave the squad.
    pub fn remove_members(&mut self, ids: &[u32]) {
        self.ctx.members.retain(|m| !ids.contains(m));
    }

    /// Carries out its command anew from where the robots are, slots and all: its members
    /// changed, or one came back from the player's hands.
    pub fn refresh(&mut self) {
        if self.ctx.verb.is_some() {
            self.ctx.fresh = true;
            self.ctx.refreshed = true;
        }
    }

    /// Takes a player's command (already checked by the caller).
    pub fn command(&mut self, verb: Verb, formation: Option<Formation>) {
        if let Some(f) = formation {
            self.ctx.formation = f;
        }
        self.order_text = verb.to_string();
        self.ctx.verb = Some(verb);
        self.ctx.fresh = true;
        self.ctx.refreshed = false;
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
mod tests;
