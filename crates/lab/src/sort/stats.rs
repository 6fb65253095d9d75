//! The statistical tests the paper reports: D'Agostino-Pearson's normality test,
//! repeated-measures ANOVA with Tukey's multiple comparisons, and paired t-tests.

use statrs::distribution::{ContinuousCDF, FisherSnedecor, StudentsT};
use statrs::function::gamma::ln_gamma;

/// Mean of a sample (NaN for an empty one).
pub fn mean(xs: &[f64]) -> f64 {
    xs.iter().sum::<f64>() / xs.len() as f64
}

/// Sample standard deviation (n - 1 in the denominator).
pub fn std_dev(xs: &[f64]) -> f64 {
    if xs.len() < 2 {
        return 0.0;
    }
    let m = mean(xs);
    (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (xs.len() - 1) as f64).sqrt()
}

/// Standard error of the mean.
pub fn std_error(xs: &[f64]) -> f64 {
    std_dev(xs) / (xs.len() as f64).sqrt()
}

/// A two-sided paired t-test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TTest {
    /// The t statistic.
    pub t: f64,
    /// Degrees of freedom.
    pub df: f64,
    /// The two-sided p-value.
    pub p: f64,
    /// Mean of `a - b`.
    pub mean_difference: f64,
}

/// Paired t-test of `a` against `b` (the same trials under two methods):
/// a one-sample t-test on the differences.
pub fn paired_t_test(a: &[f64], b: &[f64]) -> Option<TTest> {
    if a.len() != b.len() || a.len() < 2 {
        return None;
    }
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let (m, se) = (mean(&d), std_error(&d));
    let df = (d.len() - 1) as f64;
    if se == 0.0 {
        // Every difference equal: no variance to test against.
        let p = if m == 0.0 { 1.0 } else { 0.0 };
        return Some(TTest {
            t: if m == 0.0 {
                0.0
            } else {
                f64::INFINITY.copysign(m)
            },
            df,
            p,
            mean_difference: m,
        });
    }
    let t = m / se;
    let dist = StudentsT::new(0.0, 1.0, df).ok()?;
    let p = (2.0 * (1.0 - dist.cdf(t.abs()))).clamp(0.0, 1.0);
    Some(TTest {
        t,
        df,
        p,
        mean_difference: m,
    })
}

/// A one-way repeated-measures ANOVA.
#[derive(Debug, Clone, PartialEq)]
pub struct Anova {
    /// The F statistic.
    pub f: f64,
    /// Degrees of freedom between conditions.
    pub df_conditions: f64,
    /// Degrees of freedom within conditions (error).
    pub df_error: f64,
    /// The p-value.
    pub p: f64,
    /// Mean square of the error term, which Tukey's test uses.
    pub ms_error: f64,
    /// Subjects (trials) per condition.
    pub n: usize,
}

/// Repeated-measures ANOVA over `conditions[c][s]`: condition `c` (a
/// method) measured on subject `s` (a trial seed, the same initial layout for
/// every method). Every condition needs the same number of subjects.
pub fn repeated_measures_anova(conditions: &[Vec<f64>]) -> Option<Anova> {
    let k = conditions.len();
    let n = conditions.first()?.len();
    if k < 2 || n < 2 || conditions.iter().any(|c| c.len() != n) {
        return None;
    }
    let grand = conditions.iter().flatten().sum::<f64>() / (k * n) as f64;
    let cond_means: Vec<f64> = conditions.iter().map(|c| mean(c)).collect();
    let subj_means: Vec<f64> = (0..n)
        .map(|s| conditions.iter().map(|c| c[s]).sum::<f64>() / k as f64)
        .collect();
    let ss_total: f64 = conditions
        .iter()
        .flatten()
        .map(|x| (x - grand).powi(2))
        .sum();
    let ss_cond: f64 = n as f64 * cond_means.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_subj: f64 = k as f64 * subj_means.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_err = (ss_total - ss_cond - ss_subj).max(0.0);
    let (df_c, df_e) = ((k - 1) as f64, ((k - 1) * (n - 1)) as f64);
    let ms_error = ss_err / df_e;
    let f = (ss_cond / df_c) / ms_error;
    let p = if ms_error == 0.0 {
        if ss_cond > 0.0 {
            0.0
        } else {
            1.0
        }
    } else {
        let dist = FisherSnedecor::new(df_c, df_e).ok()?;
        (1.0 - dist.cdf(f)).clamp(0.0, 1.0)
    };
    Some(Anova {
        f,
        df_conditions: df_c,
        df_error: df_e,
        p,
        ms_error,
        n,
    })
}

