//! `colony sort reproduce`: the paper's experiments, figures, tables and
//! statistical tests, written into one directory with a `report.md`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use colony_sim::SceneConfig;
use colony_sort::methods::Method;
use colony_sort::params::SortParams;

use crate::sort::experiment::{write_csv, write_error, ExperimentError, TrialResult, TrialSpec};
use crate::sort::plot::{self, ArenaView, Band};
use crate::sort::stats;

/// The paper's comparisons (Sect. 4.2): methods per number of puck types.
pub fn methods_for(types: usize) -> Vec<Method> {
    if types == 1 {
        vec![Method::Bhd, Method::ProbSeek, Method::CacheCons]
    } else {
        vec![
            Method::ProbSeek,
            Method::CacheCons,
            Method::CacheConsIgnore,
            Method::CacheConsInformed,
        ]
    }
}

/// The puck-type counts of Fig. 7.
pub const TYPE_COUNTS: [usize; 4] = [1, 2, 4, 8];

/// Every trial of the reproduction. Trial `t` uses seed `seed + t` for every
/// method, so the methods start from the same layouts and tests can pair them.
pub fn specs(
    scene: &SceneConfig,
    params: &SortParams,
    steps: u64,
    trials: u64,
    seed: u64,
) -> Vec<TrialSpec> {
    let mut snapshot_at: Vec<u64> = [0, 1_000, 2_000, 5_000, steps / 2, steps]
        .into_iter()
        .filter(|&s| s <= steps)
        .collect();
    snapshot_at.dedup();
    let mut out = Vec::new();
    for types in TYPE_COUNTS {
        for method in methods_for(types) {
            for t in 0..trials {
                let mut scene = scene.clone();
                scene.pucks.kinds = types;
                out.push(TrialSpec {
                    method,
                    scene,
                    params: params.clone(),
                    steps,
                    seed: seed + t,
                    sample_every: 100.min(steps.max(1)),
                    snapshot_at: if t == 0 {
                        snapshot_at.clone()
                    } else {
                        Vec::new()
                    },
                    disturbances: Vec::new(),
                });
            }
        }
    }
    out
}

type Groups<'a> = HashMap<(usize, Method), Vec<&'a TrialResult>>;

fn group(results: &[TrialResult]) -> Groups<'_> {
    let mut g: Groups<'_> = HashMap::new();
    for r in results {
        g.entry((r.types, r.method)).or_default().push(r);
    }
    for v in g.values_mut() {
        v.sort_by_key(|r| r.seed);
    }
    g
}

pub(crate) fn label(m: Method) -> &'static str {
    match m {
        Method::Bhd => "BHD",
        Method::ProbSeek => "PROBSEEK",
        Method::CacheCons => "CACHECONS",
        Method::CacheConsInformed => "CACHECONS_INFORMED",
        Method::CacheConsIgnore => "CacheCons_Ignore",
        Method::CacheConsErase => "CacheCons_Erase",
    }
}

/// Mean and a ±1.96 standard error band of a per-sample quantity over trials.
pub(crate) fn band(
    trials: &[&TrialResult],
    name: &str,
    value: impl Fn(&crate::sort::experiment::Sample) -> Option<f64>,
) -> Band {
    let n = trials.iter().map(|t| t.samples.len()).min().unwrap_or(0);
    let points = (0..n)
        .filter_map(|i| {
            let vals: Vec<f64> = trials.iter().filter_map(|t| value(&t.samples[i])).collect();
            if vals.is_empty() {
                return None;
            }
            let se = if vals.len() > 1 {
                stats::std_error(&vals)
            } else {
                0.0
            };
            Some((
                trials[0].samples[i].step as f64,
                stats::mean(&vals),
                1.96 * se,
            ))
        })
        .collect();
    Band {
        label: name.to_owned(),
        points,
    }
}

/// A Markdown table's header and rule: the caller's first columns, then those
/// [`summary_cells`] fills.
pub(crate) fn summary_header(first: &[&str]) -> String {
    let names = [
        "mean STC",
        "sd STC",
        "not reaching 50 %",
        "mean TWC",
        "sd TWC",
        "mean final PC",
    ];
    let all: Vec<&str> = first.iter().chain(&names).copied().collect();
    format!("| {} |\n|{}", all.join(" | "), "---|".repeat(all.len()))
}

