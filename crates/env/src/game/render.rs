//! A picture of the battlefield for `render_mode="rgb_array"`, drawn on colony-sim's
//! [`Canvas`]: terrain by cell, each team's base as a pale disc of the capture radius, flags
//! as team-coloured squares with a dark rim (a carried flag rides on its carrier), robots as
//! discs of their body's size in their team's colour with a line for the heading, destroyed
//! ones grey. The picture is a pure function of the state, so equal states give equal bytes.

use colony_game::logic::BASE_RADIUS;
use colony_game::rules::KindRules;
use colony_sim::canvas::{Canvas, View};
use colony_sim::Vec2;

use super::observation::{WALL, WATER};
use super::GameEnv;

const GROUND: [u8; 3] = [214, 204, 170];
const SWAMP: [u8; 3] = [176, 182, 140];
const TREE: [u8; 3] = [46, 92, 52];
const OUTSIDE: [u8; 3] = [40, 40, 40];
const WATER_RGB: [u8; 3] = [80, 140, 210];
const DESTROYED: [u8; 3] = [120, 120, 120];
const RIM: [u8; 3] = [20, 20, 20];

/// A team's colour: red and blue by name, the others from a short list.
fn team_colour(name: &str, index: usize) -> [u8; 3] {
    match name {
        "red" => [210, 45, 45],
        "blue" => [40, 80, 210],
        _ => [[200, 140, 20], [130, 60, 170]][index % 2],
    }
}

/// The colour half-way to white.
fn pale(c: [u8; 3]) -> [u8; 3] {
    c.map(|v| v / 2 + 128)
}

impl GameEnv {
    /// The battlefield now, `width` × `height` RGB8 pixels, row-major from the top row.
    pub fn render_rgb(&self, width: usize, height: usize) -> Vec<u8> {
        let (w, h) = self.field.size_cm();
        let view = View::fit(Vec2::ZERO, Vec2::new(w, h), width, height);
        let mut c = Canvas::new(width, height, OUTSIDE);
        let cell = self.field.cell_cm;
        let gw = self.field.grid.width() as usize;
        for (i, code) in self.cells.iter().enumerate() {
            let (x, y) = (i % gw, i / gw);
            let colour = match *code {
                WATER => WATER_RGB,
                WALL => match self.field.grid.get(x as u32, y as u32) {
                    Some(colony_game::map::Terrain::Tree) => TREE,
                    _ => OUTSIDE,
                },
                _ => match self.field.grid.get(x as u32, y as u32) {
                    Some(colony_game::map::Terrain::Swamp) => SWAMP,
                    _ => GROUND,
                },
            };
            // Row 0 of the grid is the top (north) of the world.
            let (x0, y0) = self.field.point_to_world((x as f64, y as f64));
            let (px0, py0) = view.to_pixel(Vec2::new(x0, y0));
            let (px1, py1) = view.to_pixel(Vec2::new(x0 + cell, y0 - cell));
            c.fill_rect(px0, py0, px1, py1, colour);
        }
        for (t, team) in self.teams.iter().enumerate() {
            if let Some(b) = self.bases[t] {
                let (x, y) = view.to_pixel(b);
                c.fill_disc(x, y, view.length(BASE_RADIUS), pale(team_colour(team, t)));
            }
        }
        for (t, team) in self.teams.iter().enumerate() {
            let Some(f) = &self.flags[t] else { continue };
            let (x, y) = view.to_pixel(f.at);
            let r = view.length(cell * 0.35).max(2.0);
            c.fill_rect(x - r - 1.0, y - r - 1.0, x + r + 1.0, y + r + 1.0, RIM);
            c.fill_rect(x - r, y - r, x + r, y + r, team_colour(team, t));
        }
        // The destroyed first, so the living are drawn over them.
        for pass in [false, true] {
            for s in self.seen.iter().filter(|s| s.alive == pass) {
                let team = &self.teams[s.team as usize];
                let colour = if s.alive {
                    team_colour(team, s.team as usize)
                } else {
                    DESTROYED
                };
                let (x, y) = view.to_pixel(s.pose.position());
                // Never smaller than a few pixels, so a small picture still shows every robot.
                let r = view.length(s.kind.stats().radius_cm).max(3.0);
                c.fill_disc(x, y, r + 1.0, RIM);
                c.fill_disc(x, y, r, colour);
                if s.alive {
                    // Pixels run down the picture while the world's y runs up.
                    let (sin, cos) = s.pose.theta.sin_cos();
                    let tip = r * 1.8;
                    c.line(x, y, x + cos * tip, y - sin * tip, (r * 0.4).max(1.0), RIM);
                }
                if s.carrying {
                    let flag = self
                        .teams
                        .iter()
                        .enumerate()
                        .find(|(t, _)| *t != s.team as usize);
                    if let Some((t, name)) = flag {
                        c.fill_disc(x, y, r * 0.5, team_colour(name, t));
                    }
                }
            }
        }
        c.into_rgb()
    }
}
