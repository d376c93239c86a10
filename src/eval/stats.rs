//! Statistics of trajectory agreement and of configuration comparisons: Pearson r,
//! variance-normalised MSE, and the paired t-test with its exact two-sided p-value.
//!
//! The p-value comes from Student's t distribution through the regularised incomplete beta
//! function, `p = I_{ν/(ν+t²)}(ν/2, 1/2)`, evaluated by its continued fraction (DLMF 8.17.22)
//! with the modified Lentz algorithm, and ln Γ by the Lanczos approximation (g = 7, n = 9).

use serde::{Deserialize, Serialize};

/// The finite pairs where both series have a value.
fn pairs<'a>(
    reference: &'a [Option<f64>],
    estimate: &'a [Option<f64>],
) -> impl Iterator<Item = (f64, f64)> + 'a {
    reference.iter().zip(estimate).filter_map(|(a, b)| match (a, b) {
        (Some(a), Some(b)) if a.is_finite() && b.is_finite() => Some((*a, *b)),
        _ => None,
    })
}

/// Pearson's correlation coefficient r over the frames where both series have a value.
///
/// `None` with fewer than two pairs or when either series is constant over them.
///
/// ```
/// use lipmap::eval::pearson;
/// let a = [Some(1.0), Some(2.0), Some(3.0), None];
/// let b = [Some(2.0), Some(4.0), Some(6.0), Some(0.0)];
/// assert!((pearson(&a, &b).unwrap() - 1.0).abs() < 1e-12);
/// ```
pub fn pearson(reference: &[Option<f64>], estimate: &[Option<f64>]) -> Option<f64> {
    let p: Vec<(f64, f64)> = pairs(reference, estimate).collect();
    if p.len() < 2 {
        return None;
    }
    let n = p.len() as f64;
    let (ma, mb) = p.iter().fold((0.0, 0.0), |(x, y), (a, b)| (x + a / n, y + b / n));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (a, b) in &p {
        sab += (a - ma) * (b - mb);
        saa += (a - ma) * (a - ma);
        sbb += (b - mb) * (b - mb);
    }
    let denom = (saa * sbb).sqrt();
    // Relative test: a constant series has sums of squares at rounding level only.
    let scale = p.iter().fold(0.0f64, |m, (a, b)| m.max(a.abs()).max(b.abs())).max(1e-300);
    if denom.is_nan() || denom <= 1e-24 * scale * scale * n {
        return None;
    }
    Some((sab / denom).clamp(-1.0, 1.0))
}

/// Variance-normalised MSE: `Σ(estimate − reference)² / Σ(reference − mean(reference))²`
/// over the frames where both have a value, i.e. the MSE divided by the reference's
/// (population) variance. 0 is perfect; 1 is no better than predicting the reference's mean.
///
/// `None` with fewer than two pairs or a constant reference.
pub fn normalised_mse(reference: &[Option<f64>], estimate: &[Option<f64>]) -> Option<f64> {
    let p: Vec<(f64, f64)> = pairs(reference, estimate).collect();
    if p.len() < 2 {
        return None;
    }
    let mean = p.iter().map(|(a, _)| a).sum::<f64>() / p.len() as f64;
    let var: f64 = p.iter().map(|(a, _)| (a - mean).powi(2)).sum();
    let err: f64 = p.iter().map(|(a, b)| (b - a).powi(2)).sum();
    (var > 0.0 && var.is_finite()).then(|| err / var)
}

/// A paired t-test's result.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TTest {
    /// Number of pairs.
    pub n: usize,
    /// Mean of `a − b`.
    pub mean_difference: f64,
    /// t statistic, `mean / (sd / √n)` with the sample (n − 1) standard deviation.
    pub t: f64,
    /// Degrees of freedom, n − 1.
    pub df: f64,
    /// Two-sided p-value from Student's t with `df` degrees of freedom.
    pub p: f64,
}

/// Paired two-sided t-test of `a` against `b` (same length, paired by position; pairs with a
/// non-finite member are dropped), as `scipy.stats.ttest_rel(a, b)`.
///
/// `None` with fewer than two pairs, or when all differences are equal (zero variance: t is
/// undefined).
///
/// ```
/// let t = lipmap::eval::paired_t_test(&[1.0, 2.0, 3.0, 4.0], &[1.5, 2.0, 3.5, 5.0]).unwrap();
/// assert_eq!(t.df, 3.0);
/// assert!((t.p - 0.091_721_113_311_571_86).abs() < 1e-9); // scipy ttest_rel
/// ```
pub fn paired_t_test(a: &[f64], b: &[f64]) -> Option<TTest> {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).filter(|v| v.is_finite()).collect();
    let n = d.len();
    if n < 2 || a.len() != b.len() {
        return None;
    }
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let scale = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if var.is_nan() || var <= (1e-14 * scale).powi(2) {
        return None;
    }
    let t = mean / (var / n as f64).sqrt();
    let df = (n - 1) as f64;
    let p = student_t_two_sided_p(t, df)?;
    Some(TTest { n, mean_difference: mean, t, df, p })
}