/// One pair in Tukey's multiple comparisons.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TukeyPair {
    /// The first condition's index.
    pub a: usize,
    /// The second condition's index.
    pub b: usize,
    /// mean(a) - mean(b).
    pub difference: f64,
    /// The studentized range statistic.
    pub q: f64,
    /// The adjusted p-value.
    pub p: f64,
}

/// Tukey's honestly-significant-difference test after a repeated-measures
/// ANOVA: every pair of conditions, with p-values from the studentized range.
pub fn tukey_hsd(conditions: &[Vec<f64>], anova: &Anova) -> Vec<TukeyPair> {
    let k = conditions.len();
    let se = (anova.ms_error / anova.n as f64).sqrt();
    let means: Vec<f64> = conditions.iter().map(|c| mean(c)).collect();
    let mut pairs = Vec::new();
    for a in 0..k {
        for b in a + 1..k {
            let difference = means[a] - means[b];
            let q = if se > 0.0 {
                difference.abs() / se
            } else {
                f64::INFINITY
            };
            let p = if q.is_finite() {
                1.0 - ptukey(q, k, anova.df_error)
            } else {
                0.0
            };
            pairs.push(TukeyPair {
                a,
                b,
                difference,
                q,
                p: p.clamp(0.0, 1.0),
            });
        }
    }
    pairs
}

fn normal_cdf(x: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(-x / std::f64::consts::SQRT_2)
}

fn normal_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Composite Simpson's rule over [a, b] with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for i in 1..n {
        sum += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

/// P(range of `k` standard normals < w).
fn range_cdf(w: f64, k: usize) -> f64 {
    if w <= 0.0 {
        return 0.0;
    }
    let k = k as f64;
    let inner = |z: f64| normal_pdf(z) * (normal_cdf(z) - normal_cdf(z - w)).max(0.0).powf(k - 1.0);
    (k * simpson(inner, -8.0, 8.0 + w, 800)).clamp(0.0, 1.0)
}

/// The studentized range distribution's CDF, P(Q < q) for `k` means and
/// `df` error degrees of freedom, by integrating the normal range over the
/// distribution of the standard-error estimate. statrs has no such
/// distribution; this is the textbook definition, integrated numerically.
pub fn ptukey(q: f64, k: usize, df: f64) -> f64 {
    if q <= 0.0 {
        return 0.0;
    }
    if df > 5_000.0 {
        return range_cdf(q, k);
    }
    // s = sqrt(chi2_df / df) has density c * s^(df-1) * exp(-df s^2 / 2).
    let ln_c = (df / 2.0) * df.ln() - ln_gamma(df / 2.0) - (df / 2.0 - 1.0) * 2f64.ln();
    let density = |s: f64| {
        if s <= 0.0 {
            0.0
        } else {
            (ln_c + (df - 1.0) * s.ln() - df * s * s / 2.0).exp()
        }
    };
    let upper = 1.0 + 12.0 / df.sqrt();
    simpson(|s| density(s) * range_cdf(q * s, k), 0.0, upper, 600).clamp(0.0, 1.0)
}

/// D'Agostino and Pearson's omnibus test of normality (the paper's Sect. 4.2.1 runs it
/// before choosing parametric tests): K² is the sum of the squared z-scores of the
/// sample's skewness and kurtosis, chi-squared with 2 degrees of freedom under
/// normality.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normality {
    /// The K² statistic.
    pub k2: f64,
    /// The p-value: small means the sample is unlikely to come from a normal distribution.
    pub p: f64,
}