/// One group of trials' STC, TWC and final PC as Markdown table cells (see [`summary_header`]).
pub(crate) fn summary_cells(g: &[&TrialResult]) -> String {
    let stc: Vec<f64> = g.iter().map(|r| r.stc_or_steps()).collect();
    let twc: Vec<f64> = g.iter().map(|r| r.twc).collect();
    let fin: Vec<f64> = g.iter().map(|r| r.final_pc()).collect();
    let censored = g.iter().filter(|r| r.stc.is_none()).count();
    format!(
        "| {:.0} | {:.0} | {censored} | {:.4} | {:.4} | {:.1} |",
        stats::mean(&stc),
        stats::std_dev(&stc),
        stats::mean(&twc),
        stats::std_dev(&twc),
        stats::mean(&fin)
    )
}

pub(crate) fn fmt_p(p: f64) -> String {
    if p < 0.0001 {
        "< 0.0001".to_owned()
    } else {
        format!("{p:.4}")
    }
}

pub(crate) fn plot_err(e: plot::PlotError) -> ExperimentError {
    ExperimentError::Invalid(e.to_string())
}

/// Writes CSV files, figures and `report.md` for the results of [`specs`].
pub fn write(
    out: &Path,
    results: &[TrialResult],
    scene: &SceneConfig,
    command: &str,
) -> Result<(), ExperimentError> {
    write_csv(&out.join("csv"), results)?;
    let groups = group(results);
    let mut md = String::new();
    let trials = groups.values().map(Vec::len).max().unwrap_or(0);
    let steps = results.first().map_or(0, |r| r.steps);
    let _ = writeln!(
        md,
        "# Cache consensus: reproduction of Vardy, Vorobyev and Banzhaf (2014)\n"
    );
    let _ = writeln!(md, "Made by `{command}`: {trials} trials of {steps} control steps per method and type count, 40 pucks, 4 robots, \
the standard arena; trial `t` of every method starts from the same layout (seed), so methods are compared pairwise. \
STC is the first sampled step (every 100 steps) with PC >= 50 %; a trial that never reached 50 % counts as its full length (noted where it happens).\n");

    for types in TYPE_COUNTS {
        let present: Vec<(Method, &Vec<&TrialResult>)> = methods_for(types)
            .into_iter()
            .filter_map(|m| groups.get(&(types, m)).map(|g| (m, g)))
            .collect();
        if present.is_empty() {
            continue;
        }
        let _ = writeln!(
            md,
            "## {types} puck type{}\n",
            if types > 1 { "s" } else { "" }
        );
        let bands: Vec<Band> = present
            .iter()
            .map(|(m, g)| band(g, label(*m), |s| Some(s.pc)))
            .collect();
        let pc_png = format!("pc_types{types}.png");
        plot::bands(
            &out.join(&pc_png),
            &format!("Percentage completion, {types} type(s) (Fig. 7)"),
            "time step",
            "PC (%)",
            &bands,
            Some(100.0),
        )
        .map_err(plot_err)?;
        let _ = writeln!(md, "![PC, {types} types]({pc_png})\n");
        let _ = writeln!(md, "{}", summary_header(&["method"]));
        for (m, g) in &present {
            let _ = writeln!(md, "| {} {}", label(*m), summary_cells(g));
        }
        let _ = writeln!(md);
        let stc_groups: Vec<(String, Vec<f64>)> = present
            .iter()
            .map(|(m, g)| {
                (
                    label(*m).to_owned(),
                    g.iter().map(|r| r.stc_or_steps()).collect(),
                )
            })
            .collect();
        let twc_groups: Vec<(String, Vec<f64>)> = present
            .iter()
            .map(|(m, g)| (label(*m).to_owned(), g.iter().map(|r| r.twc).collect()))
            .collect();
        let (stc_png, twc_png) = (
            format!("stc_types{types}.png"),
            format!("twc_types{types}.png"),
        );
        plot::boxes(
            &out.join(&stc_png),
            &format!("STC, {types} type(s) (Fig. 9b)"),
            "steps to 50 %",
            &stc_groups,
        )
        .map_err(plot_err)?;
        plot::boxes(
            &out.join(&twc_png),
            &format!("TWC, {types} type(s) (Fig. 9a)"),
            "TWC",
            &twc_groups,
        )
        .map_err(plot_err)?;
        let _ = writeln!(md, "![STC]({stc_png}) ![TWC]({twc_png})\n");
        tests_for(&mut md, types, &groups);
        snapshots_for(out, &mut md, types, &present, scene)?;
    }
    convergence(out, &mut md, &groups)?;
    let path = out.join("report.md");
    std::fs::write(&path, md).map_err(write_error(&path))
}

