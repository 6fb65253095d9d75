//! The paper's measurement (Table 3): how long the swarm intelligence takes
//! to split one squad command into robot sequence commands, as p50 and p99
//! over many runs, for the paper's case (a 3-robot squad capturing the enemy
//! flag on the Capture the Flag map) and a large one (a 100-robot squad
//! crossing a 1024 x 1024 map). Also: following a moving target by partial
//! replanning (the path-level comparison with planning from scratch is in
//! the `path` bench).
//!
//! `cargo bench -p colony-game --bench squad_command`

use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_game::logic::roster;
use colony_game::map::{Battlefield, Cell, GridMap, TeamSite, Terrain};
use colony_game::nav::Nav;
use colony_game::protocol::{Target, Verb};
use colony_game::rules::{Mode, RobotKind, Rules, SquadSetup, TeamSetup};
use colony_game::server::SPACING_CM;
use colony_game::squad::{SeenRobot, Squad, View};
use colony_sim::Vec2;
use rand::{Rng, SeedableRng};

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i]
}

fn report(name: &str, mut times: Vec<Duration>) {
    times.sort();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "{name}: n {} p50 {:.3} ms p99 {:.3} ms max {:.3} ms",
        times.len(),
        ms(percentile(&times, 0.5)),
        ms(percentile(&times, 0.99)),
        ms(*times.last().unwrap())
    );
}

fn view(field: &Battlefield, teams: &[TeamSetup]) -> (View, Vec<colony_game::logic::RobotEntry>) {
    let mut rules = Rules::new(Mode::CaptureTheFlag);
    rules.budget = u32::MAX;
    rules.max_squads = 100;
    let entries = roster(field, &rules, teams).unwrap();
    let at = |c: Cell| {
        let (x, y) = field.cell_center(c);
        Vec2::new(x, y)
    };
    let view = View {
        time: 0.0,
        robots: entries
            .iter()
            .map(|e| SeenRobot {
                id: e.id,
                team: e.team.clone(),
                kind: e.build.kind,
                at: e.spawn.position(),
                alive: true,
                driven: false,
            })
            .collect(),
        flags: field
            .teams
            .iter()
            .map(|t| (t.name.clone(), at(t.flag), None))
            .collect(),
        bases: field
            .teams
            .iter()
            .map(|t| (t.name.clone(), at(t.base)))
            .collect(),
        squads: Vec::new(),
    };
    (view, entries)
}

/// Times `runs` squad commands from scratch: a new squad each time, so no
/// search work carries over.
fn time_command(
    field: &Arc<Battlefield>,
    teams: &[TeamSetup],
    verb: Verb,
    runs: usize,
) -> Vec<Duration> {
    let (view, entries) = view(field, teams);
    let view = Arc::new(view);
    let members: Vec<u32> = entries
        .iter()
        .filter(|e| e.team == teams[0].name && e.squad == teams[0].squads[0].name)
        .map(|e| e.id)
        .collect();
    let mut nav = Some(Nav::new(field.clone()));
    (0..runs)
        .map(|_| {
            let mut squad = Squad::new(
                &teams[0].name,
                "alpha",
                members.clone(),
                SPACING_CM,
                nav.take().unwrap_or_else(|| Nav::new(field.clone())),
            );
            squad.command(verb.clone(), None);
            let t0 = Instant::now();
            let orders = squad.tick(view.clone());
            let t = t0.elapsed();
            assert_eq!(orders.len(), members.len(), "every robot got its sequence");
            t
        })
        .collect()
}