/// Two-sided p-value `P(|T| ≥ |t|)` of Student's t with `df` > 0 degrees of freedom:
/// `I_{df/(df+t²)}(df/2, 1/2)`. `None` for a non-positive `df` or NaN `t`.
///
/// ```
/// // df = 1 is the Cauchy distribution: p = 1 − (2/π)·atan|t|.
/// let p = lipmap::eval::stats::student_t_two_sided_p(2.0, 1.0).unwrap();
/// assert!((p - (1.0 - 2.0 / std::f64::consts::PI * 2f64.atan())).abs() < 1e-12);
/// ```
pub fn student_t_two_sided_p(t: f64, df: f64) -> Option<f64> {
    if t.is_nan() || df.is_nan() || df <= 0.0 {
        return None;
    }
    if t.is_infinite() {
        return Some(0.0);
    }
    let x = df / (df + t * t);
    regularized_incomplete_beta(0.5 * df, 0.5, x)
}

/// ln Γ(x) for x > 0, Lanczos approximation with g = 7 and 9 coefficients (relative error
/// ~1e-15); reflection for 0 < x < 0.5 keeps the series in its accurate range.
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Γ(x)Γ(1−x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).abs().ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised incomplete beta function I_x(a, b) for a, b > 0 and 0 ≤ x ≤ 1.
///
/// Uses the continued fraction for I_x(a, b) when x < (a+1)/(a+b+2), where it converges
/// fast, and the symmetry I_x(a, b) = 1 − I_{1−x}(b, a) otherwise. `None` for arguments out
/// of range or if the fraction does not converge in 10,000 terms.
///
/// ```
/// use lipmap::eval::stats::regularized_incomplete_beta as ib;
/// assert!((ib(1.0, 1.0, 0.3).unwrap() - 0.3).abs() < 1e-14);      // uniform CDF
/// assert!((ib(2.5, 2.5, 0.5).unwrap() - 0.5).abs() < 1e-14);      // symmetry
/// ```
pub fn regularized_incomplete_beta(a: f64, b: f64, x: f64) -> Option<f64> {
    let valid = a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite();
    if !valid || !(0.0..=1.0).contains(&x) {
        return None;
    }
    if x == 0.0 || x == 1.0 {
        return Some(x);
    }
    // x^a (1−x)^b / (a B(a, b)) is the prefactor of the fraction.
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (-x).ln_1p();
    if x < (a + 1.0) / (a + b + 2.0) {
        Some((ln_front.exp() * beta_continued_fraction(a, b, x)? / a).clamp(0.0, 1.0))
    } else {
        Some((1.0 - ln_front.exp() * beta_continued_fraction(b, a, 1.0 - x)? / b).clamp(0.0, 1.0))
    }
}

