//! The supplementary report: per experiment a section with the paper's finding, ours,
//! whether they agree, the table, the figures and the statistics behind the verdict.
//!
//! Each section is written to `sections/<experiment>.md` and `report.md` is put
//! together from every section present, so experiments can be run (and re-run) one
//! at a time into the same directory.

use std::fmt::Write as _;
use std::path::Path;

use crate::sort::experiment::{
    read_csv, write_csv, write_error, ExperimentError, Sample, TrialResult,
};
use crate::sort::plot::{self, Band};
use crate::sort::report::{band, fmt_p, label, plot_err, summary_cells, summary_header};
use crate::sort::stats;

use super::{disturbance_steps, Experiment, Plan, PlannedExperiment};

/// The significance level the verdicts use.
const ALPHA: f64 = 0.05;

/// Trials of one experiment: `[condition][method]`, in trial order.
type Grid<'a> = Vec<Vec<Vec<&'a TrialResult>>>;

/// Writes each planned experiment's CSV files, figures and section, then `report.md`
/// from every section in `out` (those of earlier runs included).
pub fn write(
    out: &Path,
    plan: &Plan,
    results: &[TrialResult],
    command: &str,
) -> Result<(), ExperimentError> {
    check_shape(plan, results)?;
    let sections = out.join("sections");
    std::fs::create_dir_all(&sections).map_err(write_error(&sections))?;
    for p in &plan.experiments {
        // An earlier run's files for conditions or trials this one lacks would be mistaken
        // for this run's.
        let csv = out.join("csv").join(p.experiment.name());
        match std::fs::remove_dir_all(&csv) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(write_error(&csv)(e));
            }
            _ => {}
        }
        let grid: Grid<'_> = p
            .trials
            .iter()
            .map(|by_method| {
                by_method
                    .iter()
                    .map(|ix| ix.iter().map(|&i| &results[i]).collect())
                    .collect()
            })
            .collect();
        for (c, by_method) in p.conditions.iter().zip(&grid) {
            let all: Vec<TrialResult> = by_method.iter().flatten().map(|r| (*r).clone()).collect();
            write_csv(
                &out.join("csv").join(p.experiment.name()).join(c.slug()),
                &all,
            )?;
        }
        let md = section(out, p, &grid, command)?;
        let path = sections.join(format!("{}.md", p.experiment.name()));
        std::fs::write(&path, md).map_err(write_error(&path))?;
    }
    assemble(out)
}

/// Refuses a plan not shaped as [`super::plan`] makes them (the sections read conditions
/// and methods by position) or results that do not match it.
fn check_shape(plan: &Plan, results: &[TrialResult]) -> Result<(), ExperimentError> {
    if results.len() != plan.specs.len() {
        return Err(ExperimentError::Invalid(format!(
            "{} results for a plan of {} trials",
            results.len(),
            plan.specs.len()
        )));
    }
    for p in &plan.experiments {
        let conditions = match p.experiment {
            Experiment::Shift | Experiment::Reinsert => 2,
            _ => 1,
        };
        let methods = p.experiment.methods().len();
        if p.conditions.len() < conditions
            || p.trials.len() != p.conditions.len()
            || p.trials.iter().any(|by| by.len() != methods)
            || p.trials
                .iter()
                .flatten()
                .flatten()
                .any(|&i| i >= results.len())
        {
            return Err(ExperimentError::Invalid(format!(
                "the plan of experiment {} is not one `plan` makes",
                p.experiment
            )));
        }
    }
    Ok(())
}