fn big_map(side: u32, seed: u64) -> Battlefield {
    // Open ground with 8 % of the cells in random 1-4 cell tree clumps and a
    // river across the middle with a few fords: large, and not a maze.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut g = GridMap::new(side, side, Terrain::Open);
    for _ in 0..(side as usize * side as usize / 100) {
        let (x, y) = (rng.random_range(0..side), rng.random_range(0..side));
        let s = rng.random_range(1..=4);
        for dy in 0..s {
            for dx in 0..s {
                g.set(
                    Cell::new((x + dx).min(side - 1), (y + dy).min(side - 1)),
                    Terrain::Tree,
                );
            }
        }
    }
    for x in 0..side {
        for y in side / 2 - 3..side / 2 + 3 {
            let ford = x % 128 < 6;
            g.set(
                Cell::new(x, y),
                if ford { Terrain::Open } else { Terrain::Water },
            );
        }
    }
    let clear = |g: &mut GridMap, c: Cell| {
        for y in c.y.saturating_sub(12)..(c.y + 12).min(side) {
            for x in c.x.saturating_sub(12)..(c.x + 12).min(side) {
                g.set(Cell::new(x, y), Terrain::Open);
            }
        }
    };
    let south = Cell::new(side / 8, side - side / 8);
    let north = Cell::new(side - side / 8, side / 8);
    clear(&mut g, south);
    clear(&mut g, north);
    Battlefield {
        grid: g,
        cell_cm: 20.0,
        teams: vec![
            TeamSite {
                name: "red".into(),
                base: south,
                flag: south,
                spawn: south,
            },
            TeamSite {
                name: "blue".into(),
                base: north,
                flag: north,
                spawn: north,
            },
        ],
    }
}

fn main() {
    let ctf = Arc::new(
        Battlefield::from_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../maps/ctf.map")).unwrap(),
    );
    let teams = [
        TeamSetup::parse("red", "alpha:tank,infantry,infantry").unwrap(),
        TeamSetup::parse("blue", "alpha:tank").unwrap(),
    ];
    report(
        "3-robot squad, capture flag, ctf.map 64x48",
        time_command(&ctf, &teams, Verb::Capture("blue".into()), 200),
    );
    report(
        "3-robot squad, goto across the river, ctf.map 64x48",
        time_command(&ctf, &teams, Verb::GoTo(Vec2::new(1100.0, 850.0)), 200),
    );

    let big = Arc::new(big_map(1024, 7));
    let hundred = TeamSetup {
        name: "red".into(),
        squads: vec![SquadSetup {
            name: "alpha".into(),
            robots: vec![colony_game::rules::RobotBuild::plain(RobotKind::Infantry); 100],
        }],
    };
    let teams = [hundred, TeamSetup::parse("blue", "alpha:tank").unwrap()];
    let (x, y) = big.cell_center(Cell::new(900, 140));
    report(
        "100-robot squad, goto across 1024x1024",
        time_command(&big, &teams, Verb::GoTo(Vec2::new(x, y)), 20),
    );

    // A target that keeps moving: follow it with the replanner, or plan anew.
    let (view, entries) = view(
        &ctf,
        &[
            TeamSetup::parse("red", "alpha:tank,infantry,infantry").unwrap(),
            TeamSetup::parse("blue", "alpha:scout").unwrap(),
        ],
    );
    let target = entries.iter().find(|e| e.team == "blue").unwrap().id;
    let members: Vec<u32> = entries
        .iter()
        .filter(|e| e.team == "red")
        .map(|e| e.id)
        .collect();
    let mut squad = Squad::new("red", "alpha", members, SPACING_CM, Nav::new(ctf.clone()));
    squad.command(Verb::Attack(Target::Robot(target)), None);
    let mut view = view;
    squad.tick(Arc::new(view.clone()));
    let mut follow = Vec::new();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let nav = Nav::new(ctf.clone());
    for _ in 0..3000 {
        // The target wanders, up to 2-3 cells a step.
        let step = Vec2::new(rng.random_range(-60.0..60.0), rng.random_range(-60.0..60.0));
        let to = view.robots[target as usize].at + step;
        if !nav.is_free(to, colony_game::path::Mover::Land) {
            continue;
        }
        view.robots[target as usize].at = to;
        let t0 = Instant::now();
        let orders = squad.tick(Arc::new(view.clone()));
        let t = t0.elapsed();
        // Moves under 1.5 cells, or a quarter of the squad's distance to
        // the target, don't call for a new plan; count only replans.
        if !orders.is_empty() {
            follow.push(t);
        }
    }
    report(
        "3-robot squad following a moving target (partial replan)",
        follow,
    );
}