fn stc_of(groups: &Groups<'_>, types: usize, m: Method) -> Option<Vec<f64>> {
    groups
        .get(&(types, m))
        .map(|g| g.iter().map(|r| r.stc_or_steps()).collect())
}

fn tests_for(md: &mut String, types: usize, groups: &Groups<'_>) {
    if types == 1 {
        let methods = [Method::Bhd, Method::ProbSeek, Method::CacheCons];
        let data: Option<Vec<Vec<f64>>> = methods.iter().map(|&m| stc_of(groups, 1, m)).collect();
        let Some(data) = data else { return };
        normality_lines(md, groups, 1, &methods);
        let Some(anova) = stats::repeated_measures_anova(&data) else {
            let _ = writeln!(md, "Too few trials for a repeated-measures ANOVA.\n");
            return;
        };
        let _ = writeln!(
            md,
            "Repeated-measures ANOVA on STC over BHD, PROBSEEK, CACHECONS: F({:.0}, {:.0}) = {:.2}, p {}.\n",
            anova.df_conditions,
            anova.df_error,
            anova.f,
            fmt_p(anova.p)
        );
        let _ = writeln!(
            md,
            "| Tukey pair | mean difference (steps) | q | p |\n|---|---|---|---|"
        );
        let pairs = stats::tukey_hsd(&data, &anova);
        for p in &pairs {
            let _ = writeln!(
                md,
                "| {} - {} | {:.0} | {:.2} | {} |",
                label(methods[p.a]),
                label(methods[p.b]),
                p.difference,
                p.q,
                fmt_p(p.p)
            );
        }
        let means: Vec<f64> = data.iter().map(|d| stats::mean(d)).collect();
        let ordered = means[2] < means[1] && means[1] < means[0];
        let significant = anova.p < 0.01 && pairs.iter().all(|p| p.p < 0.01);
        let _ = writeln!(
            md,
            "\nThe paper: mean STC of CACHECONS < PROBSEEK < BHD, every difference significant (p < 0.0001). Here: order {}, all differences significant at p < 0.01: **{}**.\n",
            if ordered { "as in the paper" } else { "differs from the paper" },
            if significant { "yes" } else { "no" }
        );
        return;
    }
    let pair = |md: &mut String, a: Method, b: Method, claim: &str| {
        let (Some(x), Some(y)) = (stc_of(groups, types, a), stc_of(groups, types, b)) else {
            return;
        };
        match stats::paired_t_test(&x, &y) {
            Some(t) => {
                let _ = writeln!(
                    md,
                    "- Paired t-test on STC, {} vs {}: mean difference {:.0} steps, t({:.0}) = {:.2}, p {}. {claim}",
                    label(a),
                    label(b),
                    t.mean_difference,
                    t.df,
                    t.t,
                    fmt_p(t.p)
                );
            }
            None => {
                let _ = writeln!(
                    md,
                    "- Too few trials for a paired t-test of {} vs {}.",
                    label(a),
                    label(b)
                );
            }
        }
    };
    pair(
        md,
        Method::ProbSeek,
        Method::CacheCons,
        "(Paper: PROBSEEK takes significantly longer than CACHECONS for 2, 4 and 8 types.)",
    );
    pair(md, Method::CacheCons, Method::CacheConsInformed, "(Paper: CACHECONS slower than CACHECONS_INFORMED for 2 and 4 types, p = 0.0017 and 0.0025; not significant for 8, p = 0.16.)");
    if let (Some(plain), Some(informed)) = (
        stc_of(groups, types, Method::CacheCons),
        stc_of(groups, types, Method::CacheConsInformed),
    ) {
        let (plain, informed) = (stats::mean(&plain), stats::mean(&informed));
        let _ = writeln!(
            md,
            "- The paper has CACHECONS_INFORMED faster than CACHECONS for 2, 4 and 8 types (significantly for 2 and 4). Here, with {types} types, CACHECONS_INFORMED's mean STC is {informed:.0} steps against CACHECONS's {plain:.0}: {} (whether significantly, the paired t-test above says).",
            if informed < plain {
                "faster, as in the paper"
            } else if informed > plain {
                "slower, unlike the paper"
            } else {
                "the same"
            }
        );
    }
    let _ = writeln!(md);
}