/// Reads the results of `plan` back from the CSV files an earlier run of it left in `out`,
/// to write its report again without running the trials.
pub fn read_results(out: &Path, plan: &Plan) -> Result<Vec<TrialResult>, ExperimentError> {
    let mut found: Vec<Option<TrialResult>> = vec![None; plan.specs.len()];
    for p in &plan.experiments {
        for (c, by_method) in p.conditions.iter().zip(&p.trials) {
            let dir = out.join("csv").join(p.experiment.name()).join(c.slug());
            let read = read_csv(&dir).map_err(|e| {
                let why = match &e {
                    ExperimentError::Read { source, .. } => format!("{e}: {source}"),
                    _ => e.to_string(),
                };
                ExperimentError::Invalid(format!(
                    "{why}; {} holds no results of a run with these settings: run the trials again",
                    out.display()
                ))
            })?;
            for &i in by_method.iter().flatten() {
                let spec = &plan.specs[i];
                if found[i].is_none() {
                    found[i] = read
                        .iter()
                        .find(|r| {
                            r.method == spec.method
                                && r.seed == spec.seed
                                && r.steps == spec.steps
                                && r.types == spec.scene.pucks.kinds
                        })
                        .cloned();
                }
            }
        }
    }
    found
        .into_iter()
        .zip(&plan.specs)
        .map(|(r, spec)| {
            r.ok_or_else(|| {
                ExperimentError::Invalid(format!(
                    "{} has no results for {} with seed {} over {} steps; run the trials again",
                    out.display(),
                    spec.method,
                    spec.seed,
                    spec.steps
                ))
            })
        })
        .collect()
}