/// The continued fraction 1/(1+ d1/(1+ d2/(1+ …))) of I_x(a, b) (DLMF 8.17.22), with
/// d_{2m+1} = −(a+m)(a+b+m)x / ((a+2m)(a+2m+1)) and d_{2m} = m(b−m)x / ((a+2m−1)(a+2m)),
/// by the modified Lentz method.
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> Option<f64> {
    const TINY: f64 = 1e-300;
    const EPS: f64 = 1e-15;
    let guard = |v: f64| if v.abs() < TINY { TINY } else { v };
    let mut c = 1.0;
    let mut d = 1.0 / guard(1.0 - (a + b) * x / (a + 1.0));
    let mut f = d;
    for m in 1..10_000 {
        let m = m as f64;
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        d = 1.0 / guard(1.0 + even * d);
        c = guard(1.0 + even / c);
        f *= d * c;
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        d = 1.0 / guard(1.0 + odd * d);
        c = guard(1.0 + odd / c);
        let delta = d * c;
        f *= delta;
        if (delta - 1.0).abs() < EPS {
            return Some(f);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-300)
    }

    #[test]
    fn ln_gamma_known_values() {
        assert!(ln_gamma(1.0).abs() < 1e-14);
        assert!(ln_gamma(2.0).abs() < 1e-14);
        assert!(close(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln(), 1e-14));
        // Γ(10) = 9! = 362880.
        assert!(close(ln_gamma(10.0), 362_880f64.ln(), 1e-14));
        assert!(close(ln_gamma(0.1), 2.252_712_651_734_206, 1e-13));
    }

    #[test]
    fn incomplete_beta_closed_forms() {
        for &x in &[0.01, 0.2, 0.5, 0.77, 0.999] {
            // I_x(a, 1) = x^a; I_x(1, b) = 1 − (1 − x)^b.
            assert!(close(regularized_incomplete_beta(3.7, 1.0, x).unwrap(), x.powf(3.7), 1e-12));
            let want = 1.0 - (1.0 - x).powf(2.2);
            assert!(close(regularized_incomplete_beta(1.0, 2.2, x).unwrap(), want, 1e-12));
        }
        assert!(regularized_incomplete_beta(-1.0, 1.0, 0.5).is_none());
        assert!(regularized_incomplete_beta(1.0, 1.0, 1.5).is_none());
        assert_eq!(regularized_incomplete_beta(2.0, 3.0, 0.0), Some(0.0));
    }

    #[test]
    fn incomplete_beta_scipy_values() {
        // scipy.special.betainc(a, b, x), scipy 1.17.1.
        let cases = [
            (0.5, 0.5, 0.3, 0.369_010_119_565_545_36),
            (5.0, 0.5, 0.9, 0.316_642_915_020_012_2),
            (15.0, 0.5, 0.4, 1.963_089_817_129_466_2e-7),
            (50.0, 30.0, 0.6, 0.317_057_153_969_111_9),
            (2.5, 7.5, 0.05, 0.025_809_149_284_175_863),
        ];
        for (a, b, x, want) in cases {
            let got = regularized_incomplete_beta(a, b, x).unwrap();
            assert!(close(got, want, 1e-11), "I_{x}({a}, {b}) = {got}, want {want}");
        }
    }

    #[test]
    fn student_t_closed_forms_and_scipy() {
        // df = 2: p = 1 − |t| / √(2 + t²).
        for &t in &[0.3, 1.0, 4.2] {
            let want = 1.0 - t / (2.0f64 + t * t).sqrt();
            assert!(close(student_t_two_sided_p(t, 2.0).unwrap(), want, 1e-12));
        }
        // 2·scipy.stats.t.sf(|t|, df).
        let cases = [
            (2.228_138_851_986_273_5, 10.0, 0.05),
            (1.5, 7.0, 0.177_298_486_989_97),
            (-3.2, 25.0, 0.003_715_968_433_930_124),
            (0.05, 1000.0, 0.960_132_373_071_951_8),
            (8.0, 4.0, 0.001_323_896_909_217_167_2),
        ];
        for (t, df, want) in cases {
            let got = student_t_two_sided_p(t, df).unwrap();
            assert!(close(got, want, 1e-9), "t {t} df {df}: {got} vs {want}");
        }
        assert_eq!(student_t_two_sided_p(0.0, 5.0), Some(1.0));
        assert!(student_t_two_sided_p(1.0, 0.0).is_none());
    }

    #[test]
    fn paired_t_test_matches_scipy_ttest_rel() {
        // scipy.stats.ttest_rel(a, b): statistic, pvalue.
        let a = [0.12, 0.15, 0.11, 0.19, 0.14, 0.13, 0.17, 0.16];
        let b = [0.10, 0.16, 0.09, 0.15, 0.12, 0.12, 0.13, 0.15];
        let r = paired_t_test(&a, &b).unwrap();
        assert!(close(r.t, 3.229_622_822_584_541_4, 1e-9), "t = {}", r.t);
        assert!(close(r.p, 0.014_459_299_322_561_322, 1e-9), "p = {}", r.p);
        assert_eq!((r.n, r.df), (8, 7.0));
        assert!(paired_t_test(&[1.0], &[2.0]).is_none());
        assert!(paired_t_test(&[1.0, 2.0], &[0.0, 1.0]).is_none(), "constant difference");
        assert!(paired_t_test(&[1.0, 2.0], &[0.0]).is_none(), "length mismatch");
    }

    #[test]
    fn pearson_and_nmse_known_values() {
        let a: Vec<Option<f64>> = [1.0, 2.0, 3.0, 4.0, 5.0].into_iter().map(Some).collect();
        let b: Vec<Option<f64>> = [2.0, 1.0, 4.0, 3.0, 5.0].into_iter().map(Some).collect();
        // Σ(a−ā)(b−b̄) = 8, Σ(a−ā)² = Σ(b−b̄)² = 10 → r = 0.8.
        assert!((pearson(&a, &b).unwrap() - 0.8).abs() < 1e-12);
        // Σ(b−a)² = 4 over Σ(a−ā)² = 10.
        assert!((normalised_mse(&a, &b).unwrap() - 0.4).abs() < 1e-12);
        let c = vec![Some(3.0); 5];
        assert!(pearson(&a, &c).is_none());
        assert!(normalised_mse(&c, &a).is_none());
        assert!(pearson(&a[..1], &b[..1]).is_none());
    }
}