/// The smallest sample the skewness test is defined for.
pub const NORMALITY_MIN_N: usize = 8;

/// The smallest sample the kurtosis part's approximation is good for (scipy warns below).
pub const NORMALITY_GOOD_N: usize = 20;

/// D'Agostino-Pearson's K² test of `xs`; see [`Normality`]. `None` with fewer than
/// [`NORMALITY_MIN_N`] values or none of them different (no spread to test); below
/// [`NORMALITY_GOOD_N`] values the p-value is rough.
pub fn normality_test(xs: &[f64]) -> Option<Normality> {
    let n = xs.len();
    if n < NORMALITY_MIN_N || xs.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let m = mean(xs);
    let moment = |k: i32| xs.iter().map(|x| (x - m).powi(k)).sum::<f64>() / n as f64;
    let m2 = moment(2);
    // Values all equal but for rounding in the mean leave a spread of a few ulps, whose
    // skewness and kurtosis mean nothing.
    if m2 <= f64::EPSILON * m * m || m2 == 0.0 {
        return None;
    }
    let skew = moment(3) / m2.powf(1.5);
    let kurt = moment(4) / (m2 * m2);
    let k2 = skewness_z(skew, n as f64).powi(2) + kurtosis_z(kurt, n as f64).powi(2);
    // The chi-squared survival function with 2 degrees of freedom is exp(-x / 2).
    Some(Normality {
        k2,
        p: (-k2 / 2.0).exp(),
    })
}

/// D'Agostino's transformation of the sample skewness to a standard normal z.
fn skewness_z(skew: f64, n: f64) -> f64 {
    let y = skew * ((n + 1.0) * (n + 3.0) / (6.0 * (n - 2.0))).sqrt();
    let beta2 = 3.0 * (n * n + 27.0 * n - 70.0) * (n + 1.0) * (n + 3.0)
        / ((n - 2.0) * (n + 5.0) * (n + 7.0) * (n + 9.0));
    let w2 = -1.0 + (2.0 * (beta2 - 1.0)).sqrt();
    let delta = 1.0 / (0.5 * w2.ln()).sqrt();
    let alpha = (2.0 / (w2 - 1.0)).sqrt();
    let y = if y == 0.0 { 1.0 } else { y };
    delta * (y / alpha).asinh()
}

