//! What each agent sees: four float32 arrays, agent-major, written in place into buffers the
//! caller owns (NumPy arrays handed in from Python), so a step allocates nothing for them.
//!
//! The layout, field by field, is on [`GameEnv::observe`].

use colony_game::logic::BASE_RADIUS;
use colony_game::rules::{KindRules, RobotKind, MAX_UPGRADE, UPGRADE_STEP};
use colony_sim::{Pose, Vec2};

use super::{EnvError, GameEnv, Seen, NO_ROBOT};

/// Numbers per agent in `own`.
pub const OWN_FEATURES: usize = 18;
/// Numbers per robot slot in `nearby`.
pub const NEARBY_FEATURES: usize = 10;
/// Numbers per team in `flags`.
pub const FLAG_FEATURES: usize = 9;
/// Channels per cell in `patch`.
pub const PATCH_CHANNELS: usize = 4;
/// Teams in `flags`: the learner's, then the opponent's.
pub const FLAG_TEAMS: usize = 2;
/// The most damage one shot can do under the rules: damage per shot is divided by it.
pub const MAX_DAMAGE: f64 = 15.0 * (1.0 + UPGRADE_STEP * MAX_UPGRADE as f64);

/// Terrain codes of the environment's cell table.
pub(super) const OPEN: u8 = 0;
pub(super) const WALL: u8 = 1;
pub(super) const WATER: u8 = 2;

/// The sizes of the observation's parts, per agent; each buffer holds `agents` of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObsLayout {
    /// Agents (the learner's robots).
    pub agents: usize,
    /// Numbers in `own`.
    pub own: usize,
    /// Robot slots in `nearby` (K).
    pub nearby: usize,
    /// Numbers per slot.
    pub nearby_features: usize,
    /// Teams in `flags`.
    pub flag_teams: usize,
    /// Numbers per team.
    pub flag_features: usize,
    /// Cells per side of `patch` (P).
    pub patch: usize,
    /// Channels per cell.
    pub patch_channels: usize,
}

impl ObsLayout {
    /// Numbers of `own` per agent.
    pub fn own_len(&self) -> usize {
        self.own
    }
    /// Numbers of `nearby` per agent.
    pub fn nearby_len(&self) -> usize {
        self.nearby * self.nearby_features
    }
    /// Numbers of `flags` per agent.
    pub fn flags_len(&self) -> usize {
        self.flag_teams * self.flag_features
    }
    /// Numbers of `patch` per agent.
    pub fn patch_len(&self) -> usize {
        self.patch * self.patch * self.patch_channels
    }
}

fn check(part: &'static str, buf: &[f32], want: usize) -> Result<(), EnvError> {
    if buf.len() == want {
        Ok(())
    } else {
        Err(EnvError::BufferLength {
            part,
            expected: want,
            got: buf.len(),
        })
    }
}

/// `p` relative to `pose`, in its frame, in units of `scale`.
fn local(pose: &Pose, p: Vec2, scale: f64) -> (f32, f32, f32) {
    let l = pose.to_local(p);
    (
        (l.x / scale) as f32,
        (l.y / scale) as f32,
        (l.length() / scale) as f32,
    )
}

fn bit(b: bool) -> f32 {
    if b {
        1.0
    } else {
        0.0
    }
}

impl GameEnv {
    /// The sizes of each observation part.
    pub fn layout(&self) -> ObsLayout {
        ObsLayout {
            agents: self.agents.len(),
            own: OWN_FEATURES,
            nearby: self.config.nearby,
            nearby_features: NEARBY_FEATURES,
            flag_teams: FLAG_TEAMS,
            flag_features: FLAG_FEATURES,
            patch: self.config.patch,
            patch_channels: PATCH_CHANNELS,
        }
    }

