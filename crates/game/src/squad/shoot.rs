//! `shoot` (priority 30): members with an enemy in range shoot it; the rest hold.

use colony_behave::{Behaviour, Reason};
use colony_sim::Vec2;

use super::SquadCtx;
use crate::protocol::Command;
use crate::rules::KindRules;

/// Automatic shooting: every member with an enemy in range shoots the
/// nearest one; the others hold their ground.
#[derive(Default)]
pub(super) struct Shoot {
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