/// Puts `report.md` together from the sections in `out/sections`.
pub fn assemble(out: &Path) -> Result<(), ExperimentError> {
    let mut md = String::from(
        "# Cache consensus: the supplementary experiments\n\n\
The paper's Sect. 4.1 (the k2 sweep), 4.3 (the physical robots) and 4.4 (the supplementary \
material: pucks, arena size, robots, cluster shifts, re-insertion), run in colony's simulator. \
Each section states the paper's finding, ours, and whether they agree; the command that made it \
is under its title. Under one condition every method starts trial `t` from the same layout \
(seed `seed + t`), so methods are compared with paired tests. STC is the first sampled step \
(every 100 steps) with PC >= 50 %; a trial that never got there counts as its full length.\n\n",
    );
    for e in Experiment::ALL {
        let path = out.join("sections").join(format!("{}.md", e.name()));
        match std::fs::read_to_string(&path) {
            Ok(text) => md.push_str(&text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => {
                return Err(ExperimentError::Read {
                    path: path.display().to_string(),
                    source,
                })
            }
        }
    }
    let path = out.join("report.md");
    std::fs::write(&path, md).map_err(write_error(&path))
}

fn section(
    out: &Path,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
    command: &str,
) -> Result<String, ExperimentError> {
    let mut md = String::new();
    let e = p.experiment;
    let title = match e {
        Experiment::K2 => "PROBSEEK's k2 (Sect. 4.1)",
        Experiment::Physical => "The physical robots' trials (Sect. 4.3)",
        Experiment::Pucks => "Number of pucks (Sect. 4.4)",
        Experiment::Arena => "Size of the arena (Sect. 4.4)",
        Experiment::Robots => "Number of robots (Sect. 4.4)",
        Experiment::Shift => "Cluster shifts (Sect. 4.4)",
        Experiment::Reinsert => "Random re-insertion (Sect. 4.4)",
    };
    let c0 = &p.conditions[0];
    let _ = writeln!(
        md,
        "## {title}\n\nMade by `{command}`: {} trials of {} control steps per method and condition.\n",
        c0.trials, c0.steps
    );
    let verdict = match e {
        Experiment::K2 => k2(out, &mut md, p, grid)?,
        Experiment::Physical => physical(out, &mut md, p, grid)?,
        Experiment::Pucks | Experiment::Arena | Experiment::Robots => {
            levels(out, &mut md, p, grid)?
        }
        Experiment::Shift => shift(out, &mut md, p, grid)?,
        Experiment::Reinsert => reinsert(out, &mut md, p, grid)?,
    };
    let _ = writeln!(md, "**Agrees with the paper: {verdict}.**\n");
    Ok(md)
}

fn twc(g: &[&TrialResult]) -> Vec<f64> {
    g.iter().map(|r| r.twc).collect()
}

fn stc(g: &[&TrialResult]) -> Vec<f64> {
    g.iter().map(|r| r.stc_or_steps()).collect()
}

fn level_table(md: &mut String, p: &PlannedExperiment, grid: &Grid<'_>) {
    let _ = writeln!(md, "{}", summary_header(&["condition", "method"]));
    for (c, by_method) in p.conditions.iter().zip(grid) {
        for (m, g) in p.experiment.methods().into_iter().zip(by_method) {
            let _ = writeln!(md, "| {} | {} {}", c.label, label(m), summary_cells(g));
        }
    }
    let _ = writeln!(md);
}

/// Mean ± 1.96 standard errors of `value` per condition, one curve per method.
fn level_plot(
    out: &Path,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
    what: &str,
    value: fn(&[&TrialResult]) -> Vec<f64>,
    x_label: &str,
) -> Result<String, ExperimentError> {
    let series: Vec<Band> = p
        .experiment
        .methods()
        .into_iter()
        .enumerate()
        .map(|(m, method)| Band {
            label: label(method).to_owned(),
            points: p
                .conditions
                .iter()
                .zip(grid)
                .map(|(c, by_method)| {
                    let xs = value(&by_method[m]);
                    let se = if xs.len() > 1 {
                        stats::std_error(&xs)
                    } else {
                        0.0
                    };
                    (c.level, stats::mean(&xs), 1.96 * se)
                })
                .collect(),
        })
        .collect();
    let name = format!("{}_{}.png", p.experiment.name(), what.to_lowercase());
    plot::bands(
        &out.join(&name),
        &format!("{what} against {x_label}"),
        x_label,
        what,
        &series,
        None,
    )
    .map_err(plot_err)?;
    Ok(name)
}

fn pc_plot(
    out: &Path,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
    condition: usize,
    title: &str,
) -> Result<String, ExperimentError> {
    let series: Vec<Band> = p
        .experiment
        .methods()
        .into_iter()
        .zip(&grid[condition])
        .map(|(m, g)| band(g, label(m), |s| Some(s.pc)))
        .collect();
    let name = format!("{}_pc.png", p.experiment.name());
    plot::bands(
        &out.join(&name),
        title,
        "time step",
        "PC (%)",
        &series,
        Some(100.0),
    )
    .map_err(plot_err)?;
    Ok(name)
}

/// "p 0.0123" or "too few trials".
fn t_line(a: &[f64], b: &[f64]) -> (String, Option<stats::TTest>) {
    match stats::paired_t_test(a, b) {
        Some(t) => (
            format!(
                "mean difference {:.4}, t({:.0}) = {:.2}, p {}",
                t.mean_difference,
                t.df,
                t.t,
                fmt_p(t.p)
            ),
            Some(t),
        ),
        None => ("too few trials for a test".to_owned(), None),
    }
}

fn normality_cell(xs: &[f64]) -> String {
    crate::sort::report::normality_text(xs)
}

fn index_of_max(xs: &[f64]) -> usize {
    let mut best = 0;
    for (i, x) in xs.iter().enumerate() {
        if *x > xs[best] {
            best = i;
        }
    }
    best
}

fn k2(
    out: &Path,
    md: &mut String,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
) -> Result<&'static str, ExperimentError> {
    let _ = writeln!(md, "The paper: \"We tested values in the set {{1, 2, 4, 8, 16}}. The highest average time-weighted completion (TWC) occurred for k2 = 8\" (blocks of 5 trials).\n");
    level_table(md, p, grid);
    let png = level_plot(out, p, grid, "TWC", twc, "k2")?;
    let _ = writeln!(md, "![TWC against k2]({png})\n");
    let means: Vec<f64> = grid.iter().map(|by| stats::mean(&twc(&by[0]))).collect();
    let best = index_of_max(&means);
    let eight = p.conditions.iter().position(|c| c.level == 8.0);
    let best_level = p.conditions[best].level;
    let _ = write!(
        md,
        "Here: the highest mean TWC is at k2 = {best_level} ({:.4}).",
        means[best]
    );
    let verdict = match eight {
        Some(e) if e == best => "yes",
        Some(e) => {
            let (line, t) = t_line(&twc(&grid[best][0]), &twc(&grid[e][0]));
            let _ = write!(
                md,
                " Against k2 = 8 ({:.4}), paired on layouts: {line}.",
                means[e]
            );
            match t {
                None => "not testable (too few trials for a test)",
                Some(t) if t.p >= ALPHA => {
                    "partly (k2 = 8 is not significantly worse than the best)"
                }
                Some(_) => "no",
            }
        }
        None => "not tested (k2 = 8 was not run)",
    };
    let _ = writeln!(md, "\n");
    Ok(verdict)
}

