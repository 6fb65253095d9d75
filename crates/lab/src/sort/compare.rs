//! `colony sort compare`: two runs of the paper's reproduction side by side (the same
//! experiments under two contact engines, say), judged by what the paper's conclusions
//! rest on: each method's mean STC and TWC against the reference run's 95 % confidence
//! interval, the order of the methods, and whether each test is significant in both.

use std::collections::HashMap;
use std::fmt::Write as _;

use colony_sort::methods::Method;
use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::sort::experiment::TrialResult;
use crate::sort::report::{fmt_p, label, methods_for, TYPE_COUNTS};
use crate::sort::stats;

/// The significance level the tests are compared at.
pub const ALPHA: f64 = 0.05;

type Runs<'a> = HashMap<(usize, Method), Vec<&'a TrialResult>>;

fn runs(results: &[TrialResult]) -> Runs<'_> {
    let mut out: Runs<'_> = HashMap::new();
    for r in results {
        out.entry((r.types, r.method)).or_default().push(r);
    }
    for v in out.values_mut() {
        v.sort_by_key(|r| r.seed);
    }
    out
}

/// Mean and the half-width of its 95 % confidence interval (Student's t).
fn mean_ci(xs: &[f64]) -> (f64, f64) {
    let m = stats::mean(xs);
    if xs.len() < 2 {
        return (m, f64::NAN);
    }
    let t = StudentsT::new(0.0, 1.0, (xs.len() - 1) as f64)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(f64::NAN);
    (m, t * stats::std_error(xs))
}

/// What one comparison found, for the summary.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Tally {
    /// Means compared (STC and TWC, each method and type count).
    pub means: usize,
    /// Of those, the candidate's inside the reference's 95 % confidence interval.
    pub means_inside: usize,
    /// Type counts whose method order (by mean STC) was compared.
    pub orders: usize,
    /// Of those, the ones whose order agreed.
    pub orders_same: usize,
    /// Tests compared.
    pub tests: usize,
    /// Of those, the ones significant in both runs at [`ALPHA`], or in neither.
    pub tests_same: usize,
}

fn stc(rs: &[&TrialResult]) -> Vec<f64> {
    rs.iter().map(|r| r.stc_or_steps()).collect()
}

fn twc(rs: &[&TrialResult]) -> Vec<f64> {
    rs.iter().map(|r| r.twc).collect()
}

/// The tests the report makes for `types` puck types, each as (name, p).
fn tests(types: usize, runs: &Runs<'_>) -> Vec<(String, f64)> {
    let get = |m: Method| runs.get(&(types, m)).map(|v| stc(v));
    let mut out = Vec::new();
    if types == 1 {
        let methods = [Method::Bhd, Method::ProbSeek, Method::CacheCons];
        let Some(data) = methods.iter().map(|&m| get(m)).collect::<Option<Vec<_>>>() else {
            return out;
        };
        if let Some(anova) = stats::repeated_measures_anova(&data) {
            out.push(("repeated-measures ANOVA on STC".to_owned(), anova.p));
            for p in stats::tukey_hsd(&data, &anova) {
                let name = format!("Tukey, {} - {}", label(methods[p.a]), label(methods[p.b]));
                out.push((name, p.p));
            }
        }
        return out;
    }
    for (a, b) in [
        (Method::ProbSeek, Method::CacheCons),
        (Method::CacheCons, Method::CacheConsInformed),
    ] {
        if let (Some(x), Some(y)) = (get(a), get(b)) {
            if let Some(t) = stats::paired_t_test(&x, &y) {
                out.push((
                    format!("paired t-test on STC, {} vs {}", label(a), label(b)),
                    t.p,
                ));
            }
        }
    }
    out
}