    /// Writes every agent's observation, agent-major, into the four buffers (each
    /// `agents × its part's length`, see [`GameEnv::layout`]); a buffer of another length is
    /// an error and nothing is written. It reads what the last step (or reset) saw, so it can
    /// be called any number of times between steps.
    ///
    /// Lengths are in units of `L`, the map's longer side in centimetres (so every relative
    /// position lies in [-1, 1]); relative positions are in the agent's own frame (x ahead, y to
    /// its left), so a policy need not learn rotations. A destroyed agent sees all zeros (its
    /// `alive` is 0) and keeps its place until the episode ends.
    ///
    /// - `own` ([`OWN_FEATURES`]): x / map width and y / map height (world frame, 0 to 1);
    ///   cos and sin of the heading (world frame); velocity ahead and to the left, and turn rate,
    ///   as fractions of the type's top speed and turn rate (from the last step's motion);
    ///   health / max health; damage per shot / [`MAX_DAMAGE`]; alive; carrying a flag;
    ///   reload left / the type's reload time (0: may fire); inside its own base's radius;
    ///   steps taken / max steps; the type, one-hot (scout, tank, infantry, amphibian).
    /// - `nearby` ([`NEARBY_FEATURES`] for each of the K nearest living robots, nearest first,
    ///   ties by id; empty slots all zero): valid (1); dx, dy / L; distance / L; enemy (1) or ally
    ///   (0); health / max health; cos and sin of its heading relative to the agent's; carrying a
    ///   flag; within the agent's range (a shot at it would not be refused for range). Destroyed
    ///   robots are left out, so a slot never holds one. The slot numbers are the ones
    ///   [`super::Fire::Slot`] names.
    /// - `flags` ([`FLAG_FEATURES`] for each team, the learner's first, then the opponent's): the
    ///   flag is in play (0 in Death Match, where the rest of its flag part is 0 too); the flag's
    ///   dx, dy / L and distance / L; it stands at home; it is carried; the team's base dx, dy / L
    ///   and distance / L.
    /// - `patch` (P x P x [`PATCH_CHANNELS`]): the cells around the agent's cell, world-aligned
    ///   with north up (row 0 is the northmost row, column 0 the westmost), channels: wall (trees,
    ///   out of bounds and off the map), water, an ally's centre, an enemy's centre.
    pub fn observe(
        &self,
        own: &mut [f32],
        nearby: &mut [f32],
        flags: &mut [f32],
        patch: &mut [f32],
    ) -> Result<(), EnvError> {
        let l = self.layout();
        let n = l.agents;
        check("own", own, n * l.own_len())?;
        check("nearby", nearby, n * l.nearby_len())?;
        check("flags", flags, n * l.flags_len())?;
        check("patch", patch, n * l.patch_len())?;
        own.fill(0.0);
        nearby.fill(0.0);
        flags.fill(0.0);
        patch.fill(0.0);
        for (i, agent) in self.agents.iter().enumerate() {
            let me = &self.seen[agent.robot as usize];
            if !me.alive {
                continue;
            }
            self.own(me, &mut own[i * l.own_len()..(i + 1) * l.own_len()]);
            self.nearby(
                i,
                me,
                &mut nearby[i * l.nearby_len()..(i + 1) * l.nearby_len()],
            );
            self.flags(me, &mut flags[i * l.flags_len()..(i + 1) * l.flags_len()]);
            self.patch(
                agent.robot,
                me,
                &mut patch[i * l.patch_len()..(i + 1) * l.patch_len()],
            );
        }
        Ok(())
    }

    fn own(&self, me: &Seen, out: &mut [f32]) {
        let s = me.kind.stats();
        let (w, h) = self.field.size_cm();
        let (sin, cos) = me.pose.theta.sin_cos();
        // The world velocity turned into the robot's frame: ahead and to the left.
        let v_ahead = me.vel.x * cos + me.vel.y * sin;
        let v_left = -me.vel.x * sin + me.vel.y * cos;
        let own_base = self.bases[0];
        let kind = RobotKind::ALL.iter().position(|k| *k == me.kind);
        let values = [
            (me.pose.x / w) as f32,
            (me.pose.y / h) as f32,
            cos as f32,
            sin as f32,
            (v_ahead / s.speed_cm_s) as f32,
            (v_left / s.speed_cm_s) as f32,
            (me.omega / s.turn_rad_s) as f32,
            (me.health / me.max_health) as f32,
            (me.damage / MAX_DAMAGE) as f32,
            1.0,
            bit(me.carrying),
            (me.reload_left / s.reload_s) as f32,
            bit(own_base.is_some_and(|b| b.distance(me.pose.position()) <= BASE_RADIUS)),
            (self.steps as f64 / self.config.max_steps.max(1) as f64) as f32,
        ];
        out[..values.len()].copy_from_slice(&values);
        if let Some(k) = kind {
            out[values.len() + k] = 1.0;
        }
    }

