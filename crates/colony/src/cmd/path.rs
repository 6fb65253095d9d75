//! `colony path`: runs a Moving AI benchmark scenario through our planner and
//! checks every length against the published optimum.

use std::io::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use colony_game::map::GridMap;
use colony_game::path::{scen, Algorithm, Mover, Planner};

/// Lengths within this of the published ones count as optimal.
const TOLERANCE: f64 = 1e-4;

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
    if let Some(q) = queries
        .iter()
        .find(|q| (q.width, q.height) != (map.width(), map.height()))
    {
        anyhow::bail!(
            "{} line {} is for a {} x {} map, but {} is {} x {}",
            args.scen.display(),
            q.line,
            q.width,
            q.height,
            args.map.display(),
            map.width(),
            map.height()
        );
    }
    let algorithm = match args.algorithm {
        Some(AlgorithmArg::Astar) => Algorithm::AStar,
        Some(AlgorithmArg::Jps) => Algorithm::Jps,
        None => Algorithm::fastest(Mover::Benchmark),
    };

    let mut planner = Planner::new(&map, Mover::Benchmark);
    let mut times_us = Vec::with_capacity(queries.len());
    let mut mismatches = 0usize;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    for (n, q) in queries.iter().enumerate() {
        let t0 = Instant::now();
        let found = planner.find(algorithm, q.start, q.goal);
        times_us.push(t0.elapsed().as_secs_f64() * 1e6);
        let (found_text, ok) = match &found {
            Some(p) => (
                format!("{:.5}", p.length),
                (p.length - q.optimal).abs() <= TOLERANCE,
            ),
            None => ("unreachable".to_string(), false),
        };
        if !ok {
            mismatches += 1;
        }
        if !(args.quiet && ok) {
            writeln!(
                out,
                "query {n}: {}->{} found {found_text} expected {:.5} {}",
                q.start,
                q.goal,
                q.optimal,
                if ok { "ok" } else { "MISMATCH" }
            )?;
        }
    }
    let total = queries.len();
    let mean = if total == 0 {
        0.0
    } else {
        times_us.iter().sum::<f64>() / total as f64
    };
    writeln!(
        out,
        "{total} queries, {} optimal, {mismatches} mismatches; {:?}: mean {mean:.1} µs, p99 {:.1} µs per query",
        total - mismatches,
        algorithm,
        percentile(&mut times_us, 0.99)
    )?;
    out.flush()?;
    if mismatches > 0 {
        anyhow::bail!("{mismatches} of {total} queries did not find the expected length");
    }
    Ok(())
}

/// The `p` quantile (nearest rank) of `values`; 0 for none.
fn percentile(values: &mut [f64], p: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let rank = ((p * values.len() as f64).ceil() as usize).clamp(1, values.len());
    values[rank - 1]
}
