//! `avoid-squads` (priority 20): sidestep another squad's predicted path (Fig. 5), then resume.

use colony_behave::{Behaviour, Reason};
use colony_sim::Vec2;

use super::{SquadCtx, SquadMotion};
use crate::protocol::Command;

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
pub(super) struct AvoidSquads {
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