fn physical(
    out: &Path,
    md: &mut String,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
) -> Result<&'static str, ExperimentError> {
    let c = &p.conditions[0];
    let _ = writeln!(md, "The paper: three trials of 5,000 steps per method on SRV-1 robots whose commands last 75 ms. \"The results on PROBSEEK demonstrate gradual sorting, but the algorithm is unable to reach ... one homogeneous cluster per object type within 5,000 time steps. For CACHECONS this ideal of 100 % completion is reached in one trial ... 92.5 % completion is reached in the other two.\" (Fig. 13). Here every robot holds each command for {:.0} ms of the {:.0} ms control step and then stands still ({} robots, {} pucks of {} types); no robot fails (in the paper, two of four did in one trial per method).\n",
        1000.0 * c.scene.robots.command_duration.unwrap_or(0.0),
        1000.0 * c.scene.control_step_seconds(),
        c.scene.robots.count,
        c.scene.pucks.count,
        c.scene.pucks.kinds);
    let png = pc_plot(out, p, grid, 0, "PC with commands held 75 ms (Fig. 13)")?;
    let _ = writeln!(md, "![PC]({png})\n\n| method | trial | final PC | highest PC | reached 100 % |\n|---|---|---|---|---|");
    let methods = p.experiment.methods();
    let mut finals = Vec::new();
    let mut full = Vec::new();
    for (m, g) in methods.iter().zip(&grid[0]) {
        for (t, r) in g.iter().enumerate() {
            let top = r.samples.iter().map(|s| s.pc).fold(0.0, f64::max);
            let _ = writeln!(
                md,
                "| {} | {t} | {:.1} | {top:.1} | {} |",
                label(*m),
                r.final_pc(),
                if top >= 100.0 { "yes" } else { "no" }
            );
        }
        finals.push(stats::mean(
            &g.iter().map(|r| r.final_pc()).collect::<Vec<_>>(),
        ));
        full.push(
            g.iter()
                .filter(|r| r.samples.iter().any(|s| s.pc >= 100.0))
                .count(),
        );
    }
    let _ = writeln!(
        md,
        "\nHere: mean final PC {:.1} % for PROBSEEK and {:.1} % for CACHECONS; PROBSEEK reached 100 % in {} of {} trials, CACHECONS in {} of {}.\n",
        finals[0],
        finals[1],
        full[0],
        grid[0][0].len(),
        full[1],
        grid[0][1].len()
    );
    let ahead_every_trial = grid[0][0]
        .iter()
        .zip(&grid[0][1])
        .all(|(ps, cc)| cc.final_pc() > ps.final_pc());
    let _ = writeln!(
        md,
        "CACHECONS ends ahead of PROBSEEK in {} pair of trials from the same layout; {} trials allow no test, as in the paper.\n",
        if ahead_every_trial { "every" } else { "not every" },
        grid[0][0].len()
    );
    Ok(if full[0] == 0 && ahead_every_trial {
        "yes (PROBSEEK never reaches 100 %, CACHECONS sorts further in every trial)"
    } else if ahead_every_trial {
        "partly (CACHECONS sorts further in every trial, but PROBSEEK also reached 100 %)"
    } else {
        "no"
    })
}

