//! `order` (priority 10): the player's command (gather, goto, defend, attack, capture) carried
//! out, replanned from where the robots are whenever a higher behaviour had control.

use colony_behave::{Behaviour, Reason};
use colony_sim::Vec2;

use super::SquadCtx;
use crate::formation::Formation;
use crate::path::Replanner;
use crate::protocol::{Command, Target, Verb};

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
pub(super) struct OrderBehaviour {
    phase: Phase,
    /// Where the last plan was made to.
    goal: Option<Vec2>,
    replanner: Option<Replanner>,
    /// A drawn path: the first of its points still ahead (the squad never goes back along it).
    reached: usize,
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
    /// With nothing to carry out yet.
    pub(super) fn idle() -> OrderBehaviour {
        OrderBehaviour {
            phase: Phase::Done,
            goal: None,
            replanner: None,
            reached: 0,
        }
    }
    fn start(&mut self, ctx: &mut SquadCtx, gather: bool, anew: bool) {
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
            Verb::Path(ref points) => {
                // A new drawing starts at its start; one resumed (after a fight, a sidestep, a
                // split or a merge) goes on from the point ahead nearest the squad, never back.
                if anew {
                    self.reached = 0;
                }
                let ahead = self.reached.min(points.len().saturating_sub(1));
                let resume = (ahead..points.len())
                    .min_by(|&a, &b| {
                        points[a]
                            .distance(centroid)
                            .total_cmp(&points[b].distance(centroid))
                    })
                    .filter(|_| !anew)
                    .unwrap_or(ahead);
                self.reached = resume;
                match ctx.nav.route(centroid, &points[resume..], mover) {
                    Some(route) => {
                        self.goal = route.last().copied();
                        ctx.dispatch(route, ctx.formation, gather, None);
                        self.phase = Phase::Going;
                    }
                    None => {
                        // No way there at all: nothing to carry out.
                        ctx.path.clear();
                        self.goal = None;
                        self.phase = Phase::Done;
                    }
                }
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
            return self.start(ctx, false, false);
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
            let anew = ctx.fresh && !ctx.refreshed;
            ctx.fresh = false;
            ctx.replan = false;
            ctx.refreshed = false;
            self.phase = Phase::Done;
            return self.start(ctx, gather, anew);
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
                    self.start(ctx, false, false);
                }
            }
            Some(Verb::GoTo(_) | Verb::Gather(_) | Verb::Path(_)) => {
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