/// Anscombe and Glynn's transformation of the sample kurtosis to a standard normal z.
fn kurtosis_z(kurt: f64, n: f64) -> f64 {
    let expected = 3.0 * (n - 1.0) / (n + 1.0);
    let variance =
        24.0 * n * (n - 2.0) * (n - 3.0) / ((n + 1.0) * (n + 1.0) * (n + 3.0) * (n + 5.0));
    let x = (kurt - expected) / variance.sqrt();
    let sqrt_beta1 = 6.0 * (n * n - 5.0 * n + 2.0) / ((n + 7.0) * (n + 9.0))
        * (6.0 * (n + 3.0) * (n + 5.0) / (n * (n - 2.0) * (n - 3.0))).sqrt();
    let a = 6.0
        + 8.0 / sqrt_beta1 * (2.0 / sqrt_beta1 + (1.0 + 4.0 / (sqrt_beta1 * sqrt_beta1)).sqrt());
    let term1 = 1.0 - 2.0 / (9.0 * a);
    let denom = 1.0 + x * (2.0 / (a - 4.0)).sqrt();
    if denom == 0.0 {
        return f64::NAN;
    }
    let term2 = denom.signum() * ((1.0 - 2.0 / a) / denom.abs()).cbrt();
    (term1 - term2) / (2.0 / (9.0 * a)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normality_test_matches_scipy() {
        // Reference values: scipy.stats.normaltest 1.17.1 on the same samples.
        let stc = [
            540.0, 620.0, 480.0, 510.0, 700.0, 455.0, 530.0, 580.0, 610.0, 495.0, 520.0, 560.0,
            600.0, 470.0, 650.0, 505.0, 515.0, 545.0, 590.0, 630.0,
        ];
        let outlier = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 100.0];
        let twc = [
            0.9995, 0.9991, 0.9999, 0.9987, 0.9996, 0.9993, 0.9998, 0.9990, 0.9994, 0.9960, 0.9997,
            0.9992,
        ];
        for (xs, k2, p) in [
            (&stc[..], 0.9940931557572006, 0.6083246486796506),
            (&outlier[..], 28.00690166595424, 8.286641977133213e-07),
            (&twc[..], 25.419445164273952, 3.0216044822785726e-06),
        ] {
            let t = normality_test(xs).unwrap();
            assert!((t.k2 - k2).abs() < 1e-9 * k2.max(1.0), "{t:?} against {k2}");
            assert!((t.p - p).abs() < 1e-9 * p.max(1e-6), "{t:?} against {p}");
        }
    }

    #[test]
    fn normality_test_refuses_what_it_cannot_judge() {
        assert_eq!(normality_test(&[1.0; 7]), None);
        assert_eq!(normality_test(&[3.0; 20]), None);
        assert_eq!(normality_test(&[0.1 + 0.2; 20]), None);
        assert_eq!(normality_test(&[1e-300; 9]), None);
        let mut xs: Vec<f64> = (0..10).map(f64::from).collect();
        xs[3] = f64::NAN;
        assert_eq!(normality_test(&xs), None);
    }

    #[test]
    fn ptukey_matches_published_critical_values() {
        // Upper 5 % points of the studentized range (standard tables).
        for (q, k, df) in [
            (3.44, 3, 40.0),
            (3.53, 3, 24.0),
            (2.888, 2, 30.0),
            (4.04, 5, 40.0),
            (3.31, 3, 1e9),
        ] {
            let p = ptukey(q, k, df);
            assert!((p - 0.95).abs() < 0.004, "ptukey({q}, {k}, {df}) = {p}");
        }
        // Upper 1 % point for k = 3, df = 20.
        assert!((ptukey(4.64, 3, 20.0) - 0.99).abs() < 0.002);
    }

    #[test]
    fn paired_t_test_matches_a_hand_computed_example() {
        let a = [10.0, 12.0, 9.0, 11.0, 13.0];
        let b = [8.0, 11.0, 9.0, 8.0, 10.0];
        // d = 2, 1, 0, 3, 3: mean 1.8, sd 1.3038, se 0.5831, t = 3.087, df 4.
        let t = paired_t_test(&a, &b).unwrap();
        assert!((t.t - 3.087).abs() < 1e-3, "{t:?}");
        assert!((t.p - 0.0366).abs() < 1e-3, "{t:?}");
    }

    #[test]
    fn repeated_measures_anova_matches_a_hand_computed_example() {
        // Three conditions on four subjects.
        let data = vec![
            vec![7.0, 6.0, 5.0, 8.0],
            vec![5.0, 4.0, 4.0, 6.0],
            vec![3.0, 2.0, 2.0, 4.0],
        ];
        let a = repeated_measures_anova(&data).unwrap();
        // Grand mean 56/12 = 4.6667; SS_cond = 4 * 7.0417 = 28.1667,
        // SS_subj = 3 * 3.3333 = 10.0, SS_total = 38.6667, SS_err = 0.5,
        // F = (28.1667 / 2) / (0.5 / 6) = 169 on (2, 6).
        assert!((a.f - 169.0).abs() < 1e-6, "{a:?}");
        assert_eq!((a.df_conditions, a.df_error), (2.0, 6.0));
        assert!(a.p < 0.001);
        let pairs = tukey_hsd(&data, &a);
        assert_eq!(pairs.len(), 3);
        assert!(pairs.iter().all(|p| p.p < 0.05), "{pairs:?}");
    }

    #[test]
    fn degenerate_inputs_give_none_rather_than_nonsense() {
        assert!(paired_t_test(&[1.0], &[2.0]).is_none());
        assert!(paired_t_test(&[1.0, 2.0], &[2.0]).is_none());
        assert!(repeated_measures_anova(&[vec![1.0, 2.0]]).is_none());
        assert!(repeated_measures_anova(&[vec![1.0, 2.0], vec![1.0]]).is_none());
    }
}