fn levels(
    out: &Path,
    md: &mut String,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
) -> Result<&'static str, ExperimentError> {
    let e = p.experiment;
    let base = &p.conditions[0].scene;
    let (robots, pucks, kinds, width) = (
        base.robots.count,
        base.pucks.count,
        base.pucks.kinds,
        base.arena.width,
    );
    let (paper, x_label) = match e {
        Experiment::Pucks => (format!("\"The gap in performance between CACHECONS and PROBSEEK appears to widen as the number of pucks is increased.\" Here the pucks ({kinds} types) vary with {robots} robots in an arena {width} cm wide."), "pucks"),
        Experiment::Arena => (format!("\"Increasing the size of the environment also appears to impact PROBSEEK more profoundly.\" Here both sides of the arena ({width} cm wide at scale 1) are scaled, with {pucks} pucks of {kinds} types and {robots} robots."), "arena scale factor"),
        _ => (format!("\"We modified the number of robots and identified the number at which peak performance was achieved\" (the number is in the supplementary material, not the paper). Here the robots vary with {pucks} pucks of {kinds} types in an arena {width} cm wide."), "robots"),
    };
    let _ = writeln!(md, "The paper: {paper}\n");
    level_table(md, p, grid);
    let stc_png = level_plot(out, p, grid, "STC", stc, x_label)?;
    let twc_png = level_plot(out, p, grid, "TWC", twc, x_label)?;
    let _ = writeln!(md, "![STC]({stc_png}) ![TWC]({twc_png})\n");
    let _ = writeln!(md, "| condition | PROBSEEK vs CACHECONS, paired t-test on STC | STC normality, PROBSEEK | STC normality, CACHECONS |\n|---|---|---|---|");
    for (c, by) in p.conditions.iter().zip(grid) {
        let (line, _) = t_line(&stc(&by[0]), &stc(&by[1]));
        let _ = writeln!(
            md,
            "| {} | {line} | {} | {} |",
            c.label,
            normality_cell(&stc(&by[0])),
            normality_cell(&stc(&by[1]))
        );
    }
    let _ = writeln!(md);
    let mean_stc: Vec<[f64; 2]> = grid
        .iter()
        .map(|by| [stats::mean(&stc(&by[0])), stats::mean(&stc(&by[1]))])
        .collect();
    let mean_twc: Vec<[f64; 2]> = grid
        .iter()
        .map(|by| [stats::mean(&twc(&by[0])), stats::mean(&twc(&by[1]))])
        .collect();
    let last = grid.len() - 1;
    let censored = grid
        .iter()
        .flatten()
        .flatten()
        .filter(|r| r.stc.is_none())
        .count();
    if censored > 0 {
        let _ = writeln!(md, "{censored} trials never reached 50 %: their STC counts as the trial's length, which understates how slow they were, so gaps and ratios of STC read small where they occur.\n");
    }
    Ok(match e {
        Experiment::Pucks => {
            let gaps: Vec<f64> = mean_stc.iter().map(|s| s[0] - s[1]).collect();
            let twc_gaps: Vec<f64> = mean_twc.iter().map(|s| s[1] - s[0]).collect();
            let list = |xs: &[f64], digits: usize| {
                xs.iter()
                    .map(|x| format!("{x:.digits$}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let _ = writeln!(md, "Here: PROBSEEK's mean STC minus CACHECONS's is {} steps for {} pucks; CACHECONS's mean TWC minus PROBSEEK's is {}.\n",
                list(&gaps, 0),
                p.conditions.iter().map(|c| format!("{}", c.level)).collect::<Vec<_>>().join(", "),
                list(&twc_gaps, 4));
            if gaps.windows(2).all(|w| w[1] > w[0]) {
                "yes"
            } else if gaps[last] > gaps[0] {
                "partly (the STC gap is wider with the most pucks than with the fewest, but not at every step)"
            } else {
                "no"
            }
        }
        Experiment::Arena => {
            let ratio = |m: usize, i: usize| mean_stc[i][m] / mean_stc[0][m];
            let _ = write!(md, "Here: mean STC relative to the standard arena:");
            for (i, c) in p.conditions.iter().enumerate().skip(1) {
                let _ = write!(
                    md,
                    " {}: PROBSEEK x{:.2}, CACHECONS x{:.2};",
                    c.label,
                    ratio(0, i),
                    ratio(1, i)
                );
            }
            let _ = write!(md, " mean TWC lost against the standard arena:");
            for (i, c) in p.conditions.iter().enumerate().skip(1) {
                let _ = write!(
                    md,
                    " {}: PROBSEEK {:.4}, CACHECONS {:.4};",
                    c.label,
                    mean_twc[0][0] - mean_twc[i][0],
                    mean_twc[0][1] - mean_twc[i][1]
                );
            }
            let _ = writeln!(md, " the verdict reads the STC ratios.\n");
            let harder = |i: usize| ratio(0, i) > ratio(1, i);
            if (1..=last).all(harder) {
                "yes"
            } else if harder(last) {
                "partly (PROBSEEK slows more in the largest arena only)"
            } else {
                "no"
            }
        }
        _ => {
            let mut at_an_end = Vec::new();
            let _ = write!(md, "Here:");
            for (m, method) in e.methods().into_iter().enumerate() {
                let by_twc: Vec<f64> = mean_twc.iter().map(|x| x[m]).collect();
                let by_stc: Vec<f64> = mean_stc.iter().map(|x| -x[m]).collect();
                let (bt, bs) = (index_of_max(&by_twc), index_of_max(&by_stc));
                if bt == 0 || bt == last {
                    at_an_end.push(label(method));
                }
                let _ = write!(
                    md,
                    " {} performs best with {} (highest mean TWC, {:.4}) and reaches 50 % soonest with {};",
                    label(method),
                    p.conditions[bt].label,
                    by_twc[bt],
                    p.conditions[bs].label
                );
            }
            let _ = writeln!(md, "\n");
            match at_an_end.len() {
                0 => "yes (each method's TWC peaks inside the range tested)",
                1 => {
                    let _ = writeln!(md, "{}'s best count is at an end of the range tested.\n", at_an_end[0]);
                    "partly (one method's TWC peaks inside the range tested, the other's at an end of it)"
                }
                _ => "no (each method's best count is at an end of the range tested, so no peak was found inside it)",
            }
        }
    })
}

/// The PC of a trial's last sample before `step`.
fn pc_before(r: &TrialResult, step: u64) -> Option<f64> {
    r.samples.iter().rev().find(|s| s.step < step).map(|s| s.pc)
}

/// A trial's samples from `from` (inclusive) to `to` (exclusive).
fn window(r: &TrialResult, from: u64, to: u64) -> impl Iterator<Item = &Sample> {
    r.samples
        .iter()
        .filter(move |s| s.step >= from && s.step < to)
}

/// A trial's mean PC over its samples from `from` (inclusive) to `to` (exclusive), if any.
fn window_pc(r: &TrialResult, from: u64, to: u64) -> Option<f64> {
    let pcs: Vec<f64> = window(r, from, to).map(|x| x.pc).collect();
    (!pcs.is_empty()).then(|| stats::mean(&pcs))
}

/// The end of the window after the disturbance at `at`: the next one, or the trial's end.
fn window_end(at: u64, all: &[u64], steps: u64) -> u64 {
    all.iter().copied().find(|&s| s > at).unwrap_or(steps + 1)
}

fn shift(
    out: &Path,
    md: &mut String,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
) -> Result<&'static str, ExperimentError> {
    let c = &p.conditions[1];
    let at = disturbance_steps(c.steps);
    let _ = writeln!(md, "The paper: \"PROBSEEK was found to be unaffected by cluster shifts since it maintains no memory of cluster locations. In its standard form CACHECONS exhibits a drop in performance in response to these shifts. However, we introduced a variant which simply erases its own memory periodically and this variant proved to be more robust to shift disturbances.\" Here, at steps {at:?}, the largest cluster is moved to the mirror image of its place through the arena's centre, keeping its shape; CacheCons_Erase wipes its caches with probability {} per step. Every disturbed trial is compared with the same trial (method and layout) run undisturbed: its effect is the mean PC over the steps from a shift to the next (or to the end), disturbed minus undisturbed, averaged over its shifts.\n",
        c.params.cache.erase_probability);
    let png = pc_plot(out, p, grid, 1, "PC with cluster shifts")?;
    let _ = writeln!(md, "![PC]({png})\n\n| method | mean PC before a shift | mean PC after, disturbed | the same steps undisturbed | mean effect (points) | sd | effect against 0, t-test |\n|---|---|---|---|---|---|---|");
    let mut effects = Vec::new();
    for (m, method) in p.experiment.methods().into_iter().enumerate() {
        let (mut before, mut after, mut calm) = (Vec::new(), Vec::new(), Vec::new());
        let per_trial: Vec<f64> = grid[1][m]
            .iter()
            .zip(&grid[0][m])
            .map(|(r, u)| {
                let d: Vec<f64> = at
                    .iter()
                    .filter_map(|&s| {
                        let end = window_end(s, &at, c.steps);
                        let (hit, base) = (window_pc(r, s, end)?, window_pc(u, s, end)?);
                        before.extend(pc_before(r, s));
                        after.push(hit);
                        calm.push(base);
                        Some(hit - base)
                    })
                    .collect();
                stats::mean(&d)
            })
            .collect();
        let zeros = vec![0.0; per_trial.len()];
        let (line, t) = t_line(&per_trial, &zeros);
        let _ = writeln!(
            md,
            "| {} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {line} |",
            label(method),
            stats::mean(&before),
            stats::mean(&after),
            stats::mean(&calm),
            stats::mean(&per_trial),
            stats::std_dev(&per_trial)
        );
        effects.push((per_trial, t));
    }
    let (erase_line, erase_t) = t_line(&effects[2].0, &effects[1].0);
    let _ = writeln!(
        md,
        "\nCacheCons_Erase's effect against CACHECONS's, paired on layouts: {erase_line}.\n"
    );
    let dropped = |i: usize| {
        effects[i]
            .1
            .is_some_and(|t| t.p < ALPHA && t.mean_difference < 0.0)
    };
    if erase_t.is_none() || effects.iter().any(|(_, t)| t.is_none()) {
        return Ok("not testable (too few trials for a test)");
    }
    let probseek_unaffected = !dropped(0);
    let cachecons_drops = dropped(1);
    let erase_robust = erase_t.is_some_and(|t| t.p < ALPHA && t.mean_difference > 0.0);
    let _ = writeln!(
        md,
        "Here: PROBSEEK {}; CACHECONS {}; CacheCons_Erase {}.\n",
        if probseek_unaffected {
            "shows no significant drop"
        } else {
            "drops significantly"
        },
        if cachecons_drops {
            "drops significantly"
        } else {
            "shows no significant drop"
        },
        if erase_robust {
            "loses significantly less than CACHECONS"
        } else {
            "does not lose significantly less than CACHECONS"
        }
    );
    Ok(
        match [probseek_unaffected, cachecons_drops, erase_robust]
            .iter()
            .filter(|x| **x)
            .count()
        {
            3 => "yes",
            0 => "no",
            _ => "partly (see which of the three findings hold above)",
        },
    )
}

