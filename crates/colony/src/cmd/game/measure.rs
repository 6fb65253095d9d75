//! `colony game measure`: the paper's Tables 3 and 4 on a live match over a hub of its own, each
//! hop of a player's command measured apart, printed as the paper lays the tables out with its
//! figures beside ours.

use std::time::Duration;

use anyhow::Context as _;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_hub::{HubSite, HubSpec};
use colony_lab::game::live_match::MatchPlan;
use colony_lab::game::measure::{
    run_series, Series, SeriesSpec, Stats, OUR_THINK_EVERY, PAPER_THINK_EVERY,
};

/// The paper's Table 4 intervals, ms.
const PAPER_INTERVALS: &str = "100,250,500,750,1000,1500,2000,2500,5000";
/// The paper's Table 4 rows for those intervals, ms.
const PAPER_SI: [f64; 9] = [
    1059.0, 740.0, 362.0, 270.0, 375.0, 173.0, 182.0, 314.0, 190.0,
];
const PAPER_RI: [f64; 9] = [
    629.0, 696.0, 603.0, 657.0, 500.0, 627.0, 597.0, 587.0, 551.0,
];

#[derive(clap::Args, Debug)]
pub struct MeasureArgs {
    /// Which table: 3, 4, or both.
    #[arg(long, default_value = "both", value_parser = ["3", "4", "both"])]
    pub table: String,
    /// Table 3's commands (the paper's 20).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub commands: u32,
    /// Table 4's commands at each interval (the paper's 10).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub samples: u32,
    /// Table 4's intervals between commands, ms, comma-separated.
    #[arg(long, default_value = PAPER_INTERVALS)]
    pub intervals: String,
    /// Where the measurement's own hub listens.
    #[arg(long, default_value = "127.0.0.1:0")]
    pub hub_bind: String,
}

fn intervals(text: &str) -> anyhow::Result<Vec<u64>> {
    text.split(',')
        .map(|t| {
            let v: u64 = t
                .trim()
                .parse()
                .with_context(|| format!("--intervals: {t:?} is not a whole number of ms"))?;
            anyhow::ensure!(
                (10..=60_000).contains(&v),
                "--intervals: {v} ms is outside 10 to 60000"
            );
            Ok(v)
        })
        .collect()
}

fn plan(red: &str) -> anyhow::Result<MatchPlan> {
    let teams = [
        TeamSetup::parse("red", red)?,
        TeamSetup::parse("blue", "alpha:scout")?,
    ];
    Ok(MatchPlan::shipped(
        Rules::new(Mode::CaptureTheFlag),
        &teams,
    )?)
}

fn row(name: &str, s: &Stats, paper: [f64; 4]) -> String {
    format!(
        "| {name} | {:.1} | {:.1} | {:.1} | {:.1} | {} / {} / {} / {} |",
        s.mean, s.sd, s.min, s.max, paper[0], paper[1], paper[2], paper[3]
    )
}

pub fn run(args: MeasureArgs) -> anyhow::Result<()> {
    let gaps = intervals(&args.intervals)?;
    let stop = super::super::stop_flag()?;
    let hub = HubSite::here_or_elsewhere(None, &HubSpec::new(args.hub_bind.as_str()), &stop)
        .context("cannot start the measurement's hub")?;
    let addr = hub.addr();
    let result = (|| -> anyhow::Result<()> {
        if args.table != "4" {
            let plan = plan("alpha:tank,infantry,infantry")?;
            eprintln!(
                "Table 3: {} Capture the Flag commands to a squad of three, a second apart…",
                args.commands
            );
            let s = run_series(
                &plan,
                &addr,
                &SeriesSpec {
                    think_every: OUR_THINK_EVERY,
                    interval: Duration::from_secs(1),
                    commands: args.commands as usize,
                    capture: true,
                    spread: true,
                },
            )?;
            println!("\n### Table 3: a player's command to a squad (ms; ours, then the paper's x̄ / σ / min / max)\n");
            println!("| hop | x̄ | σ | min | max | paper |");
            println!("|---|---|---|---|---|---|");
            println!(
                "{}",
                row(
                    "player → SI",
                    &s.stats(|x| x.to_server),
                    [9.0, 3.0, 6.0, 15.0]
                )
            );
            println!(
                "{}",
                row(
                    "SI (wait and arbitration)",
                    &s.stats(|x| x.server),
                    [570.0, 109.0, 365.0, 756.0]
                )
            );
            println!(
                "{}",
                row(
                    "SI → robot squad",
                    &s.stats(|x| x.to_robots),
                    [7.0, 6.0, 2.0, 24.0]
                )
            );
            let e = s.stats(|x| x.end_to_end);
            let c = s.stats(|x| x.compute);
            println!(
                "| end to end | {:.1} | {:.1} | {:.1} | {:.1} | – |",
                e.mean, e.sd, e.min, e.max
            );
            println!(
                "| of which the squad's arbitration computed | {:.2} | {:.2} | {:.2} | {:.2} | – |",
                c.mean, c.sd, c.min, c.max
            );
            println!(
                "\n{} commands followed to every robot of {} sent ({} lost or superseded).",
                s.samples.len(),
                s.sent,
                s.lost()
            );
        }
        if args.table != "3" {
            let plan = plan("alpha:infantry,infantry,infantry")?;
            let mut tables: Vec<(u64, Vec<Series>)> = Vec::new();
            for think in [OUR_THINK_EVERY, PAPER_THINK_EVERY] {
                let mut rows = Vec::new();
                for &gap in &gaps {
                    eprintln!(
                        "Table 4: {} GoTo commands {gap} ms apart, the server waiting {} ms…",
                        args.samples,
                        think * 100
                    );
                    rows.push(run_series(
                        &plan,
                        &addr,
                        &SeriesSpec {
                            think_every: think,
                            interval: Duration::from_millis(gap),
                            commands: args.samples as usize,
                            capture: false,
                            spread: false,
                        },
                    )?);
                }
                tables.push((think, rows));
            }
            println!("\n### Table 4: a squad GoTo at intervals (mean ms; SI: swarm intelligence, RI: robot intelligence)\n");
            let head: Vec<String> = gaps.iter().map(u64::to_string).collect();
            println!("| interval (ms) | {} |", head.join(" | "));
            println!("|---|{}", "---|".repeat(gaps.len()));
            for (think, rows) in &tables {
                let si: Vec<String> = rows
                    .iter()
                    .map(|s| format!("{:.0}", s.stats(|x| x.server).mean))
                    .collect();
                let ri: Vec<String> = rows
                    .iter()
                    .map(|s| format!("{:.0}", s.stats(|x| x.robot).mean))
                    .collect();
                let lost: Vec<String> = rows.iter().map(|s| s.lost().to_string()).collect();
                println!("| SI, waiting {} ms | {} |", think * 100, si.join(" | "));
                println!("| RI, waiting {} ms | {} |", think * 100, ri.join(" | "));
                println!(
                    "| commands superseded or lost, of {} | {} |",
                    args.samples,
                    lost.join(" | ")
                );
            }
            if args.intervals == PAPER_INTERVALS {
                let f = |v: &[f64]| {
                    v.iter()
                        .map(|x| format!("{x:.0}"))
                        .collect::<Vec<_>>()
                        .join(" | ")
                };
                println!("| SI, the paper (300 ms) | {} |", f(&PAPER_SI));
                println!("| RI, the paper (NXT robots) | {} |", f(&PAPER_RI));
            }
        }
        Ok(())
    })();
    hub.stop().context("the measurement's hub failed")?;
    result
}