    fn nearby(&self, agent: usize, me: &Seen, out: &mut [f32]) {
        let k = self.config.nearby;
        let range = me.kind.stats().range_cm;
        for (slot, &id) in self.neighbours[agent * k..(agent + 1) * k]
            .iter()
            .enumerate()
        {
            if id == NO_ROBOT {
                break;
            }
            let o = &self.seen[id as usize];
            let (dx, dy, d) = local(&me.pose, o.pose.position(), self.scale);
            let (sin, cos) = (o.pose.theta - me.pose.theta).sin_cos();
            let values = [
                1.0,
                dx,
                dy,
                d,
                bit(o.team != me.team),
                (o.health / o.max_health) as f32,
                cos as f32,
                sin as f32,
                bit(o.carrying),
                bit(me.pose.position().distance(o.pose.position()) <= range),
            ];
            out[slot * NEARBY_FEATURES..(slot + 1) * NEARBY_FEATURES].copy_from_slice(&values);
        }
    }

    fn flags(&self, me: &Seen, out: &mut [f32]) {
        for t in 0..FLAG_TEAMS {
            let part = &mut out[t * FLAG_FEATURES..(t + 1) * FLAG_FEATURES];
            if let Some(f) = &self.flags[t] {
                let (dx, dy, d) = local(&me.pose, f.at, self.scale);
                part[..6].copy_from_slice(&[
                    1.0,
                    dx,
                    dy,
                    d,
                    bit(f.carrier.is_none() && f.at == f.home),
                    bit(f.carrier.is_some()),
                ]);
            }
            if let Some(b) = self.bases[t] {
                let (dx, dy, d) = local(&me.pose, b, self.scale);
                part[6..].copy_from_slice(&[dx, dy, d]);
            }
        }
    }

    fn patch(&self, robot: u32, me: &Seen, out: &mut [f32]) {
        let p = self.config.patch;
        let half = (p / 2) as i64;
        let (w, h) = (
            i64::from(self.field.grid.width()),
            i64::from(self.field.grid.height()),
        );
        let Some(centre) = self.field.cell_at(me.pose.x, me.pose.y) else {
            return;
        };
        let (x0, y0) = (i64::from(centre.x) - half, i64::from(centre.y) - half);
        for row in 0..p {
            let y = y0 + row as i64;
            for col in 0..p {
                let x = x0 + col as i64;
                let terrain = if x < 0 || y < 0 || x >= w || y >= h {
                    WALL
                } else {
                    self.cells[(y * w + x) as usize]
                };
                let at = (row * p + col) * PATCH_CHANNELS;
                match terrain {
                    WALL => out[at] = 1.0,
                    WATER => out[at + 1] = 1.0,
                    _ => {}
                }
            }
        }
        for (id, o) in self.seen.iter().enumerate() {
            if id as u32 == robot || !o.alive {
                continue;
            }
            let Some(c) = self.field.cell_at(o.pose.x, o.pose.y) else {
                continue;
            };
            let (col, row) = (i64::from(c.x) - x0, i64::from(c.y) - y0);
            if (0..p as i64).contains(&col) && (0..p as i64).contains(&row) {
                let channel = if o.team == me.team { 2 } else { 3 };
                out[(row as usize * p + col as usize) * PATCH_CHANNELS + channel] = 1.0;
            }
        }
    }
}