/// D'Agostino-Pearson's test of `xs` as text: K² and p, with a caution below 20 values.
pub(crate) fn normality_text(xs: &[f64]) -> String {
    match stats::normality_test(xs) {
        Some(t) if xs.len() < stats::NORMALITY_GOOD_N => {
            format!(
                "K² {:.2}, p {} (rough: {} values)",
                t.k2,
                fmt_p(t.p),
                xs.len()
            )
        }
        Some(t) => format!("K² {:.2}, p {}", t.k2, fmt_p(t.p)),
        None => "not testable (too few or identical values)".to_owned(),
    }
}

/// D'Agostino-Pearson's test on each method's STC and TWC, as the paper runs before its ANOVA.
pub(crate) fn normality_lines(
    md: &mut String,
    groups: &Groups<'_>,
    types: usize,
    methods: &[Method],
) {
    let _ = writeln!(
        md,
        "D'Agostino-Pearson normality test (the paper: TWC of PROBSEEK and CACHECONS not normal, STC of all three normal):\n\n| method | STC | TWC |\n|---|---|---|"
    );
    for &m in methods {
        let Some(g) = groups.get(&(types, m)) else {
            continue;
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} |",
            label(m),
            normality_text(&g.iter().map(|r| r.stc_or_steps()).collect::<Vec<_>>()),
            normality_text(&g.iter().map(|r| r.twc).collect::<Vec<_>>())
        );
    }
    let _ = writeln!(md);
}

fn snapshots_for(
    out: &Path,
    md: &mut String,
    types: usize,
    present: &[(Method, &Vec<&TrialResult>)],
    scene: &SceneConfig,
) -> Result<(), ExperimentError> {
    let mut row = String::new();
    for (m, g) in present {
        let Some(first) = g.first() else { continue };
        for snap in &first.snapshots {
            let name = format!("snap_types{types}_{}_step{}.png", m, snap.step);
            let view = ArenaView {
                title: format!("{} step {}", label(*m), snap.step),
                width: scene.arena.width,
                corner_radius: scene.arena.corner_radius,
                puck_diameter: scene.pucks.diameter,
                pucks: &snap.pucks,
                robots: &snap.robots,
                caches: &snap.caches,
            };
            plot::arena(&out.join(&name), &view).map_err(plot_err)?;
            let _ = write!(row, "![{} step {}]({name}) ", label(*m), snap.step);
        }
        row.push_str("\n\n");
    }
    let _ = writeln!(
        md,
        "Snapshots of trial 0 (Figs. 8 and 10; squares are cache points):\n\n{row}"
    );
    Ok(())
}

fn convergence(out: &Path, md: &mut String, groups: &Groups<'_>) -> Result<(), ExperimentError> {
    let Some(g) = groups.get(&(2, Method::CacheCons)) else {
        return Ok(());
    };
    let b = band(g, "CACHECONS, 2 types", |s| s.cache_variance);
    let limit = 20_000.0;
    let clipped = Band {
        label: b.label.clone(),
        points: b.points.iter().copied().filter(|p| p.0 <= limit).collect(),
    };
    plot::bands(
        &out.join("cache_convergence.png"),
        "Cache-point convergence (Fig. 11)",
        "time step",
        "variance of distance to centroid (cm^2)",
        &[clipped],
        None,
    )
    .map_err(plot_err)?;
    let _ = writeln!(md, "## Cache-point convergence (standard configuration)\n\n![cache convergence](cache_convergence.png)\n");
    let _ = writeln!(md, "| step | mean variance (cm^2) |\n|---|---|");
    for (step, mean, _) in b.points.iter().filter(|p| {
        [0.0, 500.0, 1000.0, 2000.0, 5000.0, 10000.0].contains(&p.0)
            || p.0 == b.points.last().map_or(0.0, |l| l.0)
    }) {
        let _ = writeln!(md, "| {step:.0} | {mean:.1} |");
    }
    let peak = b.points.iter().map(|p| p.1).fold(0.0, f64::max);
    let at_5000 = b.points.iter().find(|p| p.0 >= 5000.0).map(|p| p.1);
    if let Some(v) = at_5000 {
        let _ = writeln!(
            md,
            "\nThe paper: cache points converge within the first few thousand steps. Here the variance peaks at {peak:.1} cm^2 and is {v:.1} cm^2 at step 5,000 ({:.0} % of the peak).\n",
            if peak > 0.0 { 100.0 * v / peak } else { 0.0 }
        );
    }
    Ok(())
}