fn reinsert(
    out: &Path,
    md: &mut String,
    p: &PlannedExperiment,
    grid: &Grid<'_>,
) -> Result<&'static str, ExperimentError> {
    let c = &p.conditions[1];
    let at = disturbance_steps(c.steps);
    let _ = writeln!(md, "The paper: \"For random re-insertion disturbances, all methods showed a similar impact on performance, although both CACHECONS variants could recover much more quickly than PROBSEEK.\" Here, at steps {at:?}, every puck is put at a new random place. A trial's recovery time is, averaged over its re-insertions, the steps from a re-insertion until PC is at 50 % again (the gap to the next re-insertion, or to the end, if it never is: such times are censored and read short). Its loss is the mean PC over the steps from a re-insertion to the next (or to the end), the same trial undisturbed minus disturbed.\n");
    let png = pc_plot(out, p, grid, 1, "PC with random re-insertion")?;
    let _ = writeln!(md, "![PC]({png})\n\n| method | mean PC before | mean PC right after | mean loss (points) | mean recovery (steps) | sd | never recovered |\n|---|---|---|---|---|---|---|");
    let mut recovery = Vec::new();
    let mut after_means = Vec::new();
    for (m, method) in p.experiment.methods().into_iter().enumerate() {
        let (mut before, mut after, mut losses, mut never) =
            (Vec::new(), Vec::new(), Vec::new(), 0);
        let per_trial: Vec<f64> = grid[1][m]
            .iter()
            .zip(&grid[0][m])
            .map(|(r, u)| {
                let times: Vec<f64> = at
                    .iter()
                    .filter_map(|&s| {
                        let end = window_end(s, &at, c.steps);
                        let mut w = window(r, s, end);
                        let first = w.next()?;
                        before.extend(pc_before(r, s));
                        after.push(first.pc);
                        if let (Some(hit), Some(calm)) =
                            (window_pc(r, s, end), window_pc(u, s, end))
                        {
                            losses.push(calm - hit);
                        }
                        let back = std::iter::once(first)
                            .chain(w)
                            .find(|x| x.pc >= colony_sort::metrics::STC_LEVEL);
                        Some(match back {
                            Some(x) => (x.step - s) as f64,
                            None => {
                                never += 1;
                                (end.min(c.steps) - s) as f64
                            }
                        })
                    })
                    .collect();
                stats::mean(&times)
            })
            .collect();
        let _ = writeln!(
            md,
            "| {} | {:.1} | {:.1} | {:.1} | {:.0} | {:.0} | {never} |",
            label(method),
            stats::mean(&before),
            stats::mean(&after),
            stats::mean(&losses),
            stats::mean(&per_trial),
            stats::std_dev(&per_trial)
        );
        recovery.push(per_trial);
        after_means.push(stats::mean(&after));
    }
    let mut faster = 0;
    let mut tested = true;
    let _ = writeln!(md);
    for i in [1, 2] {
        let (line, t) = t_line(&recovery[0], &recovery[i]);
        let _ = writeln!(
            md,
            "- Recovery, PROBSEEK against {}, paired on layouts: {line}.",
            label(p.experiment.methods()[i])
        );
        tested &= t.is_some();
        if t.is_some_and(|t| t.p < ALPHA && t.mean_difference > 0.0) {
            faster += 1;
        }
    }
    let spread = after_means.iter().fold(f64::MIN, |a, b| a.max(*b))
        - after_means.iter().fold(f64::MAX, |a, b| a.min(*b));
    let _ = writeln!(
        md,
        "\nHere: right after a re-insertion the methods' mean PC lies within {spread:.1} points of each other, which a random layout makes so whatever the method (the impact is alike by construction; the losses above show what each method then makes of it); {faster} of the two CACHECONS variants recover significantly faster than PROBSEEK.\n"
    );
    Ok(match (tested, faster) {
        (false, _) => "not testable (too few trials for a test)",
        (true, 2) => "yes",
        (true, 1) => "partly (one CACHECONS variant recovers significantly faster than PROBSEEK)",
        _ => "no",
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sort::supplementary::{plan, Scale};
    use colony_sim::SceneConfig;

    #[test]
    fn a_quick_run_of_every_experiment_writes_a_report_with_a_verdict_each() {
        let dir = tempfile::tempdir().unwrap();
        let scale = Scale {
            trials: 2,
            steps: 300,
            seed: 3,
        };
        let mut scene = SceneConfig::default();
        scene.pucks.count = 20;
        let plan = plan(
            &Experiment::ALL,
            &scene,
            &colony_sort::SortParams::default(),
            scale,
        );
        let results = crate::sort::experiment::run_trials(&plan.specs, &|_| {}).unwrap();
        write(dir.path(), &plan, &results, "test").unwrap();
        let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
        assert_eq!(
            report.matches("**Agrees with the paper: ").count(),
            7,
            "{report}"
        );
        for png in [
            "k2_twc.png",
            "physical_pc.png",
            "pucks_stc.png",
            "robots_twc.png",
            "shift_pc.png",
            "reinsert_pc.png",
        ] {
            assert!(dir.path().join(png).exists(), "{png}");
        }
        assert!(dir.path().join("csv/robots/16_robots/summary.csv").exists());
        // Sections of an earlier run survive a run of one experiment.
        let only = crate::sort::supplementary::plan(
            &[Experiment::K2],
            &scene,
            &colony_sort::SortParams::default(),
            scale,
        );
        let k2_results = crate::sort::experiment::run_trials(&only.specs, &|_| {}).unwrap();
        write(dir.path(), &only, &k2_results, "test").unwrap();
        let again = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
        assert_eq!(again, report);
        // The report can be written again from the CSV files alone, to the same verdicts.
        let read = read_results(dir.path(), &plan).unwrap();
        assert_eq!(read.len(), results.len());
        for (a, b) in read.iter().zip(&results) {
            assert_eq!(
                (a.method, a.seed, a.steps, a.stc),
                (b.method, b.seed, b.steps, b.stc)
            );
            assert_eq!(a.samples.len(), b.samples.len());
        }
        write(dir.path(), &plan, &read, "test").unwrap();
        let rebuilt = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
        let verdicts = |r: &str| -> Vec<String> {
            r.lines()
                .filter(|l| l.starts_with("**Agrees"))
                .map(str::to_owned)
                .collect()
        };
        assert_eq!(verdicts(&rebuilt), verdicts(&report));
        // Results that do not fit the plan are refused, not indexed out of range.
        assert!(write(dir.path(), &plan, &read[1..], "test").is_err());
        std::fs::remove_dir_all(dir.path().join("csv/pucks")).unwrap();
        let err = read_results(dir.path(), &plan).unwrap_err().to_string();
        assert!(err.contains("cannot read"), "{err}");
    }
}