/// The comparison as Markdown, and its tally.
pub fn compare(
    reference: &[TrialResult],
    candidate: &[TrialResult],
    names: (&str, &str),
) -> (String, Tally) {
    let (ref_runs, cand_runs) = (runs(reference), runs(candidate));
    let (a, b) = names;
    let mut md = String::new();
    let mut tally = Tally::default();
    for types in TYPE_COUNTS {
        let methods: Vec<Method> = methods_for(types)
            .into_iter()
            .filter(|m| ref_runs.contains_key(&(types, *m)) && cand_runs.contains_key(&(types, *m)))
            .collect();
        if methods.is_empty() {
            continue;
        }
        let _ = writeln!(
            md,
            "## {types} puck type{}\n",
            if types == 1 { "" } else { "s" }
        );
        let _ = writeln!(
            md,
            "| method | {a}: mean STC (95 % CI) | {b}: mean STC | inside | {a}: mean TWC (95 % CI) | {b}: mean TWC | inside |\n|---|---|---|---|---|---|---|"
        );
        let order = |runs: &Runs<'_>| {
            let mut v: Vec<(f64, Method)> = methods
                .iter()
                .map(|&m| (stats::mean(&stc(&runs[&(types, m)])), m))
                .collect();
            v.sort_by(|x, y| x.0.total_cmp(&y.0));
            v.into_iter().map(|(_, m)| m).collect::<Vec<_>>()
        };
        let (order_a, order_b) = (order(&ref_runs), order(&cand_runs));
        for &m in &methods {
            let (r, c) = (&ref_runs[&(types, m)], &cand_runs[&(types, m)]);
            let mut cells = Vec::new();
            for (xs, ys, digits) in [(stc(r), stc(c), 0), (twc(r), twc(c), 4)] {
                let (mean, half) = mean_ci(&xs);
                let other = stats::mean(&ys);
                let inside = (other - mean).abs() <= half;
                tally.means += 1;
                tally.means_inside += usize::from(inside);
                cells.push(format!(
                    "{mean:.digits$} ({:.digits$} to {:.digits$}) | {other:.digits$} | {}",
                    mean - half,
                    mean + half,
                    if inside { "yes" } else { "**no**" }
                ));
            }
            let _ = writeln!(md, "| {} | {} | {} |", label(m), cells[0], cells[1]);
        }
        let names = |o: &[Method]| o.iter().map(|&m| label(m)).collect::<Vec<_>>().join(" < ");
        tally.orders += 1;
        tally.orders_same += usize::from(order_a == order_b);
        let _ = writeln!(
            md,
            "\nMethods by mean STC, fastest first: {a} {}; {b} {}: **{}**.\n",
            names(&order_a),
            names(&order_b),
            if order_a == order_b {
                "the same"
            } else {
                "different"
            }
        );
        let (ta, tb) = (tests(types, &ref_runs), tests(types, &cand_runs));
        if !ta.is_empty() {
            let _ = writeln!(
                md,
                "| test | {a}: p | {b}: p | significant at {ALPHA} in both, or in neither |\n|---|---|---|---|"
            );
            for ((name, pa), (_, pb)) in ta.iter().zip(&tb) {
                let same = (*pa < ALPHA) == (*pb < ALPHA);
                tally.tests += 1;
                tally.tests_same += usize::from(same);
                let _ = writeln!(
                    md,
                    "| {name} | {} | {} | {} |",
                    fmt_p(*pa),
                    fmt_p(*pb),
                    if same { "yes" } else { "**no**" }
                );
            }
            md.push('\n');
        }
    }
    let _ = writeln!(
        md,
        "## In sum\n\n- Means inside {a}'s 95 % confidence interval: {} of {}.\n- Method orders the same: {} of {}.\n- Tests that agree at {ALPHA}: {} of {}.",
        tally.means_inside, tally.means, tally.orders_same, tally.orders, tally.tests_same, tally.tests
    );
    (md, tally)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trial(method: Method, types: usize, seed: u64, stc: u64, twc: f64) -> TrialResult {
        TrialResult {
            method,
            types,
            seed,
            steps: 100_000,
            samples: Vec::new(),
            stc: Some(stc),
            twc,
            snapshots: Vec::new(),
        }
    }

    fn run(shift: u64) -> Vec<TrialResult> {
        let mut out = Vec::new();
        for seed in 0..10 {
            let wobble = (seed * 37) % 11;
            out.push(trial(
                Method::ProbSeek,
                2,
                seed,
                3000 + 20 * wobble + shift,
                0.86,
            ));
            out.push(trial(
                Method::CacheCons,
                2,
                seed,
                600 + 7 * wobble + shift,
                0.99,
            ));
            out.push(trial(
                Method::CacheConsIgnore,
                2,
                seed,
                560 + 9 * wobble,
                0.97,
            ));
            out.push(trial(
                Method::CacheConsInformed,
                2,
                seed,
                430 + 5 * wobble,
                0.998,
            ));
        }
        out
    }

    #[test]
    fn a_run_agrees_with_itself_and_a_shifted_one_falls_outside() {
        let (md, same) = compare(&run(0), &run(0), ("rapier", "disc"));
        assert_eq!(same.means_inside, same.means, "{md}");
        assert_eq!((same.orders_same, same.tests_same), (1, 2), "{md}");
        let (md, shifted) = compare(&run(0), &run(500), ("rapier", "disc"));
        // PROBSEEK's and CACHECONS's STC moved by 500 steps: outside their intervals.
        assert_eq!(shifted.means_inside, shifted.means - 2, "{md}");
        assert!(md.contains("**no**"));
    }
}
