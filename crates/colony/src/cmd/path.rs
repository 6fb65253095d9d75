//! `colony path`: runs a Moving AI benchmark scenario through our planner and
//! checks every length against the published optimum.

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;
use colony_game::map::GridMap;
use colony_game::path::check::ScenarioCheck;
use colony_game::path::{scen, Algorithm, Mover};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The map, in the Moving AI `.map` format.
    pub map: PathBuf,
    /// The scenario, in the Moving AI `.scen` format.
    pub scen: PathBuf,
    /// Search algorithm (default: the fastest valid one, jump point search).
    #[arg(long, value_enum)]
    pub algorithm: Option<AlgorithmArg>,
    /// Print only mismatches and the summary.
    #[arg(long)]
    pub quiet: bool,
}

#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlgorithmArg {
    /// A* with the octile heuristic.
    Astar,
    /// Jump point search.
    Jps,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let map =
        GridMap::from_file(&args.map).with_context(|| format!("bad map {}", args.map.display()))?;
    let queries = scen::from_file(&args.scen)
        .with_context(|| format!("bad scenario {}", args.scen.display()))?;
    let algorithm = match args.algorithm {
        Some(AlgorithmArg::Astar) => Algorithm::AStar,
        Some(AlgorithmArg::Jps) => Algorithm::Jps,
        None => Algorithm::fastest(Mover::Benchmark),
    };
    let mut check = ScenarioCheck::new(&map, queries, algorithm).with_context(|| {
        format!(
            "{} does not fit {}",
            args.scen.display(),
            args.map.display()
        )
    })?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    for o in check.by_ref() {
        if !(args.quiet && o.ok) {
            let found = o
                .found
                .map_or_else(|| "unreachable".to_string(), |l| format!("{l:.5}"));
            writeln!(
                out,
                "query {}: {}->{} found {found} expected {:.5} {}",
                o.index,
                o.query.start,
                o.query.goal,
                o.query.optimal,
                if o.ok { "ok" } else { "MISMATCH" }
            )?;
        }
    }
    let summary = check.summary();
    writeln!(out, "{summary}")?;
    out.flush()?;
    if summary.mismatches > 0 {
        anyhow::bail!(
            "{} of {} queries did not find the expected length",
            summary.mismatches,
            summary.total
        );
    }
    Ok(())
}
